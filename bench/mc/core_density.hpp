#pragma once
// Packing density of a bed inside its mask over the central region: the slices from
// 2 d above the floor (lowest mask slice) to 2 d below the bed top (highest solid
// voxel), docs/references.md measurement protocol. Used before `voxpack stats` existed.
#include <algorithm>
#include <cstdint>

#include "voxpack/core/bed.hpp"

namespace voxpack::bench {

/// Core density and the slab it was measured on.
struct CoreDensity {
  double density = 0;          ///< solid / mask voxels in the slab (0 when the slab is empty)
  double zLowMm = 0;           ///< slab bottom (voxel centre, mm)
  double zHighMm = 0;          ///< slab top (voxel centre, mm)
  double bedTopMm = 0;         ///< highest solid voxel centre (mm)
  std::size_t maskVoxels = 0;  ///< voxels counted
};

/// Core density of `bed` with particle diameter `dMm`.
inline CoreDensity coreDensity(const Bed& bed, double dMm) {
  const Lattice& l = bed.lattice();
  std::int64_t kFloor = -1, kTop = -1;
  for (std::int64_t k = 0; k < l.nz(); ++k)
    for (std::size_t o = l.offset(k, 0, 0), e = l.offset(k, l.ny() - 1, l.nx() - 1) + 1; o < e;
         ++o) {
      const bool in = !bed.mask || (*bed.mask)[o];
      if (in && kFloor < 0) kFloor = k;
      if (in && bed.indicator[o] == 0) kTop = k;
    }
  CoreDensity c;
  if (kFloor < 0 || kTop < 0) return c;
  const double h = l.spacingMm[0];
  const auto margin = static_cast<std::int64_t>(std::ceil(2.0 * dMm / h));
  const std::int64_t k0 = kFloor + margin, k1 = kTop - margin;
  c.zLowMm = l.originMm[0] + static_cast<double>(k0) * h;
  c.zHighMm = l.originMm[0] + static_cast<double>(k1) * h;
  c.bedTopMm = l.originMm[0] + static_cast<double>(kTop) * h;
  std::size_t solid = 0;
  for (std::int64_t k = k0; k <= k1; ++k)
    for (std::size_t o = l.offset(k, 0, 0), e = l.offset(k, l.ny() - 1, l.nx() - 1) + 1; o < e;
         ++o) {
      if (bed.mask && !(*bed.mask)[o]) continue;
      ++c.maskVoxels;
      solid += bed.indicator[o] == 0;
    }
  c.density = c.maskVoxels ? static_cast<double>(solid) / static_cast<double>(c.maskVoxels) : 0.0;
  return c;
}

}  // namespace voxpack::bench
