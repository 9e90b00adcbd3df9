#pragma once
/// \file progress.hpp
/// Progress and cancellation hook for long work, passed into algorithms as a parameter.

#include <chrono>
#include <cstdint>
#include <string>
#include <string_view>

namespace voxpack {

/// Receives progress reports; may ask the work to stop.
class Progress {
 public:
  virtual ~Progress() = default;
  /// Reports `fraction` in [0, 1] of `stage` done. Must be cheap; called from one thread.
  virtual void report(std::string_view stage, double fraction) = 0;
  /// True when the work should stop (it then throws Cancelled or returns a status).
  virtual bool cancelled() const { return false; }
  /// Prints a one-line message (warnings, chosen settings) unless quiet.
  virtual void message(std::string_view text) = 0;
};

/// Progress that ignores everything (tests, library callers that do not care).
class NullProgress final : public Progress {
 public:
  void report(std::string_view, double) override {}
  void message(std::string_view) override {}
};

/// Progress on stderr: a bar when stderr is a terminal, nothing when quiet;
/// messages go to stderr unless quiet. Throttled to ~5 updates per second.
class StderrProgress final : public Progress {
 public:
  explicit StderrProgress(bool quiet);
  ~StderrProgress() override;
  void report(std::string_view stage, double fraction) override;
  void message(std::string_view text) override;

 private:
  bool quiet_;
  bool tty_;
  bool lineOpen_ = false;
  std::string lastStage_;
  std::chrono::steady_clock::time_point last_{};
};

/// Reports slab work as "STAGE: slab 3/10, ETA 12 s" to a Progress (the ETA from the mean
/// time per slab so far), and throws Cancelled("WHO: STAGE") when the work should stop.
class SlabProgress {
 public:
  /// For `total` slabs of `stage`; `who` names the command in the Cancelled message.
  SlabProgress(Progress& progress, std::string stage, std::int64_t total, std::string who);
  /// `done` slabs are finished: reports, and checks for cancellation.
  void step(std::int64_t done);

 private:
  Progress& p_;
  std::string stage_, who_;
  std::int64_t total_;
  std::chrono::steady_clock::time_point start_;
};

/// A NullProgress usable as a default argument.
Progress& nullProgress();

}  // namespace voxpack
