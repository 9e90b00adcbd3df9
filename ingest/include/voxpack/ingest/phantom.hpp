#pragma once
/// \file phantom.hpp
/// A synthetic MRI or XMT image of a known bed: phase intensities, container wall,
/// Gaussian blur, smooth multiplicative bias field, Rician (MRI) or Gaussian (XMT) noise.
/// The ground truth for ingest.

#include <cstdint>

#include "voxpack/core/bed.hpp"
#include "voxpack/core/progress.hpp"

namespace voxpack::ingest {

/// Imaging modality of a phantom.
enum class Modality { Mri, Xmt };

/// Options of makePhantom.
struct PhantomOptions {
  Modality modality = Modality::Mri;  ///< MRI: water (void) bright; XMT: solid bright
  double snr = 10.0;          ///< contrast between the phases / noise sigma, > 0 (inf = no noise)
  double blurMm = 0.0;        ///< Gaussian blur sigma in mm, >= 0 (point spread of the scanner)
  double biasFraction = 0.0;  ///< bias field amplitude: gain in [1 - F, 1 + F], 0 <= F < 1
  double voxelSizeMm = 0.0;   ///< > 0: output on this isotropic voxel (same box); 0 = bed lattice
  double wallThicknessMm = 0.0;  ///< container wall drawn outside the mask; 0 = 4 bed voxels
  std::uint64_t seed = 1;        ///< noise and bias field seed
};

/// Phase intensities before blur, bias and noise (documented in docs/ingest.md).
struct PhantomLevels {
  float voidLevel;     ///< pore space (water in MRI, air in XMT)
  float solidLevel;    ///< particles
  float wallLevel;     ///< container wall
  float outsideLevel;  ///< outside the container
};

/// The levels used for a modality.
PhantomLevels phantomLevels(Modality modality);

/// Simulates imaging `bed`. The result carries the output lattice (spacing and origin of
/// the bed, or resampled). Same seed -> same image for any thread count.
Grid<float> makePhantom(const Bed& bed, const PhantomOptions& options, int threads,
                        Progress& progress = nullProgress());

/// Largest phantom blur sigma, in voxels of the finest axis.
inline constexpr double kMaxBlurVoxels = 50.0;

/// Largest blur sigma in mm on lattice `l` (kMaxBlurVoxels x the smallest spacing).
double maxBlurMm(const Lattice& l);

/// Throws UsageError naming --blur-mm and the limit when sigmaMm > maxBlurMm(l).
void requireBlurWithinLimit(double sigmaMm, const Lattice& l);

/// Bytes makePhantom needs at its peak for `bed` (image, bias field, resampled copy).
std::uint64_t estimatePhantomPeakBytes(const Bed& bed, const PhantomOptions& options);

/// Separable Gaussian blur with sigma in mm (per-axis sigma / spacing voxels), edges clamped.
void gaussianBlur(Grid<float>& image, double sigmaMm, int threads);

}  // namespace voxpack::ingest
