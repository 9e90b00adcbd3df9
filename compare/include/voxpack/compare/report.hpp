#pragma once
/// \file report.hpp
/// Writes a comparison to a folder: summary.json (SPEC keys), CSV files, text arrays,
/// PNG figures drawn by matplotlib from those files, and a self-contained index.html.

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "voxpack/compare/compare.hpp"
#include "voxpack/core/progress.hpp"

namespace voxpack::compare {

/// Options of writeReport.
struct ReportOptions {
  /// Python interpreter with numpy and matplotlib (Debian's, not the first on PATH).
  std::string python = "/usr/bin/python3";
  /// Figure script on disk; empty = the copy built into voxpack.
  std::filesystem::path figureScript;
  /// False = numbers and CSV files only (no python run).
  bool figures = true;
  /// Extra top-level keys for summary.json (version, inputs, options...).
  nlohmann::json summaryExtras = nlohmann::json::object();
};

/// What writeReport produced.
struct ReportResult {
  std::filesystem::path summaryJson;           ///< DIR/summary.json
  std::filesystem::path indexHtml;             ///< DIR/index.html
  std::vector<std::filesystem::path> figures;  ///< PNG files written
  std::vector<std::string> warnings;           ///< e.g. no matplotlib: figures skipped
};

/// The summary object: {"reference", "candidates": [...]} plus "reference_stats",
/// "candidate_stats", "beds" and `extras`. Never NaN (null instead).
nlohmann::json summaryJson(const Comparison& c, const nlohmann::json& extras = {});

/// The table of the comparison as fixed-width text (one row per bed, paper Table 1 style).
std::string formatTable(const Comparison& c);

/// Creates `dir` when missing and writes every file atomically. Throws IoError when the
/// folder cannot be created or written. A missing python/matplotlib is a warning, not an
/// error: the numbers, CSV files and index.html (without figures) still come out.
ReportResult writeReport(const std::filesystem::path& dir, const Comparison& c,
                         const ReportOptions& options, Progress& progress = nullProgress());

/// Base64 (RFC 4648, with padding) of a byte string, for data: URIs.
std::string base64(const std::string& bytes);

/// The figure script built into voxpack (compare/report/make_figures.py).
const char* builtinFigureScript();

}  // namespace voxpack::compare
