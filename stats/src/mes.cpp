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

namespace {

// The moments, lognormal fit and histogram of values[n] taken count(n) times with weight
// weight(n) each; count is 1 for a list, the multiplicity for a histogram.
template <class Weight, class Count>
LengthDistribution summarize(const std::vector<double>& values, double binWidthMm, Weight weightOf,
                             Count countOf) {
  LengthDistribution d;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  d.binWidthMm = binWidthMm;
  auto usable = [&](std::size_t n) {
    const double v = values[n];
    return v > 0 && std::isfinite(v) && weightOf(n) > 0 && std::isfinite(weightOf(n)) &&
           countOf(n) > 0;
  };
  double wsum = 0, sum = 0, maxV = 0, logSum = 0;
  for (std::size_t n = 0; n < values.size(); ++n) {
    if (!usable(n)) continue;
    const double w = weightOf(n) * static_cast<double>(countOf(n));
    wsum += w;
    sum += w * values[n];
    logSum += w * std::log(values[n]);
    maxV = std::max(maxV, values[n]);
    d.samples += countOf(n);
  }
  if (d.samples == 0 || !(binWidthMm > 0)) {
    d.samples = 0;
    d.meanMm = d.stdMm = d.lognormalMu = d.lognormalSigma = nan;
    return d;
  }
  d.meanMm = sum / wsum;
  d.lognormalMu = logSum / wsum;
  double ss = 0, ls = 0;
  const std::size_t bins = static_cast<std::size_t>(std::floor(maxV / binWidthMm)) + 1;
  std::vector<double> counts(bins, 0.0);
  for (std::size_t n = 0; n < values.size(); ++n) {
    if (!usable(n)) continue;
    const double v = values[n], w = weightOf(n) * static_cast<double>(countOf(n));
    ss += w * (v - d.meanMm) * (v - d.meanMm);
    ls += w * (std::log(v) - d.lognormalMu) * (std::log(v) - d.lognormalMu);
    counts[std::min(bins - 1, static_cast<std::size_t>(std::floor(v / binWidthMm)))] += w;
  }
  d.stdMm = std::sqrt(ss / wsum);
  d.lognormalSigma = std::sqrt(ls / wsum);
  d.binsMm.resize(bins);
  d.pdf.resize(bins);
  for (std::size_t b = 0; b < bins; ++b) {
    d.binsMm[b] = (static_cast<double>(b) + 0.5) * binWidthMm;
    d.pdf[b] = counts[b] / (wsum * binWidthMm);
  }
  return d;
}

}  // namespace

LengthDistribution summarizeLengths(const std::vector<double>& values, double binWidthMm,
                                    const std::vector<double>* weights) {
  return summarize(
      values, binWidthMm, [&](std::size_t n) { return weights ? (*weights)[n] : 1.0; },
      [](std::size_t) { return std::uint64_t{1}; });
}

LengthDistribution summarizeCountedLengths(const std::vector<double>& values,
                                           const std::vector<double>& weights,
                                           const std::vector<std::uint64_t>& counts,
                                           double binWidthMm) {
  return summarize(
      values, binWidthMm, [&](std::size_t n) { return weights[n]; },
      [&](std::size_t n) { return counts[n]; });
}

std::array<bool, 3> windowCutAxes(const Bed& bed) {
  const Lattice& l = bed.lattice();
  const std::int64_t n[3] = {l.nz(), l.ny(), l.nx()};
  std::array<bool, 3> cut{false, false, false};
  for (std::int64_t k = 0; k < n[0]; ++k)
    for (std::int64_t j = 0; j < n[1]; ++j)
      for (std::int64_t i = 0; i < n[2]; ++i) {
        const bool face[3] = {k == 0 || k == n[0] - 1, j == 0 || j == n[1] - 1,
                              i == 0 || i == n[2] - 1};
        if (!face[0] && !face[1] && !face[2]) {
          i = n[2] - 2;  // jump to the far x face
          continue;
        }
        const std::size_t o = l.offset(k, j, i);
        if (bed.indicator[o] == 0 || (bed.mask && (*bed.mask)[o] == 0)) continue;
        for (int a = 0; a < 3; ++a) cut[static_cast<std::size_t>(a)] |= face[a];
      }
  return cut;
}

MesField meanEmptySpaceField(const Bed& bed, int threads, Progress& progress) {
  const Lattice& l = bed.lattice();
  const std::int64_t nz = l.nz(), ny = l.ny(), nx = l.nx();
  const std::int64_t n[3] = {nz, ny, nx};
  const std::size_t total = l.size();
  const std::uint8_t* ind = bed.indicator.data();
  const std::uint8_t* msk = bed.mask ? bed.mask->data() : nullptr;
  const std::array<bool, 3> cutAxes = windowCutAxes(bed);
  std::vector<float> sum(total, 0.0f);
  std::vector<std::uint8_t> count(total, 0), cut(total, 0);
  // Reach (voxels) of the chord star of each voxel towards − and + along each cut axis:
  // the star must fit in the window for m(x) to be observed (minus sampling).
  std::array<std::vector<std::uint16_t>, 6> reach;
  for (int a = 0; a < 3; ++a)
    if (cutAxes[static_cast<std::size_t>(a)]) {
      reach[static_cast<std::size_t>(2 * a)].assign(total, 0);
      reach[static_cast<std::size_t>(2 * a + 1)].assign(total, 0);
    }
  const auto& dirs = latticeDirections();
  MesField f;
  double directionalSum = 0;
  for (std::size_t d = 0; d < dirs.size(); ++d) {
    if (progress.cancelled()) throw Cancelled("mean empty space");
    double sumL2 = 0, sumL = 0;
    progress.report("mean empty space", static_cast<double>(d) / static_cast<double>(dirs.size()));
    const int u[3] = {dirs[d][0], dirs[d][1], dirs[d][2]};
    const int dk = u[0], dj = u[1], di = u[2];
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
    const bool lineCut =
        (dk != 0 && cutAxes[0]) || (dj != 0 && cutAxes[1]) || (di != 0 && cutAxes[2]);
    auto lineLength = [&](const Index3& p) {
      std::int64_t len = nz + ny + nx;
      if (dk) len = std::min(len, dk > 0 ? nz - p.k : p.k + 1);
      if (dj) len = std::min(len, dj > 0 ? ny - p.j : p.j + 1);
      if (di) len = std::min(len, di > 0 ? nx - p.i : p.i + 1);
      return len;
    };
    // Minus sampling over all lines of this direction: a chord of ℓ voxels is seen whole at
    // T(ℓ) = Σ_lines max(0, L − ℓ − 1) positions; its weight is 1/T(ℓ). (Lines differ in
    // length along diagonals, so a per-line weight would under-count long chords.)
    std::vector<double> lengthCount;
    for (const Index3& p : starts) {
      const auto len = static_cast<std::size_t>(lineLength(p));
      if (len >= lengthCount.size()) lengthCount.resize(len + 1, 0.0);
      lengthCount[len] += 1;
    }
    std::vector<double> positions(lengthCount.size() + 1, 0.0);
    for (std::size_t ell = 0; ell < positions.size(); ++ell)
      for (std::size_t len = ell + 2; len < lengthCount.size(); ++len)
        positions[ell] += lengthCount[len] * static_cast<double>(len - ell - 1);
#pragma omp parallel for num_threads(std::max(1, threads)) schedule(dynamic, 256) \
    reduction(+ : sumL2, sumL)
    for (std::int64_t s = 0; s < nStarts; ++s) {
      std::int64_t k = starts[static_cast<std::size_t>(s)].k,
                   j = starts[static_cast<std::size_t>(s)].j,
                   i = starts[static_cast<std::size_t>(s)].i;
      std::int64_t o = static_cast<std::int64_t>(l.offset(k, j, i));
      std::int64_t runStart = 0, runLen = 0;
      bool runCut = false;
      auto flush = [&](bool isCut) {
        const auto chord = static_cast<float>(static_cast<double>(runLen) * step);
        if (!isCut) {
          // Point-weighted mean chord along u: Σ w ℓ² / Σ w ℓ.
          const auto ell = static_cast<std::size_t>(runLen);
          const double w =
              lineCut ? 1.0 / std::max(1.0, ell < positions.size() ? positions[ell] : 1.0) : 1.0;
          sumL2 += w * static_cast<double>(chord) * static_cast<double>(chord);
          sumL += w * static_cast<double>(chord);
        }
        for (std::int64_t t = 0; t < runLen; ++t) {
          const auto p = static_cast<std::size_t>(runStart + t * stride);
          if (isCut) {
            cut[p] = 1;
            continue;
          }
          sum[p] += chord;
          ++count[p];
          // Chord ends (the bounding solid voxels) sit t + 1 steps back, runLen − t ahead.
          for (int a = 0; a < 3; ++a) {
            if (u[a] == 0 || !cutAxes[static_cast<std::size_t>(a)]) continue;
            const auto back = static_cast<std::uint16_t>(std::min<std::int64_t>(t + 1, 65535));
            const auto ahead =
                static_cast<std::uint16_t>(std::min<std::int64_t>(runLen - t, 65535));
            auto& lo = reach[static_cast<std::size_t>(2 * a)][p];
            auto& hi = reach[static_cast<std::size_t>(2 * a + 1)][p];
            lo = std::max(lo, u[a] > 0 ? back : ahead);
            hi = std::max(hi, u[a] > 0 ? ahead : back);
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
    if (sumL > 0) {
      directionalSum += sumL2 / sumL;
    } else {
      directionalSum = std::numeric_limits<double>::quiet_NaN();
    }
  }
  f.directionalMeanMm = directionalSum / static_cast<double>(dirs.size());
  f.meanMm.assign(total, std::numeric_limits<float>::quiet_NaN());
  f.weight.assign(total, 0.0f);
  for (std::size_t p = 0; p < total; ++p) {
    if (count[p] == 0 || cut[p]) continue;
    double w = 1;
    for (int a = 0; a < 3; ++a) {
      if (!cutAxes[static_cast<std::size_t>(a)]) continue;
      const double span = static_cast<double>(reach[static_cast<std::size_t>(2 * a)][p]) +
                          static_cast<double>(reach[static_cast<std::size_t>(2 * a + 1)][p]);
      // Translations of the star (span + 1 voxels) that stay in the window: n − span.
      w *= static_cast<double>(n[a]) / std::max(1.0, static_cast<double>(n[a]) - span);
    }
    f.meanMm[p] = sum[p] / static_cast<float>(count[p]);
    f.weight[p] = static_cast<float>(w);
  }
  progress.report("mean empty space", 1.0);
  return f;
}

MesResult meanEmptySpaceLattice(const Bed& bed, const MesLatticeOptions& options,
                                Progress& progress) {
  if (!std::isfinite(options.binWidthMm)) throw InputError("mean empty space: bad bin width");
  const auto t0 = std::chrono::steady_clock::now();
  const Lattice& l = bed.lattice();
  const MesField m = meanEmptySpaceField(bed, options.threads, progress);
  MesResult r;
  r.directions = static_cast<int>(latticeDirections().size());
  std::vector<double> values, weights;
  for (std::size_t p = 0; p < m.meanMm.size(); ++p) {
    const bool isVoid = bed.indicator[p] != 0 && (!bed.mask || (*bed.mask)[p] != 0);
    if (!isVoid) continue;
    ++r.voidVoxels;
    if (std::isnan(m.meanMm[p])) {
      ++r.undefinedVoxels;
      continue;
    }
    values.push_back(m.meanMm[p]);
    weights.push_back(m.weight[p]);
  }
  const double width = options.binWidthMm > 0
                           ? options.binWidthMm
                           : std::min({l.spacingMm[0], l.spacingMm[1], l.spacingMm[2]});
  r.distribution = summarizeLengths(values, width, &weights);
  r.directionalMeanMm = m.directionalMeanMm;
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace voxpack::stats
