// Contact physics beyond the paper: closed-form spheres, no pulling dashpots, rotation in the
// damping mass, wall contact regions, friction on an incline, conservation, blow-ups.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <memory>

#include "analytic.hpp"
#include "voxpack/packer/dem_geometry.hpp"
#include "voxpack/packer/shape.hpp"

namespace voxpack::test {
namespace {

using packer::dem::buildTemplate;
using packer::dem::DemOptions;
using packer::dem::DemSystem;

constexpr double kG = 9810.0;  // mm/s^2

DemOptions quiet() {
  DemOptions o;
  o.stiffnessNPerMm3 = 1.0;
  o.sleeping = false;
  o.threads = 1;
  o.gravityMmPerS2 = 0;
  o.friction = 0;
  return o;
}

std::unique_ptr<DemSystem> system1(std::shared_ptr<const DemShape> shape, double voxelMm,
                                   const DemOptions& o, std::shared_ptr<const DemContainer> box) {
  std::vector<packer::dem::ParticleTemplate> t{buildTemplate(shape, voxelMm, o.densityGPerCm3)};
  auto sys = std::make_unique<DemSystem>(std::move(t), std::move(box), o);
  sys->resolve(10.0);
  return sys;
}

// A contact that separates fast (heavy damping) would pull with a dashpot force -eta v larger
// than the spring: clamped, the separating sphere's speed never drops.
TEST(DemContacts, SeparatingContactNeverPulls) {
  for (bool closed : {false, true}) {
    DemOptions o = quiet();
    o.restitution = 0.05;
    std::shared_ptr<const DemShape> shape =
        closed ? std::shared_ptr<const DemShape>(std::make_shared<TestFastSphere>(3.0))
               : std::make_shared<TestSphere>(3.0);
    auto sys = system1(shape, 0.15, o, std::make_shared<TestBox>(40));
    sys->addParticle(0, Vec3(0, 0, 1.5 - 0.003), Quat::Identity(), Vec3(0, 0, 300));
    double vz = sys->velocity(0).z();
    int drops = 0;
    for (int s = 0; s < 3000 && sys->position(0).z() < 1.6; ++s) {
      sys->step();
      const double now = sys->velocity(0).z();
      if (now < vz - 1e-9 * std::abs(vz)) ++drops;
      vz = now;
    }
    EXPECT_EQ(drops, 0) << (closed ? "closed form" : "nodes");
    EXPECT_GE(vz, 300.0);  // and it left the floor
  }
}

// Drops a sphere from a gap H (gravity on) and returns the next apex gap.
double apexAfterBounce(std::shared_ptr<const DemShape> shape, const DemOptions& o, double gap) {
  auto sys = system1(shape, 0.15, o, std::make_shared<TestBox>(40));
  sys->addParticle(0, Vec3(0, 0, 1.5 + gap), Quat::Identity());
  bool touched = false;
  for (int s = 0; s < 400000; ++s) {
    sys->step();
    const double z = sys->position(0).z(), vz = sys->velocity(0).z();
    if (z < 1.5) touched = true;
    if (touched && z > 1.5 && vz <= 0) return z - 1.5;
  }
  return -1;
}

// Closed-form spheres rebound to e^2 H; the wall's own restitution wins over the pair's.
TEST(DemContacts, ClosedFormSphereReboundsToESquaredWithItsWallRestitution) {
  DemOptions o = quiet();
  o.gravityMmPerS2 = kG;
  o.restitution = 0.5;
  const auto sphere = std::make_shared<TestFastSphere>(3.0);
  EXPECT_NEAR(apexAfterBounce(sphere, o, 3.0) / (0.25 * 3.0), 1.0, 0.10);
  o.restitution = 0.1;
  o.wallRestitution = 0.8;
  EXPECT_NEAR(apexAfterBounce(sphere, o, 3.0) / (0.64 * 3.0), 1.0, 0.10);
}

// A cylinder d 5.4 x l 3.8 mm tilted by `tiltRad` about x falls on its lowest rim point at
// 300 mm/s (no gravity, no friction) onto a floor of face stiffness k (N/mm^3). Returns the
// rim point's normal speed after the contact over 300 (Newton's restitution) and the
// restitution from the kinetic energy lost, (1 - e^2) of 1/2 m* v^2 with m* the effective
// mass at the rim at first touch. `cap`: DemOptions::contactStiffnessCap.
void rimImpact(double tiltRad, double stiffness, double cap, double e, double& kinematic,
               double& energy) {
  DemOptions o = quiet();
  o.restitution = e;
  o.stiffnessNPerMm3 = stiffness;
  o.contactStiffnessCap = cap;
  const double r = 2.7, hl = 1.9;
  auto sys =
      system1(std::make_shared<TestCylinder>(5.4, 3.8), 0.27, o, std::make_shared<TestBox>(60));
  const Quat q(Eigen::AngleAxisd(tiltRad, Vec3::UnitX()));
  const Vec3 rim(0, -r, -hl);  // shape frame: the lowest rim point at this tilt
  const double low = -(q * rim).z();
  sys->addParticle(0, Vec3(0, 0, low + 0.05), q, Vec3(0, 0, -300));
  const double m = sys->templates()[0].massG;
  const double ix = m * (3 * r * r + 4 * hl * hl) / 12;  // about the tilt axis
  const double lever = (q * rim).y();
  const double mStar = 1.0 / (1.0 / m + lever * lever / ix);
  const double ke0 = sys->kineticEnergy();
  auto rimVelocity = [&] {
    const Vec3 arm = sys->orientation(0) * rim;
    return Vec3(sys->velocity(0) + sys->angularVelocity(0).cross(arm)).z();
  };
  auto rimHeight = [&] { return (sys->position(0) + sys->orientation(0) * rim).z(); };
  bool touched = false;
  for (int s = 0; s < 200000; ++s) {
    sys->step();
    if (rimHeight() < 0) touched = true;
    if (touched && rimHeight() > 0.002) break;
  }
  ASSERT_TRUE(touched);
  kinematic = rimVelocity() / 300.0;
  energy = std::sqrt(std::max(0.0, 1 - (ke0 - sys->kineticEnergy()) / (0.5 * mStar * 300 * 300)));
}

// A cylinder landing on its rim stops and spins: the contact point's normal speed, not the
// centre's, must come back with e. Newton's restitution holds for an impulsive contact: at
// k 100 N/mm^3 (0.5 ms of contact) the rim returns 0.506 (45 deg) and 0.504 (20 deg) of its
// speed for e 0.5. A soft contact lets the cylinder turn while touching (k 0.1: ~12 deg in
// 4.5 ms, the rim's lever 0.57 -> 1.23 mm), and the rim's speed afterwards then also holds
// that turn: 0.62 for e 0.5, 1.19 for e 1 with the energy kept to 1e-5 (the number this test
// used to report as the 10 % goal not met). The energy lost there still gives e 0.48 (no
// stiffness ceiling: with gravity 0 the ceiling sits low and this contact passes it, where
// it dissipates more, 0.43; docs/dem.md). At 20 deg (lever 1.9 mm, m* = 0.46 m) a damping
// mass without rotation returns 0.38.
TEST(DemContacts, RimImpactReboundsWithRequestedRestitution) {
  for (const double tiltDeg : {45.0, 20.0})
    for (const double e : {0.5, 0.2, 0.8}) {
      double kinematic = 0, energy = 0;
      rimImpact(tiltDeg * kPi / 180, 100.0, 1.0, e, kinematic, energy);
      RecordProperty(
          "rim_restitution_" + std::to_string(static_cast<int>(tiltDeg)) + "_" + std::to_string(e),
          std::to_string(kinematic));
      EXPECT_NEAR(kinematic / e, 1.0, 0.1) << tiltDeg << " deg, e " << e;
      EXPECT_NEAR(energy / e, 1.0, 0.1) << tiltDeg << " deg, e " << e;
    }
  double kinematic = 0, energy = 0;
  rimImpact(kPi / 4, 0.1, 0.0, 0.5, kinematic, energy);
  RecordProperty("rim_restitution_soft_energy", std::to_string(energy));
  EXPECT_NEAR(energy / 0.5, 1.0, 0.1);
}

// Ring B (d 6, di 3, l 2 mm; walls 1.5 mm) standing on edge (axis x) falls on the wall of
// ring A lying flat: the most interpenetrating pairs seen and the deepest overlap over the
// thinnest wall, over the impact (no gravity, no friction, no walls near).
void ringOnRing(double stiffness, double speed, std::size_t& mostInterpenetrating,
                double& deepestWallFraction) {
  DemOptions o = quiet();
  o.stiffnessNPerMm3 = stiffness;
  o.contactStiffnessCap = 0;
  const auto ring = packer::dem::demShape(packer::parseShape("ring:d=6,di=3,l=2"));
  auto sys = system1(ring, 0.2, o, std::make_shared<TestBox>(200));
  EXPECT_NEAR(sys->templates()[0].thinWallMm, 1.5, 0.01);
  sys->addParticle(0, Vec3(0, 0, 50), Quat::Identity());
  // B's lowest point (its outer rim) 0.05 mm above A's top face, over A's wall centre line.
  sys->addParticle(0, Vec3(0, 2.25, 50 + 1 + 3 + 0.05),
                   Quat(Eigen::AngleAxisd(kPi / 2, Vec3::UnitY())), Vec3(0, 0, -speed));
  mostInterpenetrating = 0;
  deepestWallFraction = 0;
  const auto steps = static_cast<std::size_t>(8.0 / speed / sys->timeStepS()) + 1;
  for (std::size_t s = 0; s < steps; ++s) {
    sys->step();
    mostInterpenetrating = std::max(mostInterpenetrating, sys->interpenetrationCount());
    deepestWallFraction = std::max(deepestWallFraction, sys->maxOverlapWallFraction());
  }
  // The system's own run-long record agrees with the maximum taken here step by step.
  EXPECT_DOUBLE_EQ(sys->runMaxOverlapWallFraction(), deepestWallFraction);
  EXPECT_EQ(sys->interpenetratingSteps() > 0, mostInterpenetrating > 0);
}

// Holed shapes: a gentle impact stays far from the thinnest wall and is no
// interpenetration; a far too soft one drives B's rim through A's wall (past its medial
// surface, where the level-set normal flips) and is counted.
TEST(DemContacts, RingThroughRingWallIsCountedAsInterpenetration) {
  std::size_t most = 0;
  double deepest = 0;
  ringOnRing(1.0, 100.0, most, deepest);
  RecordProperty("gentle_wall_fraction", std::to_string(deepest));
  EXPECT_EQ(most, 0u);
  EXPECT_GT(deepest, 0.0);  // they touched
  EXPECT_LT(deepest, 0.05);
  ringOnRing(1e-4, 2000.0, most, deepest);
  RecordProperty("violent_wall_fraction", std::to_string(deepest));
  EXPECT_GE(most, 1u);
  EXPECT_GT(deepest, packer::dem::kInterpenetrationWallFraction);
}

// B stacked on A, 0.01 mm to the side and sunk 0.15 mm: A's side nodes just under its rim lie
// 0.01 mm inside B's side, where B's normal is its side normal, the same as theirs (the
// medial surface of B's bottom edge meets the surface there). An ordinary stacking contact
// at a few percent of the wall, which the former flipped-normal test counted as
// interpenetration (settled beds of 10^4 cylinders reported 97 such pairs). Cylinders
// (convex) and rings (holed) alike.
TEST(DemContacts, ShallowContactAtAnEdgeIsNotInterpenetration) {
  for (const char* spec : {"cylinder:d=2,l=2", "ring:d=6,di=3,l=2"}) {
    const auto shape = packer::dem::demShape(packer::parseShape(spec));
    auto sys = system1(shape, 0.1, quiet(), std::make_shared<TestBox>(200));
    sys->addParticle(0, Vec3(0, 0, 50), Quat::Identity());
    sys->addParticle(0, Vec3(0.01, 0, 50 + 2 - 0.15), Quat::Identity());
    sys->step();
    EXPECT_GT(sys->contactCount(), 0u) << spec;
    EXPECT_LT(sys->maxOverlapWallFraction(), 0.15) << spec;
    EXPECT_EQ(sys->interpenetrationCount(), 0u) << spec;
    EXPECT_EQ(sys->interpenetratingSteps(), 0u) << spec;
  }
}

// A sphere thrown at a round wall at 45 degrees azimuth: one contact region, one damper
// (six axis classes made it two contacts, each damped with the full mass).
TEST(DemContacts, RoundWallIsOneContactRegion) {
  for (bool closed : {false, true}) {
    DemOptions o = quiet();
    o.restitution = 0.5;
    std::shared_ptr<const DemShape> shape =
        closed ? std::shared_ptr<const DemShape>(std::make_shared<TestFastSphere>(3.0))
               : std::make_shared<TestSphere>(3.0);
    auto sys = system1(shape, 0.15, o, std::make_shared<TestColumn>(20.0));
    const Vec3 u = Vec3(1, 1, 0).normalized();
    sys->addParticle(0, u * (10 - 1.5 - 0.05) + Vec3(0, 0, 50), Quat::Identity(), 300 * u);
    for (int s = 0; s < 200000; ++s) {
      sys->step();
      if (sys->velocity(0).dot(u) < 0 && (sys->position(0) - Vec3(0, 0, 50)).norm() < 8.3) break;
    }
    // Closed form within 10 %; nodes on the concave wall measured 0.433 (two contacts each
    // damped with the full mass would give ~0.3).
    EXPECT_NEAR(-sys->velocity(0).dot(u) / 300.0, 0.5, closed ? 0.05 : 0.1)
        << (closed ? "closed" : "nodes");
  }
}

// Velocity down the slope of a cylinder standing on its face on an incline, at 0.1 and
// 0.4 s (after the landing transient); displacement between them in `moved`.
void slideOnIncline(double angle, double mu, double& v1, double& v2, double& moved) {
  DemOptions o = quiet();
  o.gravityMmPerS2 = kG;
  o.friction = mu;
  o.restitution = 0.3;
  o.stiffnessNPerMm3 = 0.01;
  auto sys = system1(std::make_shared<TestCylinder>(5.4, 3.8), 0.27, o,
                     std::make_shared<TestIncline>(angle));
  const Quat q(Eigen::AngleAxisd(angle, Vec3::UnitX()));
  const Vec3 n = q * Vec3::UnitZ();
  sys->addParticle(0, 1.9 * n, q);
  const Vec3 down(0, -std::cos(angle), -std::sin(angle));
  sys->step(static_cast<std::size_t>(0.1 / sys->timeStepS()));
  const double t1 = sys->timeS();
  const Vec3 x1 = sys->position(0);
  v1 = sys->velocity(0).dot(down);
  sys->step(static_cast<std::size_t>(0.3 / sys->timeStepS()));
  v2 = sys->velocity(0).dot(down);
  moved = (sys->position(0) - x1).dot(down);
  v2 = (v2 - v1) / (sys->timeS() - t1);  // mean acceleration
}

TEST(DemContacts, BlockOnInclineSticksBelowAtanMuSlidesAbove) {
  const double mu = 0.5, critical = std::atan(mu), twoDegrees = 2 * kPi / 180;
  double v1 = 0, acc = 0, moved = 0;
  slideOnIncline(critical - twoDegrees, mu, v1, acc, moved);
  RecordProperty("stuck_moved_mm", std::to_string(moved));
  EXPECT_LT(std::abs(moved), 0.01);
  EXPECT_LT(std::abs(v1), 0.1);
  const double a = critical + twoDegrees;
  slideOnIncline(a, mu, v1, acc, moved);
  const double expected = kG * (std::sin(a) - mu * std::cos(a));
  RecordProperty("slide_acceleration_ratio", std::to_string(acc / expected));
  EXPECT_GT(moved, 5.0);
  EXPECT_NEAR(acc / expected, 1.0, 0.2);
}

// A sphere d 3 mm set rolling without slip at v0 along +x on the floor (gravity on, mu 0.5):
// how far it goes until it stops rolling (v_x < 1e-3 v0) or `capS` simulated, and when.
void rollOnFloor(std::shared_ptr<const DemShape> shape, double voxelMm, double restitution,
                 double muR, double v0, double capS, double& distance, double& timeS,
                 double& speed) {
  DemOptions o = quiet();
  o.gravityMmPerS2 = kG;
  o.friction = 0.5;
  o.rollingFriction = muR;
  o.restitution = restitution;
  auto sys = system1(shape, voxelMm, o, std::make_shared<TestBox>(200));
  // Resting overlap first (closed form k pi R delta^2 = m g), so the run starts on the floor.
  const double m = sys->templates()[0].massG, R = 1.5;
  const double delta = std::sqrt(m * kG / (sys->stiffnessNPerMm3() * 1e6 * kPi * R));
  sys->addParticle(0, Vec3(-80, 0, R - delta), Quat::Identity(), Vec3(v0, 0, 0),
                   Vec3(0, v0 / (R - delta), 0));
  const double x0 = sys->position(0).x();
  const auto every = static_cast<std::size_t>(std::max(1.0, 1e-4 / sys->timeStepS()));
  while (sys->timeS() < capS && sys->velocity(0).x() > 1e-3 * v0) sys->step(every);
  distance = sys->position(0).x() - x0;
  timeS = sys->timeS();
  speed = sys->velocity(0).x();
}

// Rolling resistance (CDT): a solid sphere rolling without slip decelerates at 5/7 mu_r g, so
// it stops after v0^2 / (2 5/7 mu_r g) in v0 / (5/7 mu_r g); without it, it keeps rolling.
// Both the closed-form sphere and the node sphere (20 voxels per d) get the couple.
TEST(DemContacts, RollingResistanceStopsARollingSphereAtTheCdtDistance) {
  const double muR = 0.05, v0 = 50;
  const double decel = 5.0 / 7.0 * muR * kG;
  const double stopDistance = v0 * v0 / (2 * decel), stopTime = v0 / decel;
  for (bool closed : {true, false}) {
    std::shared_ptr<const DemShape> shape =
        closed ? std::shared_ptr<const DemShape>(std::make_shared<TestFastSphere>(3.0))
               : std::make_shared<TestSphere>(3.0);
    const char* path = closed ? "closed form" : "nodes";
    double distance = 0, timeS = 0, speed = 0;
    // The node contact's distributed dashpot resists rolling by itself (its leading half
    // approaches the floor and is damped harder than the trailing half: at e 0.5 the free
    // sphere below loses 21 % of its speed, docs/dem.md), so the node sphere rolls undamped.
    const double e = closed ? 0.5 : 1.0;
    rollOnFloor(shape, 0.15, e, muR, v0, 3 * stopTime, distance, timeS, speed);
    RecordProperty(std::string("stop_distance_ratio_") + (closed ? "closed" : "nodes"),
                   std::to_string(distance / stopDistance));
    RecordProperty(std::string("stop_time_ratio_") + (closed ? "closed" : "nodes"),
                   std::to_string(timeS / stopTime));
    // Measured 1.003 / 1.002 (closed form), 1.006 / 1.09 (nodes). 5 %: the lever is R - delta
    // (delta/R ~ 4e-3 here) and the tangential spring stores a little of the motion; a
    // missing couple would roll 3x as far, one acting on I alone (5/2 mu_r g) stop 3.5x short.
    // The undamped node sphere chatters on its nodes (|v_z| up to 4 mm/s) and creeps for
    // the last 0.1 % of the distance, hence 15 % on its time.
    EXPECT_NEAR(distance / stopDistance, 1.0, 0.05) << path;
    EXPECT_NEAR(timeS / stopTime, 1.0, closed ? 0.05 : 0.15) << path;
    rollOnFloor(shape, 0.15, e, 0.0, v0, stopTime, distance, timeS, speed);
    EXPECT_GT(distance, 0.98 * v0 * stopTime) << path;
    EXPECT_GT(speed, 0.98 * v0) << path;
  }
}

// Total angular momentum about the origin, orbital plus spin.
Vec3 totalAngularMomentum(const DemSystem& sys) {
  Vec3 l = Vec3::Zero();
  for (std::size_t i = 0; i < sys.size(); ++i)
    l += sys.templates()[sys.templateOf(i)].massG * sys.position(i).cross(sys.velocity(i)) +
         sys.angularMomentum(i);
  return l;
}

// Two bodies collide off-centre with friction and spin, far from any wall: linear and angular
// momentum are conserved to round-off (the force pair is equal and opposite, the torque pair
// adds the lever between the centres).
TEST(DemContacts, OffCentreFrictionalImpactConservesMomentum) {
  for (bool cylinders : {true, false}) {
    DemOptions o = quiet();
    o.friction = 0.5;
    o.restitution = 0.5;
    std::shared_ptr<const DemShape> shape =
        cylinders ? std::shared_ptr<const DemShape>(std::make_shared<TestCylinder>(3.0, 2.0))
                  : std::make_shared<TestFastSphere>(3.0);
    auto sys = system1(shape, 0.15, o, std::make_shared<TestBox>(100));
    const double m = sys->templates()[0].massG;
    sys->addParticle(0, Vec3(-2.0, 0, 50), Quat(Eigen::AngleAxisd(0.3, Vec3(1, 2, 3).normalized())),
                     Vec3(100, 0, 0), Vec3(0, 5, 0));
    sys->addParticle(0, Vec3(1.6, 0.9, 50.4), Quat::Identity(), Vec3(-150, 0, 0), Vec3(0, 0, 20));
    const Vec3 p0 = m * (sys->velocity(0) + sys->velocity(1));
    const Vec3 l0 = totalAngularMomentum(*sys);
    const double scale = m * 250 * 3.0;  // relative momentum x diameter
    const std::size_t n = static_cast<std::size_t>(0.03 / sys->timeStepS());
    sys->step(n);
    const Vec3 p1 = m * (sys->velocity(0) + sys->velocity(1));
    EXPECT_LT((p1 - p0).norm() / (m * 250), 1e-9);
    EXPECT_LT((totalAngularMomentum(*sys) - l0).norm() / scale, 1e-9);
    // They did collide: sphere 0 no longer moves at +100 mm/s.
    EXPECT_LT(sys->velocity(0).x(), 90.0) << (cylinders ? "cylinders" : "spheres");
  }
}

// A NaN position never reaches the cell key: the system reports a blow-up and stops.
TEST(DemRobust, NanPositionStopsTheSystemAsDiverged) {
  auto sys =
      system1(std::make_shared<TestFastSphere>(3.0), 0.3, quiet(), std::make_shared<TestBox>(40));
  sys->addParticle(0, Vec3(0, 0, 10), Quat::Identity());
  sys->addParticle(0, Vec3(std::numeric_limits<double>::quiet_NaN(), 0, 10), Quat::Identity());
  sys->step(5);
  EXPECT_TRUE(sys->diverged());
  EXPECT_EQ(sys->timeS(), 0.0);
}

// A floor that suddenly lies 1e30 mm deep: the pour blows up, the run ends `diverged` and
// returns its last good (finite) state.
class PoisonFloor final : public DemContainer {
 public:
  double wallDistanceMm(const Vec3& p) const override {
    return p.z() > 1.0 ? c_.wallDistanceMm(p) : -1e30;
  }
  Vec3 inwardNormal(const Vec3& p) const override { return c_.inwardNormal(p); }
  Vec3 minMm() const override { return c_.minMm(); }
  Vec3 maxMm() const override { return c_.maxMm(); }

 private:
  TestColumn c_{12.0};
};

TEST(DemRobust, BlowUpEndsDivergedWithTheLastGoodState) {
  packer::dem::DemScene s;
  s.shapes = {std::make_shared<TestSphere>(3.0)};
  s.fractions = {1.0};
  s.container = std::make_shared<PoisonFloor>();
  s.voxelSizeMm = 0.3;
  s.count = 6;
  s.seed = 3;
  DemOptions o;
  o.maxTimeS = 1;
  const auto r = packer::dem::runDem(s, o, nullProgress());
  EXPECT_EQ(r.status, packer::dem::DemStatus::kDiverged);
  ASSERT_GT(r.particles.size(), 0u);
  for (std::size_t i = 0; i < r.particles.size(); ++i)
    EXPECT_TRUE(r.particles.positionMm[i].allFinite());
  EXPECT_STREQ(packer::dem::statusName(r.status), "diverged");
}

}  // namespace
}  // namespace voxpack::test
