// Resolution convergence of a poured sphere bed (issue 5: 10, 15 and 20 voxels per d).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "analytic.hpp"

namespace voxpack::test {
namespace {

using packer::dem::DemOptions;
using packer::dem::DemResult;
using packer::dem::DemScene;
using packer::dem::runDem;

// A bed of spheres in a tube of 1.5 diameters stacks as a zigzag: each sphere rests on the one
// below and on the wall opposite, a vertical pitch sqrt(d^2 - (D - d)^2) and a packing density
// (pi d^3 / 6) / (pi D^2 / 4 * pitch) = 0.3421 for rigid spheres (contact overlaps
// shorten the pitch: ~1.5 % denser at the default stiffness). Unlike a random bed (one small bed is
// one sample of a random packing, +-0.02), this one has an exact density, so the resolution
// dependence is measurable in a second: stiffness is per unit area and node forces are
// weighted by the true area, so 10, 15 and 20 voxels per diameter must agree within 2 %.
TEST(DemConvergence, SphereBedDensityAt10To20VoxelsPerDiameter) {
  const double d = 3.0, columnD = 4.5;
  const double pitch = std::sqrt(d * d - (columnD - d) * (columnD - d));
  const double exact = (kPi * d * d * d / 6) / (kPi * columnD * columnD / 4 * pitch);
  DemOptions o;
  // Low friction: a sphere still rolls to the lowest place, opposite the one below, and the
  // chain settles in a fraction of a second (frictionless, it rolls about the axis for ~6 s).
  o.friction = 0.1;
  o.restitution = 0.5;
  std::vector<double> phis;
  for (double vpd : {10.0, 15.0, 20.0}) {
    DemScene s;
    s.shapes = {std::make_shared<TestSphere>(d)};
    s.fractions = {1.0};
    s.container = std::make_shared<TestColumn>(columnD);
    s.voxelSizeMm = d / vpd;
    s.count = 10;
    s.seed = 3;
    const DemResult r = runDem(s, o, nullProgress());
    ASSERT_EQ(r.status, packer::dem::DemStatus::kSettled) << vpd;
    ASSERT_EQ(r.particles.size(), 10u);
    std::vector<double> z;
    for (const auto& p : r.particles.positionMm) z.push_back(p.z());
    std::sort(z.begin(), z.end());
    const double meanPitch = (z.back() - z.front()) / static_cast<double>(z.size() - 1);
    const double phi = (kPi * d * d * d / 6) / (kPi * columnD * columnD / 4 * meanPitch);
    RecordProperty("density_vpd" + std::to_string(static_cast<int>(vpd)), std::to_string(phi));
    EXPECT_NEAR(phi, exact, 0.03 * exact) << vpd;
    phis.push_back(phi);
  }
  const auto [lo, hi] = std::minmax_element(phis.begin(), phis.end());
  EXPECT_LT((*hi - *lo) / *lo, 0.02) << phis[0] << " " << phis[1] << " " << phis[2];
}

}  // namespace
}  // namespace voxpack::test
