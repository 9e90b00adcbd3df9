// The ingest calibration band shown beside the reference density.
#include <gtest/gtest.h>

#include <cmath>

#include "voxpack/compare/compare.hpp"

namespace voxpack::compare {
namespace {

TEST(CompareCalibration, BandIsDensityMinusBiasPlusMinusStd) {
  const nlohmann::json cal = {{"density_bias", 0.02}, {"density_bias_std", 0.005}, {"n", 4}};
  const nlohmann::json b = calibrationBand(cal, 0.65);
  ASSERT_TRUE(b.is_object());
  EXPECT_NEAR(b["density_corrected"].get<double>(), 0.63, 1e-12);
  EXPECT_NEAR(b["density_band"][0].get<double>(), 0.625, 1e-12);
  EXPECT_NEAR(b["density_band"][1].get<double>(), 0.635, 1e-12);
  EXPECT_EQ(b["n"], 4);  // the calibration's own keys are kept
}

TEST(CompareCalibration, NullWithoutABias) {
  EXPECT_TRUE(calibrationBand(nullptr, 0.6).is_null());
  EXPECT_TRUE(calibrationBand({{"density_bias", nullptr}}, 0.6).is_null());
  EXPECT_TRUE(calibrationBand({{"density_bias", 0.01}}, std::nan("")).is_null());
  // No std: a zero-width band at the corrected density.
  const nlohmann::json b = calibrationBand({{"density_bias", -0.01}}, 0.6);
  EXPECT_NEAR(b["density_band"][0].get<double>(), 0.61, 1e-12);
  EXPECT_NEAR(b["density_band"][1].get<double>(), 0.61, 1e-12);
}

}  // namespace
}  // namespace voxpack::compare
