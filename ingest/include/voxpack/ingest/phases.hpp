#pragma once
/// \file phases.hpp
/// Two-phase statistics of a grey volume: noise sigma and phase levels fitted from the
/// histogram (Gaussian or Rician peaks), the void fraction from the mean intensity (blur
/// preserves it), and the threshold that reproduces that void fraction. Derivation in
/// docs/ingest.md ("Volume-preserving threshold").

#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>

#include "voxpack/core/grid.hpp"

namespace voxpack::ingest {

/// Noise of the image: Gaussian (XMT, CT) or Rician (MRI magnitude).
enum class NoiseModel { Gaussian, Rician };

/// Phase levels of a two-phase image, fitted from its histogram.
struct PhaseLevels {
  bool clear = false;  ///< two peaks >= 3 noise sigma apart, each >= 0.5 % of the voxels
  NoiseModel model = NoiseModel::Gaussian;  ///< noise model used for the fit
  double voidLevel = 0.0;                   ///< mean reading of a pure void voxel (image units)
  double solidLevel = 0.0;                  ///< mean reading of a pure solid voxel (image units)
  double voidSignal = 0.0;                  ///< noise-free void signal (Rician: below voidLevel)
  double solidSignal = 0.0;                 ///< noise-free solid signal (Rician: 0 for no signal)
  double noiseSigma = 0.0;                  ///< noise sigma (Gaussian sd; Rician: of each channel)
  std::string note;  ///< how the levels were found, or why they are not clear
};

/// What is known of the phases before the histogram is read (NaN / 0: unknown).
struct PhaseHints {
  double noiseSigma = 0.0;  ///< noise sigma measured elsewhere (phaseInteriorStats), > 0
  double voidMean = std::numeric_limits<double>::quiet_NaN();   ///< mean deep in the void
  double solidMean = std::numeric_limits<double>::quiet_NaN();  ///< mean deep in the solid
};

/// Fits the levels from the values of `image` where `region` != 0 (null: everywhere).
/// Without hints the noise sigma comes from the outer flank of the bright peak (MRI: the
/// Rayleigh mode of the signal-free solid) and each level from a Gaussian fitted to its
/// peak's outer flank. With hints->noiseSigma > 0 that sigma is used, a phase's level is
/// its hinted mean when given, else the mean of a Gaussian of that width fitted to the far
/// outer flank (1 to 3.5 sigma out), and an MRI signal-free phase reads sigma sqrt(pi/2).
PhaseLevels fitPhaseLevels(const Grid<float>& image, const Grid<std::uint8_t>* region,
                           bool voidBright, NoiseModel model, const PhaseHints* hints = nullptr);

/// Mean and noise sigma of the voxels deep inside one phase of a preliminary segmentation.
struct InteriorStats {
  double mean = 0.0;      ///< mean reading (image units)
  double sigma = 0.0;     ///< 1.4826 MAD of x-neighbour differences / sqrt 2
  std::size_t pairs = 0;  ///< disjoint x pairs used (0: too few deep voxels)
  int depth = 0;          ///< voxels of the phase required along +-x, y, z
};

/// Statistics of `image` over x pairs lying at least 3 (else 2) voxels deep inside `phase`
/// of `indicator` (a homogeneous region: the blurred signal is flat there); >= 2000 pairs.
/// `depth` > 0: exactly that depth, else none (pairs = 0).
InteriorStats phaseInteriorStats(const Grid<float>& image, const Grid<std::uint8_t>& indicator,
                                 const Grid<std::uint8_t>* region, std::uint8_t phase,
                                 int depth = 0);

/// How phaseDeepLevel samples and fits.
struct DeepLevelOptions {
  double radius = 3.5;           ///< ball radius (voxels) tried first
  double minRadius = 2.0;        ///< smallest ball tried (steps of 0.5 voxel)
  std::size_t minVoxels = 2000;  ///< a ball is used when it holds this many voxels
  bool oneSided = false;         ///< fit the far tail (else the plain mean)
  bool upper = true;             ///< the far tail is above the level (the brighter phase)
  double cut = 1.0;              ///< the tail starts cut sigma on the near side of the level
  double fallbackSigma = 0.0;    ///< noise sigma: the dip test's, and the tail fit's when
                                 ///< the phase has < 100 deep pairs
  double dipSigmas = 2.0;        ///< leave out deep voxels whose 26 neighbours' mean lies this many
                           ///< of its sigmas towards the other phase from the window's (0: off)
  std::size_t maxExamined = std::size_t{1} << 23;  ///< voxels looked at (whole slices, strided)
  int threads = 1;                                 ///< OpenMP threads (result independent)
};

/// The level of one phase of a preliminary segmentation, read deep inside it.
struct DeepLevel {
  double level = std::numeric_limits<double>::quiet_NaN();  ///< fitted level (image units)
  double mean = std::numeric_limits<double>::quiet_NaN();   ///< plain mean of the deep voxels
  double sigma = 0.0;           ///< the phase's noise (1.4826 MAD of x-pair differences / sqrt 2)
  double radius = 0.0;          ///< ball radius used (voxels); 0: too few deep voxels
  std::size_t voxels = 0;       ///< deep voxels used
  std::size_t pairs = 0;        ///< disjoint deep x pairs behind sigma
  std::size_t dipExcluded = 0;  ///< deep voxels left out on a dip (a gap the blur closed)
  int sliceStride = 1;          ///< every sliceStride-th slice was sampled
};

/// Level of `phase`: voxels whose Euclidean ball of `radius` (else a smaller one holding
/// minVoxels) lies inside the phase and whose centre is in `region`, less those on a dip
/// (dipSigmas); their mean, or (oneSided) a normal with the phase's own sigma fitted to
/// the tail away from the other phase. Deterministic for any thread count.
DeepLevel phaseDeepLevel(const Grid<float>& image, const Grid<std::uint8_t>& indicator,
                         const Grid<std::uint8_t>* region, std::uint8_t phase,
                         const DeepLevelOptions& options);

/// Mean of a Rician variable of signal `a` and channel sigma `sigma`.
double ricianMean(double a, double sigma);

/// Excess void volume per unit surface (in voxels) that the mean-intensity estimator
/// reads at a planar solid/void interface blurred by a Gaussian of `blurVoxels`: 0 for
/// Gaussian noise (the mean is linear), negative for Rician (its mean is convex in the
/// signal near zero).
double meanEstimatorEdgeBiasVoxels(const PhaseLevels& levels, double blurVoxels);

/// Interface area per unit volume (1/voxel) of the two-phase `indicator` inside `region`
/// by stereology, S_V = 2 P_L, with P_L the phase changes per voxel length along x, y, z.
double surfaceDensityPerVoxel(const Grid<std::uint8_t>& indicator,
                              const Grid<std::uint8_t>* region);

/// The void fraction from the mean intensity and how it was corrected.
struct MeanVoidFraction {
  double meanIntensity = 0.0;    ///< <I> over the region
  double raw = 0.0;              ///< (<I> - I_solid) / (I_void - I_solid)
  double edgeBiasVoxels = 0.0;   ///< meanEstimatorEdgeBiasVoxels
  double surfacePerVoxel = 0.0;  ///< S_V used for the correction
  double phi = 0.0;              ///< raw - edgeBias * S_V, clamped to [0, 1]
  std::size_t voxels = 0;        ///< voxels in the region
};

/// phi_void from the mean of `image` over `region`, corrected for the Rician edge bias
/// with the interface density of `indicator` (any rough segmentation of the same image).
MeanVoidFraction meanVoidFraction(const Grid<float>& image, const Grid<std::uint8_t>* region,
                                  const PhaseLevels& levels, double blurVoxels,
                                  const Grid<std::uint8_t>& indicator);

/// The threshold at which the void fraction of `image` over `region` is `phi`
/// (void = value > t when voidBright, value <= t otherwise): midway between the two
/// order statistics that bracket the target count.
double volumeThreshold(const Grid<float>& image, const Grid<std::uint8_t>* region, double phi,
                       bool voidBright);

/// Void fraction of `indicator` over `region` (null: everywhere); NaN for an empty region.
double regionVoidFraction(const Grid<std::uint8_t>& indicator, const Grid<std::uint8_t>* region);

}  // namespace voxpack::ingest
