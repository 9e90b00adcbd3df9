#pragma once
/// \file mes.hpp
/// Mean empty space (docs/references.md, our definition): for a void voxel x and a direction
/// u, the chord c(x, u) = distance to the first solid along +u plus along −u (the container
/// wall counts as solid); m(x) = mean of c over the directions; reported as the
/// void-volume-weighted distribution of m. Window cuts: m(x) is kept only when no chord
/// through x is cut by the lattice boundary, and such a voxel is weighted by the inverse of
/// the fraction of window translations that keep its whole chord star inside (3D minus
/// sampling, Miles-Lantuéjoul), along the axes where the window cuts void (docs/stats.md).

#include <array>
#include <cstdint>
#include <vector>

#include "voxpack/core/bed.hpp"
#include "voxpack/core/progress.hpp"

namespace voxpack::stats {

/// Distribution of a per-voxel length (mean empty space, pore size...).
struct LengthDistribution {
  std::vector<double> binsMm;  ///< bin centres (mm)
  std::vector<double> pdf;     ///< probability density (1/mm), integrates to 1
  double binWidthMm = 0;       ///< bin width (mm)
  double meanMm = 0;           ///< mean; NaN when no sample
  double stdMm = 0;            ///< population standard deviation; NaN when no sample
  double lognormalMu = 0;      ///< mean of ln(value/mm) (maximum-likelihood lognormal)
  double lognormalSigma = 0;   ///< standard deviation of ln(value/mm)
  std::size_t samples = 0;     ///< values counted
};

/// Histogram, moments and lognormal fit of positive `values` (mm); bins of `binWidthMm`
/// from 0. Non-finite and non-positive values are skipped. `weights` (optional, same size)
/// weight each value; `samples` counts the values used.
LengthDistribution summarizeLengths(const std::vector<double>& values, double binWidthMm,
                                    const std::vector<double>* weights = nullptr);

/// As summarizeLengths for a histogram: `values[n]` occurs `counts[n]` times, each with
/// weight `weights[n]`; `samples` is the sum of the counts.
LengthDistribution summarizeCountedLengths(const std::vector<double>& values,
                                           const std::vector<double>& weights,
                                           const std::vector<std::uint64_t>& counts,
                                           double binWidthMm);

/// Axes (z, y, x) along which the lattice boundary cuts void-in-mask voxels (a void voxel on
/// one of the two faces normal to the axis): chords can be cut there.
std::array<bool, 3> windowCutAxes(const Bed& bed);

/// Per-voxel mean empty space and its minus-sampling weight.
struct MesField {
  std::vector<float> meanMm;  ///< m(x) (mm); NaN for solid, outside-mask, or any chord cut
  std::vector<float> weight;  ///< minus-sampling weight (>= 1); 0 where meanMm is NaN
  /// Mean of m over void voxels from the 13 per-direction point-weighted mean chords
  /// Σ w ℓ² / Σ w ℓ with 1D minus-sampling weights w = 1/Σ_lines(L − ℓ − 1) (linearity: E[m] is
  /// the mean over directions of E[c(x, u)]); NaN when a direction has no whole chord.
  double directionalMeanMm = 0;
};

/// Options of the lattice mean-empty-space path.
struct MesLatticeOptions {
  /// Histogram bin width (mm); <= 0 = one voxel (smallest spacing).
  double binWidthMm = 0;
  /// Worker threads (>= 1).
  int threads = 1;
};

/// Result of a mean-empty-space computation.
struct MesResult {
  LengthDistribution distribution;   ///< distribution of m over void voxels
  double directionalMeanMm = 0;      ///< lattice path: MesField::directionalMeanMm
  std::size_t voidVoxels = 0;        ///< void voxels inside the mask
  std::size_t undefinedVoxels = 0;   ///< void voxels (or samples) with a chord cut by the window
  int directions = 0;                ///< directions per voxel
  std::uint64_t sliceCutVoxels = 0;  ///< streamed: void voxels cut only by a slab window edge
  std::uint64_t sliceCutChords = 0;  ///< streamed: chords cut only by a slab window edge
  double seconds = 0;                ///< wall time of the computation
};

/// The 13 lattice line directions (k, j, i steps), one per ± pair.
const std::vector<std::array<int, 3>>& latticeDirections();

/// Per-voxel m(x) (mm) along the 13 lattice directions by run-length scans, O(N) each.
/// The sums behind the distribution and the directional mean are exact integers, so the
/// result is the same bits for any thread count, slab split (streamed) or rank count.
MesField meanEmptySpaceField(const Bed& bed, int threads, Progress& progress = nullProgress());

/// Mean empty space by the lattice path.
MesResult meanEmptySpaceLattice(const Bed& bed, const MesLatticeOptions& options,
                                Progress& progress = nullProgress());

/// Options of the isotropic (CGAL ray shooting) path.
struct MesIsotropicOptions {
  std::int64_t samples = 20000;  ///< void voxels sampled uniformly (>= 1); all when fewer
  int directions = 64;           ///< random isotropic directions per sampled voxel (>= 1)
  std::uint64_t seed = 1;        ///< seed of the sample and the directions
  double binWidthMm = 0;         ///< histogram bin width; <= 0 = one voxel
  int threads = 1;               ///< worker threads (>= 1)
};

/// Mean empty space by isotropic rays shot from sampled void voxel centres against the
/// surface of the digital solid (voxel faces between void-in-mask and the rest) with a
/// CGAL AABB tree. A ray leaving the lattice without a hit is a cut chord; window cuts are
/// handled as in the lattice path (minus-sampling weights).
/// `sampleOffsets` (optional) receives the voxel offsets sampled, `sampleMeans` their m
/// (NaN when cut).
MesResult meanEmptySpaceIsotropic(const Bed& bed, const MesIsotropicOptions& options,
                                  Progress& progress = nullProgress(),
                                  std::vector<std::size_t>* sampleOffsets = nullptr,
                                  std::vector<double>* sampleMeans = nullptr);

}  // namespace voxpack::stats
