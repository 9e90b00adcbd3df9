#pragma once
/// \file flow_compare.hpp
/// The flow part of a comparison (compare --flow): each bed's permeability, hydraulic
/// tortuosity, wall-flow share and radial axial-velocity profile (flow module), and each
/// candidate's ratios and differences against the reference (docs/compare.md).

#include <nlohmann/json.hpp>
#include <string>

#include "voxpack/core/bed.hpp"
#include "voxpack/core/memory.hpp"
#include "voxpack/core/progress.hpp"
#include "voxpack/flow/flow.hpp"

namespace voxpack::compare {

struct Comparison;

/// Options of the flow part (off unless `enabled`).
struct CompareFlowOptions {
  bool enabled = false;      ///< run the flow solver on every bed
  flow::FlowOptions solver;  ///< solver and boundary settings, the same for every bed
  MemoryBudget memory;       ///< budget of each solver run (one bed at a time)
};

/// Runs the flow analysis of one (packed-region) bed and keeps the record compare needs:
/// status, steps, converged, porosity, permeability_mm2, permeability_over_d2,
/// tortuosity_hydraulic, wall_flow_share, wall_area_share, particle_diameter_mm and
/// radial_profile {wall_distance_mm, axial_velocity_over_superficial}.
nlohmann::json flowRecord(const Bed& bed, const CompareFlowOptions& options,
                          Progress& progress = nullProgress());

/// Ratios and differences of a candidate's flow record against the reference's:
/// permeability_ratio (cand / ref), tortuosity_diff and wall_flow_share_diff (cand - ref);
/// null where either side has no number (blocked, not computed).
nlohmann::json flowDistances(const nlohmann::json& reference, const nlohmann::json& candidate);

/// The "flow" block of summary.json: {"reference": record, "candidates": [{"name", record
/// keys, distances}]}; null when the comparison has no flow records.
nlohmann::json flowSummary(const Comparison& c);

/// flow.csv: bed,wall_distance_mm,axial_velocity_over_superficial (the figure's data).
std::string flowProfileCsv(const Comparison& c);

/// The flow table of index.html (an HTML <table> with its note), empty without flow.
std::string flowHtmlTable(const Comparison& c);

/// The flow rows of the text table printed by the CLI, empty without flow.
std::string flowTextTable(const Comparison& c);

/// True when some bed of the comparison has a flow record.
bool hasFlow(const Comparison& c);

}  // namespace voxpack::compare
