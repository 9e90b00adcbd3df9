// The broad phase: a sorted cell list of particle centres gives the pairs within reach
// (bounding spheres plus a skin); tangential springs and node lists survive a rebuild.
#include <algorithm>
#include <array>
#include <cmath>
#include <iterator>
#include <numeric>

#include "system_impl.hpp"

namespace voxpack::packer::dem {

// When few particles moved since the last build (most of the bed asleep), only they are
// searched: a pair of two particles still where the last build saw them is in or out of
// reach exactly as it was then, so it is kept or left out as it was, and the moved ones'
// pairs are found in the cell list updated for them alone. Distances and reaches are computed
// as the full search computes them (x[lower] - x[higher], r[lower] + r[higher] + skin), so
// both give the same list to the bit.
void DemSystem::Impl::rebuildNeighbours() {
  ++counters.neighbourRebuilds;
  const std::size_t n = x.size();
  const double cell = 2 * rMax() + skin;
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
  auto pack = [](std::int64_t cx, std::int64_t cy, std::int64_t cz) {
    return (static_cast<std::uint64_t>(cz + (1 << 20)) << 42) |
           (static_cast<std::uint64_t>(cy + (1 << 20)) << 21) |
           static_cast<std::uint64_t>(cx + (1 << 20));
  };
  auto keyOf = [&](std::size_t i) {
    const auto c = cellIndex(x[i]);
    return std::make_pair(pack(c[0], c[1], c[2]), static_cast<std::uint32_t>(i));
  };
  auto tooFar = [&](std::size_t i) {
    return !x[i].allFinite() || x[i].cwiseAbs().maxCoeff() > 0.5 * kKeyLimit * cell;
  };
  const bool partial =
      !movedAll && cellKeys.size() == n && movedMark.size() == n &&
      static_cast<double>(movedList.size()) < opt.liveSetAwakeFraction * static_cast<double>(n);
  std::vector<std::uint32_t> searchers;  // particles whose pairs are searched
  std::vector<std::uint64_t> found;      // pairs as (i << 32 | j), i < j
  if (partial) {
    ++counters.partialRebuilds;
    searchers = movedList;
    std::sort(searchers.begin(), searchers.end());
    for (const std::uint32_t i : searchers)
      if (tooFar(i)) diverged = true;
    // The cell list: the unmoved particles' keys as they were, the moved ones' anew.
    std::vector<std::pair<std::uint64_t, std::uint32_t>> movedKeys;
    movedKeys.reserve(searchers.size());
    for (const std::uint32_t i : searchers) movedKeys.push_back(keyOf(i));
    std::sort(movedKeys.begin(), movedKeys.end());
    cellKeys.erase(std::remove_if(cellKeys.begin(), cellKeys.end(),
                                  [&](const auto& k) { return movedMark[k.second] != 0; }),
                   cellKeys.end());
    cellMerge.clear();
    std::merge(cellKeys.begin(), cellKeys.end(), movedKeys.begin(), movedKeys.end(),
               std::back_inserter(cellMerge));
    cellKeys.swap(cellMerge);
  } else {
    for (std::size_t i = 0; i < n && !diverged; ++i)
      if (tooFar(i)) diverged = true;
    cellKeys.resize(n);
    for (std::size_t i = 0; i < n; ++i) cellKeys[i] = keyOf(i);
    std::sort(cellKeys.begin(), cellKeys.end());
    searchers.resize(n);
    for (std::size_t i = 0; i < n; ++i) searchers[i] = static_cast<std::uint32_t>(i);
  }
  // Pairs found in parallel over the searchers; the sort below makes the list the same for
  // any thread count. The key keeps x in its low bits, so the three cells x-1..x+1 of one
  // (y, z) row are one key range: nine searches a particle, not 27. A full search records a
  // pair from its lower index; a partial one from a moved particle, once for two moved ones.
  const int nt = partial ? 1 : particleThreads();
  const std::int64_t ns = static_cast<std::int64_t>(searchers.size());
#pragma omp parallel num_threads(nt)
  {
    std::vector<std::uint64_t> local;
#pragma omp for schedule(static)
    for (std::int64_t k = 0; k < ns; ++k) {
      const std::uint32_t i = searchers[static_cast<std::size_t>(k)];
      const auto c = cellIndex(x[i]);
      for (int dz = -1; dz <= 1; ++dz)
        for (int dy = -1; dy <= 1; ++dy) {
          const std::uint64_t first = pack(c[0] - 1, c[1] + dy, c[2] + dz);
          const std::uint64_t last = pack(c[0] + 1, c[1] + dy, c[2] + dz);
          auto it = std::lower_bound(cellKeys.begin(), cellKeys.end(),
                                     std::make_pair(first, std::uint32_t{0}));
          for (; it != cellKeys.end() && it->first <= last; ++it) {
            const std::uint32_t j = it->second;
            if (j == i || (j < i && (!partial || movedMark[j]))) continue;
            const std::uint32_t lo = std::min(i, j), hi = std::max(i, j);
            const double reach = tmpl[tid[lo]].radiusMm + tmpl[tid[hi]].radiusMm + skin;
            if ((x[lo] - x[hi]).squaredNorm() < reach * reach)
              local.push_back(static_cast<std::uint64_t>(lo) << 32 | hi);
          }
        }
    }
#pragma omp critical
    found.insert(found.end(), local.begin(), local.end());
  }
  std::sort(found.begin(), found.end());
  // A partial rebuild changes only pairs with a moved end, old or new. Pairs are in (i, j)
  // order, so every pair whose i is below the lowest i of those is kept as it was, with its
  // index: that head (most of the bed, since the moving particles are the last poured) is not
  // touched, and the tail from `head` on is rebuilt as a full rebuild would rebuild it.
  std::size_t head = 0;
  std::uint32_t low = 0;
  if (partial) {
    low = found.empty() ? static_cast<std::uint32_t>(n)
                        : static_cast<std::uint32_t>(found.front() >> 32);
    for (const std::uint32_t i : searchers)
      for (std::uint32_t a = adjStart[i]; a < adjStart[i + 1]; ++a)
        low = std::min(low, pairs[adj[a]].i);
    head = static_cast<std::size_t>(
        std::partition_point(pairs.begin(), pairs.end(), [&](const Pair& p) { return p.i < low; }) -
        pairs.begin());
    const std::size_t fresh = found.size();
    for (std::size_t o = head; o < pairs.size(); ++o)
      if (!movedMark[pairs[o].i] && !movedMark[pairs[o].j])
        found.push_back(static_cast<std::uint64_t>(pairs[o].i) << 32 | pairs[o].j);
    std::inplace_merge(found.begin(), found.begin() + static_cast<std::ptrdiff_t>(fresh),
                       found.end());
  }
  // Carry the tangential springs and node lists of surviving pairs over (both sorted).
  std::vector<Pair> tail(found.size());
  std::size_t o = head;
  for (std::size_t f = 0; f < found.size(); ++f) {
    Pair& p = tail[f];
    p.i = static_cast<std::uint32_t>(found[f] >> 32);
    p.j = static_cast<std::uint32_t>(found[f] & 0xffffffffu);
    p.xi = Vec3::Zero();
    while (o < pairs.size() && (pairs[o].i < p.i || (pairs[o].i == p.i && pairs[o].j < p.j))) ++o;
    if (o < pairs.size() && pairs[o].i == p.i && pairs[o].j == p.j) {
      p.xi = pairs[o].xi;
      p.nodes = std::move(pairs[o].nodes);
    }
  }
  pairs.erase(pairs.begin() + static_cast<std::ptrdiff_t>(head), pairs.end());
  pairs.insert(pairs.end(), std::make_move_iterator(tail.begin()),
               std::make_move_iterator(tail.end()));
  pairOut.resize(pairs.size());  // stale contacts are never read: nothing is evaluated yet
  pairEvaluated.assign(pairs.size(), 0);
  pairOutStale = false;  // the live pair indices of the old list mean nothing now
  // Each particle's pairs in pair order (counting sort). A particle below `low` has all its
  // pairs in the head, which kept their indices, so its entries stand; the others keep their
  // head entries (as j of a head pair, first in pair order) and get their tail pairs after.
  const std::uint32_t from = low;
  const std::size_t adjFrom = partial ? adjStart[from] : 0;
  std::vector<std::uint32_t> count(n - from, 0);
  if (partial)
    for (std::uint32_t i = from; i < n; ++i)
      for (std::uint32_t a = adjStart[i]; a < adjStart[i + 1] && adj[a] < head; ++a)
        ++count[i - from];
  std::vector<std::uint32_t> headCount = count;
  for (std::size_t pi = head; pi < pairs.size(); ++pi) {
    ++count[pairs[pi].i - from];
    ++count[pairs[pi].j - from];
  }
  std::vector<std::uint32_t> seg;
  seg.resize(std::accumulate(count.begin(), count.end(), std::size_t{0}));
  std::vector<std::uint32_t> fill(n - from);
  std::size_t at = 0;
  for (std::uint32_t i = from; i < n; ++i) {
    fill[i - from] = static_cast<std::uint32_t>(at);
    if (partial)
      for (std::uint32_t a = adjStart[i]; a < adjStart[i] + headCount[i - from]; ++a)
        seg[fill[i - from]++] = adj[a];
    at += count[i - from];
  }
  for (std::size_t pi = head; pi < pairs.size(); ++pi) {
    seg[fill[pairs[pi].i - from]++] = static_cast<std::uint32_t>(pi);
    seg[fill[pairs[pi].j - from]++] = static_cast<std::uint32_t>(pi);
  }
  adjStart.resize(n + 1);
  adj.resize(adjFrom);
  adj.insert(adj.end(), seg.begin(), seg.end());
  for (std::uint32_t i = from; i < n; ++i) adjStart[i + 1] = adjStart[i] + count[i - from];
  if (partial) {
    for (const std::uint32_t i : movedList) xBuild[i] = x[i];
  } else {
    xBuild = x;
  }
  for (const std::uint32_t i : movedList) movedMark[i] = 0;
  movedList.clear();
  movedAll = false;
  needRebuild = false;
}

}  // namespace voxpack::packer::dem
