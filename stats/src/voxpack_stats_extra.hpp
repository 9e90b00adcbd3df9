#pragma once
// Private: the statistics beyond axial/radial/s2 (mes, psd, chords, shadow, labels),
// assembled into computeStats' JSON, and their CSV files.
#include <filesystem>
#include <nlohmann/json.hpp>
#include <set>
#include <string>

#include "voxpack/core/bed.hpp"
#include "voxpack/core/progress.hpp"
#include "voxpack/stats/mes.hpp"
#include "voxpack/stats/profiles.hpp"
#include "voxpack/stats/s2.hpp"
#include "voxpack/stats/stats.hpp"
#include "voxpack/stats/structure.hpp"

namespace voxpack::stats {

/// Adds mes, psd, chords, shadow, coordination, orientation to `out` when in `which`.
void addExtraStatistics(nlohmann::json& out, const Bed& bed, const StatsOptions& options,
                        const std::set<std::string>& which, double diameterMm, Progress& progress);

/// The "mes" object of one method ("lattice-13" or "isotropic-cgal").
nlohmann::json mesJson(const MesResult& result, const char* method);

/// The "chords" object.
nlohmann::json chordsJson(const ChordLengths& chords);

/// Writes the CSV files of the statistics addExtraStatistics adds.
void writeExtraCsv(const nlohmann::json& stats, const std::filesystem::path& dir,
                   const std::string& prefix);

/// Throws InputError on bad statistics options (names, threads, non-finite numbers).
void validateStatsOptions(const StatsOptions& options);

/// Mean particle diameter (mm) from the shape specs of the table; 0 when unknown.
double inferDiameterMm(const ParticleTable& particles);

/// The keys every stats JSON starts with (version, options, lattice, porosity, diameter).
nlohmann::json statsHeaderJson(const Lattice& lattice, const StatsOptions& options,
                               const std::set<std::string>& which, const BedSummary& summary,
                               double diameterMm);

/// The "axial" object.
nlohmann::json axialJson(const AxialProfile& axial, double trimMm);

/// Radial options computeStats uses (slices of the trimmed axial range, core margin 2 d).
RadialOptions radialOptions(const StatsOptions& options, const AxialProfile& axial,
                            double diameterMm);

/// The "radial" object.
nlohmann::json radialJson(const RadialProfile& radial, double diameterMm);

/// S2 options computeStats uses.
S2Options s2Options(const StatsOptions& options);

/// The "s2" object.
nlohmann::json s2Json(const S2Result& s2, const StatsOptions& options);

}  // namespace voxpack::stats
