// `voxpack compare` driven through the built binary: self-comparison, beds of different
// voxel sizes, bad input, no python, and the HTML report in headless Chromium.
#include <gtest/gtest.h>

#include <fstream>
#include <regex>
#include <sstream>

#include "cli_runner.hpp"
#include "sphere_bed.hpp"
#include "voxpack/core/json_util.hpp"

using namespace voxpack;
using namespace voxpack::test;
using nlohmann::json;

namespace {

std::filesystem::path writeSphereBed(const TempDir& dir, const std::string& name, double voxelMm,
                                     std::uint64_t seed, double heightMm = 16.0) {
  SphereBedOptions o;
  o.heightMm = heightMm;
  o.voxelMm = voxelMm;
  o.seed = seed;
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

TEST(CliCompare, SelfComparisonGivesZeroDistancesAndPValueOne) {
  TempDir tmp;
  const auto bed = writeSphereBed(tmp, "bed.h5", 0.5, 1);
  const auto out = tmp / "report";
  const CliResult r = runVoxpack({"--quiet", "compare", "--reference", bed.string(), bed.string(),
                                  "-o", out.string(), "--no-figures"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const json s = readJsonFile(out / "summary.json");
  ASSERT_EQ(s["candidates"].size(), 1u);
  const json& c = s["candidates"][0];
  EXPECT_NE(c["name"], s["reference"]);  // names stay unique
  EXPECT_EQ(c["density_rel_diff"].get<double>(), 0.0);
  EXPECT_EQ(c["axial_ks_p"].get<double>(), 1.0);
  EXPECT_EQ(c["radial_rmse"].get<double>(), 0.0);
  EXPECT_EQ(c["s2_rmse"].get<double>(), 0.0);
  EXPECT_EQ(c["mes_ks"].get<double>(), 0.0);
  EXPECT_NE(r.out.find("report:"), std::string::npos);
  EXPECT_TRUE(std::filesystem::exists(out / "index.html"));
}

TEST(CliCompare, BedsOfDifferentVoxelSizesCompare) {
  // The same sphere arrangement digitised at 0.5 mm and 0.4 mm: everything is compared in
  // mm, so the distances stay at digitisation-error size.
  TempDir tmp;
  const auto coarse = writeSphereBed(tmp, "coarse.h5", 0.4, 7, 24.0);
  const auto fine = writeSphereBed(tmp, "fine.h5", 0.3, 7, 24.0);
  const auto other = writeSphereBed(tmp, "other.h5", 0.3, 8, 24.0);
  const auto out = tmp / "report";
  const CliResult r =
      runVoxpack({"--quiet", "compare", "--reference", coarse.string(), fine.string(),
                  other.string(), "-o", out.string(), "--no-figures"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const json s = readJsonFile(out / "summary.json");
  ASSERT_EQ(s["candidates"].size(), 2u);
  for (const auto& c : s["candidates"])
    for (const char* key : {"density_mean", "density_std", "density_rel_diff", "axial_ks_p",
                            "radial_rmse", "s2_rmse", "mes_ks"})
      EXPECT_TRUE(c[key].is_number()) << c["name"] << " " << key;
  const json& same = s["candidates"][0];
  // Digitising a 3 mm sphere at 0.4 vs 0.3 mm changes its volume by a few per cent.
  EXPECT_LT(std::abs(same["density_rel_diff"].get<double>()), 0.05);
  EXPECT_LT(same["s2_rmse"].get<double>(), 0.02);
  // A different arrangement is farther than the same one at another voxel size.
  const json& diff = s["candidates"][1];
  EXPECT_GT(diff["s2_rmse"].get<double>(), same["s2_rmse"].get<double>());
  EXPECT_GT(diff["radial_rmse"].get<double>(), same["radial_rmse"].get<double>());
}

TEST(CliCompare, MissingReferenceIsExit2) {
  TempDir tmp;
  const auto bed = writeSphereBed(tmp, "bed.h5", 0.5, 1);
  const auto out = tmp / "report";
  const CliResult r = runVoxpack(
      {"compare", "--reference", (tmp / "nope.h5").string(), bed.string(), "-o", out.string()});
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_EQ(countErrorLines(r.err), 1) << r.err;
  EXPECT_NE(r.err.find("nope.h5"), std::string::npos);
  EXPECT_FALSE(std::filesystem::exists(out));
}

TEST(CliCompare, MissingCandidateIsExit2) {
  TempDir tmp;
  const auto bed = writeSphereBed(tmp, "bed.h5", 0.5, 1);
  const CliResult r = runVoxpack({"compare", "--reference", bed.string(),
                                  (tmp / "gone.h5").string(), "-o", (tmp / "r").string()});
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_EQ(countErrorLines(r.err), 1) << r.err;
  EXPECT_NE(r.err.find("gone.h5"), std::string::npos);
}

TEST(CliCompare, NoCandidatesIsExit2) {
  TempDir tmp;
  const auto bed = writeSphereBed(tmp, "bed.h5", 0.5, 1);
  const CliResult r =
      runVoxpack({"compare", "--reference", bed.string(), "-o", (tmp / "r").string()});
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_EQ(countErrorLines(r.err), 1) << r.err;
}

TEST(CliCompare, NotABedFileIsExit2) {
  TempDir tmp;
  const auto bed = writeSphereBed(tmp, "bed.h5", 0.5, 1);
  const auto junk = tmp / "junk.h5";
  std::ofstream(junk) << "not hdf5";
  const CliResult r = runVoxpack(
      {"compare", "--reference", bed.string(), junk.string(), "-o", (tmp / "r").string()});
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_EQ(countErrorLines(r.err), 1) << r.err;
}

TEST(CliCompare, UnwritableOutputDirIsExit2) {
  TempDir tmp;
  const auto bed = writeSphereBed(tmp, "bed.h5", 0.5, 1);
  const auto file = tmp / "a_file";
  std::ofstream(file) << "x";
  // A folder cannot be created below a regular file, whoever runs the test (even root).
  const CliResult r = runVoxpack(
      {"compare", "--reference", bed.string(), bed.string(), "-o", (file / "report").string()});
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_EQ(countErrorLines(r.err), 1) << r.err;
}

TEST(CliCompare, WithoutPythonNumbersStillComeOutWithAWarning) {
  TempDir tmp;
  const auto a = writeSphereBed(tmp, "a.h5", 0.5, 1);
  const auto b = writeSphereBed(tmp, "b.h5", 0.5, 2);
  const auto out = tmp / "report";
  const CliResult r = runVoxpack({"compare", "--reference", a.string(), b.string(), "-o",
                                  out.string(), "--python", "/nonexistent/python3"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_NE(r.err.find("warning:"), std::string::npos) << r.err;
  for (const char* f :
       {"summary.json", "table.csv", "axial.csv", "radial.csv", "s2.csv", "mes.csv", "index.html"})
    EXPECT_TRUE(std::filesystem::exists(out / f)) << f;
  EXPECT_FALSE(std::filesystem::exists(out / "fig_s2.png"));
  const json s = readJsonFile(out / "summary.json");
  EXPECT_TRUE(s["candidates"][0]["s2_rmse"].is_number());
}

TEST(CliCompare, ReportLoadsInHeadlessChromiumWithEveryFigure) {
  const std::filesystem::path chromium = "/usr/bin/chromium";
  if (!std::filesystem::exists(chromium))
    GTEST_SKIP() << "chromium is not installed at " << chromium;
  if (runShell(std::string(VOXPACK_PYTHON) + " -c 'import matplotlib' >/dev/null 2>&1") != 0)
    GTEST_SKIP() << VOXPACK_PYTHON << " has no matplotlib: no figures to check";
  TempDir tmp;
  const auto a = writeSphereBed(tmp, "ref.h5", 0.5, 1);
  const auto b = writeSphereBed(tmp, "cand.h5", 0.4, 2);
  const auto out = tmp / "report";
  const CliResult r = runVoxpack({"--quiet", "compare", "--reference", a.string(), b.string(), "-o",
                                  out.string(), "--python", VOXPACK_PYTHON});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  ASSERT_TRUE(r.err.empty()) << r.err;  // no warning: every figure was drawn
  const auto profile = tmp / "chromium-profile";
  const auto dom = tmp / "dom.html";
  const auto log = tmp / "chromium.log";
  const std::string cmd =
      "timeout 90 " + chromium.string() +
      " --headless --no-sandbox --disable-gpu --disable-quic --no-first-run"
      " --disable-background-networking --disable-component-update --disable-sync"
      " --enable-logging=stderr --v=0 --user-data-dir=" +
      shellQuote(profile.string()) + " --dump-dom " +
      shellQuote("file://" + (out / "index.html").string()) + " >" + shellQuote(dom.string()) +
      " 2>" + shellQuote(log.string());
  ASSERT_EQ(runShell(cmd), 0) << slurp(log);
  const std::string page = slurp(dom);
  const std::string messages = slurp(log);
  // The page itself logs nothing: any console line is an error (script, failed resource).
  EXPECT_EQ(messages.find("CONSOLE"), std::string::npos) << messages;
  std::smatch m;
  ASSERT_TRUE(std::regex_search(page, m, std::regex("data-image-sizes=\"([^\"]*)\"")))
      << "the load handler did not run";
  const std::string sizes = m[1];
  int figures = 0;
  const std::regex one("(\\w+)=(\\d+)x(\\d+)");
  for (auto it = std::sregex_iterator(sizes.begin(), sizes.end(), one);
       it != std::sregex_iterator(); ++it) {
    ++figures;
    EXPECT_GT(std::stoi((*it)[2]), 0) << (*it)[1];
    EXPECT_GT(std::stoi((*it)[3]), 0) << (*it)[1];
  }
  EXPECT_EQ(figures, 6) << sizes;
}
