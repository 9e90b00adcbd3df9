// voxpack_mc_density BED.h5 D_MM: core packing density (core_density.hpp) as one JSON line.
#include <cstdlib>
#include <iostream>
#include <nlohmann/json.hpp>

#include "core_density.hpp"
#include "voxpack/core/bed_file.hpp"

int main(int argc, char** argv) {
  if (argc != 3) {
    std::cerr << "usage: voxpack_mc_density BED.h5 PARTICLE_DIAMETER_MM\n";
    return 2;
  }
  try {
    const voxpack::Bed bed = voxpack::readBed(argv[1]);
    const double d = std::atof(argv[2]);
    const auto c = voxpack::bench::coreDensity(bed, d);
    const auto s = voxpack::summarize(bed);
    nlohmann::json j{{"file", argv[1]},
                     {"core_density", c.density},
                     {"core_z_mm", {c.zLowMm, c.zHighMm}},
                     {"bed_top_mm", c.bedTopMm},
                     {"core_mask_voxels", c.maskVoxels},
                     {"mask_density", s.packingDensity},
                     {"particles", bed.particles.size()}};
    if (bed.provenance.contains("status")) j["status"] = bed.provenance["status"];
    if (bed.provenance.contains("mc"))
      j["rebound_probability"] = bed.provenance["mc"]["options"]["rebound_probability"];
    if (bed.provenance.contains("wall_time_s")) j["wall_time_s"] = bed.provenance["wall_time_s"];
    std::cout << j.dump() << '\n';
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << '\n';
    return 2;
  }
  return 0;
}
