// Time integration: velocity Verlet for the centres, a midpoint rotation with fixed angular
// momentum in principal axes, and the blow-up guard.
#include <algorithm>
#include <cmath>

#include "system_impl.hpp"
#include "voxpack/core/errors.hpp"

namespace voxpack::packer::dem {
namespace {

void quatStep(const Quat& q, const Vec3& theta, Quat& out) {
  const double a = theta.norm();
  Quat dq = Quat::Identity();
  if (a > 0) dq = Quat(Eigen::AngleAxisd(a, theta / a));
  out = (q * dq).normalized();
}

}  // namespace

// The first half kick and the drift of every awake particle, with the blow-up guard and the
// largest move since the neighbour build (for the rebuild test) in the same pass: one
// parallel region a step instead of four passes. Returns that largest squared move. With the
// live set (forces.cpp) it visits the awake list only, and takes the largest move over the
// particles integrated since the build: every other one is still where the build saw it.
double DemSystem::Impl::kickDrift(double h) {
  const bool listed = awakeListValid && !liveAll;
  const std::int64_t n = static_cast<std::int64_t>(listed ? awakeList.size() : x.size());
  const int nt = particleThreads();
  const double bound2 = speedBound * speedBound;
  double maxMove2 = 0;
  int blownUp = 0;
#pragma omp parallel for num_threads(nt) schedule(static, 32) reduction(max         \
                                                                        : maxMove2) \
    reduction(|                                                                     \
              : blownUp)
  for (std::int64_t k = 0; k < n; ++k) {
    const std::size_t i =
        listed ? awakeList[static_cast<std::size_t>(k)] : static_cast<std::size_t>(k);
    if (awake[i]) {
      v[i] += (h / tmpl[tid[i]].massG) * F[i];
      L[i] += h * T[i];
      x[i] += dt * v[i];
      // A closed-form sphere's orientation changes neither its contacts nor its voxels; its
      // spin lives in L alone (friction reads it), so the rotation is not integrated.
      if (!closedForm[tid[i]]) {
        // Rotation with fixed angular momentum: midpoint body rate, principal axes.
        const Vec3& inertia = tmpl[tid[i]].inertiaG;
        Quat mid;
        quatStep(q[i], 0.5 * dt * bodyRate(q[i].toRotationMatrix(), L[i], inertia), mid);
        quatStep(q[i], dt * bodyRate(mid.toRotationMatrix(), L[i], inertia), q[i]);
      }
      // A blow-up (a non-finite state, or a particle far faster than anything the scene
      // can produce) stops the run; the driver keeps the last good state.
      if (!x[i].allFinite() || !v[i].allFinite() || !L[i].allFinite() ||
          !q[i].coeffs().allFinite() || v[i].squaredNorm() > bound2)
        blownUp |= 1;
    }
    maxMove2 = std::max(maxMove2, (x[i] - xBuild[i]).squaredNorm());
  }
  if (blownUp) diverged = true;
  if (!listed) {
    movedAll = true;
    return maxMove2;
  }
  movedMark.resize(x.size(), 0);
  for (const std::uint32_t i : awakeList)
    if (!movedMark[i]) {
      movedMark[i] = 1;
      movedList.push_back(i);
    }
  const std::size_t m = movedAll ? x.size() : movedList.size();
  for (std::size_t k = 0; k < m; ++k) {
    const std::size_t i = movedAll ? k : movedList[k];
    maxMove2 = std::max(maxMove2, (x[i] - xBuild[i]).squaredNorm());
  }
  return maxMove2;
}

void DemSystem::Impl::stepOnce() {
  if (!resolved) throw InternalError("DemSystem::step before resolve()");
  if (diverged) return;
  const std::size_t n = x.size();
  if (needRebuild) rebuildNeighbours();
  if (diverged) return;
  if (!forcesValid) computeForces(0);
  const double maxMove2 = kickDrift(0.5 * dt);
  t += dt;
  if (diverged) return;
  if (4 * maxMove2 > skin * skin) rebuildNeighbours();
  if (diverged) return;
  computeForces(0.5 * dt);  // and the closing half kick
  // A passage through a wall is transient (the end state may hold no overlap at all), so
  // the deepest overlap and the steps with an interpenetration are kept over the run. Only
  // the step's closing evaluation counts: the one after particles are added, and the
  // all-awake measurement at the end, re-evaluate states that are not steps.
  runMaxWallFraction = std::max(runMaxWallFraction, maxWallFraction);
  if (interpenetrations > 0) ++interpenetratingSteps;
  const std::size_t integrated = sleepUpdate();
  ++counters.steps;
  counters.particleSteps += n;
  counters.integratedParticleSteps += integrated;
}

}  // namespace voxpack::packer::dem
