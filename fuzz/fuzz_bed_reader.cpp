// libFuzzer target: the bed-file reader (HDF5 header checks, then the volumes and the
// particle table) under a 256 MiB budget. Typed voxpack errors are refusals, not findings.
#include "fuzz_common.hpp"
#include "voxpack/core/bed_file.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/core/memory.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = voxpack::fuzz::writeScratch("bed.h5", data, size);
  try {
    const voxpack::MemoryBudget budget{std::uint64_t{256} << 20};
    const voxpack::Bed bed = voxpack::readBed(path, budget);
    (void)voxpack::summarize(bed);
  } catch (const voxpack::Error&) {
  }
  return 0;
}
