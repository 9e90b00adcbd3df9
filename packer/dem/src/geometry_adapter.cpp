// Geometry shapes/containers for the DEM, and the labelled bed of a run.
#include <algorithm>
#include <cmath>
#include <map>

#include "voxpack/core/errors.hpp"
#include "voxpack/core/spec.hpp"
#include "voxpack/packer/dem_geometry.hpp"
#include "voxpack/packer/digitise.hpp"

namespace voxpack::packer::dem {
namespace {

class GeometryShape final : public DemShape {
 public:
  explicit GeometryShape(std::shared_ptr<const Shape> s) : s_(std::move(s)) {}
  std::string spec() const override { return s_->spec(); }
  double volumeMm3() const override { return s_->volumeMm3(); }
  Eigen::Matrix3d inertiaPerDensity() const override { return s_->inertiaPerDensity(); }
  double boundingRadiusMm() const override { return s_->boundingRadiusMm(); }
  bool inside(const Vec3& p) const override { return s_->inside(p); }
  double signedDistanceMm(const Vec3& p) const override { return s_->signedDistanceMm(p); }
  Vec3 normal(const Vec3& p) const override { return s_->normal(p); }

 private:
  std::shared_ptr<const Shape> s_;
};

// Signed distances of the common shapes without std::hypot (its care for overflow costs
// ~20 ns a call in the DEM's innermost loop); the rest of the shape comes from geometry.
class FastSdfShape final : public DemShape {
 public:
  FastSdfShape(std::shared_ptr<const Shape> s, bool cylinder, double r, double halfLength)
      : s_(std::move(s)), cylinder_(cylinder), r_(r), hl_(halfLength) {}
  std::string spec() const override { return s_->spec(); }
  double volumeMm3() const override { return s_->volumeMm3(); }
  Eigen::Matrix3d inertiaPerDensity() const override { return s_->inertiaPerDensity(); }
  double boundingRadiusMm() const override { return s_->boundingRadiusMm(); }
  bool inside(const Vec3& p) const override { return s_->inside(p); }
  double signedDistanceMm(const Vec3& p) const override {
    return analyticSignedDistanceMm(cylinder_ ? 2 : 1, r_, hl_, p);
  }
  int analyticForm(double& r, double& hl) const override {
    r = r_;
    hl = hl_;
    return cylinder_ ? 2 : 1;
  }
  Vec3 normal(const Vec3& p) const override {
    if (!cylinder_) {
      const double n = p.norm();
      return n > 0 ? Vec3(p / n) : Vec3(0, 0, 1);
    }
    const double rho = std::sqrt(p.x() * p.x() + p.y() * p.y());
    const Vec3 radial = rho > 0 ? Vec3(p.x() / rho, p.y() / rho, 0) : Vec3(1, 0, 0);
    const Vec3 axial(0, 0, p.z() >= 0 ? 1 : -1);
    const double dr = rho - r_, dz = std::abs(p.z()) - hl_;
    if (dr > 0 && dz > 0) return (dr * radial + dz * axial).normalized();
    return dr > dz ? radial : axial;
  }

 private:
  std::shared_ptr<const Shape> s_;
  bool cylinder_;
  double r_, hl_;
};

class OpenTopContainer final : public DemContainer {
 public:
  OpenTopContainer(std::shared_ptr<const Container> c, double margin)
      : c_(std::move(c)), b_(c_->boundsMm()) {
    zClamp_ = b_.max.z() - std::max(margin, 1e-6);
    cylinder_ = c_->cylinderAxis(cx_, cy_, r_);
    box_ = parseSpec(c_->spec(), "container").name == "box";  // axis-aligned faces
  }
  double wallDistanceMm(const Vec3& p) const override {
    if (cylinder_)
      return std::min(r_ - std::sqrt((p.x() - cx_) * (p.x() - cx_) + (p.y() - cy_) * (p.y() - cy_)),
                      p.z() - b_.min.z());
    return c_->wallDistanceMm(clamp(p));
  }
  Vec3 inwardNormal(const Vec3& p) const override {
    if (cylinder_) {
      const double dx = p.x() - cx_, dy = p.y() - cy_, rho = std::sqrt(dx * dx + dy * dy);
      if (p.z() - b_.min.z() < r_ - rho || rho == 0) return Vec3(0, 0, 1);
      return Vec3(-dx / rho, -dy / rho, 0);
    }
    return c_->inwardNormal(clamp(p));
  }
  // Regions: a cylinder's floor (5, the +z class) and its round side (0); a box's faces by
  // their normals (the default classes); other containers by the default.
  int wallRegion(const Vec3& p) const override {
    if (!cylinder_) return DemContainer::wallRegion(p);
    const double rho = std::sqrt((p.x() - cx_) * (p.x() - cx_) + (p.y() - cy_) * (p.y() - cy_));
    return p.z() - b_.min.z() < r_ - rho ? 5 : 0;
  }
  int nearWalls(const Vec3& p, double reachMm, WallPatch* out) const override {
    int n = 0;
    auto add = [&](double d, const Vec3& nrm, int region) {
      if (d < reachMm) out[n++] = WallPatch{d, nrm, region};
    };
    if (cylinder_) {
      const double dx = p.x() - cx_, dy = p.y() - cy_, rho = std::sqrt(dx * dx + dy * dy);
      add(p.z() - b_.min.z(), Vec3(0, 0, 1), 5);
      if (rho > 0) add(r_ - rho, Vec3(-dx / rho, -dy / rho, 0), 0);
      return n;
    }
    if (!box_) return DemContainer::nearWalls(p, reachMm, out);
    add(p.x() - b_.min.x(), Vec3(1, 0, 0), 1);
    add(b_.max.x() - p.x(), Vec3(-1, 0, 0), 0);
    add(p.y() - b_.min.y(), Vec3(0, 1, 0), 3);
    add(b_.max.y() - p.y(), Vec3(0, -1, 0), 2);
    add(p.z() - b_.min.z(), Vec3(0, 0, 1), 5);
    return n;
  }
  bool uprightColumn(double& cx, double& cy, double& r, double& floorZ) const override {
    if (!cylinder_) return false;
    cx = cx_;
    cy = cy_;
    r = r_;
    floorZ = b_.min.z();
    return true;
  }
  Vec3 minMm() const override { return b_.min; }
  Vec3 maxMm() const override { return b_.max; }

 private:
  Vec3 clamp(const Vec3& p) const { return Vec3(p.x(), p.y(), std::min(p.z(), zClamp_)); }
  std::shared_ptr<const Container> c_;
  BoundsMm b_;
  double zClamp_ = 0;
  bool cylinder_ = false;
  bool box_ = false;
  double cx_ = 0, cy_ = 0, r_ = 0;
};

}  // namespace

std::shared_ptr<const DemShape> demShape(std::shared_ptr<const Shape> shape) {
  if (!shape) throw InputError("dem: no shape");
  const ParsedSpec ps = parseSpec(shape->spec(), "shape");
  if (ps.name == "sphere" && ps.has("d"))
    return std::make_shared<FastSdfShape>(shape, false, 0.5 * ps.positive("d"), 0);
  if (ps.name == "cylinder" && ps.has("d") && ps.has("l"))
    return std::make_shared<FastSdfShape>(shape, true, 0.5 * ps.positive("d"),
                                          0.5 * ps.positive("l"));
  return std::make_shared<GeometryShape>(std::move(shape));
}

std::shared_ptr<const DemContainer> demContainer(std::shared_ptr<const Container> container,
                                                 double marginMm) {
  if (!container) throw InputError("dem: no container");
  return std::make_shared<OpenTopContainer>(std::move(container), marginMm);
}

Bed demBed(const ParticleTable& particles, const std::vector<std::shared_ptr<const Shape>>& shapes,
           const Container& container, double voxelMm, int supersample, int threads,
           Progress& progress, double* clippedMm3) {
  std::map<std::string, const Shape*> bySpec;
  for (const auto& s : shapes) bySpec[s->spec()] = s.get();
  // Specs the scene does not hold (a size distribution: one sphere per particle) are read
  // from the table itself.
  std::vector<std::shared_ptr<const Shape>> own;
  for (const auto& spec : particles.shape)
    if (!bySpec.count(spec)) {
      own.push_back(parseShape(spec));
      bySpec[spec] = own.back().get();
    }
  Lattice lattice = latticeForContainer(container, voxelMm, 1);
  // Extend upwards when the bed stands above the container's nominal top.
  double top = -1e300;
  for (std::size_t i = 0; i < particles.size(); ++i) {
    const auto it = bySpec.find(particles.shape[i]);
    if (it == bySpec.end()) throw InternalError("dem: no shape for " + particles.shape[i]);
    top = std::max(top, particles.positionMm[i].z() + it->second->boundingRadiusMm());
  }
  const double latticeTop = lattice.originMm[0] + (lattice.dims[0] - 0.5) * voxelMm;
  if (top > latticeTop)
    lattice.dims[0] += static_cast<std::int64_t>(std::ceil((top - latticeTop) / voxelMm)) + 1;

  Bed bed;
  bed.mask = containerMask(container, lattice, supersample);
  bed.labels = Grid<std::uint32_t>(lattice, 0);
  const std::int64_t n = static_cast<std::int64_t>(particles.size());
  std::vector<DigitalParticle> digital(particles.size());
  const DigitiseOptions dopt{supersample};
  const std::int64_t chunk = 256;
  for (std::int64_t first = 0; first < n; first += chunk) {
    const std::int64_t last = std::min(n, first + chunk);
#pragma omp parallel for num_threads(std::max(1, threads)) schedule(dynamic, 4)
    for (std::int64_t i = first; i < last; ++i) {
      const auto u = static_cast<std::size_t>(i);
      digital[u] = digitise(*bySpec.at(particles.shape[u]), particles.positionMm[u],
                            particles.orientation[u], lattice, dopt);
    }
    for (std::int64_t i = first; i < last; ++i) {
      const auto u = static_cast<std::size_t>(i);
      for (const Voxel& v : digital[u].voxels) {
        if (!lattice.contains(v.k, v.j, v.i)) continue;
        std::uint32_t& l = (*bed.labels)(v.k, v.j, v.i);
        if (l == 0) l = static_cast<std::uint32_t>(i + 1);
      }
      digital[u] = DigitalParticle{};
    }
    progress.report("dem: digitising", static_cast<double>(last) / static_cast<double>(n));
  }
  // A bed never holds solid outside its container: the soft wall lets a particle overlap
  // the wall by ~its contact overlap, and those voxels are clipped (and counted).
  std::uint64_t clipped = 0;
  for (std::size_t o = 0; o < lattice.size(); ++o)
    if ((*bed.labels)[o] != 0 && (*bed.mask)[o] == 0) {
      (*bed.labels)[o] = 0;
      ++clipped;
    }
  if (clippedMm3) *clippedMm3 = static_cast<double>(clipped) * voxelMm * voxelMm * voxelMm;
  bed.indicator = Grid<std::uint8_t>(lattice, 1);
  for (std::size_t o = 0; o < lattice.size(); ++o) bed.indicator[o] = (*bed.labels)[o] == 0 ? 1 : 0;
  bed.particles = particles;
  return bed;
}

}  // namespace voxpack::packer::dem
