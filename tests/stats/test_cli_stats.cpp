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

}  // namespace
}  // namespace voxpack::test
