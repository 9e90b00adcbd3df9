// Mean empty space (lattice and isotropic CGAL paths), pore sizes, chords, shadows, labels.
#include <gtest/gtest.h>

#include <cmath>

#include "stats_fixtures.hpp"
#include "voxpack/core/bed_file.hpp"
#include "voxpack/core/random.hpp"
#include "voxpack/stats/mes.hpp"
#include "voxpack/stats/structure.hpp"

namespace voxpack::stats {
namespace {

// A void ball of radius R in solid: every chord is bounded, none is cut by the window.
// For a uniform point in a ball and any direction (fixed or isotropic) the chord through it
// has mean E[ℓ²]/E[ℓ] over isotropic chords = 2R² / (4R/3) = 1.5 R.
Bed voidBall(double radius, std::int64_t n) {
  Bed bed = test::bedOf(Grid<std::uint8_t>(Lattice::isotropic(n, n, n, 0.5), 0));
  const double c = 0.5 * static_cast<double>(n - 1);
  for (std::int64_t k = 0; k < n; ++k)
    for (std::int64_t j = 0; j < n; ++j)
      for (std::int64_t i = 0; i < n; ++i)
        if (std::pow(i - c, 2) + std::pow(j - c, 2) + std::pow(k - c, 2) <= radius * radius)
          bed.indicator(k, j, i) = 1;
  return bed;
}

TEST(Mes, VoidBallLatticeAndIsotropic) {
  const double radius = 10, voxel = 0.5;
  const Bed bed = voidBall(radius, 24);
  const MesResult lat = meanEmptySpaceLattice(bed, {});
  EXPECT_EQ(lat.undefinedVoxels, 0u);
  // Digitisation at R = 10 voxels: measured 1.3 % low (lattice), 3 % low (isotropic rays
  // meet the staircase surface first).
  EXPECT_NEAR(lat.distribution.meanMm, 1.5 * radius * voxel, 0.05 * 1.5 * radius * voxel);
  EXPECT_NEAR(lat.directionalMeanMm, lat.distribution.meanMm, 1e-3);
  MesIsotropicOptions io;
  io.samples = 400;
  io.directions = 32;
  io.threads = 2;
  const MesResult iso = meanEmptySpaceIsotropic(bed, io);
  EXPECT_EQ(iso.undefinedVoxels, 0u);
  EXPECT_NEAR(iso.distribution.meanMm, 1.5 * radius * voxel, 0.06 * 1.5 * radius * voxel);
  // The lattice path puts every chord on a voxel count: pdf integrates to 1.
  double integral = 0;
  for (double p : lat.distribution.pdf) integral += p * lat.distribution.binWidthMm;
  EXPECT_NEAR(integral, 1.0, 1e-9);
}

TEST(Mes, BooleanSpheresMeanIsTwiceMeanChord) {
  // Boolean spheres R = 8 voxels, η = 0.9, 128³: E[m] = 2ℓ_C = 8R/(3η) = 23.70 voxels. One
  // window's E[m] scatters by ~±5 % (long chords dominate; seeds 1-8 measured 21.4..24.4
  // with the directional estimator), so we average four realisations.
  const double radius = 8, eta = 0.9;
  double sum = 0, voxelSum = 0;
  for (std::uint64_t seed = 1; seed <= 4; ++seed) {
    MesLatticeOptions o;
    o.threads = 2;
    const MesResult r =
        meanEmptySpaceLattice(test::bedOf(test::booleanSpheres(128, radius, eta, seed)), o);
    sum += r.directionalMeanMm;
    voxelSum += r.distribution.meanMm;
  }
  const double expected = 8 * radius / (3 * eta);
  EXPECT_NEAR(sum / 4, expected, 0.05 * expected);
  EXPECT_NEAR(voxelSum / 4, expected, 0.05 * expected);
}

TEST(Mes, SameResultForAnyThreadCount) {
  const Bed bed = test::bedOf(test::booleanSpheres(40, 4, 0.9, 3));
  MesIsotropicOptions io;
  io.samples = 200;
  io.directions = 8;
  io.threads = 1;
  const MesResult a = meanEmptySpaceIsotropic(bed, io);
  io.threads = 2;
  const MesResult b = meanEmptySpaceIsotropic(bed, io);
  EXPECT_EQ(a.distribution.meanMm, b.distribution.meanMm);
  MesLatticeOptions lo;
  lo.threads = 1;
  const MesResult c = meanEmptySpaceLattice(bed, lo);
  lo.threads = 3;
  const MesResult d = meanEmptySpaceLattice(bed, lo);
  // The lattice path's sums are exact integers: every number is the same bits.
  EXPECT_EQ(c.distribution.meanMm, d.distribution.meanMm);
  EXPECT_EQ(c.distribution.stdMm, d.distribution.stdMm);
  EXPECT_EQ(c.distribution.lognormalSigma, d.distribution.lognormalSigma);
  EXPECT_EQ(c.distribution.pdf, d.distribution.pdf);
  EXPECT_EQ(c.directionalMeanMm, d.directionalMeanMm);
}

TEST(Mes, ExtremesAreDefined) {
  // All solid: no sample, NaN-free summary (mean reported as NaN -> null in JSON).
  const Bed solid = test::bedOf(Grid<std::uint8_t>(Lattice::isotropic(5, 5, 5, 1.0), 0));
  const MesResult a = meanEmptySpaceLattice(solid, {});
  EXPECT_EQ(a.voidVoxels, 0u);
  EXPECT_EQ(a.distribution.samples, 0u);
  // All void: every chord is cut by the window.
  const Bed open = test::bedOf(Grid<std::uint8_t>(Lattice::isotropic(5, 5, 5, 1.0), 1));
  const MesResult b = meanEmptySpaceLattice(open, {});
  EXPECT_EQ(b.undefinedVoxels, b.voidVoxels);
  EXPECT_EQ(b.distribution.samples, 0u);
  const MesResult c = meanEmptySpaceIsotropic(open, {});
  EXPECT_EQ(c.distribution.samples, 0u);
}

TEST(PoreSize, BooleanSpheresTail) {
  // Distance from a void voxel centre to the nearest solid voxel centre vs Torquato's
  // F(δ) = exp{−η[(1 + δ/R)³ − 1]}: the nearest solid centre lies ~half a voxel inside the
  // sphere surface, so compare F(d − 0.5). Distances take discrete lattice values, so only
  // d = 2..5 voxels are compared; measured deviations 0.002..0.029 (seed 21): within 0.035.
  const double radius = 8, eta = 0.5;
  const Bed bed = test::bedOf(test::booleanSpheres(96, radius, eta, 21));
  const PoreSizeDistribution p = poreSizeDistribution(bed, 0.5, 2);
  for (std::size_t b = 4; b < p.ccdf.size() && p.ccdfMm[b] < 5.5; b += 2) {
    const double delta = p.ccdfMm[b] - 0.5;
    const double exact = std::exp(-eta * (std::pow(1 + delta / radius, 3) - 1));
    EXPECT_NEAR(p.ccdf[b], exact, 0.035) << "delta " << p.ccdfMm[b];
  }
}

TEST(PoreSize, DistanceTransformIsExact) {
  // One solid voxel in the middle of an anisotropic lattice: distances are Euclidean.
  Lattice l;
  l.dims = {7, 9, 11};
  l.spacingMm = {0.5, 0.3, 0.2};
  std::vector<std::uint8_t> src(l.size(), 0);
  src[l.offset(3, 4, 5)] = 1;
  const auto d2 = squaredDistanceTransform(src, l, 2);
  for (std::int64_t k = 0; k < 7; ++k)
    for (std::int64_t j = 0; j < 9; ++j)
      for (std::int64_t i = 0; i < 11; ++i) {
        const double e =
            std::pow((k - 3) * 0.5, 2) + std::pow((j - 4) * 0.3, 2) + std::pow((i - 5) * 0.2, 2);
        EXPECT_NEAR(d2[l.offset(k, j, i)], e, 1e-12);
      }
}

TEST(Chords, SlabsGiveExactChords) {
  // Solid planes every 6 slices along z: every z chord is 5 voxels = 2.5 mm.
  Bed bed = test::bedOf(Grid<std::uint8_t>(Lattice::isotropic(31, 4, 4, 0.5), 1));
  for (std::int64_t k = 0; k < 31; k += 6)
    for (std::int64_t j = 0; j < 4; ++j)
      for (std::int64_t i = 0; i < 4; ++i) bed.indicator(k, j, i) = 0;
  const ChordLengths c = chordLengths(bed, 0);
  EXPECT_NEAR(c.perAxis[0].meanMm, 2.5, 1e-12);
  EXPECT_EQ(c.perAxis[0].samples, 5u * 16u);
  EXPECT_EQ(c.perAxis[2].samples, 0u);  // x and y runs are all cut by the window
}

// The run counts give the distribution of the list of every chord (the definition: void
// runs bounded on both ends, weighted 1/(n - l - 1) along axes the window cuts), on a
// random masked anisotropic bed whose void touches the box faces.
TEST(Chords, RunCountsMatchAListOfEveryChord) {
  Lattice l = Lattice::isotropic(9, 11, 13, 0.5);
  l.spacingMm = {0.3, 0.5, 0.4};
  Bed bed = test::bedOf(Grid<std::uint8_t>(l, 1));
  bed.mask = Grid<std::uint8_t>(l, 1);
  RandomStream rng(3);
  for (std::size_t n = 0; n < bed.indicator.size(); ++n) {
    bed.indicator[n] = rng.uniform(0, 1) < 0.3 ? 0 : 1;
    (*bed.mask)[n] = rng.uniform(0, 1) < 0.95 ? 1 : 0;
  }
  const std::int64_t n[3] = {l.nz(), l.ny(), l.nx()};
  std::vector<double> all, allW;
  const ChordLengths c = chordLengths(bed, 0);
  for (int a = 0; a < 3; ++a) {
    std::vector<double> list, w;
    const int u = (a + 1) % 3, v = (a + 2) % 3;
    for (std::int64_t iu = 0; iu < n[u]; ++iu)
      for (std::int64_t iv = 0; iv < n[v]; ++iv) {
        std::int64_t run = 0, start = 0;
        for (std::int64_t t = 0; t <= n[a]; ++t) {
          std::int64_t idx[3];
          idx[a] = t;
          idx[u] = iu;
          idx[v] = iv;
          const bool isVoid = t < n[a] && bed.indicator(idx[0], idx[1], idx[2]) &&
                              (*bed.mask)(idx[0], idx[1], idx[2]);
          if (isVoid) {
            if (run++ == 0) start = t;
            continue;
          }
          if (run > 0 && start > 0 && t < n[a]) {
            list.push_back(static_cast<double>(run) * l.spacingMm[static_cast<std::size_t>(a)]);
            w.push_back(static_cast<double>(n[a] - 1) / std::max(1.0, double(n[a] - run - 1)));
          }
          run = 0;
        }
      }
    const LengthDistribution ref = summarizeLengths(list, 0.3, &w);
    const LengthDistribution& got = c.perAxis[static_cast<std::size_t>(a)];
    ASSERT_GT(ref.samples, 10u) << a;
    EXPECT_EQ(got.samples, ref.samples) << a;
    EXPECT_NEAR(got.meanMm, ref.meanMm, 1e-12 * ref.meanMm) << a;
    EXPECT_NEAR(got.stdMm, ref.stdMm, 1e-12 * ref.stdMm) << a;
    ASSERT_EQ(got.pdf.size(), ref.pdf.size()) << a;
    for (std::size_t b = 0; b < ref.pdf.size(); ++b)
      EXPECT_NEAR(got.pdf[b], ref.pdf[b], 1e-12 * (1 + ref.pdf[b])) << a << " bin " << b;
    all.insert(all.end(), list.begin(), list.end());
    allW.insert(allW.end(), w.begin(), w.end());
  }
  const LengthDistribution ref = summarizeLengths(all, 0.3, &allW);
  EXPECT_EQ(c.all.samples, ref.samples);
  EXPECT_NEAR(c.all.meanMm, ref.meanMm, 1e-12 * ref.meanMm);
}

// The planes split over "ranks" (one of them empty) and joined by the carry in order give
// exactly the run counts of the whole bed: runs along z crossing every boundary included.
TEST(Chords, PlanesSplitOverRanksJoinToTheWholeBed) {
  const Lattice l = Lattice::isotropic(12, 5, 6, 0.5);
  Bed bed = test::bedOf(Grid<std::uint8_t>(l, 1));
  RandomStream rng(8);
  for (std::size_t n = 0; n < bed.indicator.size(); ++n)
    bed.indicator[n] = rng.uniform(0, 1) < 0.15 ? 0 : 1;
  ChordRuns whole(12, 5, 6);
  whole.addPlanes(0, bed.indicator, nullptr, 12);
  whole.joinCarry({});
  std::array<std::vector<std::uint64_t>, 3> sum;
  std::vector<std::uint64_t> carry, cut(3, 0);
  const std::int64_t bounds[] = {0, 1, 1, 7, 8, 12};  // ranks of 1, 0, 6, 1 and 4 planes
  for (int r = 0; r + 1 < 6; ++r) {
    const std::int64_t z0 = bounds[r], z1 = bounds[r + 1];
    ChordRuns part(12, 5, 6);
    for (std::int64_t z = z0; z < z1; ++z) {  // one plane at a time, as thin slabs
      Grid<std::uint8_t> plane(subLattice(l, VoxelBox{{z, 0, 0}, {1, 5, 6}}), 0);
      for (std::int64_t j = 0; j < 5; ++j)
        for (std::int64_t i = 0; i < 6; ++i) plane(0, j, i) = bed.indicator(z, j, i);
      part.addPlanes(z, plane, nullptr, 1);
    }
    carry = part.joinCarry(r == 0 ? std::vector<std::uint64_t>{} : carry);
    for (int a = 0; a < 3; ++a) {
      auto& s = sum[static_cast<std::size_t>(a)];
      const auto& c = part.counts()[static_cast<std::size_t>(a)];
      s.resize(c.size(), 0);
      for (std::size_t k = 0; k < c.size(); ++k) s[k] += c[k];
      cut[static_cast<std::size_t>(a)] += part.windowCut()[static_cast<std::size_t>(a)];
    }
  }
  for (int a = 0; a < 3; ++a)
    EXPECT_EQ(sum[static_cast<std::size_t>(a)], whole.counts()[static_cast<std::size_t>(a)]) << a;
  std::uint64_t zChords = 0;
  for (auto v : whole.counts()[0]) zChords += v;
  EXPECT_GT(zChords, 10u);
  for (int a = 0; a < 3; ++a)
    EXPECT_EQ(cut[static_cast<std::size_t>(a)] > 0,
              whole.windowCut()[static_cast<std::size_t>(a)] > 0);
}

TEST(Shadow, ProjectionsAndCoordination) {
  Bed bed = test::bedOf(Grid<std::uint8_t>(Lattice::isotropic(2, 3, 4, 1.0), 1));
  bed.indicator(0, 1, 2) = 0;
  bed.indicator(1, 1, 2) = 0;
  bed.indicator(1, 1, 3) = 0;
  const ShadowImage z = shadowImage(bed, 0);
  ASSERT_EQ(z.rows, 3);
  ASSERT_EQ(z.cols, 4);
  EXPECT_DOUBLE_EQ(z.values[1 * 4 + 2], 1.0);
  EXPECT_DOUBLE_EQ(z.values[1 * 4 + 3], 0.5);
  EXPECT_DOUBLE_EQ(z.values[0], 0.0);
  // Labels: particles 1 and 2 touch, 3 is alone.
  bed.labels = Grid<std::uint32_t>(bed.lattice(), 0);
  (*bed.labels)(0, 1, 2) = 1;
  (*bed.labels)(1, 1, 2) = 2;
  (*bed.labels)(1, 1, 3) = 2;
  (*bed.labels)(0, 0, 0) = 3;
  const Coordination c = coordinationNumbers(bed);
  EXPECT_EQ(c.particles, 3u);
  EXPECT_EQ(c.contacts, 1u);
  EXPECT_NEAR(c.mean, 2.0 / 3.0, 1e-12);
}

TEST(Orientation, VerticalAndFlatAxes) {
  Bed bed = test::bedOf(Grid<std::uint8_t>(Lattice::isotropic(2, 2, 2, 1.0), 1));
  bed.particles.positionMm = {Vec3::Zero(), Vec3::Zero()};
  bed.particles.orientation = {Quat::Identity(), Quat(Eigen::AngleAxisd(M_PI / 2, Vec3::UnitX()))};
  const OrientationDistribution o = orientationDistribution(bed);
  EXPECT_NEAR(o.anglesDeg[0], 0, 1e-9);
  EXPECT_NEAR(o.anglesDeg[1], 90, 1e-9);
  EXPECT_NEAR(o.orderParameter, 0.25, 1e-12);  // (1 + (−0.5)) / 2
}

}  // namespace
}  // namespace voxpack::stats
