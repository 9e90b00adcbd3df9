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

/// Void chords along z, y and x as exact counts of run lengths, added plane by plane in z
/// order: the whole bed, or the z-slabs of a stream or of one MPI rank. Runs along z that
/// continue past the planes added are joined to the neighbouring planes' by a carry word
/// per column, so slabs and ranks give exactly the whole bed's counts. As in chordLengths,
/// a run touching the first or last voxel of its line is cut by the window and not counted.
class ChordRuns {
 public:
  /// For a region (the whole bed, or its ROI) of nz x ny x nx voxels.
  ChordRuns(std::int64_t nz, std::int64_t ny, std::int64_t nx);
  /// Adds the first `planes` planes of `indicator` (and `mask`, null: all inside), which are
  /// planes z0.. of the region; planes must come in order without gaps.
  void addPlanes(std::int64_t z0, const Grid<std::uint8_t>& indicator,
                 const Grid<std::uint8_t>* mask, std::int64_t planes);
  /// Joins the z runs that reach the first plane added to `carry` (the previous planes'
  /// word per column; empty: the region starts here) and returns the carry that the next
  /// planes (the next rank) start from. Called once, after the last addPlanes.
  std::vector<std::uint64_t> joinCarry(const std::vector<std::uint64_t>& carry);
  /// counts()[a][l]: whole chords of l voxels along axis a (0 z, 1 y, 2 x).
  std::array<std::vector<std::uint64_t>, 3>& counts() { return counts_; }
  /// Whether a void voxel lies on the region's faces normal to each axis (0/1 per axis).
  std::vector<std::uint64_t>& windowCut() { return windowCut_; }

 private:
  std::int64_t n_[3];
  std::int64_t planesAdded_ = 0;
  std::vector<std::uint32_t> head_, run_;  // per column: the run from the first plane, the open run
  std::vector<std::uint8_t> sawSolid_;     // per column: a non-void voxel seen
  std::array<std::vector<std::uint64_t>, 3> counts_;
  std::vector<std::uint64_t> windowCut_;
};

/// Chord lengths from the counts of `runs` (summed over slabs and ranks) on `lattice`.
ChordLengths chordLengths(ChordRuns& runs, const Lattice& lattice, double binWidthMm);

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
