// The two LIGGGHTS peer scenes run through the DEM library alone (no digitisation), one
// thread: prints one JSON line with the DEM's wall time (bench/dem/peer_compare.sh).
//   dem_peer_scene spheres|cylinders SEED [THREADS]
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "voxpack/packer/container.hpp"
#include "voxpack/packer/dem.hpp"
#include "voxpack/packer/dem_geometry.hpp"
#include "voxpack/packer/shape.hpp"

using namespace voxpack;

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: dem_peer_scene spheres|cylinders SEED [THREADS]\n");
    return 2;
  }
  const std::string scene = argv[1];
  packer::dem::DemScene s;
  packer::dem::DemOptions o;
  std::string shape, container;
  if (scene == "spheres") {  // 2000 spheres d 5.4, D/d 8, mu 0.3, e 0.5, rho 2.5
    shape = "sphere:d=5.4";
    container = "cylinder:d=43.2,h=200";
    s.count = 2000;
    s.voxelSizeMm = 0.54;
    o.friction = 0.3;
    o.densityGPerCm3 = 2.5;
  } else {  // samples/paper_dem.toml
    shape = "cylinder:d=5.4,l=3.8";
    container = "cylinder:d=43.3,h=60";
    s.fillHeightMm = 60;
    s.voxelSizeMm = 0.27;
    o.friction = 0.1;
  }
  o.restitution = 0.5;
  o.threads = argc > 3 ? std::atoi(argv[3]) : 1;
  s.seed = std::strtoull(argv[2], nullptr, 10);
  const auto sh = packer::parseShape(shape);
  s.shapes = {packer::dem::demShape(sh)};
  s.fractions = {1.0};
  s.container =
      packer::dem::demContainer(packer::parseContainer(container), 2 * sh->boundingRadiusMm());
  const auto t0 = std::chrono::steady_clock::now();
  const auto r = packer::dem::runDem(s, o, nullProgress());
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf(
      "{\"scene\": \"%s\", \"seed\": %s, \"threads\": %d, \"status\": \"%s\", \"particles\": %zu, "
      "\"wall_s\": %.3f, \"simulated_s\": %.4f, \"steps\": %llu, \"time_step_s\": %.4g, "
      "\"mean_overlap_mm\": %.5g, \"max_overlap_mm\": %.5g}\n",
      scene.c_str(), argv[2], o.threads, packer::dem::statusName(r.status), r.particles.size(),
      wall, r.simulatedTimeS, static_cast<unsigned long long>(r.counters.steps), r.timeStepS,
      r.meanOverlapMm, r.maxOverlapMm);
  return 0;
}
