#pragma once
/// \file bed_file.hpp
/// Reading and writing the bed file (HDF5), exactly as SPEC.md's table says.

#include <filesystem>

#include "voxpack/core/bed.hpp"

namespace voxpack {

/// Options for writeBed.
struct BedWriteOptions {
  int compressionLevel = 4;  ///< deflate level 0..9 (4: near-max ratio on binary fields, fast)
  bool shuffle = true;       ///< byte shuffle before deflate (helps uint32 labels)
};

/// Writes `bed` to `path` atomically (temporary name, then rename). Throws IoError.
void writeBed(const std::filesystem::path& path, const Bed& bed,
              const BedWriteOptions& options = {});

/// Reads and validates a bed file. Throws IoError (cannot open / not HDF5) or
/// FormatError (breaks the SPEC table), with a message naming the file and the problem.
Bed readBed(const std::filesystem::path& path);

/// Names of the datasets present in a bed file (e.g. "/indicator", "/mask").
std::vector<std::string> bedDatasets(const std::filesystem::path& path);

}  // namespace voxpack
