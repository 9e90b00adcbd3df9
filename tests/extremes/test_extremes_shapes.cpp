// Particles at the resolution extremes: 2-3 voxels across and 200 voxels across.
#include "extremes_support.hpp"

using namespace voxpack::test;

namespace {

nlohmann::json shapeJson(const std::vector<std::string>& extra) {
  std::vector<std::string> args = {"shape", "--json"};
  args.insert(args.end(), extra.begin(), extra.end());
  const CliResult r = runVoxpack(args);
  EXPECT_EQ(r.exitCode, 0) << r.err;
  EXPECT_FALSE(hasNonFiniteToken(r.out)) << r.out;
  return nlohmann::json::parse(r.out, nullptr, false);
}

}  // namespace

TEST(ExtremeShapes, TinySphereTwoAndAHalfVoxelsAcross) {
  const auto j = shapeJson({"--shape", "sphere:d=0.5", "--voxel-size", "0.2"});
  ASSERT_FALSE(j.is_discarded());
  // A 2.5-voxel sphere centred on a voxel holds the 7-voxel cross (centre + 6 faces) or a
  // few more; the error is large but finite and reported as such.
  EXPECT_GE(j["voxels"].get<int>(), 1);
  EXPECT_LE(j["voxels"].get<int>(), 27);
  EXPECT_TRUE(j["volume_rel_error"].is_number());
}

TEST(ExtremeShapes, TinyCylinderThreeVoxelsAcrossAnyOrientation) {
  for (const char* q : {"1,0,0,0", "0.9239,0.3827,0,0", "0.5,0.5,0.5,0.5"}) {
    const auto j =
        shapeJson({"--shape", "cylinder:d=0.6,l=0.6", "--voxel-size", "0.2", "--orientation", q});
    ASSERT_FALSE(j.is_discarded());
    EXPECT_GE(j["voxels"].get<int>(), 1) << q;
    EXPECT_TRUE(j["surface_rel_error"].is_number()) << q;
  }
}

// A sphere much smaller than a voxel, centred on a voxel centre, is that one voxel (the
// centre test), with a finite, huge relative error.
TEST(ExtremeShapes, SphereSmallerThanAVoxelIsOneVoxel) {
  const CliResult r =
      runVoxpack({"shape", "--shape", "sphere:d=0.05", "--voxel-size", "0.2", "--json"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_FALSE(hasNonFiniteToken(r.out)) << r.out;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["voxels"].get<int>(), 1);
  EXPECT_NEAR(j["volume_rel_error"].get<double>(),
              0.008 / (3.14159265358979 * 0.05 * 0.05 * 0.05 / 6) - 1, 1e-3);
}

TEST(ExtremeShapes, HugeSphereTwoHundredVoxelsAcross) {
  const auto j = shapeJson({"--shape", "sphere:d=20", "--voxel-size", "0.1"});
  ASSERT_FALSE(j.is_discarded());
  // Volume error of a 200-voxel digital sphere is ~1e-4 (it shrinks as 1/d^2 or faster).
  EXPECT_LT(std::abs(j["volume_rel_error"].get<double>()), 2e-3);
  // The voxel-face surface error tends to 50 % (paper, Fig. 2).
  EXPECT_NEAR(j["surface_rel_error"].get<double>(), 0.5, 0.05);
}
