// voxpack info FILE.h5 [--json]: what a bed file holds and its porosity inside the mask.
// The volume is never loaded whole: the header gives dims and datasets, the porosity is
// counted over z-slabs that fit --memory-limit (docs/scale.md).
#include <iomanip>
#include <iostream>

#include "command.hpp"
#include "voxpack/core/bed_file.hpp"
#include "voxpack/core/json_util.hpp"
#include "voxpack/core/version.hpp"
#include "voxpack/stats/distributed.hpp"
#include "voxpack/stats/streamed.hpp"

namespace voxpack::app {
namespace {

class InfoCommand final : public Command {
 public:
  std::string name() const override { return "info"; }
  std::string description() const override {
    return "summary of a bed file: dims, spacing, porosity, what it holds";
  }
  void addSwitches(CLI::App& sub) override {
    sub.add_option("file", file_, "bed file (.h5)")->required();
    sub.add_flag("--json", json_, "print JSON instead of text");
    sub.add_option("--slab-voxels", slabPlanes_,
                   "count the porosity in z-slabs this many planes thick (default: from "
                   "--memory-limit)")
        ->check(CLI::PositiveNumber);
  }
  int execute(const GlobalOptions& global) override {
    const stats::Communicator& comm = stats::Communicator::world();
    const BedHeader h = readBedHeader(file_);
    readBedParticles(file_, global.memory);  // validates the table (finite, unit quaternions)
    const BedSummary s = stats::summarizeStreamed(file_, global.memory, slabPlanes_, comm);
    if (comm.rank() != 0) return 0;
    const auto& datasets = h.datasets;
    const Lattice& l = h.lattice;
    nlohmann::json j;
    j["voxpack_version"] = versionString();
    j["file"] = file_;
    j["dims"] = {l.dims[0], l.dims[1], l.dims[2]};
    j["spacing_mm"] = {l.spacingMm[0], l.spacingMm[1], l.spacingMm[2]};
    j["origin_mm"] = {l.originMm[0], l.originMm[1], l.originMm[2]};
    j["voxels"] = l.size();
    j["voxels_in_mask"] = s.voxelsInMask;
    j["void_voxels"] = s.voidVoxels;
    j["porosity"] = s.emptyMask ? nlohmann::json(nullptr) : nlohmann::json(s.porosity);
    j["packing_density"] = s.emptyMask ? nlohmann::json(nullptr) : nlohmann::json(s.packingDensity);
    j["has_mask"] = h.hasMask;
    j["datasets"] = datasets;
    j["particles"] = h.particles;
    j["provenance"] = h.provenance;
    if (json_) {
      sanitizeNonFinite(j);
      std::cout << j.dump(2) << '\n';
      return 0;
    }
    std::cout << "file          " << file_ << '\n'
              << "dims (z,y,x)  " << l.dims[0] << " x " << l.dims[1] << " x " << l.dims[2] << '\n'
              << std::setprecision(6) << "spacing (mm)  " << l.spacingMm[0] << ", "
              << l.spacingMm[1] << ", " << l.spacingMm[2] << '\n'
              << "origin (mm)   " << l.originMm[0] << ", " << l.originMm[1] << ", " << l.originMm[2]
              << '\n'
              << "datasets      ";
    for (std::size_t n = 0; n < datasets.size(); ++n) std::cout << (n ? ", " : "") << datasets[n];
    std::cout << '\n'
              << "mask voxels   " << s.voxelsInMask << (h.hasMask ? "" : " (no mask: all)") << '\n';
    if (s.emptyMask) {
      std::cout << "porosity      undefined (empty mask)\n";
    } else {
      std::cout << std::setprecision(6) << "porosity      " << s.porosity << '\n'
                << "packing dens. " << s.packingDensity << '\n';
    }
    std::cout << "particles     " << h.particles << '\n';
    if (!h.provenance.empty()) std::cout << "provenance    " << h.provenance.dump() << '\n';
    return 0;
  }

 private:
  std::string file_;
  bool json_ = false;
  std::int64_t slabPlanes_ = 0;
};

}  // namespace

std::unique_ptr<Command> makeInfoCommand() { return std::make_unique<InfoCommand>(); }

}  // namespace voxpack::app
