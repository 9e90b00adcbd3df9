#pragma once
/// \file atomic_file.hpp
/// Write-to-temporary-then-rename, so no partial output file is ever left behind.

#include <filesystem>
#include <string>

namespace voxpack {

/// Owns a temporary path beside the target; commit() renames it over the target, the
/// destructor removes it when commit() was not called (error or exception).
class AtomicOutput {
 public:
  /// Checks that the target's directory exists and is writable (IoError otherwise).
  explicit AtomicOutput(std::filesystem::path target);
  ~AtomicOutput();
  AtomicOutput(const AtomicOutput&) = delete;
  AtomicOutput& operator=(const AtomicOutput&) = delete;
  /// The temporary path to write to (same directory, same extension).
  const std::filesystem::path& tempPath() const { return temp_; }
  /// The final path.
  const std::filesystem::path& target() const { return target_; }
  /// Renames the temporary file to the target. Throws IoError.
  void commit();

 private:
  std::filesystem::path target_;
  std::filesystem::path temp_;
  bool committed_ = false;
};

/// Writes text to `path` atomically. Throws IoError.
void writeTextFileAtomic(const std::filesystem::path& path, const std::string& text);

/// Throws IoError unless `dir` exists (creating it when `create`) and is writable.
void ensureWritableDirectory(const std::filesystem::path& dir, bool create);

}  // namespace voxpack
