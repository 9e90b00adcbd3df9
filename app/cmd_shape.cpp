// voxpack shape: digitises one particle and reports its digitisation error (issue 3).
#include <iomanip>
#include <iostream>

#include "command.hpp"
#include "voxpack/core/bed_file.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/core/json_util.hpp"
#include "voxpack/core/memory.hpp"
#include "voxpack/core/spec.hpp"
#include "voxpack/core/version.hpp"
#include "voxpack/packer/digitise.hpp"
#include "voxpack/packer/shape.hpp"

namespace voxpack::app {
namespace {

// (digital - exact) / exact; a zero exact value cannot occur for a parsed shape.
double relError(double digital, double exact) { return (digital - exact) / exact; }

class ShapeCommand final : public Command {
 public:
  std::string name() const override { return "shape"; }
  std::string description() const override {
    return "digitise one particle and report its digitisation error";
  }
  void addSwitches(CLI::App& sub) override {
    sub.add_option("--shape", shape_, "shape SPEC, e.g. cylinder:d=5.4,l=3.8")->required();
    sub.add_option("--voxel-size", voxelMm_, "voxel edge length (mm, > 0)")->required();
    sub.add_option("--orientation", orientation_,
                   "orientation quaternion w,x,y,z (normalised; default 1,0,0,0 = axis along z)");
    sub.add_option("--supersample", supersample_,
                   "samples per axis per voxel, 1..8 (k^3 samples, solid when >= half inside)")
        ->capture_default_str();
    sub.add_flag("--json", json_, "print JSON instead of text");
    sub.add_option("-o,--output", output_, "write the particle as a bed file (.h5)");
  }
  int execute(const GlobalOptions& global) override {
    if (!std::isfinite(voxelMm_) || !(voxelMm_ > 0))
      throw InputError("--voxel-size must be a positive number of mm, got " +
                       packer::formatNumber(voxelMm_));
    if (supersample_ < 1 || supersample_ > 8)
      throw InputError("--supersample must be in 1..8, got " + std::to_string(supersample_));
    Quat q = Quat::Identity();
    if (!orientation_.empty()) {
      const auto v = parseNumberList(orientation_, 4, "--orientation");
      q = packer::normalisedQuaternion(v[0], v[1], v[2], v[3]);
    }
    const auto shape = packer::parseShape(shape_);
    requireWithinBudget(packer::digitiseMemoryEstimateBytes(*shape, voxelMm_), global.memory,
                        "shape: digitising " + shape->spec() + " at --voxel-size " +
                            packer::formatNumber(voxelMm_) + " mm");
    // The centre of mass sits on the centre of voxel (0, 0, 0).
    const Lattice lattice = Lattice::isotropic(1, 1, 1, voxelMm_);
    packer::DigitiseOptions opt;
    opt.supersample = supersample_;
    const packer::DigitalParticle p = packer::digitise(*shape, Vec3::Zero(), q, lattice, opt);

    nlohmann::json j;
    j["voxpack_version"] = versionString();
    j["shape"] = shape->spec();
    j["voxel_size_mm"] = voxelMm_;
    j["orientation"] = {q.w(), q.x(), q.y(), q.z()};
    j["supersample"] = supersample_;
    j["volume_exact_mm3"] = shape->volumeMm3();
    j["volume_digital_mm3"] = p.volumeMm3();
    j["volume_rel_error"] = relError(p.volumeMm3(), shape->volumeMm3());
    j["surface_exact_mm2"] = shape->surfaceMm2();
    j["surface_digital_mm2"] = p.faceSurfaceMm2;
    j["surface_rel_error"] = relError(p.faceSurfaceMm2, shape->surfaceMm2());
    j["voxels"] = p.voxels.size();
    j["surface_voxels"] = p.surface.size();
    j["faces"] = p.faceCount;
    j["voxels_per_diameter"] = shape->characteristicDiameterMm() / voxelMm_;
    j["centre_of_mass_mm"] = {p.centreOfMassMm.x(), p.centreOfMassMm.y(), p.centreOfMassMm.z()};
    sanitizeNonFinite(j);

    if (!output_.empty()) writeParticleBed(*shape, q, p, global);
    if (json_) {
      std::cout << j.dump(2) << '\n';
      return 0;
    }
    std::cout << std::setprecision(6) << "shape            " << shape->spec() << '\n'
              << "voxel size (mm)  " << voxelMm_ << "  (" << std::setprecision(4)
              << shape->characteristicDiameterMm() / voxelMm_ << " voxels per diameter)\n"
              << std::setprecision(6) << "voxels           " << p.voxels.size() << " ("
              << p.surface.size() << " on the surface, " << p.faceCount << " faces)\n"
              << "volume (mm^3)    exact " << shape->volumeMm3() << ", digital " << p.volumeMm3()
              << ", rel. error " << std::setprecision(4)
              << 100 * relError(p.volumeMm3(), shape->volumeMm3()) << " %\n"
              << std::setprecision(6) << "surface (mm^2)   exact " << shape->surfaceMm2()
              << ", digital " << p.faceSurfaceMm2 << ", rel. error " << std::setprecision(4)
              << 100 * relError(p.faceSurfaceMm2, shape->surfaceMm2()) << " %\n";
    if (!output_.empty()) std::cout << "wrote            " << output_ << '\n';
    return 0;
  }

 private:
  // The particle on a lattice just large enough for it plus a two-voxel void margin.
  void writeParticleBed(const packer::Shape& shape, const Quat& q, const packer::DigitalParticle& p,
                        const GlobalOptions& global) const {
    constexpr int kMargin = 2;
    std::array<std::int64_t, 3> lo{0, 0, 0}, hi{0, 0, 0};
    if (!p.voxels.empty()) {
      lo = {p.voxels.front().k, p.voxels.front().j, p.voxels.front().i};
      hi = lo;
      for (const auto& v : p.voxels) {
        const std::array<std::int64_t, 3> x{v.k, v.j, v.i};
        for (int a = 0; a < 3; ++a) {
          lo[a] = std::min(lo[a], x[a]);
          hi[a] = std::max(hi[a], x[a]);
        }
      }
    }
    Lattice l;
    for (int a = 0; a < 3; ++a) {
      l.dims[a] = hi[a] - lo[a] + 1 + 2 * kMargin;
      l.spacingMm[a] = voxelMm_;
      l.originMm[a] = static_cast<double>(lo[a] - kMargin) * voxelMm_;
    }
    Bed bed;
    bed.indicator = Grid<std::uint8_t>(l, 1);
    bed.labels = Grid<std::uint32_t>(l, 0);
    for (const auto& v : p.voxels) {
      const std::int64_t k = v.k - lo[0] + kMargin, j = v.j - lo[1] + kMargin,
                         i = v.i - lo[2] + kMargin;
      bed.indicator(k, j, i) = 0;
      (*bed.labels)(k, j, i) = 1;
    }
    bed.particles.positionMm.push_back(Vec3::Zero());
    bed.particles.orientation.push_back(q);
    bed.particles.shape.push_back(shape.spec());
    bed.provenance = {{"voxpack_version", versionString()},
                      {"command", global.commandLine},
                      {"shape", shape.spec()},
                      {"voxel_size_mm", voxelMm_},
                      {"supersample", supersample_}};
    writeBed(output_, bed);
  }

  std::string shape_;
  double voxelMm_ = 0;
  std::string orientation_;
  int supersample_ = 1;
  bool json_ = false;
  std::string output_;
};

}  // namespace

std::unique_ptr<Command> makeShapeCommand() { return std::make_unique<ShapeCommand>(); }

}  // namespace voxpack::app
