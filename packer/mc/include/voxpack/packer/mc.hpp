#pragma once
/// \file mc.hpp
/// Monte Carlo digital packing (DigiPac MC, [Xu 2008] §2.1 in docs/references.md): particles
/// random-walk on a label lattice one voxel step at a time, overlapping moves are refused and
/// upward moves pass only with the rebounding probability. The algorithm and its choices are in
/// docs/mc.md.

#include <cstdint>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "voxpack/core/bed.hpp"
#include "voxpack/core/progress.hpp"
#include "voxpack/packer/container.hpp"
#include "voxpack/packer/shape.hpp"

namespace voxpack::packer {

/// One component of a particle mixture.
struct MixtureComponent {
  std::shared_ptr<const Shape> shape;  ///< exact master shape (never null)
  double fraction = 1.0;               ///< number fraction, > 0 (normalised over the mixture)
};

/// How a Monte Carlo run ended.
enum class McStatus {
  Settled,        ///< every particle placed (or fill height reached) and the bed settled
  CapReached,     ///< the sweep cap stopped the run before the bed settled
  ContainerFull,  ///< no further particle fitted before the count / fill height was reached
};

/// "settled", "cap_reached" or "container_full".
const char* toString(McStatus status);

/// Options of packMonteCarlo().
struct McOptions {
  double voxelSizeMm = 0.3;           ///< lattice spacing in mm, > 0
  std::int64_t count = 0;             ///< particles to pack, >= 1 (0 when fillHeightMm > 0)
  double fillHeightMm = 0.0;          ///< mm above the container floor; > 0 selects fill mode
  int supersample = 1;                ///< digitisation samples per axis, 1..8
  double reboundProbability = 0.1;    ///< p_r: acceptance of an upward move, 0..1
  double rotationProbability = 0.05;  ///< share of move attempts that are rotations, 0..1
  double maxRotationDeg = 15.0;       ///< largest angle of one random rotation, degrees, (0, 180]
  std::int64_t maxSweeps = 20000;     ///< cap on sweeps over the whole run, >= 1
  int settleSweeps = 0;               ///< K, window of the settling test in sweeps; 0 = auto
  double settleTolerance = 1e-3;      ///< settled when the mean height falls < tol * height per K
  double settleMaxFallDiameters = 0.25;  ///< ...and no particle falls > this * d per K, > 0
  int injectAttempts = 200;              ///< random poses tried for one particle before a batch
                                         ///< closes, >= 1
  int tapCycles = 0;                     ///< tapping phases after filling, >= 0
  double tapReboundProbability = 0.5;    ///< p_r during a tap, 0..1
  int tapSweeps = 0;                     ///< sweeps of raised p_r per tap; 0 = K
};

/// Throws InputError naming the option when a field is out of range. With `startBed` (a
/// run continued from a bed) count = 0 and fill height = 0 together are allowed: nothing
/// is added, the bed is only tapped.
void validate(const McOptions& options, bool startBed = false);

/// Peak bytes packMonteCarlo() needs for `container` at options.voxelSizeMm, before it
/// allocates anything: the walk's labels (4 B), occupancy bits and mask per voxel, then
/// the output bed (indicator, labels, mask) next to them. InputError when the lattice is
/// too large to index; the caller compares the estimate with the memory budget.
std::uint64_t mcMemoryEstimateBytes(const Container& container, const McOptions& options);

/// The settling window K actually used for a mixture (resolves settleSweeps = 0).
int settleWindowSweeps(const McOptions& options, double particleDiameterMm);

/// Counters of a run.
struct McStats {
  std::int64_t sweeps = 0;             ///< sweeps done (one move attempt per particle each)
  std::int64_t triedMoves = 0;         ///< translation attempts
  std::int64_t acceptedMoves = 0;      ///< translations done
  std::int64_t triedRotations = 0;     ///< rotation attempts
  std::int64_t acceptedRotations = 0;  ///< rotations done
  std::int64_t batches = 0;            ///< injection batches
  std::int64_t injected = 0;           ///< particles injected
  std::int64_t removed = 0;            ///< particles trimmed above the fill height
  int settleWindow = 0;                ///< K used by the settling test
  double wallSeconds = 0.0;            ///< wall time of the run
  double walkSeconds = 0.0;            ///< wall time spent in sweeps (moves per second)
};

/// Result of packMonteCarlo(): the bed (indicator, mask, labels, particle table) and how
/// the run ended. bed.provenance holds the "mc" options, stats and status only.
struct McResult {
  Bed bed;                              ///< the packed bed
  McStatus status = McStatus::Settled;  ///< how the run ended
  McStats stats;                        ///< counters
};

/// Resumable checkpoints of a run. A state is taken between two sweeps and holds every
/// particle's exact pose, the counters and where the run is (filling, settling window,
/// tap); the random streams are keyed by sweep and particle index, so a resumed run
/// continues with exactly the draws of the uninterrupted one.
struct McCheckpointing {
  double everySeconds = 0;  ///< wall seconds between states (0 = never)
  /// Stores one state (the caller writes it atomically); called from the walk's thread.
  std::function<void(const nlohmann::json& state)> write;
  /// A state to continue from (from `write`), or null to start afresh. InputError when it
  /// belongs to other options, seed, mixture or container.
  const nlohmann::json* resume = nullptr;
};

/// Packs `mixture` into `container` by the Monte Carlo walk. Deterministic for a given
/// seed (the walk is sequential: thread count cannot change it), and a run resumed from a
/// checkpoint gives the same bed as the uninterrupted one. With `start` (pack --from
/// BED.h5) the walk begins with the bed's particles at their stored poses (see
/// placeStartBed's checks in docs/mc.md) and options.count more are injected on top.
/// Throws InputError on bad options, a particle that digitises to nothing, or a start
/// bed whose particles do not give its own voxels again; Cancelled when progress asks.
McResult packMonteCarlo(const std::vector<MixtureComponent>& mixture, const Container& container,
                        const McOptions& options, std::uint64_t seed,
                        Progress& progress = nullProgress(),
                        const McCheckpointing& checkpointing = {}, const Bed* start = nullptr);

/// The options as a JSON object (provenance).
nlohmann::json toJson(const McOptions& options);
/// The counters as a JSON object (provenance).
nlohmann::json toJson(const McStats& stats);

}  // namespace voxpack::packer
