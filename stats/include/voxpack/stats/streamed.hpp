#pragma once
/// \file streamed.hpp
/// Statistics of beds bigger than memory (docs/scale.md): the memory each path needs, the
/// packed region, and the statistics streamed in z-slabs (axial, radial, S2, porosity,
/// orientation), on one process or spread over MPI ranks. Equal to computeStats: counts
/// exactly, S2 bit for bit in double precision.

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <string>

#include "voxpack/core/bed_file.hpp"
#include "voxpack/core/memory.hpp"
#include "voxpack/core/progress.hpp"
#include "voxpack/stats/crop.hpp"
#include "voxpack/stats/distributed.hpp"
#include "voxpack/stats/profiles.hpp"
#include "voxpack/stats/stats.hpp"

namespace voxpack::stats {

/// Resident memory of the voxpack process before any bed is read (code, libraries, heap
/// arenas): /usr/bin/time gave 41.7 MB for `stats` and `info` on a 1-voxel bed (MPI build,
/// 2026-12-03; 28 MiB when first measured, before flow, export and MPI were linked).
inline constexpr std::uint64_t kProcessBaseBytes = 44ull << 20;

/// Statistics the streamed path computes.
const std::set<std::string>& streamableStatistics();

/// Peak bytes of computeStats run in memory on the bed of `header`, cropped to `roi`
/// (readBed, the crop copy, then the largest statistic's work), plus kProcessBaseBytes.
std::uint64_t estimateInMemoryBytes(const BedHeader& header, const StatsOptions& options,
                                    const std::optional<VoxelBox>& roi);

/// Peak bytes of the streamed path on `region` of the bed with slabs of `planes`.
std::uint64_t estimateStreamedBytes(const BedHeader& header, const VoxelBox& region,
                                    const StatsOptions& options, std::int64_t planes);

/// The thickest slab (planes, <= region nz) whose streamed peak fits `budget`; 0 when even
/// one plane does not.
std::int64_t slabPlanesWithin(const BedHeader& header, const VoxelBox& region,
                              const StatsOptions& options, const MemoryBudget& budget);

/// The S2 tile edge (voxels; 0 = whole planes) whose slabs fit `budget` with the least FFT
/// work per voxel, for slabs of `slabPlanes` (0 = the thickest that fits).
std::int64_t chooseS2TileVoxels(const BedHeader& header, const VoxelBox& region,
                                const StatsOptions& options, const MemoryBudget& budget,
                                std::int64_t slabPlanes = 0);

/// The slices holding the packing, detected as `compare` does: from the first to the last
/// partly solid slice (solid fraction in (0, 0.999)) denser than `fraction` x the densest.
struct PackedSlices {
  std::int64_t firstSlice = 0;   ///< first slice of the packed region
  std::int64_t lastSlice = -1;   ///< last slice (inclusive)
  double peakDensity = 0;        ///< densest partly solid slice
  double headspaceFraction = 0;  ///< mask voxels outside the region / all mask voxels
  bool found = false;            ///< a region narrower than the whole bed was found
};

/// Packed region from per-slice counts.
PackedSlices packedSlices(const SliceCounts& counts, double fraction = 0.5);

/// The "packed_region" JSON record (slices, z range in mm, headspace, whether applied).
nlohmann::json packedRegionJson(const PackedSlices& region, const Lattice& lattice,
                                const std::string& mode, bool applied);

/// Options of the streamed path.
struct StreamOptions {
  std::int64_t slabPlanes = 0;        ///< slab thickness (planes); 0 = from `budget`
  MemoryBudget budget;                ///< memory limit of the whole run
  std::optional<CropOptions> roi;     ///< --roi-mm / --roi-box-mm crop
  bool packedRegion = false;          ///< crop to the packed region (--packed-region auto)
  double packedRegionFraction = 0.5;  ///< packed-region threshold (as compare)
  std::int64_t mesHaloPlanes = -1;    ///< mean empty space: halo planes; < 0 = from `budget`
};

/// The statistics of the bed file `path`, streamed slab by slab over the ranks of `comm`
/// (every rank calls it; every rank gets the JSON). Throws InputError when a requested
/// statistic has no streamed path, ResourceError when one slab does not fit the budget,
/// Cancelled when `progress` asks.
nlohmann::json computeStatsStreamed(const std::filesystem::path& path, const StatsOptions& options,
                                    const StreamOptions& stream, Progress& progress,
                                    const Communicator& comm = Communicator::world());

/// Porosity summary of the bed file `path` streamed in slabs that fit `budget` (`info`).
BedSummary summarizeStreamed(const std::filesystem::path& path, const MemoryBudget& budget,
                             std::int64_t slabPlanes = 0,
                             const Communicator& comm = Communicator::world());

}  // namespace voxpack::stats
