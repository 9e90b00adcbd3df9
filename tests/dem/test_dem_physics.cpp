// Analytic checks of the DEM integrator and contact law (15-20 voxels per diameter).
#include <gtest/gtest.h>

#include <cmath>
#include <memory>

#include "analytic.hpp"

namespace voxpack::test {
namespace {

using packer::dem::buildTemplate;
using packer::dem::ContactModel;
using packer::dem::DemOptions;
using packer::dem::DemSystem;

constexpr double kG = 9810.0;  // mm/s^2

std::unique_ptr<DemSystem> oneShape(std::shared_ptr<const DemShape> shape, double voxelMm,
                                    const DemOptions& o, std::shared_ptr<const DemContainer> box) {
  std::vector<packer::dem::ParticleTemplate> t{buildTemplate(shape, voxelMm, o.densityGPerCm3)};
  auto sys = std::make_unique<DemSystem>(std::move(t), std::move(box), o);
  const std::string warning = sys->resolve(10.0);
  EXPECT_TRUE(warning.empty()) << warning;
  return sys;
}

DemOptions baseOptions() {
  DemOptions o;
  o.stiffnessNPerMm3 = 1.0;
  o.sleeping = false;
  o.threads = 1;
  return o;
}

// Velocity Verlet is exact for a constant force: the drop matches 1/2 g t^2 to round-off.
TEST(DemPhysics, FreeFallMatchesHalfGTSquared) {
  auto sys = oneShape(std::make_shared<TestSphere>(3.0), 0.15, baseOptions(),
                      std::make_shared<TestBox>(100));
  sys->addParticle(0, Vec3(0, 0, 80), Quat::Identity());
  const std::size_t n = 2000;
  sys->step(n);
  const double t = sys->timeS();
  const double drop = 80 - sys->position(0).z();
  const double expected = 0.5 * kG * t * t;
  ASSERT_GT(expected, 1.0);
  ASSERT_LT(expected, 70.0);  // still in the air
  EXPECT_NEAR(drop / expected, 1.0, 1e-6);
  EXPECT_NEAR(sys->velocity(0).z() / (-kG * t), 1.0, 1e-6);
}

// Drops a sphere from a gap H and returns the next apex gap.
double reboundGap(double restitution, double gapMm, ContactModel model, double* energyIn = nullptr,
                  double* energyOut = nullptr) {
  DemOptions o = baseOptions();
  o.restitution = restitution;
  o.friction = 0;
  o.contact = model;
  auto sys = oneShape(std::make_shared<TestSphere>(3.0), 0.15, o, std::make_shared<TestBox>(40));
  sys->addParticle(0, Vec3(0, 0, 1.5 + gapMm), Quat::Identity());
  if (energyIn) *energyIn = sys->kineticEnergy() + sys->potentialEnergy();
  bool touched = false;
  double apex = -1;
  for (int s = 0; s < 400000; ++s) {
    sys->step();
    const double z = sys->position(0).z(), vz = sys->velocity(0).z();
    if (z < 1.5) touched = true;
    if (touched && z > 1.5 && vz <= 0) {
      apex = z - 1.5;
      break;
    }
  }
  if (energyOut) *energyOut = sys->kineticEnergy() + sys->potentialEnergy();
  return apex;
}

TEST(DemPhysics, ReboundHeightIsESquared) {
  for (auto model : {ContactModel::kVoxel, ContactModel::kLevelSet}) {
    const double e = 0.5, gap = 3.0;
    const double h = reboundGap(e, gap, model);
    EXPECT_NEAR(h / (e * e * gap), 1.0, 0.10) << "model " << static_cast<int>(model);
  }
}

TEST(DemPhysics, ElasticBounceConservesEnergy) {
  for (auto model : {ContactModel::kVoxel, ContactModel::kLevelSet}) {
    double e0 = 0, e1 = 0;
    const double gap = 3.0;
    const double h = reboundGap(1.0, gap, model, &e0, &e1);
    const double m = 1.5e-3 * 4.0 / 3.0 * kPi * 1.5 * 1.5 * 1.5;
    EXPECT_LT(std::abs(e1 - e0) / (m * kG * gap), 0.01);
    EXPECT_NEAR(h / gap, 1.0, 0.01);
  }
}

TEST(DemPhysics, DampedBounceLosesEnergy) {
  double e0 = 0, e1 = 0;
  const double h = reboundGap(0.7, 3.0, ContactModel::kVoxel, &e0, &e1);
  EXPECT_LT(e1, e0);
  EXPECT_LT(h, 3.0 * 0.7 * 0.7 * 1.1);
  EXPECT_GT(h, 3.0 * 0.7 * 0.7 * 0.9);
}

// A cylinder standing on its flat end: linear contact, overlap = m g / K with K = k A, or
// the contact stiffness ceiling when that is lower.
TEST(DemPhysics, RestingOverlapIsWeightOverStiffness) {
  for (double cap : {0.0, 1.0})
    for (auto model : {ContactModel::kVoxel, ContactModel::kLevelSet}) {
      DemOptions o = baseOptions();
      o.stiffnessNPerMm3 = 0.01;
      o.restitution = 0.3;
      o.contact = model;
      o.contactStiffnessCap = cap;
      auto shape = std::make_shared<TestCylinder>(5.4, 3.8);
      auto sys = oneShape(shape, 0.27, o, std::make_shared<TestBox>(40));
      sys->addParticle(0, Vec3(0.05, -0.03, 1.9 + 0.002), Quat::Identity());
      const std::size_t n = static_cast<std::size_t>(0.1 / sys->timeStepS());
      sys->step(n);
      const double m = 1.5e-3 * shape->volumeMm3();
      double stiffness = 0.01 * 1e6 * kPi * 2.7 * 2.7;  // g/s^2
      if (cap > 0) stiffness = std::min(stiffness, sys->contactStiffnessCapNPerMm() * 1e6);
      const double expected = m * kG / stiffness;
      const double overlap = 1.9 - sys->position(0).z();
      EXPECT_NEAR(overlap / expected, 1.0, 0.10)
          << "model " << static_cast<int>(model) << " cap " << cap;
      EXPECT_LT(std::abs(sys->velocity(0).z()), 1e-3);
    }
}

// Contact nodes coarser than the lattice (DemOptions::contactVoxelMm) keep the contact law:
// node forces are per unit area, so a cylinder resting on its end or on its side sinks as
// far with nodes at 0.36 mm (15 per d, 0.56 of the nodes) as at 0.27 mm. What a coarse node
// set does change is the digitised area of a face: at 0.54 mm, where the radius is 5 h, the
// end disc is 12 % short and the cylinder sinks 14 % deeper (docs/dem.md).
TEST(DemPhysics, CoarseContactNodesKeepTheRestingOverlap) {
  auto shape = std::make_shared<TestCylinder>(5.4, 3.8);
  const Quat side(Eigen::AngleAxisd(kPi / 2, Vec3::UnitX()));
  for (const bool onSide : {false, true}) {
    std::vector<double> overlap;
    std::vector<std::size_t> nodes;
    for (const double h : {0.27, 0.36}) {
      DemOptions o = baseOptions();
      o.stiffnessNPerMm3 = 0.01;
      o.restitution = 0.3;
      o.friction = 0.3;
      o.contactStiffnessCap = 0;  // the node sum alone, which is what the spacing could change
      auto sys = oneShape(shape, h, o, std::make_shared<TestBox>(40));
      const double half = onSide ? 2.7 : 1.9;
      sys->addParticle(0, Vec3(0.05, -0.03, half + 0.002), onSide ? side : Quat::Identity());
      sys->step(static_cast<std::size_t>(0.15 / sys->timeStepS()));
      overlap.push_back(half - sys->position(0).z());
      nodes.push_back(sys->templates().front().nodeP.size());
      EXPECT_LT(std::abs(sys->velocity(0).z()), 1e-3) << onSide << " " << h;
    }
    ASSERT_GT(overlap[0], 0);
    RecordProperty(onSide ? "side_overlap_ratio" : "end_overlap_ratio",
                   std::to_string(overlap[1] / overlap[0]));
    EXPECT_LT(static_cast<double>(nodes[1]), 0.6 * static_cast<double>(nodes[0]));
    EXPECT_NEAR(overlap[1] / overlap[0], 1.0, onSide ? 0.15 : 0.05)
        << (onSide ? "side" : "end") << ": " << overlap[0] << " mm at 0.27 mm nodes, " << overlap[1]
        << " mm at 0.36 mm";
  }
}

// Two spheres (different sizes, off-centre, with friction): momentum is conserved, and the
// relative normal speed of the centres comes back with e (friction acts across the normal).
TEST(DemPhysics, HeadOnCollisionConservesMomentum) {
  DemOptions o = baseOptions();
  o.gravityMmPerS2 = 0;
  o.friction = 0.3;
  o.restitution = 0.5;
  std::vector<packer::dem::ParticleTemplate> t{
      buildTemplate(std::make_shared<TestSphere>(3.0), 0.15, o.densityGPerCm3),
      buildTemplate(std::make_shared<TestSphere>(2.0), 0.1, o.densityGPerCm3)};
  const double m0 = t[0].massG, m1 = t[1].massG;
  DemSystem sys(std::move(t), std::make_shared<TestBox>(100), o);
  sys.resolve(10);
  sys.addParticle(0, Vec3(-2.0, 0, 50), Quat::Identity(), Vec3(100, 0, 0));
  sys.addParticle(1, Vec3(1.5, 0.4, 50), Quat::Identity(), Vec3(-150, 0, 0), Vec3(0, 0, 20));
  const Vec3 p0 = m0 * sys.velocity(0) + m1 * sys.velocity(1);
  const double reach = 1.5 + 1.0;
  auto gap = [&] { return (sys.position(1) - sys.position(0)).norm() - reach; };
  auto normalSpeed = [&] {
    const Vec3 n = (sys.position(1) - sys.position(0)).normalized();
    return (sys.velocity(1) - sys.velocity(0)).dot(n);
  };
  double before = 0, after = 0;
  for (int s = 0; s < 100000 && gap() > 0; ++s) {
    before = normalSpeed();
    sys.step();
  }
  ASSERT_LT(before, 0);  // approaching
  for (int s = 0; s < 100000 && gap() <= 0; ++s) sys.step();
  after = normalSpeed();
  const std::size_t n = static_cast<std::size_t>(0.01 / sys.timeStepS());
  sys.step(n);
  const Vec3 p1 = m0 * sys.velocity(0) + m1 * sys.velocity(1);
  EXPECT_LT((p1 - p0).norm() / (m0 * 100), 1e-9);
  EXPECT_NEAR(-after / before, 0.5, 0.05);
}

}  // namespace
}  // namespace voxpack::test
