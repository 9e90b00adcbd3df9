// voxpack pack: the scene shared by both packing modes (flags merged over the TOML scene
// file, validated), then the chosen mode's run(). The scene-file format is docs/scene.md.
#include <cmath>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <sstream>

#include "pack_modes.hpp"
#include "scene_text.hpp"
#include "voxel_choice.hpp"
#include "voxpack/core/atomic_file.hpp"
#include "voxpack/core/bed_file.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/core/memory.hpp"
#include "voxpack/core/spec.hpp"
#include "voxpack/core/version.hpp"
#include "voxpack/packer/container.hpp"
#include "voxpack/packer/digitise.hpp"
#include "voxpack/packer/shape.hpp"

namespace voxpack::app {
namespace {

namespace fs = std::filesystem;

std::string where(const fs::path& file, const toml::node& node) {
  std::ostringstream s;
  s << file.string() << ":" << node.source().begin.line;
  return s.str();
}

double tomlDouble(const fs::path& file, const std::string& key, const toml::node& node) {
  const auto v = node.value<double>();
  if (!v || !std::isfinite(*v))
    throw InputError(where(file, node) + ": " + key + " must be a number");
  return *v;
}

std::int64_t tomlInt(const fs::path& file, const std::string& key, const toml::node& node) {
  const auto v = node.value<std::int64_t>();
  if (!v || !node.is_integer())
    throw InputError(where(file, node) + ": " + key + " must be an integer");
  return *v;
}

// An integer key that must land in [lo, hi] (e.g. an int field): refused, naming the key
// and the range, instead of being narrowed (4294967297 would read as 1 in an int).
std::int64_t tomlIntIn(const fs::path& file, const std::string& key, const toml::node& node,
                       std::int64_t lo, std::int64_t hi) {
  const std::int64_t v = tomlInt(file, key, node);
  if (v < lo || v > hi)
    throw InputError(where(file, node) + ": " + key + " = " + std::to_string(v) +
                     " is out of range (" + std::to_string(lo) + ".." + std::to_string(hi) + ")");
  return v;
}

std::string tomlString(const fs::path& file, const std::string& key, const toml::node& node) {
  const auto v = node.value<std::string>();
  if (!v) throw InputError(where(file, node) + ": " + key + " must be a string");
  return *v;
}

// "SPEC" or "SPEC@FRACTION": the fraction follows the last '@' (shape specs never hold
// one, a mesh path might, so the tail must read as a number to count as a fraction).
ShapeFraction parseShapeFraction(const std::string& text) {
  ShapeFraction sf{text, 1.0};
  const auto at = text.rfind('@');
  if (at == std::string::npos) return sf;
  const std::string tail = text.substr(at + 1);
  char* end = nullptr;
  const double f = std::strtod(tail.c_str(), &end);
  if (tail.empty() || end != tail.c_str() + tail.size()) return sf;
  if (!std::isfinite(f) || f <= 0)
    throw InputError("--shape " + text + ": the number fraction after '@' must be > 0");
  sf.spec = text.substr(0, at);
  sf.fraction = f;
  return sf;
}

// The scene part of a checkpoint: everything mergeScene() decided.
nlohmann::json sceneJson(const PackScene& s) {
  nlohmann::json shapes = nlohmann::json::array();
  for (const auto& sf : s.shapes) shapes.push_back({{"spec", sf.spec}, {"fraction", sf.fraction}});
  return {{"shapes", shapes},
          {"container", s.containerSpec},
          {"voxel_size_mm", s.voxelSizeMm},
          {"count", s.count},
          {"fill_height_mm", s.fillHeightMm},
          {"seed", s.seed},
          {"supersample", s.supersample},
          {"provenance", s.provenance}};
}

// FNV-1a (64 bit) of a text, as 16 hex digits: a short, stable identity of the --from
// bed's provenance for the new bed's own.
std::string fnv1a64(const std::string& text) {
  std::uint64_t h = 14695981039346656037ULL;
  for (const unsigned char c : text) {
    h ^= c;
    h *= 1099511628211ULL;
  }
  std::ostringstream s;
  s << std::hex << std::setw(16) << std::setfill('0') << h;
  return s.str();
}

// Largest checkpoint read: far above any state (~100 B per particle).
constexpr std::uintmax_t kMaxCheckpointBytes = std::uintmax_t{1} << 30;

nlohmann::json readCheckpointFile(const fs::path& file) {
  std::error_code ec;
  const std::uintmax_t bytes = fs::file_size(file, ec);
  if (ec) throw IoError("--resume " + file.string() + ": cannot read the file");
  if (bytes > kMaxCheckpointBytes)
    throw InputError("--resume " + file.string() + ": " + std::to_string(bytes) +
                     " bytes, more than the checkpoint limit of 1 GiB");
  std::ifstream in(file, std::ios::binary);
  if (!in) throw IoError("--resume " + file.string() + ": cannot open the file");
  nlohmann::json doc = nlohmann::json::parse(in, nullptr, false);
  if (doc.is_discarded() || !doc.is_object() || doc.value("format", "") != "voxpack-checkpoint" ||
      doc.value("version", 0) != 1)
    throw FormatError("--resume " + file.string() + ": not a voxpack checkpoint (version 1)");
  return doc;
}

}  // namespace

void writeCheckpointFile(const PackScene& scene, const std::string& mode,
                         const nlohmann::json& state) {
  const nlohmann::json doc = {{"format", "voxpack-checkpoint"},
                              {"version", 1},
                              {"mode", mode},
                              {"scene", sceneJson(scene)},
                              {"state", state}};
  writeTextFileAtomic(scene.checkpoint, doc.dump());
}

namespace {

class PackCommand final : public Command {
 public:
  PackCommand() : mc_(makeMcMode()), dem_(makeDemMode()) {}
  std::string name() const override { return "pack"; }
  std::string description() const override { return "pack a bed (Monte Carlo or digital DEM)"; }

  void addSwitches(CLI::App& sub) override {
    sub_ = &sub;
    sub.add_option("--mode", mode_, "packing mode: mc (Monte Carlo) or dem (digital DEM)");
    sub.add_option("--shape", shapes_,
                   "particle shape SPEC; repeat for a mixture, SPEC@F gives number fraction F");
    sub.add_option("--container", container_, "container SPEC, e.g. cylinder:d=43.3,h=60");
    sub.add_option("--voxel-size", voxelSizeMm_, "lattice voxel size (mm)");
    sub.add_option("--target-volume-error", targetVolumeError_,
                   "instead of --voxel-size: the coarsest voxel whose mean digitisation volume "
                   "error of the scene's shapes is below this fraction (e.g. 0.01), measured "
                   "now over random poses");
    sub.add_option("--count", count_, "number of particles to pack");
    sub.add_option("--fill-height", fillHeightMm_, "pack until the bed reaches this height (mm)");
    sub.add_option("--seed", seed_, "random seed");
    sub.add_option("-o,--output", output_, "output bed file (.h5)");
    sub.add_option("--config", config_, "TOML scene file (flags win over it), see docs/scene.md");
    sub.add_option("--supersample", supersample_,
                   "digitisation samples per voxel axis (1..8, default 1)");
    sub.add_flag("--check", check_,
                 "parse and validate the scene (flags, scene file, the mode's options), print "
                 "it as JSON and pack nothing");
    sub.add_option("--checkpoint", checkpoint_,
                   "write a resumable state to this file (atomically) while packing");
    sub.add_option("--checkpoint-every", checkpointEvery_,
                   "seconds of wall time between checkpoints (default 60 with --checkpoint)");
    sub.add_option("--resume", resume_, "continue the run saved in this checkpoint file");
    sub.add_option("--from", from_, "continue from an existing bed file (tap it, add particles)");
    for (PackMode* mode : {mc_.get(), dem_.get()}) {
      std::set<const CLI::Option*> before;
      for (const CLI::Option* o : sub.get_options()) before.insert(o);
      mode->addSwitches(sub);
      for (const CLI::Option* o : sub.get_options())
        if (!before.count(o)) owner_[o] = mode->name();
    }
  }

  int execute(const GlobalOptions& global) override {
    commandLine_ = global.commandLine;
    memory_ = &global.memory;
    if (!resume_.empty()) return resume(global);
    toml::table doc;
    if (given("--config")) doc = loadScene(config_);
    PackScene scene = mergeScene(doc);
    PackMode* mode = scene_mode_ == "mc" ? mc_.get() : dem_.get();
    // A flag of the other mode would be silently meaningless here: refuse it.
    for (const auto& [opt, owner] : owner_)
      if (owner != mode->name() && opt->count() > 0)
        throw UsageError(opt->get_name() + " is an option of --mode " + owner + ", not of --mode " +
                         mode->name());
    const toml::table* table = doc[mode->name()].as_table();
    if (doc.contains(mode->name()) && !table)
      throw InputError(config_.string() + ": [" + mode->name() + "] must be a table");
    if (check_ && mode->name() != "mc") {
      // Only the MC mode checks its own table without packing (PackScene::checkOnly).
      std::cout << scene.provenance.dump(2) << '\n';
      return 0;
    }
    return mode->run(scene, table, *sub_, global);
  }

 private:
  bool given(const std::string& flag) const { return sub_->get_option(flag)->count() > 0; }

  // --resume FILE: the scene and the mode's options come from the checkpoint; only where
  // to write (the bed, further checkpoints) may be given again.
  int resume(const GlobalOptions& global) {
    static const std::set<std::string> allowed{"--resume",     "--output",           "-o",
                                               "--checkpoint", "--checkpoint-every", "--help"};
    for (const CLI::Option* o : sub_->get_options())
      if (o->count() > 0 && !allowed.count(o->get_name()))
        throw UsageError("--resume takes the scene from the checkpoint: " + o->get_name() +
                         " cannot be given with it");
    std::error_code ec;
    if (!fs::is_regular_file(resume_, ec))
      throw IoError("--resume " + resume_.string() + ": no such file");
    const nlohmann::json doc = readCheckpointFile(resume_);
    PackScene s;
    try {
      const auto& j = doc.at("scene");
      for (const auto& sf : j.at("shapes"))
        s.shapes.push_back({sf.at("spec").get<std::string>(), sf.at("fraction").get<double>()});
      s.containerSpec = j.at("container").get<std::string>();
      s.voxelSizeMm = j.at("voxel_size_mm").get<double>();
      s.count = j.at("count").get<std::int64_t>();
      s.fillHeightMm = j.at("fill_height_mm").get<double>();
      s.seed = j.at("seed").get<std::uint64_t>();
      s.supersample = j.at("supersample").get<int>();
      s.provenance = j.at("provenance");
      s.resumeState = doc.at("state");
    } catch (const nlohmann::json::exception& e) {
      throw FormatError("--resume " + resume_.string() + ": malformed scene (" + e.what() + ")");
    }
    const std::string mode = doc.value("mode", "");
    PackMode* m = mode == "mc" ? mc_.get() : mode == "dem" ? dem_.get() : nullptr;
    if (!m) throw FormatError("--resume " + resume_.string() + ": unknown mode '" + mode + "'");
    s.output = given("--output") ? output_
                                 : fs::path(s.provenance.value("scene", nlohmann::json::object())
                                                .value("output", std::string()));
    if (s.output.empty()) throw UsageError("-o OUT.h5 is required");
    ensureWritableDirectory(s.output.has_parent_path() ? s.output.parent_path() : fs::path("."),
                            false);
    s.resume = resume_;
    s.checkpoint = checkpoint_;
    s.checkpointEverySeconds = checkpoint_.empty()           ? 0
                               : given("--checkpoint-every") ? checkpointEvery_
                                                             : 60;
    if (!checkpoint_.empty() &&
        !(std::isfinite(s.checkpointEverySeconds) && s.checkpointEverySeconds > 0))
      throw InputError("--checkpoint-every must be > 0 seconds");
    s.provenance["resumed_from"] = resume_.string();
    s.provenance["command_line"] = commandLine_;
    return m->run(s, nullptr, *sub_, global);
  }

  toml::table loadScene(const fs::path& file) const {
    std::error_code ec;
    if (!fs::is_regular_file(file, ec))
      throw IoError("--config " + file.string() + ": no such file");
    std::ifstream in(file, std::ios::binary);
    if (!in) throw IoError("--config " + file.string() + ": cannot be read");
    std::ostringstream text;
    text << in.rdbuf();
    rejectNonAsciiOutsideStrings(text.str(), file.string());
    try {
      return toml::parse(text.str(), file.string());
    } catch (const toml::parse_error& e) {
      std::ostringstream s;
      s << file.string() << ":" << e.source().begin.line << ": " << e.description();
      throw InputError(s.str());
    }
  }

  PackScene mergeScene(const toml::table& doc) {
    const fs::path& cf = config_;
    static const std::set<std::string> known{"mode",
                                             "shape",
                                             "container",
                                             "count",
                                             "fill_height_mm",
                                             "voxel_size_mm",
                                             "seed",
                                             "output",
                                             "supersample",
                                             "mc",
                                             "dem",
                                             "target_volume_error"};
    for (const auto& [key, node] : doc)
      if (!known.count(std::string(key.str())))
        throw InputError(where(cf, node) + ": unknown key '" + std::string(key.str()) +
                         "' (see docs/scene.md)");

    PackScene s;
    s.config = config_;
    // Mode.
    std::string mode = mode_;
    if (!given("--mode") && doc.contains("mode")) mode = tomlString(cf, "mode", *doc.get("mode"));
    if (mode.empty()) throw UsageError("--mode is required (mc or dem)");
    if (mode != "mc" && mode != "dem")
      throw UsageError("--mode " + mode + ": unknown mode (use mc or dem)");
    scene_mode_ = mode;

    // --from BED.h5: the bed to continue. Read whole (the MC walk compares its voxels);
    // its scene fills in what the flags and the file leave out (docs/dem.md, "--from").
    std::shared_ptr<Bed> from;
    nlohmann::json fromScene = nlohmann::json::object();
    if (!from_.empty()) {
      if (!resume_.empty()) throw UsageError("give --resume CHECKPOINT or --from BED.h5, not both");
      std::error_code ec;
      if (!fs::is_regular_file(from_, ec))
        throw IoError("--from " + from_.string() + ": no such file");
      from = std::make_shared<Bed>(readBed(from_, *memory_));
      const ParticleTable& t = from->particles;
      if (t.empty() || t.orientation.size() != t.size() || t.shape.size() != t.size())
        throw InputError("--from " + from_.string() +
                         ": the bed has no particle table (positions, orientations and shapes); "
                         "only a packed bed can be continued");
      const auto& prov = from->provenance;
      if (prov.is_object() && prov.contains("scene") && prov["scene"].is_object())
        fromScene = prov["scene"];
    }

    // Shapes.
    if (given("--shape")) {
      for (const auto& t : shapes_) s.shapes.push_back(parseShapeFraction(t));
    } else if (const toml::node* n = doc.get("shape")) {
      if (n->is_string()) {
        s.shapes.push_back(parseShapeFraction(tomlString(cf, "shape", *n)));
      } else if (const toml::array* a = n->as_array()) {
        for (const toml::node& e : *a) {
          if (e.is_string()) {
            s.shapes.push_back(parseShapeFraction(tomlString(cf, "shape", e)));
          } else if (const toml::table* t = e.as_table()) {
            ShapeFraction sf;
            const toml::node* spec = t->get("spec");
            if (!spec) throw InputError(where(cf, e) + ": a shape table needs spec = \"...\"");
            sf.spec = tomlString(cf, "shape.spec", *spec);
            if (const toml::node* f = t->get("fraction"))
              sf.fraction = tomlDouble(cf, "fraction", *f);
            for (const auto& [k, v] : *t)
              if (k.str() != "spec" && k.str() != "fraction")
                throw InputError(where(cf, v) + ": unknown shape key '" + std::string(k.str()) +
                                 "'");
            if (!(sf.fraction > 0)) throw InputError(where(cf, e) + ": fraction must be > 0");
            s.shapes.push_back(sf);
          } else {
            throw InputError(where(cf, e) + ": shape entries are strings or {spec, fraction}");
          }
        }
      } else {
        throw InputError(where(cf, *n) + ": shape must be a string or an array");
      }
    }
    if (s.shapes.empty() && from) s.shapes = fromShapes(*from, fromScene);
    if (s.shapes.empty()) throw UsageError("--shape is required");

    // Container, voxel size, count / fill height, seed, output, supersample.
    s.containerSpec = container_;
    if (!given("--container") && doc.contains("container"))
      s.containerSpec = tomlString(cf, "container", *doc.get("container"));
    if (s.containerSpec.empty() && from && fromScene.contains("container") &&
        fromScene["container"].is_string())
      s.containerSpec = fromScene["container"].get<std::string>();
    if (s.containerSpec.empty())
      throw UsageError(from ? "--container is required (the bed --from " + from_.string() +
                                  " records none)"
                            : std::string("--container is required"));

    std::optional<double> voxel;
    std::optional<double> target;
    if (given("--target-volume-error"))
      target = targetVolumeError_;
    else if (const toml::node* n = doc.get("target_volume_error"))
      target = tomlDouble(cf, "target_volume_error", *n);
    if (given("--voxel-size") && given("--target-volume-error"))
      throw UsageError("give --voxel-size or --target-volume-error, not both");
    if (given("--voxel-size"))
      voxel = voxelSizeMm_;
    else if (target)
      voxel = chooseVoxel(s, *target);
    else if (const toml::node* n = doc.get("voxel_size_mm"))
      voxel = tomlDouble(cf, "voxel_size_mm", *n);
    else if (from)
      voxel = from->lattice().spacingMm[2];
    if (!voxel) throw UsageError("--voxel-size (or --target-volume-error) is required");
    if (!std::isfinite(*voxel) || *voxel <= 0) throw InputError("--voxel-size must be > 0");
    s.voxelSizeMm = *voxel;

    std::optional<std::int64_t> count;
    std::optional<double> fill;
    if (given("--count")) count = count_;
    if (given("--fill-height")) fill = fillHeightMm_;
    // A flag of either kind replaces both keys of the file: the flag picks the goal.
    if (!count && !fill) {
      if (const toml::node* n = doc.get("count"))
        count = tomlIntIn(cf, "count", *n, 1, std::numeric_limits<std::int64_t>::max());
      if (const toml::node* n = doc.get("fill_height_mm"))
        fill = tomlDouble(cf, "fill_height_mm", *n);
    }
    if (count && fill) throw UsageError("give either --count or --fill-height, not both");
    // With --from, --count N adds N particles and may be left out (only tap the bed).
    if (!count && !fill && !from)
      throw UsageError("one of --count N or --fill-height MM is required");
    if (count && *count < 1)
      throw InputError("--count must be >= 1 (got " + std::to_string(*count) + ")");
    if (fill && !(std::isfinite(*fill) && *fill > 0)) throw InputError("--fill-height must be > 0");
    s.count = count.value_or(0);
    s.fillHeightMm = fill.value_or(0.0);

    if (given("--seed")) {
      s.seed = seed_;
    } else if (const toml::node* n = doc.get("seed")) {
      const std::int64_t v = tomlInt(cf, "seed", *n);
      if (v < 0) throw InputError(where(cf, *n) + ": seed must be >= 0");
      s.seed = static_cast<std::uint64_t>(v);
    } else {
      throw UsageError("--seed is required");
    }

    if (given("--output"))
      s.output = output_;
    else if (const toml::node* n = doc.get("output"))
      s.output = tomlString(cf, "output", *n);
    if (s.output.empty()) throw UsageError("-o OUT.h5 is required");

    s.supersample = 1;
    if (given("--supersample"))
      s.supersample = supersample_;
    else if (const toml::node* n = doc.get("supersample"))
      s.supersample = static_cast<int>(tomlIntIn(cf, "supersample", *n, 1, 8));
    else if (from && fromScene.contains("supersample") &&
             fromScene["supersample"].is_number_integer())
      s.supersample = fromScene["supersample"].get<int>();
    if (s.supersample < 1 || s.supersample > 8) throw InputError("--supersample must be in 1..8");

    s.checkOnly = check_;
    s.checkpoint = checkpoint_;
    s.resume = resume_;
    s.from = from_;
    if (given("--checkpoint-every")) {
      if (checkpoint_.empty()) throw UsageError("--checkpoint-every needs --checkpoint FILE");
      if (!(std::isfinite(checkpointEvery_) && checkpointEvery_ > 0))
        throw InputError("--checkpoint-every must be > 0 seconds");
      s.checkpointEverySeconds = checkpointEvery_;
    } else if (!checkpoint_.empty()) {
      s.checkpointEverySeconds = 60;
    }
    if (!checkpoint_.empty())
      ensureWritableDirectory(
          checkpoint_.has_parent_path() ? checkpoint_.parent_path() : fs::path("."), false);
    validateGeometry(s);
    if (from) checkFromBed(s, *from, fromScene, mode);
    ensureWritableDirectory(s.output.has_parent_path() ? s.output.parent_path() : fs::path("."),
                            false);

    nlohmann::json shapes = nlohmann::json::array();
    double total = 0;
    for (const auto& sf : s.shapes) total += sf.fraction;
    for (const auto& sf : s.shapes)
      shapes.push_back({{"spec", sf.spec}, {"fraction", sf.fraction / total}});
    s.provenance = {{"voxpack_version", versionString()},
                    {"command", "pack"},
                    {"command_line", commandLine_},
                    {"mode", mode},
                    {"seed", s.seed},
                    {"scene",
                     {{"shapes", shapes},
                      {"container", s.containerSpec},
                      {"voxel_size_mm", s.voxelSizeMm},
                      {"voxel_choice", voxelChoice_},
                      {"count", s.count},
                      {"fill_height_mm", s.fillHeightMm},
                      {"supersample", s.supersample},
                      {"config", s.config.empty() ? nlohmann::json(nullptr)
                                                  : nlohmann::json(s.config.string())},
                      {"output", s.output.string()}}}};
    if (from) {
      // Which bed this one continues: the file and the identity of its provenance.
      const auto& p = from->provenance;
      auto field = [&p](const char* key) {
        return p.is_object() && p.contains(key) ? p[key] : nlohmann::json(nullptr);
      };
      s.provenance["from"] = {{"file", from_.string()},
                              {"particles", from->particles.size()},
                              {"mode", field("mode")},
                              {"seed", field("seed")},
                              {"status", field("status")},
                              {"command_line", field("command_line")},
                              {"voxpack_version", field("voxpack_version")},
                              {"provenance_fnv1a64", fnv1a64(p.dump())}};
      s.fromBed = std::move(from);
    }
    return s;
  }

  // The shapes of a --from bed whose scene gives none: its recorded mixture, else the
  // distinct specs of its particle table with their number fractions.
  static std::vector<ShapeFraction> fromShapes(const Bed& bed, const nlohmann::json& scene) {
    std::vector<ShapeFraction> out;
    if (scene.contains("shapes") && scene["shapes"].is_array()) {
      for (const auto& e : scene["shapes"])
        if (e.is_object() && e.contains("spec") && e["spec"].is_string())
          out.push_back({e["spec"].get<std::string>(), e.value("fraction", 1.0)});
      if (!out.empty()) return out;
    }
    std::map<std::string, std::size_t> seen;
    for (const auto& spec : bed.particles.shape) {
      if (!seen.count(spec)) out.push_back({spec, 0.0});
      ++seen[spec];
    }
    for (auto& sf : out) sf.fraction = static_cast<double>(seen[sf.spec]);
    return out;
  }

  // A --from bed must fit the scene: the same voxel size, lattice (the DEM's may be taller:
  // it grows upwards to hold a high bed), container and mask, supersampling, and shapes the
  // scene holds. Each mismatch is refused naming both sides. Canonicalises the table's specs.
  void checkFromBed(const PackScene& s, Bed& bed, const nlohmann::json& scene,
                    const std::string& mode) const {
    const std::string f = "--from " + from_.string() + ": ";
    const Lattice& l = bed.lattice();
    const double h = s.voxelSizeMm;
    for (int a = 0; a < 3; ++a)
      if (std::fabs(l.spacingMm[a] - h) > 1e-9 * h) {
        std::ostringstream m;
        m << f << "the bed's voxel size is " << l.spacingMm[0] << " x " << l.spacingMm[1] << " x "
          << l.spacingMm[2] << " mm, the scene's --voxel-size " << h << " mm";
        throw InputError(m.str());
      }
    const auto container = packer::parseContainer(s.containerSpec);
    if (scene.contains("container") && scene["container"].is_string()) {
      const std::string was = packer::parseContainer(scene["container"].get<std::string>())->spec();
      if (was != s.containerSpec)
        throw InputError(f + "the bed was packed in container " + was + ", the scene gives " +
                         s.containerSpec);
    }
    if (scene.contains("supersample") && scene["supersample"].is_number_integer() &&
        scene["supersample"].get<int>() != s.supersample)
      throw InputError(f + "the bed was digitised with --supersample " +
                       std::to_string(scene["supersample"].get<int>()) + ", the scene gives " +
                       std::to_string(s.supersample));
    const Lattice want = packer::latticeForContainer(*container, h, 1);
    bool fits = l.ny() == want.ny() && l.nx() == want.nx() &&
                (mode == "dem" ? l.nz() >= want.nz() : l.nz() == want.nz());
    for (int a = 0; a < 3; ++a)
      fits = fits && std::fabs(l.originMm[a] - want.originMm[a]) <= 1e-6 * h;
    if (!fits) {
      std::ostringstream m;
      m << f << "the bed's lattice (" << l.nz() << " x " << l.ny() << " x " << l.nx()
        << " voxels, origin z y x " << l.originMm[0] << " " << l.originMm[1] << " " << l.originMm[2]
        << " mm) is not the lattice of container " << s.containerSpec << " at " << h << " mm ("
        << want.nz() << (mode == "dem" ? " or more" : "") << " x " << want.ny() << " x "
        << want.nx() << ", origin " << want.originMm[0] << " " << want.originMm[1] << " "
        << want.originMm[2] << " mm)";
      throw InputError(m.str());
    }
    if (bed.mask) {
      // The outermost layer is left out: the MC walk marks it wall in its mask.
      const Grid<std::uint8_t> mask = packer::containerMask(*container, l, s.supersample);
      std::size_t differ = 0;
      for (std::int64_t k = 1; k + 1 < l.nz(); ++k)
        for (std::int64_t j = 1; j + 1 < l.ny(); ++j)
          for (std::int64_t i = 1; i + 1 < l.nx(); ++i)
            differ += (*bed.mask)(k, j, i) != mask(k, j, i) ? 1 : 0;
      if (differ > 0)
        throw InputError(f + "the bed's mask is not container " + s.containerSpec + "'s (" +
                         std::to_string(differ) + " voxels differ)");
    }
    std::map<std::string, std::string> canonical;
    std::string names;
    for (const auto& sf : s.shapes) names += (names.empty() ? "" : ", ") + sf.spec;
    for (std::size_t n = 0; n < bed.particles.size(); ++n) {
      std::string& spec = bed.particles.shape[n];
      auto it = canonical.find(spec);
      if (it == canonical.end()) {
        std::string c;
        try {
          c = packer::parseShape(spec)->spec();
        } catch (const Error&) {
          c = spec;  // unreadable: refused below as not one of the scene's
        }
        bool ok = false;
        for (const auto& sf : s.shapes) ok = ok || sf.spec == c;
        if (!ok)
          throw InputError(f + "particle " + std::to_string(n + 1) + " has shape " + spec +
                           ", which is not one of the scene's shapes (" + names + ")");
        it = canonical.emplace(spec, c).first;
      }
      spec = it->second;
    }
  }

  // Refuses scenes no mode can pack: particles smaller than a voxel, or a container that
  // cannot hold one particle.
  void validateGeometry(PackScene& s) const {
    const auto container = packer::parseContainer(s.containerSpec);
    s.containerSpec = container->spec();
    const packer::BoundsMm b = container->boundsMm();
    const Vec3 ext = b.max - b.min;
    const double minExtent = std::min({ext.x(), ext.y(), ext.z()});
    const Lattice unit = Lattice::isotropic(1, 1, 1, s.voxelSizeMm);
    for (auto& sf : s.shapes) {
      const auto shape = packer::parseShape(sf.spec);
      sf.spec = shape->spec();
      const double deq = shape->volumeEquivalentDiameterMm();
      if (s.voxelSizeMm >= deq) {
        std::ostringstream m;
        m << "--voxel-size " << s.voxelSizeMm << " mm is not smaller than particle " << sf.spec
          << " (volume-equivalent diameter " << deq << " mm)";
        throw InputError(m.str());
      }
      requireWithinBudget(packer::digitiseMemoryEstimateBytes(*shape, s.voxelSizeMm), *memory_,
                          "pack: digitising " + sf.spec + " at --voxel-size " +
                              packer::formatNumber(s.voxelSizeMm) + " mm");
      const packer::DigitalParticle dp = packer::digitise(
          *shape, Vec3::Zero(), Quat::Identity(), unit, packer::DigitiseOptions{s.supersample});
      if (dp.voxels.empty())
        throw InputError("particle " + sf.spec + " digitises to no voxel at --voxel-size " +
                         std::to_string(s.voxelSizeMm) + " mm");
      // Narrowest width of the particle at its reference pose, from its digitisation.
      std::array<std::int32_t, 3> lo{dp.voxels[0].i, dp.voxels[0].j, dp.voxels[0].k}, hi = lo;
      for (const auto& v : dp.voxels) {
        lo = {std::min(lo[0], v.i), std::min(lo[1], v.j), std::min(lo[2], v.k)};
        hi = {std::max(hi[0], v.i), std::max(hi[1], v.j), std::max(hi[2], v.k)};
      }
      double width = 1e300;
      for (int a = 0; a < 3; ++a) width = std::min(width, (hi[a] - lo[a] + 1) * s.voxelSizeMm);
      if (container->volumeMm3() < shape->volumeMm3() || minExtent < width) {
        std::ostringstream m;
        m << "container " << s.containerSpec << " is smaller than one particle " << sf.spec
          << " (narrowest container extent " << minExtent << " mm, particle width " << width
          << " mm)";
        throw InputError(m.str());
      }
    }
    if (s.fillHeightMm > ext.z() + 1e-9) {
      std::ostringstream m;
      m << "--fill-height " << s.fillHeightMm << " mm is above the container top (" << ext.z()
        << " mm)";
      throw InputError(m.str());
    }
  }

  std::unique_ptr<PackMode> mc_, dem_;
  std::map<const CLI::Option*, std::string> owner_;
  CLI::App* sub_ = nullptr;
  const MemoryBudget* memory_ = nullptr;  // the command's budget, set by execute()
  std::string mode_, container_, scene_mode_, commandLine_;
  std::vector<std::string> shapes_;
  double voxelSizeMm_ = 0, fillHeightMm_ = 0;
  double targetVolumeError_ = 0;
  nlohmann::json voxelChoice_ = nullptr;  // the measured ladder when the voxel was chosen

  // Picks the coarsest voxel meeting the volume-error target (app/voxel_choice.hpp) and
  // says what it chose: the user asked for accuracy, so the choice must be visible.
  double chooseVoxel(const PackScene& s, double target) {
    std::vector<std::string> specs;
    for (const auto& sf : s.shapes) specs.push_back(sf.spec);
    VoxelChoiceOptions o;
    o.targetVolumeError = target;
    const VoxelChoice c = chooseVoxelSize(specs, o);
    nlohmann::json ladder = nlohmann::json::array();
    for (const auto& r : c.ladder)
      ladder.push_back({{"voxels_per_diameter", r.voxelsPerDiameter},
                        {"voxel_size_mm", r.voxelSizeMm},
                        {"mean_abs_volume_error", r.meanAbsError},
                        {"max_abs_volume_error", r.maxAbsError}});
    const auto& last = c.ladder.back();
    voxelChoice_ = {{"target_volume_error", target}, {"met", c.met}, {"ladder", ladder}};
    std::ostringstream m;
    m << (c.met ? "pack: chose --voxel-size " : "pack: target not met; finest tried --voxel-size ")
      << c.voxelSizeMm << " mm (" << last.voxelsPerDiameter
      << " voxels per diameter): mean volume error " << 100 * last.meanAbsError << " % over "
      << o.poses << " random poses (target " << 100 * target << " %)";
    std::cerr << m.str() << '\n';
    return c.voxelSizeMm;
  }
  std::int64_t count_ = 0;
  std::uint64_t seed_ = 0;
  fs::path output_, config_, checkpoint_, resume_, from_;
  double checkpointEvery_ = 0;
  bool check_ = false;
  int supersample_ = 1;
};

}  // namespace

std::unique_ptr<Command> makePackCommand() { return std::make_unique<PackCommand>(); }

}  // namespace voxpack::app
