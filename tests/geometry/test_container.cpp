// Containers: inside tests, wall distances and normals, lattices and masks.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "cli_runner.hpp"
#include "voxpack/core/bed_file.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/packer/container.hpp"

using namespace voxpack;
using namespace voxpack::packer;

namespace {
std::size_t count(const Grid<std::uint8_t>& g) {
  std::size_t n = 0;
  for (std::size_t o = 0; o < g.size(); ++o) n += g[o];
  return n;
}
}  // namespace

TEST(Container, CylinderInsideAndWalls) {
  const auto c = parseContainer("cylinder:d=20,h=10");
  EXPECT_EQ(c->spec(), "cylinder:d=20,h=10");
  EXPECT_TRUE(c->inside(Vec3(0, 0, 5)));
  EXPECT_TRUE(c->inside(Vec3(10, 0, 0)));  // boundary counts as inside
  EXPECT_FALSE(c->inside(Vec3(7.1, 7.1, 5)));
  EXPECT_FALSE(c->inside(Vec3(0, 0, -0.01)));
  EXPECT_NEAR(c->wallDistanceMm(Vec3(0, 0, 5)), 5.0, 1e-12);    // top and bottom
  EXPECT_NEAR(c->wallDistanceMm(Vec3(8, 0, 5)), 2.0, 1e-12);    // side
  EXPECT_NEAR(c->wallDistanceMm(Vec3(12, 0, 5)), -2.0, 1e-12);  // outside
  EXPECT_NEAR(c->wallDistanceMm(Vec3(0, 0, 12)), -2.0, 1e-12);
  EXPECT_LT((c->inwardNormal(Vec3(0, 8, 5)) - Vec3(0, -1, 0)).norm(), 1e-12);
  EXPECT_LT((c->inwardNormal(Vec3(0, 0, 0.5)) - Vec3(0, 0, 1)).norm(), 1e-12);
  EXPECT_LT((c->inwardNormal(Vec3(0, 12, 5)) - Vec3(0, -1, 0)).norm(), 1e-6);
  double cx = 1, cy = 1, r = 0;
  EXPECT_TRUE(c->cylinderAxis(cx, cy, r));
  EXPECT_EQ(cx, 0);
  EXPECT_EQ(r, 10);
  EXPECT_NEAR(c->volumeMm3(), std::numbers::pi * 100 * 10, 1e-9);
}

// The digitised cylinder interior has the exact volume within 0.5 % at 80 voxels across
// (a digital disc of 80 px is ~0.1 % off; margins stay empty).
TEST(Container, CylinderMaskVolume) {
  const auto c = parseContainer("cylinder:d=20,h=10");
  const Lattice l = latticeForContainer(*c, 0.25, 2);
  EXPECT_EQ(l.nx(), 84);
  EXPECT_EQ(l.nz(), 44);
  EXPECT_NEAR(l.centerMm(0, 0, 0).x(), -10 - 1.5 * 0.25, 1e-12);
  const auto m = containerMask(*c, l);
  const double v = static_cast<double>(count(m)) * l.voxelVolumeMm3();
  EXPECT_NEAR(v, c->volumeMm3(), 0.005 * c->volumeMm3());
  for (std::int64_t j = 0; j < l.ny(); ++j)
    for (std::int64_t i = 0; i < l.nx(); ++i) {
      EXPECT_EQ(m(0, j, i), 0);
      EXPECT_EQ(m(1, j, i), 0);
      EXPECT_EQ(m(l.nz() - 1, j, i), 0);
    }
  const auto m3 = containerMask(*c, l, 3);
  const double v3 = static_cast<double>(count(m3)) * l.voxelVolumeMm3();
  EXPECT_NEAR(v3, c->volumeMm3(), 0.005 * c->volumeMm3());
}

TEST(Container, BoxMaskIsExact) {
  const auto c = parseContainer("box:x=4,y=4,z=6");
  const Lattice l = latticeForContainer(*c, 0.5, 1);
  EXPECT_EQ(l.nx(), 10);
  EXPECT_EQ(l.nz(), 14);
  const auto m = containerMask(*c, l);
  EXPECT_EQ(count(m), 8u * 8u * 12u);
  EXPECT_NEAR(c->wallDistanceMm(Vec3(1, 0, 3)), 1.0, 1e-12);
  EXPECT_NEAR(c->wallDistanceMm(Vec3(0, 0, 0.25)), 0.25, 1e-12);
  EXPECT_LT((c->inwardNormal(Vec3(1.9, 0, 3)) - Vec3(-1, 0, 0)).norm(), 1e-12);
  const Grid<float> w = wallDistanceField(*c, l);
  EXPECT_NEAR(w(1, 1, 1), 0.25, 1e-6);
  EXPECT_LT(w(0, 0, 0), 0.0f);
}

// A bed's mask used as a container: same lattice, same mask, signed wall distances.
TEST(Container, MaskFromBedFile) {
  test::TempDir tmp;
  const Lattice l = Lattice::isotropic(20, 20, 20, 0.5);
  Bed bed;
  bed.indicator = Grid<std::uint8_t>(l, 1);
  Grid<std::uint8_t> mask(l, 0);
  for (std::int64_t k = 2; k < 18; ++k)
    for (std::int64_t j = 0; j < 20; ++j)
      for (std::int64_t i = 0; i < 20; ++i)
        mask(k, j, i) = (i - 9.5) * (i - 9.5) + (j - 9.5) * (j - 9.5) <= 64 ? 1 : 0;
  bed.mask = mask;
  const auto path = tmp / "m.h5";
  writeBed(path, bed);
  const auto c = parseContainer("mask:" + path.string());
  const Lattice l2 = latticeForContainer(*c, 0.5);
  EXPECT_EQ(l2, l);
  EXPECT_EQ(containerMask(*c, l2).values(), mask.values());
  EXPECT_NEAR(c->volumeMm3(), static_cast<double>(count(mask)) * 0.125, 1e-9);
  const Vec3 centre = l.centerMm(10, 10, 10);
  EXPECT_TRUE(c->inside(centre));
  EXPECT_GT(c->wallDistanceMm(centre), 2.0);
  EXPECT_LT(c->wallDistanceMm(l.centerMm(0, 10, 10)), 0.0);
  EXPECT_GT(c->inwardNormal(l.centerMm(3, 10, 10)).z(), 0.5);
}

TEST(Container, BadSpecsAreRefused) {
  for (const char* bad : {"tube:d=1,h=1", "cylinder:d=1", "cylinder:d=0,h=1", "box:x=1,y=1,z=-1",
                          "cylinder:d=1,h=1,q=3", "mask:", "mesh:"}) {
    EXPECT_THROW(parseContainer(bad), InputError) << bad;
  }
  EXPECT_THROW(parseContainer("mask:/nonexistent/bed.h5"), Error);
  const auto c = parseContainer("box:x=1,y=1,z=1");
  EXPECT_THROW(latticeForContainer(*c, 0.0), InputError);
  EXPECT_THROW(latticeForContainer(*c, 1e-9), InputError);
}
