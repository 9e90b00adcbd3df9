// The broad phase: a sorted cell list of particle centres gives the pairs within reach
// (bounding spheres plus a skin); tangential springs and node lists survive a rebuild.
#include <algorithm>
#include <array>
#include <cmath>

#include "system_impl.hpp"

namespace voxpack::packer::dem {

void DemSystem::Impl::rebuildNeighbours() {
  ++counters.neighbourRebuilds;
  const std::size_t n = x.size();
  const double cell = 2 * rMax() + skin;
  std::vector<std::pair<std::uint64_t, std::uint32_t>> keys(n);
  // A non-finite or far-away centre must never reach the integer key (undefined
  // behaviour): such a state is a blow-up, flagged here and stopped by the integrator.
  constexpr double kKeyLimit = (1 << 20) - 2;
  auto cellIndex = [&](const Vec3& p) {
    std::array<std::int64_t, 3> c{};
    for (int a = 0; a < 3; ++a) {
      const double f = std::floor(p[a] / cell);
      c[a] = std::isfinite(f) ? static_cast<std::int64_t>(std::clamp(f, -kKeyLimit, kKeyLimit)) : 0;
    }
    return c;
  };
  for (std::size_t i = 0; i < n && !diverged; ++i)
    if (!x[i].allFinite() || x[i].cwiseAbs().maxCoeff() > 0.5 * kKeyLimit * cell) diverged = true;
  auto pack = [](std::int64_t cx, std::int64_t cy, std::int64_t cz) {
    return (static_cast<std::uint64_t>(cz + (1 << 20)) << 42) |
           (static_cast<std::uint64_t>(cy + (1 << 20)) << 21) |
           static_cast<std::uint64_t>(cx + (1 << 20));
  };
  for (std::size_t i = 0; i < n; ++i) {
    const auto c = cellIndex(x[i]);
    keys[i] = {pack(c[0], c[1], c[2]), static_cast<std::uint32_t>(i)};
  }
  std::sort(keys.begin(), keys.end());
  // Pairs found in parallel over i as (i << 32 | j); the sort below makes the list the
  // same for any thread count. The key keeps x in its low bits, so the three cells x-1..x+1
  // of one (y, z) row are one key range: nine searches a particle, not 27.
  std::vector<std::uint64_t> found;
  const int nt = particleThreads();
#pragma omp parallel num_threads(nt)
  {
    std::vector<std::uint64_t> local;
#pragma omp for schedule(static)
    for (std::int64_t si = 0; si < static_cast<std::int64_t>(n); ++si) {
      const std::size_t i = static_cast<std::size_t>(si);
      const auto c = cellIndex(x[i]);
      const double ri = tmpl[tid[i]].radiusMm;
      for (int dz = -1; dz <= 1; ++dz)
        for (int dy = -1; dy <= 1; ++dy) {
          const std::uint64_t first = pack(c[0] - 1, c[1] + dy, c[2] + dz);
          const std::uint64_t last = pack(c[0] + 1, c[1] + dy, c[2] + dz);
          auto it =
              std::lower_bound(keys.begin(), keys.end(), std::make_pair(first, std::uint32_t{0}));
          for (; it != keys.end() && it->first <= last; ++it) {
            const std::uint32_t j = it->second;
            if (j <= i) continue;
            const double reach = ri + tmpl[tid[j]].radiusMm + skin;
            if ((x[i] - x[j]).squaredNorm() < reach * reach)
              local.push_back(static_cast<std::uint64_t>(i) << 32 | j);
          }
        }
    }
#pragma omp critical
    found.insert(found.end(), local.begin(), local.end());
  }
  std::sort(found.begin(), found.end());
  // Carry the tangential springs and node lists of surviving pairs over (both sorted).
  std::vector<Pair> fresh(found.size());
  std::size_t o = 0;
  for (std::size_t f = 0; f < found.size(); ++f) {
    Pair& p = fresh[f];
    p.i = static_cast<std::uint32_t>(found[f] >> 32);
    p.j = static_cast<std::uint32_t>(found[f] & 0xffffffffu);
    p.xi = Vec3::Zero();
    while (o < pairs.size() && (pairs[o].i < p.i || (pairs[o].i == p.i && pairs[o].j < p.j))) ++o;
    if (o < pairs.size() && pairs[o].i == p.i && pairs[o].j == p.j) {
      p.xi = pairs[o].xi;
      p.nodes = std::move(pairs[o].nodes);
    }
  }
  pairs.swap(fresh);
  pairOut.assign(pairs.size(), PairOut{});
  pairOutStale = false;  // the live pair indices of the old list mean nothing now
  // Each particle's pairs in pair order (counting sort).
  adjStart.assign(n + 1, 0);
  for (const Pair& p : pairs) {
    ++adjStart[p.i + 1];
    ++adjStart[p.j + 1];
  }
  for (std::size_t i = 0; i < n; ++i) adjStart[i + 1] += adjStart[i];
  adj.resize(2 * pairs.size());
  std::vector<std::uint32_t> fill(adjStart.begin(), adjStart.end() - 1);
  for (std::size_t pi = 0; pi < pairs.size(); ++pi) {
    adj[fill[pairs[pi].i]++] = static_cast<std::uint32_t>(pi);
    adj[fill[pairs[pi].j]++] = static_cast<std::uint32_t>(pi);
  }
  xBuild = x;
  needRebuild = false;
}

}  // namespace voxpack::packer::dem
