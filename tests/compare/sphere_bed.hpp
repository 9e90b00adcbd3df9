#pragma once
// Test fixture: a cylinder column with randomly placed non-overlapping spheres, digitised
// at a chosen voxel size (a stand-in for packed and imaged beds in compare tests).
#include <cmath>
#include <filesystem>
#include <vector>

#include "voxpack/core/bed.hpp"
#include "voxpack/core/bed_file.hpp"
#include "voxpack/core/random.hpp"

namespace voxpack::test {

/// Options of sphereBed.
struct SphereBedOptions {
  double columnDiameterMm = 16.0;  ///< container diameter
  double heightMm = 16.0;          ///< container height
  double sphereDiameterMm = 3.0;   ///< particle diameter
  double voxelMm = 0.5;            ///< voxel size
  int attempts = 400;              ///< random sequential addition attempts
  std::uint64_t seed = 1;          ///< placement seed
};

/// Random sequential addition of spheres in a cylinder; voxels inside a sphere are solid.
inline Bed sphereBed(const SphereBedOptions& o) {
  const double R = 0.5 * o.columnDiameterMm, r = 0.5 * o.sphereDiameterMm;
  std::vector<Vec3> centres;
  RandomStream rng(o.seed, 0);
  for (int a = 0; a < o.attempts; ++a) {
    const double rho = (R - r) * std::sqrt(rng.uniform()), t = rng.uniform(0, 2 * M_PI);
    const Vec3 c(rho * std::cos(t), rho * std::sin(t), rng.uniform(r, o.heightMm - r));
    bool ok = true;
    for (const auto& q : centres) ok = ok && (q - c).norm() >= 2 * r;
    if (ok) centres.push_back(c);
  }
  const auto nxy = static_cast<std::int64_t>(std::ceil(o.columnDiameterMm / o.voxelMm));
  const auto nz = static_cast<std::int64_t>(std::ceil(o.heightMm / o.voxelMm));
  const double half = 0.5 * static_cast<double>(nxy - 1) * o.voxelMm;
  Bed bed;
  const Lattice l =
      Lattice::isotropic(nz, nxy, nxy, o.voxelMm, Vec3(-half, -half, 0.5 * o.voxelMm));
  bed.indicator = Grid<std::uint8_t>(l, 1);
  bed.mask = Grid<std::uint8_t>(l, 0);
  for (std::int64_t k = 0; k < nz; ++k)
    for (std::int64_t j = 0; j < nxy; ++j)
      for (std::int64_t i = 0; i < nxy; ++i) {
        const Vec3 p = l.centerMm(k, j, i);
        if (p.x() * p.x() + p.y() * p.y() > R * R) continue;
        (*bed.mask)(k, j, i) = 1;
        for (const auto& q : centres)
          if ((q - p).squaredNorm() <= r * r) {
            bed.indicator(k, j, i) = 0;
            break;
          }
      }
  for (const auto& q : centres) {
    bed.particles.positionMm.push_back(q);
    bed.particles.orientation.push_back(Quat::Identity());
    bed.particles.shape.push_back("sphere:d=" + std::to_string(o.sphereDiameterMm));
  }
  bed.provenance = {{"command_line", "test sphereBed"}, {"seed", o.seed}};
  return bed;
}

}  // namespace voxpack::test
