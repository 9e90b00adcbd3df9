#pragma once
/// \file structure.hpp
/// Further structure statistics users ask for: pore-size (distance-transform) and
/// chord-length distributions, shadow images, and, from labels and the particle table,
/// coordination numbers and the particle orientation distribution (docs/stats.md).

#include <array>
#include <cstdint>
#include <vector>

#include "voxpack/core/bed.hpp"
#include "voxpack/stats/mes.hpp"

namespace voxpack::stats {

/// Squared Euclidean distance (mm²) from each voxel centre to the nearest centre of a voxel
/// where `source` is nonzero (exact, separable: Felzenszwalb & Huttenlocher 2012);
/// +inf when there is no source voxel.
std::vector<double> squaredDistanceTransform(const std::vector<std::uint8_t>& source,
                                             const Lattice& lattice, int threads);

/// Pore-size distribution: distance (mm) from each void voxel centre to the nearest
/// non-void (solid or outside-mask) voxel centre; its density and complementary CDF.
struct PoreSizeDistribution {
  LengthDistribution distribution;  ///< over void voxels; 0 distances are impossible
  std::vector<double> ccdf;         ///< fraction of void voxels with distance > binsMm edge
  std::vector<double> ccdfMm;       ///< distances of `ccdf` (bin lower edges)
  double maxMm = 0;                 ///< largest distance (the largest inscribed sphere)
};

/// Pore-size distribution of `bed` (void inside the mask; solid and wall are the targets).
PoreSizeDistribution poreSizeDistribution(const Bed& bed, double binWidthMm, int threads);

/// Chord-length distribution along the lattice axes: void runs bounded by solid or wall on
/// both ends (runs cut by the window are excluded), number weighted.
struct ChordLengths {
  LengthDistribution all;                     ///< the three axes together
  std::array<LengthDistribution, 3> perAxis;  ///< along z, y, x
};

/// Chord lengths of `bed`.
ChordLengths chordLengths(const Bed& bed, double binWidthMm);

/// Mean projection of the solid fraction along one axis (paper Fig. 7 shadow images).
struct ShadowImage {
  std::int64_t rows = 0, cols = 0;  ///< image size
  std::vector<double> values;       ///< rows × cols solid fraction in [0, 1]; NaN: no mask
};

/// Shadow image along axis 0 (z: image [y][x]), 1 (y: image [z][x]) or 2 (x: image [z][y]).
ShadowImage shadowImage(const Bed& bed, int axis);

/// Contacts between labelled particles: face-adjacent voxels with different nonzero labels.
struct Coordination {
  std::vector<double> perParticle;  ///< coordination number of each label present (1..max)
  std::size_t contacts = 0;         ///< distinct particle pairs in contact
  std::size_t particles = 0;        ///< labels present in the volume
  double mean = 0;                  ///< mean coordination number; NaN when no particle
};

/// Coordination numbers from `bed.labels` (throws InputError when there are none).
Coordination coordinationNumbers(const Bed& bed);

/// Angles between each particle's axis (body z axis rotated by its orientation) and the
/// column axis z.
struct OrientationDistribution {
  std::vector<double> anglesDeg;          ///< per particle, 0..90°
  std::vector<double> histogramEdgesDeg;  ///< bin edges (0..90°)
  std::vector<double> histogram;          ///< fraction of particles per bin
  double meanCos = 0;                     ///< mean |cos θ| (0.5 for isotropic orientations)
  double orderParameter = 0;  ///< <(3cos²θ − 1)/2> (0 isotropic, 1 vertical, −0.5 flat)
};

/// Orientation distribution from the particle table (throws InputError without orientations).
OrientationDistribution orientationDistribution(const Bed& bed, int bins = 18);

/// Writes `img` as an 8-bit grey PNG (solid dark: 255·(1 − value), no mask white),
/// first row at the top. Throws IoError.
void writeGreyPng(const ShadowImage& img, const std::string& path, bool flipRows);

}  // namespace voxpack::stats
