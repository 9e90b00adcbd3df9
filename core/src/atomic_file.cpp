#include "voxpack/core/atomic_file.hpp"

#include <unistd.h>

#include <atomic>
#include <fstream>

#include "voxpack/core/errors.hpp"

namespace voxpack {

namespace fs = std::filesystem;

void ensureWritableDirectory(const fs::path& dir, bool create) {
  const fs::path d = dir.empty() ? fs::path(".") : dir;
  std::error_code ec;
  if (!fs::exists(d, ec)) {
    if (!create) throw IoError(d.string() + ": output directory does not exist");
    fs::create_directories(d, ec);
    if (ec) throw IoError(d.string() + ": cannot create directory (" + ec.message() + ")");
  }
  if (!fs::is_directory(d, ec)) throw IoError(d.string() + ": not a directory");
  if (access(d.c_str(), W_OK) != 0) throw IoError(d.string() + ": directory is not writable");
}

AtomicOutput::AtomicOutput(fs::path target) : target_(std::move(target)) {
  if (target_.empty()) throw IoError("empty output path");
  std::error_code ec;
  if (fs::is_directory(target_, ec))
    throw IoError(target_.string() + ": is a directory, expected a file name");
  ensureWritableDirectory(target_.parent_path(), false);
  static std::atomic<unsigned> counter{0};
  // Same directory (so rename is atomic) and same extension (so format sniffers agree).
  // GCC 12 warns falsely (-Wrestrict) on chained operator+ here; append instead.
  std::string name = ".";
  name.append(target_.stem().string()).append(".tmp").append(std::to_string(getpid()));
  name.append("_").append(std::to_string(counter++)).append(target_.extension().string());
  temp_ = target_.parent_path() / name;
}

AtomicOutput::~AtomicOutput() {
  if (!committed_) {
    std::error_code ec;
    fs::remove(temp_, ec);
  }
}

void AtomicOutput::commit() {
  std::error_code ec;
  fs::rename(temp_, target_, ec);
  if (ec) throw IoError(target_.string() + ": cannot move output into place (" + ec.message() + ")");
  committed_ = true;
}

void writeTextFileAtomic(const fs::path& path, const std::string& text) {
  AtomicOutput out(path);
  {
    std::ofstream f(out.tempPath(), std::ios::binary);
    if (!f) throw IoError(path.string() + ": cannot open for writing");
    f << text;
    f.flush();
    if (!f) throw IoError(path.string() + ": write failed");
  }
  out.commit();
}

}  // namespace voxpack
