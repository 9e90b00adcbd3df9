// compare --flow: one solver run per bed (packed region), the numbers and profile kept,
// and the candidates' ratios and differences against the reference.
#include "voxpack/compare/flow_compare.hpp"

#include <cmath>
#include <iomanip>
#include <sstream>

#include "voxpack/compare/compare.hpp"
#include "voxpack/core/json_util.hpp"

namespace voxpack::compare {
namespace {

double num(const nlohmann::json& j, const char* key) {
  return j.is_object() && j.contains(key) && j[key].is_number() ? j[key].get<double>()
                                                                : std::nan("");
}

nlohmann::json orNull(double v) { return std::isfinite(v) ? nlohmann::json(v) : nullptr; }

std::string cell(double v, int digits) {
  if (!std::isfinite(v)) return "n/a";
  std::ostringstream o;
  o << std::setprecision(digits) << v;
  return o.str();
}

std::string fixed(double v, int digits) {
  if (!std::isfinite(v)) return "n/a";
  std::ostringstream o;
  o << std::fixed << std::setprecision(digits) << v;
  return o.str();
}

std::string esc(const std::string& s) {
  std::string o;
  for (char ch : s)
    o += ch == '<' ? "&lt;" : ch == '>' ? "&gt;" : ch == '&' ? "&amp;" : std::string(1, ch);
  return o;
}

std::vector<const BedEntry*> beds(const Comparison& c) {
  std::vector<const BedEntry*> v{&c.reference};
  for (const auto& e : c.candidates) v.push_back(&e);
  return v;
}

}  // namespace

nlohmann::json flowRecord(const Bed& bed, const CompareFlowOptions& options, Progress& progress) {
  const flow::FlowReport rep = flow::computeFlow(bed, options.solver, options.memory, progress);
  const nlohmann::json& j = rep.json;
  nlohmann::json r;
  for (const char* key :
       {"status", "converged", "steps", "residual", "porosity", "permeability_mm2",
        "permeability_darcy", "permeability_over_d2", "tortuosity_hydraulic", "wall_flow_share",
        "wall_area_share", "particle_diameter_mm", "boundary", "walls", "warnings", "mlups",
        "wall_s"})
    r[key] = j.contains(key) ? j[key] : nlohmann::json(nullptr);
  r["radial_profile"] = nullptr;
  if (j.contains("radial_profile") && j["radial_profile"].is_object())
    r["radial_profile"] = {{"wall_distance_mm", j["radial_profile"]["wall_distance_mm"]},
                           {"axial_velocity_over_superficial",
                            j["radial_profile"]["axial_velocity_over_superficial"]}};
  r["pressure_gradient_darcy_pa_m"] =
      j.contains("pressure_gradient") && j["pressure_gradient"].is_object()
          ? j["pressure_gradient"]["darcy_pa_m"]
          : nlohmann::json(nullptr);
  return r;
}

nlohmann::json flowDistances(const nlohmann::json& ref, const nlohmann::json& cand) {
  const double kr = num(ref, "permeability_mm2"), kc = num(cand, "permeability_mm2");
  const double tr = num(ref, "tortuosity_hydraulic"), tc = num(cand, "tortuosity_hydraulic");
  const double wr = num(ref, "wall_flow_share"), wc = num(cand, "wall_flow_share");
  return {{"permeability_ratio", orNull(kr > 0 ? kc / kr : std::nan(""))},
          {"tortuosity_diff", orNull(tc - tr)},
          {"wall_flow_share_diff", orNull(wc - wr)}};
}

bool hasFlow(const Comparison& c) {
  for (const auto* e : beds(c))
    if (e->flow.is_object()) return true;
  return false;
}

nlohmann::json flowSummary(const Comparison& c) {
  if (!hasFlow(c)) return nullptr;
  nlohmann::json s;
  s["reference"] = c.reference.flow;
  s["reference"]["name"] = c.reference.name;
  s["candidates"] = nlohmann::json::array();
  for (const auto& e : c.candidates) {
    nlohmann::json row = e.flow.is_object() ? e.flow : nlohmann::json::object();
    row["name"] = e.name;
    row.update(flowDistances(c.reference.flow, e.flow));
    s["candidates"].push_back(row);
  }
  s["method"] =
      "voxpack flow on each bed's packed region (D3Q19 TRT lattice Boltzmann, docs/flow.md); "
      "permeability_ratio = k_candidate / k_reference; tortuosity_diff and "
      "wall_flow_share_diff = candidate - reference";
  sanitizeNonFinite(s);
  return s;
}

std::string flowProfileCsv(const Comparison& c) {
  std::ostringstream o;
  o << "bed,wall_distance_mm,axial_velocity_over_superficial\n";
  for (const auto* e : beds(c)) {
    if (!e->flow.is_object() || !e->flow["radial_profile"].is_object()) continue;
    const auto& w = e->flow["radial_profile"]["wall_distance_mm"];
    const auto& u = e->flow["radial_profile"]["axial_velocity_over_superficial"];
    std::string name = e->name;
    if (name.find_first_of(",\"\n") != std::string::npos) {
      std::string q = "\"";
      for (char ch : name) q += ch == '"' ? std::string("\"\"") : std::string(1, ch);
      name = q + "\"";
    }
    for (std::size_t k = 0; k < std::min(w.size(), u.size()); ++k) {
      if (!w[k].is_number() || !u[k].is_number()) continue;
      o << name << ',' << std::setprecision(9) << w[k].get<double>() << ',' << u[k].get<double>()
        << '\n';
    }
  }
  return o.str();
}

std::string flowHtmlTable(const Comparison& c) {
  if (!hasFlow(c)) return {};
  std::ostringstream h;
  h << "<h2>Flow</h2>\n<table id=\"flow\">\n<tr><th>bed</th><th>status</th><th>porosity</th>"
       "<th>k (mm&sup2;)</th><th>k / d&sup2;</th><th>k / k<sub>ref</sub></th>"
       "<th>tortuosity</th><th>&Delta; tortuosity</th><th>wall-flow share (1 d)</th>"
       "<th>&Delta; share</th></tr>\n";
  for (const auto* e : beds(c)) {
    const bool ref = e == &c.reference;
    const nlohmann::json d = ref ? nlohmann::json() : flowDistances(c.reference.flow, e->flow);
    h << "<tr" << (ref ? " class=\"ref\"" : "") << "><td>" << esc(e->name)
      << (ref ? " (reference)" : "") << "</td><td>"
      << esc(e->flow.is_object() && e->flow["status"].is_string()
                 ? e->flow["status"].get<std::string>()
                 : "n/a")
      << "</td><td>" << fixed(num(e->flow, "porosity"), 4) << "</td><td>"
      << cell(num(e->flow, "permeability_mm2"), 4) << "</td><td>"
      << cell(num(e->flow, "permeability_over_d2"), 4) << "</td><td>"
      << (ref ? "&mdash;" : fixed(num(d, "permeability_ratio"), 3)) << "</td><td>"
      << fixed(num(e->flow, "tortuosity_hydraulic"), 3) << "</td><td>"
      << (ref ? "&mdash;" : fixed(num(d, "tortuosity_diff"), 3)) << "</td><td>"
      << fixed(num(e->flow, "wall_flow_share"), 3) << "</td><td>"
      << (ref ? "&mdash;" : fixed(num(d, "wall_flow_share_diff"), 3)) << "</td></tr>\n";
  }
  h << "</table>\n<p>Flow: Stokes flow along z through each bed's packed region by lattice "
       "Boltzmann (voxpack flow, docs/flow.md), walls across the flow and fluid reservoirs "
       "along it. k: superficial permeability; tortuosity: &lang;|u|&rang; / &lang;u<sub>z</sub>"
       "&rang;; wall-flow share: fraction of the flow within one particle diameter of the "
       "wall. A bed resolved with fewer than about 10 voxels per particle diameter "
       "underestimates k (docs/flow.md: when to trust a number).</p>\n";
  return h.str();
}

std::string flowTextTable(const Comparison& c) {
  if (!hasFlow(c)) return {};
  std::size_t w = 9;
  for (const auto* e : beds(c)) w = std::max(w, e->name.size() + 2);
  std::ostringstream o;
  o << std::left << std::setw(static_cast<int>(w)) << "flow" << std::right;
  for (const char* head : {"status", "k_mm2", "k/k_ref", "tortuos.", "wall_share"})
    o << std::setw(14) << head;
  o << '\n';
  for (const auto* e : beds(c)) {
    const bool ref = e == &c.reference;
    const nlohmann::json d = ref ? nlohmann::json() : flowDistances(c.reference.flow, e->flow);
    o << std::left << std::setw(static_cast<int>(w)) << e->name << std::right << std::setw(14)
      << (e->flow.is_object() && e->flow["status"].is_string()
              ? e->flow["status"].get<std::string>()
              : "n/a")
      << std::setw(14) << cell(num(e->flow, "permeability_mm2"), 4) << std::setw(14)
      << (ref ? "-" : fixed(num(d, "permeability_ratio"), 3)) << std::setw(14)
      << fixed(num(e->flow, "tortuosity_hydraulic"), 3) << std::setw(14)
      << fixed(num(e->flow, "wall_flow_share"), 3) << '\n';
  }
  return o.str();
}

}  // namespace voxpack::compare
