#pragma once
// A packed-bed fixture that does not depend on the packers: random sequential addition of
// equal non-overlapping spheres inside a cylinder mask (lattice-voxel geometry).
#include <cmath>
#include <vector>

#include "voxpack/core/bed.hpp"
#include "voxpack/core/random.hpp"

namespace voxpack::test {

/// Spheres of radius `sphereVox` (voxels) in a vertical cylinder of radius `columnVox`
/// around the lattice centre; n^3 voxels of `voxelMm`. Mask = voxel centres with r < R.
inline Bed makeSphereBed(std::int64_t n, double columnVox, double sphereVox, double voxelMm,
                         std::uint64_t seed, int attempts = 20000) {
  const Lattice l = Lattice::isotropic(n, n, n, voxelMm);
  Bed bed;
  bed.indicator = Grid<std::uint8_t>(l, 1);
  bed.mask = Grid<std::uint8_t>(l, 0);
  const double c = 0.5 * static_cast<double>(n - 1);
  for (std::int64_t k = 0; k < n; ++k)
    for (std::int64_t j = 0; j < n; ++j)
      for (std::int64_t i = 0; i < n; ++i) {
        const double dx = static_cast<double>(i) - c, dy = static_cast<double>(j) - c;
        (*bed.mask)(k, j, i) = dx * dx + dy * dy < columnVox * columnVox;
      }
  RandomStream rng(seed, 0);
  std::vector<std::array<double, 3>> centres;
  const double room = columnVox - sphereVox;
  for (int a = 0; a < attempts; ++a) {
    const std::array<double, 3> p = {rng.uniform(0.0, static_cast<double>(n - 1)),
                                     c + rng.uniform(-room, room), c + rng.uniform(-room, room)};
    if ((p[1] - c) * (p[1] - c) + (p[2] - c) * (p[2] - c) > room * room) continue;
    bool free = true;
    for (const auto& q : centres) {
      const double d2 = (p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) +
                        (p[2] - q[2]) * (p[2] - q[2]);
      if (d2 < 4.0 * sphereVox * sphereVox) {
        free = false;
        break;
      }
    }
    if (free) centres.push_back(p);
  }
  for (const auto& p : centres) {
    bed.particles.positionMm.push_back(l.centerMm(0, 0, 0) + voxelMm * Vec3(p[2], p[1], p[0]));
    bed.particles.orientation.push_back(Quat::Identity());
    bed.particles.shape.push_back("sphere:d=" + std::to_string(2.0 * sphereVox * voxelMm));
  }
  const auto r = static_cast<std::int64_t>(std::ceil(sphereVox));
  for (const auto& p : centres)
    for (std::int64_t k = std::llround(p[0]) - r; k <= std::llround(p[0]) + r; ++k)
      for (std::int64_t j = std::llround(p[1]) - r; j <= std::llround(p[1]) + r; ++j)
        for (std::int64_t i = std::llround(p[2]) - r; i <= std::llround(p[2]) + r; ++i) {
          if (!l.contains(k, j, i)) continue;
          const double dz = static_cast<double>(k) - p[0], dy = static_cast<double>(j) - p[1],
                       dx = static_cast<double>(i) - p[2];
          if (dx * dx + dy * dy + dz * dz < sphereVox * sphereVox) bed.indicator(k, j, i) = 0;
        }
  return bed;
}

}  // namespace voxpack::test
