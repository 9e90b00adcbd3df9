// The streamed path (z-slabs with a halo, tiny slabs forced) equals the in-memory path:
// counts exactly, S2 to 1e-12 relative (bit for bit in practice), masked, unmasked,
// non-prism masks, anisotropic spacing, lags crossing several slabs.
#include <gtest/gtest.h>

#include <cmath>

#include "cli_runner.hpp"
#include "scale_fixtures.hpp"
#include "voxpack/core/bed_file.hpp"
#include "voxpack/core/json_util.hpp"
#include "voxpack/stats/crop.hpp"
#include "voxpack/stats/s2.hpp"
#include "voxpack/stats/stats.hpp"
#include "voxpack/stats/streamed.hpp"

using namespace voxpack;
using namespace voxpack::test;
using nlohmann::json;

namespace {

// Numbers equal to `rel` relative; arrays and objects element-wise; nulls equal.
void expectClose(const json& a, const json& b, const std::string& where, double rel = 1e-12) {
  if (a.is_number() && b.is_number()) {
    const double x = a.get<double>(), y = b.get<double>();
    EXPECT_LE(std::abs(x - y), rel * std::max({1.0, std::abs(x), std::abs(y)}))
        << where << ": " << x << " vs " << y;
    return;
  }
  ASSERT_EQ(a.type(), b.type()) << where << ": " << a.dump().substr(0, 200) << " vs "
                                << b.dump().substr(0, 200);
  if (a.is_array()) {
    ASSERT_EQ(a.size(), b.size()) << where;
    for (std::size_t i = 0; i < a.size(); ++i)
      expectClose(a[i], b[i], where + "[" + std::to_string(i) + "]", rel);
  } else if (a.is_object()) {
    for (auto it = a.begin(); it != a.end(); ++it) {
      ASSERT_TRUE(b.contains(it.key())) << where << "." << it.key();
      expectClose(it.value(), b[it.key()], where + "." + it.key(), rel);
    }
  } else {
    EXPECT_EQ(a, b) << where;
  }
}

json withoutSeconds(json j) {
  j.erase("seconds");
  return j;
}

json inMemory(const Bed& bed, const stats::StatsOptions& o) { return stats::computeStats(bed, o); }

json streamed(const std::filesystem::path& f, const stats::StatsOptions& o, std::int64_t planes,
              std::optional<stats::CropOptions> roi = std::nullopt, bool packed = false) {
  stats::StreamOptions so;
  so.slabPlanes = planes;
  so.roi = roi;
  so.packedRegion = packed;
  return stats::computeStatsStreamed(f, o, so, nullProgress());
}

// Every streamed statistic of `bed` with slabs of `planes` against the in-memory path.
// `tile` > 0 also cuts each slab into y-x tiles of that edge (S2 only).
void expectStreamedEqualsInMemory(const Bed& bed, std::int64_t planes, double s2LagMm = 0,
                                  std::int64_t tile = 0) {
  TempDir tmp;
  const auto f = tmp / "bed.h5";
  writeBed(f, bed);
  stats::StatsOptions o;
  o.only = {"axial", "radial", "s2", "chords", "mes", "orientation"};
  o.s2MaxLagMm = s2LagMm;
  const json a = inMemory(readBed(f), o);
  o.s2TileVoxels = tile;
  const json b = streamed(f, o, planes);
  ASSERT_GT(b["streamed"]["slabs"].get<int>(), 2);
  if (tile > 0) {
    EXPECT_EQ(b["streamed"]["s2_tile_voxels"], tile);
    const auto lagY = b["s2"]["max_lag_voxels"][1].get<std::int64_t>();
    EXPECT_GT(lagY, tile) << "lags must cross tiles";
  }
  const auto lag = b["s2"]["max_lag_voxels"][0].get<std::int64_t>();
  EXPECT_GT(lag, planes) << "lags must cross slabs";
  for (const char* k : {"voxels_in_mask", "void_voxels", "porosity", "packing_density",
                        "particle_diameter_mm", "lattice"})
    EXPECT_EQ(a[k], b[k]) << k;
  EXPECT_EQ(a["axial"], b["axial"]);
  EXPECT_EQ(a["radial"], b["radial"]);
  EXPECT_EQ(a["orientation"], b["orientation"]);
  // Chords along z cross the slabs; the run counts, and so the whole object, are exact.
  EXPECT_EQ(a["chords"], b["chords"]);
  EXPECT_GT(a["chords"]["z"]["samples"].get<std::int64_t>(), 0);
  // Mean empty space: the halo holds every run through a slab, and its sums are exact
  // integers, so the same bits as the whole bed.
  EXPECT_TRUE(b["streamed"]["mes"]["exact"].get<bool>());
  EXPECT_EQ(withoutSeconds(a["mes"]), withoutSeconds(b["mes"]));
  EXPECT_GT(a["mes"]["samples"].get<std::int64_t>(), 0);
  // Pair counts exact, S2 to 1e-12 relative.
  for (const char* curve : {"axial", "transverse"}) {
    EXPECT_EQ(a["s2"][curve]["pairs"], b["s2"][curve]["pairs"]) << curve;
    expectClose(a["s2"][curve]["s2"], b["s2"][curve]["s2"], std::string("s2.") + curve);
  }
  EXPECT_EQ(a["s2"]["pairs"], b["s2"]["pairs"]);
  EXPECT_EQ(a["s2"]["h_mm"], b["s2"]["h_mm"]);
  expectClose(a["s2"]["s2"], b["s2"]["s2"], "s2.s2");
  EXPECT_EQ(a["s2"]["phi"], b["s2"]["phi"]);
  expectClose(a["s2"]["correlation_length_mm"], b["s2"]["correlation_length_mm"], "corr");
}

}  // namespace

TEST(StreamedStats, PrismMaskSlabsOfThreePlanes) {
  ColumnBed o;
  expectStreamedEqualsInMemory(sphereColumn(o), 3);
}

TEST(StreamedStats, SlabsOfOnePlaneWithLongLags) {
  ColumnBed o;
  o.nz = 24;
  expectStreamedEqualsInMemory(sphereColumn(o), 1, 1.6);  // 8 voxels: 8 slabs of halo
}

TEST(StreamedStats, TaperedMaskIsNotAPrism) {
  ColumnBed o;
  o.taperedMask = true;
  expectStreamedEqualsInMemory(sphereColumn(o), 4);
}

TEST(StreamedStats, NoMaskAnisotropic) {
  ColumnBed o;
  o.mask = false;
  o.spacingMm = {0.15, 0.2, 0.25};
  expectStreamedEqualsInMemory(sphereColumn(o), 2);
}

TEST(StreamedStats, MaskedAnisotropicUnevenLastSlab) {
  ColumnBed o;
  o.nz = 37;  // 37 = 7 x 5 + 2: the last slab is thinner
  o.spacingMm = {0.3, 0.2, 0.2};
  expectStreamedEqualsInMemory(sphereColumn(o), 5, 2.4);  // 8 planes of lag
}

// Tiles narrower than the lags, an uneven last tile in y and x, lags crossing several
// tiles and slabs: the same counts as the whole volume (issue 13: FFT buffers by tile).
TEST(StreamedStats, PrismMaskTilesOfFiveVoxels) {
  ColumnBed o;
  expectStreamedEqualsInMemory(sphereColumn(o), 3, 0, 5);
}

TEST(StreamedStats, TaperedMaskTilesOfFourVoxels) {
  ColumnBed o;
  o.taperedMask = true;
  expectStreamedEqualsInMemory(sphereColumn(o), 4, 0, 4);
}

TEST(StreamedStats, NoMaskAnisotropicTilesOfThreeVoxels) {
  ColumnBed o;
  o.mask = false;
  o.spacingMm = {0.15, 0.2, 0.25};
  expectStreamedEqualsInMemory(sphereColumn(o), 2, 0, 3);
}

// Single precision through tiles stays within float rounding of the double result.
TEST(StreamedStats, FloatTilesAgreeWithDoubleToFloatRounding) {
  ColumnBed o;
  o.taperedMask = true;
  TempDir tmp;
  const auto f = tmp / "bed.h5";
  writeBed(f, sphereColumn(o));
  stats::StatsOptions d;
  d.only = {"s2"};
  const json a = streamed(f, d, 4);
  d.s2Float = true;
  d.s2TileVoxels = 6;
  const json b = streamed(f, d, 4);
  EXPECT_EQ(b["s2"]["precision"], "float");
  expectClose(a["s2"]["s2"], b["s2"]["s2"], "s2 float", 1e-5);
}

// Past a budget that cannot hold whole-plane FFT boxes, tiles are chosen, and the run
// fits the budget; with room, whole planes are kept.
TEST(StreamedStats, TileEdgeChosenFromTheBudget) {
  ColumnBed o;
  o.nz = 24;
  o.ny = o.nx = 96;
  o.radiusVox = 6;
  TempDir tmp;
  const auto f = tmp / "bed.h5";
  writeBed(f, sphereColumn(o));
  const BedHeader h = readBedHeader(f);
  const VoxelBox region{{0, 0, 0}, h.lattice.dims};
  stats::StatsOptions so;
  so.only = {"s2"};
  so.s2MaxLagMm = 16 * 0.2;
  EXPECT_EQ(stats::chooseS2TileVoxels(h, region, so, MemoryBudget{std::uint64_t{8} << 30}), 0);
  // One whole-plane slab of one plane needs (1+16) x 128 x 130 x 2 doubles: ~4.5 MB.
  stats::StatsOptions whole = so;
  const std::uint64_t onePlane = stats::estimateStreamedBytes(h, region, whole, 1);
  const MemoryBudget tight{onePlane - 1};
  const std::int64_t edge = stats::chooseS2TileVoxels(h, region, so, tight);
  ASSERT_GT(edge, 0);
  so.s2TileVoxels = edge;
  const std::int64_t t = stats::slabPlanesWithin(h, region, so, tight);
  ASSERT_GT(t, 0);
  EXPECT_LE(stats::estimateStreamedBytes(h, region, so, t), tight.limitBytes);
  stats::StreamOptions stream;
  stream.budget = tight;
  stats::StatsOptions run;
  run.only = {"s2"};
  run.s2MaxLagMm = so.s2MaxLagMm;
  const json b = stats::computeStatsStreamed(f, run, stream, nullProgress());
  EXPECT_EQ(b["streamed"]["s2_tile_voxels"], edge);
  const json a = inMemory(readBed(f), run);
  EXPECT_EQ(a["s2"]["pairs"], b["s2"]["pairs"]);
  expectClose(a["s2"]["s2"], b["s2"]["s2"], "s2");
}

// The pair counts of the slabs sum to the brute-force whole-volume counts.
TEST(StreamedStats, PairCountsEqualBruteForce) {
  ColumnBed o;
  o.nz = 12;
  o.ny = 10;
  o.nx = 9;
  o.radiusVox = 1.8;
  o.taperedMask = true;
  const Bed bed = sphereColumn(o);
  stats::S2Options so;
  so.maxLagMm = 0.8;  // 4 voxels
  so.minPairFraction = 0;
  const stats::S2Result direct = stats::twoPointProbabilityDirect(bed.indicator, &*bed.mask, so);
  for (const std::int64_t tile : {0, 3}) {  // whole planes, then tiles of 3 x 3
    SCOPED_TRACE(tile);
    so.tileVoxels = tile;
    stats::S2SlabAccumulator acc(bed.lattice(), true, false, so);
    const std::int64_t nz = o.nz, hz = acc.maxLag()[0];
    for (std::int64_t z0 = 0; z0 < nz; z0 += 2) {
      const std::int64_t z1 = std::min(nz, z0 + 2), ze = std::min(nz, z1 + hz);
      const VoxelBox box{{z0, 0, 0}, {ze - z0, o.ny, o.nx}};
      Grid<std::uint8_t> ind(subLattice(bed.lattice(), box)), m(ind.lattice());
      for (std::int64_t k = 0; k < ze - z0; ++k)
        for (std::int64_t j = 0; j < o.ny; ++j)
          for (std::int64_t i = 0; i < o.nx; ++i) {
            ind(k, j, i) = bed.indicator(z0 + k, j, i);
            m(k, j, i) = (*bed.mask)(z0 + k, j, i);
          }
      acc.addSlab(z0, z1, ind, &m);
    }
    const stats::S2Result r = acc.finish();
    EXPECT_EQ(r.radial.pairs, direct.radial.pairs);
    EXPECT_EQ(r.axial.pairs, direct.axial.pairs);
    ASSERT_EQ(r.radial.s2.size(), direct.radial.s2.size());
    for (std::size_t b = 0; b < r.radial.s2.size(); ++b)
      EXPECT_NEAR(r.radial.s2[b], direct.radial.s2[b], 1e-12 * direct.radial.s2[b]) << b;
  }
}

// ROI and packed region in the stream equal the in-memory crop.
TEST(StreamedStats, RoiAndPackedRegionEqualInMemoryCrop) {
  ColumnBed o;
  o.nz = 48;
  o.packedPlanes = 30;  // 18 planes of headspace
  const Bed bed = sphereColumn(o);
  TempDir tmp;
  const auto f = tmp / "bed.h5";
  writeBed(f, bed);
  stats::StatsOptions so;
  so.only = {"axial", "radial", "s2"};
  so.particleDiameterMm = 1.28;
  // Packed region.
  const json b = streamed(f, so, 4, std::nullopt, true);
  const auto& pr = b["packed_region"];
  EXPECT_TRUE(pr["applied"].get<bool>());
  EXPECT_GT(pr["headspace_fraction"].get<double>(), 0.3);
  const auto first = pr["first_slice"].get<std::int64_t>(),
             last = pr["last_slice"].get<std::int64_t>();
  EXPECT_LE(last, 31);
  stats::CropOptions z;
  const Lattice& l = bed.lattice();
  z.zMm =
      stats::RangeMm{l.originMm[0] + first * l.spacingMm[0], l.originMm[0] + last * l.spacingMm[0]};
  const json a = inMemory(stats::cropBed(bed, z), so);
  EXPECT_EQ(a["axial"], b["axial"]);
  EXPECT_EQ(a["radial"], b["radial"]);
  EXPECT_EQ(a["s2"]["pairs"], b["s2"]["pairs"]);
  expectClose(a["s2"]["s2"], b["s2"]["s2"], "s2");
  EXPECT_EQ(a["porosity"], b["porosity"]);
  // A z ROI.
  stats::CropOptions roi;
  roi.zMm = stats::RangeMm{2.0, 6.0};
  const json c = streamed(f, so, 3, roi);
  const json d = inMemory(stats::cropBed(bed, roi), so);
  EXPECT_EQ(c["axial"], d["axial"]);
  EXPECT_EQ(c["radial"], d["radial"]);
  EXPECT_EQ(c["s2"]["pairs"], d["s2"]["pairs"]);
  expectClose(c["s2"]["s2"], d["s2"]["s2"], "roi s2");
}

// The CLI: --slab-voxels streams and gives the in-memory numbers; info never loads the
// volume and counts the porosity in slabs.
TEST(StreamedStats, CliSlabVoxelsEqualsInMemory) {
  ColumnBed o;
  const Bed bed = sphereColumn(o);
  TempDir tmp;
  const auto f = (tmp / "bed.h5").string();
  writeBed(f, bed);
  const auto a = (tmp / "a.json").string(), b = (tmp / "b.json").string();
  const std::vector<std::string> common{"--quiet", "stats", f, "--only", "axial,radial,s2,chords"};
  auto args = common;
  args.insert(args.end(), {"-o", a});
  ASSERT_EQ(runVoxpack(args).exitCode, 0);
  args = common;
  args.insert(args.end(), {"-o", b, "--slab-voxels", "3"});
  const CliResult r = runVoxpack(args);
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const json ja = readJsonFile(a), jb = readJsonFile(b);
  EXPECT_EQ(ja["memory_estimate_bytes"]["path"], "in_memory");
  EXPECT_EQ(jb["memory_estimate_bytes"]["path"], "streamed");
  EXPECT_EQ(ja["axial"], jb["axial"]);
  EXPECT_EQ(ja["radial"], jb["radial"]);
  EXPECT_EQ(ja["s2"]["pairs"], jb["s2"]["pairs"]);
  expectClose(ja["s2"]["s2"], jb["s2"]["s2"], "cli s2");
  EXPECT_EQ(ja["chords"], jb["chords"]);
  // A statistic without a streamed path is a usage error with --slab-voxels.
  const CliResult bad = runVoxpack({"stats", f, "--only", "psd", "--slab-voxels", "3", "-o", b});
  EXPECT_EQ(bad.exitCode, 2);
  EXPECT_NE(bad.err.find("cannot be streamed"), std::string::npos) << bad.err;
  // So is the isotropic mean empty space (CGAL rays need the whole surface).
  const CliResult iso = runVoxpack(
      {"stats", f, "--only", "mes", "--mes-method", "isotropic", "--slab-voxels", "3", "-o", b});
  EXPECT_EQ(iso.exitCode, 2);
  EXPECT_NE(iso.err.find("cannot be streamed"), std::string::npos) << iso.err;
  // info in slabs of 2 planes gives the exact porosity.
  const CliResult info = runVoxpack({"info", f, "--json", "--slab-voxels", "2"});
  ASSERT_EQ(info.exitCode, 0) << info.err;
  const json ji = json::parse(info.out);
  const BedSummary s = summarize(bed);
  EXPECT_EQ(ji["porosity"].get<double>(), s.porosity);
  EXPECT_EQ(ji["voxels_in_mask"].get<std::size_t>(), s.voxelsInMask);
}

// Headspace over 10 % is warned about when included, and --packed-region auto drops it.
TEST(StreamedStats, CliPackedRegionWarnsAndCrops) {
  ColumnBed o;
  o.nz = 48;
  o.packedPlanes = 30;
  const Bed bed = sphereColumn(o);
  TempDir tmp;
  const auto f = (tmp / "bed.h5").string();
  writeBed(f, bed);
  const auto a = (tmp / "a.json").string(), b = (tmp / "b.json").string();
  const CliResult off = runVoxpack({"stats", f, "--only", "axial", "-o", a});
  ASSERT_EQ(off.exitCode, 0) << off.err;
  EXPECT_NE(off.err.find("warning:"), std::string::npos) << off.err;
  EXPECT_NE(off.err.find("--packed-region auto"), std::string::npos) << off.err;
  const CliResult on =
      runVoxpack({"stats", f, "--only", "axial", "--packed-region", "auto", "-o", b});
  ASSERT_EQ(on.exitCode, 0) << on.err;
  EXPECT_EQ(on.err.find("warning:"), std::string::npos) << on.err;
  const json ja = readJsonFile(a), jb = readJsonFile(b);
  EXPECT_FALSE(ja["packed_region"]["applied"].get<bool>());
  EXPECT_TRUE(jb["packed_region"]["applied"].get<bool>());
  EXPECT_EQ(ja["packed_region"]["first_slice"], jb["packed_region"]["first_slice"]);
  EXPECT_LT(jb["porosity"].get<double>(), ja["porosity"].get<double>() - 0.1);
  EXPECT_LE(jb["lattice"]["dims"][0].get<int>(), 32);
}

// A void run 12 planes tall, bounded by solid: a halo of 12 planes holds it from every slab of
// 4 and gives the whole bed's mean empty space; 11 planes cut it, and the cut is counted and
// the voxels left out, never guessed.
TEST(StreamedStats, MesHaloShorterThanARunIsCountedAndLeftOut) {
  Lattice l = Lattice::isotropic(20, 5, 5, 0.1);
  Bed bed;
  bed.indicator = Grid<std::uint8_t>(l, 0);
  for (std::int64_t k = 3; k <= 14; ++k) bed.indicator(k, 2, 2) = 1;
  TempDir tmp;
  const auto f = tmp / "bed.h5";
  writeBed(f, bed);
  stats::StatsOptions o;
  o.only = {"mes"};
  const json a = inMemory(readBed(f), o);
  // Along z the chord is 12 voxels; along y, x and the 10 diagonals one step (1, √2, √3).
  EXPECT_EQ(a["mes"]["samples"], 12);
  EXPECT_NEAR(a["mes"]["voxel_mean_mm"].get<double>(),
              0.1 * (14 + 6 * std::sqrt(2.0) + 4 * std::sqrt(3.0)) / 13.0, 1e-6);
  auto run = [&](std::int64_t halo) {
    stats::StreamOptions so;
    so.slabPlanes = 4;
    so.mesHaloPlanes = halo;
    return stats::computeStatsStreamed(f, o, so, nullProgress());
  };
  const json whole = run(12);
  EXPECT_TRUE(whole["streamed"]["mes"]["exact"].get<bool>());
  EXPECT_EQ(withoutSeconds(a["mes"]), withoutSeconds(whole["mes"]));
  const json cut = run(11);
  EXPECT_FALSE(cut["streamed"]["mes"]["exact"].get<bool>());
  // Slab [0, 4) owns planes 3 and the chord that starts there; it cannot see plane 15.
  EXPECT_EQ(cut["streamed"]["mes"]["slice_cut_voxels"], 1);
  EXPECT_EQ(cut["streamed"]["mes"]["slice_cut_chords"], 1);
  EXPECT_EQ(cut["mes"]["samples"], 11);
  EXPECT_EQ(cut["mes"]["undefined_voxels"], 1);
  EXPECT_EQ(cut["mes"]["void_voxels"], 12);
}
