#pragma once
/// \file compare.hpp
/// Compares candidate beds with a reference bed: the statistics of each (stats module)
/// and their distances (paper Table 1 and Figs. 4-10). Beds of different voxel sizes
/// are compared in mm.

#include <array>
#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "voxpack/compare/distances.hpp"
#include "voxpack/compare/flow_compare.hpp"
#include "voxpack/core/bed.hpp"
#include "voxpack/core/progress.hpp"
#include "voxpack/stats/stats.hpp"

namespace voxpack::compare {

/// The statistics compare needs (axial, radial, s2, mes), single-threaded.
stats::StatsOptions defaultStatsOptions();

/// Where the packed region of a bed lies along z.
struct PackedRegion {
  std::int64_t firstSlice = 0;  ///< first slice kept
  std::int64_t lastSlice = -1;  ///< last slice kept (inclusive); < firstSlice = empty
  double fromMm = 0.0;          ///< z of the first slice kept (mm)
  double toMm = 0.0;            ///< z of the last slice kept (mm)
  double peakDensity = 0.0;     ///< largest packing density of the partly solid slices
  bool cropped = false;         ///< true when slices were dropped
};

/// The slab of slices holding the packing: from the first to the last slice whose packing
/// density inside the mask is >= fraction x the peak over partly solid slices, skipping
/// fully solid slices (the end walls an imaged column shows). Without it the empty
/// headspace above a bed and the walls enter porosity, S2 and the mean empty space.
PackedRegion packedRegion(const Bed& bed, double fraction);

/// A copy of `bed` restricted to slices [first, last] (lattice origin moved accordingly).
Bed cropSlices(const Bed& bed, std::int64_t first, std::int64_t last);

/// Options of the comparison.
struct CompareOptions {
  /// Statistics options, the same for every bed so that their numbers are comparable.
  stats::StatsOptions stats = defaultStatsOptions();
  /// Packed-region crop: slices denser than this fraction of the bed's densest slice
  /// density (and not fully solid) bound the region every statistic is computed in;
  /// 0 = no crop (0..1).
  double bedRegionFraction = 0.5;
  /// KS test settings for the axial slice densities.
  KsOptions ks;
  /// Common grid of wall distance (mm) for the radial RMSE; step <= 0 = coarser bed's.
  CurveRmseOptions radialGrid;
  /// Common lag grid (mm) for the S2 RMSE; step <= 0 = coarser bed's.
  CurveRmseOptions s2Grid;
  /// Flow part (compare --flow): off by default.
  CompareFlowOptions flow;
};

/// Distances of one candidate's statistics to the reference's (NaN when undefined).
struct Distances {
  double densityMean = 0.0;     ///< candidate's mean slice packing density (axial.mean)
  double densityStd = 0.0;      ///< candidate's std of slice packing densities (axial.std)
  double densityRelDiff = 0.0;  ///< (mean_cand - mean_ref) / mean_ref, signed
  KsTest axialKs;               ///< two-sample KS test of the slice densities
  CurveRmse radial;             ///< RMSE of radial density vs wall distance (mm)
  CurveRmse s2;                 ///< RMSE of S2 vs lag (mm)
  double mesKs = 0.0;           ///< KS distance of the mean-empty-space distributions
};

/// Distances between two statistics objects of the shape computeStats returns
/// (axial{z_mm,density,mean,std}, radial{r_mm,density,radius_mm[,wall_distance_mm]},
/// s2{h_mm,s2}, mes{bins_mm,pdf}). A missing block gives NaN for its distances.
Distances computeDistances(const nlohmann::json& referenceStats,
                           const nlohmann::json& candidateStats,
                           const CompareOptions& options = {});

/// The SPEC summary entry of one candidate ("name", "density_mean", "density_std",
/// "density_rel_diff", "axial_ks_p", "radial_rmse", "s2_rmse", "mes_ks") plus details
/// (KS statistic and method, grids). NaN becomes null.
nlohmann::json distancesToJson(const std::string& name, const Distances& d);

/// Wall distance (mm) of each radial bin: the stats' wall_distance_mm when present,
/// else radius_mm - r_mm.
std::vector<double> wallDistanceMm(const nlohmann::json& radial);

/// A 2D float image with its physical extent, for the figures.
struct Image2D {
  std::int64_t rows = 0;       ///< first index (vertical in the figure)
  std::int64_t cols = 0;       ///< second index (horizontal)
  std::vector<double> values;  ///< rows*cols, row-major; NaN = outside the mask
  double rowFromMm = 0.0;      ///< centre of row 0 (mm)
  double rowToMm = 0.0;        ///< centre of the last row (mm)
  double colFromMm = 0.0;      ///< centre of column 0 (mm)
  double colToMm = 0.0;        ///< centre of the last column (mm)
  std::string rowAxis;         ///< "z" or "y"
  std::string colAxis;         ///< "x"
};

/// Shadow image (paper Fig. 7): mean solid fraction along y inside the mask, on the
/// (z, x) plane; NaN where the line holds no masked voxel.
Image2D shadowImage(const Bed& bed);

/// Horizontal slice of the void structure (paper Fig. 8) at the middle of the masked z
/// range: 1 void, 0 solid, NaN outside the mask.
Image2D voidSlice(const Bed& bed);

/// Where a bed came from, read from its provenance.
struct BedOrigin {
  std::string kind;        ///< "simulated", "synthetic image", "imaged" or "unknown"
  std::string detail;      ///< e.g. "pack --mode dem", "phantom mri"
  bool synthetic = false;  ///< true unless the bed was imaged from a real sample
};

/// Classifies a bed from its provenance (pack -> simulated; phantom anywhere in the
/// chain -> synthetic image; ingest -> imaged). `inputHeaderText` is the text of the
/// ingested image's header when known (an NRRD written by `voxpack phantom` says so).
BedOrigin classifyOrigin(const nlohmann::json& provenance, const std::string& inputHeaderText = {});

/// Everything the report needs about one bed.
struct BedEntry {
  std::string name;                   ///< display name (unique within a comparison)
  std::filesystem::path path;         ///< bed file
  BedOrigin origin;                   ///< simulated / synthetic / imaged
  nlohmann::json stats;               ///< computeStats result
  Image2D shadow;                     ///< Fig. 7
  Image2D slice;                      ///< Fig. 8
  std::array<double, 3> spacingMm{};  ///< voxel size (z, y, x)
  PackedRegion region;                ///< slices the statistics were computed on
  /// The ingest calibration of the bed's provenance ("calibration": density_bias, ...),
  /// or null when the bed has none.
  nlohmann::json calibration = nullptr;
  /// The flow record of the packed region (flowRecord), or null without --flow.
  nlohmann::json flow = nullptr;
};

/// The band of the reference's true density implied by an ingest calibration: the mean
/// slice density minus the expected bias (segmented - true), +- one bias std; null
/// when `calibration` lacks density_bias or `densityMean` is not finite.
nlohmann::json calibrationBand(const nlohmann::json& calibration, double densityMean);

/// Result of compareBedFiles.
struct Comparison {
  BedEntry reference;                 ///< the reference bed
  std::vector<BedEntry> candidates;   ///< the candidates, in input order
  std::vector<Distances> distances;   ///< distances[i] of candidates[i] to the reference
  std::vector<std::string> warnings;  ///< what could not be computed and why
};

/// Reads each bed file in turn (one bed in memory at a time), computes its statistics
/// and images, and the distances of every candidate to the reference. Names are file
/// stems, made unique with their parent folder when stems clash. Throws IoError /
/// FormatError for unreadable beds, InputError when no candidate is given.
Comparison compareBedFiles(const std::filesystem::path& reference,
                           const std::vector<std::filesystem::path>& candidates,
                           const CompareOptions& options, Progress& progress = nullProgress());

}  // namespace voxpack::compare
