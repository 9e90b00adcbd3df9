// Resampling onto an isotropic lattice over the same physical box.
#include "voxpack/ingest/resample.hpp"

#include <algorithm>
#include <cmath>

#include "voxpack/core/errors.hpp"

namespace voxpack::ingest {
namespace {

// Trilinear value at continuous index (x, y, z) = (i, j, k), clamped to the lattice.
float trilinear(const Grid<float>& g, double ci, double cj, double ck) {
  const Lattice& l = g.lattice();
  auto split = [](double c, std::int64_t n, std::int64_t& a, std::int64_t& b, double& t) {
    c = std::clamp(c, 0.0, static_cast<double>(n - 1));
    a = static_cast<std::int64_t>(std::floor(c));
    b = std::min(a + 1, n - 1);
    t = c - static_cast<double>(a);
  };
  std::int64_t i0, i1, j0, j1, k0, k1;
  double ti, tj, tk;
  split(ci, l.nx(), i0, i1, ti);
  split(cj, l.ny(), j0, j1, tj);
  split(ck, l.nz(), k0, k1, tk);
  auto lerp = [](double a, double b, double t) { return a + (b - a) * t; };
  const double c00 = lerp(g(k0, j0, i0), g(k0, j0, i1), ti);
  const double c01 = lerp(g(k0, j1, i0), g(k0, j1, i1), ti);
  const double c10 = lerp(g(k1, j0, i0), g(k1, j0, i1), ti);
  const double c11 = lerp(g(k1, j1, i0), g(k1, j1, i1), ti);
  return static_cast<float>(lerp(lerp(c00, c01, tj), lerp(c10, c11, tj), tk));
}

}  // namespace

Lattice resampledLattice(const Lattice& from, double voxelMm) {
  if (!(voxelMm > 0.0) || !std::isfinite(voxelMm))
    throw UsageError("--resample must be a positive voxel size in mm");
  Lattice to;
  for (int a = 0; a < 3; ++a) {
    const double extent = static_cast<double>(from.dims[a]) * from.spacingMm[a];
    to.dims[a] = std::max<std::int64_t>(1, std::llround(extent / voxelMm));
    to.spacingMm[a] = voxelMm;
    const double lowFace = from.originMm[a] - 0.5 * from.spacingMm[a];
    to.originMm[a] = lowFace + 0.5 * voxelMm;
  }
  if (to.size() > (std::size_t{1} << 33))
    throw UsageError("--resample " + std::to_string(voxelMm) + " mm would create " +
                     std::to_string(to.size()) + " voxels");
  return to;
}

Grid<float> resampleLinear(const Grid<float>& image, const Lattice& to, int threads) {
  const Lattice& from = image.lattice();
  Grid<float> out(to);
  // Supersample each output voxel m^3 times when coarsening (a box filter), so no input
  // voxel is skipped and the grey level stays the volume average.
  int m[3];
  for (int a = 0; a < 3; ++a)
    m[a] = std::max(1, static_cast<int>(std::ceil(to.spacingMm[a] / from.spacingMm[a] - 1e-9)));
  const double inv = 1.0 / (m[0] * m[1] * m[2]);
#pragma omp parallel for num_threads(std::max(1, threads)) schedule(dynamic, 1)
  for (std::int64_t k = 0; k < to.nz(); ++k)
    for (std::int64_t j = 0; j < to.ny(); ++j)
      for (std::int64_t i = 0; i < to.nx(); ++i) {
        double sum = 0.0;
        for (int c = 0; c < m[0]; ++c) {
          const double z =
              to.originMm[0] + (static_cast<double>(k) + (c + 0.5) / m[0] - 0.5) * to.spacingMm[0];
          for (int b = 0; b < m[1]; ++b) {
            const double y = to.originMm[1] +
                             (static_cast<double>(j) + (b + 0.5) / m[1] - 0.5) * to.spacingMm[1];
            for (int a = 0; a < m[2]; ++a) {
              const double x = to.originMm[2] +
                               (static_cast<double>(i) + (a + 0.5) / m[2] - 0.5) * to.spacingMm[2];
              sum += trilinear(image, (x - from.originMm[2]) / from.spacingMm[2],
                               (y - from.originMm[1]) / from.spacingMm[1],
                               (z - from.originMm[0]) / from.spacingMm[0]);
            }
          }
        }
        out(k, j, i) = static_cast<float>(sum * inv);
      }
  return out;
}

Grid<std::uint8_t> resampleNearest(const Grid<std::uint8_t>& field, const Lattice& to) {
  const Lattice& from = field.lattice();
  Grid<std::uint8_t> out(to, 0);
  for (std::int64_t k = 0; k < to.nz(); ++k)
    for (std::int64_t j = 0; j < to.ny(); ++j)
      for (std::int64_t i = 0; i < to.nx(); ++i) {
        const Index3 n = from.nearestIndex(to.centerMm(k, j, i));
        const std::int64_t kk = std::clamp<std::int64_t>(n.k, 0, from.nz() - 1);
        const std::int64_t jj = std::clamp<std::int64_t>(n.j, 0, from.ny() - 1);
        const std::int64_t ii = std::clamp<std::int64_t>(n.i, 0, from.nx() - 1);
        out(k, j, i) = field(kk, jj, ii);
      }
  return out;
}

}  // namespace voxpack::ingest
