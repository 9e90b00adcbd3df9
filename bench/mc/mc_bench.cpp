// voxpack_mc_bench: speed of the Monte Carlo packer on the paper's scene (reference
// cylinders d 5.4, l 3.8 mm in a 43.3 mm column). Prints one JSON line per voxel size:
// tried/accepted moves per second of the walk, wall time, status and core density.
//
//   voxpack_mc_bench [--voxel MM]... [--count N] [--container SPEC] [--shape SPEC]
//                    [--rebound P] [--seed N] [--max-sweeps N]
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core_density.hpp"
#include "voxpack/packer/container.hpp"
#include "voxpack/packer/mc.hpp"
#include "voxpack/packer/shape.hpp"

int main(int argc, char** argv) {
  using namespace voxpack;
  std::vector<double> voxels;
  std::string shape = "cylinder:d=5.4,l=3.8", container = "cylinder:d=43.3,h=100";
  std::int64_t count = 650, maxSweeps = 20000;
  double rebound = 0.1;
  std::uint64_t seed = 1;
  for (int a = 1; a + 1 < argc; a += 2) {
    const std::string k = argv[a];
    const char* v = argv[a + 1];
    if (k == "--voxel")
      voxels.push_back(std::atof(v));
    else if (k == "--count")
      count = std::atoll(v);
    else if (k == "--container")
      container = v;
    else if (k == "--shape")
      shape = v;
    else if (k == "--rebound")
      rebound = std::atof(v);
    else if (k == "--seed")
      seed = std::strtoull(v, nullptr, 10);
    else if (k == "--max-sweeps")
      maxSweeps = std::atoll(v);
    else {
      std::cerr << "unknown option " << k << '\n';
      return 2;
    }
  }
  if (voxels.empty()) voxels = {0.54};
  try {
    const auto s = packer::parseShape(shape);
    const auto c = packer::parseContainer(container);
    for (const double h : voxels) {
      packer::McOptions o;
      o.voxelSizeMm = h;
      o.count = count;
      o.reboundProbability = rebound;
      o.maxSweeps = maxSweeps;
      const packer::McResult r = packer::packMonteCarlo({{s, 1.0}}, *c, o, seed);
      const auto& st = r.stats;
      const double walk = st.walkSeconds > 0 ? st.walkSeconds : 1e-9;
      const auto core = bench::coreDensity(r.bed, s->characteristicDiameterMm());
      nlohmann::json j{
          {"voxel_mm", h},
          {"shape", shape},
          {"container", container},
          {"rebound_probability", rebound},
          {"seed", seed},
          {"particles", r.bed.particles.size()},
          {"status", packer::toString(r.status)},
          {"wall_time_s", st.wallSeconds},
          {"walk_time_s", st.walkSeconds},
          {"sweeps", st.sweeps},
          {"tried_moves_per_s", static_cast<double>(st.triedMoves) / walk},
          {"accepted_moves_per_s", static_cast<double>(st.acceptedMoves) / walk},
          {"tried_rotations_per_s", static_cast<double>(st.triedRotations) / walk},
          {"accepted_rotations_per_s", static_cast<double>(st.acceptedRotations) / walk},
          {"core_density", core.density},
          {"bed_top_mm", core.bedTopMm},
          {"batches", st.batches}};
      std::cout << j.dump() << std::endl;
    }
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << '\n';
    return 2;
  }
  return 0;
}
