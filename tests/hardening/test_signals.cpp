// Issue 14, "long runs survive interruption": SIGINT or SIGTERM while pack works ends
// with exit 130 / 143, one message, and no output file (the outputs go through
// AtomicOutput; a temporary is removed on the way out). ingest, stats and compare are
// checked the same way by hand (docs/reliability.md); their tests belong to their modules.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
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

// A mutated bed file (found by fuzz_bed_reader) makes libhdf5 loop inside H5Aread, where
// no poll is reached: `timeout 20 voxpack info` used to run for 15 CPU minutes because the
// one SIGTERM only set the flag. The grace alarm now ends it with 143 within seconds.
TEST(Signals, SigtermEndsACommandStuckInsideLibhdf5WithinTheGracePeriod) {
  TempDir tmp;
  const std::string hang = std::string(VOXPACK_SOURCE_DIR) +
                           "/fuzz/findings/bed_reader/"
                           "timeout-acb82eb23d8e2d1c4893677c6f52b0052be1f38a";
  ASSERT_TRUE(std::filesystem::exists(hang));
  const auto t0 = std::chrono::steady_clock::now();
  const auto r = runAndSignal({"info", hang}, SIGTERM, tmp / "err.txt", 60);
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_TRUE(r.wasRunning) << "info ended before the signal: " << r.err;
  EXPECT_TRUE(r.exited) << "killed instead of exiting";
  EXPECT_EQ(r.exitCode, 143) << r.err;
  EXPECT_NE(r.err.find("error: interrupted (signal 15)"), std::string::npos) << r.err;
  EXPECT_LT(s, 2.5 + kInterruptGraceSeconds + 5) << "took " << s << " s";
}
