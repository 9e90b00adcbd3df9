// Distances between statistics: KS test against exact hand counts and scipy, curve RMSE
// and distribution KS on cases with known answers.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "voxpack/compare/distances.hpp"

using namespace voxpack::compare;

TEST(KsTwoSample, IdenticalSamplesGiveZeroDistanceAndPValueOne) {
  const std::vector<double> a{0.61, 0.65, 0.63, 0.70, 0.58, 0.66};
  const KsTest t = ksTwoSample(a, a);
  EXPECT_EQ(t.statistic, 0.0);
  EXPECT_EQ(t.pValue, 1.0);
  EXPECT_EQ(t.method, KsMethod::Exact);
}

TEST(KsTwoSample, SeparatedSamplesMatchPathCount) {
  // All of a below all of b: only 2 of C(6,3) = 20 orderings reach D = 1 -> p = 0.1.
  const KsTest t = ksTwoSample(std::vector<double>{1, 2, 3}, std::vector<double>{4, 5, 6});
  EXPECT_EQ(t.statistic, 1.0);
  EXPECT_NEAR(t.pValue, 0.1, 1e-14);
  // 2 / C(10,5) = 2/252.
  const KsTest u =
      ksTwoSample(std::vector<double>{5, 1, 3, 2, 4}, std::vector<double>{9, 8, 10, 6, 7});
  EXPECT_NEAR(u.pValue, 2.0 / 252.0, 1e-14);
}

TEST(KsTwoSample, MatchesScipyExactWithTies) {
  // scipy 1.10.1 stats.ks_2samp(a, b, method='exact'): D = 0.6031746031746031,
  // p = 0.07867132867132867 (ties across the samples at 0.61 and 0.63).
  const std::vector<double> a{0.61, 0.65, 0.63, 0.70, 0.58, 0.66, 0.64};
  const std::vector<double> b{0.55, 0.60, 0.62, 0.59, 0.57, 0.63, 0.61, 0.56, 0.60};
  const KsTest t = ksTwoSample(a, b);
  EXPECT_NEAR(t.statistic, 0.6031746031746031, 1e-15);
  EXPECT_NEAR(t.pValue, 0.07867132867132867, 1e-12);
}

namespace {
const std::vector<double> kX{
    0.345584,  0.821618,  0.330437,  -1.303157, 0.905356,  0.446375,  -0.536953, 0.581118,
    0.364572,  0.294132,  0.028422,  0.546713,  -0.736454, -0.16291,  -0.482119, 0.598846,
    0.039722,  -0.292457, -0.781908, -0.257192, 0.008142,  -0.275603, 1.294064,  1.006724,
    -2.711162, -1.889013, -0.174772, -0.42219,  0.213643,  0.217322,  2.117839,  -1.112021,
    -0.377605, 2.042772,  0.646703,  0.663063,  -0.514006, -1.648075, 0.167465,  0.109014};
const std::vector<double> kY{
    -0.727352, -0.183227, 0.427956, -0.444752, 0.40173,   0.595483,  0.535586,  -0.006292, 1.093748,
    1.391167,  0.820848,  -0.31823, 1.231652,  -0.00144,  1.379161,  -0.571787, 1.414467,  0.479937,
    -0.748749, 0.186101,  0.554102, 0.772791,  -0.482188, -0.607373, 0.699585,  0.03325,   0.735506,
    1.25952,   -1.148787, 0.754388, 1.724647,  0.202473,  -0.310815, 1.252244,  0.753447,  1.395883,
    0.154784,  -0.981818, 0.389989, 0.054172,  1.275324,  0.693633,  -1.130849, -0.695163, 1.383789,
    1.179765,  -0.140243, 0.498951, 0.945574,  0.968404};
}  // namespace

TEST(KsTwoSample, MatchesScipyExactAndAsymptoticOnNormalSamples) {
  // scipy 1.10.1: D = 0.28, exact p = 0.0505304311117051; asymptotic with Stephens'
  // correction: kstwobign.sf((sqrt(e) + 0.12 + 0.11/sqrt(e)) * 0.28), e = 2000/90,
  // = 0.04946802548554043.
  const KsTest exact = ksTwoSample(kX, kY);
  EXPECT_EQ(exact.method, KsMethod::Exact);
  EXPECT_NEAR(exact.statistic, 0.28, 1e-15);
  EXPECT_NEAR(exact.pValue, 0.0505304311117051, 1e-12);
  KsOptions asym;
  asym.exactMaxProduct = 10;  // forces the Kolmogorov limit
  const KsTest a = ksTwoSample(kX, kY, asym);
  EXPECT_EQ(a.method, KsMethod::Asymptotic);
  EXPECT_NEAR(a.pValue, 0.04946802548554043, 1e-10);
  EXPECT_NEAR(a.pValue, exact.pValue, 2e-3);
}

TEST(KsTwoSample, EmptySampleIsUndefined) {
  const KsTest t = ksTwoSample(std::vector<double>{}, std::vector<double>{1.0});
  EXPECT_EQ(t.method, KsMethod::Undefined);
  EXPECT_TRUE(std::isnan(t.pValue));
}

TEST(KolmogorovSurvival, MatchesScipyKstwobign) {
  // scipy.stats.kstwobign.sf at 0.3, 0.5, 1.0, 1.36, 2.0.
  EXPECT_NEAR(kolmogorovSurvival(0.3), 9.99990694e-01, 1e-8);
  EXPECT_NEAR(kolmogorovSurvival(0.5), 9.63945244e-01, 1e-8);
  EXPECT_NEAR(kolmogorovSurvival(1.0), 2.69999672e-01, 1e-8);
  EXPECT_NEAR(kolmogorovSurvival(1.36), 4.94858768e-02, 1e-9);
  EXPECT_NEAR(kolmogorovSurvival(2.0), 6.70925256e-04, 1e-11);
  EXPECT_EQ(kolmogorovSurvival(0.0), 1.0);
  // The two series agree where they hand over.
  EXPECT_NEAR(kolmogorovSurvival(1.0 - 1e-12), kolmogorovSurvival(1.0), 1e-10);
}

namespace {
Curve line(double from, double to, double step, double slope, double offset) {
  std::vector<double> x, y;
  for (double v = from; v <= to + 1e-12; v += step) {
    x.push_back(v);
    y.push_back(slope * v + offset);
  }
  return sortedCurve(x, y);
}
}  // namespace

TEST(CurveRmse, SelfIsZero) {
  const Curve c = line(0, 5, 0.2, 0.3, 0.1);
  const CurveRmse r = curveRmse(c, c);
  EXPECT_EQ(r.rmse, 0.0);
  EXPECT_GT(r.points, 20u);
}

TEST(CurveRmse, ConstantOffsetOnDifferentGridsIsTheOffset) {
  // Linear interpolation is exact for lines, so beds sampled at 0.1 mm and 0.25 mm give
  // exactly the offset, over the overlap [0.5, 4.0] only.
  const Curve a = line(0.0, 4.0, 0.1, 2.0, 0.0);
  const Curve b = line(0.5, 6.0, 0.25, 2.0, 0.05);
  const CurveRmse r = curveRmse(a, b);
  EXPECT_NEAR(r.rmse, 0.05, 1e-12);
  EXPECT_NEAR(r.fromMm, 0.5, 1e-12);
  EXPECT_NEAR(r.toMm, 4.0, 1e-12);
  EXPECT_NEAR(r.stepMm, 0.25, 1e-12);  // the coarser grid
  EXPECT_EQ(r.points, 15u);
}

TEST(CurveRmse, KnownValueForDifferentSlopes) {
  // a = x, b = 2x on x = 0, 0.1, ..., 1: rmse = sqrt(sum (k/10)^2 / 11) = sqrt(3.85/11).
  const CurveRmse r = curveRmse(line(0, 1, 0.1, 1, 0), line(0, 1, 0.1, 2, 0));
  EXPECT_NEAR(r.rmse, std::sqrt(3.85 / 11.0), 1e-12);
}

TEST(CurveRmse, NoOverlapIsNaN) {
  const CurveRmse r = curveRmse(line(0, 1, 0.1, 1, 0), line(2, 3, 0.1, 1, 0));
  EXPECT_TRUE(std::isnan(r.rmse));
  EXPECT_EQ(r.points, 0u);
}

TEST(SortedCurve, SortsDropsNonFiniteAndMergesDuplicates) {
  const std::vector<double> x{3, 1, 2, 2, NAN};
  const std::vector<double> y{30, 10, 20, 22, 5};
  const Curve c = sortedCurve(x, y);
  ASSERT_EQ(c.xMm.size(), 3u);
  EXPECT_EQ(c.xMm[1], 2.0);
  EXPECT_EQ(c.y[1], 21.0);
  EXPECT_EQ(interpolate(c, 2.5), 25.5);
}

namespace {
void uniformBins(double from, double to, int n, std::vector<double>& c, std::vector<double>& p) {
  c.clear();
  p.clear();
  const double w = (to - from) / n;
  for (int k = 0; k < n; ++k) {
    c.push_back(from + (k + 0.5) * w);
    p.push_back(1.0 / (to - from));
  }
}
}  // namespace

TEST(DistributionKs, KnownValues) {
  std::vector<double> ca, pa, cb, pb;
  uniformBins(0, 1, 10, ca, pa);
  EXPECT_EQ(distributionKs(ca, pa, ca, pa), 0.0);
  // The same uniform law on different bins: the piecewise-linear CDFs coincide.
  uniformBins(0, 1, 4, cb, pb);
  EXPECT_NEAR(distributionKs(ca, pa, cb, pb), 0.0, 1e-12);
  // U(0,1) vs U(0.5,1.5): sup |F_a - F_b| = 0.5 at x = 1.
  uniformBins(0.5, 1.5, 10, cb, pb);
  EXPECT_NEAR(distributionKs(ca, pa, cb, pb), 0.5, 1e-12);
  // Disjoint supports: 1.
  uniformBins(2, 3, 5, cb, pb);
  EXPECT_NEAR(distributionKs(ca, pa, cb, pb), 1.0, 1e-12);
  // Scale of the pdf does not matter (normalised).
  for (double& v : pb) v *= 7.0;
  uniformBins(2, 3, 5, ca, pa);
  EXPECT_NEAR(distributionKs(ca, pa, cb, pb), 0.0, 1e-12);
}

TEST(DistributionKs, NoMassIsNaN) {
  const std::vector<double> c{1, 2}, zero{0, 0}, one{1, 1};
  EXPECT_TRUE(std::isnan(distributionKs(c, zero, c, one)));
}
