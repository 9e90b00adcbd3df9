// `voxpack stats` end to end: outputs, --only, --csv, bad input -> exit 2, no partial file.
#include <gtest/gtest.h>

#include <fstream>

#include "cli_runner.hpp"
#include "stats_fixtures.hpp"
#include "voxpack/core/bed_file.hpp"
#include "voxpack/core/json_util.hpp"

namespace voxpack::test {
namespace {

std::filesystem::path writeSample(const TempDir& dir, bool emptyMask = false) {
  Bed bed = bedOf(booleanSpheres(20, 3, 0.7, 9));
  bed.mask = Grid<std::uint8_t>(bed.lattice(), emptyMask ? 0 : 1);
  const auto path = dir / "bed.h5";
  writeBed(path, bed);
  return path;
}

TEST(CliStats, WritesJsonAndCsv) {
  TempDir dir;
  const auto in = writeSample(dir);
  const auto r = runVoxpack({"stats", in.string(), "-o", (dir / "s.json").string(), "--csv",
                             (dir / "csv").string(), "--threads", "2", "--quiet"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const auto j = readJsonFile(dir / "s.json");
  for (const char* k : {"voxpack_version", "input", "options", "porosity", "axial", "radial", "s2"})
    EXPECT_TRUE(j.contains(k)) << k;
  EXPECT_TRUE(std::filesystem::exists(dir / "csv" / "axial.csv"));
  EXPECT_TRUE(std::filesystem::exists(dir / "csv" / "s2.csv"));
}

TEST(CliStats, OnlyAndEmptyMask) {
  TempDir dir;
  const auto in = writeSample(dir, true);
  const auto r = runVoxpack(
      {"stats", in.string(), "-o", (dir / "s.json").string(), "--only", "axial,s2", "--quiet"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  std::ifstream f(dir / "s.json");
  std::stringstream ss;
  ss << f.rdbuf();
  EXPECT_EQ(ss.str().find("NaN"), std::string::npos);
  const auto j = nlohmann::json::parse(ss.str());
  EXPECT_TRUE(j["porosity"].is_null());
  EXPECT_FALSE(j.contains("radial"));
}

TEST(CliStats, BadInputExitsTwoWithOneLine) {
  TempDir dir;
  const auto in = writeSample(dir);
  const auto out = dir / "s.json";
  for (const auto& args : std::vector<std::vector<std::string>>{
           {"stats", (dir / "missing.h5").string(), "-o", out.string()},
           {"stats", in.string(), "-o", out.string(), "--only", "bogus"},
           {"stats", in.string(), "-o", out.string(), "--mes-method", "magic"},
           {"stats", in.string(), "-o", (dir / "no" / "such" / "dir.json").string()},
           {"stats", in.string()}}) {
    const auto r = runVoxpack(args);
    EXPECT_EQ(r.exitCode, 2) << args.back() << ": " << r.err;
    EXPECT_EQ(countErrorLines(r.err), 1) << r.err;
    EXPECT_FALSE(std::filesystem::exists(out));
  }
}

// --bed-window: [lowest mask slice + 2 d, highest particle centre - 2 d], the window of the
// headline densities. Solid fills slices 10..29 of 40 (0.5 mm, origin 0); d = 1 mm and the
// top centre at 12 mm give the window z in [2, 10] mm = slices 4..20, of which 10..20 are
// solid: porosity 6/17. Without the window it is 20/40.
TEST(CliStats, BedWindowCropsToTheBedInterior) {
  TempDir dir;
  Lattice l;
  l.dims = {40, 6, 6};
  l.spacingMm = {0.5, 0.5, 0.5};
  Grid<std::uint8_t> g(l, 1);
  for (std::int64_t k = 10; k < 30; ++k)
    for (std::int64_t j = 0; j < 6; ++j)
      for (std::int64_t i = 0; i < 6; ++i) g(k, j, i) = 0;
  Bed bed = bedOf(std::move(g));
  bed.mask = Grid<std::uint8_t>(l, 1);
  bed.particles.positionMm = {Vec3(1, 1, 12), Vec3(2, 2, 5)};
  bed.particles.orientation = {Quat::Identity(), Quat::Identity()};
  bed.particles.shape = {"sphere:d=1", "sphere:d=1"};
  const auto in = dir / "bed.h5";
  writeBed(in, bed);
  const auto out = dir / "s.json";
  auto r = runVoxpack({"stats", in.string(), "-o", out.string(), "--only", "axial", "--bed-window",
                       "--particle-diameter-mm", "1", "--quiet"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  auto j = readJsonFile(out);
  EXPECT_NEAR(j["porosity"].get<double>(), 6.0 / 17.0, 1e-12) << j["porosity"];
  EXPECT_NEAR(j["roi_mm"]["z"][0].get<double>(), 2.0, 1e-12) << j["roi_mm"];
  EXPECT_NEAR(j["roi_mm"]["z"][1].get<double>(), 10.0, 1e-12) << j["roi_mm"];
  r = runVoxpack({"stats", in.string(), "-o", out.string(), "--only", "axial", "--quiet"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_NEAR(readJsonFile(out)["porosity"].get<double>(), 0.5, 1e-12);
  // The window needs d, and no second crop.
  for (const auto& extra : std::vector<std::vector<std::string>>{
           {"--bed-window"},
           {"--bed-window", "--particle-diameter-mm", "1", "--roi-mm", "0:5"},
           {"--bed-window", "--particle-diameter-mm", "5"}}) {
    std::vector<std::string> args{"stats", in.string(), "-o", (dir / "x.json").string()};
    args.insert(args.end(), extra.begin(), extra.end());
    r = runVoxpack(args);
    EXPECT_EQ(r.exitCode, 2) << extra.back() << r.err;
    EXPECT_EQ(countErrorLines(r.err), 1) << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir / "x.json"));
  }
}

}  // namespace
}  // namespace voxpack::test
