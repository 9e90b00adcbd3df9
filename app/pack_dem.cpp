// voxpack pack --mode dem: the digital DEM mode's flags, its [dem] table of the scene file,
// and the run (docs/dem.md).
#include <chrono>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <numbers>
#include <sstream>

#include "pack_modes.hpp"
#include "voxpack/core/bed_file.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/core/json_util.hpp"
#include "voxpack/core/parallel.hpp"
#include "voxpack/packer/container.hpp"
#include "voxpack/packer/dem.hpp"
#include "voxpack/packer/dem_geometry.hpp"
#include "voxpack/packer/shape.hpp"

namespace voxpack::app {
namespace {

using packer::dem::DemOptions;

// One numeric DEM option: its flag, its [dem] key, where it lands in DemOptions and the
// values it accepts (checked here, so the refusal names the flag or the key as written).
struct DemKey {
  const char* flag;
  const char* key;
  const char* help;
  double DemOptions::*real = nullptr;
  int DemOptions::*integer = nullptr;
  bool (*ok)(double) = nullptr;
  const char* range = "";
};

bool nonNegative(double v) { return v >= 0; }
bool positive(double v) { return v > 0; }
bool unit(double v) { return v >= 0 && v <= 1; }
bool openUnit(double v) { return v > 0 && v <= 1; }

const std::vector<DemKey>& demKeys() {
  using O = DemOptions;
  static const std::vector<DemKey> keys{
      {"--friction", "friction", "DEM: Coulomb friction coefficient mu >= 0 (default 0.5)",
       &O::friction, nullptr, nonNegative, ">= 0"},
      {"--restitution", "restitution", "DEM: normal restitution coefficient 0..1 (default 0.5)",
       &O::restitution, nullptr, unit, "in 0..1"},
      {"--tap-cycles", "tap_cycles", "DEM: taps after the pour settled, 0 = none (default 0)",
       nullptr, &O::tapCycles, nonNegative, ">= 0"},
      {"--density", "density_g_cm3", "DEM: particle material density, g/cm^3 (default 1.5)",
       &O::densityGPerCm3, nullptr, positive, "> 0"},
      {"--stiffness", "stiffness_n_mm3",
       "DEM: face stiffness per area and depth, N/mm^3; 0 = auto from --target-overlap",
       &O::stiffnessNPerMm3, nullptr, nonNegative, ">= 0 (0 = auto)"},
      {"--contact-stiffness-cap", "contact_stiffness_cap",
       "DEM: ceiling of one contact's stiffness, in curved-contact units; 0 = none (default 1)",
       &O::contactStiffnessCap, nullptr, nonNegative, ">= 0 (0 = none)"},
      {"--target-overlap", "target_overlap",
       "DEM: auto stiffness: overlap / d under the bed weight (default 0.004)", &O::targetOverlap,
       nullptr, [](double v) { return v > 0 && v < 0.2; }, "in (0, 0.2)"},
      {"--time-step", "time_step_s",
       "DEM: time step in s; 0 = auto; above t_c/10 it is clamped with a warning", &O::timeStepS,
       nullptr, nonNegative, ">= 0 (0 = auto)"},
      {"--time-step-fraction", "time_step_fraction",
       "DEM: auto time step as a fraction of the contact time t_c, (0, 0.1] (default 1/20)",
       &O::timeStepFraction, nullptr, [](double v) { return v > 0 && v <= 0.1; }, "in (0, 0.1]"},
      {"--tap-amplitude", "tap_amplitude_mm", "DEM: container lift per tap, mm; 0 = 0.3 d",
       &O::tapAmplitudeMm, nullptr, nonNegative, ">= 0 (0 = 0.3 d)"},
      {"--tap-frequency", "tap_frequency_hz",
       "DEM: a tap is one sine period of this frequency, Hz (default 30)", &O::tapFrequencyHz,
       nullptr, positive, "> 0"},
      {"--tap-rest", "tap_rest_s", "DEM: relaxation after each tap, s (default 0.1)", &O::tapRestS,
       nullptr, nonNegative, ">= 0"},
      {"--sleep-time", "sleep_time_s",
       "DEM: time at rest before a particle sleeps, s (default 0.01)", &O::sleepTimeS, nullptr,
       nonNegative, ">= 0"},
      {"--settle-kinetic", "settle_kinetic",
       "DEM: settled when mean kinetic energy < this * m g d (default 1e-6)", &O::settleKinetic,
       nullptr, positive, "> 0"},
      {"--settle-velocity", "settle_velocity",
       "DEM: ...and max |v| < this * sqrt(g d) (default 1e-3)", &O::settleVelocity, nullptr,
       positive, "> 0"},
      {"--settle-speed", "settle_speed",
       "DEM: settled needs max |v| < this * sqrt(g d); 0 = the energy test alone (as LIGGGHTS), "
       "-1 = --settle-velocity (default)",
       &O::settleSpeed, nullptr, [](double v) { return v >= 0 || v == -1; },
       ">= 0, or -1 = --settle-velocity"},
      {"--max-time", "max_time_s", "DEM: cap on simulated time, s (default 20)", &O::maxTimeS,
       nullptr, positive, "> 0"},
      {"--rain-height", "rain_height_d",
       "DEM: height of the injection zone above the bed, in d; 0 = one cloud holding every "
       "particle at --rain-fraction (default 4)",
       &O::rainHeightDiameters, nullptr, nonNegative, ">= 0"},
      {"--rain-fraction", "rain_volume_fraction",
       "DEM: solid fraction of one injection batch (default 0.3)", &O::rainVolumeFraction, nullptr,
       openUnit, "in (0, 1]"},
      {"--wall-friction", "wall_friction",
       "DEM: particle-wall Coulomb coefficient; -1 = --friction (default)", &O::wallFriction,
       nullptr, [](double v) { return v >= 0 || v == -1; }, ">= 0, or -1 = --friction"},
      {"--wall-restitution", "wall_restitution",
       "DEM: particle-wall restitution 0..1; -1 = --restitution (default)", &O::wallRestitution,
       nullptr, [](double v) { return (v >= 0 && v <= 1) || v == -1; },
       "in 0..1, or -1 = --restitution"},
      {"--rolling-friction", "rolling_friction",
       "DEM: rolling resistance mu_r >= 0 of pair and wall contacts (constant directional "
       "torque mu_r |Fn| R); 0 = none (default)",
       &O::rollingFriction, nullptr, nonNegative, ">= 0"},
      {"--contact-voxel", "contact_voxel_mm",
       "DEM: spacing of the contact surface nodes, mm; 0 = --voxel-size (default). Coarser is "
       "faster; the bed is still digitised at --voxel-size (docs/dem.md)",
       &O::contactVoxelMm, nullptr, nonNegative, ">= 0"},
      {"--rain-speed", "rain_speed_mm_s", "DEM: initial downward speed, mm/s (default 0)",
       &O::rainSpeedMmPerS, nullptr, nonNegative, ">= 0"},
  };
  return keys;
}

packer::dem::ContactModel parseContact(const std::string& text, const std::string& where) {
  if (text == "voxel") return packer::dem::ContactModel::kVoxel;
  if (text == "levelset") return packer::dem::ContactModel::kLevelSet;
  throw InputError(where + ": contact must be voxel or levelset (got '" + text + "')");
}

// "a,b,c" as numbers (a flag's list).
std::vector<double> parseNumbers(const std::string& text, const std::string& where) {
  std::vector<double> out;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t end = std::min(text.find(',', start), text.size());
    const std::string item = text.substr(start, end - start);
    std::size_t used = 0;
    double v = 0;
    try {
      v = std::stod(item, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != item.size() || !std::isfinite(v))
      throw InputError(where + ": '" + item + "' is not a number");
    out.push_back(v);
    start = end + 1;
  }
  return out;
}

// --size-lognormal MEDIAN,GSD,MIN,MAX (mm, -, mm, mm).
packer::dem::SizeDistribution parseLogNormal(const std::string& text, const std::string& where) {
  const auto v = parseNumbers(text, where);
  if (v.size() != 4) throw InputError(where + ": expected MEDIAN,GSD,MIN,MAX (got '" + text + "')");
  packer::dem::SizeDistribution d;
  d.kind = packer::dem::SizeDistribution::Kind::kLogNormal;
  d.medianMm = v[0];
  d.geometricStd = v[1];
  d.minMm = v[2];
  d.maxMm = v[3];
  packer::dem::checkSizeDistribution(d, where);
  return d;
}

// --size-sieve EDGES:FRACTIONS, e.g. 2,2.5,3.15,4:0.3,0.5,0.2 (mm; mass fractions).
packer::dem::SizeDistribution parseSieve(const std::string& text, const std::string& where) {
  const std::size_t colon = text.find(':');
  if (colon == std::string::npos)
    throw InputError(where + ": expected EDGES:FRACTIONS, e.g. 2,2.5,3.15,4:0.3,0.5,0.2");
  packer::dem::SizeDistribution d;
  d.kind = packer::dem::SizeDistribution::Kind::kSieve;
  d.edgesMm = parseNumbers(text.substr(0, colon), where);
  d.massFractions = parseNumbers(text.substr(colon + 1), where);
  packer::dem::checkSizeDistribution(d, where);
  return d;
}

// The [dem.sizes] table: lognormal_median_mm, geometric_std, min_mm, max_mm; or
// sieve_edges_mm and sieve_mass_fractions (arrays).
packer::dem::SizeDistribution parseSizesTable(const toml::table& t, const std::string& cfg) {
  using packer::dem::SizeDistribution;
  SizeDistribution d;
  auto where = [&](const toml::node& n) {
    return cfg + ":" + std::to_string(n.source().begin.line) + ": [dem.sizes] ";
  };
  auto number = [&](const toml::node& n, const std::string& key) {
    const auto v = n.value<double>();
    if (!v) throw InputError(where(n) + key + " must be a number");
    return *v;
  };
  auto numbers = [&](const toml::node& n, const std::string& key) {
    const auto* a = n.as_array();
    if (!a) throw InputError(where(n) + key + " must be an array of numbers");
    std::vector<double> out;
    for (const auto& e : *a) out.push_back(number(e, key));
    return out;
  };
  // The log-normal keys and the sieve keys, and where each lands.
  const std::pair<const char*, double SizeDistribution::*> reals[] = {
      {"lognormal_median_mm", &SizeDistribution::medianMm},
      {"geometric_std", &SizeDistribution::geometricStd},
      {"min_mm", &SizeDistribution::minMm},
      {"max_mm", &SizeDistribution::maxMm}};
  const std::pair<const char*, std::vector<double> SizeDistribution::*> lists[] = {
      {"sieve_edges_mm", &SizeDistribution::edgesMm},
      {"sieve_mass_fractions", &SizeDistribution::massFractions}};
  bool logNormal = false, sieve = false;
  std::string at = cfg + ": [dem.sizes]";
  for (const auto& [k, node] : t) {
    const std::string key(k.str());
    at = where(node);
    bool known = false;
    for (const auto& [name, field] : reals)
      if (key == name) {
        d.*field = number(node, key);
        logNormal = known = true;
      }
    for (const auto& [name, field] : lists)
      if (key == name) {
        d.*field = numbers(node, key);
        sieve = known = true;
      }
    if (!known) throw InputError(where(node) + "unknown key '" + key + "' (see docs/dem.md)");
  }
  if (logNormal && sieve)
    throw InputError(at + "give either the log-normal keys or the sieve keys, not both");
  d.kind = logNormal ? SizeDistribution::Kind::kLogNormal
           : sieve   ? SizeDistribution::Kind::kSieve
                     : SizeDistribution::Kind::kNone;
  packer::dem::checkSizeDistribution(d, cfg + ": [dem.sizes]");
  return d;
}

bool parseOnOff(const std::string& text, const std::string& where) {
  if (text == "on" || text == "true" || text == "1") return true;
  if (text == "off" || text == "false" || text == "0") return false;
  throw InputError(where + ": expected on or off (got '" + text + "')");
}

class DemMode final : public PackMode {
 public:
  std::string name() const override { return "dem"; }

  void addSwitches(CLI::App& pack) override {
    const auto& keys = demKeys();
    values_.assign(keys.size(), 0.0);
    for (std::size_t n = 0; n < keys.size(); ++n)
      pack.add_option(keys[n].flag, values_[n], keys[n].help);
    pack.add_option("--contact", contact_,
                    "DEM: node force direction: voxel (paper, face normal) or levelset "
                    "(LS-DEM, exact normal); default levelset");
    pack.add_option("--sleeping", sleeping_,
                    "DEM: on/off: particles at rest away from motion are frozen (default on)");
    pack.add_option("--size-lognormal", sizeLogNormal_,
                    "DEM: sphere diameters log-normal by number, MEDIAN,GSD,MIN,MAX (mm, "
                    "geometric std, truncation mm); the one --shape must be a sphere");
    pack.add_option("--size-sieve", sizeSieve_,
                    "DEM: sphere diameters from a sieve table EDGES:FRACTIONS (mm; mass "
                    "fractions), e.g. 2,2.5,3.15,4:0.3,0.5,0.2");
  }

  int run(const PackScene& scene, const toml::table* table, const CLI::App& pack,
          const GlobalOptions& global) override {
    const auto t0 = std::chrono::steady_clock::now();
    DemOptions o;
    packer::dem::SizeDistribution sizes;
    if (!scene.resumeState.is_null()) {
      // The options the checkpointed run had (runDem checks its identity again).
      if (!scene.resumeState.is_object() || !scene.resumeState.contains("identity") ||
          !scene.resumeState["identity"].contains("options"))
        throw FormatError("--resume " + scene.resume.string() + ": not a DEM state");
      o = packer::dem::optionsFromJson(scene.resumeState["identity"]["options"]);
      // The size distribution of the checkpointed run (its identity holds it when set).
      const auto& id = scene.resumeState["identity"];
      if (id.contains("sizes") && id["sizes"].is_object()) {
        const auto& j = id["sizes"];
        try {
          if (j.at("kind") == "lognormal") {
            sizes.kind = packer::dem::SizeDistribution::Kind::kLogNormal;
            sizes.medianMm = j.at("median_mm").get<double>();
            sizes.geometricStd = j.at("geometric_std").get<double>();
            sizes.minMm = j.at("min_mm").get<double>();
            sizes.maxMm = j.at("max_mm").get<double>();
          } else {
            sizes.kind = packer::dem::SizeDistribution::Kind::kSieve;
            sizes.edgesMm = j.at("edges_mm").get<std::vector<double>>();
            sizes.massFractions = j.at("mass_fractions").get<std::vector<double>>();
          }
        } catch (const nlohmann::json::exception& e) {
          throw FormatError("--resume " + scene.resume.string() + ": bad size distribution (" +
                            e.what() + ")");
        }
      }
    }
    const auto& keys = demKeys();
    const std::string cfg = scene.config.string();
    if (table) {
      for (const auto& [k, node] : *table) {
        const std::string where = cfg + ":" + std::to_string(node.source().begin.line);
        if (k.str() == "contact") {
          const auto v = node.value<std::string>();
          if (!v) throw InputError(where + ": contact must be a string");
          o.contact = parseContact(*v, where);
          continue;
        }
        if (k.str() == "sizes") {
          const toml::table* t = node.as_table();
          if (!t) throw InputError(where + ": sizes must be a table ([dem.sizes])");
          sizes = parseSizesTable(*t, cfg);
          continue;
        }
        if (k.str() == "sleeping") {
          const auto v = node.value<bool>();
          if (!v) throw InputError(where + ": sleeping must be true or false");
          o.sleeping = *v;
          continue;
        }
        const DemKey* key = nullptr;
        for (const auto& c : keys)
          if (k.str() == c.key) key = &c;
        if (!key)
          throw InputError(where + ": unknown [dem] key '" + std::string(k.str()) +
                           "' (see docs/dem.md)");
        const auto v = node.value<double>();
        if (!v) throw InputError(where + ": " + key->key + " must be a number");
        set(o, *key, *v, where + ": " + key->key);
      }
    }
    for (std::size_t n = 0; n < keys.size(); ++n)
      if (pack.get_option(keys[n].flag)->count() > 0) set(o, keys[n], values_[n], keys[n].flag);
    if (pack.get_option("--contact")->count() > 0) o.contact = parseContact(contact_, "--contact");
    if (pack.get_option("--sleeping")->count() > 0)
      o.sleeping = parseOnOff(sleeping_, "--sleeping");
    const bool logNormalFlag = pack.get_option("--size-lognormal")->count() > 0;
    const bool sieveFlag = pack.get_option("--size-sieve")->count() > 0;
    if (logNormalFlag && sieveFlag)
      throw InputError("--size-lognormal and --size-sieve: give one size distribution");
    if (logNormalFlag) sizes = parseLogNormal(sizeLogNormal_, "--size-lognormal");
    if (sieveFlag) sizes = parseSieve(sizeSieve_, "--size-sieve");
    o.threads = resolveThreads(global.threads);

    packer::dem::DemScene ds;
    std::vector<std::shared_ptr<const packer::Shape>> shapes;
    double rMax = 0;
    for (const auto& sf : scene.shapes) {
      shapes.push_back(packer::parseShape(sf.spec));
      ds.shapes.push_back(packer::dem::demShape(shapes.back()));
      ds.fractions.push_back(sf.fraction);
      rMax = std::max(rMax, shapes.back()->boundingRadiusMm());
    }
    const auto container = packer::parseContainer(scene.containerSpec);
    ds.container = packer::dem::demContainer(container, 2 * rMax);
    ds.voxelSizeMm = scene.voxelSizeMm;
    ds.count = scene.count;
    ds.fillHeightMm = scene.fillHeightMm;
    ds.seed = scene.seed;
    ds.sizes = sizes;

    CommandProgress progress(global);
    packer::dem::DemCheckpointing ckpt;
    if (!scene.checkpoint.empty()) {
      ckpt.everySeconds = scene.checkpointEverySeconds;
      ckpt.write = [&scene](const nlohmann::json& state) {
        writeCheckpointFile(scene, "dem", state);
      };
    }
    if (!scene.resumeState.is_null()) ckpt.resume = &scene.resumeState;
    // --from: the bed's particles start at rest at their stored poses; --count N more are
    // poured on top (docs/dem.md, "Continuing a bed").
    if (scene.fromBed) ds.initial = scene.fromBed->particles;
    const packer::dem::DemResult r = packer::dem::runDem(ds, o, progress, ckpt);
    // A cancelled run (signal, or a Python KeyboardInterrupt through the hook) writes no
    // partial bed: the caller gets Cancelled, as from the Monte Carlo walk.
    if (r.status == packer::dem::DemStatus::kCancelled)
      throw Cancelled("DEM run cancelled after " + std::to_string(r.simulatedTimeS) +
                      " s simulated; no bed written");
    double clippedMm3 = 0;
    Bed bed = packer::dem::demBed(r.particles, shapes, *container, scene.voxelSizeMm,
                                  scene.supersample, o.threads, progress, &clippedMm3);
    double dRef = 1e300;
    for (const auto& sh : shapes)
      dRef = std::min(dRef, std::cbrt(6 * sh->volumeMm3() / std::numbers::pi));
    if (!sizes.none()) {
      // Overlaps in units of the smallest sphere poured (the table holds each diameter).
      dRef = 1e300;
      for (const auto& spec : r.particles.shape)
        dRef = std::min(dRef, packer::parseShape(spec)->volumeEquivalentDiameterMm());
    }

    nlohmann::json prov = scene.provenance;
    nlohmann::json dem = {
        {"friction", o.friction},
        {"restitution", o.restitution},
        {"tap_cycles", o.tapCycles},
        {"density_g_cm3", o.densityGPerCm3},
        {"stiffness_n_mm3", r.stiffnessNPerMm3},
        {"stiffness_auto", o.stiffnessNPerMm3 == 0},
        {"stiffness_load_height_mm", r.loadHeightMm},
        {"target_overlap", o.targetOverlap},
        {"contact_stiffness_cap", o.contactStiffnessCap},
        {"time_step_s", r.timeStepS},
        {"contact_time_s", r.contactTimeS},
        {"time_step_fraction", o.timeStepFraction},
        {"contact", o.contact == packer::dem::ContactModel::kVoxel ? "voxel" : "levelset"},
        {"tap_amplitude_mm", o.tapAmplitudeMm},
        {"tap_frequency_hz", o.tapFrequencyHz},
        {"tap_rest_s", o.tapRestS},
        {"sleeping", o.sleeping},
        {"sleep_time_s", o.sleepTimeS},
        {"settle_kinetic", o.settleKinetic},
        {"settle_speed", o.settleSpeed},
        {"settle_velocity", o.settleVelocity},
        {"max_time_s", o.maxTimeS},
        {"rain_height_d", o.rainHeightDiameters},
        {"rain_volume_fraction", o.rainVolumeFraction},
        {"rain_speed_mm_s", o.rainSpeedMmPerS},
        {"gravity_mm_s2", o.gravityMmPerS2},
        {"units", "mm, g, s; double precision"},
        {"simulated_time_s", r.simulatedTimeS},
        {"settle_time_s", r.settleTimeS},
        {"max_overlap_mm", r.maxOverlapMm},
        {"max_overlap_d", r.maxOverlapMm / dRef},
        {"mean_overlap_d", r.meanOverlapMm / dRef},
        {"contacts", r.contacts},
        {"interpenetrations", r.interpenetrations},
        {"max_overlap_wall_fraction", r.maxOverlapWallFraction},
        {"max_overlap_wall_fraction_run", r.maxOverlapWallFractionRun},
        {"interpenetrating_steps", r.interpenetratingSteps},
        {"clipped_outside_mask_mm3", clippedMm3},
        {"wall_friction", o.wallFriction >= 0 ? o.wallFriction : o.friction},
        {"wall_restitution", o.wallRestitution >= 0 ? o.wallRestitution : o.restitution},
        {"rolling_friction", o.rollingFriction},
        {"contact_voxel_mm", o.contactVoxelMm > 0 ? o.contactVoxelMm : scene.voxelSizeMm},
        {"size_distribution", packer::dem::toJson(sizes)},
        {"dem_wall_time_s", r.wallTimeS},
        {"threads", o.threads},
        {"steps", r.counters.steps},
        {"particle_steps", r.counters.particleSteps},
        {"integrated_particle_steps", r.counters.integratedParticleSteps},
        {"pair_checks", r.counters.pairChecks},
        {"pair_evaluations", r.counters.pairEvaluations},
        {"node_evaluations", r.counters.nodeEvaluations},
        {"neighbour_rebuilds", r.counters.neighbourRebuilds},
        {"neighbour_rebuilds_partial", r.counters.partialRebuilds},
        {"messages", r.messages}};
    prov["dem"] = dem;
    prov["status"] = packer::dem::statusName(r.status);
    prov["particles"] = bed.particles.size();
    prov["wall_time_s"] =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    sanitizeNonFinite(prov);
    bed.provenance = prov;
    writeBed(scene.output, bed);

    const BedSummary sum = summarize(bed);
    if (r.status != packer::dem::DemStatus::kSettled)
      progress.message(std::string("warning: DEM run ended with status ") +
                       packer::dem::statusName(r.status));
    std::cout << std::setprecision(4) << "status " << packer::dem::statusName(r.status) << ", "
              << bed.particles.size() << " particles, " << r.simulatedTimeS
              << " s simulated, time step " << r.timeStepS << " s, packing density in container "
              << sum.packingDensity << ", wall " << prov["wall_time_s"].get<double>() << " s -> "
              << scene.output.string() << '\n';
    return 0;
  }

 private:
  static void set(DemOptions& o, const DemKey& key, double v, const std::string& where) {
    if (!std::isfinite(v)) throw InputError(where + " must be a finite number");
    if (key.ok && !key.ok(v)) {
      std::ostringstream m;
      m << where << " must be " << key.range << " (got " << v << ")";
      throw InputError(m.str());
    }
    if (key.real) {
      o.*key.real = v;
      return;
    }
    if (v != std::floor(v) || std::fabs(v) > 1e9) throw InputError(where + " must be an integer");
    o.*key.integer = static_cast<int>(v);
  }

  std::vector<double> values_;
  std::string contact_ = "levelset";
  std::string sleeping_ = "on";
  std::string sizeLogNormal_, sizeSieve_;
};

}  // namespace

std::unique_ptr<PackMode> makeDemMode() { return std::make_unique<DemMode>(); }

}  // namespace voxpack::app
