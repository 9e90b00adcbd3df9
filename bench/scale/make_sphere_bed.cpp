// voxpack_make_sphere_bed OUT.h5 N [SLAB_PLANES] [SEED]: an N³ bed of spheres (d = N/16
// voxels, one per jittered cell, never overlapping) in a cylinder mask of radius N/2 − 1,
// written z-slab by z-slab (memory: one slab, whatever N). The synthetic XMT-like volume of
// docs/scale.md; same N and seed give the same bytes.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "voxpack/core/bed_file.hpp"

namespace {
// SplitMix64 of the cell and seed: a jitter that is the same whichever slab asks.
double jitter(std::int64_t a, std::int64_t b, std::int64_t c, int axis, std::uint64_t seed) {
  std::uint64_t x = seed * 0x9E3779B97F4A7C15ull ^ (static_cast<std::uint64_t>(a) * 73856093ull) ^
                    (static_cast<std::uint64_t>(b) * 19349663ull) ^
                    (static_cast<std::uint64_t>(c) * 83492791ull) ^
                    (static_cast<std::uint64_t>(axis) << 58);
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  x ^= x >> 31;
  return static_cast<double>(x >> 11) / 9007199254740992.0 - 0.5;  // [-0.5, 0.5)
}
}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: %s OUT.h5 N [SLAB_PLANES] [SEED]\n", argv[0]);
    return 2;
  }
  using namespace voxpack;
  const std::int64_t n = std::atoll(argv[2]);
  const std::int64_t slab = argc > 3 ? std::atoll(argv[3]) : 32;
  const std::uint64_t seed = argc > 4 ? std::strtoull(argv[4], nullptr, 10) : 1;
  const double voxel = 0.05;  // mm
  const Lattice l = Lattice::isotropic(n, n, n, voxel);
  const double radius = n / 32.0;                        // voxels
  const double pitch = 2 * radius + 2;                   // cell size: 1 voxel gap at least
  const double room = 0.5 * (pitch - 2 * radius) - 0.5;  // jitter amplitude keeps a gap
  const double colR = 0.5 * static_cast<double>(n) - 1, c0 = 0.5 * static_cast<double>(n - 1);
  try {
    BedSlabWriter w(argv[1], l, true, false);
    for (std::int64_t z0 = 0; z0 < n; z0 += slab) {
      const std::int64_t z1 = std::min(n, z0 + slab);
      const VoxelBox box{{z0, 0, 0}, {z1 - z0, n, n}};
      Grid<std::uint8_t> ind(subLattice(l, box), 1), mask(ind.lattice(), 0);
      for (std::int64_t k = z0; k < z1; ++k)
        for (std::int64_t j = 0; j < n; ++j)
          for (std::int64_t i = 0; i < n; ++i) {
            const double dx = static_cast<double>(i) - c0, dy = static_cast<double>(j) - c0;
            mask(k - z0, j, i) = dx * dx + dy * dy <= colR * colR;
            const auto ck = static_cast<std::int64_t>(std::floor(k / pitch)),
                       cj = static_cast<std::int64_t>(std::floor(j / pitch)),
                       ci = static_cast<std::int64_t>(std::floor(i / pitch));
            const double sz = (ck + 0.5) * pitch + room * 2 * jitter(ck, cj, ci, 0, seed);
            const double sy = (cj + 0.5) * pitch + room * 2 * jitter(ck, cj, ci, 1, seed);
            const double sx = (ci + 0.5) * pitch + room * 2 * jitter(ck, cj, ci, 2, seed);
            const double ez = k - sz, ey = j - sy, ex = i - sx;
            if (ez * ez + ey * ey + ex * ex <= radius * radius) ind(k - z0, j, i) = 0;
          }
      w.writeIndicator(z0, ind);
      w.writeMask(z0, mask);
      std::fprintf(stderr, "\rslab %lld/%lld", static_cast<long long>(z1),
                   static_cast<long long>(n));
    }
    ParticleTable none;
    w.finish(none, {{"generator", "bench/scale/make_sphere_bed"},
                    {"n", n},
                    {"seed", seed},
                    {"sphere_d_mm", 2 * radius * voxel}});
    std::fprintf(stderr, "\n");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}
