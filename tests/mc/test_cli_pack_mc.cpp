// `voxpack pack --mode mc` through the built binary: thread-count invariance, seeds, the
// scene file, and every refused input (exit 2, one error line, no output file).
#include <gtest/gtest.h>

#include <fstream>

#include "cli_runner.hpp"
#include "voxpack/core/bed_file.hpp"

using namespace voxpack;
using namespace voxpack::test;

namespace {

std::vector<std::string> scene(const std::string& out, const std::string& seed) {
  return {"pack",
          "--mode",
          "mc",
          "--shape",
          "sphere:d=3",
          "--container",
          "cylinder:d=10,h=12",
          "--voxel-size",
          "0.5",
          "--count",
          "12",
          "--seed",
          seed,
          "-o",
          out};
}

std::vector<std::string> with(std::vector<std::string> v, const std::vector<std::string>& more) {
  v.insert(v.end(), more.begin(), more.end());
  return v;
}

std::vector<std::string> threads(const std::string& n, const std::vector<std::string>& v) {
  std::vector<std::string> r{"--threads", n, "--quiet"};
  r.insert(r.end(), v.begin(), v.end());
  return r;
}

void expectRefused(const std::vector<std::string>& args, const std::string& needle) {
  TempDir dir;
  std::vector<std::string> a = args;
  for (auto& s : a)
    if (s == "OUT") s = (dir / "bed.h5").string();
  const CliResult r = runVoxpack(a);
  EXPECT_EQ(r.exitCode, 2) << r.err;
  EXPECT_EQ(countErrorLines(r.err), 1) << r.err;
  EXPECT_NE(r.err.find(needle), std::string::npos) << r.err;
  EXPECT_TRUE(listDir(dir.path()).empty()) << "a file was left behind";
}

}  // namespace

TEST(CliPackMc, ThreadCountDoesNotChangeTheBed) {
  TempDir dir;
  const auto a = (dir / "a.h5").string(), b = (dir / "b.h5").string(), c = (dir / "c.h5").string();
  ASSERT_EQ(runVoxpack(threads("1", scene(a, "11"))).exitCode, 0);
  ASSERT_EQ(runVoxpack(threads("2", scene(b, "11"))).exitCode, 0);
  ASSERT_EQ(runVoxpack(threads("2", scene(c, "12"))).exitCode, 0);
  const Bed ba = readBed(a), bb = readBed(b), bc = readBed(c);
  EXPECT_EQ(ba.indicator.values(), bb.indicator.values());
  EXPECT_EQ(ba.labels->values(), bb.labels->values());
  EXPECT_NE(ba.indicator.values(), bc.indicator.values());
}

TEST(CliPackMc, WritesTableMaskAndProvenance) {
  TempDir dir;
  const auto out = (dir / "bed.h5").string();
  const CliResult r = runVoxpack(with(scene(out, "3"), {"--rebound-probability", "0.2"}));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_NE(r.out.find("status settled"), std::string::npos) << r.out;
  const Bed bed = readBed(out);
  EXPECT_EQ(bed.particles.size(), 12u);
  ASSERT_TRUE(bed.mask && bed.labels);
  const auto& p = bed.provenance;
  EXPECT_EQ(p.at("seed").get<std::uint64_t>(), 3u);
  EXPECT_EQ(p.at("mode"), "mc");
  EXPECT_EQ(p.at("status"), "settled");
  EXPECT_DOUBLE_EQ(p.at("mc").at("options").at("rebound_probability").get<double>(), 0.2);
  EXPECT_GE(p.at("wall_time_s").get<double>(), 0.0);
  EXPECT_TRUE(p.at("scene").contains("container"));
}

TEST(CliPackMc, SceneFileWithFlagsWinning) {
  TempDir dir;
  const auto cfg = dir / "scene.toml";
  std::ofstream(cfg) << "mode = \"mc\"\nshape = \"sphere:d=3\"\n"
                        "container = \"cylinder:d=10,h=12\"\nvoxel_size_mm = 0.5\ncount = 8\n"
                        "seed = 4\n[mc]\nrebound_probability = 0.3\nmax_sweeps = 3000\n"
                        "[dem]\nfriction = 0.5\n";
  const auto out = (dir / "bed.h5").string();
  const CliResult r = runVoxpack({"--quiet", "pack", "--config", cfg.string(), "--count", "6",
                                  "--rebound-probability", "0.05", "-o", out});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const Bed bed = readBed(out);
  EXPECT_EQ(bed.particles.size(), 6u);
  const auto& o = bed.provenance.at("mc").at("options");
  EXPECT_DOUBLE_EQ(o.at("rebound_probability").get<double>(), 0.05);
  EXPECT_EQ(o.at("max_sweeps").get<std::int64_t>(), 3000);
  EXPECT_EQ(bed.provenance.at("seed").get<std::uint64_t>(), 4u);
}

TEST(CliPackMc, RefusesContainerSmallerThanOneParticle) {
  expectRefused(
      {"pack", "--mode", "mc", "--shape", "sphere:d=3", "--container", "cylinder:d=2,h=10",
       "--voxel-size", "0.5", "--count", "5", "--seed", "1", "-o", "OUT"},
      "smaller than one particle");
}

TEST(CliPackMc, RefusesCountZero) {
  expectRefused(with(scene("OUT", "1"), {"--count", "0"}), "--count");
}

TEST(CliPackMc, RefusesReboundProbabilityOutsideUnitInterval) {
  expectRefused(with(scene("OUT", "1"), {"--rebound-probability", "-0.1"}),
                "--rebound-probability");
  expectRefused(with(scene("OUT", "1"), {"--rebound-probability", "1.5"}), "--rebound-probability");
}

TEST(CliPackMc, RefusesVoxelLargerThanParticle) {
  expectRefused(
      {"pack", "--mode", "mc", "--shape", "sphere:d=3", "--container", "cylinder:d=40,h=40",
       "--voxel-size", "4", "--count", "5", "--seed", "1", "-o", "OUT"},
      "--voxel-size");
}

TEST(CliPackMc, RefusesUsageMistakes) {
  expectRefused(
      {"pack", "--mode", "xyz", "--shape", "sphere:d=3", "--container", "cylinder:d=10,h=12",
       "--voxel-size", "0.5", "--count", "5", "--seed", "1", "-o", "OUT"},
      "--mode");
  expectRefused(with(scene("OUT", "1"), {"--fill-height", "5"}), "--fill-height");
  expectRefused(with(scene("OUT", "1"), {"--mc-max-rotation-deg", "0"}), "rotation");
  expectRefused(with(scene("OUT", "1"), {"--shape", "sphere:d=3@-1"}), "fraction");
}

TEST(CliPackMc, RefusesBadSceneFile) {
  TempDir dir;
  const auto cfg = dir / "scene.toml";
  std::ofstream(cfg) << "mode = \"mc\"\nshape = \"sphere:d=3\"\nvoxel_sise_mm = 0.5\n";
  expectRefused({"pack", "--config", cfg.string(), "-o", "OUT"}, "voxel_sise_mm");
  const auto cfg2 = dir / "broken.toml";
  std::ofstream(cfg2) << "mode = \"mc\"\n[mc]\nrebound_probability = \n";
  expectRefused({"pack", "--config", cfg2.string(), "-o", "OUT"}, "broken.toml");
}
