// Statistics and info of degenerate volumes: all void, all solid, one slice, one voxel,
// empty mask. Each yields defined values (or a clear refusal), never NaN/Inf.
#include "extremes_support.hpp"

using namespace voxpack;
using namespace voxpack::test;

namespace {

std::filesystem::path writeVolume(const TempDir& tmp, const std::string& name, std::int64_t nz,
                                  std::int64_t ny, std::int64_t nx, std::uint8_t fill,
                                  bool withMask, std::uint8_t maskFill = 1) {
  Bed bed;
  bed.indicator = Grid<std::uint8_t>(Lattice::isotropic(nz, ny, nx, 0.2), fill);
  if (withMask) bed.mask = Grid<std::uint8_t>(bed.indicator.lattice(), maskFill);
  const auto p = tmp / name;
  writeBed(p, bed);
  return p;
}

struct Case {
  const char* name;
  std::int64_t nz, ny, nx;
  std::uint8_t fill;
  bool mask;
  std::uint8_t maskFill;
  double porosity;  // expected; < 0 = undefined (null)
};

const Case kCases[] = {
    {"all_void", 24, 20, 20, 1, true, 1, 1.0},  {"all_solid", 24, 20, 20, 0, true, 1, 0.0},
    {"one_slice", 1, 20, 20, 1, false, 1, 1.0}, {"one_voxel", 1, 1, 1, 0, false, 1, 0.0},
    {"empty_mask", 8, 8, 8, 1, true, 0, -1.0},  {"one_row", 1, 1, 30, 1, false, 1, 1.0},
};

}  // namespace

class ExtremeVolumes : public ::testing::TestWithParam<Case> {};

TEST_P(ExtremeVolumes, InfoIsDefined) {
  TempDir tmp;
  const Case& c = GetParam();
  const auto bed = writeVolume(tmp, "bed.h5", c.nz, c.ny, c.nx, c.fill, c.mask, c.maskFill);
  const CliResult r = runVoxpack({"info", bed.string(), "--json"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_FALSE(hasNonFiniteToken(r.out));
  const auto j = nlohmann::json::parse(r.out);
  if (c.porosity < 0) {
    EXPECT_TRUE(j["porosity"].is_null());
  } else {
    EXPECT_DOUBLE_EQ(j["porosity"].get<double>(), c.porosity);
  }
}

TEST_P(ExtremeVolumes, StatsAreDefinedOrRefused) {
  TempDir tmp;
  const Case& c = GetParam();
  const auto bed = writeVolume(tmp, "bed.h5", c.nz, c.ny, c.nx, c.fill, c.mask, c.maskFill);
  const auto out = tmp / "stats.json";
  const auto csv = tmp / "csv";
  const CliResult r =
      runVoxpack({"stats", bed.string(), "-o", out.string(), "--csv", csv.string(), "--quiet"});
  expectCleanOutcome(r, c.name);
  if (r.exitCode != 0) {
    EXPECT_FALSE(std::filesystem::exists(out)) << "partial output after a refusal";
    return;
  }
  const auto j = readFiniteJson(out);
  if (c.porosity < 0) {
    EXPECT_TRUE(j["porosity"].is_null());
  } else {
    EXPECT_DOUBLE_EQ(j["porosity"].get<double>(), c.porosity) << c.name;
    EXPECT_DOUBLE_EQ(j["packing_density"].get<double>(), 1.0 - c.porosity) << c.name;
    // S2(0) = phi whenever S2 is defined.
    if (j.contains("s2") && j["s2"].is_object() && j["s2"]["s2"].is_array() &&
        !j["s2"]["s2"].empty() && !j["s2"]["s2"][0].is_null()) {
      EXPECT_NEAR(j["s2"]["s2"][0].get<double>(), c.porosity, 1e-9) << c.name;
    }
  }
  for (const auto& e : std::filesystem::directory_iterator(csv))
    EXPECT_FALSE(hasNonFiniteToken(slurp(e.path()))) << e.path();
}

INSTANTIATE_TEST_SUITE_P(Volumes, ExtremeVolumes, ::testing::ValuesIn(kCases),
                         [](const auto& info) { return std::string(info.param.name); });
