#pragma once
/// \file stats.hpp
/// Entry point of the statistics library: every statistic of a bed as one JSON object
/// with the keys docs/interfaces.md fixes (porosity, packing_density, axial, radial, s2, mes, ...).
/// The compare module and `voxpack stats` both call computeStats.

#include <cstdint>
#include <filesystem>
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
  /// Largest S2 lag (mm); <= 0 = default (a quarter of the smallest extent, <= 64 voxels).
  double s2MaxLagMm = 0;
  /// S2 in single precision (faster, pair counts off by ~1; docs/stats.md).
  bool s2Float = false;
  /// Streamed S2: edge (voxels) of the y-x tiles of each slab; 0 = chosen from the memory
  /// budget (whole planes when they fit). The in-memory path ignores it.
  std::int64_t s2TileVoxels = 0;
  /// Radial annulus width (mm); <= 0 = one voxel.
  double radialBinMm = 0;
  /// Mean empty space method: "lattice" (13 directions, default), "isotropic" (CGAL ray
  /// shooting on a sample of void voxels), or "both".
  std::string mesMethod = "lattice";
  /// Void voxels sampled by the isotropic mean-empty-space path (>= 1).
  std::int64_t mesSamples = 20000;
  /// Directions per sampled voxel in the isotropic path (>= 1).
  int mesDirections = 64;
  /// Seed of the random choices (isotropic sample and directions).
  std::uint64_t seed = 1;
  /// Worker threads (>= 1).
  int threads = 1;
};

/// Names accepted in StatsOptions::only.
const std::set<std::string>& statisticNames();

/// Computes the requested statistics of `bed`. The result carries "voxpack_version" and
/// "options"; undefined values are null, never NaN. Throws InputError on bad options.
nlohmann::json computeStats(const Bed& bed, const StatsOptions& options,
                            Progress& progress = nullProgress());

/// Writes one CSV per statistic present in `stats` into `dir` (created), named
/// `<prefix>axial.csv` (z_mm,density), `<prefix>radial.csv` (r_mm,wall_distance_mm,density),
/// `<prefix>s2.csv` (h_mm,s2), `<prefix>mes.csv` (bin_mm,pdf), and the others in
/// docs/stats.md. Null values are written as empty fields. Throws IoError.
void writeStatsCsv(const nlohmann::json& stats, const std::filesystem::path& dir,
                   const std::string& prefix = "");

/// Writes the shadow images of `stats` (if present) as grey PNGs
/// `<prefix>shadow_{x,y,z}.png` into `dir`. Throws IoError.
void writeShadowPngs(const nlohmann::json& stats, const std::filesystem::path& dir,
                     const std::string& prefix = "");

}  // namespace voxpack::stats
