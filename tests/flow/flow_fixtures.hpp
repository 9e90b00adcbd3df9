#pragma once
// Small lattices with analytic flows: slit, tube, simple-cubic sphere array.
#include <cmath>
#include <cstdint>
#include <numbers>

#include "voxpack/core/bed.hpp"
#include "voxpack/flow/lbm.hpp"

namespace voxpack::test {

/// A slit of `width` fluid cells across y (walls at the box faces), periodic in z and x.
inline flow::LbmDomain slitDomain(std::int64_t width) {
  flow::LbmDomain d;
  d.dims = {1, width, 1};
  d.fluid.assign(static_cast<std::size_t>(width), 1);
  d.periodic = {true, false, true};
  return d;
}

/// Fluid where the cell centre lies within `radius` of the cross-section centre;
/// `distance`: with the exact signed distance radius - r (interpolated bounce-back).
inline flow::LbmDomain tubeDomain(std::int64_t box, double radius, bool distance = false) {
  flow::LbmDomain d;
  d.dims = {1, box, box};
  d.fluid.assign(static_cast<std::size_t>(box * box), 0);
  if (distance) d.signedDistance.assign(d.fluid.size(), 0.0f);
  const double c = 0.5 * static_cast<double>(box - 1);
  for (std::int64_t j = 0; j < box; ++j)
    for (std::int64_t i = 0; i < box; ++i) {
      const double r = std::hypot(static_cast<double>(j) - c, static_cast<double>(i) - c);
      d.fluid[static_cast<std::size_t>(j * box + i)] = r < radius ? 1 : 0;
      if (distance)
        d.signedDistance[static_cast<std::size_t>(j * box + i)] = static_cast<float>(radius - r);
    }
  d.periodic = {true, false, false};
  return d;
}

/// Solid cells of a sphere of `radius` centred in a periodic cube of side `n`.
inline std::size_t sphereCells(std::int64_t n, double radius, flow::LbmDomain* out) {
  const double c = 0.5 * static_cast<double>(n - 1);
  std::size_t solid = 0;
  if (out) {
    out->dims = {n, n, n};
    out->fluid.assign(static_cast<std::size_t>(n * n * n), 1);
    out->periodic = {true, true, true};
  }
  for (std::int64_t k = 0; k < n; ++k)
    for (std::int64_t j = 0; j < n; ++j)
      for (std::int64_t i = 0; i < n; ++i) {
        const double dz = static_cast<double>(k) - c, dy = static_cast<double>(j) - c,
                     dx = static_cast<double>(i) - c;
        if (dx * dx + dy * dy + dz * dz < radius * radius) {
          ++solid;
          if (out) out->fluid[static_cast<std::size_t>((k * n + j) * n + i)] = 0;
        }
      }
  return solid;
}

/// A simple-cubic unit cell of about `perD` voxels per sphere diameter at solid fraction
/// `phi`: for sides n around perD (pi / (6 phi))^(1/3), the radius whose solid voxel
/// count is closest to phi n^3; the side with the closest digitised fraction wins
/// (voxel counts jump by whole symmetric shells). Returns the digitised solid fraction.
inline double scUnitCell(double phi, double perD, flow::LbmDomain& d, double* diameter) {
  const std::int64_t n0 =
      static_cast<std::int64_t>(std::lround(perD * std::cbrt(std::numbers::pi / (6.0 * phi))));
  std::int64_t bestN = n0;
  double bestR = 0, bestErr = 1e300;
  for (std::int64_t n = n0 - 1; n <= n0 + 1; ++n) {
    const double target = phi * static_cast<double>(n * n * n);
    double lo = 0.1 * static_cast<double>(n), hi = 0.6 * static_cast<double>(n);
    for (int it = 0; it < 60; ++it) {
      const double mid = 0.5 * (lo + hi);
      if (static_cast<double>(sphereCells(n, mid, nullptr)) < target)
        lo = mid;
      else
        hi = mid;
    }
    for (double r : {lo, hi}) {
      const double err =
          std::abs(static_cast<double>(sphereCells(n, r, nullptr)) - target) / target;
      if (err < bestErr) bestErr = err, bestN = n, bestR = r;
    }
  }
  const std::size_t solid = sphereCells(bestN, bestR, &d);
  const double phiDigital = static_cast<double>(solid) / static_cast<double>(bestN * bestN * bestN);
  // Diameter of the sphere with the digitised volume (the bounce-back wall sits halfway).
  *diameter = std::cbrt(6.0 * static_cast<double>(solid) / std::numbers::pi);
  return phiDigital;
}

/// A simple-cubic unit cell of side round(perD (pi / (6 phi))^(1/3)) holding the sphere of
/// the exact solid fraction phi (radius n (3 phi / (4 pi))^(1/3)), with its exact signed
/// distance (nearest periodic image) for interpolated bounce-back. Returns the diameter.
inline double scUnitCellExact(double phi, double perD, flow::LbmDomain& d) {
  const std::int64_t n =
      static_cast<std::int64_t>(std::lround(perD * std::cbrt(std::numbers::pi / (6.0 * phi))));
  const double nn = static_cast<double>(n);
  const double radius = nn * std::cbrt(3.0 * phi / (4.0 * std::numbers::pi));
  const double c = 0.5 * (nn - 1.0);
  d.dims = {n, n, n};
  d.fluid.assign(static_cast<std::size_t>(n * n * n), 1);
  d.signedDistance.assign(d.fluid.size(), 0.0f);
  d.periodic = {true, true, true};
  auto image = [&](std::int64_t k) {
    const double a = std::abs(static_cast<double>(k) - c);
    return std::min(a, nn - a);
  };
  for (std::int64_t k = 0; k < n; ++k)
    for (std::int64_t j = 0; j < n; ++j)
      for (std::int64_t i = 0; i < n; ++i) {
        const double r = std::sqrt(image(k) * image(k) + image(j) * image(j) + image(i) * image(i));
        const std::size_t o = static_cast<std::size_t>((k * n + j) * n + i);
        d.signedDistance[o] = static_cast<float>(r - radius);
        d.fluid[o] = r >= radius ? 1 : 0;
      }
  return 2.0 * radius;
}

/// A bed with the given indicator values (1 void) on an isotropic lattice.
inline Bed bedFromDomain(const flow::LbmDomain& d, double voxelMm) {
  Bed bed;
  bed.indicator = Grid<std::uint8_t>(Lattice::isotropic(d.dims[0], d.dims[1], d.dims[2], voxelMm));
  for (std::size_t o = 0; o < d.fluid.size(); ++o) bed.indicator[o] = d.fluid[o];
  return bed;
}

}  // namespace voxpack::test
