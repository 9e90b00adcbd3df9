// The contact law: spring-dashpot normal force (per node, or in closed form for spheres),
// damping calibrated to the restitution for the local force exponent, Coulomb friction.
#include <algorithm>
#include <cmath>

#include "system_impl.hpp"

namespace voxpack::packer::dem {
namespace {

// Restitution of one impact with F = delta^p, damping 2 zeta sqrt(K), K = dF/d(delta),
// unit mass and unit approach speed (the result does not depend on either). The dashpot
// cannot pull: the force is clamped at zero, as in the DEM.
double powerLawRestitution(double zeta, double p) {
  double x = 0, v = 1;
  const double h = 1e-3;
  for (int s = 0; s < 200000; ++s) {
    const double xp = std::max(x, 0.0);
    const double f =
        std::min(0.0, -std::pow(xp, p) - 2 * zeta * std::sqrt(p * std::pow(xp, p - 1)) * v);
    v += h * f;
    x += h * v;
    if (x <= 0 && v < 0) return -v;
  }
  return 0;
}

// Damping ratio that gives restitution e for the law F ~ delta^p (bisection).
double calibratedZeta(double e, double p) {
  if (e >= 1) return 0;
  const double target = std::max(e, 1e-3);
  double lo = 0, hi = 4;
  for (int it = 0; it < 30; ++it) {
    const double mid = 0.5 * (lo + hi);
    (powerLawRestitution(mid, p) > target ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

Vec3 relativeVelocity(const Body& a, const Body& b, const Vec3& p) {
  return a.v + a.w.cross(p - a.x) - b.v - b.w.cross(p - b.x);
}

}  // namespace

ContactLaw ContactLaw::calibrated(double friction, double restitution) {
  ContactLaw law;
  law.friction = friction;
  for (std::size_t i = 0; i < law.zeta.size(); ++i)
    law.zeta[i] = calibratedZeta(restitution, 1.0 + 0.25 * static_cast<double>(i));
  return law;
}

// Tangential spring and Coulomb limit at the contact point cp (normal n on A), added to out.
void DemSystem::Impl::friction(const Vec3& n, const Vec3& cp, double fnMag, double kSum,
                               double zetaC, double mStar, const Body& a, const Body& b,
                               const ContactLaw& law, const Vec3& xiOld, ContactOut& out) const {
  const Vec3 vrel = relativeVelocity(a, b, cp);
  const Vec3 vt = vrel - vrel.dot(n) * n;
  // Keep the spring in the current tangent plane with its length (contact rotation).
  Vec3 xi = xiOld - xiOld.dot(n) * n;
  const double oldLen = xiOld.norm(), newLen = xi.norm();
  if (newLen > 0) xi *= oldLen / newLen;
  xi += vt * dt;
  const double kt = opt.tangentialStiffnessRatio * kSum;
  const double etaT = 2 * zetaC * std::sqrt(mStar * kt);
  Vec3 ft = -kt * xi - etaT * vt;
  const double ftMag = ft.norm();
  const double limit = law.friction * fnMag;
  if (ftMag > limit) {
    ft = ftMag > 0 ? Vec3(ft * (limit / ftMag)) : Vec3::Zero();
    xi = kt > 0 ? Vec3(-(ft + etaT * vt) / kt) : Vec3::Zero();
  }
  out.force += ft;
  out.torqueA += (cp - a.x).cross(ft);
  out.xi = xi;
  rolling(n, cp, fnMag, a, b, law, out);
}

// Rolling resistance, constant directional torque (Ai et al. 2011, model A; LIGGGHTS
// `rolling_friction cdt`): a couple of magnitude mu_r |Fn| R_eff against the relative
// rolling rate (the relative spin without its part about the normal, which is torsion).
// R_eff = R_a R_b / (R_a + R_b), each R the distance of the contact point from the centre
// (a sphere's radius; a wall: R_a). A solid sphere rolling on a plane then decelerates at
// 5/7 mu_r g. Plain CDT flips sign every step once a particle has (almost) stopped rolling,
// so the couple is capped at what would cut the relative rolling rate by 1/kRollCap in one
// step: a particle at rest stays at rest, and a dozen contacts capped together cannot
// overshoot.
void DemSystem::Impl::rolling(const Vec3& n, const Vec3& cp, double fnMag, const Body& a,
                              const Body& b, const ContactLaw& law, ContactOut& out) const {
  if (!(law.rolling > 0) || !(fnMag > 0)) return;
  constexpr double kRollCap = 8;
  Vec3 wr = a.w - b.w;
  wr -= wr.dot(n) * n;
  const double wMag = wr.norm();
  if (!(wMag > 0)) return;
  const Vec3 u = wr / wMag;
  const double ra = (cp - a.x).norm();
  const double rb = b.rot ? (cp - b.x).norm() : 0.0;
  const double rEff = rb > 0 ? ra * rb / (ra + rb) : ra;
  double couple = law.rolling * fnMag * rEff;
  const double invI = a.inverseInertiaAbout(u) + b.inverseInertiaAbout(u);
  if (invI > 0) couple = std::min(couple, wMag / (kRollCap * invI * dt));
  out.torqueA -= couple * u;
}

// Spring-dashpot over the hits of one contact, plus the tangential spring of the contact.
ContactOut DemSystem::Impl::nodeContact(const std::vector<Hit>& hits, const Body& a, const Body& b,
                                        const ContactLaw& law, const Vec3& xiOld) const {
  ContactOut out;
  if (hits.empty()) return out;
  out.touching = true;
  double wd = 0;
  Vec3 spring = Vec3::Zero(), cp = Vec3::Zero();
  for (const Hit& h : hits) {
    spring += h.kw * h.depth * h.dir;
    cp += h.kw * h.depth * h.p;
    wd += h.kw * h.depth;
    out.maxDepth = std::max(out.maxDepth, h.depth);
    out.elastic += 0.5 * h.kw * h.depth * h.depth;
    out.wallFraction = std::max(out.wallFraction, h.wallFraction);
  }
  cp /= wd;
  const double springMag = spring.norm();
  const Vec3 nHat = springMag > 0 ? Vec3(spring / springMag) : Vec3(0, 0, 1);
  // Tangent stiffness K = dF/d(delta) of the contact: node stiffnesses projected on the
  // contact normal (a voxel face across the normal adds no normal stiffness).
  double kSum = 0;
  for (const Hit& h : hits) kSum += h.kw * std::abs(h.dir.dot(nHat));
  if (!(kSum > 0)) return out;
  // Stiffness ceiling: a wide flat contact (face on face) would otherwise be far stiffer
  // than the curved contacts the time step is made for; it saturates at kCap instead.
  const double scale = kCap > 0 && kSum > kCap ? kCap / kSum : 1.0;
  kSum *= scale;
  out.elastic *= scale;
  // Local force law F ~ delta^p (p = 1 flat faces, 2 sphere caps) picks the damping
  // ratio that gives the requested restitution for that law (calibrated at start-up).
  const double p = springMag > 0 ? kSum * out.maxDepth / springMag : 1.0;
  const double zetaC = law.zetaFor(p);
  // Effective mass along the contact normal at the contact point, rotation included: a
  // cylinder landing on its rim turns as it stops, and damping with m alone would miss e.
  const double mStar = 1.0 / (a.inverseMassAlong(cp, nHat) + b.inverseMassAlong(cp, nHat));
  // Contact damping 2 zeta sqrt(m* K), shared among the nodes like their stiffness.
  const double eta = 2 * zetaC * std::sqrt(mStar * kSum);
  const double etaPerK = eta / kSum;
  Vec3 springF = Vec3::Zero(), dampF = Vec3::Zero(), springT = Vec3::Zero(), dampT = Vec3::Zero();
  for (const Hit& h : hits) {
    const Vec3 vrel = relativeVelocity(a, b, h.p);
    const double c = std::abs(h.dir.dot(nHat));
    const Vec3 fs = (scale * h.kw * h.depth) * h.dir;
    const Vec3 fd = (-scale * h.kw * c * etaPerK * vrel.dot(h.dir)) * h.dir;
    springF += fs;
    dampF += fd;
    springT += (h.p - a.x).cross(fs);
    dampT += (h.p - a.x).cross(fd);
  }
  // A dashpot never pulls: when a separating contact's damping would outweigh its springs,
  // the damping is cut so the normal force is zero (the restitution calibration does the same).
  const double fs = springF.dot(nHat), fd = dampF.dot(nHat);
  const double keep = fs + fd < 0 && fd < 0 ? fs / -fd : 1.0;
  out.force = springF + keep * dampF;
  out.torqueA = springT + keep * dampT;
  if (springMag > 0)
    friction(nHat, cp, std::max(0.0, out.force.dot(nHat)), kSum, zetaC, mStar, a, b, law, xiOld,
             out);
  return out;
}

// Closed form: normal force k V (V the overlap volume, what the node sum converges to),
// contact stiffness k A (A = dV/d delta, the overlap's cross-section), one contact point.
ContactOut DemSystem::Impl::closedContact(double volume, double area, double depth, const Vec3& n,
                                          const Vec3& cp, const Body& a, const Body& b,
                                          const ContactLaw& law, const Vec3& xiOld) const {
  ContactOut out;
  out.touching = true;
  out.maxDepth = depth;
  double kSum = k * area, spring = k * volume;
  if (!(kSum > 0)) return out;
  const double scale = kCap > 0 && kSum > kCap ? kCap / kSum : 1.0;
  kSum *= scale;
  spring *= scale;
  out.elastic = spring * depth / 3;  // integral of F ~ delta^2
  const double zetaC = law.zetaFor(kSum * depth / spring);
  // Closed-form contacts (sphere-sphere, sphere-wall) push along the line of centres: no
  // turn, so the effective mass is the translational one.
  const double mStar = 1.0 / (a.invMass + b.invMass);
  const double eta = 2 * zetaC * std::sqrt(mStar * kSum);
  const double fn = std::max(0.0, spring - eta * relativeVelocity(a, b, cp).dot(n));
  out.force = fn * n;
  out.torqueA = (cp - a.x).cross(out.force);
  friction(n, cp, fn, kSum, zetaC, mStar, a, b, law, xiOld, out);
  return out;
}

}  // namespace voxpack::packer::dem
