// Digitisations per second of the reference cylinder (d 5.4, l 3.8 mm) at 10, 20 and 30
// voxels per diameter, random orientation and sub-voxel position each time (as MC/DEM
// re-digitise after every rotation); the analytic shape with k = 1, 2, 3 and a 96-facet
// STL of it with k = 1. Usage: bench_digitise [CPU seconds per case = 1]
#include <time.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <numbers>
#include <string>

#include "voxpack/core/random.hpp"
#include "voxpack/packer/digitise.hpp"

using namespace voxpack;
using namespace voxpack::packer;

namespace {

// Thread CPU time: the machine is shared, so wall time would measure the neighbours.
double cpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

// The reference cylinder as a 96-facet ASCII STL in the temp folder.
std::string writeCylinderStl() {
  const auto path = std::filesystem::temp_directory_path() / "voxpack_bench_cylinder.stl";
  std::ofstream f(path);
  f.precision(17);
  f << "solid c\n";
  const int n = 96;
  const double r = 2.7, h = 1.9;
  for (int s = 0; s < n; ++s) {
    const double a0 = 2 * std::numbers::pi * s / n, a1 = 2 * std::numbers::pi * ((s + 1) % n) / n;
    const double x0 = r * std::cos(a0), y0 = r * std::sin(a0), x1 = r * std::cos(a1),
                 y1 = r * std::sin(a1);
    const double tris[4][3][3] = {{{0, 0, -h}, {x1, y1, -h}, {x0, y0, -h}},
                                  {{0, 0, h}, {x0, y0, h}, {x1, y1, h}},
                                  {{x0, y0, -h}, {x1, y1, -h}, {x1, y1, h}},
                                  {{x0, y0, -h}, {x1, y1, h}, {x0, y0, h}}};
    for (const auto& t : tris) {
      f << "facet normal 0 0 0\nouter loop\n";
      for (const auto& p : t) f << "vertex " << p[0] << ' ' << p[1] << ' ' << p[2] << '\n';
      f << "endloop\nendfacet\n";
    }
  }
  f << "endsolid c\n";
  return path.string();
}

void run(const Shape& shape, const char* label, double seconds, std::initializer_list<int> ks) {
  for (int ss : ks) {
    for (int perD : {10, 20, 30}) {
      const double h = 5.4 / perD;
      const Lattice l = Lattice::isotropic(1, 1, 1, h);
      DigitiseOptions opt;
      opt.supersample = ss;
      RandomStream rng(1, static_cast<std::uint64_t>(perD));
      std::size_t n = 0, voxels = 0;
      const double t0 = cpuSeconds();
      double elapsed = 0;
      while (elapsed < seconds) {
        for (int r = 0; r < 16; ++r) {
          Quat q(rng.normal(), rng.normal(), rng.normal(), rng.normal());
          q.normalize();
          const Vec3 c(rng.uniform() * h, rng.uniform() * h, rng.uniform() * h);
          voxels += digitise(shape, c, q, l, opt).voxels.size();
          ++n;
        }
        elapsed = cpuSeconds() - t0;
      }
      std::printf("| %s | %d | %.3f | %d | %.0f | %.0f | %.1f |\n", label, perD, h, ss,
                  static_cast<double>(voxels) / static_cast<double>(n),
                  static_cast<double>(n) / elapsed, 1e6 * elapsed / static_cast<double>(n));
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  const double seconds = argc > 1 ? std::atof(argv[1]) : 1.0;
  std::printf(
      "| shape | voxels per d | voxel (mm) | k | voxels | digitisations per CPU second | CPU "
      "us each |\n|---|---|---|---|---|---|---|\n");
  run(*parseShape("cylinder:d=5.4,l=3.8"), "cylinder", seconds, {1, 2, 3});
  const std::string stl = writeCylinderStl();
  run(*parseShape("mesh:" + stl), "96-facet STL", seconds, {1});
  std::filesystem::remove(stl);
  return 0;
}
