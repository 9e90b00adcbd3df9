// pack --target-volume-error: picks the coarsest voxel meeting the target and records it.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "cli_runner.hpp"

using namespace voxpack::test;

namespace {
std::vector<std::string> scene(const std::string& out) {
  return {"pack",
          "--mode",
          "mc",
          "--shape",
          "cylinder:d=5.4,l=3.8",
          "--container",
          "cylinder:d=20,h=20",
          "--count",
          "3",
          "--seed",
          "1",
          "-o",
          out,
          "--quiet"};
}
}  // namespace

TEST(CliVoxelChoice, PicksCoarsestVoxelMeetingTarget) {
  TempDir tmp;
  double previous = 1e9;
  for (const char* target : {"0.02", "0.005"}) {
    auto args = scene((tmp / "b.h5").string());
    args.insert(args.end(), {"--target-volume-error", target});
    const CliResult r = runVoxpack(args);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.err.find("chose --voxel-size"), std::string::npos) << r.err;
    const CliResult info = runVoxpack({"info", (tmp / "b.h5").string(), "--json"});
    const auto j = nlohmann::json::parse(info.out);
    const auto& choice = j["provenance"]["scene"]["voxel_choice"];
    ASSERT_TRUE(choice["met"].get<bool>());
    const auto& ladder = choice["ladder"];
    const double t = std::stod(target);
    // The chosen (last) rung meets the target, every coarser rung missed it.
    EXPECT_LE(ladder.back()["mean_abs_volume_error"].get<double>(), t);
    for (std::size_t n = 0; n + 1 < ladder.size(); ++n)
      EXPECT_GT(ladder[n]["mean_abs_volume_error"].get<double>(), t);
    const double voxel = j["spacing_mm"][0].get<double>();
    EXPECT_DOUBLE_EQ(voxel, ladder.back()["voxel_size_mm"].get<double>());
    // A tighter target never gives a coarser voxel.
    EXPECT_LE(voxel, previous);
    previous = voxel;
  }
}

TEST(CliVoxelChoice, RefusesBadTargetsAndBothFlags) {
  TempDir tmp;
  for (const std::vector<std::string>& extra :
       {std::vector<std::string>{"--target-volume-error", "0"},
        std::vector<std::string>{"--target-volume-error", "1.5"},
        std::vector<std::string>{"--target-volume-error", "0.01", "--voxel-size", "0.3"}}) {
    auto args = scene((tmp / "b.h5").string());
    args.insert(args.end(), extra.begin(), extra.end());
    const CliResult r = runVoxpack(args);
    EXPECT_EQ(r.exitCode, 2) << r.err;
    EXPECT_EQ(countErrorLines(r.err), 1) << r.err;
    EXPECT_FALSE(std::filesystem::exists(tmp / "b.h5"));
  }
}
