#pragma once
/// \file image_writer.hpp
/// Writing a voxel grid as an image file through ITK (NRRD, MHA), for `voxpack export`.
/// ITK stays inside ingest/: callers see only core types.

#include <cstdint>
#include <filesystem>

#include "voxpack/core/grid.hpp"

namespace voxpack::ingest {

/// Writes `grid` to `path` (the format from the extension: .nrrd, .nhdr, .mha, .mhd) with
/// its spacing and origin, compressed; atomically (temporary name, then rename).
void writeImageUint8(const Grid<std::uint8_t>& grid, const std::filesystem::path& path);

}  // namespace voxpack::ingest
