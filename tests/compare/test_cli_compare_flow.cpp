// `voxpack compare --flow` through the binary: each bed's permeability, tortuosity and
// wall-flow share against the reference, flow.csv, the flow table and figure.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <sstream>

#include "cli_runner.hpp"
#include "sphere_bed.hpp"
#include "voxpack/core/json_util.hpp"

using namespace voxpack;
using namespace voxpack::test;
using nlohmann::json;

namespace {

// Coarse beds (1 mm voxels, 3 mm spheres, 16 mm column and height): a second per solve.
std::filesystem::path writeBedFile(const TempDir& dir, const std::string& name, std::uint64_t seed,
                                   int attempts) {
  SphereBedOptions o;
  o.voxelMm = 1.0;
  o.seed = seed;
  o.attempts = attempts;
  const auto p = dir / name;
  writeBed(p, sphereBed(o));
  return p;
}

std::string slurp(const std::filesystem::path& p) {
  std::ifstream f(p);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

}  // namespace

TEST(CliCompareFlow, PermeabilityTortuosityAndWallShareAgainstTheReference) {
  TempDir tmp;
  const auto ref = writeBedFile(tmp, "ref.h5", 1, 400);
  const auto other = writeBedFile(tmp, "other.h5", 2, 400);
  const auto empty = writeBedFile(tmp, "empty.h5", 1, 0);  // an empty column
  const auto out = tmp / "report";
  const CliResult r =
      runVoxpack({"--quiet", "compare", "--reference", ref.string(), ref.string(), other.string(),
                  empty.string(), "-o", out.string(), "--flow", "--flow-tolerance", "1e-5",
                  "--bed-fraction", "0", "--python", VOXPACK_PYTHON});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const json s = readJsonFile(out / "summary.json");
  ASSERT_TRUE(s.contains("flow")) << s.dump();
  const json& f = s["flow"];
  EXPECT_EQ(f["reference"]["status"], "converged");
  const double kRef = f["reference"]["permeability_mm2"].get<double>();
  EXPECT_GT(kRef, 0.0);
  EXPECT_GT(f["reference"]["tortuosity_hydraulic"].get<double>(), 1.0);
  ASSERT_EQ(f["candidates"].size(), 3u);
  for (const json& b : f["candidates"])
    std::printf("%s: k %.5g mm2, %lld steps, %.2f s\n", b["name"].get<std::string>().c_str(),
                b["permeability_mm2"].get<double>(), b["steps"].get<long long>(),
                b["wall_s"].get<double>());
  // The reference against itself: the solver is deterministic, so exactly 1 and 0.
  const json& self = f["candidates"][0];
  EXPECT_EQ(self["permeability_ratio"].get<double>(), 1.0);
  EXPECT_EQ(self["tortuosity_diff"].get<double>(), 0.0);
  EXPECT_EQ(self["wall_flow_share_diff"].get<double>(), 0.0);
  // Another random bed of the same spheres: same order of permeability.
  const json& o = f["candidates"][1];
  EXPECT_EQ(o["status"], "converged");
  EXPECT_GT(o["permeability_ratio"].get<double>(), 0.5);
  EXPECT_LT(o["permeability_ratio"].get<double>(), 2.0);
  // The empty column: far more permeable (Poiseuille in the whole tube: k = R^2/8 =
  // 8 mm^2 against ~0.1 mm^2 for the bed), straight streamlines (tortuosity 1).
  const json& e = f["candidates"][2];
  EXPECT_GT(e["permeability_ratio"].get<double>(), 10.0);
  EXPECT_NEAR(e["tortuosity_hydraulic"].get<double>(), 1.0, 1e-3);
  EXPECT_LT(e["tortuosity_diff"].get<double>(), 0.0);
  // The reference ratio row agrees with the two permeabilities.
  EXPECT_NEAR(o["permeability_ratio"].get<double>(), o["permeability_mm2"].get<double>() / kRef,
              1e-12);
  // Wall share within 1 d of the wall: a fraction; the empty tube's is its Poiseuille
  // share of the flow within 3 mm of an 8 mm radius wall: 1 - (1 - (5/8)^2)... computed
  // from the parabola: 1 - [2 (5/8)^2 - (5/8)^4] = 0.371; the staircase and coarse bins
  // of 1 mm move it by a few per cent.
  EXPECT_NEAR(e["wall_flow_share"].get<double>(), 0.371, 0.05);
  // The profile data and the report.
  const std::string csv = slurp(out / "flow.csv");
  EXPECT_EQ(csv.rfind("bed,wall_distance_mm,axial_velocity_over_superficial\n", 0), 0u);
  for (const json& bed : f["candidates"])  // every bed has profile rows
    EXPECT_NE(csv.find("\n" + bed["name"].get<std::string>() + ","), std::string::npos)
        << bed["name"];
  EXPECT_NE(csv.find("\n" + f["reference"]["name"].get<std::string>() + ","), std::string::npos);
  const std::string html = slurp(out / "index.html");
  EXPECT_NE(html.find("id=\"flow\""), std::string::npos);
  if (std::filesystem::exists(out / "fig_radial.png")) {  // matplotlib present
    EXPECT_TRUE(std::filesystem::exists(out / "fig_flow.png"));
    EXPECT_NE(html.find("id=\"fig_flow\""), std::string::npos);
  }
  EXPECT_NE(r.out.find("k/k_ref"), std::string::npos) << r.out;
}

TEST(CliCompareFlow, WithoutFlowNoFlowBlockAndBadOptionsAreRefused) {
  TempDir tmp;
  const auto ref = writeBedFile(tmp, "ref.h5", 1, 400);
  const auto out = tmp / "report";
  CliResult r = runVoxpack({"--quiet", "compare", "--reference", ref.string(), ref.string(), "-o",
                            out.string(), "--no-figures"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_FALSE(readJsonFile(out / "summary.json").contains("flow"));
  EXPECT_FALSE(std::filesystem::exists(out / "flow.csv"));
  for (const std::vector<std::string>& bad :
       {std::vector<std::string>{"--flow-tolerance", "0"}, {"--flow-max-steps", "0"}}) {
    std::vector<std::string> args = {"--quiet",     "compare", "--reference",          ref.string(),
                                     ref.string(),  "-o",      (tmp / "bad").string(), "--flow",
                                     "--no-figures"};
    args.insert(args.end(), bad.begin(), bad.end());
    r = runVoxpack(args);
    EXPECT_EQ(r.exitCode, 2) << bad[0] << " " << r.err;
  }
  // The flow options need --flow; the walls are one of two.
  for (const std::vector<std::string>& bad :
       {std::vector<std::string>{"--flow-walls", "interpolated"}, {"--flow-max-steps", "10"}}) {
    std::vector<std::string> args = {
        "--quiet",    "compare", "--reference",           ref.string(),
        ref.string(), "-o",      (tmp / "bad2").string(), "--no-figures"};
    args.insert(args.end(), bad.begin(), bad.end());
    r = runVoxpack(args);
    EXPECT_EQ(r.exitCode, 2) << bad[0] << " " << r.err;
    EXPECT_NE(r.err.find("needs --flow"), std::string::npos) << r.err;
  }
  r = runVoxpack({"--quiet", "compare", "--reference", ref.string(), ref.string(), "-o",
                  (tmp / "bad3").string(), "--no-figures", "--flow", "--flow-walls", "exact"});
  EXPECT_EQ(r.exitCode, 2) << r.err;
  // A cap too small to converge: the numbers come out with a warning in the summary.
  r = runVoxpack({"--quiet", "compare", "--reference", ref.string(), ref.string(), "-o",
                  (tmp / "capped").string(), "--no-figures", "--flow", "--flow-max-steps", "20"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const json s = readJsonFile(tmp / "capped" / "summary.json");
  EXPECT_EQ(s["flow"]["reference"]["status"], "not_converged");
  bool warned = false;
  for (const auto& w : s["warnings"])
    warned = warned || w.get<std::string>().find("not_converged") != std::string::npos;
  EXPECT_TRUE(warned) << s["warnings"].dump();
}

// --flow-walls interpolated reaches each bed's solver: the record says which walls ran, and
// the exact sphere and column surfaces give a different permeability from the staircase.
TEST(CliCompareFlow, InterpolatedWallsReachTheSolver) {
  TempDir tmp;
  const auto ref = writeBedFile(tmp, "ref.h5", 1, 400);
  json k;
  for (const std::string walls : {"halfway", "interpolated"}) {
    const auto out = tmp / walls;
    const CliResult r = runVoxpack({"--quiet", "compare", "--reference", ref.string(), ref.string(),
                                    "-o", out.string(), "--no-figures", "--flow",
                                    "--flow-tolerance", "1e-4", "--flow-walls", walls});
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const json s = readJsonFile(out / "summary.json");
    EXPECT_EQ(s["options"]["flow_walls"], walls);
    EXPECT_EQ(s["flow"]["reference"]["walls"], walls);
    EXPECT_EQ(s["flow"]["reference"]["status"], "converged");
    k[walls] = s["flow"]["reference"]["permeability_mm2"];
  }
  const double ratio = k["interpolated"].get<double>() / k["halfway"].get<double>();
  EXPECT_GT(std::abs(ratio - 1.0), 1e-3) << k.dump();
  EXPECT_LT(std::abs(ratio - 1.0), 0.5) << k.dump();
}
