// Mean empty space, lattice path: 13 line directions, run-length scans (docs/stats.md).
#include "voxpack/stats/mes.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "mes_window.hpp"
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
  const std::int64_t nz = l.nz(), ny = l.ny(), nx = l.nx();
  const std::uint8_t* ind = bed.indicator.data();
  const std::uint8_t* msk = bed.mask ? bed.mask->data() : nullptr;
  // The y and x faces plane by plane, as the streamed path marks them; z: the end planes.
  std::vector<std::uint64_t> faceY(static_cast<std::size_t>(nz)), faceX(faceY.size());
  markFaceVoid(ind, msk, nz, ny, nx, 0, faceY, faceX);
  auto planeHasVoid = [&](std::int64_t k) {
    for (std::size_t o = l.offset(k, 0, 0), e = o + static_cast<std::size_t>(ny * nx); o < e; ++o)
      if (ind[o] != 0 && (!msk || msk[o] != 0)) return true;
    return false;
  };
  auto any = [](const std::vector<std::uint64_t>& v) {
    return std::any_of(v.begin(), v.end(), [](std::uint64_t x) { return x != 0; });
  };
  return {nz > 0 && (planeHasVoid(0) || planeHasVoid(nz - 1)), any(faceY), any(faceX)};
}

namespace {

// The whole bed in memory is every slab's window; its planes are scanned a chunk at a time
// (mesInMemoryChunkPlanes), so the scratch is a chunk's, whatever the cut axes.
MesSums scanInChunks(const Bed& bed, const MesGeometry& g, double binWidthMm, int threads,
                     Progress& progress, MesField* field) {
  const Lattice& l = bed.lattice();
  MesSums sums(l, binWidthMm);
  const std::int64_t nz = l.nz(), t = mesInMemoryChunkPlanes(l.nz(), l.ny(), l.nx());
  const auto plane = static_cast<std::size_t>(l.ny() * l.nx());
  if (field) {
    field->meanMm.assign(l.size(), std::numeric_limits<float>::quiet_NaN());
    field->weight.assign(l.size(), 0.0f);
  }
  NullProgress quiet;
  for (std::int64_t z0 = 0; z0 < nz; z0 += t) {
    if (progress.cancelled()) throw Cancelled("mean empty space");
    progress.report("mean empty space", static_cast<double>(z0) / static_cast<double>(nz));
    MesWindow w;
    w.indicator = bed.indicator.data();
    w.mask = bed.mask ? bed.mask->data() : nullptr;
    w.planes = nz;
    w.ownFirst = z0;
    w.ownLast = std::min(nz, z0 + t);
    MesField part;
    scanMesWindow(w, g, threads, sums, quiet, field ? &part : nullptr);
    if (field) {
      const auto at = static_cast<std::ptrdiff_t>(static_cast<std::size_t>(z0) * plane);
      std::copy(part.meanMm.begin(), part.meanMm.end(), field->meanMm.begin() + at);
      std::copy(part.weight.begin(), part.weight.end(), field->weight.begin() + at);
    }
  }
  progress.report("mean empty space", 1.0);
  return sums;
}

}  // namespace

MesField meanEmptySpaceField(const Bed& bed, int threads, Progress& progress) {
  const MesGeometry g = mesGeometry(bed.lattice(), windowCutAxes(bed));
  MesField f;
  f.directionalMeanMm = scanInChunks(bed, g, 0, threads, progress, &f).finish(g).directionalMeanMm;
  return f;
}

MesResult meanEmptySpaceLattice(const Bed& bed, const MesLatticeOptions& options,
                                Progress& progress) {
  if (!std::isfinite(options.binWidthMm)) throw InputError("mean empty space: bad bin width");
  const auto t0 = std::chrono::steady_clock::now();
  const MesGeometry g = mesGeometry(bed.lattice(), windowCutAxes(bed));
  MesResult r =
      scanInChunks(bed, g, options.binWidthMm, options.threads, progress, nullptr).finish(g);
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace voxpack::stats
