// Comparison of hand-made statistics objects (the shape computeStats returns), images of
// tiny beds, provenance classification and the report files.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <iomanip>
#include <numbers>
#include <sstream>

#include "cli_runner.hpp"
#include "voxpack/compare/compare.hpp"
#include "voxpack/compare/report.hpp"
#include "voxpack/core/json_util.hpp"

using namespace voxpack;
using namespace voxpack::compare;
using nlohmann::json;

namespace {

// Statistics of an imaginary bed sampled every `stepMm`: smooth analytic profiles, so
// that two samplings differ only by interpolation error.
json makeStats(double stepMm, double densityShift = 0.0) {
  const double pi = std::numbers::pi;
  json s;
  std::vector<double> z, d;
  for (double v = 0.0; v <= 40.0 + 1e-9; v += stepMm) {
    z.push_back(v);
    d.push_back(0.63 + densityShift + 0.02 * std::sin(2 * pi * v / 7.0));
  }
  double mean = 0, var = 0;
  for (double x : d) mean += x / static_cast<double>(d.size());
  for (double x : d) var += (x - mean) * (x - mean) / static_cast<double>(d.size());
  s["axial"] = {{"z_mm", z}, {"density", d}, {"mean", mean}, {"std", std::sqrt(var)}};
  s["packing_density"] = mean;
  s["porosity"] = 1 - mean;
  std::vector<double> r, rd, w;
  const double radius = 20.0;
  for (double v = 0.5 * stepMm; v < radius; v += stepMm) {
    r.push_back(v);
    const double wall = radius - v;
    w.push_back(wall);
    rd.push_back(0.6 + densityShift + 0.3 * std::cos(2 * pi * wall / 5.4) * std::exp(-wall / 5.0));
  }
  s["radial"] = {{"r_mm", r},
                 {"density", rd},
                 {"axis_mm", {0.0, 0.0}},
                 {"radius_mm", radius},
                 {"wall_distance_mm", w}};
  const double phi = 0.37 - densityShift;
  std::vector<double> h, s2;
  for (double v = 0.0; v <= 10.0 + 1e-9; v += stepMm) {
    h.push_back(v);
    s2.push_back(phi * phi + (phi - phi * phi) * std::exp(-v / 1.5));
  }
  s["s2"] = {{"h_mm", h}, {"s2", s2}, {"phi", phi}};
  std::vector<double> b, p;
  for (double v = 0.5 * stepMm; v < 8.0; v += stepMm) {
    b.push_back(v);
    const double l = std::log(v / (1.8 + densityShift * 10));
    p.push_back(std::exp(-l * l / (2 * 0.3 * 0.3)) / (v * 0.3 * std::sqrt(2 * pi)));
  }
  s["mes"] = {{"bins_mm", b}, {"pdf", p}, {"mean_mm", 1.8}, {"std_mm", 0.5}};
  return s;
}

}  // namespace

TEST(ComputeDistances, SelfComparisonIsZeroWithPValueOne) {
  const json s = makeStats(0.2);
  const Distances d = computeDistances(s, s);
  EXPECT_EQ(d.densityRelDiff, 0.0);
  EXPECT_EQ(d.axialKs.pValue, 1.0);
  EXPECT_EQ(d.axialKs.statistic, 0.0);
  EXPECT_EQ(d.radial.rmse, 0.0);
  EXPECT_EQ(d.s2.rmse, 0.0);
  EXPECT_EQ(d.mesKs, 0.0);
  EXPECT_NEAR(d.densityMean, s["axial"]["mean"].get<double>(), 0.0);
  const json j = distancesToJson("self", d);
  for (const char* key : {"name", "density_mean", "density_std", "density_rel_diff", "axial_ks_p",
                          "radial_rmse", "s2_rmse", "mes_ks"})
    EXPECT_TRUE(j.contains(key)) << key;
  EXPECT_EQ(j["axial_ks_p"].get<double>(), 1.0);
}

TEST(ComputeDistances, DifferentVoxelSizesCompareInMm) {
  // The same analytic bed sampled at 0.2 mm and 0.3 mm: the distances are interpolation
  // error only. Bound: h^2/8 |f''| with h = 0.3 mm, |f''| <= 0.3 (2 pi / 5.4)^2 ~ 0.41 for
  // the radial profile -> 0.005; S2 and MES are smoother.
  const Distances d = computeDistances(makeStats(0.2), makeStats(0.3));
  EXPECT_LT(std::abs(d.densityRelDiff), 0.002);
  EXPECT_LT(d.radial.rmse, 0.005);
  EXPECT_LT(d.s2.rmse, 0.001);
  EXPECT_LT(d.mesKs, 0.03);
  EXPECT_GT(d.axialKs.pValue, 0.5);  // the same arcsine-like distribution of slices
  EXPECT_NEAR(d.radial.stepMm, 0.3, 1e-12);
}

TEST(ComputeDistances, ShiftedDensityIsSeen) {
  const json ref = makeStats(0.2);
  const Distances d = computeDistances(ref, makeStats(0.2, -0.15));
  EXPECT_NEAR(d.densityRelDiff, -0.15 / ref["axial"]["mean"].get<double>(), 1e-3);
  EXPECT_NEAR(d.radial.rmse, 0.15, 1e-9);  // a constant shift of the radial profile
  EXPECT_LT(d.axialKs.pValue, 1e-6);       // disjoint slice-density ranges
  EXPECT_GT(d.s2.rmse, 0.01);
  EXPECT_GT(d.mesKs, 0.5);
}

TEST(ComputeDistances, MissingBlocksGiveNullNotNaN) {
  json ref = makeStats(0.2);
  json cand = ref;
  cand.erase("mes");
  cand.erase("s2");
  const Distances d = computeDistances(ref, cand);
  EXPECT_TRUE(std::isnan(d.mesKs));
  EXPECT_TRUE(std::isnan(d.s2.rmse));
  const json j = distancesToJson("c", d);
  EXPECT_TRUE(j["mes_ks"].is_null());
  EXPECT_TRUE(j["s2_rmse"].is_null());
  EXPECT_EQ(j["radial_rmse"].get<double>(), 0.0);
}

TEST(ComputeDistances, WallDistanceFallsBackToRadiusMinusR) {
  const json radial = {{"r_mm", {1.0, 2.0}}, {"density", {0.5, 0.6}}, {"radius_mm", 10.0}};
  const auto w = wallDistanceMm(radial);
  ASSERT_EQ(w.size(), 2u);
  EXPECT_EQ(w[0], 9.0);
  EXPECT_EQ(w[1], 8.0);
}

namespace {
Bed tinyBed() {
  // 2 x 3 x 4 voxels of 0.5 mm; solid where (k + i) is even; mask drops column i = 3.
  Bed bed;
  const Lattice l = Lattice::isotropic(2, 3, 4, 0.5);
  bed.indicator = Grid<std::uint8_t>(l, 1);
  bed.mask = Grid<std::uint8_t>(l, 1);
  for (int k = 0; k < 2; ++k)
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 4; ++i) {
        bed.indicator(k, j, i) = ((k + i) % 2 == 0) ? 0 : 1;
        if (i == 3) (*bed.mask)(k, j, i) = 0;
      }
  bed.indicator(0, 0, 0) = 1;  // one void voxel in an otherwise solid line
  return bed;
}
}  // namespace

TEST(Images, ShadowIsMeanSolidFractionAlongY) {
  const Image2D s = shadowImage(tinyBed());
  ASSERT_EQ(s.rows, 2);
  ASSERT_EQ(s.cols, 4);
  EXPECT_NEAR(s.values[0], 2.0 / 3.0, 1e-15);  // (k=0,i=0): 2 of 3 solid
  EXPECT_EQ(s.values[1], 0.0);                 // (k=0,i=1): void
  EXPECT_TRUE(std::isnan(s.values[3]));        // outside the mask
  EXPECT_EQ(s.values[4 + 1], 1.0);             // (k=1,i=1): solid
  EXPECT_EQ(s.colToMm, 1.5);
  EXPECT_EQ(s.rowToMm, 0.5);
}

TEST(Images, SliceHoldsIndicatorInsideMask) {
  const Image2D s = voidSlice(tinyBed());  // masked z range 0..1 -> k = 0
  ASSERT_EQ(s.rows, 3);
  ASSERT_EQ(s.cols, 4);
  EXPECT_EQ(s.values[0], 1.0);
  EXPECT_EQ(s.values[4], 0.0);
  EXPECT_EQ(s.values[1], 1.0);
  EXPECT_TRUE(std::isnan(s.values[3]));
}

TEST(ClassifyOrigin, PackPhantomIngest) {
  const json mc = {{"command_line", "voxpack pack --mode mc --seed 1 -o a.h5"}};
  EXPECT_EQ(classifyOrigin(mc).kind, "simulated");
  EXPECT_EQ(classifyOrigin(mc).detail, "pack --mode mc");
  const json dem = {{"command_line", "voxpack pack --mode dem -o b.h5"}};
  EXPECT_EQ(classifyOrigin(dem).detail, "pack --mode dem");
  // The mode comes from --mode, not from a path that happens to contain "dem".
  const json mcInDemo = {{"command_line", "voxpack pack --mode mc -o demo/out.h5"}};
  EXPECT_EQ(classifyOrigin(mcInDemo).detail, "pack --mode mc");
  EXPECT_EQ(classifyOrigin({{"command", "pack"}, {"mode", "dem"}}).detail, "pack --mode dem");
  const json ing = {{"command_line", "voxpack ingest scan.nrrd -o r.h5"}};
  EXPECT_EQ(classifyOrigin(ing).kind, "imaged");
  EXPECT_FALSE(classifyOrigin(ing).synthetic);
  // The phantom shows in the ingested image's header or anywhere in the provenance.
  EXPECT_TRUE(classifyOrigin(ing, "NRRD0004\n# voxpack phantom --modality mri\n").synthetic);
  EXPECT_TRUE(classifyOrigin(ing, "NRRD0004\nvoxpack_modality:=mri\n").synthetic);
  const json chain = {{"command_line", "voxpack ingest p.nrrd -o r.h5"},
                      {"inputs", {{"image", {{"synthetic", true}}}}}};
  EXPECT_EQ(classifyOrigin(chain).kind, "synthetic image");
  EXPECT_EQ(classifyOrigin(json::object()).kind, "unknown");
}

TEST(Base64, Rfc4648Vectors) {
  EXPECT_EQ(base64(""), "");
  EXPECT_EQ(base64("f"), "Zg==");
  EXPECT_EQ(base64("fo"), "Zm8=");
  EXPECT_EQ(base64("foo"), "Zm9v");
  EXPECT_EQ(base64("foob"), "Zm9vYg==");
  EXPECT_EQ(base64("fooba"), "Zm9vYmE=");
  EXPECT_EQ(base64("foobar"), "Zm9vYmFy");
  EXPECT_EQ(base64(std::string("\xff\x00\x80", 3)), "/wCA");
}

namespace {
Comparison handMade() {
  Comparison c;
  c.reference.name = "ref";
  c.reference.path = "ref.h5";
  c.reference.origin =
      classifyOrigin({{"command_line", "voxpack ingest x -o ref.h5"}}, "# voxpack phantom");
  c.reference.stats = makeStats(0.2);
  c.reference.shadow = shadowImage(tinyBed());
  c.reference.slice = voidSlice(tinyBed());
  c.reference.spacingMm = {0.2, 0.2, 0.2};
  for (double shift : {-0.1, -0.02}) {
    BedEntry e = c.reference;
    e.name = shift < -0.05 ? "mc" : "dem";
    e.path = e.name + ".h5";
    e.origin = classifyOrigin({{"command_line", "voxpack pack --mode " + e.name}});
    e.stats = makeStats(0.3, shift);
    e.spacingMm = {0.3, 0.3, 0.3};
    c.distances.push_back(computeDistances(c.reference.stats, e.stats));
    c.candidates.push_back(e);
  }
  return c;
}

std::string slurp(const std::filesystem::path& p) {
  std::ifstream f(p);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}
}  // namespace

TEST(Report, WithoutPythonNumbersAndCsvStillComeOut) {
  test::TempDir tmp;
  const auto dir = tmp.path() / "new" / "report";
  ReportOptions o;
  o.python = "/nonexistent/python3";
  const ReportResult r = writeReport(dir, handMade(), o);
  ASSERT_FALSE(r.warnings.empty());
  EXPECT_NE(r.warnings.back().find("figures skipped"), std::string::npos);
  for (const char* f : {"summary.json", "index.html", "table.csv", "beds.csv", "axial.csv",
                        "radial.csv", "s2.csv", "mes.csv", "shadow_0.txt", "slice_2.txt"})
    EXPECT_TRUE(std::filesystem::exists(dir / f)) << f;
  EXPECT_TRUE(r.figures.empty());
  const json s = readJsonFile(dir / "summary.json");
  EXPECT_EQ(s["reference"], "ref");
  ASSERT_EQ(s["candidates"].size(), 2u);
  EXPECT_EQ(s["candidates"][0]["name"], "mc");
  EXPECT_TRUE(s.contains("reference_stats"));
  const std::string html = slurp(dir / "index.html");
  EXPECT_NE(html.find("synthetic reference"), std::string::npos);
  EXPECT_NE(html.find("No figures"), std::string::npos);
  // No temporary or staging file left behind.
  for (const auto& name : test::listDir(dir)) EXPECT_EQ(name.find(".tmp"), std::string::npos);
}

TEST(Report, FiguresAreEmbeddedWhenMatplotlibIsThere) {
  if (test::runShell(std::string(VOXPACK_PYTHON) +
                     " -c 'import matplotlib, numpy' >/dev/null 2>&1") != 0)
    GTEST_SKIP() << VOXPACK_PYTHON << " has no matplotlib/numpy";
  test::TempDir tmp;
  ReportOptions o;
  o.python = VOXPACK_PYTHON;
  const ReportResult r = writeReport(tmp.path(), handMade(), o);
  EXPECT_EQ(r.figures.size(), 6u);
  for (const auto& w : r.warnings) ADD_FAILURE() << w;
  const std::string html = slurp(tmp.path() / "index.html");
  std::size_t n = 0;
  for (auto p = html.find("data:image/png;base64,"); p != std::string::npos;
       p = html.find("data:image/png;base64,", p + 1))
    ++n;
  EXPECT_EQ(n, 6u);
  for (const auto& name : test::listDir(tmp.path()))
    EXPECT_NE(name.rfind(".figures-", 0), 0u) << "staging folder left: " << name;
}

TEST(Report, TableListsEveryBed) {
  const std::string t = formatTable(handMade());
  EXPECT_NE(t.find("ref"), std::string::npos);
  EXPECT_NE(t.find("mc"), std::string::npos);
  EXPECT_NE(t.find("dem"), std::string::npos);
  EXPECT_NE(t.find("synthetic ref"), std::string::npos);
  EXPECT_EQ(t.find("calibrated"), std::string::npos);  // no ingest calibration: no band
}

// The reference's ingest error budget (ingest --calibrate) is printed under it: its density
// less the bias measured on its phantoms, +- one std.
TEST(Report, TableShowsTheReferenceCalibrationBand) {
  Comparison c = handMade();
  c.reference.calibration = {{"density_bias", 0.02}, {"density_bias_std", 0.005}, {"n", 3}};
  const std::string t = formatTable(c);
  const double m = c.reference.stats["axial"]["mean"].get<double>();
  const auto at = t.find("calibrated: true density ");
  ASSERT_NE(at, std::string::npos) << t;
  std::ostringstream lo;
  lo << std::fixed << std::setprecision(4) << m - 0.025;
  EXPECT_NE(t.find(lo.str(), at), std::string::npos) << t;
  EXPECT_NE(t.find("on 3 phantoms", at), std::string::npos) << t;
}

TEST(PackedRegion, DropsHeadspaceAndSolidEndWalls) {
  // 10 slices: a solid bottom wall, 6 packed slices at density 0.6, a sparse top surface,
  // empty headspace with one speck, a solid lid.
  const Lattice l = Lattice::isotropic(10, 1, 10, 0.5);
  Bed bed;
  bed.indicator = Grid<std::uint8_t>(l, 1);
  const int solidPerSlice[10] = {10, 6, 6, 6, 6, 6, 6, 2, 1, 10};
  for (int k = 0; k < 10; ++k)
    for (int i = 0; i < solidPerSlice[k]; ++i) bed.indicator(k, 0, i) = 0;
  const PackedRegion r = packedRegion(bed, 0.5);
  EXPECT_EQ(r.firstSlice, 1);
  EXPECT_EQ(r.lastSlice, 6);
  EXPECT_TRUE(r.cropped);
  EXPECT_NEAR(r.peakDensity, 0.6, 1e-12);
  EXPECT_NEAR(r.fromMm, 0.5, 1e-12);
  const PackedRegion none = packedRegion(bed, 0.0);
  EXPECT_FALSE(none.cropped);
  EXPECT_EQ(none.lastSlice, 9);

  const Bed c = cropSlices(bed, r.firstSlice, r.lastSlice);
  EXPECT_EQ(c.lattice().nz(), 6);
  EXPECT_NEAR(c.lattice().originMm[0], 0.5, 1e-12);
  EXPECT_EQ(c.indicator(0, 0, 5), 0);
  EXPECT_EQ(c.indicator(0, 0, 6), 1);
  EXPECT_NEAR(summarize(c).packingDensity, 0.6, 1e-12);
}
