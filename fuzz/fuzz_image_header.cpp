// libFuzzer target: the ingest header path. The first byte picks the format, the rest is
// the file: 0 attached NRRD (.nrrd), 1 MetaImage (.mha), 2 detached NRRD header (.nhdr)
// and 3 MetaImage header (.mhd), both beside a 4 KiB raw data file `data.raw`.
#include <array>
#include <vector>

#include "fuzz_common.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/ingest/image_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  static const bool raw = [] {
    std::vector<std::uint8_t> bytes(4096);
    for (std::size_t n = 0; n < bytes.size(); ++n) bytes[n] = static_cast<std::uint8_t>(n * 7);
    voxpack::fuzz::writeScratch("data.raw", bytes.data(), bytes.size());
    return true;
  }();
  (void)raw;
  static const std::array<const char*, 4> names{"img.nrrd", "img.mha", "img.nhdr", "img.mhd"};
  const auto path = voxpack::fuzz::writeScratch(names[data[0] % 4], data + 1, size - 1);
  try {
    voxpack::ingest::ReadOptions o;
    (void)voxpack::ingest::readVolume(path, o);
  } catch (const voxpack::Error&) {
  }
  return 0;
}
