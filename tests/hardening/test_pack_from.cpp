// Issue 14, "pack --from BED.h5 continues from an existing bed: tap it more, or add
// particles", for both modes, through the CLI on tiny scenes: tapping a bed again sinks it,
// --count N adds exactly N particles (no overlap, no solid outside the mask), a bed that
// does not fit the scene is refused with exit 2 and one error line, and the thread count
// changes no byte.
#include <gtest/gtest.h>

#include <filesystem>
#include <set>

#include "cli_runner.hpp"
#include "hardening_support.hpp"
#include "voxpack/core/bed_file.hpp"

using namespace voxpack;
using namespace voxpack::test;

namespace {

// Spheres of 5 voxels per d in a 10 mm tube: 60 pour and settle in about a second.
std::vector<std::string> demScene(const std::string& maxTime = "3") {
  return {"pack",
          "--mode",
          "dem",
          "--shape",
          "sphere:d=2",
          "--container",
          "cylinder:d=10,h=14",
          "--voxel-size",
          "0.4",
          "--seed",
          "3",
          "--max-time",
          maxTime,
          "--quiet"};
}

// 20 cylinders in a small box for the Monte Carlo walk.
std::vector<std::string> mcScene() {
  return {"pack",        "--mode",           "mc",           "--shape", "cylinder:d=2,l=1.6",
          "--container", "box:x=8,y=8,z=12", "--voxel-size", "0.25",    "--seed",
          "5",           "--quiet"};
}

std::vector<std::string> with(std::vector<std::string> a, const std::vector<std::string>& more) {
  a.insert(a.end(), more.begin(), more.end());
  return a;
}

double meanCentreZ(const Bed& b) {
  double z = 0;
  for (const auto& p : b.particles.positionMm) z += p.z();
  return b.particles.empty() ? 0 : z / static_cast<double>(b.particles.size());
}

// Every solid voxel inside the mask, and labels 1..N each present (no particle lost).
void expectContainedAndLabelled(const Bed& b) {
  ASSERT_TRUE(b.mask && b.labels);
  std::size_t outside = 0;
  std::set<std::uint32_t> ids;
  for (std::size_t o = 0; o < b.indicator.size(); ++o) {
    if (b.indicator[o] == 0 && (*b.mask)[o] == 0) ++outside;
    if ((*b.labels)[o] != 0) ids.insert((*b.labels)[o]);
  }
  EXPECT_EQ(outside, 0u) << "solid outside the mask";
  EXPECT_EQ(ids.size(), b.particles.size());
  if (!ids.empty()) {
    EXPECT_EQ(*ids.rbegin(), b.particles.size());
  }
}

// Exit 2, one line on stderr starting "error: " and holding `what`, no output file.
void expectRefused(const CliResult& r, const std::string& what, const std::filesystem::path& out) {
  EXPECT_EQ(r.exitCode, 2) << r.err;
  EXPECT_EQ(r.err.rfind("error: ", 0), 0u) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_NE(r.err.find(what), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(out));
}

}  // namespace

TEST(PackFrom, DemTapViaFromSinksTheBedLikeTappingInOneRun) {
  TempDir tmp;
  const auto poured = tmp / "poured.h5", tapped = tmp / "tapped.h5", once = tmp / "once.h5";
  auto r = runVoxpack(with(demScene(), {"--count", "60", "-o", poured.string()}));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  r = runVoxpack(
      with(demScene(), {"--from", poured.string(), "--tap-cycles", "3", "-o", tapped.string()}));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  r = runVoxpack(with(demScene(), {"--count", "60", "--tap-cycles", "3", "-o", once.string()}));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const Bed a = readBed(poured), b = readBed(tapped), c = readBed(once);
  ASSERT_EQ(b.particles.size(), a.particles.size());
  EXPECT_EQ(b.provenance.value("status", ""), "settled");
  // Taps sink the bed: the mean centre falls, measured 0.032 d (docs/dem.md, "Continuing
  // a bed"); a --from that ignored --tap-cycles would leave it where it was.
  const double d = 2.0;
  EXPECT_LT(meanCentreZ(b), meanCentreZ(a) - 0.02 * d);
  // ...to where the same taps in the pouring run take it: measured 0.003 d apart.
  EXPECT_NEAR(meanCentreZ(b), meanCentreZ(c), 0.01 * d);
  expectContainedAndLabelled(b);
  ASSERT_TRUE(b.provenance.contains("from"));
  EXPECT_EQ(b.provenance["from"].value("file", ""), poured.string());
  EXPECT_EQ(b.provenance["from"].value("particles", 0), 60);
  EXPECT_EQ(b.provenance["from"].value("mode", ""), "dem");
  EXPECT_EQ(b.provenance["from"].value("provenance_fnv1a64", "").size(), 16u);
}

TEST(PackFrom, DemCountAddsExactlyNParticlesContainedAndSameBytesAtOneAndTwoThreads) {
  TempDir tmp;
  const auto poured = tmp / "poured.h5";
  auto r = runVoxpack(with(demScene(), {"--count", "16", "-o", poured.string()}));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const Bed a = readBed(poured);
  Bed more[2];
  for (const int threads : {1, 2}) {
    const auto out = tmp / ("more" + std::to_string(threads) + ".h5");
    auto args = with(demScene(), {"--from", poured.string(), "--count", "10", "-o", out.string()});
    args.insert(args.begin(), {"--threads", std::to_string(threads)});
    r = runVoxpack(args);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    more[threads - 1] = readBed(out);
  }
  const Bed& b = more[0];
  ASSERT_EQ(b.particles.size(), a.particles.size() + 10);
  EXPECT_EQ(b.provenance.value("status", ""), "settled");
  // The new ones are poured on top: the old bed's particles stay below the new mean.
  double oldTop = -1e300;
  for (const auto& p : a.particles.positionMm) oldTop = std::max(oldTop, p.z());
  double newMean = 0;
  for (std::size_t i = a.particles.size(); i < b.particles.size(); ++i)
    newMean += b.particles.positionMm[i].z() / 10.0;
  EXPECT_GT(newMean, oldTop - 1.0);
  // Soft contacts only: the deepest overlap stays a small fraction of d.
  EXPECT_LT(b.provenance["dem"].value("max_overlap_d", 1.0), 0.05);
  expectContainedAndLabelled(b);
  expectSameBed(more[0], more[1]);
}

TEST(PackFrom, McFromAddsExactlyNParticlesAndANoOpFromGivesTheBedBack) {
  TempDir tmp;
  const auto poured = tmp / "poured.h5", same = tmp / "same.h5", more = tmp / "more.h5",
             again = tmp / "again.h5", more2 = tmp / "more2.h5";
  auto r = runVoxpack(with(mcScene(), {"--count", "20", "-o", poured.string()}));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  // Nothing to add and no tap: the walk rebuilds the bed from its particle table exactly.
  r = runVoxpack(with(mcScene(), {"--from", poured.string(), "-o", same.string()}));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const Bed a = readBed(poured), s = readBed(same);
  expectSameBed(a, s);
  r = runVoxpack(with(mcScene(), {"--from", poured.string(), "--count", "8", "-o", more.string()}));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const Bed b = readBed(more);
  ASSERT_EQ(b.particles.size(), a.particles.size() + 8);
  expectContainedAndLabelled(b);
  // No overlap: the new bed is continued again without a voxel of difference (the walk
  // re-digitises every particle and refuses any overlap or voxel it cannot rebuild).
  r = runVoxpack(with(mcScene(), {"--from", more.string(), "-o", again.string()}));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  expectSameBed(b, readBed(again));
  // The walk is sequential: two threads give the same bytes.
  r = runVoxpack(with(mcScene(), {"--threads", "2", "--from", poured.string(), "--count", "8", "-o",
                                  more2.string()}));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  expectSameBed(b, readBed(more2));
}

TEST(PackFrom, McTapViaFromSinksTheBed) {
  TempDir tmp;
  const auto poured = tmp / "poured.h5", tapped = tmp / "tapped.h5";
  auto r = runVoxpack(with(mcScene(), {"--count", "20", "-o", poured.string()}));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  r = runVoxpack(
      with(mcScene(), {"--from", poured.string(), "--mc-tap-cycles", "3", "-o", tapped.string()}));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const Bed a = readBed(poured), b = readBed(tapped);
  ASSERT_EQ(b.particles.size(), a.particles.size());
  EXPECT_LT(meanCentreZ(b), meanCentreZ(a));
  expectContainedAndLabelled(b);
}

TEST(PackFrom, BedThatDoesNotFitTheSceneIsRefusedNamingTheMismatch) {
  TempDir tmp;
  const auto dem = tmp / "dem.h5", mc = tmp / "mc.h5", bare = tmp / "bare.h5", out = tmp / "o.h5";
  auto r = runVoxpack(with(demScene("0.05"), {"--count", "8", "-o", dem.string()}));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  r = runVoxpack(with(mcScene(), {"--count", "6", "-o", mc.string()}));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  // Only the mode, the seed and the mismatching flag: the rest of the scene comes from the
  // bed (its recorded scene, else its lattice and particle table).
  const auto from = [&](const std::string& mode, const std::filesystem::path& bed,
                        const std::vector<std::string>& more) {
    return runVoxpack(with({"pack", "--mode", mode, "--seed", "1", "--from", bed.string(), "-o",
                            out.string(), "--quiet"},
                           more));
  };
  expectRefused(from("dem", dem, {"--voxel-size", "0.5"}), "voxel size", out);
  expectRefused(from("dem", dem, {"--container", "cylinder:d=11,h=14"}), "container", out);
  expectRefused(from("dem", dem, {"--shape", "sphere:d=2.5"}), "not one of the scene's shapes",
                out);
  expectRefused(from("dem", dem, {"--supersample", "2"}), "supersample", out);
  expectRefused(from("dem", mc, {"--container", "cylinder:d=10,h=14"}), "container", out);
  // Without a recorded scene the lattice tells another container apart.
  {
    Bed anon = readBed(dem);
    anon.provenance = nlohmann::json::object();
    writeBed(tmp / "anon.h5", anon);
    expectRefused(from("dem", tmp / "anon.h5", {"--container", "cylinder:d=11,h=14"}),
                  "is not the lattice of container", out);
    expectRefused(from("dem", tmp / "anon.h5", {}), "--container is required", out);
  }
  // A particle table whose poses do not give the bed's voxels again cannot be continued by
  // the walk, which moves voxel sets: the top particle lifted by 0.6 voxel into free space
  // (its voxels differ), and one moved sideways into its neighbour (an overlap).
  {
    Bed moved = readBed(mc);
    std::size_t top = 0;
    for (std::size_t p = 0; p < moved.particles.size(); ++p)
      if (moved.particles.positionMm[p].z() > moved.particles.positionMm[top].z()) top = p;
    moved.particles.positionMm[top].z() += 0.15;
    writeBed(tmp / "lifted.h5", moved);
    expectRefused(from("mc", tmp / "lifted.h5", {}), "voxels differ from the bed's own", out);
    moved = readBed(mc);
    moved.particles.positionMm[0].x() += 0.15;
    writeBed(tmp / "moved.h5", moved);
    expectRefused(from("mc", tmp / "moved.h5", {}), "overlaps another particle", out);
  }
  // A bed without its particle table (an imaged bed) cannot be continued.
  Bed b = readBed(mc);
  b.particles = ParticleTable{};
  writeBed(bare, b);
  expectRefused(from("mc", bare, {}), "no particle table", out);
  expectRefused(from("dem", bare, {}), "no particle table", out);
}

TEST(PackFrom, CheckpointOfARunFromABedResumesWithoutTheBed) {
  TempDir tmp;
  for (const std::string mode : {"dem", "mc"}) {
    SCOPED_TRACE(mode);
    const auto scene = mode == "dem" ? demScene() : mcScene();
    const auto bed = tmp / (mode + "_bed.h5"), a = tmp / (mode + "_a.h5"),
               b = tmp / (mode + "_b.h5"), ckpt = tmp / (mode + ".ckpt");
    auto r = runVoxpack(with(scene, {"--count", "16", "-o", bed.string()}));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    // Checkpoints often (the MC walk takes ~0.05 s); the file ends with one of its late
    // states.
    r = runVoxpack(with(scene, {"--from", bed.string(), "--count", "10",
                                mode == "dem" ? "--tap-cycles" : "--mc-tap-cycles", "1", "-o",
                                a.string(), "--checkpoint", ckpt.string(), "--checkpoint-every",
                                mode == "dem" ? "0.05" : "0.001"}));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    ASSERT_TRUE(std::filesystem::exists(ckpt));
    // The state holds every particle: the start bed is not needed to resume.
    std::filesystem::remove(bed);
    r = runVoxpack(
        {"--threads", "2", "pack", "--resume", ckpt.string(), "-o", b.string(), "--quiet"});
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const Bed ba = readBed(a), bb = readBed(b);
    EXPECT_EQ(bb.particles.size(), 26u);
    expectSameBed(ba, bb);
    EXPECT_EQ(bb.provenance["from"].value("file", ""), bed.string());
  }
}
