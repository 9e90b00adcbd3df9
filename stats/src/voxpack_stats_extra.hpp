#pragma once
// Private: the statistics beyond axial/radial/s2 (mes, psd, chords, shadow, labels),
// assembled into computeStats' JSON, and their CSV files.
#include <filesystem>
#include <nlohmann/json.hpp>
#include <set>
#include <string>

#include "voxpack/core/bed.hpp"
#include "voxpack/core/progress.hpp"
#include "voxpack/stats/stats.hpp"

namespace voxpack::stats {

/// Adds mes, psd, chords, shadow, coordination, orientation to `out` when in `which`.
void addExtraStatistics(nlohmann::json& out, const Bed& bed, const StatsOptions& options,
                        const std::set<std::string>& which, double diameterMm, Progress& progress);

/// Writes the CSV files of the statistics addExtraStatistics adds.
void writeExtraCsv(const nlohmann::json& stats, const std::filesystem::path& dir,
                   const std::string& prefix);

}  // namespace voxpack::stats
