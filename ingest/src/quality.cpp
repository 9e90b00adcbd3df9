// Image-quality measures of an ingested bed, its packed region, and the pipeline's memory
// estimate.
#include <algorithm>
#include <cmath>
#include <limits>

#include "voxpack/ingest/ingest.hpp"
#include "voxpack/ingest/resample.hpp"

namespace voxpack::ingest {

double voxelsPerDiameter(const Grid<std::uint8_t>& ind, const Grid<std::uint8_t>* region) {
  // Mean chord of the solid along the three axes = 4V/S for isotropic structures (Cauchy);
  // a sphere of diameter d has 4V/S = 2d/3, so the sphere-equivalent d is 1.5 x the mean
  // chord. Chords cut by the region's edge are dropped (they would be short).
  const Lattice& l = ind.lattice();
  const std::int64_t dims[3] = {l.nz(), l.ny(), l.nx()};
  double total = 0, count = 0;
  for (int axis = 0; axis < 3; ++axis) {
    const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
    for (std::int64_t u = 0; u < dims[a1]; ++u)
      for (std::int64_t v = 0; v < dims[a2]; ++v) {
        std::int64_t run = 0;
        bool open = false;  // the current run began after a void voxel inside the region
        for (std::int64_t w = 0; w < dims[axis]; ++w) {
          std::int64_t idx[3];
          idx[axis] = w;
          idx[a1] = u;
          idx[a2] = v;
          const std::size_t o = l.offset(idx[0], idx[1], idx[2]);
          const bool in = !region || (*region)[o];
          if (!in) {
            run = 0;
            open = false;
            continue;
          }
          if (ind[o] == 0) {
            ++run;
          } else {
            if (open && run > 0) {
              total += static_cast<double>(run);
              count += 1;
            }
            run = 0;
            open = true;
          }
        }
      }
  }
  return count > 0 ? 1.5 * total / count : 0.0;
}

double packedRegionDensity(const Bed& bed, std::int64_t* first, std::int64_t* last) {
  const Lattice& l = bed.lattice();
  const auto plane = static_cast<std::size_t>(l.ny() * l.nx());
  std::vector<double> in(static_cast<std::size_t>(l.nz()), 0), solid(in.size(), 0);
  for (std::int64_t k = 0; k < l.nz(); ++k)
    for (std::size_t p = 0; p < plane; ++p) {
      const std::size_t o = static_cast<std::size_t>(k) * plane + p;
      if (bed.mask && !(*bed.mask)[o]) continue;
      in[static_cast<std::size_t>(k)] += 1;
      solid[static_cast<std::size_t>(k)] += bed.indicator[o] == 0;
    }
  double peak = 0;
  for (std::size_t k = 0; k < in.size(); ++k)
    if (in[k] > 0) peak = std::max(peak, solid[k] / in[k]);
  double a = 0, b = 0;
  std::int64_t k0 = -1, k1 = -1;
  for (std::size_t k = 0; k < in.size(); ++k) {
    if (!(in[k] > 0) || solid[k] / in[k] < 0.5 * peak) continue;
    if (k0 < 0) k0 = static_cast<std::int64_t>(k);
    k1 = static_cast<std::int64_t>(k);
  }
  if (k0 >= 0)
    for (auto k = static_cast<std::size_t>(k0); k <= static_cast<std::size_t>(k1); ++k) {
      a += in[k];
      b += solid[k];
    }
  if (first) *first = k0;
  if (last) *last = k1;
  return a > 0 ? b / a : std::numeric_limits<double>::quiet_NaN();
}

std::uint64_t estimateIngestPeakBytes(const Lattice& input, const IngestOptions& o) {
  const auto n = static_cast<std::uint64_t>(input.size());
  std::uint64_t out = n;
  if (o.resampleMm > 0.0) {
    Lattice l = input;
    out = static_cast<std::uint64_t>(resampledLattice(l, o.resampleMm).size());
  }
  // Reading: ITK's float buffer and ours (8 B/voxel). Pipeline (per output voxel): raw
  // copy, denoised image, denoise/resample scratch, the quantile's value copy (4 B each),
  // preliminary and final indicators, core mask, mask, flood-fill marks (1 B each) and
  // the flood-fill stack (up to 8 B). N4 adds its input copy and ITK's images; labels the
  // distance map, basins and their copies. Calibration holds the bed (2 B) beside a
  // phantom (8 B with the bias field) and a nested pipeline.
  std::uint64_t perVoxel = 16 + 5 + 8;
  if (o.n4) perVoxel += 16;
  if (o.labels) perVoxel += 16;
  std::uint64_t peak = std::max<std::uint64_t>(8 * n, perVoxel * out + 4 * n);
  if (o.calibrationRuns > 0) peak = std::max(peak, (perVoxel + 10) * out);
  return peak;
}

}  // namespace voxpack::ingest
