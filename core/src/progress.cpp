#include "voxpack/core/progress.hpp"

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <iostream>

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

}  // namespace voxpack
