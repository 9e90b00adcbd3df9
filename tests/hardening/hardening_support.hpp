#pragma once
// Helpers of the hardening suite: timed CLI runs and runs interrupted by a signal.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "cli_runner.hpp"
#include "voxpack/core/bed.hpp"

namespace voxpack::test {

/// A CLI run with its wall time.
struct TimedResult {
  CliResult cli;       ///< exit code and output
  double seconds = 0;  ///< wall time
};

/// runVoxpack with its wall time.
inline TimedResult runTimed(const std::vector<std::string>& args) {
  const auto t0 = std::chrono::steady_clock::now();
  TimedResult r{runVoxpack(args), 0};
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

/// Text of a file ("" when absent).
inline std::string fileText(const std::filesystem::path& p) {
  std::ifstream f(p);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

/// Starts `voxpack ARGS` in a child process (stdout to /dev/null, stderr to errFile) and
/// returns its pid without waiting.
inline pid_t spawnVoxpack(const std::vector<std::string>& args,
                          const std::filesystem::path& errFile = "/dev/null") {
  const pid_t pid = fork();
  if (pid == 0) {
    std::vector<std::string> all{VOXPACK_BINARY};
    all.insert(all.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (auto& a : all) argv.push_back(a.data());
    argv.push_back(nullptr);
    if (!freopen("/dev/null", "w", stdout) || !freopen(errFile.c_str(), "w", stderr)) _exit(127);
    execv(VOXPACK_BINARY, argv.data());
    _exit(127);
  }
  return pid;
}

/// Starts `voxpack ARGS` (a run that writes the checkpoint `ckpt`), SIGKILLs it as soon as
/// the checkpoint file appears (at most 60 s), and tells whether it died of that kill (false
/// when it finished first). kill -9 gives the run no chance to clean up.
inline bool killAfterFirstCheckpoint(const std::vector<std::string>& args,
                                     const std::filesystem::path& ckpt) {
  const pid_t pid = spawnVoxpack(args);
  int status = 0;
  for (int t = 0; t < 6000; ++t) {
    if (waitpid(pid, &status, WNOHANG) == pid) return false;
    if (std::filesystem::exists(ckpt)) {
      kill(pid, SIGKILL);
      waitpid(pid, &status, 0);
      return WIFSIGNALED(status);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  kill(pid, SIGKILL);
  waitpid(pid, &status, 0);
  return false;
}

/// What an interrupted run did.
struct SignalResult {
  int exitCode = -1;        ///< exit status (128 + signal when killed by it)
  bool exited = false;      ///< true when the process exited (did not die of the signal)
  bool wasRunning = false;  ///< the signal arrived while the command was working
  std::string err;          ///< stderr
};

/// Starts `voxpack ARGS`, waits until its stderr shows that the work has started (or 2 s),
/// sends `sig` while it still runs, and waits (at most
/// `timeoutS` seconds, then SIGKILL) for it to end.
inline SignalResult runAndSignal(const std::vector<std::string>& args, int sig,
                                 const std::filesystem::path& errFile, double timeoutS = 60) {
  SignalResult r;
  const pid_t pid = spawnVoxpack(args, errFile);
  const auto t0 = std::chrono::steady_clock::now();
  const auto elapsed = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  };
  int status = 0;
  bool done = false;
  while (elapsed() < timeoutS) {
    if (waitpid(pid, &status, WNOHANG) == pid) {
      done = true;
      break;
    }
    // Progress (stderr) shows that the work runs; without a terminal there may be none,
    // so 2 s after the start count as running too (the handlers are installed first).
    if (!fileText(errFile).empty() || elapsed() > 2.0) {
      r.wasRunning = true;
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  if (!done) {
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    kill(pid, sig);
    while (elapsed() < timeoutS && waitpid(pid, &status, WNOHANG) != pid)
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    if (elapsed() >= timeoutS) {
      kill(pid, SIGKILL);
      waitpid(pid, &status, 0);
    }
  }
  r.exited = WIFEXITED(status);
  r.exitCode = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  r.err = fileText(errFile);
  return r;
}

/// Bytes of two grids equal (same size, memcmp).
template <class T>
bool sameBytes(const Grid<T>& a, const Grid<T>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0;
}

/// Two particle tables equal: positions and orientations bit for bit, shapes (gtest checks).
inline void expectSameParticles(const ParticleTable& a, const ParticleTable& b) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t p = 0; p < a.size(); ++p) {
    EXPECT_EQ(std::memcmp(a.positionMm[p].data(), b.positionMm[p].data(), 3 * sizeof(double)), 0)
        << p;
    EXPECT_EQ(std::memcmp(a.orientation[p].coeffs().data(), b.orientation[p].coeffs().data(),
                          4 * sizeof(double)),
              0)
        << p;
    EXPECT_EQ(a.shape[p], b.shape[p]);
  }
}

/// Every dataset and the particle table of two beds equal byte for byte (gtest checks).
inline void expectSameBed(const Bed& a, const Bed& b) {
  ASSERT_EQ(a.lattice(), b.lattice());
  EXPECT_TRUE(sameBytes(a.indicator, b.indicator));
  ASSERT_TRUE(a.labels && b.labels && a.mask && b.mask);
  EXPECT_TRUE(sameBytes(*a.labels, *b.labels));
  EXPECT_TRUE(sameBytes(*a.mask, *b.mask));
  expectSameParticles(a.particles, b.particles);
}

}  // namespace voxpack::test
