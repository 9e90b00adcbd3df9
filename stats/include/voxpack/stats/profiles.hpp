#pragma once
/// \file profiles.hpp
/// Axial and radial packing-density profiles inside the mask (paper §4, docs/references.md).

#include <array>
#include <cstdint>
#include <optional>
#include <vector>

#include "voxpack/core/bed.hpp"

namespace voxpack::stats {

/// D'Agostino-Pearson K² omnibus normality test (skewness + kurtosis).
struct NormalityTest {
  double statistic = -1;  ///< K², >= 0; < 0 when undefined (n < 8 or zero variance)
  double pValue = -1;     ///< chi-square(2) upper tail of K²; < 0 when undefined
  double skewness = 0;    ///< sample skewness g1 (biased, as scipy.stats.skew)
  double kurtosis = 0;    ///< sample excess kurtosis g2 (biased)
};

/// D'Agostino-Pearson test of `x` (scipy.stats.normaltest's formulas).
NormalityTest dagostinoPearson(const std::vector<double>& x);

/// Options of axialProfile.
struct AxialOptions {
  /// mm trimmed at each end of the bed (>= 0); the bed spans the slices holding solid.
  double trimMm = 0;
  /// Histogram bins of the slice densities (>= 1).
  int histogramBins = 20;
};

/// Per-slice packing density along z and its statistics over the trimmed slices.
struct AxialProfile {
  std::vector<double> zMmAll;           ///< centre z (mm) of every slice
  std::vector<double> densityAll;       ///< density of every slice; NaN when no mask voxel
  std::int64_t firstSlice = 0;          ///< first slice used (after trimming)
  std::int64_t lastSlice = -1;          ///< last slice used; < firstSlice when none
  std::vector<double> zMm;              ///< z of the slices used
  std::vector<double> density;          ///< density of the slices used (all defined)
  double mean = 0;                      ///< mean of `density`; NaN when empty
  double std = 0;                       ///< sample standard deviation (n−1); NaN when n < 2
  std::vector<double> histogramEdges;   ///< bin edges of the histogram of `density`
  std::vector<double> histogramCounts;  ///< counts per bin
  NormalityTest normality;              ///< D'Agostino-Pearson on `density`
};

/// Axial profile of `bed`.
AxialProfile axialProfile(const Bed& bed, const AxialOptions& options);

/// Per-slice voxel counts inside the mask: what the axial profile, the porosity and the
/// packed-region detection need, accumulated slab by slab (integers: exact in any order).
struct SliceCounts {
  std::vector<std::uint64_t> mask;   ///< voxels inside the mask per slice
  std::vector<std::uint64_t> solid;  ///< solid voxels inside the mask per slice
};

/// Slice counts of a whole bed.
SliceCounts sliceCounts(const Bed& bed);

/// Adds the slices of a slab whose first plane is slice `z0` of the whole lattice.
void accumulateSliceCounts(SliceCounts& counts, std::int64_t z0,
                           const Grid<std::uint8_t>& indicator, const Grid<std::uint8_t>* mask);

/// Axial profile from slice counts over `lattice` (counts.mask.size() == nz).
AxialProfile axialProfile(const Lattice& lattice, const SliceCounts& counts,
                          const AxialOptions& options);

/// Options of radialProfile.
struct RadialOptions {
  /// Column axis (x, y) in mm; empty = fitted as the centroid of the mask.
  std::optional<std::array<double, 2>> axisMm;
  /// Column radius (mm); <= 0 = fitted from the mean mask area per slice, sqrt(A/π).
  double radiusMm = 0;
  /// Annulus width (mm); <= 0 = one voxel (smallest of the x, y spacings).
  double binWidthMm = 0;
  /// Sub-samples per voxel side (1..64) for the fractional annulus areas; 1 assigns each
  /// voxel to the annulus of its centre.
  int supersample = 8;
  /// Slices used, inclusive; lastSlice < 0 = up to the top.
  std::int64_t firstSlice = 0;
  std::int64_t lastSlice = -1;  ///< see firstSlice
  /// Width (mm) of the wall zone excluded from the "core" summary; <= 0 = radius / 2.
  double coreMarginMm = 0;
};

/// Annular packing density around the column axis.
struct RadialProfile {
  std::vector<double> rMm;             ///< annulus centre radius (mm)
  std::vector<double> wallDistanceMm;  ///< radius − r (mm), distance from the fitted wall
  std::vector<double> density;         ///< solid area / mask area; NaN when no mask area
  std::vector<double> areaMm2;         ///< mask area of the annulus summed over slices (mm²)
  std::array<double, 2> axisMm{0, 0};  ///< (x, y) of the axis, same frame as voxel centres
  double radiusMm = 0;                 ///< fitted or given column radius
  double coreDensity = 0;              ///< density for r <= radius − coreMargin; NaN if none
  double wholeDensity = 0;             ///< density over the whole section; NaN if none
  double coreRadiusMm = 0;             ///< radius − coreMargin
};

/// Radial profile of `bed`.
RadialProfile radialProfile(const Bed& bed, const RadialOptions& options);

/// Per-column (y, x) counts over the slices used: the radial profile's input, accumulated
/// slab by slab (integer-valued doubles: exact in any order).
struct ColumnCounts {
  ColumnCounts() = default;
  ColumnCounts(std::int64_t ny, std::int64_t nx);  ///< zeros for ny*nx columns
  std::vector<double> mask;                        ///< mask voxels per column
  std::vector<double> solid;                       ///< solid mask voxels per column
  std::uint64_t slicesWithMask = 0;                ///< slices used holding at least one mask voxel
};

/// Adds the slices of a slab (first plane = slice `z0`) that lie in [firstSlice, lastSlice].
void accumulateColumnCounts(ColumnCounts& counts, std::int64_t z0,
                            const Grid<std::uint8_t>& indicator, const Grid<std::uint8_t>* mask,
                            std::int64_t firstSlice, std::int64_t lastSlice);

/// Radial profile from column counts over `lattice` (`hasMask`: the bed has a /mask).
RadialProfile radialProfile(const Lattice& lattice, bool hasMask, const ColumnCounts& counts,
                            const RadialOptions& options);

}  // namespace voxpack::stats
