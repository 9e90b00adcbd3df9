// Specific surface from crossing counts along the 13 lattice directions, and the z-crop.
#include <cmath>
#include <sstream>

#include "voxpack/core/errors.hpp"
#include "voxpack/flow/flow.hpp"

namespace voxpack::flow {

double specificSurfaceMmInv(const Bed& bed, bool periodic) {
  // Cauchy-Crofton: for an isotropic interface a test line of length L crosses it
  // S_v L / 2 times on average, so S_v = 2 <crossings per unit line length> over
  // directions. Voxel pairs (x, x + e) estimate the crossing rate along e; the 13
  // directions are weighted by their share of the sphere (Voronoi areas of the 26
  // lattice directions; Lang et al., J. Microsc. 2001: 0.0457778, 0.0369806, 0.0351327).
  // Normalised by the pairs inside the box (and mask): unbiased for a stationary
  // structure; a periodic sample wraps its pairs.
  static const int dirs[13][3] = {{1, 0, 0},  {0, 1, 0},  {0, 0, 1},  {1, 1, 0},  {1, -1, 0},
                                  {1, 0, 1},  {1, 0, -1}, {0, 1, 1},  {0, 1, -1}, {1, 1, 1},
                                  {1, 1, -1}, {1, -1, 1}, {1, -1, -1}};
  const auto& lat = bed.lattice();
  const auto d = lat.dims;
  const double h = lat.spacingMm[0];
  double sum = 0, wsum = 0;
  for (const auto& e : dirs) {
    const int nz = std::abs(e[0]) + std::abs(e[1]) + std::abs(e[2]);
    const double w = nz == 1 ? 0.0457778 : nz == 2 ? 0.0369806 : 0.0351327;
    double pairs = 0, cross = 0;
    for (std::int64_t k = 0; k < d[0]; ++k) {
      std::int64_t k2 = k + e[0];
      if (periodic) k2 = (k2 + d[0]) % d[0];
      if (k2 < 0 || k2 >= d[0]) continue;
      for (std::int64_t j = 0; j < d[1]; ++j) {
        std::int64_t j2 = j + e[1];
        if (periodic) j2 = (j2 + d[1]) % d[1];
        if (j2 < 0 || j2 >= d[1]) continue;
        const std::size_t row = lat.offset(k, j, 0), row2 = lat.offset(k2, j2, 0);
        for (std::int64_t i = 0; i < d[2]; ++i) {
          std::int64_t i2 = i + e[2];
          if (periodic) i2 = (i2 + d[2]) % d[2];
          if (i2 < 0 || i2 >= d[2]) continue;
          const std::size_t a = row + static_cast<std::size_t>(i);
          const std::size_t b = row2 + static_cast<std::size_t>(i2);
          if (bed.mask && (!(*bed.mask)[a] || !(*bed.mask)[b])) continue;
          pairs += 1;
          cross += bed.indicator[a] != bed.indicator[b];
        }
      }
    }
    if (pairs == 0) continue;
    const double len = std::sqrt(static_cast<double>(nz)) * h;
    sum += w * 2.0 * cross / (pairs * len);
    wsum += w;
  }
  return wsum > 0 ? sum / wsum : 0.0;
}

std::pair<double, double> parseRoiMm(const std::string& text) {
  const auto colon = text.find(':');
  if (colon == std::string::npos)
    throw UsageError("--roi-mm: expected Z0:Z1 in mm, got '" + text + "'");
  try {
    std::size_t used = 0;
    const std::string a = text.substr(0, colon), b = text.substr(colon + 1);
    const double z0 = std::stod(a, &used);
    if (used != a.size()) throw std::invalid_argument(a);
    const double z1 = std::stod(b, &used);
    if (used != b.size()) throw std::invalid_argument(b);
    if (!std::isfinite(z0) || !std::isfinite(z1) || !(z0 < z1))
      throw UsageError("--roi-mm: need finite Z0 < Z1, got '" + text + "'");
    return {z0, z1};
  } catch (const std::logic_error&) {
    throw UsageError("--roi-mm: expected Z0:Z1 in mm, got '" + text + "'");
  }
}

Bed cropBedZ(const Bed& bed, double z0, double z1) {
  const Lattice& lat = bed.lattice();
  std::int64_t k0 = lat.nz(), k1 = -1;
  for (std::int64_t k = 0; k < lat.nz(); ++k) {
    const double z = lat.originMm[0] + static_cast<double>(k) * lat.spacingMm[0];
    if (z >= z0 && z <= z1) k0 = std::min(k0, k), k1 = std::max(k1, k);
  }
  if (k1 < k0) {
    std::ostringstream m;
    m << "--roi-mm: no layer of the bed has its centre in [" << z0 << ", " << z1
      << "] mm (the bed spans z " << lat.originMm[0] << " to "
      << lat.originMm[0] + static_cast<double>(lat.nz() - 1) * lat.spacingMm[0] << " mm)";
    throw InputError(m.str());
  }
  Lattice out = lat;
  out.dims[0] = k1 - k0 + 1;
  out.originMm[0] = lat.originMm[0] + static_cast<double>(k0) * lat.spacingMm[0];
  const std::size_t plane = static_cast<std::size_t>(lat.ny() * lat.nx());
  const std::size_t first = static_cast<std::size_t>(k0) * plane;
  const std::size_t count = static_cast<std::size_t>(out.dims[0]) * plane;
  Bed c;
  c.indicator = Grid<std::uint8_t>(out);
  std::copy_n(bed.indicator.data() + first, count, c.indicator.data());
  if (bed.mask) {
    c.mask = Grid<std::uint8_t>(out);
    std::copy_n(bed.mask->data() + first, count, c.mask->data());
  }
  c.particles = bed.particles;  // kept for the particle diameter (spheres' d)
  c.provenance = bed.provenance;
  return c;
}

}  // namespace voxpack::flow
