// Issue 14, "long runs survive interruption" for Monte Carlo, CLI: a run resumed from any of
// its checkpoints gives the bed of the uninterrupted run, byte for byte (every dataset and
// the particle table; only wall times differ in the provenance).
#include <gtest/gtest.h>

#include <csignal>
#include <cstring>

#include "cli_runner.hpp"
#include "hardening_support.hpp"
#include "voxpack/core/bed_file.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/packer/container.hpp"
#include "voxpack/packer/mc.hpp"
#include "voxpack/packer/shape.hpp"

using namespace voxpack;
using namespace voxpack::packer;
using namespace voxpack::test;

// The CLI end to end: kill -9 mid-run (no chance to clean up), resume, compare the bytes
// of every dataset with the uninterrupted run.
TEST(McResume, CliKillMidRunThenResumeEqualsUninterrupted) {
  TempDir tmp;
  const std::vector<std::string> args{"pack",
                                      "--mode",
                                      "mc",
                                      "--shape",
                                      "sphere:d=1.6",
                                      "--container",
                                      "cylinder:d=12,h=20",
                                      "--voxel-size",
                                      "0.15",
                                      "--count",
                                      "200",
                                      "--seed",
                                      "4"};
  auto a = args;
  a.insert(a.end(), {"-o", (tmp / "a.h5").string(), "--quiet"});
  const auto ra = runVoxpack(a);
  ASSERT_EQ(ra.exitCode, 0) << ra.err;

  const auto ckpt = tmp / "run.ckpt";
  auto b = args;
  b.insert(b.end(), {"-o", (tmp / "b_unused.h5").string(), "--checkpoint", ckpt.string(),
                     "--checkpoint-every", "0.05"});
  ASSERT_TRUE(killAfterFirstCheckpoint(b, ckpt))
      << "the run ended before it could be killed mid-way";
  EXPECT_FALSE(std::filesystem::exists(tmp / "b_unused.h5"));
  const auto rr =
      runVoxpack({"pack", "--resume", ckpt.string(), "-o", (tmp / "b.h5").string(), "--quiet"});
  ASSERT_EQ(rr.exitCode, 0) << rr.err;
  const Bed bedA = readBed(tmp / "a.h5"), bedB = readBed(tmp / "b.h5");
  expectSameBed(bedA, bedB);
  EXPECT_EQ(bedB.provenance.value("resumed_from", ""), ckpt.string());
}

TEST(McResume, ResumeRefusesSceneFlags) {
  TempDir tmp;
  const auto ckpt = tmp / "c.ckpt";
  std::ofstream(ckpt) << "{}";
  const auto r =
      runVoxpack({"pack", "--resume", ckpt.string(), "--seed", "3", "-o", (tmp / "x.h5").string()});
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.err.find("--seed cannot be given"), std::string::npos) << r.err;
  const auto r2 = runVoxpack({"pack", "--resume", ckpt.string(), "-o", (tmp / "x.h5").string()});
  EXPECT_EQ(r2.exitCode, 2);
  EXPECT_NE(r2.err.find("not a voxpack checkpoint"), std::string::npos) << r2.err;
}
