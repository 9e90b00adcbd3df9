#pragma once
// Shared helpers of the libFuzzer targets: the input goes to a scratch file (the readers
// under test take paths), and voxpack's typed errors count as correct refusals; anything
// else escaping (std::out_of_range, bad_alloc, a crash, a sanitizer report) is a finding.
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

namespace voxpack::fuzz {

/// A per-process scratch folder under /tmp (removed by scripts/fuzz.sh at the end).
inline const std::filesystem::path& scratchDir() {
  static const std::filesystem::path dir = [] {
    auto d = std::filesystem::temp_directory_path() / ("voxpack_fuzz_" + std::to_string(getpid()));
    std::filesystem::create_directories(d);
    return d;
  }();
  return dir;
}

/// Writes `size` bytes to scratchDir()/name and returns the path.
inline std::filesystem::path writeScratch(const std::string& name, const std::uint8_t* data,
                                          std::size_t size) {
  const auto p = scratchDir() / name;
  std::ofstream f(p, std::ios::binary | std::ios::trunc);
  f.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  return p;
}

/// Silences stdout/stderr of the code under test (progress bars, tables) once.
inline void quietOutput() {
  static const bool done = [] {
    std::freopen("/dev/null", "w", stdout);
    return true;
  }();
  (void)done;
}

}  // namespace voxpack::fuzz
