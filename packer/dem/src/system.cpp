// DemSystem set-up (option checks, stiffness and time step, particles) and its accessors;
// the integrator itself lives in the files named in system_impl.hpp. docs/dem.md.
#include <omp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>

#include "node_filter.hpp"
#include "system_impl.hpp"
#include "voxpack/core/errors.hpp"

namespace voxpack::packer::dem {

const char* statusName(DemStatus s) {
  switch (s) {
    case DemStatus::kSettled:
      return "settled";
    case DemStatus::kTimeCap:
      return "time_cap";
    case DemStatus::kCancelled:
      return "cancelled";
    case DemStatus::kDiverged:
      return "diverged";
  }
  return "unknown";
}

double DemSystem::Impl::rMax() const { return rMaxMm; }

double DemSystem::Impl::dMin() const { return dMinMm; }

int DemSystem::Impl::threadsFor(double items, double work) const {
  const int threads = std::max(1, opt.threads);
  return items >= static_cast<double>(opt.parallelMinItems) && work >= opt.parallelMinNodeWork
             ? threads
             : 1;
}

// The per-particle passes (kick and drift, the force sum, sleeping, the neighbour search) run
// on as many threads as the contact region: a team that is already awake costs a barrier
// (~1 us idle) per pass, while running these passes serially beside a parallel contact
// region left the second thread spinning for a quarter of its time on the paper's bed. They
// deal particles in interleaved chunks of 32 (the same chunks in every pass, so a particle's
// state stays with one core): plain static halves split the early-landed, sleeping particles
// from the falling ones.
int DemSystem::Impl::particleThreads() const {
  const double n = static_cast<double>(x.size());
  return threadsFor(n / 4, std::max(n * 64, workTotal));
}

Body DemSystem::Impl::body(std::size_t i) const {
  Body b;
  b.x = x[i];
  b.v = v[i];
  b.w = omegaW[i];
  b.invMass = invMass[tid[i]];
  b.invInertia = invInertia[tid[i]];
  b.rot = &rot[i];
  return b;
}

DemSystem::DemSystem(std::vector<ParticleTemplate> templates,
                     std::shared_ptr<const DemContainer> container, const DemOptions& options)
    : impl_(std::make_unique<Impl>()) {
  if (templates.empty()) throw InputError("dem: no particle template");
  if (!container) throw InputError("dem: no container");
  const DemOptions& o = options;
  if (!(o.friction >= 0) || !std::isfinite(o.friction))
    throw InputError("--friction must be >= 0 (got " + std::to_string(o.friction) + ")");
  if (!(o.restitution >= 0 && o.restitution <= 1))
    throw InputError("--restitution must be in 0..1 (got " + std::to_string(o.restitution) + ")");
  if (!(o.stiffnessNPerMm3 >= 0) || !std::isfinite(o.stiffnessNPerMm3))
    throw InputError("--stiffness must be >= 0 (0 = auto)");
  if (!(o.contactStiffnessCap >= 0) || !std::isfinite(o.contactStiffnessCap))
    throw InputError("--contact-stiffness-cap must be >= 0 (0 = none)");
  if (!(o.targetOverlap > 0 && o.targetOverlap < 0.2))
    throw InputError("--target-overlap must be in (0, 0.2)");
  if (!(o.timeStepS >= 0) || !std::isfinite(o.timeStepS))
    throw InputError("--time-step must be >= 0 (0 = auto)");
  if (!(o.timeStepFraction > 0 && o.timeStepFraction <= 0.1))
    throw InputError("--time-step-fraction must be in (0, 0.1]");
  if (o.tapCycles < 0) throw InputError("--tap-cycles must be >= 0");
  if (!(o.tapFrequencyHz > 0) || !(o.tapAmplitudeMm >= 0) || !(o.tapRestS >= 0))
    throw InputError("--tap-frequency must be > 0, --tap-amplitude and --tap-rest >= 0");
  if (!(o.maxTimeS > 0)) throw InputError("--max-time must be > 0");
  if (!(o.gravityMmPerS2 >= 0)) throw InputError("dem: gravity must be >= 0");
  impl_->tmpl = std::move(templates);
  // Once: a size distribution has one template per particle, and sleeping reads dMin()
  // every step.
  for (const auto& t0 : impl_->tmpl) {
    impl_->rMaxMm = std::max(impl_->rMaxMm, t0.radiusMm);
    impl_->dMinMm = std::min(impl_->dMinMm, t0.diameterMm);
  }
  impl_->container = std::move(container);
  impl_->opt = options;
  if (!(o.wallFriction >= 0 || o.wallFriction == -1) || !std::isfinite(o.wallFriction))
    throw InputError("--wall-friction must be >= 0 (or -1 = --friction)");
  if (!((o.wallRestitution >= 0 && o.wallRestitution <= 1) || o.wallRestitution == -1))
    throw InputError("--wall-restitution must be in 0..1 (or -1 = --restitution)");
  impl_->pairLaw = ContactLaw::calibrated(o.friction, o.restitution);
  impl_->wallLaw =
      ContactLaw::calibrated(o.wallFriction >= 0 ? o.wallFriction : o.friction,
                             o.wallRestitution >= 0 ? o.wallRestitution : o.restitution);
  if (!(o.rollingFriction >= 0) || !std::isfinite(o.rollingFriction))
    throw InputError("--rolling-friction must be >= 0 (got " + std::to_string(o.rollingFriction) +
                     ")");
  impl_->pairLaw.rolling = impl_->wallLaw.rolling = o.rollingFriction;
  impl_->skin = 0.1 * impl_->rMax();
  if (!(o.nodeSkinDiameters >= 0) || !std::isfinite(o.nodeSkinDiameters))
    throw InputError("dem: node skin must be >= 0");
  impl_->nodeSkin = o.nodeSkinDiameters * impl_->dMin();
  for (const auto& tp : impl_->tmpl) {
    impl_->toShape.push_back(tp.principalToShape.toRotationMatrix());
    Impl::Analytic a;
    a.form = tp.shape->analyticForm(a.r, a.hl);
    impl_->analytic.push_back(a);
    // Spheres along exact normals have a closed-form contact: no surface nodes at all.
    impl_->closedForm.push_back(a.form == 1 && o.contact == ContactModel::kLevelSet ? 1 : 0);
    impl_->invMass.push_back(1.0 / tp.massG);
    impl_->invInertia.push_back(tp.inertiaG.cwiseInverse());
    impl_->nodeCoords.push_back(nodeCoordsOf(tp.nodeP));
  }
  impl_->avx2 = __builtin_cpu_supports("avx2");
  Impl::Column& col = impl_->column;
  col.on = impl_->container->uprightColumn(col.cx, col.cy, col.r, col.floorZ);
}

DemSystem::~DemSystem() = default;

std::string DemSystem::resolve(double bedHeightMm) {
  Impl& s = *impl_;
  const DemOptions& o = s.opt;
  const double rho = o.densityGPerCm3 * 1e-3;
  const double g = o.gravityMmPerS2;
  double d = 0, mStar = 1e300, flat = 0;
  for (const auto& tp : s.tmpl) {
    d = std::max(d, tp.diameterMm);
    // A contact off the centre line also turns the particle: 1/m_eff = 1/m + |r x n|^2 / I
    // at the worst surface node (a sphere's normal forces have no lever: m_eff = m).
    double lever = 0;
    for (std::size_t n = 0; n < tp.nodeP.size(); ++n) {
      const Vec3 rn = tp.nodeP[n].cross(tp.nodeNormal[n]);
      lever = std::max(lever, rn.cwiseProduct(rn).cwiseQuotient(tp.inertiaG).sum());
    }
    const double mEff = 1.0 / (1.0 / tp.massG + lever);
    mStar = std::min(mStar, 0.5 * mEff);
    flat = std::max(flat, tp.flatAreaMm2);
  }
  const double dRef = s.dMin();
  if (o.stiffnessNPerMm3 > 0) {
    s.k = o.stiffnessNPerMm3 * 1e6;
  } else {
    // Load on one of ~3 supporting contacts of a particle at the bottom of the bed, carried
    // by the curved contact law F = k pi (d/4) delta^2 at delta = targetOverlap * d.
    const double h = std::max(bedHeightMm, 2 * dRef);
    const double load = rho * std::max(g, 1.0) * 0.6 * h * (kPi * dRef * dRef / 4) / 3;
    const double delta = o.targetOverlap * dRef;
    s.k = load / (kPi * (dRef / 4) * delta * delta);
  }
  // Deepest expected overlap: a particle falling from one injection zone height.
  const double fall = (o.rainHeightDiameters + 1) * d;
  const double v2 = 2 * g * fall + o.rainSpeedMmPerS * o.rainSpeedMmPerS;
  const double deltaImpact = std::cbrt(3 * mStar * v2 / (2 * s.k * kPi * dRef / 4));
  const double deltaMax = std::max(5 * o.targetOverlap * dRef, deltaImpact);
  const double kCurved = 2 * s.k * kPi * (dRef / 4) * deltaMax;
  s.kCap = o.contactStiffnessCap > 0 ? o.contactStiffnessCap * kCurved : 0;
  const double kContact =
      s.kCap > 0 ? std::min(s.kCap, std::max(s.k * flat, kCurved)) : std::max(s.k * flat, kCurved);
  s.tc = kPi * std::sqrt(mStar / kContact);
  std::string warning;
  const double dtMax = s.tc / 10;
  if (o.timeStepS > 0) {
    s.dt = o.timeStepS;
    if (s.dt > dtMax) {
      std::ostringstream w;
      w << "warning: --time-step " << o.timeStepS
        << " s is above the stability limit t_c/10 = " << dtMax << " s; clamped to " << dtMax;
      warning = w.str();
      s.dt = dtMax;
    }
  } else {
    s.dt = o.timeStepFraction * s.tc;
  }
  // Faster than this is a blow-up: a thousand times the speed of a fall of one diameter.
  s.speedBound = std::max(s.speedBound, 1e3 * std::sqrt(std::max(g, 1.0) * d));
  s.resolved = true;
  return warning;
}

std::size_t DemSystem::addParticle(std::size_t templateIndex, const Vec3& positionMm,
                                   const Quat& qShape, const Vec3& velocity,
                                   const Vec3& angularVelocity) {
  Impl& s = *impl_;
  if (templateIndex >= s.tmpl.size()) throw InputError("dem: bad template index");
  const ParticleTemplate& tp = s.tmpl[templateIndex];
  const Quat qp = (qShape.normalized() * tp.principalToShape).normalized();
  s.x.push_back(positionMm);
  s.v.push_back(velocity);
  s.q.push_back(qp);
  const Eigen::Matrix3d r = qp.toRotationMatrix();
  const Vec3 wb = r.transpose() * angularVelocity;
  s.L.push_back(r * tp.inertiaG.cwiseProduct(wb));
  s.F.push_back(Vec3::Zero());
  s.T.push_back(Vec3::Zero());
  s.tid.push_back(static_cast<std::uint32_t>(templateIndex));
  s.awake.push_back(1);
  s.slowSteps.push_back(0);
  s.xRest.push_back(positionMm);
  s.qRest.push_back(qp);
  s.wallXi.push_back({});
  for (auto& xi : s.wallXi.back()) xi.setZero();
  s.wallTouching.push_back(0);
  s.speedBound =
      std::max(s.speedBound, 100 * (velocity.norm() + angularVelocity.norm() * tp.radiusMm));
  s.wallF.push_back(Vec3::Zero());
  s.wallT.push_back(Vec3::Zero());
  s.wallElastic.push_back(0);
  s.wallDepth.push_back(0);
  s.wallLists.emplace_back();
  // Contact work of one particle: its node count, or a fixed 64 for a closed form.
  s.workTotal += s.closedForm[templateIndex] ? 64.0 : static_cast<double>(tp.nodeP.size());
  s.xBuild.push_back(positionMm);
  s.needRebuild = true;
  s.forcesValid = false;
  s.awakeListValid = false;
  return s.x.size() - 1;
}

void DemSystem::step(std::size_t n) {
  for (std::size_t s = 0; s < n; ++s) impl_->stepOnce();
}

std::size_t DemSystem::size() const { return impl_->x.size(); }
Vec3 DemSystem::position(std::size_t i) const { return impl_->x.at(i); }
Vec3 DemSystem::velocity(std::size_t i) const { return impl_->v.at(i); }
Vec3 DemSystem::angularVelocity(std::size_t i) const {
  const Impl& s = *impl_;
  return worldRate(s.q.at(i).toRotationMatrix(), s.L[i], s.tmpl[s.tid[i]].inertiaG);
}
Quat DemSystem::orientation(std::size_t i) const {
  return (impl_->q.at(i) * impl_->tmpl[impl_->tid[i]].principalToShape.conjugate()).normalized();
}
Vec3 DemSystem::angularMomentum(std::size_t i) const { return impl_->L.at(i); }
std::size_t DemSystem::templateOf(std::size_t i) const { return impl_->tid.at(i); }
bool DemSystem::asleep(std::size_t i) const { return !impl_->awake.at(i); }
double DemSystem::kineticEnergy() const {
  const Impl& s = *impl_;
  double e = 0;
  for (std::size_t i = 0; i < s.x.size(); ++i) {
    e += 0.5 * s.tmpl[s.tid[i]].massG * s.v[i].squaredNorm();
    e += 0.5 * s.L[i].dot(angularVelocity(i));
  }
  return e;
}
double DemSystem::potentialEnergy() const {
  const Impl& s = *impl_;
  double e = 0;
  for (std::size_t i = 0; i < s.x.size(); ++i)
    e += s.tmpl[s.tid[i]].massG * s.opt.gravityMmPerS2 * s.x[i].z();
  return e;
}
double DemSystem::elasticEnergy() const { return impl_->elastic; }
double DemSystem::maxOverlapMm() const { return impl_->maxDepth; }
double DemSystem::meanOverlapMm() const {
  return impl_->contactCount ? impl_->sumDepth / static_cast<double>(impl_->contactCount) : 0;
}
std::size_t DemSystem::contactCount() const { return impl_->contactCount; }
std::size_t DemSystem::interpenetrationCount() const { return impl_->interpenetrations; }
double DemSystem::maxOverlapWallFraction() const { return impl_->maxWallFraction; }
double DemSystem::runMaxOverlapWallFraction() const { return impl_->runMaxWallFraction; }
std::uint64_t DemSystem::interpenetratingSteps() const { return impl_->interpenetratingSteps; }
bool DemSystem::diverged() const { return impl_->diverged; }
double DemSystem::timeStepS() const { return impl_->dt; }
double DemSystem::contactTimeS() const { return impl_->tc; }
double DemSystem::stiffnessNPerMm3() const { return impl_->k * 1e-6; }
double DemSystem::contactStiffnessCapNPerMm() const { return impl_->kCap * 1e-6; }
double DemSystem::timeS() const { return impl_->t; }
const DemCounters& DemSystem::counters() const { return impl_->counters; }
const DemOptions& DemSystem::options() const { return impl_->opt; }
const std::vector<ParticleTemplate>& DemSystem::templates() const { return impl_->tmpl; }
void DemSystem::setWallMotion(double startS, int cycles) {
  impl_->tapStart = startS;
  impl_->tapCycles = cycles;
}
bool DemSystem::wallMoving() const { return impl_->wallMovingAt(impl_->t); }
void DemSystem::motionMeasures(double& maxSpeed, double& meanKinetic) const {
  const Impl& s = *impl_;
  maxSpeed = 0;
  double e = 0;
  for (std::size_t i = 0; i < s.x.size(); ++i) {
    if (!s.awake[i]) continue;
    maxSpeed = std::max(maxSpeed, s.v[i].norm());
    e += 0.5 * s.tmpl[s.tid[i]].massG * s.v[i].squaredNorm() + 0.5 * s.L[i].dot(angularVelocity(i));
  }
  meanKinetic = s.x.empty() ? 0 : e / static_cast<double>(s.x.size());
}
void DemSystem::measureAllContacts() {
  Impl& s = *impl_;
  if (s.diverged || !s.resolved || s.x.empty()) return;
  const std::vector<std::uint8_t> keep = s.awake;
  std::fill(s.awake.begin(), s.awake.end(), 1);
  s.awakeListValid = false;
  if (s.needRebuild) s.rebuildNeighbours();
  s.computeForces(0);
  s.awake = keep;
  // Every particle's sum now holds its contacts: the next evaluation recomputes them all.
  s.awakeListValid = false;
  s.liveAllNext = true;
}
void DemSystem::wakeAll() {
  for (auto& a : impl_->awake) a = 1;
  impl_->awakeListValid = false;
  for (std::size_t i = 0; i < impl_->x.size(); ++i) impl_->restartWindow(i);
}

}  // namespace voxpack::packer::dem
