// Packing-density helper for the DEM measurements (until `voxpack stats` is used):
//   dem_bed_density BED.h5 D_MM [RADIAL_CSV]
// Prints JSON: density over the whole cross-section between 2 d above the floor and 2 d
// below the bed top (top = highest particle centre), mean / std of the slice densities
// there, the core (r < R - 2d) density, and the radial profile's first maximum (distance
// from the wall in d). Radial bins d/20 wide, voxel centres, axis = centroid of the mask.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>

#include "voxpack/core/bed_file.hpp"

int main(int argc, char** argv) {
  if (argc < 3) {
    std::cerr << "usage: dem_bed_density BED.h5 D_MM [RADIAL_CSV]\n";
    return 2;
  }
  try {
    const voxpack::Bed bed = voxpack::readBed(argv[1]);
    const double d = std::stod(argv[2]);
    const voxpack::Lattice& l = bed.lattice();
    auto inMask = [&](std::size_t o) { return !bed.mask || (*bed.mask)[o] != 0; };
    double cx = 0, cy = 0, n = 0, floorZ = 1e300;
    for (std::size_t o = 0; o < l.size(); ++o)
      if (inMask(o)) {
        const auto idx = l.indexOf(o);
        const voxpack::Vec3 p = l.centerMm(idx.k, idx.j, idx.i);
        cx += p.x();
        cy += p.y();
        n += 1;
        floorZ = std::min(floorZ, p.z() - 0.5 * l.spacingMm[0]);
      }
    cx /= n;
    cy /= n;
    double top = -1e300;
    for (const auto& p : bed.particles.positionMm) top = std::max(top, p.z());
    const double zLo = floorZ + 2 * d, zHi = top - 2 * d;
    // Wall radius: largest mask distance from the axis in the region.
    double radius = 0;
    for (std::size_t o = 0; o < l.size(); ++o)
      if (inMask(o)) {
        const auto idx = l.indexOf(o);
        const voxpack::Vec3 p = l.centerMm(idx.k, idx.j, idx.i);
        radius = std::max(radius, std::hypot(p.x() - cx, p.y() - cy) + 0.5 * l.spacingMm[2]);
      }
    std::vector<double> sliceSolid(static_cast<std::size_t>(l.nz()), 0),
        sliceAll(static_cast<std::size_t>(l.nz()), 0);
    const double bin = d / 20;
    const std::size_t nb = static_cast<std::size_t>(std::ceil(radius / bin)) + 1;
    std::vector<double> rs(nb, 0), ra(nb, 0);
    double coreS = 0, coreA = 0;
    for (std::size_t o = 0; o < l.size(); ++o) {
      if (!inMask(o)) continue;
      const auto idx = l.indexOf(o);
      const voxpack::Vec3 p = l.centerMm(idx.k, idx.j, idx.i);
      if (p.z() < zLo || p.z() > zHi) continue;
      const double solid = bed.indicator[o] == 0 ? 1 : 0;
      sliceSolid[static_cast<std::size_t>(idx.k)] += solid;
      sliceAll[static_cast<std::size_t>(idx.k)] += 1;
      const double r = std::hypot(p.x() - cx, p.y() - cy);
      const std::size_t b = std::min(nb - 1, static_cast<std::size_t>((radius - r) / bin));
      rs[b] += solid;
      ra[b] += 1;
      if (r < radius - 2 * d) {
        coreS += solid;
        coreA += 1;
      }
    }
    double s = 0, a = 0, sum = 0, sum2 = 0, cnt = 0;
    for (std::size_t k = 0; k < sliceAll.size(); ++k) {
      if (sliceAll[k] == 0) continue;
      s += sliceSolid[k];
      a += sliceAll[k];
      const double phi = sliceSolid[k] / sliceAll[k];
      sum += phi;
      sum2 += phi * phi;
      cnt += 1;
    }
    const double mean = cnt > 0 ? sum / cnt : 0;
    const double sd =
        cnt > 1 ? std::sqrt(std::max(0.0, (sum2 - cnt * mean * mean) / (cnt - 1))) : 0;
    // First maximum of the radial density profile, from the wall inwards.
    double firstMax = -1;
    std::vector<double> prof(nb, 0);
    for (std::size_t b = 0; b < nb; ++b) prof[b] = ra[b] > 0 ? rs[b] / ra[b] : 0;
    for (std::size_t b = 1; b + 1 < nb && b * bin < 1.5 * d; ++b)
      if (prof[b] >= prof[b - 1] && prof[b] >= prof[b + 1] && prof[b] > 0.5) {
        // The largest value within the first diameter.
        std::size_t best = b;
        for (std::size_t c = b; c < nb && c * bin < 1.0 * d; ++c)
          if (prof[c] > prof[best]) best = c;
        firstMax = (static_cast<double>(best) + 0.5) * bin / d;
        break;
      }
    if (argc > 3) {
      std::ofstream csv(argv[3]);
      csv << "wall_distance_d,density\n";
      for (std::size_t b = 0; b < nb; ++b)
        if (ra[b] > 0) csv << (static_cast<double>(b) + 0.5) * bin / d << ',' << prof[b] << '\n';
    }
    nlohmann::json j{{"file", argv[1]},
                     {"particles", bed.particles.size()},
                     {"z_range_mm", {zLo, zHi}},
                     {"bed_top_mm", top},
                     {"density_cross_section", a > 0 ? s / a : 0},
                     {"axial_mean", mean},
                     {"axial_std", sd},
                     {"slices", cnt},
                     {"core_density", coreA > 0 ? coreS / coreA : 0},
                     {"radial_first_max_d", firstMax},
                     {"column_radius_mm", radius}};
    std::cout << j.dump(1) << '\n';
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << '\n';
    return 2;
  }
  return 0;
}
