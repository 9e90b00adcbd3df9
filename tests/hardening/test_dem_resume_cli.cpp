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
  ASSERT_TRUE(killAfterFirstCheckpoint(b, ckpt))
      << "the run ended before it could be killed mid-way";
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
