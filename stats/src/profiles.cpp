// Axial and radial packing-density profiles (docs/stats.md).
#include "voxpack/stats/profiles.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "voxpack/core/errors.hpp"

namespace voxpack::stats {
namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

}  // namespace

NormalityTest dagostinoPearson(const std::vector<double>& x) {
  NormalityTest t;
  const double n = static_cast<double>(x.size());
  if (x.size() < 8) return t;
  double mean = 0;
  for (double v : x) mean += v;
  mean /= n;
  double m2 = 0, m3 = 0, m4 = 0;
  for (double v : x) {
    const double d = v - mean;
    m2 += d * d;
    m3 += d * d * d;
    m4 += d * d * d * d;
  }
  m2 /= n;
  m3 /= n;
  m4 /= n;
  if (!(m2 > 1e-300)) return t;
  t.skewness = m3 / std::pow(m2, 1.5);
  const double b2 = m4 / (m2 * m2);
  t.kurtosis = b2 - 3;
  // Skewness test (D'Agostino 1970).
  double y = t.skewness * std::sqrt((n + 1) * (n + 3) / (6 * (n - 2)));
  const double beta2 =
      3 * (n * n + 27 * n - 70) * (n + 1) * (n + 3) / ((n - 2) * (n + 5) * (n + 7) * (n + 9));
  const double w2 = -1 + std::sqrt(2 * (beta2 - 1));
  const double delta = 1 / std::sqrt(0.5 * std::log(w2));
  const double alpha = std::sqrt(2 / (w2 - 1));
  if (y == 0) y = 1;
  const double zs = delta * std::log(y / alpha + std::sqrt((y / alpha) * (y / alpha) + 1));
  // Kurtosis test (Anscombe & Glynn 1983).
  const double e = 3 * (n - 1) / (n + 1);
  const double varb2 = 24 * n * (n - 2) * (n - 3) / ((n + 1) * (n + 1) * (n + 3) * (n + 5));
  const double xk = (b2 - e) / std::sqrt(varb2);
  const double sqrtBeta1 = 6 * (n * n - 5 * n + 2) / ((n + 7) * (n + 9)) *
                           std::sqrt(6 * (n + 3) * (n + 5) / (n * (n - 2) * (n - 3)));
  const double a = 6 + 8 / sqrtBeta1 * (2 / sqrtBeta1 + std::sqrt(1 + 4 / (sqrtBeta1 * sqrtBeta1)));
  const double term1 = 1 - 2 / (9 * a);
  const double denom = 1 + xk * std::sqrt(2 / (a - 4));
  if (denom == 0) return t;
  const double term2 = (denom > 0 ? 1.0 : -1.0) * std::cbrt((1 - 2 / a) / std::abs(denom));
  const double zk = (term1 - term2) / std::sqrt(2 / (9 * a));
  t.statistic = zs * zs + zk * zk;
  t.pValue = std::exp(-0.5 * t.statistic);  // chi-square, 2 degrees of freedom
  return t;
}

SliceCounts sliceCounts(const Bed& bed) {
  SliceCounts c;
  accumulateSliceCounts(c, 0, bed.indicator, bed.mask ? &*bed.mask : nullptr);
  return c;
}

void accumulateSliceCounts(SliceCounts& c, std::int64_t z0, const Grid<std::uint8_t>& indicator,
                           const Grid<std::uint8_t>* mask) {
  const Lattice& l = indicator.lattice();
  const std::size_t slice = static_cast<std::size_t>(l.ny() * l.nx());
  const std::size_t need = static_cast<std::size_t>(z0 + l.nz());
  if (c.mask.size() < need) {
    c.mask.resize(need, 0);
    c.solid.resize(need, 0);
  }
  for (std::int64_t k = 0; k < l.nz(); ++k) {
    const std::size_t base = static_cast<std::size_t>(k) * slice;
    std::uint64_t m = 0, s = 0;
    for (std::size_t o = base; o < base + slice; ++o) {
      if (mask && (*mask)[o] == 0) continue;
      ++m;
      s += indicator[o] == 0;
    }
    c.mask[static_cast<std::size_t>(z0 + k)] += m;
    c.solid[static_cast<std::size_t>(z0 + k)] += s;
  }
}

AxialProfile axialProfile(const Bed& bed, const AxialOptions& options) {
  return axialProfile(bed.lattice(), sliceCounts(bed), options);
}

AxialProfile axialProfile(const Lattice& l, const SliceCounts& counts,
                          const AxialOptions& options) {
  if (!(options.trimMm >= 0) || !std::isfinite(options.trimMm))
    throw InputError("axial profile: trim must be a finite number of mm >= 0");
  if (options.histogramBins < 1) throw InputError("axial profile: histogram bins must be >= 1");
  const std::int64_t nz = l.nz();
  if (counts.mask.size() != static_cast<std::size_t>(nz) ||
      counts.solid.size() != counts.mask.size())
    throw InternalError("axial profile: slice counts do not match the lattice");
  AxialProfile p;
  p.zMmAll.resize(static_cast<std::size_t>(nz));
  p.densityAll.assign(static_cast<std::size_t>(nz), kNaN);
  const auto& maskCount = counts.mask;
  const auto& solidCount = counts.solid;
  for (std::int64_t k = 0; k < nz; ++k) {
    const auto kk = static_cast<std::size_t>(k);
    p.zMmAll[kk] = l.originMm[0] + static_cast<double>(k) * l.spacingMm[0];
    if (maskCount[kk] > 0)
      p.densityAll[kk] = static_cast<double>(solidCount[kk]) / static_cast<double>(maskCount[kk]);
  }
  // The bed spans the slices holding solid; without solid, every slice with mask voxels.
  std::int64_t lo = -1, hi = -1;
  for (std::int64_t k = 0; k < nz; ++k)
    if (solidCount[static_cast<std::size_t>(k)] > 0) {
      if (lo < 0) lo = k;
      hi = k;
    }
  if (lo < 0)
    for (std::int64_t k = 0; k < nz; ++k)
      if (maskCount[static_cast<std::size_t>(k)] > 0) {
        if (lo < 0) lo = k;
        hi = k;
      }
  p.firstSlice = 0;
  p.lastSlice = -1;
  if (lo >= 0) {
    const double zlo = p.zMmAll[static_cast<std::size_t>(lo)];
    const double zhi = p.zMmAll[static_cast<std::size_t>(hi)];
    const double eps = 1e-9 * l.spacingMm[0];
    bool any = false;
    for (std::int64_t k = lo; k <= hi; ++k) {
      const auto kk = static_cast<std::size_t>(k);
      const double z = p.zMmAll[kk];
      if (z - zlo < options.trimMm - eps || zhi - z < options.trimMm - eps) continue;
      if (!any) p.firstSlice = k;
      any = true;
      p.lastSlice = k;
    }
  }
  for (std::int64_t k = p.firstSlice; k <= p.lastSlice; ++k) {
    const auto kk = static_cast<std::size_t>(k);
    if (maskCount[kk] == 0) continue;
    p.zMm.push_back(p.zMmAll[kk]);
    p.density.push_back(p.densityAll[kk]);
  }
  const std::size_t n = p.density.size();
  p.mean = kNaN;
  p.std = kNaN;
  if (n >= 1) {
    double s = 0;
    for (double v : p.density) s += v;
    p.mean = s / static_cast<double>(n);
    if (n >= 2) {
      double ss = 0;
      for (double v : p.density) ss += (v - p.mean) * (v - p.mean);
      p.std = std::sqrt(ss / static_cast<double>(n - 1));
    }
    double lo2 = *std::min_element(p.density.begin(), p.density.end());
    double hi2 = *std::max_element(p.density.begin(), p.density.end());
    if (hi2 - lo2 < 1e-12) {
      lo2 -= 0.005;
      hi2 += 0.005;
    }
    const int bins = options.histogramBins;
    p.histogramEdges.resize(static_cast<std::size_t>(bins) + 1);
    for (int b = 0; b <= bins; ++b)
      p.histogramEdges[static_cast<std::size_t>(b)] = lo2 + (hi2 - lo2) * b / bins;
    p.histogramCounts.assign(static_cast<std::size_t>(bins), 0.0);
    for (double v : p.density) {
      int b = static_cast<int>(std::floor((v - lo2) / (hi2 - lo2) * bins));
      b = std::clamp(b, 0, bins - 1);
      p.histogramCounts[static_cast<std::size_t>(b)] += 1;
    }
  }
  p.normality = dagostinoPearson(p.density);
  return p;
}

namespace {
void checkRadialOptions(const RadialOptions& options) {
  if (options.supersample < 1 || options.supersample > 64)
    throw InputError("radial profile: supersample must be in 1..64");
  if (!std::isfinite(options.binWidthMm) || !std::isfinite(options.radiusMm) ||
      !std::isfinite(options.coreMarginMm))
    throw InputError("radial profile: bin width, radius and core margin must be finite");
  if (options.axisMm &&
      (!std::isfinite((*options.axisMm)[0]) || !std::isfinite((*options.axisMm)[1])))
    throw InputError("radial profile: the axis must be finite");
}
}  // namespace

ColumnCounts::ColumnCounts(std::int64_t ny, std::int64_t nx)
    : mask(static_cast<std::size_t>(ny * nx), 0.0), solid(mask.size(), 0.0) {}

void accumulateColumnCounts(ColumnCounts& c, std::int64_t z0, const Grid<std::uint8_t>& indicator,
                            const Grid<std::uint8_t>* mask, std::int64_t firstSlice,
                            std::int64_t lastSlice) {
  const Lattice& l = indicator.lattice();
  const std::size_t columns = static_cast<std::size_t>(l.ny() * l.nx());
  if (c.mask.size() != columns) throw InternalError("radial profile: column counts mismatch");
  const std::int64_t k0 = std::max<std::int64_t>(0, firstSlice - z0);
  const std::int64_t k1 = std::min<std::int64_t>(l.nz() - 1, lastSlice - z0);
  for (std::int64_t k = k0; k <= k1; ++k) {
    bool any = false;
    for (std::size_t col = 0; col < columns; ++col) {
      const std::size_t o = static_cast<std::size_t>(k) * columns + col;
      if (mask && (*mask)[o] == 0) continue;
      any = true;
      c.mask[col] += 1;
      c.solid[col] += indicator[o] == 0;
    }
    c.slicesWithMask += any;
  }
}

RadialProfile radialProfile(const Bed& bed, const RadialOptions& options) {
  checkRadialOptions(options);
  const Lattice& l = bed.lattice();
  const std::int64_t nz = l.nz();
  const std::int64_t k0 = std::max<std::int64_t>(0, options.firstSlice);
  const std::int64_t k1 = options.lastSlice < 0 ? nz - 1 : std::min(nz - 1, options.lastSlice);
  ColumnCounts c(l.ny(), l.nx());
  accumulateColumnCounts(c, 0, bed.indicator, bed.mask ? &*bed.mask : nullptr, k0, k1);
  return radialProfile(l, bed.mask.has_value(), c, options);
}

RadialProfile radialProfile(const Lattice& l, bool hasMask, const ColumnCounts& counts,
                            const RadialOptions& options) {
  checkRadialOptions(options);
  const std::int64_t ny = l.ny(), nx = l.nx();
  const double sy = l.spacingMm[1], sx = l.spacingMm[2];
  const std::vector<double>& maskCol = counts.mask;
  const std::vector<double>& solidCol = counts.solid;
  const std::size_t slicesWithMask = counts.slicesWithMask;
  RadialProfile p;
  double total = 0, cx = 0, cy = 0;
  for (std::int64_t j = 0; j < ny; ++j)
    for (std::int64_t i = 0; i < nx; ++i) {
      const double w = maskCol[static_cast<std::size_t>(j * nx + i)];
      const Vec3 c = l.centerMm(0, j, i);
      total += w;
      cx += w * c.x();
      cy += w * c.y();
    }
  if (options.axisMm) {
    p.axisMm = *options.axisMm;
  } else if (hasMask && total > 0) {
    p.axisMm = {cx / total, cy / total};
  } else {
    const Vec3 a = l.centerMm(0, 0, 0), b = l.centerMm(0, ny - 1, nx - 1);
    p.axisMm = {0.5 * (a.x() + b.x()), 0.5 * (a.y() + b.y())};
  }
  if (options.radiusMm > 0) {
    p.radiusMm = options.radiusMm;
  } else if (hasMask && slicesWithMask > 0) {
    const double area = total * sx * sy / static_cast<double>(slicesWithMask);
    p.radiusMm = std::sqrt(area / std::numbers::pi);
  } else {
    p.radiusMm = 0.5 * std::min(static_cast<double>(nx) * sx, static_cast<double>(ny) * sy);
  }
  const double width = options.binWidthMm > 0 ? options.binWidthMm : std::min(sx, sy);
  p.coreRadiusMm =
      p.radiusMm - (options.coreMarginMm > 0 ? options.coreMarginMm : 0.5 * p.radiusMm);
  const int q = options.supersample;
  const double sub = 1.0 / (q * q);
  std::vector<double> area, solid;
  double coreArea = 0, coreSolid = 0, wholeArea = 0, wholeSolid = 0;
  for (std::int64_t j = 0; j < ny; ++j)
    for (std::int64_t i = 0; i < nx; ++i) {
      const std::size_t c = static_cast<std::size_t>(j * nx + i);
      if (maskCol[c] == 0) continue;
      const Vec3 centre = l.centerMm(0, j, i);
      for (int a = 0; a < q; ++a)
        for (int b = 0; b < q; ++b) {
          const double y = centre.y() + ((a + 0.5) / q - 0.5) * sy - p.axisMm[1];
          const double x = centre.x() + ((b + 0.5) / q - 0.5) * sx - p.axisMm[0];
          const double r = std::sqrt(x * x + y * y);
          const auto bin = static_cast<std::size_t>(std::floor(r / width));
          if (bin >= area.size()) {
            area.resize(bin + 1, 0.0);
            solid.resize(bin + 1, 0.0);
          }
          const double am = sub * maskCol[c] * sx * sy, as = sub * solidCol[c] * sx * sy;
          area[bin] += am;
          solid[bin] += as;
          wholeArea += am;
          wholeSolid += as;
          if (r <= p.coreRadiusMm) {
            coreArea += am;
            coreSolid += as;
          }
        }
    }
  for (std::size_t b = 0; b < area.size(); ++b) {
    const double r = (static_cast<double>(b) + 0.5) * width;
    p.rMm.push_back(r);
    p.wallDistanceMm.push_back(p.radiusMm - r);
    p.areaMm2.push_back(area[b]);
    p.density.push_back(area[b] > 0 ? solid[b] / area[b] : kNaN);
  }
  p.coreDensity = coreArea > 0 ? coreSolid / coreArea : kNaN;
  p.wholeDensity = wholeArea > 0 ? wholeSolid / wholeArea : kNaN;
  return p;
}

}  // namespace voxpack::stats
