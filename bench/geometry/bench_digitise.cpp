// Digitisations per second of the reference cylinder (d 5.4, l 3.8 mm) at 10, 20 and 30
// voxels per diameter, random orientation and sub-voxel position each time (as MC/DEM
// re-digitise after every rotation). Usage: bench_digitise [seconds per case = 1]
#include <time.h>

#include <cstdio>
#include <cstdlib>

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
}  // namespace

int main(int argc, char** argv) {
  const double seconds = argc > 1 ? std::atof(argv[1]) : 1.0;
  const auto shape = parseShape("cylinder:d=5.4,l=3.8");
  std::printf(
      "| voxels per d | voxel (mm) | supersample | voxels | digitisations per CPU second "
      "| CPU us each |\n");
  std::printf("|---|---|---|---|---|---|\n");
  for (int ss : {1, 2, 3}) {
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
          voxels += digitise(*shape, c, q, l, opt).voxels.size();
          ++n;
        }
        elapsed = cpuSeconds() - t0;
      }
      std::printf("| %d | %.3f | %d | %.0f | %.0f | %.1f |\n", perD, h, ss,
                  static_cast<double>(voxels) / static_cast<double>(n),
                  static_cast<double>(n) / elapsed, 1e6 * elapsed / static_cast<double>(n));
    }
  }
  return 0;
}
