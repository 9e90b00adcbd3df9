#include "voxpack/core/progress.hpp"

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <iostream>
#include <string>

#include "voxpack/core/errors.hpp"

namespace voxpack {

StderrProgress::StderrProgress(bool quiet) : quiet_(quiet), tty_(isatty(STDERR_FILENO) != 0) {}

StderrProgress::~StderrProgress() {
  if (lineOpen_) std::fputc('\n', stderr);
}

void StderrProgress::report(std::string_view stage, double fraction) {
  if (quiet_ || !tty_) return;
  const auto now = std::chrono::steady_clock::now();
  const bool newStage = stage != lastStage_;
  if (!newStage && fraction < 1.0 && now - last_ < std::chrono::milliseconds(200)) return;
  last_ = now;
  lastStage_ = stage;
  const int pct = static_cast<int>(std::clamp(fraction, 0.0, 1.0) * 100.0 + 0.5);
  std::fprintf(stderr, "\r%-24.*s %3d%%", static_cast<int>(stage.size()), stage.data(), pct);
  std::fflush(stderr);
  lineOpen_ = true;
}

void StderrProgress::message(std::string_view text) {
  if (quiet_) return;
  if (lineOpen_) {
    std::fputc('\n', stderr);
    lineOpen_ = false;
  }
  std::fprintf(stderr, "%.*s\n", static_cast<int>(text.size()), text.data());
}

Progress& nullProgress() {
  static NullProgress p;
  return p;
}

SlabProgress::SlabProgress(Progress& progress, std::string stage, std::int64_t total,
                           std::string who)
    : p_(progress),
      stage_(std::move(stage)),
      who_(std::move(who)),
      total_(std::max<std::int64_t>(total, 1)),
      start_(std::chrono::steady_clock::now()) {}

void SlabProgress::step(std::int64_t done) {
  if (p_.cancelled()) throw Cancelled(who_ + ": " + stage_);
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  char buf[200];
  if (done > 0)
    std::snprintf(buf, sizeof buf, "%s: slab %lld/%lld, ETA %.0f s", stage_.c_str(),
                  static_cast<long long>(done), static_cast<long long>(total_),
                  s / static_cast<double>(done) * static_cast<double>(total_ - done));
  else
    std::snprintf(buf, sizeof buf, "%s: slab 0/%lld", stage_.c_str(),
                  static_cast<long long>(total_));
  p_.report(buf, static_cast<double>(done) / static_cast<double>(total_));
}

}  // namespace voxpack
