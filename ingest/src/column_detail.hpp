#pragma once
// Geometry shared by the column mask and the wall-blur correction (not public).
#include <cmath>
#include <cstdint>
#include <vector>

#include "voxpack/ingest/column.hpp"

namespace voxpack::ingest::column_detail {

/// Calls f(j, i, r2) for every voxel centre of plane k, r2 its squared distance (mm^2) from
/// the column's (possibly tilted) axis at that plane's height.
template <class F>
void forEachInPlane(const Lattice& l, const ColumnFit& c, std::int64_t k, F&& f) {
  const double z = l.originMm[0] + static_cast<double>(k) * l.spacingMm[0];
  const double ax = c.axisXMm + c.slopeX * (z - c.zRefMm);
  const double ay = c.axisYMm + c.slopeY * (z - c.zRefMm);
  for (std::int64_t j = 0; j < l.ny(); ++j) {
    const double dy = l.originMm[1] + static_cast<double>(j) * l.spacingMm[1] - ay;
    for (std::int64_t i = 0; i < l.nx(); ++i) {
      const double dx = l.originMm[2] + static_cast<double>(i) * l.spacingMm[2] - ax;
      f(j, i, dx * dx + dy * dy);
    }
  }
}

/// Slabs of fitColumn and refineColumn over nz planes: slab s holds planes
/// [s nz / slabs, (s + 1) nz / slabs).
std::int64_t columnSlabs(std::int64_t nz, int slabSlices);

/// One slab's circle of fitColumn (found = false: none seen in that slab).
struct SlabCircle {
  bool found = false;
  bool touches = false;  ///< the circle leaves the field of view
  double zMm = 0, xMm = 0, yMm = 0, radiusMm = 0;
};

/// fitColumn's circle of the slab of planes [z0, z1) of lattice `l`, from each pixel's count
/// of solid voxels over those planes.
SlabCircle fitSlabCircle(const std::vector<std::int32_t>& solidCount, const Lattice& l,
                         std::int64_t z0, std::int64_t z1, const ColumnFitOptions& options);

/// fitColumn's axis (least squares through the slab centres) and median radius.
ColumnFit combineSlabCircles(const std::vector<SlabCircle>& slabs, const Lattice& l);

/// Throws InputError for fitColumn options out of range.
void checkFitOptions(const ColumnFitOptions& options);

/// Throws InputError for refineColumn options out of range.
void checkRefineOptions(const ColumnRefineOptions& options);

/// refineColumn's radial wall profiles of one iteration, filled plane by plane (in any
/// order of slabs; within a slab in increasing z, as the in-memory refinement does).
class WallProfiles {
 public:
  /// Profiles about `fit` for the image lattice `l` (the whole volume's).
  WallProfiles(const Lattice& l, const ColumnFit& fit, double innerW,
               const ColumnRefineOptions& options);
  /// Adds plane k (global index) of values `plane` (ny x nx).
  void addPlane(const float* plane, std::int64_t k);
  /// Every profile's numbers, flat (to sum over processes that each filled other slabs).
  std::vector<double>& flat() { return data_; }
  /// The refinement step: the refined fit (refined = true), or `rough` with a note.
  /// `innerW` gets the next iteration's inner width; `done` is set when the refinement
  /// stopped (returned rough), so no iteration follows.
  ColumnFit fit(const ColumnFit& rough, double& innerW, bool& done) const;
  /// Whether the fit's radius is large enough to refine at this inner width.
  static bool usable(const Lattice& l, const ColumnFit& fit, double innerW);

 private:
  Lattice l_;
  ColumnFit fit_;
  ColumnRefineOptions o_;
  double innerW_ = 4.0, r0_ = 0;
  std::int64_t slabs_ = 1;
  std::size_t bins_ = 0, stride_ = 0;
  std::vector<double> data_;  // per (slab, sector): bins sums, bins counts, sum cos, sum sin
};

/// refineColumn's iterations about `rough` on the image lattice `l`: `fill(profiles)` adds
/// every plane of the image to each iteration's WallProfiles (in memory, or slab by slab
/// and summed over processes). `rough` comes back when the pixels are not square, the
/// radius is too small or the step is not seen.
template <class Fill>
ColumnFit refineIterations(const Lattice& l, const ColumnFit& rough, const ColumnRefineOptions& o,
                           Fill&& fill) {
  checkRefineOptions(o);
  if (!rough.found) return rough;
  if (std::abs(l.spacingMm[2] - l.spacingMm[1]) > 1e-6 * l.spacingMm[2])
    return rough;  // in-plane pixels must be square
  ColumnFit fit = rough;
  double innerW = 4.0;
  for (int iter = 0; iter < o.iterations; ++iter) {
    if (!WallProfiles::usable(l, fit, innerW)) return rough;
    WallProfiles prof(l, fit, innerW, o);
    fill(prof);
    bool done = false;
    fit = prof.fit(rough, innerW, done);
    if (done) return fit;
  }
  return fit;
}

}  // namespace voxpack::ingest::column_detail
