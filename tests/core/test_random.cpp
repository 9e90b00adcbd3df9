#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "voxpack/core/random.hpp"

using namespace voxpack;

TEST(RandomStream, SameSeedSameSequence) {
  RandomStream a(42, 7), b(42, 7);
  for (int n = 0; n < 1000; ++n) EXPECT_EQ(a(), b());
}

TEST(RandomStream, StreamsDiffer) {
  RandomStream a(42, 0), b(42, 1), c(43, 0);
  int sameAB = 0, sameAC = 0;
  for (int n = 0; n < 1000; ++n) {
    const auto x = a();
    sameAB += x == b();
    sameAC += x == c();
  }
  EXPECT_EQ(sameAB, 0);
  EXPECT_EQ(sameAC, 0);
}

TEST(RandomStream, UniformMomentsAndRange) {
  RandomStream r(1);
  const int n = 200000;
  double s = 0, s2 = 0;
  for (int k = 0; k < n; ++k) {
    const double u = r.uniform();
    ASSERT_GE(u, 0.0);
    ASSERT_LT(u, 1.0);
    s += u;
    s2 += u * u;
  }
  // Mean 1/2 and variance 1/12 within ~5 standard errors.
  EXPECT_NEAR(s / n, 0.5, 5 * std::sqrt(1.0 / 12 / n));
  EXPECT_NEAR(s2 / n - (s / n) * (s / n), 1.0 / 12, 2e-3);
}

TEST(RandomStream, BelowIsUnbiasedOverSmallRange) {
  RandomStream r(5);
  std::array<int, 6> counts{};
  const int n = 60000;
  for (int k = 0; k < n; ++k) counts[r.below(6)]++;
  for (int c : counts) EXPECT_NEAR(c, n / 6, 5 * std::sqrt(n / 6.0));
}

TEST(RandomStream, NormalMoments) {
  RandomStream r(9);
  const int n = 100000;
  double s = 0, s2 = 0;
  for (int k = 0; k < n; ++k) {
    const double x = r.normal();
    ASSERT_TRUE(std::isfinite(x));
    s += x;
    s2 += x * x;
  }
  EXPECT_NEAR(s / n, 0.0, 0.02);
  EXPECT_NEAR(s2 / n, 1.0, 0.02);
}
