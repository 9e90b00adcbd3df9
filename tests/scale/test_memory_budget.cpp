// The memory budget of `stats` and `ingest` (issue 13): the estimate against the measured peak RSS
// of the child process (within 25 %), refusal in < 5 s with exit 2 and the estimate, and a run
// under `ulimit -v` of twice its estimate that completes.
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <vector>

#include "cli_runner.hpp"
#include "scale_fixtures.hpp"
#include "voxpack/core/bed_file.hpp"
#include "voxpack/core/json_util.hpp"
#include "voxpack/core/random.hpp"

using namespace voxpack;
using namespace voxpack::test;
using nlohmann::json;

namespace {

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

// Runs voxpack ARGS (stdout/stderr to /dev/null) and returns {exit code, peak RSS bytes}.
std::pair<int, std::uint64_t> runMeasured(const std::vector<std::string>& args,
                                          const std::string& stdoutPath = "/dev/null") {
  const pid_t pid = fork();
  if (pid == 0) {
    std::vector<char*> argv;
    argv.push_back(const_cast<char*>(VOXPACK_BINARY));
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    if (!freopen(stdoutPath.c_str(), "w", stdout)) _exit(126);
    execv(VOXPACK_BINARY, argv.data());
    _exit(127);
  }
  int status = 0;
  struct rusage ru {};
  wait4(pid, &status, 0, &ru);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : 128,
          static_cast<std::uint64_t>(ru.ru_maxrss) * 1024};
}

// A moderate bed: 8.6 M voxels with a mask, so the volume terms dominate the process base.
class BudgetBed : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new TempDir;
    ColumnBed o;
    o.nz = 224;
    o.ny = 196;
    o.nx = 196;
    o.radiusVox = 8;
    o.spacingMm = {0.1, 0.1, 0.1};
    writeBed(path(), sphereColumn(o));
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  static std::string path() { return (*dir_ / "bed.h5").string(); }
  static std::string out(const std::string& n) { return (*dir_ / n).string(); }
  static TempDir* dir_;

  // Runs stats, checks the estimate it reports against the measured peak.
  void expectEstimateWithin25Percent(std::vector<std::string> extra, const char* which,
                                     const std::string& only = "axial,radial,s2") {
    std::vector<std::string> args{"--quiet", "--threads", "1",  "stats",      path(),
                                  "--only",  only,        "-o", out("e.json")};
    args.insert(args.end(), extra.begin(), extra.end());
    const auto [rc, rss] = runMeasured(args);
    ASSERT_EQ(rc, 0);
    const json j = readJsonFile(out("e.json"));
    const double estimate = std::string(which) == "streamed"
                                ? j["streamed"]["estimate_bytes"].get<double>()
                                : j["memory_estimate_bytes"]["in_memory"].get<double>();
    EXPECT_EQ(j["memory_estimate_bytes"]["path"], which);
    const double ratio = estimate / static_cast<double>(rss);
    RecordProperty("estimate_over_rss", std::to_string(ratio));
    EXPECT_GT(ratio, 0.75) << "estimate " << estimate << " B, peak RSS " << rss << " B";
    EXPECT_LT(ratio, 1.25) << "estimate " << estimate << " B, peak RSS " << rss << " B";
  }
};
TempDir* BudgetBed::dir_ = nullptr;

}  // namespace

TEST_F(BudgetBed, InMemoryEstimateWithin25PercentOfPeakRss) {
  if (sanitized()) GTEST_SKIP() << "RSS under AddressSanitizer is not the program's";
  expectEstimateWithin25Percent({}, "in_memory");
}

TEST_F(BudgetBed, StreamedEstimateWithin25PercentOfPeakRss) {
  if (sanitized()) GTEST_SKIP() << "RSS under AddressSanitizer is not the program's";
  expectEstimateWithin25Percent({"--slab-voxels", "24"}, "streamed");
}

// Mean empty space: in memory one chunk of planes at the worst case of three cut axes (the
// mask leaves only z cut here); streamed, slabs of 24 planes with a halo of the whole bed.
TEST_F(BudgetBed, MesEstimatesWithin25PercentOfPeakRss) {
  if (sanitized()) GTEST_SKIP() << "RSS under AddressSanitizer is not the program's";
  expectEstimateWithin25Percent({}, "in_memory", "mes");
  expectEstimateWithin25Percent({"--slab-voxels", "24"}, "streamed", "mes");
}

// Over the limit, a statistic with no streamed path is refused up front: exit 2, the
// estimate and the limit, in well under 5 s, and no output file.
TEST_F(BudgetBed, OverBudgetWithoutStreamedPathIsRefusedFast) {
  const auto t0 = std::chrono::steady_clock::now();
  const CliResult r = runVoxpack(
      {"--memory-limit", "40M", "stats", path(), "--only", "s2,psd", "-o", out("refused.json")});
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_EQ(r.exitCode, 2) << r.err;
  EXPECT_EQ(countErrorLines(r.err), 1) << r.err;
  EXPECT_NE(r.err.find("needs about"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("memory limit is 40.00 MiB"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("psd cannot stream"), std::string::npos) << r.err;
  EXPECT_LT(s, 5.0);
  EXPECT_FALSE(std::filesystem::exists(out("refused.json")));
}

// Over the limit with streamable statistics: the command streams in slabs that fit and
// gives the in-memory numbers.
TEST_F(BudgetBed, OverBudgetStreamsAndAgrees) {
  const CliResult a =
      runVoxpack({"--quiet", "stats", path(), "--only", "axial,s2", "-o", out("mem.json")});
  ASSERT_EQ(a.exitCode, 0) << a.err;
  const json ja = readJsonFile(out("mem.json"));
  // A limit 20 % under the in-memory estimate: too small for the in-memory path, enough
  // for slabs (the base process and the halo planes are most of a slab's estimate here).
  const double limit = 0.8 * ja["memory_estimate_bytes"]["in_memory"].get<double>();
  const std::string limitArg = std::to_string(static_cast<long long>(limit));
  const CliResult b = runVoxpack({"--quiet", "--memory-limit", limitArg, "stats", path(), "--only",
                                  "axial,s2", "-o", out("lim.json")});
  ASSERT_EQ(b.exitCode, 0) << b.err;
  const json jb = readJsonFile(out("lim.json"));
  EXPECT_EQ(ja["memory_estimate_bytes"]["path"], "in_memory");
  EXPECT_EQ(jb["memory_estimate_bytes"]["path"], "streamed");
  EXPECT_LE(jb["streamed"]["estimate_bytes"].get<double>(), limit);
  EXPECT_EQ(ja["axial"], jb["axial"]);
  EXPECT_EQ(ja["s2"]["pairs"], jb["s2"]["pairs"]);
  EXPECT_EQ(ja["s2"]["s2"], jb["s2"]["s2"]);
}

// Under an address-space limit of twice the estimate, the command completes.
TEST_F(BudgetBed, CompletesUnderUlimitOfTwiceItsEstimate) {
  if (sanitized()) GTEST_SKIP() << "ulimit -v does not work under AddressSanitizer";
  const CliResult probe = runVoxpack({"--quiet", "--threads", "1", "stats", path(), "--only",
                                      "axial,radial,s2", "-o", out("probe.json")});
  ASSERT_EQ(probe.exitCode, 0) << probe.err;
  const double estimate =
      readJsonFile(out("probe.json"))["memory_estimate_bytes"]["in_memory"].get<double>();
  const auto kb = static_cast<long long>(2 * estimate / 1024);
  // One thread and two malloc arenas: the address space then holds the work, not the
  // per-thread reservations glibc and OpenMP make (docs/scale.md).
  const int rc =
      runShell("ulimit -v " + std::to_string(kb) + "; MALLOC_ARENA_MAX=2 OMP_NUM_THREADS=1 " +
               shellQuote(VOXPACK_BINARY) + " --quiet --threads 1 stats " + shellQuote(path()) +
               " --only axial,radial,s2 -o " + shellQuote(out("ulimit.json")));
  EXPECT_EQ(rc, 0) << "ulimit -v " << kb << " KB";
  EXPECT_TRUE(std::filesystem::exists(out("ulimit.json")));
}

// Ingest: the estimate of each pipeline against the child's peak RSS, in memory and
// streamed. The input is a 160³ uint8 raw NRRD of spheres on a grid (void dark, as in
// XMT) with Gaussian noise.
TEST(IngestBudget, EstimatesWithin25PercentOfPeakRss) {
  if (sanitized()) GTEST_SKIP() << "RSS under AddressSanitizer is not the program's";
  TempDir tmp;
  const std::int64_t n = 160;
  const auto nrrd = (tmp / "grey.nrrd").string();
  {
    std::ofstream f(nrrd, std::ios::binary);
    f << "NRRD0004\ntype: uint8\ndimension: 3\nsizes: " << n << ' ' << n << ' ' << n
      << "\nspacings: 0.1 0.1 0.1\nencoding: raw\n\n";
    RandomStream rng(3, 0);
    std::vector<char> plane(static_cast<std::size_t>(n * n));
    for (std::int64_t k = 0; k < n; ++k) {
      for (std::int64_t j = 0; j < n; ++j)
        for (std::int64_t i = 0; i < n; ++i) {
          const double dk = static_cast<double>(k % 20) - 9.5,
                       dj = static_cast<double>(j % 20) - 9.5,
                       di = static_cast<double>(i % 20) - 9.5;
          const double v = (dk * dk + dj * dj + di * di < 64 ? 180.0 : 60.0) + 15.0 * rng.normal();
          plane[static_cast<std::size_t>(j * n + i)] =
              static_cast<char>(static_cast<unsigned char>(std::clamp(v, 0.0, 255.0)));
        }
      f.write(plane.data(), static_cast<std::streamsize>(plane.size()));
    }
  }
  const std::vector<std::vector<std::string>> pipelines{
      {},                                                  // volume threshold, auto column
      {"--threshold", "otsu", "--column", "9.55,9.55,9"},  // Otsu, explicit column
      {"--threshold", "otsu", "--column", "none", "--slab-voxels", "24"}};  // streamed
  for (const auto& extra : pipelines) {
    std::vector<std::string> args{
        "--quiet", "--threads", "1", "ingest", nrrd, "-o", (tmp / "bed.h5").string(), "--json"};
    args.insert(args.end(), extra.begin(), extra.end());
    const std::string report = (tmp / "report.json").string();
    const auto [rc, rss] = runMeasured(args, report);
    ASSERT_EQ(rc, 0) << extra.size();
    const nlohmann::json j = readJsonFile(report);
    const double estimate = j.contains("streamed")
                                ? j["streamed"]["memory_estimate_bytes"].get<double>()
                                : j["memory_estimate_bytes"]["in_memory"].get<double>();
    const double ratio = estimate / static_cast<double>(rss);
    EXPECT_GT(ratio, 0.75) << "pipeline " << extra.size() << ": estimate " << estimate
                           << " B, peak RSS " << rss << " B";
    EXPECT_LT(ratio, 1.25) << "pipeline " << extra.size() << ": estimate " << estimate
                           << " B, peak RSS " << rss << " B";
    // Under an address-space limit of twice the estimate it completes (one thread and two
    // malloc arenas, as for stats above).
    const auto kb = static_cast<long long>(2 * estimate / 1024);
    std::string cmd = "ulimit -v " + std::to_string(kb) +
                      "; MALLOC_ARENA_MAX=2 OMP_NUM_THREADS=1 " + shellQuote(VOXPACK_BINARY);
    for (const auto& a : args) cmd += " " + shellQuote(a);
    EXPECT_EQ(runShell(cmd + " >/dev/null"), 0)
        << "pipeline " << extra.size() << " under ulimit -v " << kb << " KB";
  }
}
