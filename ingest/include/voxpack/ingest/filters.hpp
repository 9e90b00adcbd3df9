#pragma once
/// \file filters.hpp
/// Image filters: median (ours), and the ITK-backed curvature anisotropic diffusion,
/// N4 bias-field correction and distance-map watershed.

#include <algorithm>
#include <cstdint>
#include <vector>

#include "voxpack/core/grid.hpp"
#include "voxpack/core/progress.hpp"

namespace voxpack::ingest {

/// Median over the (2r+1)^3 box around each voxel (edges clamped); 1 <= r <= 5.
Grid<float> medianFilter(const Grid<float>& image, int radiusVoxels, int threads);

/// Median of each voxel and its 6 face neighbours (edges clamped): removes noise like the
/// 3^3 box but keeps one-voxel-wide pores and throats, which the box erases.
Grid<float> crossMedianFilter(const Grid<float>& image, int threads);

/// crossMedianFilter's value at one voxel.
inline float crossMedianAt(const Grid<float>& image, std::int64_t k, std::int64_t j,
                           std::int64_t i) {
  const Lattice& l = image.lattice();
  const std::int64_t nz = l.nz(), ny = l.ny(), nx = l.nx();
  float w[7] = {image(k, j, i),
                image(std::max<std::int64_t>(k - 1, 0), j, i),
                image(std::min(k + 1, nz - 1), j, i),
                image(k, std::max<std::int64_t>(j - 1, 0), i),
                image(k, std::min(j + 1, ny - 1), i),
                image(k, j, std::max<std::int64_t>(i - 1, 0)),
                image(k, j, std::min(i + 1, nx - 1))};
  std::nth_element(w, w + 3, w + 7);
  return w[3];
}

/// medianFilter's value at one voxel; `window` is scratch.
float boxMedianAt(const Grid<float>& image, int radiusVoxels, std::int64_t k, std::int64_t j,
                  std::int64_t i, std::vector<float>& window);

/// Options of curvatureDiffusion (ITK CurvatureAnisotropicDiffusionImageFilter).
struct CurvatureDiffusionOptions {
  int iterations = 5;             ///< diffusion steps, 1..100
  double conductance = 1.0;       ///< edge-stopping strength, > 0 (lower keeps edges sharper)
  double timeStepFraction = 0.9;  ///< fraction of the stable step 1/2^(d+1) in voxel units, (0, 1]
};

/// Edge-preserving smoothing (Whitaker's modified curvature diffusion), in place.
void curvatureDiffusion(Grid<float>& image, const CurvatureDiffusionOptions& options, int threads);

/// Richardson-Lucy deconvolution (ITK) with a Gaussian point-spread function of standard
/// deviation `sigmaMm`, `iterations` steps (1..200), in place. Negative values are clipped
/// to 0 first (the method needs a non-negative image); returns how many were.
std::size_t richardsonLucy(Grid<float>& image, double sigmaMm, int iterations, int threads);

/// Options of n4BiasCorrection (ITK N4BiasFieldCorrectionImageFilter, Tustison 2010).
struct N4Options {
  int shrinkFactor = 4;         ///< fit on a grid shrunk by this factor per axis, 1..16
  int fittingLevels = 3;        ///< B-spline multi-resolution levels, 1..6
  int iterationsPerLevel = 50;  ///< maximum iterations at each level, >= 1
  double convergence = 1e-3;    ///< stop when the field's coefficient of variation change is below
  int controlPoints = 4;        ///< B-spline control points per axis at the first level, >= 4
};

/// Removes a smooth multiplicative bias field, in place; returns the field's max/min ratio.
/// Intensities must be positive where it matters (MRI magnitude); values <= 0 are left out
/// of the fit.
double n4BiasCorrection(Grid<float>& image, const N4Options& options, int threads,
                        Progress& progress = nullProgress());

/// Particle labels of the solid phase (indicator == 0): Euclidean distance map, markers at
/// maxima deeper than `markerDepthVoxels`, morphological watershed, labels 1..N, 0 = void.
Grid<std::uint32_t> watershedLabels(const Grid<std::uint8_t>& indicator, double markerDepthVoxels,
                                    int threads, std::size_t* labelCount = nullptr);

}  // namespace voxpack::ingest
