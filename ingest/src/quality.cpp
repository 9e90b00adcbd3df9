// Image-quality measures of an ingested bed, its packed region, and the pipeline's memory
// estimate.
#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include "voxpack/ingest/ingest.hpp"
#include "voxpack/ingest/resample.hpp"
#include "voxpack/ingest/segment.hpp"

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

namespace {
// Voxels inside the mask and solid voxels among them, per slice.
void sliceCounts(const Grid<std::uint8_t>& ind, const Grid<std::uint8_t>* mask,
                 std::vector<double>& in, std::vector<double>& solid) {
  const Lattice& l = ind.lattice();
  const auto plane = static_cast<std::size_t>(l.ny() * l.nx());
  in.assign(static_cast<std::size_t>(l.nz()), 0);
  solid.assign(in.size(), 0);
  for (std::int64_t k = 0; k < l.nz(); ++k)
    for (std::size_t p = 0; p < plane; ++p) {
      const std::size_t o = static_cast<std::size_t>(k) * plane + p;
      if (mask && !(*mask)[o]) continue;
      in[static_cast<std::size_t>(k)] += 1;
      solid[static_cast<std::size_t>(k)] += ind[o] == 0;
    }
}

std::pair<std::int64_t, std::int64_t> halfPeakSlices(const std::vector<double>& in,
                                                     const std::vector<double>& solid) {
  // A fully solid slice is a floor or a lid segmented with the bed (as compare's packed
  // region has it): it would set the peak and join the far end's lid to the bed.
  auto packing = [&](std::size_t k) { return in[k] > 0 && solid[k] / in[k] < 0.999; };
  double peak = 0;
  for (std::size_t k = 0; k < in.size(); ++k)
    if (packing(k)) peak = std::max(peak, solid[k] / in[k]);
  std::int64_t k0 = -1, k1 = -1;
  for (std::size_t k = 0; k < in.size(); ++k) {
    if (!packing(k) || solid[k] / in[k] < 0.5 * peak) continue;
    if (k0 < 0) k0 = static_cast<std::int64_t>(k);
    k1 = static_cast<std::int64_t>(k);
  }
  return {k0, k1};
}
}  // namespace

std::pair<std::int64_t, std::int64_t> bedSlices(const Grid<std::uint8_t>& indicator,
                                                const Grid<std::uint8_t>* mask) {
  std::vector<double> in, solid;
  sliceCounts(indicator, mask, in, solid);
  return bedSlicesFromCounts(in, solid);
}

std::pair<std::int64_t, std::int64_t> bedSlicesFromCounts(const std::vector<double>& in,
                                                          const std::vector<double>& solid) {
  std::vector<double> share(in.size(), 0);
  double top = 0;
  for (std::size_t k = 0; k < in.size(); ++k) {
    share[k] = in[k] > 0 ? solid[k] / in[k] : 0;
    top = std::max(top, share[k]);
  }
  // The typical slice of the bed: the median share over the slices that hold any bed
  // (>= 0.1 of the densest), so neither the headspace nor a solid floor plate (share ~1)
  // sets the level. The bed is the longest run at >= half of it; a run, not first..last,
  // so that a plate at the far end of the headspace does not pull the headspace in.
  std::vector<double> held;
  for (double x : share)
    if (x >= 0.1 * top && x > 0) held.push_back(x);
  if (held.empty()) return {-1, -1};
  const auto mid = held.begin() + static_cast<std::ptrdiff_t>(held.size() / 2);
  std::nth_element(held.begin(), mid, held.end());
  const double cut = 0.5 * *mid;
  std::int64_t best0 = -1, best1 = -1, run0 = -1;
  for (std::size_t k = 0; k <= share.size(); ++k) {
    const bool in_run = k < share.size() && in[k] > 0 && share[k] >= cut;
    if (in_run && run0 < 0) run0 = static_cast<std::int64_t>(k);
    if (!in_run && run0 >= 0) {
      const auto last = static_cast<std::int64_t>(k) - 1;
      if (best0 < 0 || last - run0 > best1 - best0) {
        best0 = run0;
        best1 = last;
      }
      run0 = -1;
    }
  }
  return {best0, best1};
}

double packedRegionDensity(const Bed& bed, std::int64_t* first, std::int64_t* last) {
  std::vector<double> in, solid;
  sliceCounts(bed.indicator, bed.mask ? &*bed.mask : nullptr, in, solid);
  const auto [k0, k1] = halfPeakSlices(in, solid);
  double a = 0, b = 0;
  if (k0 >= 0)
    for (auto k = static_cast<std::size_t>(k0); k <= static_cast<std::size_t>(k1); ++k) {
      a += in[k];
      b += solid[k];
    }
  if (first) *first = k0;
  if (last) *last = k1;
  return a > 0 ? b / a : std::numeric_limits<double>::quiet_NaN();
}

std::uint64_t estimateIngestPeakBytes(const Lattice& input, const IngestOptions& o,
                                      std::optional<bool> voidBright, int threads) {
  const auto n = static_cast<std::uint64_t>(input.size());
  std::uint64_t m = n;
  auto plane = static_cast<std::uint64_t>(input.ny()) * static_cast<std::uint64_t>(input.nx());
  if (o.resampleMm > 0.0) {
    Lattice l = input;
    const Lattice r = resampledLattice(l, o.resampleMm);
    m = static_cast<std::uint64_t>(r.size());
    plane = static_cast<std::uint64_t>(r.ny()) * static_cast<std::uint64_t>(r.nx());
  }
  // The pipeline's stages, with what each holds per voxel (pipeline.cpp); the peak is the
  // largest. Read off the code and checked against the peak RSS of each pipeline at 256³
  // (docs/scale.md). The raw copy (4 B) is kept for the volume threshold and for the
  // squared-wall column refinement of Rician (MRI) images, and for the image quality that
  // --calibrate images its phantoms at.
  const bool volume =
      o.threshold == ThresholdMethod::Auto || o.threshold == ThresholdMethod::Volume;
  const bool maybeRician =
      o.noise == NoiseChoice::Rician || (o.noise == NoiseChoice::Auto && voidBright.value_or(true));
  // The phase levels (read for the volume threshold and for --calibrate's image quality,
  // pipeline.cpp's wantLevels) need the raw copy and, in fitPhaseLevels, a value copy.
  const bool levels = volume || o.calibrationRuns > 0;
  const std::uint64_t raw =
      levels || (maybeRician && o.column != ColumnMode::None && o.refineColumn) ? 4 : 0;
  // Reading: ITK's float buffer and ours.
  std::uint64_t peak = 8 * n;
  // Denoising, in the input lattice: the image and the filter's output (curvature: ITK's
  // input copy, output and update buffer as well).
  const std::uint64_t denoise = o.denoise == DenoiseMethod::Curvature ? 20
                                : o.denoise == DenoiseMethod::None    ? 4
                                                                      : 8;
  peak = std::max(peak, (denoise + raw) * n);
  if (o.n4) peak = std::max(peak, (20 + raw) * n);  // its input copy and ITK's images
  if (o.resampleMm > 0.0) peak = std::max(peak, (4 + raw) * (n + m));
  // In the output lattice. Threshold choice: the image, raw, the preliminary indicator,
  // the column core (or, with no column, the bed's slices) and (the phase levels, and the
  // volume threshold's quantile after them) a value copy. Segmentation: the image, the core, two
  // indicators and the clean-up's marks (its search holds <= maxVoxels + 6).
  const std::uint64_t choose = 4 + raw + 1 + 1 + (levels ? 4 : 0);
  const std::uint64_t segment = 4 + 1 + 1 + 1 + 1;
  std::uint64_t perOut = std::max(choose, segment);
  // Labels: the distance map, the basins and their copies (28.5 B measured at 256³).
  if (o.labels) perOut = std::max<std::uint64_t>(perOut, 30);
  // Richardson-Lucy (ITK): the image, its iterates and the FFT buffers of the padded box;
  // 63.5 B/voxel measured at 256³ with the image (67.3 with the raw copy).
  if (o.deconvolveIterations > 0) perOut = std::max<std::uint64_t>(perOut, 64 + raw);
  const std::uint64_t search = cleanupSearchBytes(std::max(o.maxSpeckVoxels, o.maxHoleVoxels), m);
  // The phase levels' memos per thread and sampled slice (deep_level.cpp): the dip test's
  // corner values (2 slices of doubles) and its cube's deep flags (2 ceil(radius) + 1 slices
  // of bytes; the radius is at most 15, and the blur that sets it is not known yet).
  const std::uint64_t memos =
      levels ? static_cast<std::uint64_t>(std::max(1, threads)) * (16 + 31) * plane : 0;
  peak = std::max(peak, perOut * m + search + memos);
  // Calibration holds the bed (2 B) beside a phantom (8 B with the bias field) and the
  // same pipeline run on it.
  if (o.calibrationRuns > 0)
    peak = std::max(peak, 10 * m + peak * m / std::max<std::uint64_t>(n, 1));
  return peak + kIngestProcessBaseBytes;
}

}  // namespace voxpack::ingest
