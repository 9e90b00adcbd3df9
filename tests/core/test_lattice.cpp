#include <gtest/gtest.h>

#include "voxpack/core/errors.hpp"
#include "voxpack/core/grid.hpp"

using namespace voxpack;

TEST(Lattice, IndexToMmAndBack) {
  Lattice l;
  l.dims = {4, 5, 6};
  l.spacingMm = {0.5, 0.25, 0.2};
  l.originMm = {10.0, -1.0, 2.0};
  const Vec3 p = l.centerMm(3, 2, 1);
  EXPECT_DOUBLE_EQ(p.x(), 2.2);
  EXPECT_DOUBLE_EQ(p.y(), -0.5);
  EXPECT_DOUBLE_EQ(p.z(), 11.5);
  const Index3 ix = l.nearestIndex(p + Vec3(0.09, 0.12, -0.24));
  EXPECT_EQ(ix, (Index3{3, 2, 1}));
  const Vec3 c = l.continuousIndex(p);
  EXPECT_NEAR(c.x(), 1.0, 1e-12);
  EXPECT_NEAR(c.y(), 2.0, 1e-12);
  EXPECT_NEAR(c.z(), 3.0, 1e-12);
}

TEST(Lattice, OffsetRoundTripCOrder) {
  Lattice l;
  l.dims = {3, 4, 5};
  EXPECT_EQ(l.offset(0, 0, 1), 1u);
  EXPECT_EQ(l.offset(0, 1, 0), 5u);
  EXPECT_EQ(l.offset(1, 0, 0), 20u);
  for (std::size_t n = 0; n < l.size(); ++n) {
    const Index3 ix = l.indexOf(n);
    EXPECT_EQ(l.offset(ix.k, ix.j, ix.i), n);
  }
}

TEST(Lattice, ValidateRejectsBadSpacing) {
  Lattice l = Lattice::isotropic(2, 2, 2, 0.1);
  EXPECT_NO_THROW(l.validate());
  l.spacingMm[1] = 0;
  EXPECT_THROW(l.validate(), InputError);
  l.spacingMm[1] = std::nan("");
  EXPECT_THROW(l.validate(), InputError);
  l = Lattice::isotropic(0, 2, 2, 0.1);
  EXPECT_THROW(l.validate(), InputError);
}

TEST(Grid, OneVoxel) {
  Grid<std::uint8_t> g(Lattice::isotropic(1, 1, 1, 1.0), 1);
  EXPECT_EQ(g.size(), 1u);
  EXPECT_EQ(g(0, 0, 0), 1);
  g(0, 0, 0) = 0;
  EXPECT_EQ(g[0], 0);
}
