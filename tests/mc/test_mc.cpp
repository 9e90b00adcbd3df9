// The Monte Carlo packer on small scenes: exclusion and containment checked voxel by voxel
// against a fresh digitisation, determinism, settling, mixtures, statuses.
#include <gtest/gtest.h>

#include <map>
#include <set>

#include "voxpack/core/errors.hpp"
#include "voxpack/packer/container.hpp"
#include "voxpack/packer/digitise.hpp"
#include "voxpack/packer/mc.hpp"
#include "voxpack/packer/shape.hpp"

using namespace voxpack;
using namespace voxpack::packer;

namespace {

McResult pack(const std::vector<std::pair<std::string, double>>& shapes,
              const std::string& container, McOptions o, std::uint64_t seed) {
  std::vector<MixtureComponent> mix;
  for (const auto& [spec, f] : shapes) mix.push_back({parseShape(spec), f});
  const auto c = parseContainer(container);
  return packMonteCarlo(mix, *c, o, seed);
}

McOptions small(double voxelMm, std::int64_t count) {
  McOptions o;
  o.voxelSizeMm = voxelMm;
  o.count = count;
  o.reboundProbability = 0.1;
  o.maxSweeps = 4000;
  return o;
}

// Every labelled voxel belongs to one particle, each particle's voxels are exactly its
// digitisation at the reported pose, nothing solid lies outside the container mask, and
// the indicator is the complement of the labels.
void expectExclusiveAndContained(const McResult& r) {
  const Bed& bed = r.bed;
  ASSERT_TRUE(bed.labels && bed.mask);
  const Lattice& l = bed.lattice();
  const auto& labels = *bed.labels;
  const auto& mask = *bed.mask;
  const std::size_t n = bed.particles.size();
  std::vector<std::size_t> counted(n + 1, 0);
  for (std::size_t o = 0; o < l.size(); ++o) {
    const std::uint32_t id = labels[o];
    ASSERT_LE(id, n);
    ASSERT_EQ(bed.indicator[o], id == 0 ? 1 : 0) << "offset " << o;
    if (id != 0) {
      ASSERT_EQ(mask[o], 1) << "solid voxel outside the container at offset " << o;
      ++counted[id];
    }
  }
  for (std::size_t p = 0; p < n; ++p) {
    const auto shape = parseShape(bed.particles.shape[p]);
    const DigitalParticle dp =
        digitise(*shape, bed.particles.positionMm[p], bed.particles.orientation[p], l);
    ASSERT_EQ(counted[p + 1], dp.voxels.size()) << "particle " << p + 1;
    for (const Voxel& v : dp.voxels) {
      ASSERT_TRUE(l.contains(v.k, v.j, v.i));
      ASSERT_EQ(labels(v.k, v.j, v.i), p + 1) << "particle " << p + 1;
    }
  }
}

}  // namespace

TEST(McPacker, SpheresAreExclusiveAndContained) {
  const McResult r = pack({{"sphere:d=3", 1.0}}, "cylinder:d=12,h=15", small(0.5, 20), 1);
  EXPECT_EQ(r.status, McStatus::Settled);
  EXPECT_EQ(r.bed.particles.size(), 20u);
  expectExclusiveAndContained(r);
}

TEST(McPacker, RotatedCylindersAreExclusiveAndContained) {
  McOptions o = small(0.4, 15);
  o.rotationProbability = 0.5;  // many re-digitisations
  const McResult r = pack({{"cylinder:d=3,l=2", 1.0}}, "box:x=10,y=10,z=14", o, 7);
  EXPECT_GT(r.stats.acceptedRotations, 0);
  EXPECT_EQ(r.bed.particles.size(), 15u);
  expectExclusiveAndContained(r);
}

TEST(McPacker, SameSeedSameBedOtherSeedOtherBed) {
  const auto a = pack({{"sphere:d=3", 1.0}}, "cylinder:d=10,h=12", small(0.5, 12), 5);
  const auto b = pack({{"sphere:d=3", 1.0}}, "cylinder:d=10,h=12", small(0.5, 12), 5);
  const auto c = pack({{"sphere:d=3", 1.0}}, "cylinder:d=10,h=12", small(0.5, 12), 6);
  EXPECT_EQ(a.bed.indicator.values(), b.bed.indicator.values());
  EXPECT_EQ(a.bed.labels->values(), b.bed.labels->values());
  EXPECT_NE(a.bed.indicator.values(), c.bed.indicator.values());
}

// Without rebounds particles can only go down or sideways: the bed ends up near the floor.
// 20 spheres of 14.1 mm^3 in a 113 mm^2 column fill ~5 mm at density 0.5; injected up
// to 15 mm high, none may still hang above 10 mm.
TEST(McPacker, ParticlesSettleToTheFloor) {
  McOptions o = small(0.5, 20);
  o.reboundProbability = 0.0;
  const McResult r = pack({{"sphere:d=3", 1.0}}, "cylinder:d=12,h=15", o, 3);
  ASSERT_EQ(r.status, McStatus::Settled);
  for (const Vec3& p : r.bed.particles.positionMm) EXPECT_LT(p.z(), 10.0);
  double lowest = 1e9;
  for (const Vec3& p : r.bed.particles.positionMm) lowest = std::min(lowest, p.z());
  EXPECT_LT(lowest, 1.5 + 0.5);  // a sphere resting on the floor has its centre at ~r
}

TEST(McPacker, MixtureFollowsNumberFractions) {
  const auto r =
      pack({{"sphere:d=3", 0.7}, {"sphere:d=2", 0.3}}, "cylinder:d=14,h=14", small(0.5, 10), 2);
  std::map<std::string, int> n;
  for (const auto& s : r.bed.particles.shape) ++n[s];
  EXPECT_EQ(n[parseShape("sphere:d=3")->spec()], 7);
  EXPECT_EQ(n[parseShape("sphere:d=2")->spec()], 3);
  expectExclusiveAndContained(r);
}

TEST(McPacker, FillHeightTrimsAtTheHeight) {
  McOptions o = small(0.5, 0);
  o.fillHeightMm = 6.0;
  const McResult r = pack({{"sphere:d=3", 1.0}}, "cylinder:d=10,h=14", o, 4);
  ASSERT_GT(r.bed.particles.size(), 3u);
  double top = 0;
  for (const Vec3& p : r.bed.particles.positionMm) {
    EXPECT_LE(p.z(), 6.0 + 1e-9);
    top = std::max(top, p.z());
  }
  EXPECT_GT(top, 6.0 - 3.0);  // the bed reaches within one diameter of the fill height
  expectExclusiveAndContained(r);
}

TEST(McPacker, TappingKeepsTheBedValid) {
  McOptions o = small(0.5, 12);
  o.tapCycles = 2;
  o.tapSweeps = 10;
  const McResult r = pack({{"sphere:d=3", 1.0}}, "cylinder:d=10,h=12", o, 9);
  EXPECT_EQ(r.bed.particles.size(), 12u);
  expectExclusiveAndContained(r);
}

TEST(McPacker, SweepCapGivesStatusNotException) {
  McOptions o = small(0.5, 10);
  o.maxSweeps = 3;
  const McResult r = pack({{"sphere:d=3", 1.0}}, "cylinder:d=10,h=12", o, 1);
  EXPECT_EQ(r.status, McStatus::CapReached);
  EXPECT_EQ(r.stats.sweeps, 3);
  expectExclusiveAndContained(r);
}

TEST(McPacker, FullContainerGivesStatus) {
  McOptions o = small(0.5, 500);
  o.injectAttempts = 50;
  const McResult r = pack({{"sphere:d=3", 1.0}}, "cylinder:d=7,h=7", o, 1);
  EXPECT_EQ(r.status, McStatus::ContainerFull);
  EXPECT_LT(r.bed.particles.size(), 500u);
  EXPECT_GT(r.bed.particles.size(), 0u);
  expectExclusiveAndContained(r);
}

TEST(McPacker, RefusesBadOptions) {
  McOptions o = small(0.5, 10);
  o.reboundProbability = -0.01;
  EXPECT_THROW(validate(o), InputError);
  o.reboundProbability = 1.01;
  EXPECT_THROW(validate(o), InputError);
  o.reboundProbability = 1.0;
  EXPECT_NO_THROW(validate(o));
  o.count = 0;
  EXPECT_THROW(validate(o), InputError);
  o.count = 5;
  o.fillHeightMm = 3;
  EXPECT_THROW(validate(o), InputError);  // both goals
}

// Filling to the lid is a reachable goal: the bed ends settled, not "container full".
TEST(McPacker, FillToTheLidIsSettled) {
  McOptions o = small(0.5, 0);
  o.fillHeightMm = 8.0;
  const McResult r = pack({{"sphere:d=3", 1.0}}, "cylinder:d=8,h=8", o, 2);
  EXPECT_EQ(r.status, McStatus::Settled);
  EXPECT_GT(r.bed.particles.size(), 3u);
  expectExclusiveAndContained(r);
}
