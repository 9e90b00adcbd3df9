// Contacts from exact signed distances, and the contact treatments checked with CGAL:
// gap leaves no two particle meshes intersecting, bridge and overlap make one closed solid,
// cap keeps every shell closed.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "voxpack/export/cgal_ops.hpp"
#include "voxpack/export/contacts.hpp"
#include "voxpack/export/surfaces.hpp"
#include "voxpack/export/tessellate.hpp"
#include "voxpack/packer/container.hpp"

namespace voxpack::exporter {
namespace {

PosedParticle make(const std::string& spec, const Vec3& c, const Quat& q = Quat::Identity()) {
  PosedParticle p;
  p.shape = packer::parseShape(spec);
  p.centreMm = c;
  p.orientation = q;
  p.surface = posed(tessellateShape(spec, p.shape->characteristicDiameterMm() / 500), c, q);
  return p;
}

TEST(Contacts, TouchingSpheresGiveOnePointContact) {
  const std::vector<PosedParticle> ps = {make("sphere:d=3", {0, 0, 0}),
                                         make("sphere:d=3", {3, 0, 0})};
  const auto c = findContacts(ps, nullptr, {0.05, 1});
  ASSERT_EQ(c.size(), 1u);
  EXPECT_NEAR(c[0].gapMm, 0.0, 1e-6);
  EXPECT_NEAR((c[0].pointMm - Vec3(1.5, 0, 0)).norm(), 0.0, 1e-6);
  EXPECT_NEAR(c[0].normal.x(), 1.0, 1e-6);
}

TEST(Contacts, GapsAreExactAndTheToleranceDecides) {
  const std::vector<PosedParticle> ps = {make("sphere:d=3", {0, 0, 0}),
                                         make("sphere:d=3", {0, 3.5, 0})};
  EXPECT_TRUE(findContacts(ps, nullptr, {0.25, 1}).empty());
  const auto c = findContacts(ps, nullptr, {0.6, 2});
  ASSERT_EQ(c.size(), 1u);
  EXPECT_NEAR(c[0].gapMm, 0.5, 1e-6);
  EXPECT_NEAR(c[0].normal.y(), 1.0, 1e-6);
}

TEST(Contacts, CylinderOnSphereAndTiltedCylinders) {
  // Cylinder standing on a sphere (face on a point), then a cylinder resting tilted on a
  // flat face: its rim touches at one point.
  const double tilt = 0.5;
  const Quat q(Eigen::AngleAxisd(tilt, Vec3::UnitX()));
  // Lowest point of a tilted cylinder (r=1.5, h=1): z = -(r sin t + h cos t).
  const double drop = 1.5 * std::sin(tilt) + 1.0 * std::cos(tilt);
  const std::vector<PosedParticle> ps = {
      make("sphere:d=3", {0, 0, 0}), make("cylinder:d=3,l=2", {0, 0, 2.5}),
      make("cylinder:d=3,l=2", {0.3, 0.2, 3.5 + drop + 0.01}, q)};
  const auto c = findContacts(ps, nullptr, {0.05, 1});
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(c[0].a, 0);
  EXPECT_EQ(c[0].b, 1);
  EXPECT_NEAR(c[0].gapMm, 0.0, 1e-6);
  EXPECT_NEAR(c[0].normal.z(), 1.0, 1e-6);
  EXPECT_EQ(c[1].a, 1);
  EXPECT_EQ(c[1].b, 2);
  EXPECT_NEAR(c[1].gapMm, 0.01, 2e-4);
}

TEST(Contacts, WallContact) {
  const auto wall = packer::parseContainer("cylinder:d=11,h=11");
  // Sphere 1 touches the side wall only; sphere 2 is 0.5 mm above the floor.
  const std::vector<PosedParticle> ps = {make("sphere:d=3", {0, -4, 5}),
                                         make("sphere:d=3", {0, 0, 2})};
  const auto c = findContacts(ps, wall.get(), {0.05, 1});
  ASSERT_EQ(c.size(), 1u);
  EXPECT_EQ(c[0].b, -1);
  EXPECT_NEAR(c[0].gapMm, 0.0, 1e-6);  // wall distance of the exact surface point
  EXPECT_NEAR(c[0].normal.y(), -1.0, 1e-6);
  const auto c2 = findContacts(ps, wall.get(), {0.6, 1});
  ASSERT_EQ(c2.size(), 2u);
  EXPECT_NEAR(c2[1].gapMm, 0.5, 1e-6);
  EXPECT_NEAR(c2[1].normal.z(), -1.0, 1e-6);
}

// A sphere in the corner of floor and round wall touches both: one contact per wall part,
// each with its own normal (the container's single wall distance would give only one).
TEST(Contacts, CornerParticleGetsOneContactPerWallPart) {
  const auto wall = packer::parseContainer("cylinder:d=11,h=11");
  const std::vector<PosedParticle> ps = {make("sphere:d=3", {0, -4, 1.5})};
  auto c = findContacts(ps, wall.get(), {0.05, 1});
  ASSERT_EQ(c.size(), 2u);
  std::sort(c.begin(), c.end(), [](const Contact& x, const Contact& y) { return x.wall < y.wall; });
  EXPECT_EQ(c[0].wall, WallPart::Side);
  EXPECT_NEAR(c[0].normal.y(), -1.0, 1e-6);
  EXPECT_NEAR(c[0].pointMm.z(), 1.5, 1e-4);
  EXPECT_EQ(c[1].wall, WallPart::Floor);
  EXPECT_NEAR(c[1].normal.z(), -1.0, 1e-9);
  EXPECT_NEAR(c[1].gapMm, 0.0, 1e-6);
  // Open column ends (CFD inlet/outlet): only the round wall takes contacts.
  const auto side = findContacts(ps, wall.get(), {0.05, 1, WallContacts::Side});
  ASSERT_EQ(side.size(), 1u);
  EXPECT_EQ(side[0].wall, WallPart::Side);
  EXPECT_TRUE(findContacts(ps, wall.get(), {0.05, 1, WallContacts::None}).empty());
  // A box: a sphere in the corner of two vertical faces and the floor touches three.
  const auto box = packer::parseContainer("box:x=10,y=10,z=10");
  const auto cb = findContacts({make("sphere:d=3", {-3.5, 3.5, 1.5})}, box.get(), {0.05, 1});
  EXPECT_EQ(cb.size(), 3u);
}

// A chain of touching spheres and a cylinder on top, in a column: a bed without voxels
// (the surfaces need only the particle table and the container).
Bed chainBed() {
  Bed bed;
  bed.indicator = Grid<std::uint8_t>(Lattice::isotropic(4, 4, 4, 0.25), 1);
  const std::vector<std::pair<std::string, Vec3>> ps = {{"sphere:d=3", {0, 0, 1.5}},
                                                        {"sphere:d=3", {3, 0, 1.5}},
                                                        {"sphere:d=3", {0, -4, 1.5}},
                                                        {"cylinder:d=3,l=2", {0, 0, 4}},
                                                        {"sphere:d=3", {-3, 0, 1.5}}};
  for (const auto& [s, c] : ps) {
    bed.particles.shape.push_back(s);
    bed.particles.positionMm.push_back(c);
    bed.particles.orientation.push_back(Quat::Identity());
  }
  bed.provenance = {{"scene", {{"container", "cylinder:d=11,h=11"}}}};
  return bed;
}

TEST(Treatments, NoneTouchesGapSeparates) {
  const Bed bed = chainBed();
  SurfaceOptions o;
  o.contactToleranceMm = 0.05;
  const SurfaceResult none = particleSurfaces(bed, o);
  ASSERT_EQ(none.solids.size(), 6u);
  // The exact spheres touch; their volume-exact meshes (vertices just outside) intersect:
  // the check below can fail.
  EXPECT_TRUE(meshesIntersect(none.solids[0].mesh, none.solids[1].mesh));
  o.contacts = ContactTreatment::Gap;
  const SurfaceResult gap = particleSurfaces(bed, o);
  ASSERT_EQ(gap.solids.size(), 6u);
  for (std::size_t a = 0; a < 5; ++a) {
    EXPECT_TRUE(isClosedManifold(gap.solids[a].mesh));
    for (std::size_t b = a + 1; b < 5; ++b)
      EXPECT_FALSE(meshesIntersect(gap.solids[a].mesh, gap.solids[b].mesh)) << a << " " << b;
  }
  EXPECT_EQ(gap.report["particle_contacts"], 3);
  // The four spheres stand on the floor, and the one at y = -4 also touches the round wall.
  EXPECT_EQ(gap.report["wall_contacts"], 5);
  EXPECT_EQ(gap.report["wall_contacts_by_part"]["floor"], 4);
  EXPECT_EQ(gap.report["wall_contacts_by_part"]["side"], 1);
}

TEST(Treatments, BridgeAndOverlapGiveOneClosedSolid) {
  const Bed bed = chainBed();
  for (ContactTreatment t : {ContactTreatment::Bridge, ContactTreatment::Overlap}) {
    SurfaceOptions o;
    o.contactToleranceMm = 0.05;
    o.contacts = t;
    o.toleranceMm = 0.03;
    o.wall = false;
    const SurfaceResult r = particleSurfaces(bed, o);
    ASSERT_EQ(r.solids.size(), 1u);
    const TriMesh& m = r.solids[0].mesh;
    EXPECT_TRUE(isClosedManifold(m));
    // Spheres 1, 2, 5 and the cylinder are one body; sphere 3 touches only the wall, so
    // it (with its wall bridge) is a second shell of the one solid.
    EXPECT_EQ(connectedComponents(m), 2u);
    EXPECT_EQ(r.report["self_intersecting"], selfIntersects(m));
    double sum = 0;
    for (const auto& s : bed.particles.shape) sum += packer::parseShape(s)->volumeMm3();
    // Bridges add a little volume; overlaps (x1.01 each) add 3 % and lose the lenses.
    EXPECT_GT(enclosedVolumeMm3(m), sum * 0.999);
    EXPECT_LT(enclosedVolumeMm3(m), sum * 1.04);
  }
}

TEST(Treatments, CapFlattensAndKeepsShellsClosed) {
  const Bed bed = chainBed();
  SurfaceOptions o;
  o.contactToleranceMm = 0.05;
  o.contacts = ContactTreatment::Cap;
  const SurfaceResult r = particleSurfaces(bed, o);
  ASSERT_EQ(r.solids.size(), 6u);
  // Sphere 1 has three contacts (spheres 2 and 5, the cylinder): three caps of height
  // h = R - sqrt(R^2 - a^2) with a = 0.1 d. Cap volume pi h^2 (3R - h) / 3.
  const double R = 1.5, a = 0.3, h = R - std::sqrt(R * R - a * a);
  const double want =
      4.0 / 3 * std::numbers::pi * R * R * R - 3 * std::numbers::pi * h * h * (3 * R - h) / 3;
  EXPECT_TRUE(isClosedManifold(r.solids[0].mesh));
  EXPECT_NEAR(enclosedVolumeMm3(r.solids[0].mesh) / want, 1.0, 2e-3);
  for (std::size_t a1 = 0; a1 < 5; ++a1) {
    EXPECT_TRUE(isClosedManifold(r.solids[a1].mesh)) << a1;
    for (std::size_t b = a1 + 1; b < 5; ++b)
      EXPECT_FALSE(meshesIntersect(r.solids[a1].mesh, r.solids[b].mesh)) << a1 << " " << b;
  }
}

}  // namespace
}  // namespace voxpack::exporter
