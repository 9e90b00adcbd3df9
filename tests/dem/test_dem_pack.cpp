// Whole runs on small scenes: thread invariance, extremes, geometry glue.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "analytic.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/core/random.hpp"
#include "voxpack/packer/dem_geometry.hpp"

namespace voxpack::test {
namespace {

using packer::dem::DemOptions;
using packer::dem::DemResult;
using packer::dem::DemScene;
using packer::dem::runDem;

DemScene smallScene(int count, std::uint64_t seed = 7) {
  DemScene s;
  s.shapes = {std::make_shared<TestSphere>(3.0)};
  s.fractions = {1.0};
  s.container = std::make_shared<TestColumn>(12.0);
  s.voxelSizeMm = 0.3;
  s.count = count;
  s.seed = seed;
  return s;
}

bool allFiniteInside(const DemResult& r, const DemContainer& c) {
  for (std::size_t i = 0; i < r.particles.size(); ++i) {
    const Vec3& p = r.particles.positionMm[i];
    if (!p.allFinite() || !r.particles.orientation[i].coeffs().allFinite()) return false;
    if (c.wallDistanceMm(p) <= 0) return false;
  }
  return true;
}

// Same particles at the same poses, to the last bit.
void expectIdenticalBeds(const DemResult& a, const DemResult& b) {
  ASSERT_EQ(a.particles.size(), b.particles.size());
  for (std::size_t i = 0; i < a.particles.size(); ++i) {
    EXPECT_EQ(a.particles.positionMm[i], b.particles.positionMm[i]) << i;
    EXPECT_EQ(a.particles.orientation[i].coeffs(), b.particles.orientation[i].coeffs());
  }
}

// Forces are summed per pair slot and then in pair order: any thread count, same bits.
TEST(DemPack, IdenticalForAnyThreadCount) {
  DemOptions o;
  o.maxTimeS = 0.12;
  o.friction = 0.3;
  o.parallelMinItems = 1;  // parallel regions even for this small scene
  o.parallelMinNodeWork = 0;
  DemResult r[2];
  for (int t = 0; t < 2; ++t) {
    o.threads = t + 1;
    r[t] = runDem(smallScene(24), o, nullProgress());
  }
  ASSERT_GT(r[0].particles.size(), 10u);
  expectIdenticalBeds(r[0], r[1]);
}

// Once most of a bed sleeps a step visits only the live set (the awake particles, the
// sleepers touching them, their pairs) and a rebuild searches only the particles that moved;
// that must be the full pass's bed to the last bit, through a pour, its sleepers and the
// taps that wake them all, on one and two threads.
TEST(DemPack, LiveSetStepsGiveTheFullPassBed) {
  DemScene s = smallScene(30, 9);
  s.shapes = {std::make_shared<TestCylinder>(3.0, 2.1)};
  DemOptions o;
  o.friction = 0.3;
  o.maxTimeS = 3;
  o.tapCycles = 1;
  o.parallelMinItems = 1;
  o.parallelMinNodeWork = 0;
  DemResult full, live[2];
  o.liveSetAwakeFraction = 0;  // always the full pass
  full = runDem(s, o, nullProgress());
  o.liveSetAwakeFraction = 2;  // the live set whenever any particle sleeps
  for (int t = 0; t < 2; ++t) {
    o.threads = t + 1;
    live[t] = runDem(s, o, nullProgress());
  }
  ASSERT_EQ(full.status, packer::dem::DemStatus::kSettled);
  ASSERT_EQ(full.particles.size(), 30u);
  // The live runs did skip: fewer pairs checked, the same pairs evaluated, and most cell
  // lists rebuilt for the moved particles alone (a missed pair would be a missed contact).
  EXPECT_LT(live[0].counters.pairChecks, full.counters.pairChecks * 9 / 10);
  EXPECT_EQ(full.counters.partialRebuilds, 0u);
  EXPECT_GT(live[0].counters.partialRebuilds, live[0].counters.neighbourRebuilds / 2);
  EXPECT_EQ(live[0].counters.neighbourRebuilds, full.counters.neighbourRebuilds);
  EXPECT_EQ(live[0].counters.pairEvaluations, full.counters.pairEvaluations);
  EXPECT_EQ(live[0].counters.steps, full.counters.steps);
  for (const DemResult& r : live) {
    EXPECT_EQ(r.status, full.status);
    EXPECT_EQ(r.simulatedTimeS, full.simulatedTimeS);
    expectIdenticalBeds(full, r);
  }
}

// A long pour of spheres onto its own sleeping bed: most rebuilds search the moved
// particles alone, against sleepers of lower and higher index; a missed pair would be a
// missed contact and another bed.
TEST(DemPack, PartialNeighbourRebuildsGiveTheFullSearchBed) {
  DemScene s = smallScene(120, 4);
  s.shapes = {std::make_shared<TestFastSphere>(3.0)};
  DemOptions o;
  o.friction = 0.3;
  o.maxTimeS = 2.5;
  o.rainHeightDiameters = 1.5;  // small batches land on sleepers
  DemResult full, live;
  o.liveSetAwakeFraction = 0;
  full = runDem(s, o, nullProgress());
  o.liveSetAwakeFraction = 2;
  live = runDem(s, o, nullProgress());
  ASSERT_EQ(full.particles.size(), 120u);
  EXPECT_GT(live.counters.partialRebuilds, live.counters.neighbourRebuilds / 2);
  EXPECT_EQ(live.counters.pairEvaluations, full.counters.pairEvaluations);
  expectIdenticalBeds(full, live);
}

// The auto stiffness carries the weight of a bed only down to three Janssen lengths
// (3 A / (P K mu_w), K = 0.4): in a 12 mm column at wall friction 0.3 that is 75 mm, however
// tall the bed; a frictionless wall, or a bed shallower than that, keeps the whole weight.
TEST(DemPack, AutoStiffnessStopsAtThreeJanssenLengths) {
  DemScene s = smallScene(2000, 3);
  s.container = std::make_shared<TestColumn>(12.0, 2000.0);
  DemOptions o;
  o.maxTimeS = 1e-4;  // the stiffness is chosen before the first step
  o.friction = 0.3;
  const DemResult tall = runDem(s, o, nullProgress());
  const double bed = 2000 * (kPi / 6 * 27) / (0.6 * kPi * 36);  // as run.cpp sizes it
  EXPECT_NEAR(tall.loadHeightMm, 3 * 12.0 / (4 * 0.4 * 0.3), 0.03 * 75);
  o.wallFriction = 0;
  const DemResult smooth = runDem(s, o, nullProgress());
  EXPECT_NEAR(smooth.loadHeightMm, bed, 0.02 * bed);
  // The face stiffness follows the load: k ~ depth.
  EXPECT_NEAR(tall.stiffnessNPerMm3 / smooth.stiffnessNPerMm3,
              tall.loadHeightMm / smooth.loadHeightMm, 1e-9);
  o.wallFriction = -1;
  s.count = 100;  // ~21 mm deep: under the cap
  const DemResult shallow = runDem(s, o, nullProgress());
  EXPECT_NEAR(shallow.loadHeightMm, bed / 20, 0.02 * bed / 20);
}

// Node lists are a cache: a contact re-searches its nodes only when the relative pose moved
// more than the skin. Skin 0 searches every step; the forces, hence the bed, must not change.
TEST(DemPack, NodeListsDoNotChangeTheForces) {
  DemScene s = smallScene(16, 5);
  s.shapes = {std::make_shared<TestCylinder>(3.0, 2.1)};
  DemOptions o;
  o.maxTimeS = 0.15;
  o.friction = 0.3;
  DemResult r[2];
  for (int k = 0; k < 2; ++k) {
    o.nodeSkinDiameters = k == 0 ? 0.0 : 0.05;
    r[k] = runDem(s, o, nullProgress());
  }
  EXPECT_GE(r[0].counters.nodeListRebuilds, r[0].counters.pairEvaluations);
  EXPECT_LT(r[1].counters.nodeListRebuilds, r[0].counters.nodeListRebuilds / 4);
  ASSERT_GT(r[0].particles.size(), 8u);
  expectIdenticalBeds(r[0], r[1]);
}

TEST(DemPack, SameSeedSameBedOtherSeedOtherBed) {
  DemOptions o;
  o.maxTimeS = 0.05;
  const DemResult a = runDem(smallScene(12, 3), o, nullProgress());
  const DemResult b = runDem(smallScene(12, 3), o, nullProgress());
  const DemResult c = runDem(smallScene(12, 4), o, nullProgress());
  EXPECT_EQ(a.particles.positionMm, b.particles.positionMm);
  EXPECT_NE(a.particles.positionMm, c.particles.positionMm);
}

// Tapping starts from the settled pour (same seed, same bed up to that moment) and may only
// compact it: the centres sink on average, the bed ends settled, nothing leaves the container.
TEST(DemPack, TappingCompactsTheSettledPour) {
  DemScene s = smallScene(30, 11);
  DemOptions o;
  o.friction = 0.3;
  o.maxTimeS = 3;
  const DemResult poured = runDem(s, o, nullProgress());
  o.tapCycles = 4;
  const DemResult tapped = runDem(s, o, nullProgress());
  ASSERT_EQ(poured.status, packer::dem::DemStatus::kSettled);
  ASSERT_EQ(tapped.status, packer::dem::DemStatus::kSettled);
  EXPECT_NEAR(tapped.settleTimeS, poured.settleTimeS, 1e-12);  // identical until the taps
  EXPECT_GT(tapped.simulatedTimeS, poured.simulatedTimeS + 4 * (1.0 / 30 + 0.1) - 1e-9);
  ASSERT_EQ(poured.particles.size(), tapped.particles.size());
  double zp = 0, zt = 0;
  for (std::size_t i = 0; i < poured.particles.size(); ++i) {
    zp += poured.particles.positionMm[i].z();
    zt += tapped.particles.positionMm[i].z();
  }
  zp /= static_cast<double>(poured.particles.size());
  zt /= static_cast<double>(tapped.particles.size());
  RecordProperty("mean_height_poured_mm", std::to_string(zp));
  RecordProperty("mean_height_tapped_mm", std::to_string(zt));
  EXPECT_LT(zt, zp - 0.01);
  EXPECT_TRUE(allFiniteInside(tapped, *s.container));
}

// Stiffness x1000: the step shrinks by ~sqrt(1000) and the run stays finite and contained.
TEST(DemPack, StiffnessTimesThousandShrinksTheStep) {
  DemOptions o;
  o.maxTimeS = 0.03;
  o.stiffnessNPerMm3 = 0.5;
  const DemResult soft = runDem(smallScene(8), o, nullProgress());
  o.stiffnessNPerMm3 = 500;
  o.maxTimeS = 0.004;
  const DemResult stiff = runDem(smallScene(8), o, nullProgress());
  EXPECT_LT(stiff.timeStepS, soft.timeStepS / 10);
  EXPECT_TRUE(allFiniteInside(soft, *smallScene(1).container));
  EXPECT_TRUE(allFiniteInside(stiff, *smallScene(1).container));
}

TEST(DemPack, ExtremeRestitutionAndFrictionStayFiniteAndContained) {
  for (double e : {0.0, 1.0})
    for (double mu : {0.0, 10.0}) {
      DemOptions o;
      o.restitution = e;
      o.friction = mu;
      o.maxTimeS = 0.1;
      const DemResult r = runDem(smallScene(10), o, nullProgress());
      EXPECT_EQ(r.particles.size(), 10u);
      EXPECT_TRUE(allFiniteInside(r, *smallScene(1).container)) << "e " << e << " mu " << mu;
      EXPECT_LT(r.maxOverlapMm, 0.3) << "e " << e << " mu " << mu;
    }
}

TEST(DemPack, RefusesBadOptions) {
  DemOptions o;
  o.restitution = 1.5;
  EXPECT_THROW(runDem(smallScene(2), o, nullProgress()), InputError);
  o = DemOptions{};
  o.friction = -0.1;
  EXPECT_THROW(runDem(smallScene(2), o, nullProgress()), InputError);
  o = DemOptions{};
  o.timeStepS = 1.0;  // far above stability: clamped with a warning, not refused
  o.maxTimeS = 0.01;
  const DemResult r = runDem(smallScene(2), o, nullProgress());
  ASSERT_FALSE(r.messages.empty());
  EXPECT_NE(r.messages.front().find("clamped"), std::string::npos);
}

// Standard normal CDF.
double normalCdf(double z) { return 0.5 * std::erfc(-z / std::sqrt(2.0)); }

// Log-normal diameters (median 3 mm, geometric std 1.3, truncated at median / gsd^2 and
// median gsd^2): 4000 draws stay in range, their median and the share within one geometric
// std match the truncated law within 4 standard errors of the sample statistics.
TEST(DemSizes, LogNormalDrawsMatchTheTruncatedDistribution) {
  packer::dem::SizeDistribution d;
  d.kind = packer::dem::SizeDistribution::Kind::kLogNormal;
  d.medianMm = 3.0;
  d.geometricStd = 1.3;
  d.minMm = 3.0 / (1.3 * 1.3);
  d.maxMm = 3.0 * 1.3 * 1.3;
  const int n = 4000;
  std::vector<double> lnD;
  int within = 0;
  for (int i = 0; i < n; ++i) {
    RandomStream rs(11, static_cast<std::uint64_t>(i));
    const double x = packer::dem::drawDiameterMm(d, rs);
    ASSERT_GE(x, d.minMm);
    ASSERT_LE(x, d.maxMm);
    lnD.push_back(std::log(x));
    within += x >= 3.0 / 1.3 && x <= 3.0 * 1.3 ? 1 : 0;
  }
  std::nth_element(lnD.begin(), lnD.begin() + n / 2, lnD.end());
  const double sigma = std::log(1.3);
  // Standard error of a sample median: sqrt(pi/2) sigma / sqrt(n) (sigma of the untruncated
  // law, an upper bound).
  const double seMedian = std::sqrt(kPi / 2) * sigma / std::sqrt(double(n));
  RecordProperty("median_mm", std::to_string(std::exp(lnD[n / 2])));
  EXPECT_NEAR(lnD[n / 2], std::log(3.0), 4 * seMedian);
  const double p = (normalCdf(1) - normalCdf(-1)) / (normalCdf(2) - normalCdf(-2));  // 0.7152
  RecordProperty("share_within_one_gsd", std::to_string(double(within) / n));
  EXPECT_NEAR(double(within) / n, p, 4 * std::sqrt(p * (1 - p) / n));
}

// Sieve table: bins [2, 2.5), [2.5, 3.15), [3.15, 4) mm holding 30 / 50 / 20 % of the mass.
// The number share of a bin is its mass fraction over its mean d^3; the drawn mass fractions
// come back within 0.03 (measured spread of 4000 draws: ~0.01).
TEST(DemSizes, SieveDrawsGiveTheMassFractions) {
  packer::dem::SizeDistribution d;
  d.kind = packer::dem::SizeDistribution::Kind::kSieve;
  d.edgesMm = {2.0, 2.5, 3.15, 4.0};
  d.massFractions = {0.3, 0.5, 0.2};
  double mass[3] = {0, 0, 0}, total = 0;
  for (int i = 0; i < 4000; ++i) {
    RandomStream rs(5, static_cast<std::uint64_t>(i));
    const double x = packer::dem::drawDiameterMm(d, rs);
    ASSERT_GE(x, 2.0);
    ASSERT_LT(x, 4.0);
    const int bin = x < 2.5 ? 0 : x < 3.15 ? 1 : 2;
    mass[bin] += x * x * x;
    total += x * x * x;
  }
  for (int b = 0; b < 3; ++b) {
    RecordProperty("mass_fraction_" + std::to_string(b), std::to_string(mass[b] / total));
    EXPECT_NEAR(mass[b] / total, d.massFractions[static_cast<std::size_t>(b)], 0.03) << b;
  }
  d.massFractions = {0.3, 0.5};
  EXPECT_THROW(packer::dem::checkSizeDistribution(d, "test"), InputError);
}

// A log-normal pour: the bed stores each particle's diameter (its spec), the one its stream
// draws (RandomStream(seed, index): the shape's draw, then the diameter's), and 1 and 2
// threads give the same bits. A size distribution on a non-sphere is refused.
TEST(DemSizes, LogNormalBedStoresEachDiameterSameBitsOnOneAndTwoThreads) {
  DemScene s = smallScene(30, 3);
  s.shapes = {std::make_shared<TestFastSphere>(3.0)};
  s.container = std::make_shared<TestColumn>(15.0);
  s.sizes.kind = packer::dem::SizeDistribution::Kind::kLogNormal;
  s.sizes.medianMm = 2.5;
  s.sizes.geometricStd = 1.25;
  s.sizes.minMm = 1.8;
  s.sizes.maxMm = 3.6;
  DemOptions o;
  o.maxTimeS = 0.1;
  o.friction = 0.3;
  o.parallelMinItems = 1;
  o.parallelMinNodeWork = 0;
  DemResult r[2];
  for (int t = 0; t < 2; ++t) {
    o.threads = t + 1;
    r[t] = runDem(s, o, nullProgress());
  }
  ASSERT_EQ(r[0].particles.size(), 30u);
  expectIdenticalBeds(r[0], r[1]);
  EXPECT_EQ(r[0].particles.shape, r[1].particles.shape);
  for (std::size_t i = 0; i < r[0].particles.size(); ++i) {
    RandomStream rs(3, i);
    rs.uniform();
    const double want = packer::dem::drawDiameterMm(s.sizes, rs);
    const std::string& spec = r[0].particles.shape[i];
    ASSERT_EQ(spec.rfind("sphere:d=", 0), 0u) << spec;
    EXPECT_EQ(std::stod(spec.substr(9)), want) << i;  // the exact double (shortest text)
  }
  EXPECT_TRUE(allFiniteInside(r[0], *s.container));
  s.shapes = {std::make_shared<TestCylinder>(3.0, 2.0)};
  EXPECT_THROW(runDem(s, o, nullProgress()), InputError);
}

// The DEM's own signed distances of spheres and cylinders agree with the geometry module.
TEST(DemGeometry, FastSignedDistanceMatchesGeometry) {
  for (const char* spec : {"sphere:d=3", "cylinder:d=5.4,l=3.8"}) {
    const auto shape = packer::parseShape(spec);
    const auto dem = packer::dem::demShape(shape);
    RandomStream rs(1, 0);
    for (int n = 0; n < 2000; ++n) {
      const Vec3 p(rs.uniform(-4, 4), rs.uniform(-4, 4), rs.uniform(-4, 4));
      EXPECT_NEAR(dem->signedDistanceMm(p), shape->signedDistanceMm(p), 1e-9) << spec;
      EXPECT_EQ(dem->inside(p), shape->inside(p));
    }
  }
}

TEST(DemGeometry, OpenTopCylinderContainer) {
  const auto c = packer::dem::demContainer(packer::parseContainer("cylinder:d=20,h=30"), 3.0);
  EXPECT_NEAR(c->wallDistanceMm(Vec3(0, 0, 5)), 5.0, 1e-9);     // floor nearest
  EXPECT_NEAR(c->wallDistanceMm(Vec3(8, 0, 15)), 2.0, 1e-9);    // side wall
  EXPECT_NEAR(c->wallDistanceMm(Vec3(0, 0, 100)), 10.0, 1e-9);  // open top: side wall
  EXPECT_LT(c->wallDistanceMm(Vec3(11, 0, 100)), 0.0);
}

}  // namespace
}  // namespace voxpack::test
