// Whole beds on the fast paths: thread invariance, overlap under the bed's weight, tapping.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "analytic.hpp"

namespace voxpack::test {
namespace {

using packer::dem::DemOptions;
using packer::dem::DemResult;
using packer::dem::DemScene;
using packer::dem::DemStatus;
using packer::dem::runDem;

DemScene column(std::shared_ptr<const DemShape> shape, double columnD, int count,
                std::uint64_t seed) {
  DemScene s;
  s.shapes = {std::move(shape)};
  s.fractions = {1.0};
  s.container = std::make_shared<TestColumn>(columnD, 400);
  s.voxelSizeMm = 0.3;
  s.count = count;
  s.seed = seed;
  return s;
}

void expectSameBits(const DemResult& a, const DemResult& b) {
  ASSERT_EQ(a.particles.size(), b.particles.size());
  for (std::size_t i = 0; i < a.particles.size(); ++i) {
    EXPECT_EQ(a.particles.positionMm[i], b.particles.positionMm[i]) << i;
    EXPECT_EQ(a.particles.orientation[i].coeffs(), b.particles.orientation[i].coeffs()) << i;
  }
}

// The parallel force sum, integration and sleeping give the same bits on 1 and 2 threads,
// for closed-form spheres and node cylinders, sleeping on and off.
TEST(DemBed, FastPathsIdenticalForAnyThreadCount) {
  for (bool spheres : {true, false})
    for (bool sleeping : {true, false}) {
      std::shared_ptr<const DemShape> shape =
          spheres ? std::shared_ptr<const DemShape>(std::make_shared<TestFastSphere>(3.0))
                  : std::make_shared<TestCylinder>(3.0, 2.1);
      DemOptions o;
      o.maxTimeS = spheres ? 0.3 : 0.12;
      o.friction = 0.3;
      o.sleeping = sleeping;
      o.parallelMinItems = 1;  // parallel regions even for this small scene
      o.parallelMinNodeWork = 0;
      DemResult r[2];
      for (int t = 0; t < 2; ++t) {
        o.threads = t + 1;
        r[t] = runDem(column(shape, 12.0, spheres ? 60 : 20, 7), o, nullProgress());
      }
      ASSERT_GT(r[0].particles.size(), 10u);
      expectSameBits(r[0], r[1]);
    }
}

// Mean packing height (mm) of the centres.
double meanHeight(const DemResult& r) {
  double z = 0;
  for (const auto& p : r.particles.positionMm) z += p.z();
  return z / static_cast<double>(r.particles.size());
}

// A bed 30 d deep under its own weight: the automatic stiffness sizes the contacts so the
// mean overlap of the particle contacts stays within 1.5x the target (0.4 % of d).
TEST(DemBed, MeanOverlapOfA30DiameterBedNearTarget) {
  const double d = 3.0, columnD = 12.0;
  // 30 d of bed at ~0.55 solid fraction.
  const int count =
      static_cast<int>(0.55 * (kPi * columnD * columnD / 4) * 30 * d / (kPi * d * d * d / 6));
  DemOptions o;
  o.friction = 0.3;
  o.maxTimeS = 6;
  const DemResult r =
      runDem(column(std::make_shared<TestFastSphere>(d), columnD, count, 2), o, nullProgress());
  RecordProperty("run_status", packer::dem::statusName(r.status));
  RecordProperty("mean_overlap_d", std::to_string(r.meanOverlapMm / d));
  RecordProperty("max_overlap_d", std::to_string(r.maxOverlapMm / d));
  ASSERT_GT(r.contacts, static_cast<std::size_t>(count));
  EXPECT_LT(r.meanOverlapMm / d, 1.5 * o.targetOverlap);
  EXPECT_GT(r.meanOverlapMm / d, 0.1 * o.targetOverlap);
}

// Tapping a 200-sphere bed compacts it: the mean centre height drops by more than a measured
// amount (see the recorded property), and the tapped bed settles.
TEST(DemBed, TappingCompactsA200ParticleBed) {
  const double d = 3.0;
  DemOptions o;
  o.friction = 0.3;
  o.maxTimeS = 8;
  const DemScene s = column(std::make_shared<TestFastSphere>(d), 15.0, 200, 5);
  const DemResult poured = runDem(s, o, nullProgress());
  o.tapCycles = 5;
  const DemResult tapped = runDem(s, o, nullProgress());
  ASSERT_EQ(poured.status, DemStatus::kSettled);
  ASSERT_EQ(tapped.status, DemStatus::kSettled);
  const double drop = (meanHeight(poured) - meanHeight(tapped)) / d;
  RecordProperty("mean_height_drop_d", std::to_string(drop));
  EXPECT_GT(drop, 0.02);
}

// Rain height 0 pours every particle at once from one cloud at the rain fraction (the peer
// LIGGGHTS's insert/pack): all are present after the first check, and the cloud is as tall
// as that fraction needs. The default rain zone (4 d at 0.3) holds fewer than all of them.
TEST(DemBed, RainHeightZeroPoursOneCloud) {
  const double d = 3.0, columnD = 12.0;
  const int count = 40;
  DemOptions o;
  o.maxTimeS = 0.004;  // two driver checks: the first batch only
  const DemScene s = column(std::make_shared<TestFastSphere>(d), columnD, count, 3);
  const DemResult rain = runDem(s, o, nullProgress());
  o.rainHeightDiameters = 0;
  o.rainVolumeFraction = 0.2;
  const DemResult cloud = runDem(s, o, nullProgress());
  EXPECT_LT(rain.particles.size(), static_cast<std::size_t>(count));
  ASSERT_EQ(cloud.particles.size(), static_cast<std::size_t>(count));
  const double area = kPi * columnD * columnD / 4, v = kPi * d * d * d / 6;
  const double height = count * v / (0.2 * area) + d;
  double top = 0;
  for (const auto& p : cloud.particles.positionMm) top = std::max(top, p.z());
  EXPECT_GT(top, 0.6 * height);
  EXPECT_LT(top, height);
  EXPECT_TRUE(std::any_of(cloud.messages.begin(), cloud.messages.end(), [](const std::string& m) {
    return m.find("one cloud") != std::string::npos;
  }));
}

}  // namespace
}  // namespace voxpack::test
