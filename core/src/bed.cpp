#include "voxpack/core/bed.hpp"

#include <cmath>

#include "voxpack/core/errors.hpp"

namespace voxpack {

namespace {
void checkBinary(const Grid<std::uint8_t>& g, const char* name) {
  for (std::size_t n = 0; n < g.size(); ++n)
    if (g[n] > 1) {
      const Index3 ix = g.lattice().indexOf(n);
      throw FormatError(std::string("/") + name + " holds value " + std::to_string(g[n]) + " at [" +
                        std::to_string(ix.k) + "," + std::to_string(ix.j) + "," +
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
    throw FormatError("/particles/orientation has " + std::to_string(particles.orientation.size()) +
                      " rows, position has " + std::to_string(n));
  if (!particles.shape.empty() && particles.shape.size() != n)
    throw FormatError("/particles/shape has " + std::to_string(particles.shape.size()) +
                      " rows, position has " + std::to_string(n));
  for (const Vec3& p : particles.positionMm)
    if (!p.allFinite()) throw FormatError("/particles/position_mm holds a non-finite value");
  for (std::size_t r = 0; r < particles.orientation.size(); ++r)
    checkUnitQuaternion(particles.orientation[r], r);
}

void checkUnitQuaternion(const Quat& q, std::size_t row) {
  if (!q.coeffs().allFinite())
    throw FormatError("/particles/orientation row " + std::to_string(row) +
                      " holds a non-finite value");
  const double n = q.norm();
  if (std::abs(n - 1.0) > 1e-6)
    throw FormatError("/particles/orientation row " + std::to_string(row) +
                      " is not a unit quaternion (norm " + std::to_string(n) +
                      "; must be 1 within 1e-6)");
}

void accumulateSummary(BedSummary& s, const Grid<std::uint8_t>& ind,
                       const Grid<std::uint8_t>* mask) {
  if (mask) {
    const auto& m = *mask;
    for (std::size_t n = 0; n < ind.size(); ++n) {
      if (m[n]) {
        ++s.voxelsInMask;
        s.voidVoxels += ind[n];
      }
    }
  } else {
    s.voxelsInMask += ind.size();
    for (std::size_t n = 0; n < ind.size(); ++n) s.voidVoxels += ind[n];
  }
}

void finishSummary(BedSummary& s) {
  s.emptyMask = s.voxelsInMask == 0;
  s.porosity = 0;
  s.packingDensity = 0;
  if (!s.emptyMask) {
    s.porosity = static_cast<double>(s.voidVoxels) / static_cast<double>(s.voxelsInMask);
    s.packingDensity = 1.0 - s.porosity;
  }
}

BedSummary summarize(const Bed& bed) {
  BedSummary s;
  accumulateSummary(s, bed.indicator, bed.mask ? &*bed.mask : nullptr);
  finishSummary(s);
  return s;
}

}  // namespace voxpack
