#pragma once
/// \file pack_modes.hpp
/// The split of `voxpack pack` between the shared scene (cmd_pack.cpp) and the two
/// modes (pack_mc.cpp, pack_dem.cpp). Each mode registers its own flags and reads its
/// own table of the TOML scene file ([mc] / [dem]); flags win over the file.

#include <toml++/toml.h>

#include <CLI/CLI.hpp>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "command.hpp"
#include "voxpack/core/bed.hpp"

namespace voxpack::app {

/// One component of a particle mixture.
struct ShapeFraction {
  std::string spec;       ///< shape SPEC
  double fraction = 1.0;  ///< number fraction (normalised over the mixture)
};

/// The scene shared by both modes, after flags and TOML are merged and validated.
struct PackScene {
  std::vector<ShapeFraction> shapes;  ///< mixture by number fraction
  std::string containerSpec;          ///< container SPEC
  double voxelSizeMm = 0;             ///< lattice spacing
  std::int64_t count = 0;             ///< particles to pack (0 when fillHeightMm is used)
  double fillHeightMm = 0;            ///< pack until the bed reaches this height (0 = unused)
  std::uint64_t seed = 0;             ///< random seed
  std::filesystem::path output;       ///< -o OUT.h5
  std::filesystem::path config;       ///< --config SCENE.toml (may be empty)
  int supersample = 1;                ///< digitisation samples per axis
  nlohmann::json provenance;          ///< version, command line, scene (mode adds its own)
  std::filesystem::path checkpoint;   ///< --checkpoint FILE: resumable state (empty = none)
  double checkpointEverySeconds = 0;  ///< --checkpoint-every SECONDS of wall time (0 = never)
  std::filesystem::path resume;       ///< --resume FILE: continue from a checkpoint
  std::filesystem::path from;         ///< --from BED.h5: continue from an existing bed
  /// The bed of --from, read and checked against the scene (null = none); its particle
  /// table's shape specs are canonical.
  std::shared_ptr<const Bed> fromBed;
  bool checkOnly = false;      ///< --check: validate everything, print, pack nothing
  nlohmann::json resumeState;  ///< the mode's state read from --resume (null = none)
};

/// Writes the checkpoint file of `scene` (JSON: format "voxpack-checkpoint", version 1,
/// the mode, the scene, the mode's `state`) atomically to scene.checkpoint.
void writeCheckpointFile(const PackScene& scene, const std::string& mode,
                         const nlohmann::json& state);

/// Flags and TOML keys of one packing mode.
class PackMode {
 public:
  virtual ~PackMode() = default;
  /// "mc" or "dem".
  virtual std::string name() const = 0;
  /// Registers the mode's flags on the pack subcommand.
  virtual void addSwitches(CLI::App& pack) = 0;
  /// Packs the scene; `table` is the mode's TOML table ([mc]/[dem]) or null. Writes
  /// scene.output atomically; returns the exit code (0 also when the run ended by its
  /// cap: the status is printed and stored in the provenance).
  virtual int run(const PackScene& scene, const toml::table* table, const CLI::App& pack,
                  const GlobalOptions& global) = 0;
};

std::unique_ptr<PackMode> makeMcMode();   ///< Monte Carlo mode
std::unique_ptr<PackMode> makeDemMode();  ///< digital DEM mode

}  // namespace voxpack::app
