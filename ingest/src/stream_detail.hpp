#pragma once
// Private pieces of the streamed ingest path (stream_*.cpp), shared between its files.
#include <cstdint>
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>
#include <unordered_map>
#include <utility>
#include <vector>

#include "voxpack/core/communicator.hpp"
#include "voxpack/core/grid.hpp"
#include "voxpack/core/progress.hpp"
#include "voxpack/ingest/column.hpp"
#include "voxpack/ingest/ingest.hpp"
#include "voxpack/ingest/stream.hpp"

namespace voxpack::ingest::stream_detail {

/// Planes [from, to) of `g` (local indices) as their own grid, origin moved along.
Grid<std::uint8_t> cropPlanes(const Grid<std::uint8_t>& g, std::int64_t from, std::int64_t to);
/// Planes [from, to) of a float grid.
Grid<float> cropPlanes(const Grid<float>& g, std::int64_t from, std::int64_t to);

/// Solid-chord sums of voxelsPerDiameter (quality.cpp), accumulated slab by slab.
struct ChordSums {
  double total = 0;                ///< sum of chord lengths, voxels (an integer)
  double count = 0;                ///< chords (an integer)
  std::vector<std::int64_t> run;   ///< z: open run length per (j, i)
  std::vector<std::uint8_t> open;  ///< z: run began after a void voxel inside the region
  /// Chords along x and y of the planes of `ind` (a slab's own planes).
  void addInPlane(const Grid<std::uint8_t>& ind, const Grid<std::uint8_t>* region);
  /// Chords along z, continuing the runs of the previous slab; call for slabs in z order.
  void addAlongZ(const Grid<std::uint8_t>& ind, const Grid<std::uint8_t>* region);
  /// 1.5 x the mean chord (0 without chords), as voxelsPerDiameter.
  double diameter() const { return count > 0 ? 1.5 * total / count : 0.0; }
};

/// Exact counts of grey values: integers 0..65535 (8/16-bit files, and their medians) in a
/// flat array, any other value in a map of at most kMaxDistinct entries (then `overflow`).
struct ValueCounts {
  static constexpr std::size_t kMaxDistinct = std::size_t{1} << 20;
  std::vector<std::uint64_t> small = std::vector<std::uint64_t>(65536, 0);
  std::unordered_map<float, std::uint64_t> other;
  bool overflow = false;  ///< more distinct values than kMaxDistinct (or, over ranks, any other)
  float lo = std::numeric_limits<float>::infinity();
  float hi = -std::numeric_limits<float>::infinity();
  void add(float v);
  /// Sums over the ranks (integer counts: exact in any order); values outside the flat
  /// array on any rank set `overflow` on all.
  void reduce(const Communicator* comm);
  /// (value, count) in increasing value order (empty when `overflow`).
  std::vector<std::pair<float, std::uint64_t>> sorted() const;
};

/// The threshold at which a `phi` share of the counted values is void (volumeThreshold's
/// rule on the whole image: midway between the two order statistics bracketing the count).
double quantileThreshold(const std::vector<std::pair<float, std::uint64_t>>& sorted, double phi,
                         bool voidBright);

/// The same from `bins` equal bins over [lo, hi], linear inside the bin that holds the count.
double quantileThresholdFromBins(const std::vector<double>& bins, float lo, float hi, double phi,
                                 bool voidBright);

/// Distance from the column wall of every pixel of plane k, in whole voxels: ring r
/// (0..kRings) for R - r_pixel in [r, r + 1) voxels (kRings: deeper), kOutside outside the
/// column. Without a column every pixel is kRings.
constexpr int kRings = 24;
constexpr int kOutside = kRings + 1;
std::vector<std::uint8_t> wallRings(const Lattice& lattice, const ColumnFit* column,
                                    std::int64_t k = 0);

/// wallRings plane by plane: one map for an upright axis (a given column, or a fit without
/// tilt), else each plane's own (the last one kept).
class PlaneRings {
 public:
  /// Maps of the planes of `lattice` (the whole volume's) about `column` (null: none).
  PlaneRings(const Lattice& lattice, const ColumnFit* column);
  /// The map of plane k (global index).
  const std::vector<std::uint8_t>& operator()(std::int64_t k);
  std::size_t plane() const { return map_.size(); }  ///< pixels per plane

 private:
  Lattice l_;
  std::optional<ColumnFit> column_;
  bool upright_ = true;
  std::int64_t at_ = -1;
  std::vector<std::uint8_t> map_;
};

/// Raw grey sums and voxel counts per plane and wall ring (pass 1 of the volume threshold).
struct RingSums {
  std::optional<PlaneRings> rings;  ///< the wall rings of each plane
  std::vector<double> sum;          ///< [plane * (kOutside + 1) + ring]
  std::vector<double> count;        ///< voxels added, same layout
  /// Zero sums for the planes of `lattice` about `column` (null: none).
  void reset(const Lattice& lattice, const ColumnFit* column);
  /// Adds planes [from, to) of `raw` (local indices), which start at global plane z.
  void add(const Grid<float>& raw, std::int64_t from, std::int64_t to, std::int64_t z);
  /// Sums over the ranks (each plane added on one rank: exact).
  void reduce(const Communicator* comm);
};

/// The column fitted on a streamed image (fitColumn, then refineColumn when
/// o.refineColumn; docs/scale.md): one pass for the circles on the cut at tOtsu, one per
/// refinement iteration. `passes` is advanced by the passes made.
ColumnFit streamedColumnFit(const VolumeHeader& h, const IngestOptions& o, double tOtsu,
                            bool voidBright, bool squared, std::int64_t slabPlanes, int threads,
                            Progress& progress, const Communicator* comm, int& passes);

/// The wall-blur correction of the streamed volume threshold (correctWallBlur per slab).
struct WallFix {
  ColumnFit column;               ///< the given column
  WallBlurCorrection correction;  ///< blur, levels and model from the sample slab
};

/// Planes the denoise filter reads beyond a slab on each side (0: none).
std::int64_t denoiseHalo(const IngestOptions& o);

/// The denoised image over planes [a, b) (the filter's halo read and dropped). `fix`, when
/// given, divides the wall's blur out of the raw slab first; `raw`, when given, gets the
/// (corrected) raw planes [a, b) before the filter.
Grid<float> denoisedPlanes(const VolumeHeader& h, const IngestOptions& o, std::int64_t a,
                           std::int64_t b, int threads, RingSums* raw = nullptr,
                           const WallFix* fix = nullptr);

/// What the volume threshold decided, and its provenance.
struct StreamedVolume {
  bool used = false;                          ///< false: Otsu (levels not clear)
  double threshold = 0;                       ///< image units, on the image `cut` names
  DenoiseMethod cut = DenoiseMethod::Median;  ///< the filter of the image the threshold cuts
  std::int64_t first = 0, last = -1;          ///< the bed's slices it was aimed over
  int ring = 0;                ///< region: wall rings ring..kRings (0: the whole column)
  std::optional<WallFix> fix;  ///< the wall-blur correction, when applied
  double aimed = 0;            ///< void fraction aimed at over the region
  std::int64_t sampleFirst = 0, sampleLast = -1;  ///< the sample slab's planes
  int passes = 0;                                 ///< passes over the volume it added
  nlohmann::json thresholdJson, qualityJson, sampleJson;
};

/// The volume-preserving threshold of a streamed image (docs/scale.md): levels, blur
/// and interface density from a sample slab in the bed, the mean intensity from `sums`
/// (pass 1), the order statistics over the bed's slices from one more pass.
StreamedVolume streamedVolumeThreshold(const VolumeHeader& h, const IngestOptions& o,
                                       const ColumnFit* column, bool voidBright, double tOtsu,
                                       double otsuVoidMean, double otsuSolidMean,
                                       const RingSums& sums, std::int64_t slabPlanes, int threads,
                                       Progress& progress, const Communicator* comm);

/// Planes of the volume threshold's sample slab: 2^26 voxels, 16 to 32 planes, at most nz.
std::int64_t volumeSamplePlanes(const Lattice& lattice);

}  // namespace voxpack::ingest::stream_detail
