// computeStats: SPEC keys, --only, extremes never give NaN/Inf, CSV files.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "cli_runner.hpp"
#include "stats_fixtures.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/stats/stats.hpp"

namespace voxpack::stats {
namespace {

using nlohmann::json;

// Every number in `j` is finite (nlohmann keeps NaN as a number until dumped).
void expectFinite(const json& j, const std::string& where = "") {
  if (j.is_number_float()) {
    EXPECT_TRUE(std::isfinite(j.get<double>())) << where;
  } else if (j.is_object()) {
    for (auto it = j.begin(); it != j.end(); ++it) expectFinite(it.value(), where + "/" + it.key());
  } else if (j.is_array()) {
    for (std::size_t n = 0; n < j.size(); ++n) expectFinite(j[n], where + "/" + std::to_string(n));
  }
}

Bed columnBed() {
  // A small column: cylinder mask radius 8 voxels, Boolean spheres inside.
  Bed bed = test::bedOf(test::booleanSpheres(24, 3, 0.8, 5));
  Lattice l = Lattice::isotropic(24, 24, 24, 0.25);
  bed.indicator.setLattice(l);
  bed.mask = Grid<std::uint8_t>(l, 0);
  for (std::int64_t k = 0; k < 24; ++k)
    for (std::int64_t j = 0; j < 24; ++j)
      for (std::int64_t i = 0; i < 24; ++i)
        (*bed.mask)(k, j, i) = std::hypot(i - 11.5, j - 11.5) <= 10 ? 1 : 0;
  return bed;
}

TEST(StatsJson, SpecKeysPresent) {
  const json s = computeStats(columnBed(), {});
  for (const char* k :
       {"voxpack_version", "options", "porosity", "packing_density", "axial", "radial", "s2"})
    EXPECT_TRUE(s.contains(k)) << k;
  for (const char* k : {"z_mm", "density", "mean", "std"}) EXPECT_TRUE(s["axial"].contains(k)) << k;
  for (const char* k : {"r_mm", "density", "axis_mm", "radius_mm", "wall_distance_mm"})
    EXPECT_TRUE(s["radial"].contains(k)) << k;
  for (const char* k : {"h_mm", "s2", "phi", "axial", "transverse"})
    EXPECT_TRUE(s["s2"].contains(k)) << k;
  EXPECT_EQ(s["s2"]["h_mm"][0].get<double>(), 0.0);
  EXPECT_NEAR(s["s2"]["s2"][0].get<double>(), s["porosity"].get<double>(), 1e-12);
  EXPECT_NEAR(s["radial"]["axis_mm"][0].get<double>(), 11.5 * 0.25, 1e-9);
  expectFinite(s);
}

TEST(StatsJson, OnlyComputesWhatIsAsked) {
  StatsOptions o;
  o.only = {"s2"};
  const json s = computeStats(columnBed(), o);
  EXPECT_TRUE(s.contains("s2"));
  EXPECT_FALSE(s.contains("axial"));
  EXPECT_FALSE(s.contains("radial"));
  o.only = {"nonsense"};
  EXPECT_THROW(computeStats(columnBed(), o), InputError);
}

void checkExtreme(const Bed& bed, const char* name) {
  SCOPED_TRACE(name);
  json s;
  ASSERT_NO_THROW(s = computeStats(bed, {}));
  expectFinite(s);
  const std::string text = s.dump();
  EXPECT_EQ(text.find("NaN"), std::string::npos);
  EXPECT_EQ(text.find("Infinity"), std::string::npos);
}

TEST(StatsJson, ExtremesGiveDefinedValues) {
  checkExtreme(test::bedOf(Grid<std::uint8_t>(Lattice::isotropic(6, 7, 8, 1.0), 0)), "porosity 0");
  checkExtreme(test::bedOf(Grid<std::uint8_t>(Lattice::isotropic(6, 7, 8, 1.0), 1)), "porosity 1");
  checkExtreme(test::bedOf(test::booleanSpheres(1, 0.4, 0.5, 3)), "one voxel");
  Bed slice = test::bedOf(Grid<std::uint8_t>(Lattice::isotropic(1, 16, 16, 1.0), 1));
  slice.indicator(0, 3, 3) = 0;
  checkExtreme(slice, "one slice");
  Bed empty = columnBed();
  empty.mask->fill(0);
  checkExtreme(empty, "empty mask");
  const json e = computeStats(empty, {});
  EXPECT_TRUE(e["porosity"].is_null());
  EXPECT_TRUE(e["s2"]["phi"].is_null());
  EXPECT_TRUE(e["axial"]["mean"].is_null());
}

TEST(StatsJson, CsvFilesHaveTheAgreedHeaders) {
  const json s = computeStats(columnBed(), {});
  test::TempDir dir;
  writeStatsCsv(s, dir.path() / "sub", "ref_");
  auto firstLine = [&](const std::string& name) {
    std::ifstream f(dir.path() / "sub" / name);
    std::string line;
    std::getline(f, line);
    return line;
  };
  EXPECT_EQ(firstLine("ref_axial.csv"), "z_mm,density");
  EXPECT_EQ(firstLine("ref_radial.csv"), "r_mm,wall_distance_mm,density");
  EXPECT_EQ(firstLine("ref_s2.csv"), "h_mm,s2");
  EXPECT_EQ(firstLine("ref_s2_axial.csv"), "h_mm,s2");
}

}  // namespace
}  // namespace voxpack::stats
