// Issue 14, "long runs survive interruption": SIGINT or SIGTERM while pack, ingest, stats
// or compare works ends with exit 130 / 143, one message, and no output file (the outputs
// go through AtomicOutput; a temporary is removed on the way out).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <stdlib.h>
#include <sys/stat.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <fstream>

#include "cli_runner.hpp"
#include "hardening_support.hpp"
#include "voxpack/core/bed_file.hpp"
#include "voxpack/core/interrupt.hpp"
#include "voxpack/core/random.hpp"

using namespace voxpack;
using namespace voxpack::test;

namespace {

void expectInterrupted(const SignalResult& r, int sig, const std::filesystem::path& dir,
                       const std::vector<std::string>& before) {
  ASSERT_TRUE(r.wasRunning) << "the command ended before the signal: " << r.err;
  EXPECT_TRUE(r.exited) << "killed by the signal instead of handling it";
  EXPECT_EQ(r.exitCode, 128 + sig) << r.err;
  EXPECT_NE(r.err.find("error: interrupted (signal " + std::to_string(sig) + ")"),
            std::string::npos)
      << r.err;
  // Nothing new in the output folder: no output, no temporary left behind.
  auto now = listDir(dir);
  std::sort(now.begin(), now.end());
  EXPECT_EQ(now, before);
}

// What a run interrupted at a named stage did.
struct StageSignalResult {
  SignalResult run;
  double stopSeconds = -1;  ///< from the signal to the end of the process
};

// Starts `voxpack ARGS` with stderr on a pseudo-terminal (progress lines are printed only
// to a terminal), waits until the stages `marks` have appeared on it in that order (the
// command is then inside the last one), sends `sig`, and waits for the end (at most
// `timeoutS`, then SIGKILL). No blind sleep: the signal lands in a known stage however
// loaded the machine is.
StageSignalResult runToStageAndSignal(const std::vector<std::string>& args,
                                      const std::vector<std::string>& marks, int sig,
                                      double timeoutS = 60) {
  StageSignalResult r;
  const int master = posix_openpt(O_RDWR | O_NOCTTY);
  if (master < 0 || grantpt(master) != 0 || unlockpt(master) != 0) {
    ADD_FAILURE() << "no pseudo-terminal: " << std::strerror(errno);
    return r;
  }
  const std::string slave = ptsname(master);
  const pid_t pid = fork();
  if (pid == 0) {
    const int fd = open(slave.c_str(), O_RDWR | O_NOCTTY);
    if (fd < 0 || dup2(fd, STDERR_FILENO) < 0 || !freopen("/dev/null", "w", stdout)) _exit(127);
    close(master);
    std::vector<std::string> all{VOXPACK_BINARY};
    all.insert(all.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (auto& a : all) argv.push_back(a.data());
    argv.push_back(nullptr);
    execv(VOXPACK_BINARY, argv.data());
    _exit(127);
  }
  fcntl(master, F_SETFL, fcntl(master, F_GETFL) | O_NONBLOCK);
  std::string& text = r.run.err;
  const auto drain = [&] {
    char buf[4096];
    for (ssize_t n; (n = read(master, buf, sizeof buf)) > 0;) text.append(buf, std::size_t(n));
  };
  const auto t0 = std::chrono::steady_clock::now();
  const auto since = [](std::chrono::steady_clock::time_point t) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
  };
  const auto reached = [&] {
    std::size_t at = 0;
    for (const auto& m : marks) {
      at = text.find(m, at);
      if (at == std::string::npos) return false;
    }
    return true;
  };
  int status = 0;
  bool done = false;
  while (!done && since(t0) < timeoutS) {
    drain();
    if (reached()) {
      r.run.wasRunning = true;
      break;
    }
    done = waitpid(pid, &status, WNOHANG) == pid;
    if (!done) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  if (!done) {
    kill(pid, sig);
    const auto tSig = std::chrono::steady_clock::now();
    while (since(t0) < timeoutS && waitpid(pid, &status, WNOHANG) != pid) {
      drain();
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    if (since(t0) >= timeoutS) {
      kill(pid, SIGKILL);
      waitpid(pid, &status, 0);
    }
    r.stopSeconds = since(tSig);
  }
  drain();
  close(master);
  r.run.exited = WIFEXITED(status);
  r.run.exitCode = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  return r;
}

// Runs `voxpack ARGS` to the stages `marks` and signals it there; expects the clean stop:
// the command itself reached a poll and unwound (the message of runMain, not the grace
// alarm's "no clean stop"), before the alarm, leaving the empty folder `dir` empty.
void expectCleanStopAt(const std::vector<std::string>& args, const std::vector<std::string>& marks,
                       int sig, const std::filesystem::path& dir) {
  const StageSignalResult r = runToStageAndSignal(args, marks, sig);
  expectInterrupted(r.run, sig, dir, {});
  EXPECT_NE(
      r.run.err.find("error: interrupted (signal " + std::to_string(sig) + "): no output written"),
      std::string::npos)
      << r.run.err;
  EXPECT_LT(r.stopSeconds, kInterruptGraceSeconds) << r.run.err;
}

// Overlapping spheres (d = 20 voxels) at random on an n^3 lattice: 1 inside a sphere,
// 0 elsewhere, in (k, j, i) order.
std::vector<std::uint8_t> randomSpheres(std::int64_t n, std::uint64_t seed) {
  std::vector<std::uint8_t> in(static_cast<std::size_t>(n * n * n), 0);
  RandomStream rng(seed, 0);
  const double r = 10.0;
  const auto count = static_cast<int>(0.9 * static_cast<double>(n * n * n) / (4.19 * r * r * r));
  for (int s = 0; s < count; ++s) {
    const double x = rng.uniform(0, n), y = rng.uniform(0, n), z = rng.uniform(0, n);
    const auto lo = [&](double v) { return std::max<std::int64_t>(0, std::int64_t(v - r)); };
    const auto hi = [&](double v) { return std::min<std::int64_t>(n - 1, std::int64_t(v + r)); };
    for (std::int64_t k = lo(z); k <= hi(z); ++k)
      for (std::int64_t j = lo(y); j <= hi(y); ++j)
        for (std::int64_t i = lo(x); i <= hi(x); ++i)
          if ((k - z) * (k - z) + (j - y) * (j - y) + (i - x) * (i - x) < r * r)
            in[static_cast<std::size_t>((k * n + j) * n + i)] = 1;
  }
  return in;
}

// A bed of those spheres (solid) in a cylinder mask, 0.1 mm voxels, written to `path`: big
// enough that stats and compare take seconds.
void writeSphereBed(const std::filesystem::path& path, std::int64_t n, std::uint64_t seed) {
  Bed bed;
  const Lattice l = Lattice::isotropic(n, n, n, 0.1);
  bed.indicator = Grid<std::uint8_t>(l, 1);
  bed.mask = Grid<std::uint8_t>(l, 0);
  const std::vector<std::uint8_t> solid = randomSpheres(n, seed);
  const double c = 0.5 * static_cast<double>(n - 1), rc = 0.5 * static_cast<double>(n);
  for (std::int64_t k = 0; k < n; ++k)
    for (std::int64_t j = 0; j < n; ++j)
      for (std::int64_t i = 0; i < n; ++i) {
        (*bed.mask)(k, j, i) = (j - c) * (j - c) + (i - c) * (i - c) < rc * rc ? 1 : 0;
        bed.indicator(k, j, i) = solid[static_cast<std::size_t>((k * n + j) * n + i)] ? 0 : 1;
      }
  writeBed(path, bed);
}

// A grey XMT-like volume (uint8 NRRD, n^3 voxels of 0.1 mm) of those spheres, solid bright,
// void dark, with noise: ingest's median filter, threshold and column fit take a while.
void writeGreyNrrd(const std::filesystem::path& path, std::int64_t n, std::uint64_t seed) {
  std::vector<std::uint8_t> v = randomSpheres(n, seed);
  RandomStream rng(seed, 1);
  for (auto& x : v)
    x = static_cast<std::uint8_t>(std::clamp((x ? 200 : 60) + 15.0 * rng.normal(), 0.0, 255.0));
  std::ofstream f(path, std::ios::binary);
  f << "NRRD0004\ntype: uint8\ndimension: 3\nsizes: " << n << " " << n << " " << n
    << "\nspacings: 0.1 0.1 0.1\nencoding: raw\n\n";
  f.write(reinterpret_cast<const char*>(v.data()), static_cast<std::streamsize>(v.size()));
}

}  // namespace

TEST(Signals, SigintDuringMcPackExits130WithoutOutput) {
  TempDir tmp;
  const auto out = tmp / "out";
  std::filesystem::create_directories(out);
  const auto r = runAndSignal(
      {"pack", "--mode", "mc", "--shape", "sphere:d=1", "--container", "cylinder:d=12,h=30",
       "--voxel-size", "0.1", "--count", "3000", "--seed", "1", "-o", (out / "bed.h5").string()},
      SIGINT, tmp / "err.txt");
  expectInterrupted(r, SIGINT, out, {});
}

TEST(Signals, SigtermDuringMcPackExits143WithoutOutput) {
  TempDir tmp;
  const auto out = tmp / "out";
  std::filesystem::create_directories(out);
  const auto r = runAndSignal(
      {"pack", "--mode", "mc", "--shape", "sphere:d=1", "--container", "cylinder:d=12,h=30",
       "--voxel-size", "0.1", "--count", "3000", "--seed", "1", "-o", (out / "bed.h5").string()},
      SIGTERM, tmp / "err.txt");
  expectInterrupted(r, SIGTERM, out, {});
}

// A command stuck inside a library call reaches no poll: a mutated bed file made libhdf5
// loop inside H5Aread, and `timeout 20 voxpack info` ran for 15 CPU minutes because the one
// SIGTERM only set the flag. The grace alarm now ends it with 143 within seconds. The stuck
// state here is ITK's NRRD reader blocked in open() of a FIFO that has no writer (the bed
// file stops hanging once the reader checks the global heap before H5Aread).
TEST(Signals, SigtermEndsACommandStuckInsideALibraryCallWithinTheGracePeriod) {
  TempDir tmp;
  const auto out = tmp / "out";
  std::filesystem::create_directories(out);
  const auto fifo = tmp / "never_written.nrrd";
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0) << std::strerror(errno);
  const auto t0 = std::chrono::steady_clock::now();
  const auto r = runAndSignal({"ingest", fifo.string(), "-o", (out / "bed.h5").string()}, SIGTERM,
                              tmp / "err.txt", 60);
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_TRUE(r.wasRunning) << "ingest ended before the signal: " << r.err;
  EXPECT_TRUE(r.exited) << "killed instead of exiting";
  EXPECT_EQ(r.exitCode, 143) << r.err;
  EXPECT_NE(r.err.find("error: interrupted (signal 15): no clean stop"), std::string::npos)
      << r.err;
  EXPECT_LT(s, 2.5 + kInterruptGraceSeconds + 5) << "took " << s << " s";
  EXPECT_TRUE(listDir(out).empty());
}

// stats polled the interrupt only inside the mean empty space: a SIGTERM during the pore
// sizes (or any statistic after it) let the command run on and write its JSON and CSV files
// (exit 0), or end by the grace alarm when the rest took longer than 10 s.
TEST(Signals, SigtermDuringStatsAfterTheMeanEmptySpaceStopsCleanly) {
  TempDir tmp;
  const auto out = tmp / "out";
  std::filesystem::create_directories(out);
  writeSphereBed(tmp / "bed.h5", 128, 1);
  expectCleanStopAt({"--threads", "2", "stats", (tmp / "bed.h5").string(), "-o",
                     (out / "stats.json").string(), "--csv", (out / "csv").string()},
                    {"mean empty space", "pore sizes"}, SIGTERM, out);
}

// ingest did not poll the interrupt at all on its in-memory path: a SIGINT during the
// threshold let it segment, write the bed and exit 0 (or, with a slow watershed after it,
// end by the grace alarm).
TEST(Signals, SigintDuringInMemoryIngestStopsCleanly) {
  TempDir tmp;
  const auto out = tmp / "out";
  std::filesystem::create_directories(out);
  writeGreyNrrd(tmp / "grey.nrrd", 128, 2);
  expectCleanStopAt(
      {"--threads", "2", "ingest", (tmp / "grey.nrrd").string(), "-o", (out / "bed.h5").string()},
      {"threshold"}, SIGINT, out);
}

// compare polled only inside the mean empty space of each bed: a SIGTERM while it wrote the
// report (here: while the figure script runs, 2 s) let it finish the report into the
// output folder and exit 0. Now the folder it created is gone again.
TEST(Signals, SigtermWhileCompareWritesItsReportLeavesNoReport) {
  TempDir tmp;
  const auto out = tmp / "out";
  std::filesystem::create_directories(out);
  writeSphereBed(tmp / "ref.h5", 64, 3);
  writeSphereBed(tmp / "cand.h5", 64, 4);
  // A figure script that only takes time: the signal lands inside the report stage.
  std::ofstream(tmp / "slow_figures.sh") << "sleep 2\n";
  expectCleanStopAt(
      {"--threads", "2", "compare", "--reference", (tmp / "ref.h5").string(),
       (tmp / "cand.h5").string(), "--particle-diameter", "2", "--python", "/bin/sh",
       "--figure-script", (tmp / "slow_figures.sh").string(), "-o", (out / "report").string()},
      {"compare: report"}, SIGTERM, out);
}
