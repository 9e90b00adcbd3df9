// libFuzzer target: the TOML scene file of `voxpack pack` with the shape and container
// SPEC parsers behind it. `pack --check` parses, merges and validates the scene (and the
// [mc] table) and packs nothing; --memory-limit bounds what validation may digitise.
// The first input line, when it starts with '#!', is also fed to parseShape and
// parseContainer directly, so the SPEC grammars are fuzzed without TOML quoting.
#include <string>
#include <vector>

#include "cli.hpp"
#include "fuzz_common.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/packer/container.hpp"
#include "voxpack/packer/shape.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  voxpack::fuzz::quietOutput();
  const std::string text(reinterpret_cast<const char*>(data), size);
  if (text.rfind("#!", 0) == 0) {
    const std::string spec = text.substr(2, text.find('\n') - 2);
    // Mesh and mask specs name files: only the grammar is fuzzed here.
    if (spec.find("mesh") == std::string::npos && spec.find("mask") == std::string::npos) {
      try {
        (void)voxpack::packer::parseShape(spec);
      } catch (const voxpack::Error&) {
      }
      try {
        (void)voxpack::packer::parseContainer(spec);
      } catch (const voxpack::Error&) {
      }
    }
  }
  const auto path = voxpack::fuzz::writeScratch("scene.toml", data, size);
  try {
    (void)voxpack::app::runCommandLine({"voxpack", "--quiet", "--memory-limit", "256M", "pack",
                                        "--check", "--config", path.string()});
  } catch (const voxpack::Error&) {
  }
  return 0;
}
