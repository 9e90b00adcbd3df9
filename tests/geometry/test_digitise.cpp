// The digitiser: volume/surface errors against the numbers, face bits, moments,
// translation invariance, holes, supersampling and refusals.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <thread>

#include "voxpack/core/errors.hpp"
#include "voxpack/core/random.hpp"
#include "voxpack/packer/digitise.hpp"

using namespace voxpack;
using namespace voxpack::packer;

namespace {

Quat randomRotation(RandomStream& rng) {
  // Uniform on SO(3): a normalised 4D Gaussian.
  Quat q(rng.normal(), rng.normal(), rng.normal(), rng.normal());
  q.normalize();
  return q;
}

double volumeError(const Shape& s, const DigitalParticle& p) {
  return (p.volumeMm3() - s.volumeMm3()) / s.volumeMm3();
}

}  // namespace

// Paper Fig. 2 at 50 voxels across: the volume error is small, the voxel-face surface
// error is near its asymptote of 50 % (a sphere's faces overcount the area by 3/2).
TEST(Digitise, Sphere50VoxelsAcross) {
  const auto s = parseShape("sphere:d=50");
  const Lattice l = Lattice::isotropic(1, 1, 1, 1.0);
  const DigitalParticle p = digitise(*s, Vec3(0.1, 0.2, 0.3), Quat::Identity(), l);
  EXPECT_LT(std::abs(volumeError(*s, p)), 0.005);
  const double surfErr = (p.faceSurfaceMm2 - s->surfaceMm2()) / s->surfaceMm2();
  EXPECT_GT(surfErr, 0.40);
  EXPECT_LT(surfErr, 0.60);
  // Digital moments: COM within 0.05 voxel of the exact centre, inertia within 1 %.
  EXPECT_LT((p.centreOfMassMm - Vec3(0.1, 0.2, 0.3)).norm(), 0.05);
  const Eigen::Matrix3d I = s->inertiaPerDensity();
  EXPECT_LT((p.inertiaPerDensity - I).norm(), 0.01 * I.norm());
}

// Reference cylinder at 0.18 mm (30 voxels per diameter), 100 random orientations.
TEST(Digitise, ReferenceCylinderOrientations) {
  const auto s = parseShape("cylinder:d=5.4,l=3.8");
  const Lattice l = Lattice::isotropic(1, 1, 1, 0.18);
  std::size_t lo = SIZE_MAX, hi = 0;
  double worst = 0, sum = 0, sum2 = 0;
  for (int t = 0; t < 100; ++t) {
    RandomStream rng(2024, static_cast<std::uint64_t>(t));
    const Quat q = randomRotation(rng);
    const Vec3 c(rng.uniform(), rng.uniform(), rng.uniform());
    const DigitalParticle p = digitise(*s, c, q, l);
    worst = std::max(worst, std::abs(volumeError(*s, p)));
    lo = std::min(lo, p.voxels.size());
    hi = std::max(hi, p.voxels.size());
    const double n = static_cast<double>(p.voxels.size());
    sum += n;
    sum2 += n * n;
  }
  const double mean = sum / 100, sd = std::sqrt(std::max(0.0, sum2 / 100 - mean * mean));
  std::printf(
      "reference cylinder @0.18 mm, 100 orientations: voxels min %zu max %zu mean %.1f "
      "sd %.1f (exact %.1f), worst |volume error| %.3f %%\n",
      lo, hi, mean, sd, s->volumeMm3() / (0.18 * 0.18 * 0.18), 100 * worst);
  EXPECT_LT(worst, 0.01);
}

// Face bits agree with the voxel set: a bit is set exactly when that neighbour is absent;
// voxels are sorted and unique; the surface list holds every voxel with a face.
TEST(Digitise, FaceBitsMatchNeighbours) {
  RandomStream rng(7);
  for (const char* spec : {"ring:d=10,di=6,l=4", "trilobe:d=6,l=5", "ellipsoid:a=4,b=3,c=2"}) {
    const auto s = parseShape(spec);
    const Lattice l = Lattice::isotropic(1, 1, 1, 0.5);
    const DigitalParticle p = digitise(*s, Vec3(0.3, -0.2, 0.1), randomRotation(rng), l);
    ASSERT_TRUE(std::is_sorted(p.voxels.begin(), p.voxels.end()));
    ASSERT_EQ(std::adjacent_find(p.voxels.begin(), p.voxels.end()), p.voxels.end());
    const auto has = [&](Voxel v) {
      return std::binary_search(p.voxels.begin(), p.voxels.end(), v);
    };
    std::vector<std::uint8_t> bits(p.voxels.size(), 0);
    ASSERT_EQ(p.surface.size(), p.surfaceFaces.size());
    for (std::size_t n = 0; n < p.surface.size(); ++n) bits[p.surface[n]] = p.surfaceFaces[n];
    std::size_t faces = 0;
    for (std::size_t n = 0; n < p.voxels.size(); ++n) {
      const Voxel v = p.voxels[n];
      const Voxel nb[6] = {{v.k, v.j, v.i - 1}, {v.k, v.j, v.i + 1}, {v.k, v.j - 1, v.i},
                           {v.k, v.j + 1, v.i}, {v.k - 1, v.j, v.i}, {v.k + 1, v.j, v.i}};
      for (int f = 0; f < 6; ++f) {
        const bool out = !has(nb[f]);
        ASSERT_EQ(out, (bits[n] >> f & 1) != 0) << spec;
        faces += out;
      }
    }
    EXPECT_EQ(faces, p.faceCount);
    EXPECT_DOUBLE_EQ(p.faceSurfaceMm2, static_cast<double>(faces) * 0.25);
  }
}

// An axis-aligned box whose faces fall between voxel centres is reproduced exactly.
TEST(Digitise, AlignedBoxIsExact) {
  const auto s = parseShape("box:x=4,y=3,z=2");
  const Lattice l = Lattice::isotropic(1, 1, 1, 1.0);
  const DigitalParticle p = digitise(*s, Vec3(0.5, 0, 0.5), Quat::Identity(), l);
  EXPECT_EQ(p.voxels.size(), 24u);
  EXPECT_EQ(p.faceCount, 2u * (12 + 8 + 6));
  EXPECT_DOUBLE_EQ(p.faceSurfaceMm2, s->surfaceMm2());
  EXPECT_LT((p.centreOfMassMm - Vec3(0.5, 0, 0.5)).norm(), 1e-12);
  // Voxel cubes included: a block of whole voxels has the exact box inertia.
  EXPECT_LT((p.inertiaPerDensity - s->inertiaPerDensity()).norm(), 1e-9);
}

// Shifting the centre by whole voxels shifts the voxel set and nothing else.
TEST(Digitise, IntegerTranslationInvariance) {
  const auto s = parseShape("cylinder:d=5.4,l=3.8");
  const Lattice l = Lattice::isotropic(1, 1, 1, 0.27);
  RandomStream rng(9);
  const Quat q = randomRotation(rng);
  const Vec3 c(0.05, 0.11, -0.07);
  const DigitalParticle a = digitise(*s, c, q, l);
  const DigitalParticle b = digitise(*s, c + Vec3(3, -2, 5) * 0.27, q, l);
  ASSERT_EQ(a.voxels.size(), b.voxels.size());
  for (std::size_t n = 0; n < a.voxels.size(); ++n) {
    EXPECT_EQ(b.voxels[n].i, a.voxels[n].i + 3);
    EXPECT_EQ(b.voxels[n].j, a.voxels[n].j - 2);
    EXPECT_EQ(b.voxels[n].k, a.voxels[n].k + 5);
  }
  EXPECT_EQ(a.surfaceFaces, b.surfaceFaces);
}

// A ring's hole stays empty at any orientation and with supersampling: no solid voxel
// contains a point of the axis segment inside the hole.
TEST(Digitise, RingHoleStaysEmpty) {
  const auto s = parseShape("ring:d=10,di=6,l=10");
  const Lattice l = Lattice::isotropic(1, 1, 1, 1.0);  // hole 6 voxels across
  for (int ss : {1, 3}) {
    for (int t = 0; t < 50; ++t) {
      RandomStream rng(31, static_cast<std::uint64_t>(t));
      const Quat q = randomRotation(rng);
      const Vec3 c(rng.uniform(), rng.uniform(), rng.uniform());
      DigitiseOptions opt;
      opt.supersample = ss;
      const DigitalParticle p = digitise(*s, c, q, l, opt);
      for (double z = -4.9; z <= 4.9; z += 0.1) {
        const Vec3 w = c + q * Vec3(0, 0, z);
        const Index3 x = l.nearestIndex(w);
        const Voxel v{static_cast<std::int32_t>(x.k), static_cast<std::int32_t>(x.j),
                      static_cast<std::int32_t>(x.i)};
        ASSERT_FALSE(std::binary_search(p.voxels.begin(), p.voxels.end(), v))
            << "ss=" << ss << " t=" << t << " z=" << z;
      }
      // The ring has a hole in its digital form: the voxel at the centre is void.
      EXPECT_LT(std::abs(volumeError(*s, p)), 0.05);
    }
  }
}

// Supersampling reduces the volume error of a small sphere (10 voxels across) averaged
// over sub-voxel positions.
TEST(Digitise, SupersamplingRefinesVolume) {
  const auto s = parseShape("sphere:d=10");
  const Lattice l = Lattice::isotropic(1, 1, 1, 1.0);
  double err1 = 0, err3 = 0;
  for (int t = 0; t < 20; ++t) {
    RandomStream rng(77, static_cast<std::uint64_t>(t));
    const Vec3 c(rng.uniform(), rng.uniform(), rng.uniform());
    DigitiseOptions o3;
    o3.supersample = 3;
    err1 += std::abs(volumeError(*s, digitise(*s, c, Quat::Identity(), l)));
    err3 += std::abs(volumeError(*s, digitise(*s, c, Quat::Identity(), l, o3)));
  }
  EXPECT_LT(err1 / 20, 0.05);
  EXPECT_LT(err3 / 20, 0.05);
}

TEST(Digitise, Refusals) {
  const auto s = parseShape("sphere:d=1");
  const Lattice l = Lattice::isotropic(1, 1, 1, 0.1);
  EXPECT_THROW(digitise(*s, Vec3::Zero(), Quat(0, 0, 0, 0), l), InputError);
  EXPECT_THROW(digitise(*s, Vec3::Zero(), Quat(2, 0, 0, 0), l), InputError);
  DigitiseOptions bad;
  bad.supersample = 0;
  EXPECT_THROW(digitise(*s, Vec3::Zero(), Quat::Identity(), l, bad), InputError);
  EXPECT_THROW(normalisedQuaternion(0, 0, 0, 0), InputError);
  EXPECT_THROW(normalisedQuaternion(std::nan(""), 0, 0, 1), InputError);
  const Quat q = normalisedQuaternion(2, 0, 0, 0);
  EXPECT_DOUBLE_EQ(q.w(), 1.0);
  // A voxel size far too small is refused rather than allocating terabytes.
  EXPECT_THROW(digitise(*s, Vec3::Zero(), Quat::Identity(), Lattice::isotropic(1, 1, 1, 1e-6)),
               InputError);
}

// A shape smaller than the gap between voxel centres may vanish; that is a result.
TEST(Digitise, TinyShapeMayBeEmpty) {
  const auto s = parseShape("sphere:d=0.1");
  const DigitalParticle p =
      digitise(*s, Vec3(0.5, 0.5, 0.5), Quat::Identity(), Lattice::isotropic(1, 1, 1, 1.0));
  EXPECT_TRUE(p.voxels.empty());
  EXPECT_EQ(p.faceCount, 0u);
}

// Per-thread scratch: concurrent digitisations give exactly the serial result.
TEST(Digitise, ConcurrentCallsMatchSerial) {
  const auto s = parseShape("trilobe:d=3,l=4");
  const Lattice l = Lattice::isotropic(1, 1, 1, 0.1);
  std::vector<Quat> poses;
  for (int t = 0; t < 16; ++t) {
    RandomStream rng(55, static_cast<std::uint64_t>(t));
    poses.push_back(randomRotation(rng));
  }
  std::vector<DigitalParticle> serial, parallel(poses.size());
  for (const auto& q : poses) serial.push_back(digitise(*s, Vec3(0.01, 0.02, 0.03), q, l));
  std::vector<std::thread> workers;
  for (int w = 0; w < 4; ++w)
    workers.emplace_back([&, w] {
      for (std::size_t n = static_cast<std::size_t>(w); n < poses.size(); n += 4)
        parallel[n] = digitise(*s, Vec3(0.01, 0.02, 0.03), poses[n], l);
    });
  for (auto& t : workers) t.join();
  for (std::size_t n = 0; n < poses.size(); ++n) {
    EXPECT_EQ(serial[n].voxels, parallel[n].voxels);
    EXPECT_EQ(serial[n].surfaceFaces, parallel[n].surfaceFaces);
    EXPECT_EQ(serial[n].centreOfMassMm, parallel[n].centreOfMassMm);
  }
}
