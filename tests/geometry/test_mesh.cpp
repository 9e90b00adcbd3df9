// Mesh shapes and containers from STL files generated here.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "cli_runner.hpp"
#include "stl_fixtures.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/core/random.hpp"
#include "voxpack/packer/container.hpp"
#include "voxpack/packer/digitise.hpp"

using namespace voxpack;
using namespace voxpack::packer;
using voxpack::test::TempDir;

namespace {
Quat randomRotation(RandomStream& rng) {
  Quat q(rng.normal(), rng.normal(), rng.normal(), rng.normal());
  q.normalize();
  return q;
}
}  // namespace

// An off-centre ASCII box: exact volume/area, shifted to its centre of mass, box inertia.
TEST(Mesh, AsciiBoxMatchesAnalyticBox) {
  TempDir tmp;
  const auto path = tmp / "box.stl";
  test::writeAsciiStl(path, test::boxTriangles(Vec3(1, 2, 3), Vec3(3, 5, 7)));
  const auto m = parseShape("mesh:" + path.string());
  const auto b = parseShape("box:x=2,y=3,z=4");
  EXPECT_NEAR(m->volumeMm3(), 24.0, 1e-12);
  EXPECT_NEAR(m->surfaceMm2(), b->surfaceMm2(), 1e-12);
  EXPECT_LT((m->inertiaPerDensity() - b->inertiaPerDensity()).norm(), 1e-9);
  EXPECT_NEAR(m->bodyBoundsMm().min.x(), -1.0, 1e-12);
  EXPECT_NEAR(m->bodyBoundsMm().max.z(), 2.0, 1e-12);
  EXPECT_TRUE(m->inside(Vec3(0.9, 1.4, 1.9)));
  EXPECT_FALSE(m->inside(Vec3(1.1, 0, 0)));
  EXPECT_NEAR(m->signedDistanceMm(Vec3(0.5, 0, 0)), -0.5, 1e-12);
  EXPECT_NEAR(m->signedDistanceMm(Vec3(0, 0, 3)), 1.0, 1e-12);
  EXPECT_LT((m->normal(Vec3(0, 0, 1.9)) - Vec3(0, 0, 1)).norm(), 1e-9);
  // Scale multiplies lengths.
  const auto m2 = parseShape("mesh:" + path.string() + ",scale=2");
  EXPECT_NEAR(m2->volumeMm3(), 24.0 * 8, 1e-9);
  EXPECT_EQ(m2->spec(), "mesh:" + path.string() + ",scale=2");
}

// Digital volume within 1 % of the mesh volume at ~30 voxels across, any orientation.
TEST(Mesh, DigitalVolumeOfStlBoxAndCylinder) {
  TempDir tmp;
  test::writeAsciiStl(tmp / "box.stl", test::boxTriangles(Vec3(0, 0, 0), Vec3(3, 2, 1.5)));
  test::writeBinaryStl(tmp / "cyl.stl", test::cylinderTriangles(1.5, -1, 1, 96));
  const auto box = parseShape("mesh:" + (tmp / "box.stl").string());
  const auto cyl = parseShape("mesh:" + (tmp / "cyl.stl").string());
  // 96-gon prism: V = n/2 r^2 sin(2 pi / n) l.
  EXPECT_NEAR(cyl->volumeMm3(), 48 * 2.25 * std::sin(2 * std::numbers::pi / 96) * 2, 1e-5);
  const Lattice l = Lattice::isotropic(1, 1, 1, 0.1);  // 30 voxels across both
  for (int t = 0; t < 10; ++t) {
    RandomStream rng(41, static_cast<std::uint64_t>(t));
    const Quat q = randomRotation(rng);
    const Vec3 c(rng.uniform(), rng.uniform(), rng.uniform());
    for (const auto* s : {box.get(), cyl.get()}) {
      const DigitalParticle p = digitise(*s, c, q, l);
      EXPECT_LT(std::abs(p.volumeMm3() - s->volumeMm3()), 0.01 * s->volumeMm3()) << s->spec();
    }
  }
  // The faceted cylinder digitises like the analytic one (same voxel count within 1 %).
  const auto exact = parseShape("cylinder:d=3,l=2");
  // (Off a voxel centre: at the origin the caps fall exactly on voxel centres.)
  const Vec3 off(0.031, 0.017, 0.013);
  const auto a = digitise(*cyl, off, Quat::Identity(), l);
  const auto b = digitise(*exact, off, Quat::Identity(), l);
  EXPECT_LT(std::abs(static_cast<double>(a.voxels.size()) - static_cast<double>(b.voxels.size())),
            0.01 * static_cast<double>(b.voxels.size()));
}

// The row classifier agrees with one inside query per point, including rows through
// vertices and along edges of the mesh.
TEST(Mesh, RowTestAgreesWithPointTest) {
  TempDir tmp;
  test::writeBinaryStl(tmp / "cyl.stl", test::cylinderTriangles(1.0, -1, 1, 12));
  const auto s = parseShape("mesh:" + (tmp / "cyl.stl").string());
  RandomStream rng(5);
  std::vector<std::uint8_t> row(64);
  for (int t = 0; t < 300; ++t) {
    Vec3 p0(rng.uniform(-1.5, 1.5), rng.uniform(-1.5, 1.5), rng.uniform(-1.5, 1.5));
    Vec3 step = Vec3(rng.normal(), rng.normal(), rng.normal()).normalized() * 0.05;
    if (t % 3 == 0) {  // axis-aligned rows through the mesh vertices' planes
      p0 = Vec3(-1.6, 0, (t % 2) ? 1.0 : 0.0);
      step = Vec3(0.05, 0, 0);
    }
    s->insideRow(p0, step, 64, row.data());
    for (int k = 0; k < 64; ++k)
      ASSERT_EQ(row[static_cast<std::size_t>(k)] != 0, s->inside(p0 + k * step)) << t << " " << k;
  }
}

TEST(Mesh, BadMeshesAreRefused) {
  TempDir tmp;
  auto tris = test::boxTriangles(Vec3(0, 0, 0), Vec3(1, 1, 1));
  tris.pop_back();
  test::writeAsciiStl(tmp / "open.stl", tris);
  {
    std::ofstream f(tmp / "garbage.stl");
    f << "this is not an STL file\n";
  }
  {
    std::ofstream f(tmp / "badascii.stl");
    f << "solid x\n facet normal 0 0 1\n outer loop\n vertex 0 0 zz\n";
  }
  {
    std::ofstream f(tmp / "empty.stl");
    f << "solid empty\nendsolid empty\n";
  }
  for (const char* name : {"open.stl", "garbage.stl", "badascii.stl", "empty.stl"}) {
    const std::string path = (tmp / name).string();
    try {
      parseShape("mesh:" + path);
      ADD_FAILURE() << name << " accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    }
  }
  EXPECT_THROW(parseShape("mesh:" + (tmp / "missing.stl").string()), IoError);
  EXPECT_THROW(parseShape("mesh:" + (tmp / "open.stl").string() + ",scale=0"), InputError);
  EXPECT_THROW(parseContainer("mesh:" + (tmp / "open.stl").string()), InputError);
}

// A box mesh as a container reproduces the analytic box container's mask.
TEST(Mesh, MeshContainerMatchesBox) {
  TempDir tmp;
  test::writeAsciiStl(tmp / "box.stl", test::boxTriangles(Vec3(-2, -2, 0), Vec3(2, 2, 6)));
  const auto mc = parseContainer("mesh:" + (tmp / "box.stl").string());
  const auto bc = parseContainer("box:x=4,y=4,z=6");
  EXPECT_NEAR(mc->volumeMm3(), 96.0, 1e-9);
  const Lattice l = latticeForContainer(*mc, 0.5, 1);
  EXPECT_EQ(l, latticeForContainer(*bc, 0.5, 1));
  EXPECT_EQ(containerMask(*mc, l).values(), containerMask(*bc, l).values());
  for (const Vec3& p : {Vec3(0, 0, 3), Vec3(1.5, 0, 1), Vec3(0, 0, 7), Vec3(0.3, -1.9, 5.5)}) {
    EXPECT_NEAR(mc->wallDistanceMm(p), bc->wallDistanceMm(p), 1e-9);
  }
  EXPECT_LT((mc->inwardNormal(Vec3(1.9, 0, 3)) - Vec3(-1, 0, 0)).norm(), 1e-9);
}
