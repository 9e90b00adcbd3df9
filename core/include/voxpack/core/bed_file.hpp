#pragma once
/// \file bed_file.hpp
/// Reading and writing the bed file (HDF5), exactly as docs/FORMATS.md's table says:
/// whole beds (readBed/writeBed), the header alone (readBedHeader: no volume is read), and
/// z-slabs or boxes of the volumes (BedSlabReader/BedSlabWriter) for work that streams.

#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "voxpack/core/bed.hpp"
#include "voxpack/core/memory.hpp"

namespace voxpack {

/// Options for writeBed.
struct BedWriteOptions {
  int compressionLevel = 4;  ///< deflate level 0..9 (4: near-max ratio on binary fields, fast)
  bool shuffle = true;       ///< byte shuffle before deflate (helps uint32 labels)
};

/// Largest voxel count a bed file may declare (2^44, about 17.6 T voxels: 26000³). Files
/// declaring more are refused before anything is allocated (a hostile or corrupt header).
inline constexpr std::uint64_t kMaxBedVoxels = std::uint64_t{1} << 44;

/// Largest particle table (rows) a bed file may declare (2^32).
inline constexpr std::uint64_t kMaxBedParticles = std::uint64_t{1} << 32;

/// What a bed file holds, read from its attributes and dataset shapes only (no volume).
struct BedHeader {
  Lattice lattice;                    ///< dims (from /indicator), spacing, origin
  bool hasMask = false;               ///< /mask present
  bool hasLabels = false;             ///< /labels present
  std::uint64_t particles = 0;        ///< rows of /particles/position_mm (0 = none)
  bool hasOrientation = false;        ///< /particles/orientation present
  bool hasShape = false;              ///< /particles/shape present
  std::vector<std::string> datasets;  ///< names of the datasets present
  nlohmann::json provenance = nlohmann::json::object();  ///< root attribute provenance
};

/// Reads and checks the header of a bed file: attributes, dataset types and shapes, the
/// voxel count (<= kMaxBedVoxels) and the particle rows (<= kMaxBedParticles). Throws
/// IoError or FormatError naming the file. Reads no volume.
BedHeader readBedHeader(const std::filesystem::path& path);

/// Bytes readBed allocates for the bed of `header` (volumes and particle table).
std::uint64_t bedMemoryBytes(const BedHeader& header);

/// Bytes of the particle table of `header` once read.
std::uint64_t particleTableBytes(const BedHeader& header);

/// Writes `bed` to `path` atomically (temporary name, then rename). Throws IoError.
void writeBed(const std::filesystem::path& path, const Bed& bed,
              const BedWriteOptions& options = {});

/// Reads and validates a bed file. Throws IoError (cannot open / not HDF5), FormatError
/// (breaks the format table, with a message naming the file and the problem), or
/// ResourceError when bedMemoryBytes() exceeds `budget` (checked before allocating).
Bed readBed(const std::filesystem::path& path, const MemoryBudget& budget);

/// readBed with the default budget (75 % of the memory available now).
Bed readBed(const std::filesystem::path& path);

/// The particle table of a bed file alone (checked against `budget` first).
ParticleTable readBedParticles(const std::filesystem::path& path, const MemoryBudget& budget);

/// Names of the datasets present in a bed file (e.g. "/indicator", "/mask").
std::vector<std::string> bedDatasets(const std::filesystem::path& path);

/// A voxel box of a lattice: first voxel (k, j, i) and extent (nz, ny, nx).
struct VoxelBox {
  std::array<std::int64_t, 3> first{0, 0, 0};  ///< first voxel (k, j, i)
  std::array<std::int64_t, 3> dims{0, 0, 0};   ///< voxels (nz, ny, nx)
};

/// The lattice of `box` inside `lattice`: same spacing, origin at the box's first voxel.
Lattice subLattice(const Lattice& lattice, const VoxelBox& box);

/// Reads boxes (z-slabs) of a bed file's volumes by HDF5 hyperslab; the file stays open.
/// With `parallel` (MPI builds, inside an MPI run) the file is opened through the MPI-IO
/// driver; every rank must then construct and destroy the reader together.
class BedSlabReader {
 public:
  /// Opens `path` and reads its header. Throws as readBedHeader.
  explicit BedSlabReader(const std::filesystem::path& path, bool parallel = false);
  ~BedSlabReader();
  BedSlabReader(const BedSlabReader&) = delete;
  BedSlabReader& operator=(const BedSlabReader&) = delete;
  /// The file's header.
  const BedHeader& header() const;
  /// The indicator inside `box` (values checked to be 0/1). Throws IoError/FormatError.
  Grid<std::uint8_t> indicator(const VoxelBox& box) const;
  /// The mask inside `box`, or nothing when the file has no /mask.
  std::optional<Grid<std::uint8_t>> mask(const VoxelBox& box) const;
  /// The labels inside `box`, or nothing when the file has no /labels.
  std::optional<Grid<std::uint32_t>> labels(const VoxelBox& box) const;
  /// Whole-plane slab [z0, z1) of the indicator.
  Grid<std::uint8_t> indicatorSlab(std::int64_t z0, std::int64_t z1) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Writes a bed file z-slab by z-slab (bounded memory); the file appears only at finish().
class BedSlabWriter {
 public:
  /// Creates the datasets of a bed on `lattice` (with /mask and /labels when asked).
  BedSlabWriter(const std::filesystem::path& path, const Lattice& lattice, bool withMask,
                bool withLabels, const BedWriteOptions& options = {});
  ~BedSlabWriter();
  BedSlabWriter(const BedSlabWriter&) = delete;
  BedSlabWriter& operator=(const BedSlabWriter&) = delete;
  /// Writes planes [z0, z0 + slab.nz) of the indicator (slab spans whole planes).
  void writeIndicator(std::int64_t z0, const Grid<std::uint8_t>& slab);
  /// Writes planes of the mask.
  void writeMask(std::int64_t z0, const Grid<std::uint8_t>& slab);
  /// Writes planes of the labels.
  void writeLabels(std::int64_t z0, const Grid<std::uint32_t>& slab);
  /// Writes the particle table and provenance, closes and renames the file into place.
  void finish(const ParticleTable& particles, const nlohmann::json& provenance);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace voxpack
