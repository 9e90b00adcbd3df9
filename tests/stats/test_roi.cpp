// ROI cropping (`cropBed`, `voxpack stats --roi-mm / --roi-box-mm`): values and world
// coordinates kept, statistics equal to those of a bed cropped by hand, bad ROIs refused.
#include <gtest/gtest.h>

#include <cmath>

#include "cli_runner.hpp"
#include "stats_fixtures.hpp"
#include "voxpack/core/bed_file.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/core/json_util.hpp"
#include "voxpack/stats/crop.hpp"
#include "voxpack/stats/stats.hpp"

namespace voxpack::test {
namespace {

using nlohmann::json;

// Boolean spheres on an anisotropic lattice with an off-zero origin, a cylinder mask and a
// label per voxel (a few "particles" by z band), so every cropped field is checked.
Bed sampleBed() {
  Grid<std::uint8_t> g = booleanSpheres(24, 3, 0.8, 11);
  Lattice l = g.lattice();
  l.spacingMm = {0.3, 0.25, 0.2};
  l.originMm = {-1.15, 2.5, -3.1};
  g.setLattice(l);
  Bed b = bedOf(std::move(g));
  b.mask = Grid<std::uint8_t>(l, 0);
  b.labels = Grid<std::uint32_t>(l, 0);
  for (std::int64_t k = 0; k < l.nz(); ++k)
    for (std::int64_t j = 0; j < l.ny(); ++j)
      for (std::int64_t i = 0; i < l.nx(); ++i) {
        const double dy = static_cast<double>(j) - 11.5, dx = static_cast<double>(i) - 11.5;
        (*b.mask)(k, j, i) = dx * dx + dy * dy <= 11.5 * 11.5;
        if (b.indicator(k, j, i) == 0) (*b.labels)(k, j, i) = static_cast<std::uint32_t>(k / 6 + 1);
      }
  for (int p = 0; p < 4; ++p) {
    b.particles.positionMm.push_back(l.centerMm(6 * p + 3, 12, 12));
    b.particles.orientation.push_back(Quat::Identity());
    b.particles.shape.push_back("sphere:d=" + std::to_string(p + 1));
  }
  return b;
}

TEST(Crop, KeepsValuesAndWorldCoordinates) {
  const Bed bed = sampleBed();
  const Lattice& l = bed.lattice();
  stats::CropOptions o;
  o.zMm = stats::RangeMm{0.0, 3.05};  // centres -1.15 + 0.3 k: k = 4 (0.05) .. 14 (3.05)
  o.xMm = stats::RangeMm{-2.0, 0.0};  // centres -3.1 + 0.2 i: i = 6 (-1.9) .. 15 (-0.1)
  stats::CropBox box;
  const Bed c = stats::cropBed(bed, o, &box);
  EXPECT_EQ(box.first, (std::array<std::int64_t, 3>{4, 0, 6}));
  EXPECT_EQ(box.dims, (std::array<std::int64_t, 3>{11, 24, 10}));
  const Lattice& cl = c.lattice();
  EXPECT_EQ(cl.dims, box.dims);
  EXPECT_EQ(cl.spacingMm, l.spacingMm);
  for (int a = 0; a < 3; ++a)
    EXPECT_EQ(cl.originMm[a], l.originMm[a] + static_cast<double>(box.first[a]) * l.spacingMm[a]);
  ASSERT_TRUE(c.mask && c.labels);
  // Every voxel of the input lattice is kept iff its centre lies in the ROI, with its values
  // at the same world position (1e-12 mm: two roundings of origin + k * spacing).
  std::size_t kept = 0;
  for (std::int64_t k = 0; k < l.nz(); ++k)
    for (std::int64_t j = 0; j < l.ny(); ++j)
      for (std::int64_t i = 0; i < l.nx(); ++i) {
        const Vec3 p = l.centerMm(k, j, i);
        const bool in =
            p.z() >= 0.0 - 1e-12 && p.z() <= 3.05 + 1e-12 && p.x() >= -2.0 && p.x() <= 0.0;
        const std::int64_t ck = k - box.first[0], cj = j - box.first[1], ci = i - box.first[2];
        ASSERT_EQ(in, cl.contains(ck, cj, ci)) << k << " " << j << " " << i;
        if (!in) continue;
        ++kept;
        EXPECT_LT((cl.centerMm(ck, cj, ci) - p).norm(), 1e-12);
        EXPECT_EQ(c.indicator(ck, cj, ci), bed.indicator(k, j, i));
        EXPECT_EQ((*c.mask)(ck, cj, ci), (*bed.mask)(k, j, i));
      }
  EXPECT_EQ(kept, cl.size());
  // Labels: bands 1..4 are z 0-5, 6-11, 12-17, 18-23; k 4..14 holds bands 1-3, renumbered
  // in order; the table keeps those three particles.
  ASSERT_EQ(c.particles.size(), 3u);
  EXPECT_EQ(c.particles.shape[2], bed.particles.shape[2]);
  for (std::int64_t k = 0; k < cl.nz(); ++k)
    for (std::int64_t j = 0; j < cl.ny(); ++j)
      for (std::int64_t i = 0; i < cl.nx(); ++i) {
        const std::uint32_t old = (*bed.labels)(k + 4, j, i + 6);
        EXPECT_EQ((*c.labels)(k, j, i), old);  // bands 1-3 keep their numbers here
      }
  EXPECT_NO_THROW(c.validate());
}

TEST(Crop, RenumbersLabelsAndFiltersParticlesWithoutLabels) {
  Bed bed = sampleBed();
  stats::CropOptions o;
  o.zMm = stats::RangeMm{-1.15 + 0.3 * 12, 100.0};  // k >= 12: bands 3 and 4
  const Bed c = stats::cropBed(bed, o);
  ASSERT_EQ(c.particles.size(), 2u);
  EXPECT_EQ(c.particles.shape[0], "sphere:d=3");
  for (std::uint32_t v : c.labels->values()) EXPECT_LE(v, 2u);
  // Same number of voxels per particle as before, under the new numbers.
  std::size_t before = 0, after = 0;
  for (std::uint32_t v : bed.labels->values()) before += v == 4;
  for (std::uint32_t v : c.labels->values()) after += v == 2;
  EXPECT_EQ(before, after);
  // Without labels the table keeps the particles whose centre lies in the ROI (k = 15, 21).
  bed.labels.reset();
  const Bed d = stats::cropBed(bed, o);
  ASSERT_EQ(d.particles.size(), 2u);
  EXPECT_EQ(d.particles.shape[1], "sphere:d=4");
}

TEST(Crop, BoundOnAVoxelCentreIsInclusive) {
  // Spacing 0.27, origin -0.135: centres are not exact binary fractions.
  const Lattice l = Lattice::isotropic(40, 2, 2, 0.27, Vec3(0, 0, -0.135));
  const auto b = stats::cropBox(l, stats::parseRoiZ("2.565:5.265"));  // k = 10 .. 20
  EXPECT_EQ(b.first[0], 10);
  EXPECT_EQ(b.dims[0], 11);
  const auto one = stats::cropBox(l, stats::parseRoiZ("2.565:2.565"));  // one slice
  EXPECT_EQ(one.dims[0], 1);
  const auto all = stats::cropBox(l, stats::parseRoiZ("-1e9:1e9"));
  EXPECT_EQ(all.first[0], 0);
  EXPECT_EQ(all.dims[0], 40);
  const auto box = stats::parseRoiBox(":,,0:1");
  EXPECT_FALSE(box.xMm || box.yMm);
  ASSERT_TRUE(box.zMm);
  EXPECT_EQ(box.zMm->hi, 1.0);
}

TEST(Crop, BadRoiRefused) {
  for (const char* bad : {"5:1", "nan:3", "1:nan", "inf:2", "abc", "1", "1:2:3", ":", ""})
    EXPECT_THROW(stats::parseRoiZ(bad), InputError) << bad;
  for (const char* bad : {"0:1,0:1", "0:1,0:1,0:1,0:1", "0:1,2:1,0:1", "0:1,0:1,x:1"})
    EXPECT_THROW(stats::parseRoiBox(bad), InputError) << bad;
  const Lattice l = Lattice::isotropic(10, 10, 10, 1.0);
  EXPECT_THROW(stats::cropBox(l, stats::parseRoiZ("9.5:20")), InputError);   // above
  EXPECT_THROW(stats::cropBox(l, stats::parseRoiZ("3.2:3.8")), InputError);  // between centres
  EXPECT_THROW(stats::cropBox(l, stats::parseRoiZ("-5:-0.5")), InputError);  // below
}

// --- CLI -------------------------------------------------------------------------------

// Numbers equal to `tol` (relative to max(1, |a|)), everything else equal, recursively;
// "seconds" (a timing) is ignored at any depth.
void expectSameJson(const json& a, const json& b, double tol, const std::string& where = "") {
  if (a.is_number() && b.is_number()) {
    const double x = a.get<double>(), y = b.get<double>();
    EXPECT_LE(std::abs(x - y), tol * std::max(1.0, std::abs(x))) << where;
    return;
  }
  ASSERT_EQ(a.type(), b.type()) << where;
  if (a.is_object()) {
    ASSERT_EQ(a.size(), b.size()) << where;
    for (auto it = a.begin(); it != a.end(); ++it) {
      if (it.key() == "seconds") continue;
      ASSERT_TRUE(b.contains(it.key())) << where << "/" << it.key();
      expectSameJson(it.value(), b[it.key()], tol, where + "/" + it.key());
    }
  } else if (a.is_array()) {
    ASSERT_EQ(a.size(), b.size()) << where;
    for (std::size_t n = 0; n < a.size(); ++n)
      expectSameJson(a[n], b[n], tol, where + "[" + std::to_string(n) + "]");
  } else {
    EXPECT_EQ(a, b) << where;
  }
}

json withoutRunKeys(json j) {
  // The memory estimate depends on the size read and the limit on the memory free now.
  for (const char* k :
       {"input", "command_line", "input_provenance", "roi_mm", "memory_estimate_bytes"})
    j.erase(k);
  return j;
}

// The crop done by hand (loops over the world coordinates, not cropBed).
Bed handCropZ(const Bed& bed, double z0, double z1) {
  const Lattice& l = bed.lattice();
  std::int64_t k0 = -1, k1 = -1;
  for (std::int64_t k = 0; k < l.nz(); ++k) {
    const double z = l.originMm[0] + static_cast<double>(k) * l.spacingMm[0];
    if (z >= z0 && z <= z1) {
      if (k0 < 0) k0 = k;
      k1 = k;
    }
  }
  Lattice c = l;
  c.dims[0] = k1 - k0 + 1;
  c.originMm[0] = l.originMm[0] + static_cast<double>(k0) * l.spacingMm[0];
  Bed out;
  out.indicator = Grid<std::uint8_t>(c);
  out.mask = Grid<std::uint8_t>(c);
  for (std::int64_t k = 0; k < c.nz(); ++k)
    for (std::int64_t j = 0; j < c.ny(); ++j)
      for (std::int64_t i = 0; i < c.nx(); ++i) {
        out.indicator(k, j, i) = bed.indicator(k + k0, j, i);
        (*out.mask)(k, j, i) = (*bed.mask)(k + k0, j, i);
      }
  return out;
}

Bed cliBed() {
  Bed b = sampleBed();
  b.labels.reset();
  b.particles = {};
  return b;
}

TEST(CliRoi, StatsEqualThoseOfAHandCroppedBed) {
  TempDir dir;
  const Bed bed = cliBed();
  writeBed(dir / "bed.h5", bed);
  // z centres -1.15 + 0.3 k; [1.0, 4.5] keeps k = 8 (1.25) .. 18 (4.25).
  writeBed(dir / "hand.h5", handCropZ(bed, 1.0, 4.5));
  const std::vector<std::string> common = {
      "--only", "axial,radial,s2,mes,psd,chords,shadow", "--trim-mm", "0", "--threads", "1",
      "--quiet"};
  auto run = [&](std::vector<std::string> args) {
    args.insert(args.end(), common.begin(), common.end());
    const auto r = runVoxpack(args);
    EXPECT_EQ(r.exitCode, 0) << r.err;
  };
  run({"stats", (dir / "bed.h5").string(), "-o", (dir / "roi.json").string(), "--roi-mm",
       "1.0:4.5"});
  run({"stats", (dir / "hand.h5").string(), "-o", (dir / "hand.json").string()});
  const json roi = readJsonFile(dir / "roi.json"), hand = readJsonFile(dir / "hand.json");
  EXPECT_EQ(roi["roi_mm"]["z"], json::array({1.0, 4.5}));
  EXPECT_TRUE(roi["roi_mm"]["x"].is_null());
  EXPECT_EQ(roi["roi_mm"]["first_voxel"], json::array({8, 0, 0}));
  EXPECT_EQ(roi["lattice"]["dims"], json::array({11, 24, 24}));
  EXPECT_TRUE(hand["roi_mm"].is_null());
  // Porosity and the axial profile identical to the last bit; the rest to FFT round-off.
  EXPECT_EQ(roi["porosity"], hand["porosity"]);
  EXPECT_EQ(roi["axial"]["z_all_mm"], hand["axial"]["z_all_mm"]);
  EXPECT_EQ(roi["axial"]["density_all"], hand["axial"]["density_all"]);
  EXPECT_EQ(roi["axial"]["density"], hand["axial"]["density"]);
  expectSameJson(withoutRunKeys(roi), withoutRunKeys(hand), 1e-12);
}

TEST(CliRoi, WholeBedRoiEqualsNoRoi) {
  TempDir dir;
  writeBed(dir / "bed.h5", cliBed());
  const std::string in = (dir / "bed.h5").string();
  for (const char* roiArg : {"--roi-mm=-1e6:1e6", "--roi-box-mm=-50:50,-50:50,-1.15:5.75"}) {
    const auto a = runVoxpack({"stats", in, "-o", (dir / "a.json").string(), "--quiet"});
    const auto b = runVoxpack({"stats", in, "-o", (dir / "b.json").string(), roiArg, "--quiet"});
    ASSERT_EQ(a.exitCode, 0) << a.err;
    ASSERT_EQ(b.exitCode, 0) << b.err;
    const json ja = readJsonFile(dir / "a.json"), jb = readJsonFile(dir / "b.json");
    EXPECT_TRUE(ja["roi_mm"].is_null());
    EXPECT_EQ(jb["roi_mm"]["dims"], ja["lattice"]["dims"]) << roiArg;
    expectSameJson(withoutRunKeys(ja), withoutRunKeys(jb), 1e-12);
  }
}

TEST(CliRoi, BadRoiExitsTwoWithoutOutput) {
  TempDir dir;
  writeBed(dir / "bed.h5", cliBed());
  const std::string in = (dir / "bed.h5").string();
  const auto out = dir / "s.json";
  for (const auto& extra : std::vector<std::vector<std::string>>{
           {"--roi-mm", "5:1"},
           {"--roi-mm", "nan:3"},
           {"--roi-mm", "1:nan"},
           {"--roi-mm", "100:200"},  // no voxel centre inside
           {"--roi-mm", "1.3:1.4"},  // between two centres (1.25, 1.55)
           {"--roi-mm", "oops"},
           {"--roi-box-mm", "0:1,0:1"},
           {"--roi-box-mm", "0:1,0:1,3:2"},
           {"--roi-mm", "0:1", "--roi-box-mm", "0:1,0:1,0:1"}}) {
    std::vector<std::string> args = {"stats", in, "-o", out.string()};
    args.insert(args.end(), extra.begin(), extra.end());
    const auto r = runVoxpack(args);
    EXPECT_EQ(r.exitCode, 2) << extra[1] << ": " << r.err;
    EXPECT_EQ(countErrorLines(r.err), 1) << r.err;
    EXPECT_FALSE(std::filesystem::exists(out)) << extra[1];
  }
}

}  // namespace
}  // namespace voxpack::test
