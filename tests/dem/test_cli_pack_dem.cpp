// `voxpack pack --mode dem` through the built binary.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <set>

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
  EXPECT_EQ(dem.at("interpenetrations").get<int>(), 0);
  EXPECT_LT(dem.at("max_overlap_wall_fraction").get<double>(), 0.05);
  EXPECT_TRUE(bed.provenance.contains("status"));
  EXPECT_EQ(bed.provenance.at("seed").get<std::uint64_t>(), 1u);
}

TEST(CliPackDem, TomlTableAndFlagsWin) {
  TempDir tmp;
  {
    std::ofstream f(tmp / "scene.toml");
    f << "[dem]\nfriction = 0.7\nrestitution = 0.2\nsleeping = false\nrolling_friction = 0.05\n";
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
  EXPECT_DOUBLE_EQ(dem.at("rolling_friction").get<double>(), 0.05);
  // The contact nodes follow the lattice unless --contact-voxel says otherwise.
  EXPECT_DOUBLE_EQ(dem.at("contact_voxel_mm").get<double>(), 0.5);
}

// --contact-voxel: coarser contact nodes, the bed still digitised at --voxel-size.
TEST(CliPackDem, ContactVoxelCoarserThanTheLattice) {
  TempDir tmp;
  auto args = baseArgs(tmp);
  args[6] = "cylinder:d=3,l=2";
  for (const char* a : {"--contact-voxel", "0.75"}) args.push_back(a);
  const CliResult r = runVoxpack(args);
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const Bed bed = readBed(tmp / "bed.h5");
  EXPECT_DOUBLE_EQ(bed.provenance.at("dem").at("contact_voxel_mm").get<double>(), 0.75);
  EXPECT_DOUBLE_EQ(bed.lattice().spacingMm[0], 0.5);
  EXPECT_EQ(bed.particles.size(), 10u);
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

// Invalid [dem] values are refused before any work, naming the key as written.
TEST(CliPackDem, InvalidDemTomlValuesExitTwoNamingTheKey) {
  for (const auto& [key, value] :
       std::vector<std::pair<std::string, std::string>>{{"settle_velocity", "-1"},
                                                        {"settle_kinetic", "0"},
                                                        {"max_time_s", "-3"},
                                                        {"rain_volume_fraction", "1.5"},
                                                        {"time_step_fraction", "0.5"},
                                                        {"wall_restitution", "2"},
                                                        {"rolling_friction", "-0.1"},
                                                        {"contact_voxel_mm", "-0.2"}}) {
    TempDir tmp;
    {
      std::ofstream f(tmp / "scene.toml");
      f << "[dem]\n" << key << " = " << value << "\n";
    }
    auto args = baseArgs(tmp);
    args.push_back("--config");
    args.push_back((tmp / "scene.toml").string());
    const CliResult r = runVoxpack(args);
    EXPECT_EQ(r.exitCode, 2) << key << ": " << r.err;
    EXPECT_EQ(countErrorLines(r.err), 1) << r.err;
    EXPECT_NE(r.err.find(key), std::string::npos) << r.err;
    EXPECT_FALSE(std::filesystem::exists(tmp / "bed.h5"));
  }
  TempDir tmp;
  auto args = baseArgs(tmp);
  args.push_back("--settle-velocity");
  args.push_back("-1");
  const CliResult r = runVoxpack(args);
  EXPECT_EQ(r.exitCode, 2) << r.err;
  EXPECT_NE(r.err.find("--settle-velocity"), std::string::npos) << r.err;
}

// Size distributions through the CLI: --size-lognormal gives each sphere its own diameter
// (in range, stored in the table, recorded in the provenance); [dem.sizes] gives a sieve
// table; bad distributions and non-sphere shapes exit 2 with one error line.
TEST(CliPackDem, SizeDistributionsFromFlagsAndSceneTable) {
  {
    TempDir tmp;
    auto args = baseArgs(tmp);
    for (const char* a : {"--size-lognormal", "2.5,1.2,2,3.2"}) args.push_back(a);
    const CliResult r = runVoxpack(args);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const Bed bed = readBed(tmp / "bed.h5");
    ASSERT_EQ(bed.particles.size(), 10u);
    std::set<std::string> distinct(bed.particles.shape.begin(), bed.particles.shape.end());
    EXPECT_EQ(distinct.size(), 10u);
    for (const auto& spec : bed.particles.shape) {
      ASSERT_EQ(spec.rfind("sphere:d=", 0), 0u) << spec;
      const double d = std::stod(spec.substr(9));
      EXPECT_GE(d, 2.0);
      EXPECT_LE(d, 3.2);
    }
    const auto& sd = bed.provenance.at("dem").at("size_distribution");
    EXPECT_EQ(sd.at("kind").get<std::string>(), "lognormal");
    EXPECT_DOUBLE_EQ(sd.at("median_mm").get<double>(), 2.5);
  }
  {
    TempDir tmp;
    {
      std::ofstream f(tmp / "scene.toml");
      f << "[dem.sizes]\nsieve_edges_mm = [2.0, 2.5, 3.0]\nsieve_mass_fractions = [0.4, 0.6]\n";
    }
    auto args = baseArgs(tmp);
    args.push_back("--config");
    args.push_back((tmp / "scene.toml").string());
    const CliResult r = runVoxpack(args);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const Bed bed = readBed(tmp / "bed.h5");
    for (const auto& spec : bed.particles.shape) {
      const double d = std::stod(spec.substr(9));
      EXPECT_GE(d, 2.0);
      EXPECT_LT(d, 3.0);
    }
    EXPECT_EQ(bed.provenance.at("dem").at("size_distribution").at("kind").get<std::string>(),
              "sieve");
  }
  for (const auto& extra : std::vector<std::vector<std::string>>{
           {"--size-lognormal", "3,0.5,2,4"},
           {"--size-lognormal", "3,1.2,2"},
           {"--size-sieve", "2,3:0.5,0.5"},
           {"--size-sieve", "2,3,2.5:0.5,0.5"},
           {"--size-lognormal", "3,1.2,2,4", "--shape", "cylinder:d=3,l=2"}}) {
    TempDir tmp;
    auto args = baseArgs(tmp);
    if (extra.size() > 2) {
      const auto it = std::find(args.begin(), args.end(), "sphere:d=3");
      *it = extra[3];
    }
    args.push_back(extra[0]);
    args.push_back(extra[1]);
    const CliResult r = runVoxpack(args);
    EXPECT_EQ(r.exitCode, 2) << extra[0] << " " << extra[1] << ": " << r.err;
    EXPECT_EQ(countErrorLines(r.err), 1) << r.err;
    EXPECT_FALSE(std::filesystem::exists(tmp / "bed.h5"));
  }
}

// Soft contacts press particles into the wall; the bed still holds no solid outside its
// mask, and the clipped volume is reported.
TEST(CliPackDem, NoSolidOutsideTheMask) {
  TempDir tmp;
  auto args = baseArgs(tmp);
  for (std::size_t a = 0; a + 1 < args.size(); ++a)
    if (args[a] == "--voxel-size") args[a + 1] = "0.25";
  for (const char* a : {"--target-overlap", "0.1"}) args.push_back(a);
  const CliResult r = runVoxpack(args);
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const Bed bed = readBed(tmp / "bed.h5");
  ASSERT_TRUE(bed.mask.has_value());
  std::size_t outside = 0;
  for (std::size_t o = 0; o < bed.indicator.size(); ++o)
    if ((*bed.mask)[o] == 0 && (bed.indicator[o] == 0 || (*bed.labels)[o] != 0)) ++outside;
  EXPECT_EQ(outside, 0u);
  const auto& dem = bed.provenance.at("dem");
  EXPECT_GE(dem.at("clipped_outside_mask_mm3").get<double>(), 0.0);
  EXPECT_GE(dem.at("mean_overlap_d").get<double>(), 0.0);
  EXPECT_GE(dem.at("max_overlap_d").get<double>(), dem.at("mean_overlap_d").get<double>());
}

}  // namespace
}  // namespace voxpack::test
