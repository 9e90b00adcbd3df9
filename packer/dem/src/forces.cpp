// One force evaluation: contacts of all pairs and walls (parallel, one slot each), then each
// particle sums its own contacts in pair order, so the bits do not depend on the threads,
// and (within a step) takes its closing half kick.
#include <omp.h>

#include <algorithm>
#include <cmath>

#include "system_impl.hpp"

namespace voxpack::packer::dem {

// Chooses what this evaluation visits. While liveSetAwakeFraction (a quarter) or more of the
// particles are awake (a pour's start, a tap, the paper's bed) it is everything. Otherwise it
// is the awake particles, the sleepers sharing a pair with one, and those pairs: a pair of
// two sleepers keeps its spring and is never evaluated, and a sleeper's wall forces are
// zero, so a sleeper away from every awake particle always sums to its weight alone. The
// sleepers live in the last evaluation are visited once more, which resets their sums to
// that weight, so every skipped particle holds exactly what a full pass would give it and
// the bits are those of a full pass.
namespace {

// How many pairs ahead the pair loop prefetches node lists (one pair's narrow phase covers
// a memory latency).
constexpr std::int64_t kPairPrefetch = 2;

// Sorts a list of distinct indices below n that `marked` picks out: by a sort when it is
// short against n, by a scan of the marks otherwise (the same list either way).
template <class Marked>
void ascending(std::vector<std::uint32_t>& list, std::size_t n, Marked marked) {
  if (list.size() * 64 < n) {
    std::sort(list.begin(), list.end());
    return;
  }
  list.clear();
  for (std::size_t i = 0; i < n; ++i)
    if (marked(i)) list.push_back(static_cast<std::uint32_t>(i));
}

}  // namespace

void DemSystem::Impl::listAwake() {
  awakeList.clear();
  for (std::size_t i = 0; i < x.size(); ++i)
    if (awake[i]) awakeList.push_back(static_cast<std::uint32_t>(i));
  awakeListValid = true;
}

void DemSystem::Impl::selectLive() {
  const std::size_t n = x.size();
  // Last evaluation's marks move to bit 1 (only its live list holds marks, unless it was a
  // full pass or particles were added since).
  if (liveAll || liveMark.size() != n) {
    liveMark.resize(n, 0);
    for (auto& m : liveMark) m = static_cast<std::uint8_t>((m & 1) << 1);
  } else {
    for (const std::uint32_t i : liveList)
      liveMark[i] = static_cast<std::uint8_t>((liveMark[i] & 1) << 1);
  }
  if (!awakeListValid) listAwake();
  // Evaluated flags of the last evaluation's pairs go back to false (a full pass resets
  // them all in its pair loop; a rebuild starts from all false).
  if (pairOutStale && liveAll) {
    std::fill(pairEvaluated.begin(), pairEvaluated.end(), std::uint8_t{0});
  } else if (pairOutStale) {
    for (const std::uint32_t pi : livePairs) pairEvaluated[pi] = 0;
  }
  const bool wasAll = liveAll;
  std::vector<std::uint32_t> lastLive;
  lastLive.swap(liveList);
  livePairs.clear();
  pairOutStale = true;
  liveAll = liveAllNext || static_cast<double>(awakeList.size()) >=
                               opt.liveSetAwakeFraction * static_cast<double>(n);
  liveAllNext = false;
  if (liveAll) {
    std::fill(liveMark.begin(), liveMark.end(), std::uint8_t{3});
    return;
  }
  // Each live particle and pair once, in the order met; then ascending, by a sort when the
  // list is short against the whole (a sort of a few thousand costs ~50 us a step), by a scan
  // of the marks otherwise.
  auto live = [&](std::uint32_t i) {
    if (!(liveMark[i] & 1)) liveList.push_back(i);
    liveMark[i] |= 1;
  };
  for (const std::uint32_t i : awakeList) {
    live(i);
    for (std::uint32_t a = adjStart[i]; a < adjStart[i + 1]; ++a) {
      const Pair& p = pairs[adj[a]];
      const std::uint32_t j = p.i == i ? p.j : p.i;
      live(j);
      if (!awake[j] || i < j) livePairs.push_back(adj[a]);
    }
  }
  if (wasAll) {  // the last evaluation's list is everyone: the marks say who
    liveList.clear();
    for (std::size_t i = 0; i < n; ++i)
      if (liveMark[i]) liveList.push_back(static_cast<std::uint32_t>(i));
  } else {
    for (const std::uint32_t i : lastLive)
      if (liveMark[i] == 2) liveList.push_back(i);  // the last evaluation's alone
    ascending(liveList, n, [&](std::size_t i) { return liveMark[i] != 0; });
  }
  pairMark.resize(pairs.size(), 0);
  for (const std::uint32_t pi : livePairs) pairMark[pi] = 1;
  ascending(livePairs, pairs.size(), [&](std::size_t pi) { return pairMark[pi] != 0; });
  for (const std::uint32_t pi : livePairs) pairMark[pi] = 0;
}

void DemSystem::Impl::computeForces(double kick) {
  const std::size_t n = x.size();
  const std::int64_t sn = static_cast<std::int64_t>(n);
  double vw = 0;
  const double zw = wallOffset(t, &vw);
  const double meanWork = workTotal / std::max<double>(1.0, static_cast<double>(n));
  const int sumThreads = particleThreads();
  rot.resize(n);
  omegaW.resize(n);
  std::uint64_t evalsTotal = 0, evaluated = 0, searches = 0;
  std::uint64_t wallEvals = 0, wallSearches = 0;
  selectLive();
  // The pairs visited: all of them, or the live ones (ascending, so the pair-order sums
  // below meet the evaluated pairs in the same order either way).
  const std::int64_t np = static_cast<std::int64_t>(liveAll ? pairs.size() : livePairs.size());
  auto pairAt = [&](std::int64_t k) {
    return liveAll ? static_cast<std::size_t>(k) : livePairs[static_cast<std::size_t>(k)];
  };
  // The particles whose walls and sums are visited: all, or the live ones.
  const std::int64_t nw = liveAll ? sn : static_cast<std::int64_t>(liveList.size());
  auto liveAt = [&](std::int64_t k) {
    return liveAll ? static_cast<std::size_t>(k) : liveList[static_cast<std::size_t>(k)];
  };
  // The particles whose poses change: all (the sleepers skip), or the awake ones.
  const std::int64_t na = liveAll ? sn : static_cast<std::int64_t>(awakeList.size());
  const double visited = static_cast<double>(nw);
  // Small systems run serial: a parallel region costs more than it saves there, and far
  // more on an oversubscribed machine. Poses, pairs and walls share one region. Poses and
  // pairs are dealt in fixed interleaved chunks of 32: each pair's spring and output stay
  // in one core's cache from step to step (dynamic chunks moved them between the cores
  // every step: on the paper's bed 2 threads took 0.4-14 % longer in 4 alternating runs),
  // and the walls, dealt dynamically after the pairs without a barrier, even out the load.
  const int forceThreads =
      std::max(threadsFor(static_cast<double>(np), static_cast<double>(np) * meanWork),
               threadsFor(visited / 4, visited * meanWork));
  if (scratch.size() < static_cast<std::size_t>(forceThreads))
    scratch.resize(static_cast<std::size_t>(forceThreads));
#pragma omp parallel num_threads(forceThreads) \
    reduction(+ : evalsTotal, evaluated, searches, wallEvals, wallSearches)
  {
    Scratch& sc = scratch[static_cast<std::size_t>(omp_get_thread_num())];
#pragma omp for schedule(static, 32)
    for (std::int64_t k = 0; k < na; ++k) {
      const std::size_t i =
          liveAll ? static_cast<std::size_t>(k) : awakeList[static_cast<std::size_t>(k)];
      // A sleeping particle keeps its pose and has no spin (sleepUpdate zeroed both rates),
      // so its rotation and rate stay as they were when it fell asleep (particles are added
      // awake, and a restored state fills both for all).
      if (!awake[i]) continue;
      rot[i] = q[i].toRotationMatrix();
      omegaW[i] = worldRate(rot[i], L[i], tmpl[tid[i]].inertiaG);
    }
    // (implicit barrier: the contacts read every pose)
#pragma omp for schedule(static, 32) nowait
    for (std::int64_t k = 0; k < np; ++k) {
      const std::size_t pi = pairAt(k);
      if (k + kPairPrefetch < np) {
        // Each pair's node lists are short (~21 nodes) heap blocks: the first touch of one
        // misses every cache, and the hardware prefetcher cannot guess the next block.
        const NodeList& ahead = pairs[pairAt(k + kPairPrefetch)].nodes;
        __builtin_prefetch(ahead.a.data());
        __builtin_prefetch(ahead.b.data());
      }
      Pair& p = pairs[pi];
      ContactOut& c = pairOut[pi];
      pairEvaluated[pi] = 0;                     // the contact is read only when evaluated
      if (!awake[p.i] && !awake[p.j]) continue;  // two sleepers keep their spring
      const double reach = tmpl[tid[p.i]].radiusMm + tmpl[tid[p.j]].radiusMm;
      if ((x[p.i] - x[p.j]).squaredNorm() >= reach * reach) {
        p.xi.setZero();  // separated pairs lose their spring
        continue;
      }
      ++evaluated;
      pairEvaluated[pi] = 1;
      if (closedForm[tid[p.i]] && closedForm[tid[p.j]]) {
        c = spherePair(p);
      } else {
        sc.pair.clear();
        std::uint64_t evals = 0;
        // Both surfaces probe each other at half stiffness: symmetric, and a flat contact
        // of area A and overlap delta carries k A delta as against a wall.
        pairHits(p, sc.pair, evals, searches);
        evalsTotal += evals;
        c = nodeContact(sc.pair, body(p.i), body(p.j), pairLaw, p.xi);
      }
      p.xi = c.touching ? c.xi : Vec3::Zero();
    }
#pragma omp for schedule(dynamic, 16)
    for (std::int64_t k = 0; k < nw; ++k)
      wallForces(liveAt(k), zw, vw, sc.wall, wallEvals, wallSearches);
  }
  counters.nodeEvaluations += evalsTotal + wallEvals;
  counters.nodeListRebuilds += searches + wallSearches;
  counters.pairChecks += static_cast<std::uint64_t>(np);
  counters.pairEvaluations += evaluated;

  // Diagnostics in pair order (cheap, serial).
  elastic = 0;
  maxDepth = 0;
  sumDepth = 0;
  contactCount = 0;
  interpenetrations = 0;
  maxWallFraction = 0;
  for (std::int64_t k = 0; k < np; ++k) {
    const std::size_t pi = pairAt(k);
    const ContactOut& c = pairOut[pi];
    if (!pairEvaluated[pi] || !c.touching) continue;
    elastic += c.elastic;
    maxDepth = std::max(maxDepth, c.maxDepth);
    sumDepth += c.maxDepth;
    ++contactCount;
    maxWallFraction = std::max(maxWallFraction, c.wallFraction);
    if (c.wallFraction > kInterpenetrationWallFraction) ++interpenetrations;
  }
  for (std::int64_t k = 0; k < nw; ++k) {  // a skipped sleeper's wall terms are zero
    const std::size_t i = liveAt(k);
    elastic += wallElastic[i];
    maxDepth = std::max(maxDepth, wallDepth[i]);
  }
  // Each particle: gravity, its pair contacts in pair order, then its walls; then the kick.
#pragma omp parallel for num_threads(sumThreads) schedule(static, 32)
  for (std::int64_t k = 0; k < nw; ++k) {
    const std::size_t i = liveAt(k);  // a skipped one holds its weight alone (selectLive)
    Vec3 f(0, 0, -opt.gravityMmPerS2 * tmpl[tid[i]].massG), tq = Vec3::Zero();
    for (std::uint32_t a = adjStart[i]; a < adjStart[i + 1]; ++a) {
      const std::size_t pi = adj[a];
      const ContactOut& c = pairOut[pi];
      if (!pairEvaluated[pi] || !c.touching) continue;
      const Pair& p = pairs[pi];
      if (p.i == i) {
        f += c.force;
        tq += c.torqueA;
      } else {
        f -= c.force;
        tq -= c.torqueA + (x[p.i] - x[p.j]).cross(c.force);
      }
    }
    F[i] = f + wallF[i];
    T[i] = tq + wallT[i];
    if (kick > 0 && awake[i]) {
      v[i] += (kick / tmpl[tid[i]].massG) * F[i];
      L[i] += kick * T[i];
    }
  }
  forcesValid = true;
}

}  // namespace voxpack::packer::dem
