// `voxpack pack --mode dem` through the built binary.
#include <gtest/gtest.h>

#include <fstream>

#include "cli_runner.hpp"
#include "voxpack/core/bed_file.hpp"

namespace voxpack::test {
namespace {

std::vector<std::string> baseArgs(const TempDir& tmp) {
  return {"--threads",
          "2",
          "pack",
          "--mode",
          "dem",
          "--shape",
          "sphere:d=3",
          "--container",
          "cylinder:d=12,h=20",
          "--voxel-size",
          "0.5",
          "--count",
          "10",
          "--seed",
          "1",
          "--max-time",
          "0.2",
          "-o",
          (tmp / "bed.h5").string()};
}

TEST(CliPackDem, WritesALabelledBedWithProvenance) {
  TempDir tmp;
  auto args = baseArgs(tmp);
  for (const char* a : {"--friction", "0.3", "--restitution", "0.6", "--contact", "levelset"})
    args.push_back(a);
  const CliResult r = runVoxpack(args);
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_NE(r.out.find("status"), std::string::npos);
  const Bed bed = readBed(tmp / "bed.h5");
  EXPECT_EQ(bed.particles.size(), 10u);
  ASSERT_TRUE(bed.labels.has_value());
  ASSERT_TRUE(bed.mask.has_value());
  std::uint32_t maxLabel = 0;
  for (auto v : bed.labels->values()) maxLabel = std::max(maxLabel, v);
  EXPECT_EQ(maxLabel, 10u);
  const auto& dem = bed.provenance.at("dem");
  EXPECT_DOUBLE_EQ(dem.at("friction").get<double>(), 0.3);
  EXPECT_DOUBLE_EQ(dem.at("restitution").get<double>(), 0.6);
  EXPECT_EQ(dem.at("contact").get<std::string>(), "levelset");
  EXPECT_GT(dem.at("time_step_s").get<double>(), 0);
  EXPECT_TRUE(bed.provenance.contains("status"));
  EXPECT_EQ(bed.provenance.at("seed").get<std::uint64_t>(), 1u);
}

TEST(CliPackDem, TomlTableAndFlagsWin) {
  TempDir tmp;
  {
    std::ofstream f(tmp / "scene.toml");
    f << "[dem]\nfriction = 0.7\nrestitution = 0.2\nsleeping = false\n";
  }
  auto args = baseArgs(tmp);
  for (const std::string& a :
       std::vector<std::string>{"--config", (tmp / "scene.toml").string(), "--friction", "0.1"})
    args.push_back(a);
  const CliResult r = runVoxpack(args);
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const auto dem = readBed(tmp / "bed.h5").provenance.at("dem");
  EXPECT_DOUBLE_EQ(dem.at("friction").get<double>(), 0.1);
  EXPECT_DOUBLE_EQ(dem.at("restitution").get<double>(), 0.2);
  EXPECT_FALSE(dem.at("sleeping").get<bool>());
}

TEST(CliPackDem, BadValuesExitTwoWithOneErrorLine) {
  for (const auto& [flag, value] :
       std::vector<std::pair<std::string, std::string>>{{"--restitution", "1.5"},
                                                        {"--friction", "-1"},
                                                        {"--contact", "nearest"},
                                                        {"--tap-cycles", "-2"},
                                                        {"--sleeping", "maybe"}}) {
    TempDir tmp;
    auto args = baseArgs(tmp);
    args.push_back(flag);
    args.push_back(value);
    const CliResult r = runVoxpack(args);
    EXPECT_EQ(r.exitCode, 2) << flag << " " << value << ": " << r.err;
    EXPECT_EQ(countErrorLines(r.err), 1) << r.err;
    EXPECT_FALSE(std::filesystem::exists(tmp / "bed.h5"));
  }
}

}  // namespace
}  // namespace voxpack::test
