#pragma once
/// \file distances.hpp
/// Distances between statistics of two beds: two-sample Kolmogorov-Smirnov test, RMSE of
/// two curves on a common grid (mm), KS distance between two binned distributions.
/// Everything is in mm so beds of different voxel sizes compare directly.

#include <cstddef>
#include <span>
#include <vector>

namespace voxpack::compare {

/// Which Kolmogorov distribution gave a KS p-value.
enum class KsMethod {
  Exact,       ///< exact null distribution of D for samples without ties (lattice-path count)
  Asymptotic,  ///< Kolmogorov limit Q((sqrt(e) + 0.12 + 0.11/sqrt(e)) D), e = n m/(n + m)
  Undefined,   ///< an empty sample: no test
};

/// Result of a two-sample Kolmogorov-Smirnov test.
struct KsTest {
  double statistic = 0.0;                 ///< D = sup |F_a - F_b|, in [0, 1]
  double pValue = 1.0;                    ///< P(D' >= D) under the null hypothesis, in [0, 1]
  KsMethod method = KsMethod::Undefined;  ///< which distribution gave pValue
};

/// Options of ksTwoSample.
struct KsOptions {
  /// Largest n*m for which the exact O(n m) path count is used (4e6: ~10 ms); above it
  /// the asymptotic Kolmogorov distribution with Stephens' correction.
  double exactMaxProduct = 4.0e6;
};

/// Two-sample two-sided KS test of `a` against `b` (values need not be sorted; NaN are
/// dropped). An empty sample gives method Undefined and a NaN statistic and p-value.
KsTest ksTwoSample(std::span<const double> a, std::span<const double> b,
                   const KsOptions& options = {});

/// Survival function of the Kolmogorov distribution, Q(lambda) = P(K > lambda).
double kolmogorovSurvival(double lambda);

/// Name of a KsMethod ("exact", "asymptotic", "undefined").
const char* ksMethodName(KsMethod m);

/// A sampled curve y(x); x in mm, strictly increasing after `sortedCurve`.
struct Curve {
  std::vector<double> xMm;  ///< abscissa (mm)
  std::vector<double> y;    ///< ordinate
};

/// Sorts by x, drops non-finite points and merges duplicate x (mean of y).
Curve sortedCurve(std::span<const double> xMm, std::span<const double> y);

/// Options of curveRmse.
struct CurveRmseOptions {
  /// Step of the common grid (mm); <= 0 = the coarser of the two curves' median steps.
  double gridStepMm = 0.0;
};

/// Result of curveRmse.
struct CurveRmse {
  double rmse = 0.0;       ///< sqrt(mean (y_a - y_b)^2) over the common grid; NaN if no overlap
  double fromMm = 0.0;     ///< start of the overlapping range
  double toMm = 0.0;       ///< end of the overlapping range
  double stepMm = 0.0;     ///< grid step used
  std::size_t points = 0;  ///< grid points used (0 = no overlap)
};

/// RMSE between two curves, both linearly interpolated onto one uniform grid over the
/// range where both are defined (no extrapolation).
CurveRmse curveRmse(const Curve& a, const Curve& b, const CurveRmseOptions& options = {});

/// Linear interpolation of a sorted curve at x (clamped to the ends).
double interpolate(const Curve& c, double xMm);

/// KS distance sup |F_a - F_b| between two binned densities given by bin centres (mm,
/// uniform or not) and non-negative densities. Each is turned into a piecewise-linear CDF
/// over its bin edges (edges halfway between centres; the first and last bins symmetric);
/// the supremum is taken over the union of all edges, where it is attained. NaN when a
/// distribution has no mass.
double distributionKs(std::span<const double> binsMmA, std::span<const double> pdfA,
                      std::span<const double> binsMmB, std::span<const double> pdfB);

}  // namespace voxpack::compare
