// `voxpack --version` and `voxpack info`, including every bad-input case of the bed file.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "cli_runner.hpp"

using namespace voxpack::test;

namespace {

// Writes the h5py beds once per test binary run.
class H5pyBeds : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new TempDir();
    const std::string cmd =
        std::string(VOXPACK_PYTHON) + " " +
        shellQuote(std::string(VOXPACK_SOURCE_DIR) + "/tests/cli/make_h5py_beds.py") + " " +
        shellQuote(dir_->path().string()) + " > " +
        shellQuote((dir_->path() / "porosity.txt").string());
    ASSERT_EQ(runShell(cmd), 0) << cmd;
    std::ifstream f(dir_->path() / "porosity.txt");
    f >> porosity_ >> porosity_unmasked_;
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  static std::string file(const std::string& name) { return (dir_->path() / name).string(); }
  static void expectRefused(const std::string& name, const std::string& needle) {
    const CliResult r = runVoxpack({"info", file(name)});
    EXPECT_EQ(r.exitCode, 2) << name << ": " << r.err;
    EXPECT_EQ(countErrorLines(r.err), 1) << r.err;
    EXPECT_NE(r.err.find(needle), std::string::npos) << "stderr: " << r.err;
    EXPECT_TRUE(r.out.empty());
  }
  static inline TempDir* dir_ = nullptr;
  static inline double porosity_ = -1;
  static inline double porosity_unmasked_ = -1;  // of the indicator without the mask
};

}  // namespace

TEST(Cli, VersionPrintsVersion) {
  const CliResult r = runVoxpack({"--version"});
  EXPECT_EQ(r.exitCode, 0);
  EXPECT_EQ(r.out.rfind("voxpack ", 0), 0u) << r.out;
}

TEST(Cli, UnknownOptionIsUsageError) {
  const CliResult r = runVoxpack({"info", "--no-such-option", "x.h5"});
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_EQ(countErrorLines(r.err), 1) << r.err;
}

TEST(Cli, HelpForEveryCommand) {
  for (const char* c : {"info", "shape", "pack", "ingest", "phantom", "stats", "compare"}) {
    const CliResult r = runVoxpack({c, "--help"});
    EXPECT_EQ(r.exitCode, 0) << c;
    EXPECT_NE(r.out.find(c), std::string::npos) << c;
  }
}

TEST_F(H5pyBeds, InfoJsonReportsExactPorosityOfH5pyFile) {
  const CliResult r = runVoxpack({"info", file("good.h5"), "--json"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["porosity"].get<double>(), porosity_);  // exact: same integer ratio
  EXPECT_DOUBLE_EQ(j["packing_density"].get<double>(), 1.0 - porosity_);
  EXPECT_EQ(j["dims"], nlohmann::json({12, 10, 9}));
  EXPECT_EQ(j["spacing_mm"], nlohmann::json({0.25, 0.2, 0.2}));
  EXPECT_EQ(j["particles"], 2);
  EXPECT_EQ(j["provenance"]["writer"], "h5py by hand");
  EXPECT_TRUE(j["has_mask"].get<bool>());
}

TEST_F(H5pyBeds, InfoTextRuns) {
  const CliResult r = runVoxpack({"info", file("good.h5")});
  EXPECT_EQ(r.exitCode, 0) << r.err;
  EXPECT_NE(r.out.find("porosity"), std::string::npos);
}

TEST_F(H5pyBeds, NonexistentPath) { expectRefused("missing.h5", "no such file"); }
TEST_F(H5pyBeds, TextFileNamedH5) { expectRefused("text.h5", "not an HDF5 file"); }
TEST_F(H5pyBeds, TruncatedHdf5) { expectRefused("truncated.h5", "truncated.h5"); }
TEST_F(H5pyBeds, NoIndicator) { expectRefused("no_indicator.h5", "/indicator is missing"); }
TEST_F(H5pyBeds, IndicatorWrongType) { expectRefused("float_indicator.h5", "integer"); }
TEST_F(H5pyBeds, IndicatorWrongRank) { expectRefused("rank2_indicator.h5", "rank 3"); }
TEST_F(H5pyBeds, ValuesOtherThanZeroOne) { expectRefused("values.h5", "value 2"); }
TEST_F(H5pyBeds, MaskShapeDiffers) { expectRefused("mask_shape.h5", "/mask shape"); }
TEST_F(H5pyBeds, SpacingZero) { expectRefused("spacing_zero.h5", "spacing_mm"); }
TEST_F(H5pyBeds, SpacingNaN) { expectRefused("spacing_nan.h5", "non-finite"); }
TEST_F(H5pyBeds, WrongFormatAttribute) { expectRefused("wrong_format.h5", "voxpack-bed"); }
// A filter libhdf5 lacks is named, not reported as a corrupt file ("cannot read").
TEST_F(H5pyBeds, LzfCompressionIsNamed) { expectRefused("lzf.h5", "filter lzf (id 32000)"); }
// Shuffle + gzip in chunks of 5 x 3 x 4 (voxpack inflates them itself): the exact porosity.
TEST_F(H5pyBeds, ShuffleGzipInOddChunksReadsExactly) {
  const CliResult r = runVoxpack({"info", file("shuffle_gzip.h5"), "--json"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  const double expected = porosity_unmasked_;
  EXPECT_EQ(j["porosity"].get<double>(), expected);
}
