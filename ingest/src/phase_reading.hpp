#pragma once
// Pieces of the in-memory pipeline (pipeline.cpp) the streamed path shares (not public):
// the phase levels as the volume threshold reads them, and the column's provenance.
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>

#include "voxpack/core/grid.hpp"
#include "voxpack/ingest/column.hpp"
#include "voxpack/ingest/ingest.hpp"
#include "voxpack/ingest/phases.hpp"

namespace voxpack::ingest {

/// The noise and the two phases' levels of a grey image and its preliminary segmentation.
struct PhaseReading {
  PhaseLevels levels;        ///< fitPhaseLevels with the deep levels as hints
  DeepLevel deep[2];         ///< solid, void: read deep inside each phase
  double interiorSigma = 0;  ///< noise sigma from voxel pairs deep in the void phase
};

/// Reads the noise deep in the void, each phase's level deep inside it (a ball of 3 blur
/// sigma, 3.5 to 15 voxels), and fits the levels with those as hints, over `region` (null:
/// everywhere). `tail`: each deep level from its far tail (--phase-level tail).
PhaseReading readPhaseLevels(const Grid<float>& raw, const Grid<std::uint8_t>& prelim,
                             const Grid<std::uint8_t>* region, double blurVoxels, bool voidBright,
                             NoiseModel model, bool tail, int threads);

/// The stderr warning when `--column auto` found no column (`column.note` says why).
std::string noColumnWarning(const ColumnFit& column);

/// The provenance's "column" record of a fitted, given or absent column.
nlohmann::json columnJson(const ColumnFit& column, ColumnMode mode);

}  // namespace voxpack::ingest
