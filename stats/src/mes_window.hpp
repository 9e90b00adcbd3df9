#pragma once
// Private: the lattice mean-empty-space scan over a window of z-planes (the whole bed in
// memory, or one slab with its halo when streamed), and its exact sums (docs/scale.md).
#include <algorithm>
#include <array>
#include <cstdint>
#include <vector>

#include "voxpack/core/communicator.hpp"
#include "voxpack/core/lattice.hpp"
#include "voxpack/core/progress.hpp"
#include "voxpack/stats/mes.hpp"

namespace voxpack::stats {

/// What the scan needs of the whole bed: its dims and spacing, the axes along which the
/// lattice boundary cuts void, and per direction the minus-sampling positions T(ℓ).
struct MesGeometry {
  Lattice lattice;                             ///< the whole bed's lattice
  std::array<bool, 3> cutAxes{};               ///< windowCutAxes of the whole bed
  std::vector<std::vector<double>> positions;  ///< per direction: T(ℓ), ℓ in voxels
  std::vector<double> stepMm;                  ///< per direction: length of one step
  std::vector<bool> lineCut;                   ///< per direction: lines can be cut
};

/// The geometry of `whole` with the cut axes `cutAxes`.
MesGeometry mesGeometry(const Lattice& whole, const std::array<bool, 3>& cutAxes);

/// Exact sums of the mean-empty-space distribution: every sum is a 128-bit fixed-point
/// integer (2^-44 resolution, values in voxels) or an integer count, so any split over
/// slabs, threads and ranks gives the same bits.
class MesSums {
 public:
  /// Sums for values histogrammed in bins of `binWidthMm`, lengths scaled by `voxelMm`.
  MesSums(double voxelMm, double binWidthMm, std::size_t directions);
  /// Sums for `lattice`'s 13 directions, scaled by its smallest spacing, in bins of
  /// `binWidthMm` (<= 0: one smallest spacing).
  MesSums(const Lattice& lattice, double binWidthMm);
  /// A void voxel inside the mask whose m(x) is `meanMm` with weight `weight` (NaN = cut).
  void addVoxel(float meanMm, float weight);
  /// `n` uncut chords of `length` voxels along direction `d`.
  void addChords(std::size_t d, std::int64_t length, std::uint64_t n);
  /// Empty sums with the same bins, scale and directions.
  MesSums emptyLike() const { return MesSums(voxelMm_, binWidthMm_, chords_.size()); }
  /// Adds another partial sum (same bins and scale).
  void merge(const MesSums& other);
  /// Sums over the ranks of `comm`, in place on every rank.
  void reduce(const Communicator& comm);
  /// The distribution and the directional mean of `geometry`.
  MesResult finish(const MesGeometry& geometry) const;

  std::uint64_t sliceCutVoxels = 0;  ///< void voxels whose star was cut by a slab window only
  std::uint64_t sliceCutChords = 0;  ///< own chords cut by a slab window edge inside the bed

 private:
  __extension__ typedef __int128 Fixed;
  Fixed fixed(double value);
  void add(Fixed& to, Fixed value);
  bool overflow_ = false;
  double voxelMm_, binWidthMm_;
  std::uint64_t voidVoxels_ = 0, undefined_ = 0, samples_ = 0;
  Fixed w_ = 0, wu_ = 0, wu2_ = 0, wl_ = 0, wl2_ = 0;  // Σw, Σw u, Σw u², Σw ln u, Σw ln² u
  std::vector<Fixed> histogram_;                       // Σw per bin of m
  std::vector<std::vector<std::uint64_t>> chords_;     // per direction: chords per length
};

/// A window of whole z-planes of the bed and the planes it owns.
struct MesWindow {
  const std::uint8_t* indicator = nullptr;  ///< window planes, C order
  const std::uint8_t* mask = nullptr;       ///< same shape, or null
  std::int64_t planes = 0;                  ///< planes in the window
  std::int64_t firstPlane = 0;              ///< bed plane of window plane 0
  std::int64_t ownFirst = 0;                ///< first owned window plane
  std::int64_t ownLast = 0;                 ///< one past the last owned window plane
};

/// Scans `window` along the 13 lattice directions and adds the m(x) of its owned void voxels
/// and the chords that start in its owned planes to `sums`. A run that reaches a window
/// edge inside the bed is cut there (counted in sums.sliceCut*). `field` (optional) receives
/// m and the weight of the owned planes (MesField layout).
void scanMesWindow(const MesWindow& window, const MesGeometry& geometry, int threads, MesSums& sums,
                   Progress& progress, MesField* field = nullptr);

/// Planes the in-memory path scans at a time: at least 32 (a run crossing a chunk's first
/// plane is walked back, about a chord per void voxel of that plane) and at least 2^20
/// voxels, at most nz.
inline std::int64_t mesInMemoryChunkPlanes(std::int64_t nz, std::int64_t ny, std::int64_t nx) {
  const std::int64_t plane = std::max<std::int64_t>(1, ny * nx);
  return std::max<std::int64_t>(
      1, std::min(nz, std::max<std::int64_t>(32, ((1 << 20) + plane - 1) / plane)));
}

/// Bytes per owned voxel of scanMesWindow's scratch for `cutAxes` (sums, counts, flags,
/// reach).
std::uint64_t mesScratchBytesPerVoxel(const std::array<bool, 3>& cutAxes);

/// Per-plane flags of void-in-mask voxels on the y and x faces of planes [z0, z0 + n) of a
/// slab: cutY[z0 + k], cutX[z0 + k] set to 1 (windowCutAxes, streamed).
void markFaceVoid(const std::uint8_t* indicator, const std::uint8_t* mask, std::int64_t n,
                  std::int64_t ny, std::int64_t nx, std::int64_t z0,
                  std::vector<std::uint64_t>& cutY, std::vector<std::uint64_t>& cutX);

}  // namespace voxpack::stats

#include "voxpack/core/bed_file.hpp"
#include "voxpack/core/memory.hpp"

namespace voxpack::stats {

/// Slabs and halo of the streamed mean empty space.
struct MesStreamPlan {
  std::int64_t slabPlanes = 0;  ///< planes each slab owns
  std::int64_t haloPlanes = 0;  ///< planes read beyond each side of a slab
  std::uint64_t bytes = 0;      ///< estimated peak (whole process)
};

/// Peak bytes of the streamed mean empty space on `region` with slabs of `slab` planes and
/// halos of `halo` (window planes, owned scratch, process base).
std::uint64_t estimateMesStreamedBytes(const BedHeader& header, const VoxelBox& region,
                                       const std::array<bool, 3>& cutAxes, std::int64_t slab,
                                       std::int64_t halo);

/// The plan that fits `budget`: `slab` (> 0) and `halo` (>= 0) as given; else the whole
/// region in one window when it fits on one rank; else the thickest slabs (at most a rank's
/// share of `ranks`) that fit with a halo of twice their thickness, and then the tallest
/// halo that fits beside them (a halo plane costs 1–2 bytes per voxel, an owned plane 7 to
/// 20). Throws ResourceError when the plan does not fit.
MesStreamPlan planMesStream(const BedHeader& header, const VoxelBox& region,
                            const std::array<bool, 3>& cutAxes, const MemoryBudget& budget,
                            std::int64_t slab, std::int64_t halo, int ranks);

/// Mean empty space of `region` of the bed `reader` reads, slab by slab with the halo of
/// `plan`, over the ranks of `comm` (every rank gets the result).
MesResult meanEmptySpaceStreamed(const BedSlabReader& reader, const VoxelBox& region,
                                 const MesGeometry& geometry, const MesStreamPlan& plan,
                                 double binWidthMm, int threads, Progress& progress,
                                 const Communicator& comm);

}  // namespace voxpack::stats
