#pragma once
/// \file stream.hpp
/// Streamed ingest for volumes bigger than the memory budget (docs/scale.md): the
/// image header is read alone, the voxels by z-slab with the halo each step needs, the
/// threshold comes from a value histogram streamed in a first pass, and the bed is written
/// slab by slab. For the option sets it supports the bed equals in-memory ingest's byte
/// for byte; the others are refused up front (streamedIngestUnsupported).

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "voxpack/core/communicator.hpp"
#include "voxpack/core/grid.hpp"
#include "voxpack/core/memory.hpp"
#include "voxpack/core/progress.hpp"
#include "voxpack/ingest/ingest.hpp"

namespace voxpack::ingest {

/// Where the voxels of a streamable input lie on disk.
struct StreamSource {
  enum class Kind { None, Raw, Slices };
  Kind kind = Kind::None;                     ///< None: the input cannot be read by slab
  std::filesystem::path dataFile;             ///< Raw: file holding the voxels
  std::uint64_t dataOffset = 0;               ///< Raw: byte offset of voxel (0, 0, 0)
  int componentBytes = 0;                     ///< Raw: bytes per voxel (1, 2, 4, 8)
  char componentKind = 'u';                   ///< Raw: 'u' unsigned, 's' signed, 'f' float
  bool bigEndian = false;                     ///< Raw: byte order of multi-byte voxels
  std::vector<std::filesystem::path> slices;  ///< Slices: one 2-D file per z plane, in order
  std::string whyNot;                         ///< None: why (e.g. "gzip-encoded NRRD")
};

/// The header of an input: what readVolume would produce, without the voxels.
struct VolumeHeader {
  Lattice lattice;      ///< as readVolume's image lattice (after --voxel-size)
  VolumeInfo info;      ///< as readVolume's info
  StreamSource source;  ///< how to read it by slab
};

/// Reads the header of `input` only (ITK ReadImageInformation; a slice folder's first
/// slice). Nothing when the lattice is not known without reading (a DICOM series).
/// Throws as readVolume for missing or malformed inputs.
std::optional<VolumeHeader> readVolumeHeader(const std::filesystem::path& input,
                                             const ReadOptions& options);

/// Reads whole z planes [z0, z1) of a streamable input as float (the values readVolume
/// gives); throws FormatError on NaN/inf, IoError on a short file.
Grid<float> readVolumeSlab(const VolumeHeader& header, std::int64_t z0, std::int64_t z1);

/// Empty when `options` have a streamed path on `header`, else why not (one phrase).
std::string streamedIngestUnsupported(const IngestOptions& options, const VolumeHeader& header);

/// Planes of halo each side of a slab: denoise radius + (speck + 1) + (hole + 1).
std::int64_t streamedHaloPlanes(const IngestOptions& options, std::int64_t nz);

/// Peak bytes of the streamed path with slabs of `slabPlanes` own planes on `threads`
/// threads (the volume threshold's sample slab holds per-thread buffers).
std::uint64_t estimateStreamedIngestBytes(const VolumeHeader& header, const IngestOptions& options,
                                          std::int64_t slabPlanes, int threads = 1);

/// Own planes per slab: `slabPlanes` (capped at nz) when > 0 (--slab-voxels), else the
/// most that fit in `budget` (0 when not even one plane fits).
std::int64_t streamedSlabPlanes(const VolumeHeader& header, const IngestOptions& options,
                                const MemoryBudget& budget, std::int64_t slabPlanes,
                                int threads = 1);

/// What a streamed ingest produced (the bed is on disk).
struct StreamedIngestResult {
  Lattice lattice;           ///< output lattice
  double thresholdUsed = 0;  ///< image units
  bool voidBright = false;   ///< polarity used
  ColumnFit column;          ///< the column used (found = false: no mask)
  nlohmann::json report;     ///< the provenance "ingest" object (with "streamed")
};

/// Streamed ingest of `header`'s input into the bed file `output` (written atomically:
/// nothing appears on error or cancel). `extraProvenance` keys are added to the root
/// provenance (e.g. command_line). Throws UsageError when streamedIngestUnsupported.
/// With `comm` of more than one rank, slab s is read, denoised and segmented by rank
/// s mod ranks, and rank 0 writes every slab in order (the same bed as one process);
/// only rank 0's result holds the report.
StreamedIngestResult ingestVolumeStreamed(const VolumeHeader& header, const IngestOptions& options,
                                          const std::filesystem::path& output,
                                          std::int64_t slabPlanes, int threads,
                                          Progress& progress = nullProgress(),
                                          const nlohmann::json& extraProvenance = {},
                                          const Communicator* comm = nullptr);

}  // namespace voxpack::ingest
