// The column wall's blur divided out of the grey values next to it; model in docs/ingest.md
// ("Wall-blur correction").
#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "column_detail.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/ingest/column.hpp"
#include "voxpack/ingest/filters.hpp"

namespace voxpack::ingest {
namespace {

double cdf(double x) { return 0.5 * std::erfc(-x / std::numbers::sqrt2); }

// Calls f(k, j, i, offset, r) for every voxel whose centre lies at a distance r (mm) from
// the (possibly tilted) axis with rLo <= r < rHi; planes in parallel.
template <class F>
void forEachInRing(const Lattice& l, const ColumnFit& c, double rLo, double rHi, int threads,
                   F&& f) {
  const double lo2 = std::max(0.0, rLo) * std::max(0.0, rLo), hi2 = rHi * rHi;
#pragma omp parallel for num_threads(std::max(1, threads)) schedule(dynamic, 1)
  for (std::int64_t k = 0; k < l.nz(); ++k)
    column_detail::forEachInPlane(l, c, k, [&](std::int64_t j, std::int64_t i, double r2) {
      if (r2 >= lo2 && r2 < hi2) f(k, j, i, l.offset(k, j, i), std::sqrt(r2));
    });
}

double reachMm(const WallBlurCorrection& c) { return c.reachSigmas * c.blurMm; }

}  // namespace

std::size_t correctWallBlur(Grid<float>& image, const ColumnFit& column,
                            const WallBlurCorrection& c, int threads) {
  if (!column.found || !(c.blurMm > 0.0) || !std::isfinite(c.blurMm)) return 0;
  const double R = column.radiusMm, s = c.blurMm, T = c.wallThicknessMm;
  const double s2 = 2.0 * c.noiseSigma * c.noiseSigma;
  std::vector<std::size_t> perPlane(static_cast<std::size_t>(image.lattice().nz()), 0);
  forEachInRing(image.lattice(), column, R - reachMm(c), R, threads,
                [&](std::int64_t k, std::int64_t, std::int64_t, std::size_t o, double r) {
                  const double w = cdf((R - r) / s);
                  const double v = image[o];
                  double out;
                  if (c.rician) {
                    out = std::sqrt(std::max(0.0, (v * v - s2) / (w * w) + s2));
                  } else {
                    const double beyond = T > 0.0 ? cdf((r - R - T) / s) : 0.0;
                    out =
                        (v - c.wallLevel * (1.0 - w) - (c.outsideLevel - c.wallLevel) * beyond) / w;
                  }
                  image[o] = static_cast<float>(out);
                  ++perPlane[static_cast<std::size_t>(k)];
                });
  std::size_t changed = 0;
  for (std::size_t n : perPlane) changed += n;
  return changed;
}

void refilterNearWall(Grid<float>& filtered, const Grid<float>& source, const ColumnFit& column,
                      const WallBlurCorrection& c, int medianRadius, bool box, int threads) {
  if (filtered.lattice().dims != source.lattice().dims)
    throw InputError("wall-blur correction: filtered and source images differ in size");
  if (!column.found || !(c.blurMm > 0.0) || !std::isfinite(c.blurMm)) return;
  const Lattice& l = source.lattice();
  const double vox = std::max(l.spacingMm[1], l.spacingMm[2]);
  // A filtered voxel changes when a voxel of its window changed; the window reaches
  // medianRadius voxels along x and y (sqrt 2 of that in the plane), the cross one voxel.
  const double margin = (box ? std::numbers::sqrt2 * medianRadius : 1.0) * vox * 1.01;
  const double R = column.radiusMm;
  forEachInRing(l, column, R - reachMm(c) - margin, R + margin, threads,
                [&](std::int64_t k, std::int64_t j, std::int64_t i, std::size_t o, double) {
                  thread_local std::vector<float> window;
                  filtered[o] = box ? boxMedianAt(source, medianRadius, k, j, i, window)
                                    : crossMedianAt(source, k, j, i);
                });
}

}  // namespace voxpack::ingest
