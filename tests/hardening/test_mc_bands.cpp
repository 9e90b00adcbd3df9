// Issue 14, "tests that can fail" for Monte Carlo: bands measured on small beds, narrow
// enough that a 2 % change of the packing density fails them.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>

#include "voxpack/core/bed.hpp"
#include "voxpack/packer/container.hpp"
#include "voxpack/packer/mc.hpp"
#include "voxpack/packer/shape.hpp"

using namespace voxpack;
using namespace voxpack::packer;

namespace {

// Solid fraction inside the mask over the slices from 1 d above the floor to 1 d below
// the highest solid voxel (the core of a small bed, away from both ends).
double coreDensity(const Bed& bed, double dMm) {
  const Lattice& l = bed.lattice();
  std::int64_t top = -1;
  for (std::int64_t k = 0; k < l.nz(); ++k)
    for (std::int64_t o = 0; o < l.ny() * l.nx(); ++o)
      if (bed.indicator[static_cast<std::size_t>(k * l.ny() * l.nx() + o)] == 0) top = k;
  const auto dv = static_cast<std::int64_t>(dMm / l.spacingMm[0]);
  std::size_t solid = 0, inside = 0;
  for (std::int64_t k = 1 + dv; k <= top - dv; ++k)
    for (std::int64_t j = 0; j < l.ny(); ++j)
      for (std::int64_t i = 0; i < l.nx(); ++i) {
        if (!(*bed.mask)(k, j, i)) continue;
        ++inside;
        solid += bed.indicator(k, j, i) == 0;
      }
  return inside ? static_cast<double>(solid) / static_cast<double>(inside) : 0.0;
}

McResult packSpheres(double pr, std::uint64_t seed, std::int64_t count = 120) {
  McOptions o;
  o.voxelSizeMm = 0.25;
  o.count = count;
  o.reboundProbability = pr;
  o.maxSweeps = 6000;
  const std::vector<MixtureComponent> mix{{parseShape("sphere:d=2"), 1.0}};
  return packMonteCarlo(mix, *parseContainer("cylinder:d=12,h=30"), o, seed);
}

}  // namespace

// The regression band: spheres d 2 mm at 0.25 mm in a 12 mm column, p_r 0.1, seed 1.
// Measured core density 0.487784 (deterministic: same seed, same bytes). The band is
// +-1 %, so a 2 % change of the density fails it.
TEST(McBands, SmallBedDensityRegressionBand) {
  const McResult r = packSpheres(0.1, 1);
  ASSERT_EQ(r.status, McStatus::Settled);
  const double phi = coreDensity(r.bed, 2.0);
  std::printf("core density %.6f\n", phi);
  EXPECT_NEAR(phi, 0.487784, 0.01 * 0.487784);
}

// Upward moves pass with probability p_r: the more pass, the looser the bed. Measured
// (core density, 60 spheres, seeds 1-3): p_r 0.1 -> 0.4275, 0.6 -> 0.3016, 0.9 -> 0.1076.
// The means must fall by at least half of the measured drop at each step.
TEST(McBands, DensityFallsAsReboundProbabilityRises) {
  const double prs[] = {0.1, 0.6, 0.9};
  double mean[3] = {0, 0, 0};
  for (int p = 0; p < 3; ++p) {
    for (std::uint64_t seed = 1; seed <= 3; ++seed) {
      const McResult r = packSpheres(prs[p], seed, 60);
      mean[p] += coreDensity(r.bed, 2.0) / 3;
    }
    std::printf("p_r %.2f: mean core density %.6f\n", prs[p], mean[p]);
  }
  EXPECT_LT(mean[1], mean[0] - 0.063);
  EXPECT_LT(mean[2], mean[1] - 0.097);
}

// p_r = 1 removes the downward drift: the walk never settles and the run must end by
// its sweep cap. It used to be called "settled" after 180 sweeps (seed 3): the settling
// test only asked that the mean height stop falling, and a drift-free gas passes that.
TEST(McBands, ReboundProbabilityOneEndsByItsCap) {
  McOptions o;
  o.voxelSizeMm = 0.3;
  o.count = 6;
  o.reboundProbability = 1.0;
  o.maxSweeps = 400;
  const std::vector<MixtureComponent> mix{{parseShape("sphere:d=3"), 1.0}};
  const McResult r = packMonteCarlo(mix, *parseContainer("cylinder:d=10,h=12"), o, 3);
  EXPECT_EQ(r.status, McStatus::CapReached);
  EXPECT_EQ(r.stats.sweeps, 400);
  EXPECT_EQ(r.bed.provenance["mc"]["status"], "cap_reached");
}
