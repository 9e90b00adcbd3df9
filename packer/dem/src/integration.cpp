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

void DemSystem::Impl::kick(double h) {
  const std::int64_t n = static_cast<std::int64_t>(x.size());
  const int nt = threadsFor(static_cast<double>(n) / 4, static_cast<double>(n) * 64);
#pragma omp parallel for num_threads(nt) schedule(static)
  for (std::int64_t si = 0; si < n; ++si) {
    const std::size_t i = static_cast<std::size_t>(si);
    if (!awake[i]) continue;
    v[i] += (h / tmpl[tid[i]].massG) * F[i];
    L[i] += h * T[i];
  }
}

void DemSystem::Impl::drift() {
  const std::int64_t n = static_cast<std::int64_t>(x.size());
  const int nt = threadsFor(static_cast<double>(n) / 4, static_cast<double>(n) * 64);
#pragma omp parallel for num_threads(nt) schedule(static)
  for (std::int64_t si = 0; si < n; ++si) {
    const std::size_t i = static_cast<std::size_t>(si);
    if (!awake[i]) continue;
    x[i] += dt * v[i];
    // A closed-form sphere's orientation changes neither its contacts nor its voxels; its
    // spin lives in L alone (friction reads it), so the rotation is not integrated.
    if (closedForm[tid[i]]) continue;
    // Rotation with fixed angular momentum: midpoint body rate, principal axes.
    const Vec3& inertia = tmpl[tid[i]].inertiaG;
    Quat mid;
    quatStep(q[i], 0.5 * dt * bodyRate(q[i].toRotationMatrix(), L[i], inertia), mid);
    quatStep(q[i], dt * bodyRate(mid.toRotationMatrix(), L[i], inertia), q[i]);
  }
}

// A blow-up (a non-finite state, or a particle far faster than anything the scene can
// produce) stops the run; the driver keeps the last good state.
void DemSystem::Impl::checkFinite() {
  const std::size_t n = x.size();
  const double bound2 = speedBound * speedBound;
  for (std::size_t i = 0; i < n && !diverged; ++i) {
    if (!awake[i]) continue;
    if (!x[i].allFinite() || !v[i].allFinite() || !L[i].allFinite() || !q[i].coeffs().allFinite() ||
        v[i].squaredNorm() > bound2)
      diverged = true;
  }
}

void DemSystem::Impl::stepOnce() {
  if (!resolved) throw InternalError("DemSystem::step before resolve()");
  if (diverged) return;
  const std::size_t n = x.size();
  if (needRebuild) rebuildNeighbours();
  if (diverged) return;
  if (!forcesValid) computeForces();
  kick(0.5 * dt);
  drift();
  t += dt;
  checkFinite();
  if (diverged) return;
  double maxMove2 = 0;
  for (std::size_t i = 0; i < n; ++i)
    maxMove2 = std::max(maxMove2, (x[i] - xBuild[i]).squaredNorm());
  if (4 * maxMove2 > skin * skin) rebuildNeighbours();
  if (diverged) return;
  computeForces();
  kick(0.5 * dt);
  sleepUpdate();
  ++counters.steps;
  counters.particleSteps += n;
  for (std::size_t i = 0; i < n; ++i) counters.integratedParticleSteps += awake[i] ? 1 : 0;
}

}  // namespace voxpack::packer::dem
