#pragma once
/// \file dem.hpp
/// Digital DEM packer (method paper §2.2, eq. 1): spring-dashpot forces per out-facing
/// voxel face of each particle's digitised surface, summed into force and torque about the
/// centre of mass; Newton-Euler motion with quaternions in principal axes.
///
/// Units inside and outside: mm, g, s (force g*mm/s^2 = 1e-6 N). Doubles throughout: the
/// overlaps (~1e-3 mm) sit on coordinates of ~1e2 mm, and free fall must match 1/2 g t^2 to
/// 1e-6. See docs/dem.md for the derivations.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "voxpack/core/bed.hpp"
#include "voxpack/core/progress.hpp"
#include "voxpack/core/random.hpp"

namespace voxpack::packer::dem {

/// An exact particle shape as the DEM sees it; body frame origin at the centre of mass.
class DemShape {
 public:
  virtual ~DemShape() = default;
  /// Canonical spec text.
  virtual std::string spec() const = 0;
  /// Exact volume (mm^3).
  virtual double volumeMm3() const = 0;
  /// Inertia tensor per unit density about the centre of mass (mm^5), body frame.
  virtual Eigen::Matrix3d inertiaPerDensity() const = 0;
  /// Radius of the smallest origin-centred sphere containing the shape (mm).
  virtual double boundingRadiusMm() const = 0;
  /// Inside test of a body-frame point (mm).
  virtual bool inside(const Vec3& p) const = 0;
  /// Signed distance (mm), < 0 inside; never larger than the true distance outside.
  virtual double signedDistanceMm(const Vec3& p) const = 0;
  /// Outward unit normal at the surface point nearest to p (body frame).
  virtual Vec3 normal(const Vec3& p) const = 0;
  /// Inlined fast path of signedDistanceMm for the DEM's inner loop: 1 = sphere of radius r,
  /// 2 = cylinder along z of radius r and half length hl; 0 = none (virtual calls). The
  /// DEM then also takes the normal at a node inside from the form (the nearer face's,
  /// radial on a tie-free side, axial on the ends), so normal() must agree there.
  virtual int analyticForm(double& r, double& hl) const {
    r = hl = 0;
    return 0;
  }
};

/// Exact signed distance (mm) of DemShape::analyticForm `form` (1 sphere of radius r,
/// 2 cylinder along z of radius r and half length hl) at a shape-frame point.
inline double analyticSignedDistanceMm(int form, double r, double hl, const Vec3& p) {
  if (form == 1) return std::sqrt(p.squaredNorm()) - r;
  const double dr = std::sqrt(p.x() * p.x() + p.y() * p.y()) - r;
  const double dz = std::abs(p.z()) - hl;
  const double ox = std::max(dr, 0.0), oz = std::max(dz, 0.0);
  return std::sqrt(ox * ox + oz * oz) + std::min(std::max(dr, dz), 0.0);
}

/// One wall near a point: its distance, its inward normal and its contact region.
struct WallPatch {
  double distanceMm = 0;        ///< > 0 inside
  Vec3 normal = Vec3::UnitZ();  ///< inward unit normal
  int region = 0;               ///< 0..5, see DemContainer::wallRegion
};

/// The container as the DEM sees it: an open-top vessel (walls extend upwards).
class DemContainer {
 public:
  virtual ~DemContainer() = default;
  /// Distance (mm) of a point to the wall: > 0 inside, < 0 outside; the top is open.
  virtual double wallDistanceMm(const Vec3& p) const = 0;
  /// Inward unit normal of the nearest wall.
  virtual Vec3 inwardNormal(const Vec3& p) const = 0;
  /// Contact region (0..5) of the wall nearest to p: one wall contact per region, and its
  /// friction history stays while a particle moves along the region (a round side wall is
  /// one region). Default: the main axis and sign of the inward normal (a box's faces).
  virtual int wallRegion(const Vec3& p) const {
    const Vec3 nw = inwardNormal(p);
    int axis = 0;
    nw.cwiseAbs().maxCoeff(&axis);
    return 2 * axis + (nw[axis] > 0 ? 1 : 0);
  }
  /// The walls within reachMm of p, at most one per region, into out[0..5]; returns how
  /// many. Default: the nearest wall only.
  virtual int nearWalls(const Vec3& p, double reachMm, WallPatch* out) const {
    const double d = wallDistanceMm(p);
    if (d >= reachMm) return 0;
    out[0] = WallPatch{d, inwardNormal(p), wallRegion(p)};
    return 1;
  }
  /// True when the wall is an upright round column on a flat floor, with its axis at
  /// (cx, cy), radius r and floor at z = floorZ (mm): wallDistanceMm is then
  /// min(r - rho, z - floorZ), and the DEM pre-tests wall nodes in float. Default: false.
  virtual bool uprightColumn(double& cx, double& cy, double& r, double& floorZ) const {
    (void)cx, (void)cy, (void)r, (void)floorZ;
    return false;
  }
  /// Lower corner (x, y, z) of the interior bounds (mm).
  virtual Vec3 minMm() const = 0;
  /// Upper corner (x, y, z) of the interior bounds (mm); z = nominal top.
  virtual Vec3 maxMm() const = 0;
};

/// How a surface node's force is directed.
enum class ContactModel {
  kVoxel,    ///< paper eq. 1: along the node's voxel-face normal (lattice axis, body frame)
  kLevelSet  ///< LS-DEM (Kawamoto 2016): along the other body's exact surface normal
};

/// Options of the DEM packer (mm, g, s).
struct DemOptions {
  double friction = 0.5;        ///< Coulomb coefficient mu, >= 0
  double restitution = 0.5;     ///< normal restitution e, 0..1
  double densityGPerCm3 = 1.5;  ///< particle material density (g/cm^3), > 0
  /// Face stiffness per unit area and unit depth (N/mm^3): F = k * area * depth. 0 = auto
  /// from targetOverlap under the estimated bed weight.
  double stiffnessNPerMm3 = 0;
  /// Ceiling of one contact's stiffness dF/d(delta), as a multiple of a curved (sphere-like)
  /// contact's at the deepest expected overlap; wide flat contacts saturate there so the
  /// time step need not resolve them. 0 = no ceiling (the step then follows the flattest face).
  double contactStiffnessCap = 1.0;
  double targetOverlap = 0.004;        ///< auto stiffness: overlap / d under the bed weight
  double timeStepS = 0;                ///< requested step (s); 0 = timeStepFraction * t_c
  double timeStepFraction = 1.0 / 20;  ///< step as a fraction of the contact time t_c (1/50..1/10)
  ContactModel contact = ContactModel::kLevelSet;  ///< direction of node forces
  double gravityMmPerS2 = 9810.0;                  ///< gravity magnitude, acting along -z
  double tangentialStiffnessRatio = 2.0 / 7.0;     ///< k_t / k_n (elastic spheres)
  double wallFriction = -1;     ///< particle-wall Coulomb coefficient; -1 = friction
  double wallRestitution = -1;  ///< particle-wall restitution; -1 = restitution
  /// Rolling resistance mu_r >= 0 of pair and wall contacts: a constant directional torque
  /// mu_r |Fn| R_eff against the relative rolling rate (Ai et al. 2011, model A; LIGGGHTS
  /// `rolling_friction cdt`); 0 = none.
  double rollingFriction = 0;
  int tapCycles = 0;             ///< taps after the pour settled (0 = none)
  double tapAmplitudeMm = 0;     ///< container lift per tap; 0 = 0.3 d
  double tapFrequencyHz = 30;    ///< one tap = one sine period of the container lift
  double tapRestS = 0.1;         ///< free relaxation after each tap (s)
  bool sleeping = true;          ///< particles at rest away from motion are frozen
  double sleepTimeS = 0.01;      ///< time a particle must be at rest before it sleeps
  double settleKinetic = 1e-6;   ///< settled: mean KE per particle < this * m g d
  double settleVelocity = 1e-3;  ///< sleeping, and settled: max |v| < this * sqrt(g d)
  /// Settled needs max |v| < this * sqrt(g d); 0 = the kinetic-energy test alone (the rule of
  /// LIGGGHTS's scene: one particle rolling on the floor then does not hold the run);
  /// -1 = settleVelocity.
  double settleSpeed = -1;
  double maxTimeS = 20;             ///< simulated time cap (s)
  double rainHeightDiameters = 4;   ///< height of one injection batch zone (in d)
  double rainVolumeFraction = 0.3;  ///< solid fraction of an injection batch
  double rainSpeedMmPerS = 0;       ///< initial downward speed of injected particles
  double fillHeightPhiGuess = 0.6;  ///< --fill-height: density used to size the count
  /// Node-list skin (in d): a contact keeps the nodes within this distance of the other body
  /// and re-searches only after the relative pose moved that far. Tuning only: the forces
  /// are the same for any value. 0.01 rather than 0.03: a third of the nodes to evaluate each
  /// step for a few more re-searches (docs/dem.md, "Narrow phase with node lists").
  double nodeSkinDiameters = 0.01;
  /// Spacing of the surface nodes that carry the contacts, mm; 0 = the scene's voxel size.
  /// Coarser is faster (nodes ~ 1/h^2 a particle; the node forces are per area, so the
  /// contact law is the same), at an accuracy measured in docs/dem.md ("Contact nodes
  /// coarser than the lattice"); the bed is still digitised at the scene's voxel size.
  double contactVoxelMm = 0;
  int threads = 1;  ///< worker threads (results do not depend on it)
  /// Fewest neighbour pairs (particles / 4) worth a parallel region; tuning only.
  std::int64_t parallelMinItems = 64;
  /// Fewest pairs x surface nodes per particle worth a parallel region (the work of one
  /// force evaluation; a closed-form sphere counts 64 nodes, so does integrating one
  /// particle); tuning only. Measured: 98 cylinders at 0.9 mm (~500 pairs x ~150 nodes) ran
  /// 3x slower on 2 threads than on 1, the paper's bed at 0.27 mm (1894 nodes) 1.8x faster.
  double parallelMinNodeWork = 1e5;
  /// Below this share of particles awake, a step visits only the awake ones, the sleepers
  /// touching them and their pairs, and below this share moved since the last neighbour
  /// build, a rebuild searches the moved ones alone; tuning only: the bits are those of a
  /// full pass (docs/dem.md, "Sleeping"). 0 = always the full pass.
  double liveSetAwakeFraction = 0.25;
};

/// Precomputed body-frame (principal axes) data of one particle shape at one voxel size.
struct ParticleTemplate {
  std::shared_ptr<const DemShape> shape;     ///< exact master shape
  Quat principalToShape = Quat::Identity();  ///< rotation principal frame -> shape frame
  double massG = 0;                          ///< mass (g)
  Vec3 inertiaG = Vec3::Zero();              ///< principal moments (g mm^2)
  double radiusMm = 0;                       ///< bounding radius (mm)
  double diameterMm = 0;                     ///< volume-equivalent diameter (mm)
  double flatAreaMm2 = 0;                    ///< largest flat face (for the time step)
  /// Thinnest wall (mm): the shortest chord through the body along the inward normal of a
  /// surface node (a sphere: d; a ring: min(wall, length)). Past half of it the other body's
  /// nodes cross the medial surface and the level-set normal flips (interpenetration).
  double thinWallMm = 0;
  std::vector<Vec3> nodeP;         ///< node on the exact surface (principal frame)
  std::vector<Vec3> nodeFace;      ///< voxel face normal of the node (principal)
  std::vector<Vec3> nodeNormal;    ///< exact outward normal (principal)
  std::vector<double> nodeArea;    ///< voxel face area h^2 (mm^2)
  std::vector<double> nodeLsArea;  ///< h^2 * (face . normal): true-area weight
  /// Bounding spheres of node groups, two levels (coarse groups of fine groups).
  struct Cluster {
    Vec3 centre = Vec3::Zero();  ///< principal frame
    double radius = 0;           ///< mm
    std::uint32_t begin = 0;     ///< first child (fine cluster or node)
    std::uint32_t end = 0;       ///< one past the last child
  };
  std::vector<Cluster> coarse;  ///< children are fine clusters
  std::vector<Cluster> fine;    ///< children are nodes
  /// Signed distance in the principal frame.
  double sdf(const Vec3& p) const { return shape->signedDistanceMm(principalToShape * p); }
  /// Outward normal in the principal frame.
  Vec3 normal(const Vec3& p) const {
    return principalToShape.conjugate() * shape->normal(principalToShape * p);
  }
};

/// Builds the template of `shape` digitised at `voxelMm` (density in g/cm^3).
ParticleTemplate buildTemplate(std::shared_ptr<const DemShape> shape, double voxelMm,
                               double densityGPerCm3);
/// `base` scaled by `s` about its centre of mass, for `shape` (base's shape scaled by s):
/// mass s^3, inertia s^5, nodes at s x their place with s^2 their area; `nodes` false drops
/// the surface nodes (a closed-form sphere needs none, and a size distribution has one
/// template per particle).
ParticleTemplate scaledTemplate(const ParticleTemplate& base, std::shared_ptr<const DemShape> shape,
                                double s, bool nodes);

/// How a run ended.
enum class DemStatus { kSettled, kTimeCap, kCancelled, kDiverged };
/// "settled", "time_cap", "cancelled", "diverged".
const char* statusName(DemStatus s);

/// Work counters of a run (sleeping savings).
struct DemCounters {
  std::uint64_t steps = 0;                    ///< time steps
  std::uint64_t particleSteps = 0;            ///< particles present x steps
  std::uint64_t integratedParticleSteps = 0;  ///< of which integrated (awake)
  std::uint64_t pairChecks = 0;               ///< neighbour pairs x steps
  std::uint64_t pairEvaluations = 0;          ///< of which narrow-phase evaluated
  std::uint64_t nodeEvaluations = 0;          ///< signed-distance evaluations at nodes
  std::uint64_t neighbourRebuilds = 0;        ///< cell-list rebuilds
  std::uint64_t nodeListRebuilds = 0;         ///< contact node-list searches (pairs + walls)
  std::uint64_t partialRebuilds = 0;          ///< of the cell-list rebuilds, moved ones only
};

/// A pair overlap deeper than this fraction of the thinnest wall of the body it enters is an
/// interpenetration: half-way to that wall's medial surface, where the level-set normal flips.
inline constexpr double kInterpenetrationWallFraction = 0.25;

/// A rigid-body system of template particles in a container (the integrator).
class DemSystem {
 public:
  /// A system over `templates` in `container` with resolved options (see resolve()).
  DemSystem(std::vector<ParticleTemplate> templates, std::shared_ptr<const DemContainer> container,
            const DemOptions& options);
  ~DemSystem();
  DemSystem(const DemSystem&) = delete;
  DemSystem& operator=(const DemSystem&) = delete;

  /// Chooses stiffness (when auto, for a bed `bedHeightMm` high) and the time step; returns
  /// a warning text when a requested step was clamped, else empty.
  std::string resolve(double bedHeightMm);
  /// Adds a particle (orientation of the shape frame, body -> world); returns its index.
  std::size_t addParticle(std::size_t templateIndex, const Vec3& positionMm, const Quat& q,
                          const Vec3& velocityMmPerS = Vec3::Zero(),
                          const Vec3& angularVelocity = Vec3::Zero());
  /// Advances `n` steps.
  void step(std::size_t n = 1);

  std::size_t size() const;                     ///< particles
  Vec3 position(std::size_t i) const;           ///< centre of mass (mm)
  Vec3 velocity(std::size_t i) const;           ///< mm/s
  Vec3 angularVelocity(std::size_t i) const;    ///< rad/s, world
  Vec3 angularMomentum(std::size_t i) const;    ///< about the centre, g mm^2/s, world
  Quat orientation(std::size_t i) const;        ///< shape frame -> world
  std::size_t templateOf(std::size_t i) const;  ///< template index
  bool asleep(std::size_t i) const;             ///< frozen by sleeping
  double kineticEnergy() const;                 ///< g mm^2/s^2, translation + rotation
  double potentialEnergy() const;               ///< gravity, g mm^2/s^2 (z = 0 datum)
  double elasticEnergy() const;                 ///< normal springs, last step
  double maxOverlapMm() const;                  ///< deepest node penetration, last step
  double meanOverlapMm() const;      ///< mean of the pair contacts' deepest overlap, last step
  std::size_t contactCount() const;  ///< touching particle pairs, last step
  /// Touching pairs that interpenetrate, last step: a node deeper than
  /// kInterpenetrationWallFraction of the other body's thinnest wall.
  std::size_t interpenetrationCount() const;
  /// Deepest pair overlap over the thinnest wall of the body it enters, last step.
  double maxOverlapWallFraction() const;
  /// The same, deepest over every step this object has taken (not carried by checkpoints).
  double runMaxOverlapWallFraction() const;
  /// Steps this object has taken with at least one interpenetrating pair.
  std::uint64_t interpenetratingSteps() const;
  /// True once the state blew up (non-finite, or a runaway speed); step() then does nothing.
  bool diverged() const;
  double timeStepS() const;                                ///< chosen step (s)
  double contactTimeS() const;                             ///< t_c of the reference contact (s)
  double stiffnessNPerMm3() const;                         ///< chosen face stiffness
  double contactStiffnessCapNPerMm() const;                ///< contact stiffness ceiling (0 = none)
  double timeS() const;                                    ///< simulated time (s)
  const DemCounters& counters() const;                     ///< work counters
  const DemOptions& options() const;                       ///< resolved options
  const std::vector<ParticleTemplate>& templates() const;  ///< templates
  /// Vertical container offset (tapping) as a function of time; default none.
  void setWallMotion(double startS, int cycles);
  /// True while the container moves.
  bool wallMoving() const;
  /// Max particle speed |v| + |w| R (mm/s) and mean kinetic energy per particle.
  void motionMeasures(double& maxSpeed, double& meanKinetic) const;
  /// Wakes every sleeping particle.
  void wakeAll();
  /// Evaluates every contact once with all particles awake, without moving anything, so the
  /// overlap measures cover the whole bed (sleeping pairs are otherwise skipped). For the end
  /// of a run: the tangential springs are refreshed.
  void measureAllContacts();
  /// Everything that drives the trajectory, exactly (docs/dem.md, "Checkpoints"): poses as
  /// stored (principal axes), velocities, angular momenta, the last forces, springs of
  /// pairs and walls, node lists, neighbour list, sleeping windows, tap phase, time, step
  /// counters. Between two steps of a resolved, finite system.
  nlohmann::json saveState() const;
  /// Replaces the particles and the integrator state by `state` (from saveState() of a
  /// system with the same templates, container and options, resolved the same way):
  /// stepping on gives the bits the saved system would have given. FormatError when the
  /// state is malformed or does not fit the templates.
  void restoreState(const nlohmann::json& state);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// A continuous distribution of sphere diameters (mm) for a pour: each new particle's
/// diameter is drawn from RandomStream(seed, particle index) (docs/dem.md, "Size
/// distributions").
struct SizeDistribution {
  /// kNone: the scene's shapes as given; kLogNormal: ln d normal by number (median,
  /// geometric standard deviation), truncated to [minMm, maxMm]; kSieve: sieve bins
  /// [edge_k, edge_k+1) holding mass fractions, the diameter uniform by number in its bin.
  enum class Kind { kNone, kLogNormal, kSieve };
  Kind kind = Kind::kNone;            ///< which distribution
  double medianMm = 0;                ///< log-normal: number median diameter
  double geometricStd = 1;            ///< log-normal: exp(sigma of ln d), >= 1
  double minMm = 0;                   ///< log-normal: truncation, smallest diameter (> 0)
  double maxMm = 0;                   ///< log-normal: truncation, largest diameter (>= minMm)
  std::vector<double> edgesMm;        ///< sieve: n + 1 increasing bin edges (mm, > 0)
  std::vector<double> massFractions;  ///< sieve: n mass fractions (>= 0, normalised)
  /// True for kNone.
  bool none() const { return kind == Kind::kNone; }
};

/// InputError (naming `where`) unless `sizes` is a valid distribution.
void checkSizeDistribution(const SizeDistribution& sizes, const std::string& where);
/// One diameter (mm) of `sizes` (not kNone) from `rs`: one uniform for log-normal (inverse
/// CDF), two for a sieve (bin, then the place in it).
double drawDiameterMm(const SizeDistribution& sizes, RandomStream& rs);
/// The distribution as JSON (provenance, checkpoint identity); null for kNone.
nlohmann::json toJson(const SizeDistribution& sizes);

/// A packing job: shapes (mixture by number fraction), container and target.
struct DemScene {
  std::vector<std::shared_ptr<const DemShape>> shapes;  ///< mixture
  std::vector<double> fractions;                        ///< number fractions (normalised)
  std::shared_ptr<const DemContainer> container;        ///< vessel
  double voxelSizeMm = 0.3;                             ///< surface node spacing
  /// Particles to pour (or 0 with fillHeight; with `initial`, 0 = pour none, only settle
  /// and tap).
  std::int64_t count = 0;
  double fillHeightMm = 0;  ///< pack to this height (0 = unused)
  std::uint64_t seed = 0;   ///< random seed
  /// Particles present at the start, at rest (pack --from BED.h5): each spec must be one of
  /// `shapes` (a shape only the start holds has fraction 0). New ones are poured on top.
  ParticleTable initial;
  /// Diameters of the new particles (the one shape must then be a sphere); kNone = as given.
  SizeDistribution sizes;
};

/// Resumable checkpoints of a run. A state is taken between two checks of the driver
/// (every ~2 ms simulated) and holds the whole DemSystem state (DemSystem::saveState) and
/// where the driver is (particles injected, last injection time, tap started, settle time);
/// injection draws are keyed by seed and particle index, so a resumed run continues with
/// exactly the draws and the bits of the uninterrupted one, for any thread count.
struct DemCheckpointing {
  double everySeconds = 0;  ///< wall seconds between states (0 = never)
  /// Stores one state (the caller writes it atomically); also called once when the run is
  /// cancelled, so an interrupted run can be resumed from where it stopped.
  std::function<void(const nlohmann::json& state)> write;
  /// A state to continue from (from `write`), or null to start afresh. InputError when it
  /// belongs to another scene or other options (threads excepted); FormatError when it is
  /// not a DEM state of this version.
  const nlohmann::json* resume = nullptr;
};

/// The options as a JSON object: every field that changes a trajectory (not the threads
/// or the parallel thresholds). A checkpoint's identity; optionsFromJson() reads it back.
nlohmann::json toJson(const DemOptions& options);
/// The options of toJson(); FormatError on a missing or mistyped field.
DemOptions optionsFromJson(const nlohmann::json& j);

/// Result of a packing run.
struct DemResult {
  DemStatus status = DemStatus::kTimeCap;   ///< how it ended
  ParticleTable particles;                  ///< final centres, orientations, shape specs
  double timeStepS = 0;                     ///< time step used
  double contactTimeS = 0;                  ///< reference contact duration
  double stiffnessNPerMm3 = 0;              ///< face stiffness used
  double loadHeightMm = 0;                  ///< bed depth whose weight set the auto stiffness
  double simulatedTimeS = 0;                ///< simulated time
  double wallTimeS = 0;                     ///< elapsed wall-clock time
  double settleTimeS = 0;                   ///< simulated time when the pour settled
  double maxOverlapMm = 0;                  ///< deepest node penetration at the end
  double meanOverlapMm = 0;                 ///< mean deepest overlap of pair contacts, end
  std::size_t contacts = 0;                 ///< touching particle pairs at the end
  std::size_t interpenetrations = 0;        ///< interpenetrating pairs at the end
  double maxOverlapWallFraction = 0;        ///< deepest overlap / thinnest wall, end
  double maxOverlapWallFractionRun = 0;     ///< the same, deepest over the run
  std::uint64_t interpenetratingSteps = 0;  ///< steps with an interpenetrating pair
  DemCounters counters;                     ///< work done
  std::vector<std::string> messages;        ///< chosen settings and warnings
};

/// Pours scene.count particles in batches (on top of scene.initial), settles, taps, settles
/// again; checkpoints and resumes through `checkpointing`.
DemResult runDem(const DemScene& scene, const DemOptions& options, Progress& progress,
                 const DemCheckpointing& checkpointing = {});

}  // namespace voxpack::packer::dem
