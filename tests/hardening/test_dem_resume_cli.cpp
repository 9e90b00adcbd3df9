// Issue 14, "long runs survive interruption" for DEM, CLI: kill -9 mid-pour (after a
// checkpoint appeared), resume with another thread count, compare the bytes of every
// dataset and the particle table with the uninterrupted run.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <thread>

#include "cli_runner.hpp"
#include "hardening_support.hpp"
#include "voxpack/core/bed_file.hpp"

using namespace voxpack;
using namespace voxpack::test;

namespace {

const std::vector<std::string> kScene{"pack",
                                      "--mode",
                                      "dem",
                                      "--shape",
                                      "sphere:d=2",
                                      "--container",
                                      "cylinder:d=10,h=14",
                                      "--voxel-size",
                                      "0.4",
                                      "--count",
                                      "60",
                                      "--seed",
                                      "3",
                                      "--max-time",
                                      "1.5"};

}  // namespace

TEST(DemResume, CliKillMidPourThenResumeEqualsUninterrupted) {
  TempDir tmp;
  auto a = kScene;
  a.insert(a.end(), {"-o", (tmp / "a.h5").string(), "--quiet"});
  const auto ra = runVoxpack(a);
  ASSERT_EQ(ra.exitCode, 0) << ra.err;

  const auto ckpt = tmp / "run.ckpt";
  auto b = kScene;
  b.insert(b.end(), {"-o", (tmp / "b_unused.h5").string(), "--checkpoint", ckpt.string(),
                     "--checkpoint-every", "0.05"});
  const pid_t pid = fork();
  if (pid == 0) {
    std::vector<std::string> all{VOXPACK_BINARY};
    all.insert(all.end(), b.begin(), b.end());
    std::vector<char*> argv;
    for (auto& s : all) argv.push_back(s.data());
    argv.push_back(nullptr);
    if (!freopen("/dev/null", "w", stdout) || !freopen("/dev/null", "w", stderr)) _exit(127);
    execv(VOXPACK_BINARY, argv.data());
    _exit(127);
  }
  bool killed = false;
  int status = 0;
  for (int t = 0; t < 6000; ++t) {
    if (waitpid(pid, &status, WNOHANG) == pid) break;
    if (std::filesystem::exists(ckpt)) {
      kill(pid, SIGKILL);
      waitpid(pid, &status, 0);
      killed = WIFSIGNALED(status);
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_TRUE(killed) << "the run ended before it could be killed mid-way";
  EXPECT_FALSE(std::filesystem::exists(tmp / "b_unused.h5"));
  const auto rr = runVoxpack({"--threads", "2", "pack", "--resume", ckpt.string(), "-o",
                              (tmp / "b.h5").string(), "--quiet"});
  ASSERT_EQ(rr.exitCode, 0) << rr.err;
  const Bed bedA = readBed(tmp / "a.h5"), bedB = readBed(tmp / "b.h5");
  expectSameBed(bedA, bedB);
  EXPECT_EQ(bedB.provenance.value("resumed_from", ""), ckpt.string());

  // The same checkpoint with its scene edited (another seed) is another run: exit 2, one
  // error line.
  nlohmann::json doc = nlohmann::json::parse(fileText(ckpt));
  doc["scene"]["seed"] = 4;
  std::ofstream(tmp / "edited.ckpt") << doc.dump();
  const auto re = runVoxpack(
      {"pack", "--resume", (tmp / "edited.ckpt").string(), "-o", (tmp / "c.h5").string()});
  EXPECT_EQ(re.exitCode, 2) << re.err;
  EXPECT_NE(re.err.find("error: "), std::string::npos) << re.err;
  EXPECT_NE(re.err.find("another DEM run"), std::string::npos) << re.err;
  EXPECT_FALSE(std::filesystem::exists(tmp / "c.h5"));
}
