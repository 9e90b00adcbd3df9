#include "voxpack/core/bed.hpp"

#include <cmath>

#include "voxpack/core/errors.hpp"

namespace voxpack {

namespace {
void checkBinary(const Grid<std::uint8_t>& g, const char* name) {
  for (std::size_t n = 0; n < g.size(); ++n)
    if (g[n] > 1) {
      const Index3 ix = g.lattice().indexOf(n);
      throw FormatError(std::string("/") + name + " holds value " + std::to_string(g[n]) +
                        " at [" + std::to_string(ix.k) + "," + std::to_string(ix.j) + "," +
                        std::to_string(ix.i) + "] (only 0 and 1 allowed)");
    }
}
}  // namespace

void Bed::validate() const {
  const Lattice& l = indicator.lattice();
  try {
    l.validate("/indicator lattice");
  } catch (const InputError& e) {
    throw FormatError(e.what());
  }
  if (indicator.size() != l.size()) throw FormatError("/indicator size does not match its dims");
  checkBinary(indicator, "indicator");
  if (mask) {
    if (mask->lattice().dims != l.dims)
      throw FormatError("/mask shape differs from /indicator shape");
    checkBinary(*mask, "mask");
  }
  if (labels && labels->lattice().dims != l.dims)
    throw FormatError("/labels shape differs from /indicator shape");
  const std::size_t n = particles.positionMm.size();
  if (!particles.orientation.empty() && particles.orientation.size() != n)
    throw FormatError("/particles/orientation has " +
                      std::to_string(particles.orientation.size()) + " rows, position has " +
                      std::to_string(n));
  if (!particles.shape.empty() && particles.shape.size() != n)
    throw FormatError("/particles/shape has " + std::to_string(particles.shape.size()) +
                      " rows, position has " + std::to_string(n));
  for (const Vec3& p : particles.positionMm)
    if (!p.allFinite()) throw FormatError("/particles/position_mm holds a non-finite value");
}

BedSummary summarize(const Bed& bed) {
  BedSummary s;
  const auto& ind = bed.indicator;
  if (bed.mask) {
    const auto& m = *bed.mask;
    for (std::size_t n = 0; n < ind.size(); ++n) {
      if (m[n]) {
        ++s.voxelsInMask;
        s.voidVoxels += ind[n];
      }
    }
  } else {
    s.voxelsInMask = ind.size();
    for (std::size_t n = 0; n < ind.size(); ++n) s.voidVoxels += ind[n];
  }
  s.emptyMask = s.voxelsInMask == 0;
  if (!s.emptyMask) {
    s.porosity = static_cast<double>(s.voidVoxels) / static_cast<double>(s.voxelsInMask);
    s.packingDensity = 1.0 - s.porosity;
  }
  return s;
}

}  // namespace voxpack
