#pragma once
// Synthetic media with analytic statistics, for the stats tests.
#include <cmath>
#include <cstdint>
#include <numbers>

#include "voxpack/core/bed.hpp"
#include "voxpack/core/random.hpp"

namespace voxpack::test {

/// Boolean (overlapping) spheres of radius `radius` voxels at reduced density `eta` in an
/// n³ unit-spacing lattice; indicator 1 = void. Centres are uniform in a box grown by the
/// radius on every side, so the window sees a stationary medium: at lattice points S2 is
/// exactly the continuous exp[−η(1 + 3r/4R − r³/16R³)] in expectation.
inline Grid<std::uint8_t> booleanSpheres(std::int64_t n, double radius, double eta,
                                         std::uint64_t seed) {
  Grid<std::uint8_t> g(Lattice::isotropic(n, n, n, 1.0), 1);
  const double lo = -radius, hi = static_cast<double>(n - 1) + radius;
  const double volume = std::pow(hi - lo, 3);
  const double rho = eta / (4.0 / 3.0 * std::numbers::pi * radius * radius * radius);
  const auto count = static_cast<std::int64_t>(std::llround(rho * volume));
  RandomStream rng(seed, 0);
  for (std::int64_t s = 0; s < count; ++s) {
    const double cx = rng.uniform(lo, hi), cy = rng.uniform(lo, hi), cz = rng.uniform(lo, hi);
    const auto k0 = std::max<std::int64_t>(0, static_cast<std::int64_t>(std::ceil(cz - radius)));
    const auto k1 =
        std::min<std::int64_t>(n - 1, static_cast<std::int64_t>(std::floor(cz + radius)));
    const auto j0 = std::max<std::int64_t>(0, static_cast<std::int64_t>(std::ceil(cy - radius)));
    const auto j1 =
        std::min<std::int64_t>(n - 1, static_cast<std::int64_t>(std::floor(cy + radius)));
    const auto i0 = std::max<std::int64_t>(0, static_cast<std::int64_t>(std::ceil(cx - radius)));
    const auto i1 =
        std::min<std::int64_t>(n - 1, static_cast<std::int64_t>(std::floor(cx + radius)));
    for (std::int64_t k = k0; k <= k1; ++k)
      for (std::int64_t j = j0; j <= j1; ++j)
        for (std::int64_t i = i0; i <= i1; ++i) {
          const double dx = static_cast<double>(i) - cx, dy = static_cast<double>(j) - cy,
                       dz = static_cast<double>(k) - cz;
          if (dx * dx + dy * dy + dz * dz <= radius * radius) g(k, j, i) = 0;
        }
  }
  return g;
}

/// Analytic S2 of the void phase of Boolean spheres (Torquato 2002).
inline double booleanS2(double r, double radius, double eta) {
  if (r >= 2 * radius) return std::exp(-2 * eta);
  const double x = r / radius;
  return std::exp(-eta * (1 + 0.75 * x - x * x * x / 16));
}

/// A bed over `grid` with no mask.
inline Bed bedOf(Grid<std::uint8_t> grid) {
  Bed b;
  b.indicator = std::move(grid);
  return b;
}

}  // namespace voxpack::test
