// Hostile bed files (issue 14): tiny files whose headers ask for huge work are refused in
// seconds with exit 2 and one `error:` line naming the file and the limit.
#include <gtest/gtest.h>

#include <chrono>
#include <limits>
#include <nlohmann/json.hpp>

#include "cli_runner.hpp"
#include "scale_fixtures.hpp"
#include "voxpack/core/bed_file.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/core/json_util.hpp"

using namespace voxpack;
using namespace voxpack::test;

namespace {

// Runs voxpack and checks a refusal: exit 2, one error line holding `file` and `needle`,
// within `seconds`.
void expectRefusal(const std::vector<std::string>& args, const std::string& file,
                   const std::string& needle, double seconds = 5) {
  const auto t0 = std::chrono::steady_clock::now();
  const CliResult r = runVoxpack(args);
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_EQ(r.exitCode, 2) << r.err;
  EXPECT_EQ(countErrorLines(r.err), 1) << r.err;
  EXPECT_NE(r.err.find(file), std::string::npos) << r.err;
  EXPECT_NE(r.err.find(needle), std::string::npos) << r.err;
  EXPECT_LT(s, seconds) << "refusal took " << s << " s";
}

bool sanitized() {
#if defined(__SANITIZE_ADDRESS__)
  return true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
  return true;
#endif
#endif
  return false;
}

}  // namespace

// 2^21 per axis is 2^63 voxels: the product used to wrap or reach std::vector's max_size.
TEST(HostileBeds, DimsProductOverflowIsRefused) {
  TempDir tmp;
  const auto f = (tmp / "overflow.h5").string();
  {
    HostileFile h(f);
    const hsize_t n = hsize_t{1} << 21;
    h.empty("/indicator", {n, n, n}, H5T_STD_U8LE);
  }
  EXPECT_LT(std::filesystem::file_size(f), 100000u);
  expectRefusal({"info", f}, f, "limit of 2^44 voxels");
  expectRefusal({"stats", f, "-o", (tmp / "s.json").string()}, f, "limit of 2^44 voxels");
  EXPECT_THROW(readBedHeader(f), FormatError);
}

// A 3000³ indicator in a file of a few KB: the estimate is checked against the budget
// before anything is allocated (it used to end in "out of memory", exit 1).
TEST(HostileBeds, HugeIndicatorInTinyFileIsRefusedBeforeAllocating) {
  TempDir tmp;
  const auto f = (tmp / "huge.h5").string();
  {
    HostileFile h(f);
    h.empty("/indicator", {3000, 3000, 3000}, H5T_STD_U8LE);
  }
  EXPECT_LT(std::filesystem::file_size(f), 100000u);
  expectRefusal({"--memory-limit", "1G", "stats", f, "-o", (tmp / "s.json").string()}, f,
                "memory limit is 1.00 GiB");
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_THROW(readBed(f, MemoryBudget{1ull << 30}), ResourceError);
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 5.0);
  EXPECT_FALSE(std::filesystem::exists(tmp / "s.json"));
}

// One /labels voxel of id 0xFFFFFFFF in a 20³ bed: coordination numbers used to size
// per-label tables by the largest id (38 GB). Tables are now indexed by the labels present.
TEST(HostileBeds, HugeLabelIdDoesNotSizeTables) {
  if (sanitized()) GTEST_SKIP() << "ulimit -v does not work under AddressSanitizer";
  TempDir tmp;
  Bed bed;
  bed.indicator = Grid<std::uint8_t>(Lattice::isotropic(20, 20, 20, 0.1), 1);
  bed.labels = Grid<std::uint32_t>(bed.indicator.lattice(), 0);
  for (std::int64_t i = 5; i < 8; ++i) {
    bed.indicator(10, 10, i) = 0;
    (*bed.labels)(10, 10, i) = i == 7 ? 0xFFFFFFFFu : 3u;
  }
  const auto f = (tmp / "labels.h5").string();
  writeBed(f, bed);
  const auto out = (tmp / "s.json").string();
  // 2 GB of address space: the old per-label table alone needed 4 G x 9 bytes.
  const int rc = runShell("ulimit -v 2000000; " + shellQuote(VOXPACK_BINARY) + " --quiet stats " +
                          shellQuote(f) + " --only coordination -o " + shellQuote(out));
  ASSERT_EQ(rc, 0);
  const auto j = readJsonFile(out);
  EXPECT_EQ(j["coordination"]["particles"], 2);
  EXPECT_EQ(j["coordination"]["contacts"], 1);
  EXPECT_EQ(j["coordination"]["mean"], 1.0);
}

// /particles/position_mm of 2^40 rows x 3: rows x cols x 8 bytes is refused before any
// allocation (it could wrap), naming the dataset and the limit.
TEST(HostileBeds, ParticleRowsOverflowIsRefused) {
  TempDir tmp;
  const auto f = (tmp / "rows.h5").string();
  {
    HostileFile h(f);
    h.full<std::uint8_t>("/indicator", {4, 4, 4}, H5T_STD_U8LE, H5T_NATIVE_UINT8,
                         std::vector<std::uint8_t>(64, 1));
    h.empty("/particles/position_mm", {hsize_t{1} << 40, 3}, H5T_IEEE_F64LE);
  }
  expectRefusal({"info", f}, f, "/particles/position_mm declares 1099511627776 rows");
  expectRefusal({"stats", f, "-o", (tmp / "s.json").string()}, f, "limit of 4294967296");
}

// 2^31 rows fit the row limit but not a 1 GiB budget: refused with the estimate.
TEST(HostileBeds, ParticleTableOverBudgetIsRefused) {
  TempDir tmp;
  const auto f = (tmp / "table.h5").string();
  {
    HostileFile h(f);
    h.full<std::uint8_t>("/indicator", {4, 4, 4}, H5T_STD_U8LE, H5T_NATIVE_UINT8,
                         std::vector<std::uint8_t>(64, 1));
    h.empty("/particles/position_mm", {hsize_t{1} << 31, 3}, H5T_IEEE_F64LE);
  }
  expectRefusal({"--memory-limit", "1G", "info", f}, f, "memory limit is 1.00 GiB");
  expectRefusal({"--memory-limit", "1G", "stats", f, "-o", (tmp / "s.json").string()}, f,
                "memory limit is 1.00 GiB");
}

// Orientations must be finite unit quaternions.
TEST(HostileBeds, OrientationsNotFiniteOrNotUnitAreRefused) {
  TempDir tmp;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (const auto& [name, q, needle] :
       {std::tuple{"nan.h5", std::vector<double>{1, 0, 0, 0, nan, 0, 0, 1}, "non-finite"},
        std::tuple{"long.h5", std::vector<double>{1, 0, 0, 0, 2, 0, 0, 0}, "not a unit quaternion"},
        std::tuple{"zero.h5", std::vector<double>{0, 0, 0, 0, 1, 0, 0, 0},
                   "not a unit quaternion"}}) {
    const auto f = (tmp / name).string();
    {
      HostileFile h(f);
      h.full<std::uint8_t>("/indicator", {4, 4, 4}, H5T_STD_U8LE, H5T_NATIVE_UINT8,
                           std::vector<std::uint8_t>(64, 1));
      h.full<double>("/particles/position_mm", {2, 3}, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE,
                     {0.1, 0.1, 0.1, 0.2, 0.2, 0.2});
      h.full<double>("/particles/orientation", {2, 4}, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, q);
    }
    expectRefusal({"info", f}, f, needle);
    expectRefusal({"stats", f, "--only", "orientation", "-o", (tmp / "s.json").string()}, f,
                  needle);
    EXPECT_THROW(readBed(f), FormatError) << name;
  }
}
