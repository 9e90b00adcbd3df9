#pragma once
// Shared checks of the extremes suite: a run either succeeds with finite outputs or is
// refused cleanly (exit 2, one "error:" line) -- never a crash, never NaN/Inf.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>

#include "cli_runner.hpp"
#include "voxpack/core/bed_file.hpp"

namespace voxpack::test {

/// Exit 0, or exit 2 with exactly one error line; never a signal or exit 1.
inline void expectCleanOutcome(const CliResult& r, const std::string& what) {
  EXPECT_TRUE(r.exitCode == 0 || r.exitCode == 2)
      << what << ": exit " << r.exitCode << "\nstderr: " << r.err;
  if (r.exitCode == 2) {
    EXPECT_EQ(countErrorLines(r.err), 1) << what << ": " << r.err;
  }
}

/// Exit 2, one error line, and `needle` in it.
inline void expectRefusal(const CliResult& r, const std::string& needle, const std::string& what) {
  EXPECT_EQ(r.exitCode, 2) << what << "\nstderr: " << r.err;
  EXPECT_EQ(countErrorLines(r.err), 1) << what << ": " << r.err;
  if (!needle.empty()) {
    EXPECT_NE(r.err.find(needle), std::string::npos) << what << ": " << r.err;
  }
}

/// Text of a file.
inline std::string slurp(const std::filesystem::path& p) {
  std::ifstream f(p);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

/// True when the text holds a bare NaN/Inf value (what a broken JSON or CSV writer emits):
/// a token after ':', '[', ',' or at a line start, not a word such as "info" or "nano".
inline bool hasNonFiniteToken(const std::string& text) {
  static const std::regex bad(R"((^|[:\[,])\s*[-+]?(nan|NaN|NAN|inf|Inf|INF|infinity|Infinity)\b)",
                              std::regex::multiline);
  return std::regex_search(text, bad);
}

/// Parses a JSON file strictly (NaN would not parse) and checks every number is finite.
inline nlohmann::json readFiniteJson(const std::filesystem::path& p) {
  const std::string text = slurp(p);
  EXPECT_FALSE(hasNonFiniteToken(text)) << p;
  auto j = nlohmann::json::parse(text, nullptr, false);
  EXPECT_FALSE(j.is_discarded()) << p << " is not valid JSON";
  return j;
}

/// Every particle of a bed file is finite and its labels match the table size.
inline void expectSaneBed(const std::filesystem::path& p) {
  const Bed bed = readBed(p);
  for (const auto& x : bed.particles.positionMm) EXPECT_TRUE(x.allFinite());
  for (const auto& q : bed.particles.orientation) {
    EXPECT_TRUE(q.coeffs().allFinite());
    EXPECT_NEAR(q.norm(), 1.0, 1e-6);
  }
  if (bed.labels && bed.mask) {
    // No solid (labelled) voxel outside the container.
    for (std::size_t n = 0; n < bed.labels->size(); ++n)
      if ((*bed.labels)[n] != 0) {
        ASSERT_EQ((*bed.mask)[n], 1) << "particle voxel outside the container in " << p;
      }
  }
}

}  // namespace voxpack::test
