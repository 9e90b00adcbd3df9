#include "voxpack/core/lattice.hpp"

#include <cmath>
#include <string>

#include "voxpack/core/errors.hpp"

namespace voxpack {

Lattice Lattice::isotropic(std::int64_t nz, std::int64_t ny, std::int64_t nx, double voxelMm,
                           const Vec3& originXyzMm) {
  Lattice l;
  l.dims = {nz, ny, nx};
  l.spacingMm = {voxelMm, voxelMm, voxelMm};
  l.originMm = {originXyzMm.z(), originXyzMm.y(), originXyzMm.x()};
  return l;
}

Index3 Lattice::indexOf(std::size_t off) const {
  const auto nx = static_cast<std::size_t>(dims[2]);
  const auto ny = static_cast<std::size_t>(dims[1]);
  Index3 r;
  r.i = static_cast<std::int64_t>(off % nx);
  off /= nx;
  r.j = static_cast<std::int64_t>(off % ny);
  r.k = static_cast<std::int64_t>(off / ny);
  return r;
}

Index3 Lattice::nearestIndex(const Vec3& pMm) const {
  const Vec3 c = continuousIndex(pMm);
  return {static_cast<std::int64_t>(std::llround(c.z())),
          static_cast<std::int64_t>(std::llround(c.y())),
          static_cast<std::int64_t>(std::llround(c.x()))};
}

bool Lattice::isIsotropic() const {
  const double s = spacingMm[0];
  return std::abs(spacingMm[1] - s) <= 1e-9 * s && std::abs(spacingMm[2] - s) <= 1e-9 * s;
}

void Lattice::validate(const char* what) const {
  for (int a = 0; a < 3; ++a) {
    if (dims[a] < 1)
      throw InputError(std::string(what) + ": dimension " + std::to_string(a) +
                       " is " + std::to_string(dims[a]) + " (must be >= 1)");
    if (!std::isfinite(spacingMm[a]) || spacingMm[a] <= 0)
      throw InputError(std::string(what) + ": spacing must be finite and > 0, got " +
                       std::to_string(spacingMm[a]));
    if (!std::isfinite(originMm[a]))
      throw InputError(std::string(what) + ": origin must be finite");
  }
}

}  // namespace voxpack
