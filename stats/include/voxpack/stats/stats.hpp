#pragma once
/// \file stats.hpp
/// Entry point of the statistics library: every statistic of a bed as one JSON object
/// with the keys SPEC.md fixes (porosity, packing_density, axial, radial, s2, mes, ...).
/// The compare module and `voxpack stats` both call computeStats.

#include <nlohmann/json.hpp>
#include <set>
#include <string>

#include "voxpack/core/bed.hpp"
#include "voxpack/core/progress.hpp"

namespace voxpack::stats {

/// Options of computeStats (each statistic's own options live in its own struct).
struct StatsOptions {
  /// Statistics to compute; empty = all. Names: axial, radial, s2, mes, psd, chords,
  /// shadow, coordination, orientation.
  std::set<std::string> only;
  /// Particle diameter (mm) used for end trimming and wall distances; <= 0 = infer from
  /// the bed's particle table when present, else unknown.
  double particleDiameterMm = 0;
  /// Axial profile: mm trimmed at each bed end; < 0 = default (2 particle diameters when
  /// known, else none).
  double trimMm = -1;
  /// Largest S2 lag (mm); <= 0 = default.
  double s2MaxLagMm = 0;
  /// Worker threads (>= 1).
  int threads = 1;
};

/// Computes the requested statistics of `bed`. The result carries "voxpack_version" and
/// "options"; undefined values are null, never NaN. Throws InputError on bad options.
nlohmann::json computeStats(const Bed& bed, const StatsOptions& options,
                            Progress& progress = nullProgress());

}  // namespace voxpack::stats
