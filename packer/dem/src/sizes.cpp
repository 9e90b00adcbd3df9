// Continuous size distributions of a pour: truncated log-normal and sieve tables, one
// diameter per particle from its own random stream (docs/dem.md, "Size distributions").
#include <algorithm>
#include <cmath>
#include <sstream>

#include "voxpack/core/errors.hpp"
#include "voxpack/packer/dem.hpp"

namespace voxpack::packer::dem {
namespace {

// Standard normal CDF.
double phi(double z) { return 0.5 * std::erfc(-z / std::sqrt(2.0)); }

// The z in [lo, hi] with phi(z) = p, by bisection: monotone, no tables, the same bits on
// every machine that has the same erfc.
double phiInverse(double p, double lo, double hi) {
  for (int it = 0; it < 100 && hi - lo > 1e-14; ++it) {
    const double mid = 0.5 * (lo + hi);
    (phi(mid) < p ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

std::string num(double v) {
  std::ostringstream o;
  o << v;
  return o.str();
}

}  // namespace

void checkSizeDistribution(const SizeDistribution& d, const std::string& where) {
  using K = SizeDistribution::Kind;
  if (d.kind == K::kNone) return;
  if (d.kind == K::kLogNormal) {
    if (!(d.medianMm > 0) || !std::isfinite(d.medianMm))
      throw InputError(where + ": log-normal median must be > 0 mm (got " + num(d.medianMm) + ")");
    if (!(d.geometricStd >= 1) || !std::isfinite(d.geometricStd))
      throw InputError(where + ": log-normal geometric standard deviation must be >= 1 (got " +
                       num(d.geometricStd) + ")");
    if (!(d.minMm > 0) || !(d.maxMm >= d.minMm) || !std::isfinite(d.maxMm))
      throw InputError(where + ": log-normal range needs 0 < min <= max (got " + num(d.minMm) +
                       ", " + num(d.maxMm) + ")");
    if (d.geometricStd == 1 && !(d.medianMm >= d.minMm && d.medianMm <= d.maxMm))
      throw InputError(where + ": with geometric standard deviation 1 the median must lie in " +
                       "[min, max]");
    return;
  }
  const std::size_t n = d.massFractions.size();
  if (n == 0 || d.edgesMm.size() != n + 1)
    throw InputError(where + ": a sieve table needs n + 1 edges for n mass fractions (got " +
                     std::to_string(d.edgesMm.size()) + " edges, " + std::to_string(n) +
                     " fractions)");
  double total = 0;
  for (std::size_t k = 0; k < n; ++k) {
    if (!(d.edgesMm[k] > 0) || !(d.edgesMm[k + 1] > d.edgesMm[k]) ||
        !std::isfinite(d.edgesMm[k + 1]))
      throw InputError(where + ": sieve edges must be > 0 and increasing (mm)");
    if (!(d.massFractions[k] >= 0) || !std::isfinite(d.massFractions[k]))
      throw InputError(where + ": sieve mass fractions must be >= 0");
    total += d.massFractions[k];
  }
  if (!(total > 0)) throw InputError(where + ": sieve mass fractions sum to 0");
}

double drawDiameterMm(const SizeDistribution& d, RandomStream& rs) {
  if (d.kind == SizeDistribution::Kind::kLogNormal) {
    const double u = rs.uniform();
    if (d.geometricStd == 1) return d.medianMm;
    const double ls = std::log(d.geometricStd);
    const double zLo = std::log(d.minMm / d.medianMm) / ls;
    const double zHi = std::log(d.maxMm / d.medianMm) / ls;
    const double pLo = phi(zLo), pHi = phi(zHi);
    const double z = phiInverse(pLo + u * (pHi - pLo), zLo, zHi);
    return std::clamp(d.medianMm * std::exp(z * ls), d.minMm, d.maxMm);
  }
  if (d.kind == SizeDistribution::Kind::kSieve) {
    // A bin's share by number is its mass fraction over the mean d^3 in it (uniform in d:
    // (b^4 - a^4) / (4 (b - a))).
    const double u1 = rs.uniform(), u2 = rs.uniform();
    const std::size_t n = d.massFractions.size();
    std::vector<double> cum(n);
    double total = 0;
    for (std::size_t k = 0; k < n; ++k) {
      const double a = d.edgesMm[k], b = d.edgesMm[k + 1];
      const double meanCube = (b * b * b * b - a * a * a * a) / (4 * (b - a));
      total += d.massFractions[k] / meanCube;
      cum[k] = total;
    }
    const auto bin = static_cast<std::size_t>(std::min<std::ptrdiff_t>(
        static_cast<std::ptrdiff_t>(n) - 1,
        std::upper_bound(cum.begin(), cum.end(), u1 * total) - cum.begin()));
    return d.edgesMm[bin] + u2 * (d.edgesMm[bin + 1] - d.edgesMm[bin]);
  }
  throw InternalError("drawDiameterMm: no distribution");
}

nlohmann::json toJson(const SizeDistribution& d) {
  switch (d.kind) {
    case SizeDistribution::Kind::kNone:
      return nullptr;
    case SizeDistribution::Kind::kLogNormal:
      return {{"kind", "lognormal"},
              {"median_mm", d.medianMm},
              {"geometric_std", d.geometricStd},
              {"min_mm", d.minMm},
              {"max_mm", d.maxMm}};
    case SizeDistribution::Kind::kSieve:
      return {{"kind", "sieve"}, {"edges_mm", d.edgesMm}, {"mass_fractions", d.massFractions}};
  }
  return nullptr;
}

}  // namespace voxpack::packer::dem
