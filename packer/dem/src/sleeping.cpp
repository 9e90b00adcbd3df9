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
    return n;
  }
  const double vSleep = opt.settleVelocity * std::sqrt(opt.gravityMmPerS2 * dMin());
  const double vWake = 10 * vSleep;
  const std::uint32_t need =
      static_cast<std::uint32_t>(std::max(1.0, std::ceil(opt.sleepTimeS / dt)));
  const int nt = particleThreads();
  fast.assign(n, 0);
#pragma omp parallel num_threads(nt)
  {
#pragma omp for schedule(static, 32)
    for (std::int64_t si = 0; si < sn; ++si) {
      const auto i = static_cast<std::size_t>(si);
      if (!awake[i]) continue;
      const ParticleTemplate& tp = tmpl[tid[i]];
      const double spin = worldRate(rot[i], L[i], tp.inertiaG).norm();  // rot: this step's pose
      const double speed = v[i].norm() + spin * tp.radiusMm;
      fast[i] = speed >= vWake ? 1 : 0;
    }
    // Each particle looks at its own neighbours: woken (2) when one of them moves fast.
#pragma omp for schedule(static, 32)
    for (std::int64_t si = 0; si < sn; ++si) {
      const auto i = static_cast<std::size_t>(si);
      // Not live in this step's forces: asleep with every neighbour asleep, so nothing here
      // can wake it (selectLive in forces.cpp).
      if (!(liveMark[i] & 1)) continue;
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
  std::size_t integrated = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (awake[i] == 2) awake[i] = 1;
    integrated += awake[i];
  }
  return integrated;
}

}  // namespace voxpack::packer::dem
