// voxpack pack --mode mc: the Monte Carlo mode's flags, its [mc] table of the scene file,
// and the run (docs/mc.md, docs/scene.md).
#include <chrono>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "pack_modes.hpp"
#include "voxpack/core/bed_file.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/core/json_util.hpp"
#include "voxpack/core/memory.hpp"
#include "voxpack/packer/container.hpp"
#include "voxpack/packer/mc.hpp"
#include "voxpack/packer/shape.hpp"

namespace voxpack::app {
namespace {

// One MC option: its flag, its [mc] key and where it lands in McOptions.
struct McKey {
  const char* flag;
  const char* key;
  const char* help;
  enum Kind { Real, Integer } kind;
  double packer::McOptions::*real = nullptr;
  int packer::McOptions::*integer = nullptr;
  std::int64_t packer::McOptions::*integer64 = nullptr;
};

const std::vector<McKey>& mcKeys() {
  using O = packer::McOptions;
  static const std::vector<McKey> keys{
      {"--rebound-probability", "rebound_probability",
       "MC: acceptance probability of an upward move, 0..1 (default 0.1)", McKey::Real,
       &O::reboundProbability},
      {"--mc-rotation-probability", "rotation_probability",
       "MC: share of move attempts that are rotations, 0..1 (default 0.05)", McKey::Real,
       &O::rotationProbability},
      {"--mc-max-rotation-deg", "max_rotation_deg",
       "MC: largest angle of one random rotation, degrees (default 15)", McKey::Real,
       &O::maxRotationDeg},
      {"--mc-max-sweeps", "max_sweeps", "MC: cap on sweeps over the whole run (default 20000)",
       McKey::Integer, nullptr, nullptr, &O::maxSweeps},
      {"--mc-settle-sweeps", "settle_sweeps",
       "MC: settling window K in sweeps (0 = auto, 3 d / voxel)", McKey::Integer, nullptr,
       &O::settleSweeps},
      {"--mc-settle-tolerance", "settle_tolerance",
       "MC: settled when the mean height falls < this fraction per window (default 1e-3)",
       McKey::Real, &O::settleTolerance},
      {"--mc-settle-max-fall", "settle_max_fall_diameters",
       "MC: ...and no particle falls more than this many diameters per window (default 0.25)",
       McKey::Real, &O::settleMaxFallDiameters},
      {"--mc-inject-attempts", "inject_attempts",
       "MC: random poses tried per particle before a batch closes (default 200)", McKey::Integer,
       nullptr, &O::injectAttempts},
      {"--mc-tap-cycles", "tap_cycles", "MC: tapping phases after filling (default 0)",
       McKey::Integer, nullptr, &O::tapCycles},
      {"--mc-tap-rebound-probability", "tap_rebound_probability",
       "MC: rebound probability during a tap, 0..1 (default 0.5)", McKey::Real,
       &O::tapReboundProbability},
      {"--mc-tap-sweeps", "tap_sweeps", "MC: sweeps of one tap (0 = the settling window K)",
       McKey::Integer, nullptr, &O::tapSweeps},
  };
  return keys;
}

class McMode final : public PackMode {
 public:
  std::string name() const override { return "mc"; }

  void addSwitches(CLI::App& pack) override {
    const auto& keys = mcKeys();
    values_.assign(keys.size(), 0.0);
    for (std::size_t n = 0; n < keys.size(); ++n) {
      CLI::Option* opt = pack.add_option(keys[n].flag, values_[n], keys[n].help);
      if (keys[n].kind == McKey::Integer) opt->type_name("INT");
    }
  }

  int run(const PackScene& scene, const toml::table* table, const CLI::App& pack,
          const GlobalOptions& global) override {
    const auto t0 = std::chrono::steady_clock::now();
    packer::McOptions o;
    o.voxelSizeMm = scene.voxelSizeMm;
    o.count = scene.count;
    o.fillHeightMm = scene.fillHeightMm;
    o.supersample = scene.supersample;
    const auto& keys = mcKeys();
    if (!scene.resumeState.is_null()) {
      // The options the checkpointed run had (its state checks them again).
      try {
        fromJson(o, scene.resumeState.at("identity").at("options"));
      } catch (const nlohmann::json::exception& e) {
        throw FormatError("--resume " + scene.resume.string() + ": malformed options (" + e.what() +
                          ")");
      }
    }
    if (table) {
      for (const auto& [k, node] : *table) {
        const McKey* key = nullptr;
        for (const auto& c : keys)
          if (k.str() == c.key) key = &c;
        if (!key)
          throw InputError(scene.config.string() + ":" + std::to_string(node.source().begin.line) +
                           ": unknown [mc] key '" + std::string(k.str()) + "' (see docs/scene.md)");
        set(o, *key, node, scene.config.string());
      }
    }
    for (std::size_t n = 0; n < keys.size(); ++n)
      if (pack.get_option(keys[n].flag)->count() > 0) set(o, keys[n], values_[n], keys[n].flag);
    // A run from a bed (--from, or resumed from one's checkpoint) may add nothing.
    packer::validate(o, scene.fromBed != nullptr || scene.provenance.contains("from"));
    if (scene.checkOnly) {
      nlohmann::json j = scene.provenance;
      j["mc"] = packer::toJson(o);
      sanitizeNonFinite(j);
      std::cout << j.dump(2) << '\n';
      return 0;
    }

    std::vector<packer::MixtureComponent> mixture;
    for (const auto& sf : scene.shapes)
      mixture.push_back({packer::parseShape(sf.spec), sf.fraction});
    const auto container = packer::parseContainer(scene.containerSpec);

    {
      // Estimate before allocating: a tiny voxel must be refused in seconds, not by the
      // kernel's OOM killer.
      const Lattice l = packer::latticeForContainer(*container, o.voxelSizeMm, 1);
      std::ostringstream what;
      what << "pack --mode mc: a " << l.nx() << " x " << l.ny() << " x " << l.nz()
           << " lattice (--voxel-size " << o.voxelSizeMm << " mm)";
      requireWithinBudget(packer::mcMemoryEstimateBytes(*container, o), global.memory, what.str());
    }
    CommandProgress progress(global);
    packer::McCheckpointing ckpt;
    if (!scene.checkpoint.empty()) {
      ckpt.everySeconds = scene.checkpointEverySeconds;
      ckpt.write = [&scene](const nlohmann::json& state) {
        writeCheckpointFile(scene, "mc", state);
      };
    }
    if (!scene.resumeState.is_null()) ckpt.resume = &scene.resumeState;
    packer::McResult r;
    try {
      r = packer::packMonteCarlo(mixture, *container, o, scene.seed, progress, ckpt,
                                 scene.fromBed.get());
    } catch (const InputError& e) {
      // The walk's refusal of the start bed names the file it came from.
      const std::string m = e.what(), tag = "the start bed: ";
      if (m.rfind(tag, 0) != 0) throw;
      throw InputError("--from " + scene.from.string() + ": " + m.substr(tag.size()));
    }

    nlohmann::json prov = scene.provenance;
    prov["mc"] = r.bed.provenance["mc"];
    prov["status"] = packer::toString(r.status);
    prov["particles"] = r.bed.particles.size();
    prov["threads_note"] = "the Monte Carlo walk is sequential; --threads does not change it";
    prov["wall_time_s"] =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    sanitizeNonFinite(prov);
    r.bed.provenance = prov;
    writeBed(scene.output, r.bed);

    const BedSummary sum = summarize(r.bed);
    if (r.status != packer::McStatus::Settled)
      progress.message(std::string("warning: Monte Carlo run ended with status ") +
                       packer::toString(r.status));
    std::cout << std::setprecision(4) << "status " << packer::toString(r.status) << ", "
              << r.bed.particles.size() << " particles, " << r.stats.sweeps << " sweeps, "
              << "packing density in container " << sum.packingDensity << ", wall "
              << prov["wall_time_s"].get<double>() << " s -> " << scene.output.string() << '\n';
    return 0;
  }

 private:
  // McOptions from packer::toJson(McOptions) (a checkpoint's identity).
  static void fromJson(packer::McOptions& o, const nlohmann::json& j) {
    o.voxelSizeMm = j.at("voxel_size_mm").get<double>();
    o.count = j.at("count").get<std::int64_t>();
    o.fillHeightMm = j.at("fill_height_mm").get<double>();
    o.supersample = j.at("supersample").get<int>();
    o.reboundProbability = j.at("rebound_probability").get<double>();
    o.rotationProbability = j.at("rotation_probability").get<double>();
    o.maxRotationDeg = j.at("max_rotation_deg").get<double>();
    o.maxSweeps = j.at("max_sweeps").get<std::int64_t>();
    o.settleSweeps = j.at("settle_sweeps").get<int>();
    o.settleTolerance = j.at("settle_tolerance").get<double>();
    o.settleMaxFallDiameters = j.at("settle_max_fall_diameters").get<double>();
    o.injectAttempts = j.at("inject_attempts").get<int>();
    o.tapCycles = j.at("tap_cycles").get<int>();
    o.tapReboundProbability = j.at("tap_rebound_probability").get<double>();
    o.tapSweeps = j.at("tap_sweeps").get<int>();
  }

  static void set(packer::McOptions& o, const McKey& key, double v, const std::string& where) {
    if (!std::isfinite(v)) throw InputError(where + " must be a finite number");
    if (key.kind == McKey::Real) {
      o.*key.real = v;
      return;
    }
    if (v != std::floor(v) || std::fabs(v) > 9.0e15)
      throw InputError(where + " must be an integer");
    if (key.integer) {
      if (std::fabs(v) > 2.0e9)
        throw InputError(where + " is out of range (|value| <= 2000000000)");
      o.*key.integer = static_cast<int>(v);
    } else {
      o.*key.integer64 = static_cast<std::int64_t>(v);
    }
  }
  static void set(packer::McOptions& o, const McKey& key, const toml::node& node,
                  const std::string& file) {
    const std::string where =
        file + ":" + std::to_string(node.source().begin.line) + ": [mc] " + key.key;
    const auto v = node.value<double>();
    if (!v) throw InputError(where + " must be a number");
    set(o, key, *v, where);
  }

  std::vector<double> values_;
};

}  // namespace

std::unique_ptr<PackMode> makeMcMode() { return std::make_unique<McMode>(); }

}  // namespace voxpack::app
