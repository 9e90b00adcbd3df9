// Thresholds, clean-up, filters, column fit, resampling and phantom statistics on small
// synthetic volumes with known answers.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <vector>

#include "voxpack/core/errors.hpp"
#include "voxpack/core/random.hpp"
#include "voxpack/ingest/column.hpp"
#include "voxpack/ingest/filters.hpp"
#include "voxpack/ingest/phantom.hpp"
#include "voxpack/ingest/resample.hpp"
#include "voxpack/ingest/segment.hpp"

using namespace voxpack;
using namespace voxpack::ingest;

namespace {

Grid<float> twoLevels(float a, float b, double fractionB) {
  Grid<float> g(Lattice::isotropic(10, 10, 10, 1.0), a);
  const auto nb = static_cast<std::size_t>(fractionB * static_cast<double>(g.size()));
  for (std::size_t n = 0; n < nb; ++n) g[n] = b;
  return g;
}

// Column of radius r (voxels) whose axis drifts by `drift` voxels in x over the height;
// wall = always solid outside, inside: alternating solid/void layers (a "bed").
Grid<std::uint8_t> tiltedColumn(std::int64_t n, double r, double drift) {
  Grid<std::uint8_t> g(Lattice::isotropic(n, n, n, 0.5), 0);
  const double c = 0.5 * static_cast<double>(n - 1);
  for (std::int64_t k = 0; k < n; ++k) {
    const double ax = c + drift * (static_cast<double>(k) / static_cast<double>(n - 1) - 0.5);
    for (std::int64_t j = 0; j < n; ++j)
      for (std::int64_t i = 0; i < n; ++i) {
        const double dx = static_cast<double>(i) - ax, dy = static_cast<double>(j) - c;
        if (dx * dx + dy * dy < r * r) g(k, j, i) = ((i / 3 + j / 3 + k / 3) % 2) ? 1 : 0;
      }
  }
  return g;
}

}  // namespace

TEST(Threshold, OtsuAndKMeansSplitTwoLevels) {
  for (double f : {0.2, 0.5, 0.8}) {
    const Grid<float> g = twoLevels(10.0f, 50.0f, f);
    const double t = otsuThreshold(g);
    EXPECT_GT(t, 10.0);
    EXPECT_LT(t, 50.0);
    EXPECT_NEAR(kmeansThreshold(g), 30.0, 1e-6);  // mean of the two class means
    const auto ind = applyThreshold(g, t, true);
    std::size_t bright = 0;
    for (auto v : ind.values()) bright += v;
    EXPECT_EQ(bright, static_cast<std::size_t>(f * 1000));
  }
}

TEST(Threshold, PolarityFlipsTheIndicator) {
  const Grid<float> g = twoLevels(0.0f, 1.0f, 0.3);
  const auto bright = applyThreshold(g, 0.5, true);
  const auto dark = applyThreshold(g, 0.5, false);
  for (std::size_t n = 0; n < g.size(); ++n) EXPECT_EQ(bright[n] + dark[n], 1);
}

TEST(Cleanup, SmallInteriorComponentsFlipBorderOnesStay) {
  Grid<std::uint8_t> g(Lattice::isotropic(12, 12, 12, 1.0), 1);
  g(5, 5, 5) = 0;                              // one-voxel speck inside
  for (int i = 2; i < 5; ++i) g(8, 8, i) = 0;  // 3-voxel speck
  g(0, 3, 3) = 0;                              // speck on the border: kept
  for (int k = 2; k < 10; ++k)                 // big block: kept
    for (int j = 2; j < 5; ++j) g(k, j, 9) = 0;
  EXPECT_EQ(removeSmallComponents(g, 0, 8), 2u);
  EXPECT_EQ(g(5, 5, 5), 1);
  EXPECT_EQ(g(8, 8, 3), 1);
  EXPECT_EQ(g(0, 3, 3), 0);
  EXPECT_EQ(g(5, 3, 9), 0);
  EXPECT_EQ(removeSmallComponents(g, 0, 0), 0u);
}

// The bounded search gives the components a whole labelling would: random beds at several
// densities and size limits, against a reference that labels every component fully (the
// former flood fill), including a count restricted to some planes.
TEST(Cleanup, BoundedSearchEqualsAFullLabelling) {
  auto reference = [](Grid<std::uint8_t>& g, std::uint8_t phase, std::size_t maxV, std::int64_t z0,
                      std::int64_t z1) {
    const Lattice& l = g.lattice();
    std::vector<int> label(g.size(), -1);
    std::size_t flipped = 0;
    for (std::size_t s = 0; s < g.size(); ++s) {
      if (label[s] >= 0 || g[s] != phase) continue;
      std::vector<std::size_t> comp{s}, stack{s};
      label[s] = 1;
      bool border = false;
      while (!stack.empty()) {
        const Index3 p = l.indexOf(stack.back());
        stack.pop_back();
        border = border || p.k == 0 || p.j == 0 || p.i == 0 || p.k == l.nz() - 1 ||
                 p.j == l.ny() - 1 || p.i == l.nx() - 1;
        const std::int64_t nb[6][3] = {{-1, 0, 0}, {1, 0, 0},  {0, -1, 0},
                                       {0, 1, 0},  {0, 0, -1}, {0, 0, 1}};
        for (const auto& d : nb) {
          if (!l.contains(p.k + d[0], p.j + d[1], p.i + d[2])) continue;
          const std::size_t o = l.offset(p.k + d[0], p.j + d[1], p.i + d[2]);
          if (label[o] < 0 && g[o] == phase) {
            label[o] = 1;
            stack.push_back(o);
            comp.push_back(o);
          }
        }
      }
      if (comp.size() <= maxV && !border) {
        for (std::size_t o : comp) g[o] = static_cast<std::uint8_t>(1 - phase);
        const auto k = static_cast<std::int64_t>(s / static_cast<std::size_t>(l.ny() * l.nx()));
        if (k >= z0 && k < z1) ++flipped;
      }
    }
    return flipped;
  };
  RandomStream rng(11, 0);
  for (double voidFraction : {0.2, 0.5, 0.75})
    for (std::size_t maxV : {std::size_t{1}, std::size_t{4}, std::size_t{30}, std::size_t{5000}}) {
      Grid<std::uint8_t> a(Lattice::isotropic(14, 11, 13, 1.0), 0);
      for (std::size_t n = 0; n < a.size(); ++n) a[n] = rng.uniform() < voidFraction ? 1 : 0;
      for (std::uint8_t phase : {std::uint8_t{0}, std::uint8_t{1}}) {
        Grid<std::uint8_t> b = a;
        const std::size_t got = removeSmallComponents(a, phase, maxV, 3, 9);
        const std::size_t want = reference(b, phase, maxV, 3, 9);
        EXPECT_EQ(got, want) << voidFraction << " " << maxV << " " << int(phase);
        EXPECT_TRUE(std::equal(a.data(), a.data() + a.size(), b.data()))
            << voidFraction << " " << maxV << " " << int(phase);
      }
    }
}

// A step along x blurred by an exact Gaussian of 1.5 voxels: Richardson-Lucy with that PSF
// steepens it back (10-90 % rise from 3.8 voxels to under 2.5) and keeps the total.
TEST(Filters, RichardsonLucySharpensABlurredStepAndKeepsTheTotal) {
  const Lattice l = Lattice::isotropic(8, 8, 40, 0.1);
  Grid<float> g(l, 0.0f);
  const double sigma = 1.5;  // voxels
  for (std::int64_t k = 0; k < l.nz(); ++k)
    for (std::int64_t j = 0; j < l.ny(); ++j)
      for (std::int64_t i = 0; i < l.nx(); ++i)
        g(k, j, i) = static_cast<float>(
            100.0 +
            800.0 * 0.5 * std::erfc(-(static_cast<double>(i) - 19.5) / (sigma * std::sqrt(2.0))));
  auto rise = [&](const Grid<float>& img) {  // voxels from 10 % to 90 % of the step
    double x10 = 0, x90 = 0;
    for (std::int64_t i = 1; i < l.nx(); ++i) {
      const double a = img(4, 4, i - 1), b = img(4, 4, i);
      for (auto [level, x] : {std::pair<double, double*>{180.0, &x10}, {820.0, &x90}})
        if (a < level && b >= level) *x = static_cast<double>(i - 1) + (level - a) / (b - a);
    }
    return x90 - x10;
  };
  double before = 0, after = 0;
  for (float v : g.values()) before += v;
  const double r0 = rise(g);
  EXPECT_NEAR(r0, 2 * 1.2816 * sigma, 0.3);  // 3.84 exactly; linear interpolation reads 4.06
  EXPECT_EQ(richardsonLucy(g, sigma * 0.1, 20, 1), 0u);
  for (float v : g.values()) after += v;
  EXPECT_LT(rise(g), 2.5) << "from " << r0;
  EXPECT_NEAR(after / before, 1.0, 5e-3);  // measured +0.24 %: the padding at the box ends
  EXPECT_THROW(richardsonLucy(g, 0.0, 10, 1), InputError);
  EXPECT_THROW(richardsonLucy(g, 0.1, 0, 1), InputError);
}

TEST(Filters, CrossMedianRemovesSpikesAndKeepsOneVoxelSheets) {
  Grid<float> g(Lattice::isotropic(9, 9, 9, 1.0), 0.0f);
  g(4, 4, 4) = 100.0f;  // isolated spike
  EXPECT_EQ(crossMedianFilter(g, 2)(4, 4, 4), 0.0f);
  EXPECT_EQ(medianFilter(g, 1, 2)(4, 4, 4), 0.0f);
  // A one-voxel-thick sheet (a thin throat between particles): 5 of the 7 cross samples
  // lie in it, so the cross median keeps it; the 3^3 box (9 of 27) erases it.
  Grid<float> s(Lattice::isotropic(9, 9, 9, 1.0), 0.0f);
  for (int j = 0; j < 9; ++j)
    for (int i = 0; i < 9; ++i) s(4, j, i) = 1.0f;
  EXPECT_EQ(crossMedianFilter(s, 1)(4, 4, 4), 1.0f);
  EXPECT_EQ(medianFilter(s, 1, 1)(4, 4, 4), 0.0f);
  EXPECT_THROW(medianFilter(g, 0, 1), InputError);
}

TEST(Column, FitsTiltedAxisAndRadius) {
  const double r = 20.0, drift = 4.0;
  const auto g = tiltedColumn(64, r, drift);
  const ColumnFit f = fitColumn(g, {.slabSlices = 16});
  ASSERT_TRUE(f.found) << f.note;
  const double h = 0.5;  // mm per voxel
  // Area-equivalent radius of a digital disc is within 0.1 voxel of r; the axis moving
  // by 1 voxel within a slab widens the enclosed region by up to ~0.3 voxel.
  EXPECT_NEAR(f.radiusMm, r * h, 0.4 * h);
  EXPECT_NEAR(f.axisXMm, 31.5 * h, 0.25 * h);
  EXPECT_NEAR(f.axisYMm, 31.5 * h, 0.25 * h);
  // Slope dx/dz: drift voxels over 63 voxels of height (slab quantisation ~ 5 %).
  EXPECT_NEAR(f.slopeX, drift / 63.0, 0.1 * drift / 63.0);
  EXPECT_NEAR(f.slopeY, 0.0, 0.01);
  const auto mask = columnMask(g.lattice(), f);
  std::size_t agree = 0, inside = 0;
  for (std::int64_t k = 0; k < 64; ++k)
    for (std::int64_t j = 0; j < 64; ++j)
      for (std::int64_t i = 0; i < 64; ++i) {
        const double ax = 31.5 + drift * (static_cast<double>(k) / 63.0 - 0.5);
        const double dx = static_cast<double>(i) - ax, dy = static_cast<double>(j) - 31.5;
        const bool truth = dx * dx + dy * dy < r * r;
        inside += truth;
        agree += truth == static_cast<bool>(mask(k, j, i));
      }
  // Mismatches sit on the rim (one voxel ring ~ 2 pi r / (pi r^2) = 10 % of the disc):
  // a 0.3-voxel radius excess flips at most ~3 % of the rim, ~0.5 % of the volume.
  EXPECT_GT(static_cast<double>(agree) / static_cast<double>(g.size()), 0.99);
  EXPECT_GT(inside, 0u);
}

TEST(Column, NoneFoundWithoutWall) {
  Grid<std::uint8_t> g(Lattice::isotropic(32, 32, 32, 1.0), 0);
  for (std::size_t n = 0; n < g.size(); ++n) g[n] = (n * 2654435761u >> 7) % 3 == 0;
  EXPECT_FALSE(fitColumn(g).found);
}

TEST(Resample, KeepsConstantsAndLinearRamps) {
  Lattice l = Lattice::isotropic(8, 10, 12, 0.5);
  Grid<float> g(l);
  for (std::int64_t k = 0; k < 8; ++k)
    for (std::int64_t j = 0; j < 10; ++j)
      for (std::int64_t i = 0; i < 12; ++i) g(k, j, i) = static_cast<float>(2.0 * i * 0.5 + 1.0);
  const Lattice to = resampledLattice(l, 1.0);
  EXPECT_EQ(to.dims, (std::array<std::int64_t, 3>{4, 5, 6}));
  // Same box: first centre half a new voxel inside the old box's low face.
  EXPECT_DOUBLE_EQ(to.originMm[2], -0.25 + 0.5);
  const auto r = resampleLinear(g, to, 2);
  for (std::int64_t i = 1; i < 5; ++i)  // interior: the box average of a ramp is the ramp
    EXPECT_NEAR(r(2, 2, i), 2.0 * to.centerMm(2, 2, i).x() + 1.0, 1e-5);
  const auto fine = resampleLinear(g, resampledLattice(l, 0.25), 1);
  EXPECT_EQ(fine.lattice().dims, (std::array<std::int64_t, 3>{16, 20, 24}));
  EXPECT_THROW(resampledLattice(l, 0.0), InputError);
}

TEST(Phantom, NoiseMatchesSnrAndIsThreadInvariant) {
  Bed bed;
  bed.indicator = Grid<std::uint8_t>(Lattice::isotropic(40, 40, 40, 0.1), 1);
  for (std::int64_t k = 0; k < 40; ++k)
    for (std::int64_t j = 0; j < 40; ++j)
      for (std::int64_t i = 20; i < 40; ++i) bed.indicator(k, j, i) = 0;
  PhantomOptions o;
  o.modality = Modality::Xmt;
  o.snr = 8.0;
  o.seed = 11;
  const auto a = makePhantom(bed, o, 1);
  const auto b = makePhantom(bed, o, 2);
  ASSERT_EQ(a.values(), b.values());
  o.seed = 12;
  EXPECT_NE(makePhantom(bed, o, 2).values(), a.values());
  // Gaussian noise: sample sd of the void half ~ contrast / SNR (32000 samples: 1 %).
  const PhantomLevels lv = phantomLevels(Modality::Xmt);
  const double sigma = (lv.solidLevel - lv.voidLevel) / 8.0;
  double s = 0, s2 = 0, n = 0;
  for (std::int64_t k = 0; k < 40; ++k)
    for (std::int64_t j = 0; j < 40; ++j)
      for (std::int64_t i = 0; i < 20; ++i) {
        s += a(k, j, i);
        s2 += a(k, j, i) * a(k, j, i);
        n += 1;
      }
  const double mean = s / n, sd = std::sqrt(s2 / n - mean * mean);
  EXPECT_NEAR(mean, lv.voidLevel, 4.0 * sigma / std::sqrt(n));
  EXPECT_NEAR(sd, sigma, 0.03 * sigma);
}

TEST(Phantom, BiasFieldSpansTheRequestedGain) {
  Bed bed;
  bed.indicator = Grid<std::uint8_t>(Lattice::isotropic(30, 30, 30, 0.1), 1);
  PhantomOptions o;
  o.modality = Modality::Mri;
  o.snr = 1e9;  // noise-free
  o.biasFraction = 0.2;
  o.seed = 5;
  const auto img = makePhantom(bed, o, 2);
  const auto [lo, hi] = std::minmax_element(img.values().begin(), img.values().end());
  EXPECT_NEAR(*lo, 800.0, 1.0);
  EXPECT_NEAR(*hi, 1200.0, 1.0);
}

TEST(Phantom, BlurPreservesMeanAndResampleKeepsBox) {
  Bed bed;
  bed.indicator = Grid<std::uint8_t>(Lattice::isotropic(20, 20, 20, 0.2), 1);
  for (std::int64_t k = 5; k < 15; ++k)
    for (std::int64_t j = 5; j < 15; ++j)
      for (std::int64_t i = 5; i < 15; ++i) bed.indicator(k, j, i) = 0;
  PhantomOptions o;
  o.modality = Modality::Mri;
  o.snr = 1e9;
  o.blurMm = 0.2;
  const auto img = makePhantom(bed, o, 2);
  double sum = 0;
  for (float v : img.values()) sum += v;
  // The cube sits 5 voxels (> 3 sigma) from the edges: mass is conserved.
  EXPECT_NEAR(sum, 1000.0 * (8000 - 1000), 1e-3 * 1000.0 * 7000);
  o.voxelSizeMm = 0.4;
  const auto coarse = makePhantom(bed, o, 2);
  EXPECT_EQ(coarse.lattice().dims, (std::array<std::int64_t, 3>{10, 10, 10}));
  EXPECT_NEAR(coarse.lattice().originMm[0], 0.1, 1e-12);
}

TEST(Filters, CurvatureDiffusionSmoothsNoiseAndKeepsAStep) {
  // A step 0 | 100 with Gaussian noise of sd 10: diffusion must lower the noise in the
  // flat halves and leave the step where it was (the mid-level still between x = 9, 10).
  Grid<float> g(Lattice::isotropic(12, 12, 20, 1.0), 0.0f);
  RandomStream rng(3, 0);
  for (std::int64_t k = 0; k < 12; ++k)
    for (std::int64_t j = 0; j < 12; ++j)
      for (std::int64_t i = 0; i < 20; ++i)
        g(k, j, i) = static_cast<float>((i >= 10 ? 100.0 : 0.0) + 10.0 * rng.normal());
  auto sd = [](const Grid<float>& img, std::int64_t i0, std::int64_t i1) {
    double s = 0, s2 = 0, n = 0;
    for (std::int64_t k = 0; k < 12; ++k)
      for (std::int64_t j = 0; j < 12; ++j)
        for (std::int64_t i = i0; i < i1; ++i) {
          s += img(k, j, i);
          s2 += img(k, j, i) * img(k, j, i);
          n += 1;
        }
    return std::sqrt(s2 / n - (s / n) * (s / n));
  };
  const double before = sd(g, 0, 6);
  curvatureDiffusion(g, {.iterations = 10, .conductance = 1.0, .timeStepFraction = 0.9}, 2);
  EXPECT_LT(sd(g, 0, 6), 0.7 * before);
  double left = 0, right = 0;
  for (std::int64_t k = 0; k < 12; ++k)
    for (std::int64_t j = 0; j < 12; ++j) {
      left += g(k, j, 9);
      right += g(k, j, 10);
    }
  EXPECT_LT(left / 144.0, 50.0);
  EXPECT_GT(right / 144.0, 50.0);
  EXPECT_THROW(curvatureDiffusion(g, {.iterations = 0}, 1), InputError);
}

// A uniform bed (1000) inside a column of radius 25 voxels, a wall of 5 voxels (200) and an
// outside (50), each voxel the area average of 8 x 8 sub-samples, blurred by 1 voxel: next
// to the wall the bed reads as low as ~600. Dividing the blurred wall out restores it.
TEST(Column, WallBlurCorrectionRestoresTheBedNextToTheWall) {
  const double h = 0.1, R = 25.0, T = 5.0;
  Grid<float> g(Lattice::isotropic(8, 64, 64, h), 0.0f);
  const double c = 31.5;
  for (std::int64_t j = 0; j < 64; ++j)
    for (std::int64_t i = 0; i < 64; ++i) {
      double acc = 0;
      for (int b = 0; b < 8; ++b)
        for (int a = 0; a < 8; ++a) {
          const double r = std::hypot(static_cast<double>(i) - 0.5 + (a + 0.5) / 8 - c,
                                      static_cast<double>(j) - 0.5 + (b + 0.5) / 8 - c);
          acc += r < R ? 1000.0 : r < R + T ? 200.0 : 50.0;
        }
      for (std::int64_t k = 0; k < 8; ++k) g(k, j, i) = static_cast<float>(acc / 64.0);
    }
  gaussianBlur(g, h, 1);
  ColumnFit col;
  col.found = true;
  col.axisXMm = col.axisYMm = c * h;
  col.radiusMm = R * h;
  WallBlurCorrection wc;
  wc.blurMm = std::sqrt(1.0 + 1.0 / 12.0) * h;  // the blur and the voxel's box
  wc.wallLevel = 200.0;
  wc.outsideLevel = 50.0;
  wc.wallThicknessMm = T * h;
  const Grid<float> before = g;
  const std::size_t changed = correctWallBlur(g, col, wc, 2);
  EXPECT_GT(changed, 0u);
  double worstBefore = 0, worstAfter = 0;
  for (std::int64_t j = 0; j < 64; ++j)
    for (std::int64_t i = 0; i < 64; ++i) {
      const double r = std::hypot(static_cast<double>(i) - c, static_cast<double>(j) - c);
      if (r >= R) continue;
      worstBefore = std::max(worstBefore, std::abs(before(4, j, i) - 1000.0));
      worstAfter = std::max(worstAfter, std::abs(g(4, j, i) - 1000.0));
    }
  std::cout << "[ measured ] worst bed voxel inside the column: " << worstBefore << " before, "
            << worstAfter << " after the correction\n";
  EXPECT_GT(worstBefore, 250.0);
  EXPECT_LT(worstAfter, 30.0);
}
