// Axial and radial profiles: known synthetic densities, trimming, the normality test.
#include <gtest/gtest.h>

#include <cmath>

#include "stats_fixtures.hpp"
#include "voxpack/stats/profiles.hpp"

namespace voxpack::stats {
namespace {

TEST(Axial, KnownSliceDensitiesAndTrim) {
  // Slice k has exactly k % 5 solid voxels out of 10 x 10 = 100: density (k % 5) / 100,
  // except slices 0 and 19 which are full (bed ends).
  Bed bed = test::bedOf(Grid<std::uint8_t>(Lattice::isotropic(20, 10, 10, 0.5), 1));
  for (std::int64_t k = 0; k < 20; ++k) {
    const std::int64_t solid = (k == 0 || k == 19) ? 100 : k % 5 + 1;
    for (std::int64_t s = 0; s < solid; ++s) bed.indicator(k, s / 10, s % 10) = 0;
  }
  AxialOptions o;
  o.trimMm = 1.0;  // two slices at each end
  const AxialProfile p = axialProfile(bed, o);
  ASSERT_EQ(p.densityAll.size(), 20u);
  EXPECT_DOUBLE_EQ(p.densityAll[0], 1.0);
  EXPECT_DOUBLE_EQ(p.densityAll[7], 0.03);
  EXPECT_EQ(p.firstSlice, 2);
  EXPECT_EQ(p.lastSlice, 17);
  ASSERT_EQ(p.density.size(), 16u);
  double mean = 0;
  for (std::int64_t k = 2; k <= 17; ++k) mean += (k % 5 + 1) / 100.0;
  mean /= 16;
  EXPECT_NEAR(p.mean, mean, 1e-12);
  EXPECT_NEAR(p.zMm.front(), 1.0, 1e-12);
  double hist = 0;
  for (double c : p.histogramCounts) hist += c;
  EXPECT_EQ(hist, 16);
}

TEST(Axial, DagostinoPearsonMatchesScipy) {
  // scipy.stats.normaltest([...]) = (statistic 2.0395693, pvalue 0.3606726) for this vector
  // (computed with scipy 1.10, /usr/bin/python3).
  const std::vector<double> x{0.61, 0.63, 0.64, 0.60, 0.66, 0.65, 0.62, 0.59, 0.70, 0.63,
                              0.64, 0.61, 0.62, 0.68, 0.63, 0.65, 0.60, 0.64, 0.62, 0.66};
  const NormalityTest t = dagostinoPearson(x);
  EXPECT_NEAR(t.statistic, 2.0395693, 1e-6);
  EXPECT_NEAR(t.pValue, 0.3606726, 1e-6);
  EXPECT_LT(dagostinoPearson({1, 2, 3}).statistic, 0);                  // n < 8: undefined
  EXPECT_LT(dagostinoPearson(std::vector<double>(10, 1.0)).pValue, 0);  // zero variance
}

// Column of radius 10 mm at 1 mm voxels; the solid fraction of each voxel column (over 10
// slices) is set by the ring (width 2 mm) its centre lies in: ring q has density
// (q + 1) / 10. With centre assignment every annulus has exactly its ring's density; with
// fractional areas every annulus whose voxels all lie in one ring does.
struct RingBed {
  Bed bed;
  double ringDensity(double r) const { return (std::floor(r / 2.0) + 1) / 10.0; }
  RingBed() {
    Lattice l = Lattice::isotropic(10, 24, 24, 1.0, Vec3(-11.5, -11.5, 0));
    bed.indicator = Grid<std::uint8_t>(l, 1);
    bed.mask = Grid<std::uint8_t>(l, 0);
    for (std::int64_t j = 0; j < 24; ++j)
      for (std::int64_t i = 0; i < 24; ++i) {
        const Vec3 c = l.centerMm(0, j, i);
        const double r = std::hypot(c.x(), c.y());
        if (r > 10) continue;
        const auto solidSlices = static_cast<std::int64_t>(std::lround(ringDensity(r) * 10));
        for (std::int64_t k = 0; k < 10; ++k) {
          (*bed.mask)(k, j, i) = 1;
          if (k < solidSlices) bed.indicator(k, j, i) = 0;
        }
      }
  }
};

TEST(Radial, KnownAnnularDensitiesCentreAssignment) {
  RingBed rb;
  RadialOptions o;
  o.axisMm = std::array<double, 2>{0, 0};
  o.radiusMm = 10;
  o.supersample = 1;
  const RadialProfile p = radialProfile(rb.bed, o);
  ASSERT_GE(p.rMm.size(), 10u);
  for (std::size_t b = 0; b < 10; ++b) {
    EXPECT_NEAR(p.rMm[b], b + 0.5, 1e-12);
    EXPECT_NEAR(p.wallDistanceMm[b], 10 - (b + 0.5), 1e-12);
    EXPECT_NEAR(p.density[b], rb.ringDensity(p.rMm[b]), 1e-6) << "annulus " << b;
  }
}

TEST(Radial, KnownAnnularDensitiesFractionalAreas) {
  RingBed rb;
  RadialOptions o;  // axis fitted from the mask: must come out at (0, 0)
  o.supersample = 8;
  const RadialProfile p = radialProfile(rb.bed, o);
  EXPECT_NEAR(p.axisMm[0], 0, 1e-9);
  EXPECT_NEAR(p.axisMm[1], 0, 1e-9);
  // Fitted radius sqrt(A/π) of the digital disc (area = its voxel count, 1 mm² each).
  double discVoxels = 0;
  for (std::int64_t j = 0; j < 24; ++j)
    for (std::int64_t i = 0; i < 24; ++i) discVoxels += (*rb.bed.mask)(0, j, i);
  EXPECT_NEAR(p.radiusMm, std::sqrt(discVoxels / M_PI), 1e-9);
  int checked = 0;
  for (std::size_t b = 0; b < p.rMm.size(); ++b) {
    // Voxels overlapping annulus [b, b+1) have centres within b − √2/2 .. b + 1 + √2/2.
    const double lo = static_cast<double>(b) - 0.7072, hi = static_cast<double>(b) + 1.7072;
    if (std::floor(std::max(0.0, lo) / 2) != std::floor(hi / 2) || hi > 10) continue;
    EXPECT_NEAR(p.density[b], rb.ringDensity(static_cast<double>(b) + 0.5), 1e-6) << b;
    ++checked;
  }
  EXPECT_GE(checked, 1);
}

TEST(Radial, WholeAndCoreSummaries) {
  RingBed rb;
  RadialOptions o;
  o.axisMm = std::array<double, 2>{0, 0};
  o.radiusMm = 10;
  o.coreMarginMm = 8.5;  // core: r <= 1.5 mm, all in ring 0 (density 0.1)
  const RadialProfile p = radialProfile(rb.bed, o);
  EXPECT_NEAR(p.coreDensity, 0.1, 1e-12);
  double solid = 0, area = 0;
  for (std::size_t c = 0; c < rb.bed.mask->size(); ++c) {
    area += (*rb.bed.mask)[c];
    solid += (*rb.bed.mask)[c] && rb.bed.indicator[c] == 0;
  }
  EXPECT_NEAR(p.wholeDensity, solid / area, 1e-12);
}

}  // namespace
}  // namespace voxpack::stats
