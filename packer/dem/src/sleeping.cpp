// Sleeping: particles at rest, away from moving neighbours, are frozen until woken.
//
// A particle falls asleep when, over a window of sleepTime, it never moved faster than vWake
// and its net displacement (centre plus rotation at its bounding radius) stayed below
// vSleep x window. The net displacement, not the instantaneous speed, is what matters:
// contact forces leave a few particles of a bed jittering about a fixed place (~1e-5 mm at a
// few kHz), which a speed test never lets sleep, and those few then keep the whole bed from
// meeting the settling thresholds.
#include <algorithm>
#include <cmath>

#include "system_impl.hpp"

namespace voxpack::packer::dem {

void DemSystem::Impl::restartWindow(std::size_t i) {
  slowSteps[i] = 0;
  xRest[i] = x[i];
  qRest[i] = q[i];
}

std::size_t DemSystem::Impl::sleepUpdate() {
  const std::size_t n = x.size();
  const std::int64_t sn = static_cast<std::int64_t>(n);
  if (!opt.sleeping) return n;  // everyone stays awake; rest windows are never read
  // Sleeping is allowed in the rests between taps (every lift wakes all again).
  if (wallLiftingAt(t)) {
    for (std::size_t i = 0; i < n; ++i) {
      awake[i] = 1;
      restartWindow(i);
    }
    awakeListValid = false;
    return n;
  }
  const double vSleep = opt.settleVelocity * std::sqrt(opt.gravityMmPerS2 * dMin());
  const double vWake = 10 * vSleep;
  const std::uint32_t need =
      static_cast<std::uint32_t>(std::max(1.0, std::ceil(opt.sleepTimeS / dt)));
  const int nt = particleThreads();
  // With the live set (forces.cpp) only its particles are visited: a sleeper outside it has
  // every neighbour asleep, so nothing here can wake it.
  const bool listed = !liveAll;
  const std::int64_t na = listed ? static_cast<std::int64_t>(awakeList.size()) : sn;
  const std::int64_t nl = listed ? static_cast<std::int64_t>(liveList.size()) : sn;
  auto awakeAt = [&](std::int64_t k) {
    return listed ? awakeList[static_cast<std::size_t>(k)] : static_cast<std::size_t>(k);
  };
  auto liveAt = [&](std::int64_t k) {
    return listed ? liveList[static_cast<std::size_t>(k)] : static_cast<std::size_t>(k);
  };
  fast.resize(n, 0);  // all zero between calls
#pragma omp parallel num_threads(nt)
  {
#pragma omp for schedule(static, 32)
    for (std::int64_t k = 0; k < na; ++k) {
      const std::size_t i = awakeAt(k);
      if (!awake[i]) continue;
      const ParticleTemplate& tp = tmpl[tid[i]];
      const double spin = worldRate(rot[i], L[i], tp.inertiaG).norm();  // rot: this step's pose
      const double speed = v[i].norm() + spin * tp.radiusMm;
      fast[i] = speed >= vWake ? 1 : 0;
    }
    // Each particle looks at its own neighbours: woken (2) when one of them moves fast.
#pragma omp for schedule(static, 32)
    for (std::int64_t k = 0; k < nl; ++k) {
      const std::size_t i = liveAt(k);
      if (!(liveMark[i] & 1)) continue;  // live in the last evaluation only: all asleep
      bool neighbourFast = false;
      for (std::uint32_t a = adjStart[i]; a < adjStart[i + 1] && !neighbourFast; ++a) {
        const auto& p = pairs[adj[a]];
        neighbourFast = fast[p.i == i ? p.j : p.i] != 0;
      }
      if (fast[i] || neighbourFast) {
        restartWindow(i);
        if (!awake[i]) awake[i] = 2;
        continue;
      }
      if (!awake[i]) continue;
      ++slowSteps[i];
      if (awake[i] == 1 && slowSteps[i] >= need) {
        const double turn =
            2 * std::asin(std::min(1.0, (qRest[i].conjugate() * q[i]).vec().norm()));
        const double moved = (x[i] - xRest[i]).norm() + turn * tmpl[tid[i]].radiusMm;
        if (moved < vSleep * static_cast<double>(slowSteps[i]) * dt) {
          awake[i] = 0;
          v[i].setZero();
          L[i].setZero();
          omegaW[i].setZero();
        } else {
          restartWindow(i);
        }
      }
    }
  }
  for (std::int64_t k = 0; k < na; ++k) fast[awakeAt(k)] = 0;
  // The awake list for the next step, from the only particles whose flags could change.
  if (listed) awakeList.clear();
  std::size_t integrated = 0;
  for (std::int64_t k = 0; k < nl; ++k) {
    const std::size_t i = liveAt(k);
    if (awake[i] == 2) awake[i] = 1;
    integrated += awake[i];
    if (listed && awake[i]) awakeList.push_back(static_cast<std::uint32_t>(i));
  }
  awakeListValid = listed;
  return integrated;
}

}  // namespace voxpack::packer::dem
