// writeImageUint8: a uint8 grid out through ITK. The float path of writeVolume (image_io.cpp)
// already writes every ITK format atomically with spacing and origin; uint8 values 0..255
// are exact in float and come back exact after its round-and-clamp, so this delegates.
#include "voxpack/ingest/image_writer.hpp"

#include "voxpack/core/errors.hpp"
#include "voxpack/ingest/image_io.hpp"

namespace voxpack::ingest {

void writeImageUint8(const Grid<std::uint8_t>& grid, const std::filesystem::path& path) {
  const std::string ext = path.extension().string();
  if (ext != ".nrrd" && ext != ".nhdr" && ext != ".mha" && ext != ".mhd")
    throw UsageError(path.string() + ": expected a .nrrd, .nhdr, .mha or .mhd file name");
  Grid<float> image(grid.lattice(), 0.0f);
  for (std::size_t n = 0; n < grid.size(); ++n) image[n] = static_cast<float>(grid[n]);
  writeVolume(path, image, PixelType::UInt8);
}

}  // namespace voxpack::ingest
