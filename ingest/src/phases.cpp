// Phase levels from the histogram, the mean-intensity void fraction and the threshold that
// reproduces it; derivation in docs/ingest.md ("Volume-preserving threshold").
#include "voxpack/ingest/phases.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

#include "voxpack/core/errors.hpp"

namespace voxpack::ingest {
namespace {

std::vector<float> regionValues(const Grid<float>& image, const Grid<std::uint8_t>* region) {
  if (region && region->size() != image.size())
    throw InputError("phase statistics: region and image differ in size");
  std::vector<float> v;
  v.reserve(region ? image.size() / 2 : image.size());
  for (std::size_t n = 0; n < image.size(); ++n)
    if (!region || (*region)[n]) v.push_back(image[n]);
  return v;
}

struct Peak {
  double mean = 0.0, sigma = 0.0;  // in bins
  bool fitted = false;
};

// Gaussian fitted to the outer flank of the peak at `peak` (dir +1: the upper side):
// log h = a + b x + c x^2, weighted by the counts, over [peak - dir 0.5 s0, peak + dir 2.5 s0].
// The outer flank holds only noise: partial-volume voxels lie between the peaks.
Peak fitFlank(const std::vector<double>& h, int peak, int dir) {
  const int nb = static_cast<int>(h.size());
  const double hmax = h[static_cast<std::size_t>(peak)];
  double half = 0.0;
  for (int b = peak; b >= 0 && b < nb; b += dir) {
    if (h[static_cast<std::size_t>(b)] < 0.5 * hmax) {
      const double hp = h[static_cast<std::size_t>(b - dir)], hb = h[static_cast<std::size_t>(b)];
      half = std::abs(b - peak) - (0.5 * hmax - hb) / std::max(1e-300, hp - hb);
      break;
    }
  }
  Peak p;
  p.mean = peak;
  p.sigma = std::max(0.3, half / std::sqrt(2.0 * std::log(2.0)));
  if (half < 1.5) return p;  // a spike: too narrow for a fit
  const int from = static_cast<int>(std::floor(peak - dir * 0.5 * p.sigma));
  const int to = static_cast<int>(std::ceil(peak + dir * 2.5 * p.sigma));
  double s[5] = {0, 0, 0, 0, 0}, t[3] = {0, 0, 0};
  for (int b = std::min(from, to); b <= std::max(from, to); ++b) {
    if (b < 0 || b >= nb) continue;
    const double y = h[static_cast<std::size_t>(b)];
    if (y < 0.02 * hmax || y <= 0) continue;
    const double x = b - peak, ly = std::log(y);
    double xp = y;
    for (int q = 0; q < 5; ++q) {
      s[q] += xp;
      if (q < 3) t[q] += xp * ly;
      xp *= x;
    }
  }
  // Normal equations of the weighted parabola fit.
  const double m[3][3] = {{s[0], s[1], s[2]}, {s[1], s[2], s[3]}, {s[2], s[3], s[4]}};
  const double det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
                     m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                     m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
  if (!(std::abs(det) > 1e-300)) return p;
  auto solve = [&](int col) {
    double a[3][3];
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) a[r][c] = c == col ? t[r] : m[r][c];
    return (a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) -
            a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
            a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0])) /
           det;
  };
  const double bq = solve(1), cq = solve(2);
  if (!(cq < 0)) return p;
  const double mu = -bq / (2 * cq), sg = std::sqrt(-1.0 / (2 * cq));
  if (!(std::abs(mu) < 3 * p.sigma + 2) || !(sg > 0.2 * p.sigma && sg < 5 * p.sigma)) return p;
  p.mean = peak + mu;
  p.sigma = sg;
  p.fitted = true;
  return p;
}

// The mean of a Gaussian of known width `s` (bins) fitted to the outer flank of the peak at
// `peak` (dir +1: the upper side), from the peak out to 2.5 s: log h + x^2 / 2 s^2 is linear
// in x with slope mu / s^2 (x from the peak bin), weighted by the counts. Only the outer
// flank: the partial-volume voxels lie between the peaks. Returns NaN when no fit.
double fitFlankMean(const std::vector<double>& h, int peak, int dir, double s) {
  const int nb = static_cast<int>(h.size());
  const double hmax = h[static_cast<std::size_t>(peak)];
  // From 1 sigma out: nearer the peak, voxels a little inside the blurred interfaces
  // still pull the fit (measured: 21 and 9 units low at 10 and 20 voxels per d on a
  // 1005 level from the peak out, 2 and 6 from 1 sigma out).
  const int from = peak + dir * static_cast<int>(std::floor(1.0 * s));
  const int to = peak + dir * static_cast<int>(std::ceil(3.5 * s));
  double sw = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (int b = from; dir > 0 ? b <= to : b >= to; b += dir) {
    if (b < 0 || b >= nb) break;
    const double c = h[static_cast<std::size_t>(b)];
    if (c <= 0 || c < 0.02 * hmax) continue;
    const double x = b - peak, y = std::log(c) + x * x / (2.0 * s * s);
    sw += c;
    sx += c * x;
    sy += c * y;
    sxx += c * x * x;
    sxy += c * x * y;
  }
  const double det = sw * sxx - sx * sx;
  if (!(sw > 0) || !(std::abs(det) > 1e-12 * sw * sw))
    return std::numeric_limits<double>::quiet_NaN();
  const double mu = (sw * sxy - sx * sy) / det * s * s;
  if (!(std::abs(mu) < 2.0 * s + 2.0)) return std::numeric_limits<double>::quiet_NaN();
  return peak + mu;
}

// Inverse of ricianMean in a (bisection; the mean is increasing in a).
double ricianSignal(double mean, double sigma) {
  if (!(sigma > 0)) return mean;
  if (mean <= ricianMean(0.0, sigma)) return 0.0;
  double lo = 0.0, hi = mean;
  for (int it = 0; it < 80; ++it) {
    const double mid = 0.5 * (lo + hi);
    (ricianMean(mid, sigma) < mean ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

double normalCdf(double x) { return 0.5 * std::erfc(-x / std::numbers::sqrt2); }

}  // namespace

double ricianMean(double a, double sigma) {
  if (!(sigma > 0)) return std::abs(a);
  const double x = a * a / (4.0 * sigma * sigma);          // argument of the Bessel functions
  if (x > 200.0) return std::sqrt(a * a + sigma * sigma);  // asymptote, error ~ sigma^4 / a^3
  // sigma sqrt(pi/2) L_{1/2}(-a^2 / 2 sigma^2), Laguerre via exponentially scaled Bessels.
  const double e = std::exp(-x);
  return sigma * std::sqrt(std::numbers::pi / 2.0) *
         ((1.0 + 2.0 * x) * e * std::cyl_bessel_i(0.0, x) +
          2.0 * x * e * std::cyl_bessel_i(1.0, x));
}

PhaseLevels fitPhaseLevels(const Grid<float>& image, const Grid<std::uint8_t>* region,
                           bool voidBright, NoiseModel model, const PhaseHints* hints) {
  PhaseLevels L;
  L.model = model;
  std::vector<float> v = regionValues(image, region);
  if (v.size() < 64) {
    L.note = "too few voxels for a histogram";
    return L;
  }
  const std::size_t n = v.size();
  // Range from the 0.01 % and 99.99 % quantiles: single outliers must not stretch the bins.
  auto quantile = [&](double q) {
    const auto k = static_cast<std::size_t>(q * static_cast<double>(n - 1));
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
    return static_cast<double>(v[k]);
  };
  double lo = quantile(1e-4), hi = quantile(1.0 - 1e-4);
  if (!(hi > lo)) {
    L.note = "one grey level: a single phase";
    return L;
  }
  const double pad = 0.02 * (hi - lo);
  lo -= pad;
  hi += pad;
  constexpr int kBins = 1024;
  const double width = (hi - lo) / kBins;
  std::vector<double> h(kBins, 0.0);
  for (float x : v) {
    const double b = (x - lo) / width;
    if (b >= 0 && b < kBins) h[static_cast<std::size_t>(b)] += 1.0;
  }
  // Otsu's split separates the two peaks (any cut between them will do here).
  double total = 0, sumAll = 0;
  for (int b = 0; b < kBins; ++b) {
    total += h[static_cast<std::size_t>(b)];
    sumAll += b * h[static_cast<std::size_t>(b)];
  }
  double w0 = 0, s0 = 0, best = -1;
  int split = kBins / 2;
  for (int b = 0; b < kBins - 1; ++b) {
    w0 += h[static_cast<std::size_t>(b)];
    s0 += b * h[static_cast<std::size_t>(b)];
    const double w1 = total - w0;
    if (w0 <= 0 || w1 <= 0) continue;
    const double d = s0 / w0 - (sumAll - s0) / w1;
    if (w0 * w1 * d * d > best) {
      best = w0 * w1 * d * d;
      split = b;
    }
  }
  // Peaks on a lightly smoothed histogram, fits on the raw counts.
  std::vector<double> sm(kBins, 0.0);
  for (int b = 0; b < kBins; ++b) {
    double acc = 0, wsum = 0;
    for (int t = -2; t <= 2; ++t) {
      const int q = b + t;
      if (q < 0 || q >= kBins) continue;
      const double w = 3 - std::abs(t);
      acc += w * h[static_cast<std::size_t>(q)];
      wsum += w;
    }
    sm[static_cast<std::size_t>(b)] = acc / wsum;
  }
  const int darkBin =
      static_cast<int>(std::max_element(sm.begin(), sm.begin() + split + 1) - sm.begin());
  const int brightBin =
      static_cast<int>(std::max_element(sm.begin() + split + 1, sm.end()) - sm.begin());
  const Peak bright = fitFlank(h, brightBin, +1);
  auto toValue = [&](double bin) { return lo + (bin + 0.5) * width; };
  // A spike (noise-free image): its level is the mean of the values within one bin.
  auto spikeMean = [&](int bin) {
    const double a = toValue(bin) - width, b = toValue(bin) + width;
    double s = 0;
    std::size_t c = 0;
    for (float x : v)
      if (x >= a && x <= b) {
        s += x;
        ++c;
      }
    return c ? s / static_cast<double>(c) : toValue(bin);
  };
  double sigma = bright.sigma * width;
  double brightLevel = bright.fitted ? toValue(bright.mean) : spikeMean(brightBin);
  bool rayleighDark = false;  // MRI: the dark phase carries no signal
  double darkLevel = 0, darkSignal = 0;
  double brightSignal = brightLevel;
  if (model == NoiseModel::Rician) {
    brightSignal = ricianSignal(brightLevel, sigma);
    // No signal in the dark phase gives a Rayleigh peak: its mode is sigma, its mean
    // sigma sqrt(pi/2). The mode (vertex of a log-parabola over 0.6..1.5 x the peak bin)
    // is the purer noise estimate: the bright flank also carries any left-over bias field.
    if (toValue(darkBin) < 2.0 * sigma) {
      rayleighDark = true;
      const double m0 = toValue(darkBin);
      double s4[5] = {0, 0, 0, 0, 0}, t3[3] = {0, 0, 0};
      for (int b = 0; b < kBins; ++b) {
        const double x = toValue(b), y = h[static_cast<std::size_t>(b)];
        if (x < 0.6 * m0 || x > 1.5 * m0 || y <= 0) continue;
        const double u = (x - m0) / m0, ly = std::log(y);
        double up = y;
        for (int q = 0; q < 5; ++q) {
          s4[q] += up;
          if (q < 3) t3[q] += up * ly;
          up *= u;
        }
      }
      const double a[3][3] = {{s4[0], s4[1], s4[2]}, {s4[1], s4[2], s4[3]}, {s4[2], s4[3], s4[4]}};
      auto det3 = [](const double mm[3][3]) {
        return mm[0][0] * (mm[1][1] * mm[2][2] - mm[1][2] * mm[2][1]) -
               mm[0][1] * (mm[1][0] * mm[2][2] - mm[1][2] * mm[2][0]) +
               mm[0][2] * (mm[1][0] * mm[2][1] - mm[1][1] * mm[2][0]);
      };
      const double d = det3(a);
      double mode = m0;
      if (std::abs(d) > 1e-300) {
        double bq[3][3], cq[3][3];
        for (int r = 0; r < 3; ++r)
          for (int c = 0; c < 3; ++c) {
            bq[r][c] = c == 1 ? t3[r] : a[r][c];
            cq[r][c] = c == 2 ? t3[r] : a[r][c];
          }
        const double b1 = det3(bq) / d, c2 = det3(cq) / d;
        if (c2 < 0 && std::abs(-b1 / (2 * c2)) < 0.5) mode = m0 * (1.0 - b1 / (2 * c2));
      }
      if (mode > 0.3 * sigma && mode < 2.0 * sigma) sigma = mode;
      brightSignal = ricianSignal(brightLevel, sigma);
      darkSignal = 0.0;
      darkLevel = ricianMean(0.0, sigma);
    } else {
      const Peak dark = fitFlank(h, darkBin, -1);
      darkLevel = dark.fitted ? toValue(dark.mean) : spikeMean(darkBin);
      darkSignal = ricianSignal(darkLevel, sigma);
    }
  } else {
    const Peak dark = fitFlank(h, darkBin, -1);
    darkLevel = dark.fitted ? toValue(dark.mean) : spikeMean(darkBin);
    darkSignal = darkLevel;
  }
  // A noise sigma measured elsewhere (deep inside a phase): the flanks' own widths read
  // high under blur (partial-volume voxels reach the peaks), and so do the levels fitted
  // with them. The levels: the phases' interior means when known, else the peaks' means
  // fitted with the width held.
  if (hints && hints->noiseSigma > 0.0) {
    sigma = hints->noiseSigma;
    const double sb = sigma / width;
    const double brightHint = voidBright ? hints->voidMean : hints->solidMean;
    const double darkHint = voidBright ? hints->solidMean : hints->voidMean;
    auto level = [&](double hint, int bin, int dir, double fallback) {
      if (std::isfinite(hint)) return hint;
      const double m = fitFlankMean(h, bin, dir, sb);
      return std::isfinite(m) ? toValue(m) : fallback;
    };
    brightLevel = level(brightHint, brightBin, +1, brightLevel);
    if (model == NoiseModel::Rician) {
      brightSignal = ricianSignal(brightLevel, sigma);
      if (rayleighDark) {
        darkLevel = ricianMean(0.0, sigma);
      } else {
        darkLevel = level(darkHint, darkBin, -1, darkLevel);
        darkSignal = ricianSignal(darkLevel, sigma);
      }
    } else {
      brightSignal = brightLevel;
      darkLevel = darkSignal = level(darkHint, darkBin, -1, darkLevel);
    }
  }
  L.noiseSigma = sigma;
  if (voidBright) {
    L.voidLevel = brightLevel;
    L.voidSignal = brightSignal;
    L.solidLevel = darkLevel;
    L.solidSignal = darkSignal;
  } else {
    L.voidLevel = darkLevel;
    L.voidSignal = darkSignal;
    L.solidLevel = brightLevel;
    L.solidSignal = brightSignal;
  }
  // Each phase must hold a visible share of the voxels near its level.
  auto near = [&](double level) {
    std::size_t c = 0;
    const double r = std::max(sigma, width);
    for (float x : v) c += std::abs(x - level) <= r;
    return static_cast<double>(c) / static_cast<double>(n);
  };
  const double gap = std::abs(brightLevel - darkLevel);
  L.clear =
      gap >= 3.0 * std::max(sigma, width) && near(brightLevel) >= 0.005 && near(darkLevel) >= 0.005;
  L.note = L.clear ? "two phases, " + std::string(bright.fitted ? "fitted" : "spike") + " peaks"
                   : "phases not clear (peaks " + std::to_string(gap / std::max(sigma, width)) +
                         " noise sigma apart, or one phase is rare)";
  return L;
}

InteriorStats phaseInteriorStats(const Grid<float>& image, const Grid<std::uint8_t>& indicator,
                                 const Grid<std::uint8_t>* region, std::uint8_t phase,
                                 int onlyDepth) {
  const Lattice& l = image.lattice();
  const std::int64_t nz = l.nz(), ny = l.ny(), nx = l.nx();
  InteriorStats st;
  const std::vector<int> depths =
      onlyDepth > 0 ? std::vector<int>{onlyDepth} : std::vector<int>{3, 2};
  for (int depth : depths) {
    // (k, j, i) lies deep in `phase` when the phase holds along x, y and z within depth.
    auto deep = [&](std::int64_t k, std::int64_t j, std::int64_t i) {
      if (k < depth || j < depth || i < depth || k >= nz - depth || j >= ny - depth ||
          i >= nx - depth)
        return false;
      for (int d = -depth; d <= depth; ++d)
        if (indicator(k + d, j, i) != phase || indicator(k, j + d, i) != phase ||
            indicator(k, j, i + d) != phase)
          return false;
      return true;
    };
    std::vector<double> diff;
    double sum = 0;
    for (std::int64_t k = 0; k < nz; ++k)
      for (std::int64_t j = 0; j < ny; ++j)
        for (std::int64_t i = 0; i + 1 < nx; i += 2) {  // disjoint pairs: independent samples
          const std::size_t o = l.offset(k, j, i);
          if (region && (!(*region)[o] || !(*region)[o + 1])) continue;
          if (!deep(k, j, i) || !deep(k, j, i + 1)) continue;
          diff.push_back(static_cast<double>(image[o + 1]) - image[o]);
          sum += static_cast<double>(image[o]) + image[o + 1];
        }
    if (diff.size() < 2000) continue;
    st.pairs = diff.size();
    st.depth = depth;
    st.mean = sum / (2.0 * static_cast<double>(diff.size()));
    // Robust sd of the difference (1.4826 MAD about 0), / sqrt 2 for one voxel.
    for (double& d : diff) d = std::abs(d);
    const auto mid = diff.begin() + static_cast<std::ptrdiff_t>(diff.size() / 2);
    std::nth_element(diff.begin(), mid, diff.end());
    st.sigma = 1.4826 * *mid / std::numbers::sqrt2;
    return st;
  }
  return st;
}

double meanEstimatorEdgeBiasVoxels(const PhaseLevels& L, double blur) {
  if (L.model == NoiseModel::Gaussian || !(blur > 0.02) || !(L.noiseSigma > 0)) return 0.0;
  const double gs = ricianMean(L.solidSignal, L.noiseSigma);
  const double gv = ricianMean(L.voidSignal, L.noiseSigma);
  if (!(std::abs(gv - gs) > 0)) return 0.0;
  // Across the interface the void share is f = Phi(x / blur); the estimator reads
  // (g(A_s + f (A_v - A_s)) - g(A_s)) / (g(A_v) - g(A_s)). Trapezoid rule over +-7 blur.
  constexpr int kSteps = 2800;
  const double x0 = -7.0 * blur, dx = 14.0 * blur / kSteps;
  double acc = 0;
  for (int s = 0; s <= kSteps; ++s) {
    const double f = normalCdf((x0 + s * dx) / blur);
    const double a = L.solidSignal + f * (L.voidSignal - L.solidSignal);
    const double est = (ricianMean(a, L.noiseSigma) - gs) / (gv - gs);
    acc += (s == 0 || s == kSteps ? 0.5 : 1.0) * (est - f);
  }
  return acc * dx;
}

double surfaceDensityPerVoxel(const Grid<std::uint8_t>& ind, const Grid<std::uint8_t>* region) {
  const Lattice& l = ind.lattice();
  double changes[3] = {0, 0, 0}, pairs[3] = {0, 0, 0};
  for (std::int64_t k = 0; k < l.nz(); ++k)
    for (std::int64_t j = 0; j < l.ny(); ++j)
      for (std::int64_t i = 0; i < l.nx(); ++i) {
        const std::size_t o = l.offset(k, j, i);
        if (region && !(*region)[o]) continue;
        const std::int64_t nb[3][3] = {{k + 1, j, i}, {k, j + 1, i}, {k, j, i + 1}};
        for (int a = 0; a < 3; ++a) {
          if (!l.contains(nb[a][0], nb[a][1], nb[a][2])) continue;
          const std::size_t q = l.offset(nb[a][0], nb[a][1], nb[a][2]);
          if (region && !(*region)[q]) continue;
          pairs[a] += 1;
          changes[a] += ind[o] != ind[q];
        }
      }
  double pl = 0;
  int axes = 0;
  for (int a = 0; a < 3; ++a)
    if (pairs[a] > 0) {
      pl += changes[a] / pairs[a];
      ++axes;
    }
  return axes ? 2.0 * pl / axes : 0.0;
}

MeanVoidFraction meanVoidFraction(const Grid<float>& image, const Grid<std::uint8_t>* region,
                                  const PhaseLevels& L, double blurVoxels,
                                  const Grid<std::uint8_t>& indicator) {
  MeanVoidFraction m;
  double sum = 0;
  for (std::size_t n = 0; n < image.size(); ++n)
    if (!region || (*region)[n]) {
      sum += image[n];
      ++m.voxels;
    }
  if (m.voxels == 0) throw InputError("mean void fraction: empty region");
  m.meanIntensity = sum / static_cast<double>(m.voxels);
  m.raw = (m.meanIntensity - L.solidLevel) / (L.voidLevel - L.solidLevel);
  m.edgeBiasVoxels = meanEstimatorEdgeBiasVoxels(L, blurVoxels);
  m.surfacePerVoxel = m.edgeBiasVoxels != 0.0 ? surfaceDensityPerVoxel(indicator, region) : 0.0;
  m.phi = std::clamp(m.raw - m.edgeBiasVoxels * m.surfacePerVoxel, 0.0, 1.0);
  return m;
}

double volumeThreshold(const Grid<float>& image, const Grid<std::uint8_t>* region, double phi,
                       bool voidBright) {
  std::vector<float> v = regionValues(image, region);
  if (v.empty()) throw InputError("volume threshold: empty region");
  const std::size_t n = v.size();
  const auto nv =
      static_cast<std::size_t>(std::llround(std::clamp(phi, 0.0, 1.0) * static_cast<double>(n)));
  const float lo = *std::min_element(v.begin(), v.end());
  const float hi = *std::max_element(v.begin(), v.end());
  // The k smallest values form the lower class: solid when the void is bright.
  const std::size_t k = voidBright ? n - nv : nv;
  if (k == 0) return static_cast<double>(lo) - 1.0;
  if (k == n) return hi;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k - 1), v.end());
  const double a = v[k - 1];
  const double b = *std::min_element(v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return a == b ? a : 0.5 * (a + b);
}

double regionVoidFraction(const Grid<std::uint8_t>& ind, const Grid<std::uint8_t>* region) {
  std::size_t in = 0, vo = 0;
  for (std::size_t n = 0; n < ind.size(); ++n)
    if (!region || (*region)[n]) {
      ++in;
      vo += ind[n] != 0;
    }
  return in ? static_cast<double>(vo) / static_cast<double>(in)
            : std::numeric_limits<double>::quiet_NaN();
}

}  // namespace voxpack::ingest
