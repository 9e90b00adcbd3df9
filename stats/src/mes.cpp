// Mean empty space, lattice path: 13 line directions, run-length scans (docs/stats.md).
#include "voxpack/stats/mes.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "voxpack/core/errors.hpp"

namespace voxpack::stats {

const std::vector<std::array<int, 3>>& latticeDirections() {
  static const std::vector<std::array<int, 3>> dirs{
      {1, 0, 0}, {0, 1, 0},  {0, 0, 1}, {0, 1, 1},  {0, 1, -1}, {1, 0, 1},  {1, 0, -1},
      {1, 1, 0}, {1, -1, 0}, {1, 1, 1}, {1, 1, -1}, {1, -1, 1}, {1, -1, -1}};
  return dirs;
}

LengthDistribution summarizeLengths(const std::vector<double>& values, double binWidthMm) {
  LengthDistribution d;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  d.binWidthMm = binWidthMm;
  double sum = 0, maxV = 0, logSum = 0;
  std::size_t n = 0;
  for (double v : values) {
    if (!(v > 0) || !std::isfinite(v)) continue;
    sum += v;
    logSum += std::log(v);
    maxV = std::max(maxV, v);
    ++n;
  }
  d.samples = n;
  if (n == 0 || !(binWidthMm > 0)) {
    d.meanMm = d.stdMm = d.lognormalMu = d.lognormalSigma = nan;
    return d;
  }
  d.meanMm = sum / static_cast<double>(n);
  d.lognormalMu = logSum / static_cast<double>(n);
  double ss = 0, ls = 0;
  const std::size_t bins = static_cast<std::size_t>(std::floor(maxV / binWidthMm)) + 1;
  std::vector<double> counts(bins, 0.0);
  for (double v : values) {
    if (!(v > 0) || !std::isfinite(v)) continue;
    ss += (v - d.meanMm) * (v - d.meanMm);
    ls += (std::log(v) - d.lognormalMu) * (std::log(v) - d.lognormalMu);
    counts[std::min(bins - 1, static_cast<std::size_t>(std::floor(v / binWidthMm)))] += 1;
  }
  d.stdMm = std::sqrt(ss / static_cast<double>(n));
  d.lognormalSigma = std::sqrt(ls / static_cast<double>(n));
  d.binsMm.resize(bins);
  d.pdf.resize(bins);
  for (std::size_t b = 0; b < bins; ++b) {
    d.binsMm[b] = (static_cast<double>(b) + 0.5) * binWidthMm;
    d.pdf[b] = counts[b] / (static_cast<double>(n) * binWidthMm);
  }
  return d;
}

std::vector<float> meanEmptySpaceField(const Bed& bed, int threads, Progress& progress) {
  const Lattice& l = bed.lattice();
  const std::int64_t nz = l.nz(), ny = l.ny(), nx = l.nx();
  const std::size_t total = l.size();
  const std::uint8_t* ind = bed.indicator.data();
  const std::uint8_t* msk = bed.mask ? bed.mask->data() : nullptr;
  std::vector<float> sum(total, 0.0f);
  std::vector<std::uint8_t> count(total, 0);
  const auto& dirs = latticeDirections();
  for (std::size_t d = 0; d < dirs.size(); ++d) {
    if (progress.cancelled()) throw Cancelled("mean empty space");
    progress.report("mean empty space", static_cast<double>(d) / static_cast<double>(dirs.size()));
    const int dk = dirs[d][0], dj = dirs[d][1], di = dirs[d][2];
    const double step =
        std::sqrt(std::pow(dk * l.spacingMm[0], 2) + std::pow(dj * l.spacingMm[1], 2) +
                  std::pow(di * l.spacingMm[2], 2));
    const std::int64_t stride = (dk * ny + dj) * nx + di;
    // Line starts: voxels whose predecessor p − u lies outside the lattice.
    const std::int64_t ek = dk > 0 ? 0 : nz - 1, ej = dj > 0 ? 0 : ny - 1, ei = di > 0 ? 0 : nx - 1;
    std::vector<Index3> starts;
    for (std::int64_t k = 0; k < nz; ++k)
      for (std::int64_t j = 0; j < ny; ++j) {
        const bool onK = dk != 0 && k == ek, onJ = dj != 0 && j == ej;
        if (onK || onJ) {
          for (std::int64_t i = 0; i < nx; ++i) starts.push_back({k, j, i});
        } else if (di != 0) {
          starts.push_back({k, j, ei});
        }
      }
    const auto nStarts = static_cast<std::int64_t>(starts.size());
#pragma omp parallel for num_threads(std::max(1, threads)) schedule(dynamic, 256)
    for (std::int64_t s = 0; s < nStarts; ++s) {
      std::int64_t k = starts[static_cast<std::size_t>(s)].k,
                   j = starts[static_cast<std::size_t>(s)].j,
                   i = starts[static_cast<std::size_t>(s)].i;
      std::int64_t o = static_cast<std::int64_t>(l.offset(k, j, i));
      std::int64_t runStart = 0, runLen = 0;
      bool runCut = false;
      auto flush = [&](bool cut) {
        if (!cut) {
          const auto chord = static_cast<float>(static_cast<double>(runLen) * step);
          for (std::int64_t u = 0; u < runLen; ++u) {
            const auto p = static_cast<std::size_t>(runStart + u * stride);
            sum[p] += chord;
            ++count[p];
          }
        }
        runLen = 0;
      };
      bool first = true;
      while (k >= 0 && j >= 0 && i >= 0 && k < nz && j < ny && i < nx) {
        const auto p = static_cast<std::size_t>(o);
        const bool isVoid = ind[p] != 0 && (!msk || msk[p] != 0);
        if (isVoid) {
          if (runLen == 0) {
            runStart = o;
            runCut = first;  // the run begins at the window boundary
          }
          ++runLen;
        } else if (runLen > 0) {
          flush(runCut);
        }
        first = false;
        k += dk;
        j += dj;
        i += di;
        o += stride;
      }
      if (runLen > 0) flush(true);  // the run ends at the window boundary
    }
  }
  std::vector<float> m(total, std::numeric_limits<float>::quiet_NaN());
  for (std::size_t p = 0; p < total; ++p)
    if (count[p] > 0) m[p] = sum[p] / static_cast<float>(count[p]);
  progress.report("mean empty space", 1.0);
  return m;
}

MesResult meanEmptySpaceLattice(const Bed& bed, const MesLatticeOptions& options,
                                Progress& progress) {
  if (!std::isfinite(options.binWidthMm)) throw InputError("mean empty space: bad bin width");
  const auto t0 = std::chrono::steady_clock::now();
  const Lattice& l = bed.lattice();
  const std::vector<float> m = meanEmptySpaceField(bed, options.threads, progress);
  MesResult r;
  r.directions = static_cast<int>(latticeDirections().size());
  std::vector<double> values;
  for (std::size_t p = 0; p < m.size(); ++p) {
    const bool isVoid = bed.indicator[p] != 0 && (!bed.mask || (*bed.mask)[p] != 0);
    if (!isVoid) continue;
    ++r.voidVoxels;
    if (std::isnan(m[p])) {
      ++r.undefinedVoxels;
      continue;
    }
    values.push_back(m[p]);
  }
  const double width = options.binWidthMm > 0
                           ? options.binWidthMm
                           : std::min({l.spacingMm[0], l.spacingMm[1], l.spacingMm[2]});
  r.distribution = summarizeLengths(values, width);
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace voxpack::stats
