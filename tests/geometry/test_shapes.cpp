// Exact shapes: analytic volumes/areas, Monte Carlo oracles for volume and inertia,
// signed distances against brute force, and the spec parser's refusals.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "voxpack/core/errors.hpp"
#include "voxpack/core/random.hpp"
#include "voxpack/packer/shape.hpp"

using namespace voxpack;
using namespace voxpack::packer;

namespace {

constexpr double kPi = std::numbers::pi;

const char* kSpecs[] = {"sphere:d=5",          "cylinder:d=5.4,l=3.8",  "ring:d=10,di=6,l=10",
                        "box:x=2,y=3,z=4",     "ellipsoid:a=3,b=2,c=1", "trilobe:d=3,l=4",
                        "trilobe:d=3,dl=2,l=1"};

// Monte Carlo volume and inertia by sampling the body bounds; n samples.
struct McMoments {
  double volume = 0;
  Vec3 centroid = Vec3::Zero();
  Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero();
  double volumeSigma = 0;
};
McMoments monteCarlo(const Shape& s, int n, std::uint64_t seed) {
  RandomStream rng(seed);
  const BoundsMm b = s.bodyBoundsMm();
  const Vec3 ext = b.max - b.min;
  const double boxV = ext.prod();
  std::size_t hits = 0;
  Vec3 sum = Vec3::Zero();
  Eigen::Matrix3d I = Eigen::Matrix3d::Zero();
  for (int t = 0; t < n; ++t) {
    const Vec3 p(b.min.x() + ext.x() * rng.uniform(), b.min.y() + ext.y() * rng.uniform(),
                 b.min.z() + ext.z() * rng.uniform());
    if (!s.inside(p)) continue;
    ++hits;
    sum += p;
    I += p.squaredNorm() * Eigen::Matrix3d::Identity() - p * p.transpose();
  }
  McMoments m;
  const double f = static_cast<double>(hits) / n;
  m.volume = f * boxV;
  m.volumeSigma = std::sqrt(f * (1 - f) / n) * boxV;
  m.centroid = sum / static_cast<double>(hits);
  m.inertia = I * (boxV / n);
  return m;
}

}  // namespace

TEST(Shapes, AnalyticVolumesAndAreas) {
  EXPECT_NEAR(parseShape("sphere:d=2")->volumeMm3(), 4.0 / 3.0 * kPi, 1e-12);
  EXPECT_NEAR(parseShape("sphere:d=2")->surfaceMm2(), 4 * kPi, 1e-12);
  // Reference cylinder: V = 87.03 mm^3, d_pe = 5.498 mm (docs/references.md).
  const auto cyl = parseShape("cylinder:d=5.4,l=3.8");
  EXPECT_NEAR(cyl->volumeMm3(), 87.03, 0.01);
  EXPECT_NEAR(cyl->volumeEquivalentDiameterMm(), 5.498, 0.001);
  EXPECT_NEAR(cyl->surfaceMm2(), 2 * kPi * 2.7 * 2.7 + kPi * 5.4 * 3.8, 1e-9);
  const auto ring = parseShape("ring:d=10,di=6,l=10");
  EXPECT_NEAR(ring->volumeMm3(), kPi * (25 - 9) * 10, 1e-9);
  EXPECT_NEAR(ring->surfaceMm2(), 2 * kPi * 16 + kPi * 16 * 10, 1e-9);
  EXPECT_NEAR(parseShape("box:x=2,y=3,z=4")->surfaceMm2(), 2 * (6 + 12 + 8), 1e-12);
}

TEST(Shapes, CanonicalSpecRoundTrips) {
  for (const char* text : kSpecs) {
    const auto s = parseShape(text);
    const auto again = parseShape(s->spec());
    EXPECT_EQ(s->spec(), again->spec()) << text;
    EXPECT_DOUBLE_EQ(s->volumeMm3(), again->volumeMm3()) << text;
  }
  EXPECT_EQ(parseShape("cylinder:d=5.4,l=3.8")->spec(), "cylinder:d=5.4,l=3.8");
}

// Monte Carlo oracle of volume, centroid (origin = COM) and inertia for every shape:
// 400k samples give a relative volume sigma ~ 0.1-0.2 %, so 5 sigma is safe.
TEST(Shapes, MonteCarloVolumeCentroidInertia) {
  std::uint64_t seed = 11;
  for (const char* text : kSpecs) {
    const auto s = parseShape(text);
    const McMoments m = monteCarlo(*s, 400000, seed++);
    EXPECT_NEAR(m.volume, s->volumeMm3(), 5 * m.volumeSigma + 1e-12) << text;
    const double r = s->boundingRadiusMm();
    EXPECT_LT(m.centroid.norm(), 0.01 * r) << text;
    const Eigen::Matrix3d I = s->inertiaPerDensity();
    EXPECT_LT((m.inertia - I).norm(), 0.01 * I.norm()) << text;
  }
}

TEST(Shapes, BoundsContainTheShape) {
  std::uint64_t seed = 3;
  for (const char* text : kSpecs) {
    const auto s = parseShape(text);
    RandomStream rng(seed++);
    const double r = s->boundingRadiusMm() * 1.2;
    const BoundsMm b = s->bodyBoundsMm();
    for (int t = 0; t < 100000; ++t) {
      const Vec3 p(rng.uniform(-r, r), rng.uniform(-r, r), rng.uniform(-r, r));
      if (!s->inside(p)) continue;
      ASSERT_LE(p.norm(), s->boundingRadiusMm() * (1 + 1e-12)) << text;
      ASSERT_TRUE((p.array() >= b.min.array() - 1e-12).all() &&
                  (p.array() <= b.max.array() + 1e-12).all())
          << text;
    }
  }
}

// The signed distance has the inside test's sign and is a true distance: stepping
// |d| along the normal lands on the surface, and no surface point found by bisection
// along random rays is closer than |d|.
TEST(Shapes, SignedDistanceIsExact) {
  std::uint64_t seed = 5;
  for (const char* text : kSpecs) {
    const auto s = parseShape(text);
    RandomStream rng(seed++);
    const double r = s->boundingRadiusMm();
    for (int t = 0; t < 300; ++t) {
      const Vec3 p(rng.uniform(-1.3 * r, 1.3 * r), rng.uniform(-1.3 * r, 1.3 * r),
                   rng.uniform(-1.3 * r, 1.3 * r));
      const double d = s->signedDistanceMm(p);
      ASSERT_EQ(d <= 0, s->inside(p)) << text << " d=" << d;
      // Bisection along random rays for boundary points.
      for (int ray = 0; ray < 20; ++ray) {
        Vec3 u(rng.normal(), rng.normal(), rng.normal());
        u.normalize();
        const bool in0 = s->inside(p);
        double a = 0, b = -1;
        for (double t2 = r / 64; t2 < 3 * r; t2 += r / 64)
          if (s->inside(p + t2 * u) != in0) {
            b = t2;
            a = t2 - r / 64;
            break;
          }
        if (b < 0) continue;
        for (int it = 0; it < 60; ++it) {
          const double m = 0.5 * (a + b);
          (s->inside(p + m * u) == in0 ? a : b) = m;
        }
        ASSERT_LE(std::abs(d), a + 1e-9 * r) << text;
      }
      // The projected point lies on the surface.
      const Vec3 n = s->normal(p);
      const Vec3 foot = p - d * n;
      EXPECT_NEAR(s->signedDistanceMm(foot), 0.0, 1e-3 * r) << text;
    }
  }
}

// Ellipsoid area (Legendre's elliptic-integral form) against closed forms and a dense
// parametric quadrature.
TEST(Shapes, EllipsoidSurfaceArea) {
  EXPECT_NEAR(parseShape("ellipsoid:a=2,b=2,c=2")->surfaceMm2(), 16 * kPi, 1e-9);
  // Oblate spheroid a = b = 2, c = 1: S = 2 pi a^2 + pi c^2 / e ln((1 + e)/(1 - e)).
  const double e = std::sqrt(1 - 1.0 / 4);
  EXPECT_NEAR(parseShape("ellipsoid:a=2,b=2,c=1")->surfaceMm2(),
              2 * kPi * 4 + kPi / e * std::log((1 + e) / (1 - e)), 1e-9);
  // General: integrate |r_u x r_v| on a 2000 x 1000 midpoint grid.
  const double a = 3, b = 2, c = 1;
  double area = 0;
  const int nu = 2000, nv = 1000;
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      const double u = (i + 0.5) * 2 * kPi / nu, v = (j + 0.5) * kPi / nv;
      const Vec3 ru(-a * std::sin(u) * std::sin(v), b * std::cos(u) * std::sin(v), 0);
      const Vec3 rv(a * std::cos(u) * std::cos(v), b * std::sin(u) * std::cos(v), -c * std::sin(v));
      area += ru.cross(rv).norm();
    }
  area *= (2 * kPi / nu) * (kPi / nv);
  EXPECT_NEAR(parseShape("ellipsoid:a=3,b=2,c=1")->surfaceMm2(), area, 1e-5 * area);
  EXPECT_NEAR(parseShape("ellipsoid:a=1,b=3,c=2")->surfaceMm2(), area, 1e-5 * area);
}

TEST(Shapes, TrilobeSectionLimits) {
  // As dl -> d the lobes merge into one disc of diameter d.
  const auto t = parseShape("trilobe:d=2,dl=1.999999,l=1");
  EXPECT_NEAR(t->volumeMm3(), kPi, 1e-4);
  EXPECT_NEAR(t->surfaceMm2(), 2 * kPi + 2 * kPi, 1e-4);
}

TEST(Shapes, BadSpecsAreRefused) {
  for (const char* bad : {"blob:d=1", "sphere", "sphere:d=0", "sphere:d=-1", "sphere:d=abc",
                          "cylinder:d=1", "ring:d=5,di=5,l=1", "ring:d=5,di=6,l=1", "box:x=1,y=1",
                          "sphere:d=1,q=2", "ellipsoid:a=1,b=1,c=0", "trilobe:d=2,dl=3,l=1",
                          "trilobe:d=2,dl=0.5,l=1", "sphere:d=1,extra", "mesh:", ""}) {
    EXPECT_THROW(parseShape(bad), InputError) << bad;
  }
}

// The analytic row fill agrees with the point test away from rounding at the surface.
TEST(Shapes, RowFillAgreesWithPointTest) {
  std::uint64_t seed = 21;
  std::vector<std::uint8_t> row(80);
  for (const char* text : kSpecs) {
    const auto s = parseShape(text);
    RandomStream rng(seed++);
    const double r = s->boundingRadiusMm();
    for (int t = 0; t < 400; ++t) {
      const Vec3 p0(rng.uniform(-1.2 * r, 1.2 * r), rng.uniform(-1.2 * r, 1.2 * r),
                    rng.uniform(-1.2 * r, 1.2 * r));
      Vec3 step = Vec3(rng.normal(), rng.normal(), rng.normal()).normalized() * (r / 30);
      if (t % 4 == 0) step = Vec3(r / 30, 0, 0);  // axis-parallel rows
      if (t % 4 == 1) step = Vec3(0, 0, r / 30);
      s->insideRow(p0, step, 80, row.data());
      for (int k = 0; k < 80; ++k) {
        const Vec3 p = p0 + k * step;
        if (std::abs(s->signedDistanceMm(p)) < 1e-9 * r) continue;
        ASSERT_EQ(row[static_cast<std::size_t>(k)] != 0, s->inside(p)) << text << " " << t;
      }
    }
  }
}
