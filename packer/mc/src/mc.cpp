// Monte Carlo digital packing. docs/mc.md explains the walk, the settling test and the
// choices the paper leaves open.
#include "voxpack/packer/mc.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include "voxpack/core/errors.hpp"
#include "voxpack/core/memory.hpp"
#include "voxpack/core/random.hpp"
#include "voxpack/packer/digitise.hpp"

namespace voxpack::packer {

const char* toString(McStatus status) {
  switch (status) {
    case McStatus::Settled:
      return "settled";
    case McStatus::CapReached:
      return "cap_reached";
    case McStatus::ContainerFull:
      return "container_full";
  }
  return "unknown";
}

namespace {

void require(bool ok, const std::string& what) {
  if (!ok) throw InputError(what);
}

bool finite(double v) { return std::isfinite(v); }

}  // namespace

void validate(const McOptions& o, bool startBed) {
  require(finite(o.voxelSizeMm) && o.voxelSizeMm > 0, "voxel size must be a positive number");
  require(o.count >= 0, "--count must be >= 1");
  require(finite(o.fillHeightMm) && o.fillHeightMm >= 0, "--fill-height must be > 0");
  require(
      (o.count > 0) != (o.fillHeightMm > 0) || (startBed && o.count == 0 && o.fillHeightMm == 0),
      "give exactly one of --count N (>= 1) and --fill-height MM (> 0)");
  require(o.supersample >= 1 && o.supersample <= 8, "--supersample must be in 1..8");
  require(finite(o.reboundProbability) && o.reboundProbability >= 0 && o.reboundProbability <= 1,
          "--rebound-probability must be in [0, 1]");
  require(finite(o.rotationProbability) && o.rotationProbability >= 0 && o.rotationProbability <= 1,
          "--mc-rotation-probability must be in [0, 1]");
  require(finite(o.maxRotationDeg) && o.maxRotationDeg > 0 && o.maxRotationDeg <= 180,
          "--mc-max-rotation-deg must be in (0, 180]");
  require(o.maxSweeps >= 1, "--mc-max-sweeps must be >= 1");
  require(o.settleSweeps >= 0, "--mc-settle-sweeps must be >= 0 (0 = auto)");
  require(finite(o.settleTolerance) && o.settleTolerance > 0 && o.settleTolerance < 1,
          "--mc-settle-tolerance must be in (0, 1)");
  require(finite(o.settleMaxFallDiameters) && o.settleMaxFallDiameters > 0,
          "--mc-settle-max-fall must be > 0");
  require(o.injectAttempts >= 1, "--mc-inject-attempts must be >= 1");
  require(o.tapCycles >= 0, "--mc-tap-cycles must be >= 0");
  require(finite(o.tapReboundProbability) && o.tapReboundProbability >= 0 &&
              o.tapReboundProbability <= 1,
          "--mc-tap-rebound-probability must be in [0, 1]");
  require(o.tapSweeps >= 0, "--mc-tap-sweeps must be >= 0 (0 = auto)");
}

std::uint64_t mcMemoryEstimateBytes(const Container& container, const McOptions& o) {
  const Lattice l = latticeForContainer(container, o.voxelSizeMm, 1);
  const std::uint64_t n =
      checkedProduct({static_cast<std::uint64_t>(l.nz()), static_cast<std::uint64_t>(l.ny()),
                      static_cast<std::uint64_t>(l.nx())},
                     "Monte Carlo lattice");
  // Walk: labels 4 + mask 1 + bits 1/8; output bed: indicator 1 + labels 4 + mask 1.
  // 12 B per voxel leaves ~0.9 B for the writer's chunk buffers and particle lists.
  return checkedProduct({n, 12}, "Monte Carlo memory estimate");
}

int settleWindowSweeps(const McOptions& o, double particleDiameterMm) {
  if (o.settleSweeps > 0) return o.settleSweeps;
  // A free particle falls ~0.33 voxel per sweep (9 of 26 directions go down, 5 % of
  // attempts are rotations): a window of 3 d/h sweeps lets it fall ~1 d, well above the
  // 0.25 d fall threshold, so a falling particle is never taken for a settled one.
  const double k = 3.0 * particleDiameterMm / o.voxelSizeMm;
  return static_cast<int>(std::clamp(std::ceil(k), 20.0, 1.0e6));
}

nlohmann::json toJson(const McOptions& o) {
  return {{"voxel_size_mm", o.voxelSizeMm},
          {"count", o.count},
          {"fill_height_mm", o.fillHeightMm},
          {"supersample", o.supersample},
          {"rebound_probability", o.reboundProbability},
          {"rotation_probability", o.rotationProbability},
          {"max_rotation_deg", o.maxRotationDeg},
          {"max_sweeps", o.maxSweeps},
          {"settle_sweeps", o.settleSweeps},
          {"settle_tolerance", o.settleTolerance},
          {"settle_max_fall_diameters", o.settleMaxFallDiameters},
          {"inject_attempts", o.injectAttempts},
          {"tap_cycles", o.tapCycles},
          {"tap_rebound_probability", o.tapReboundProbability},
          {"tap_sweeps", o.tapSweeps}};
}

nlohmann::json toJson(const McStats& s) {
  return {{"sweeps", s.sweeps},
          {"tried_moves", s.triedMoves},
          {"accepted_moves", s.acceptedMoves},
          {"tried_rotations", s.triedRotations},
          {"accepted_rotations", s.acceptedRotations},
          {"batches", s.batches},
          {"injected", s.injected},
          {"removed", s.removed},
          {"settle_window_sweeps", s.settleWindow},
          {"wall_time_s", s.wallSeconds},
          {"walk_time_s", s.walkSeconds}};
}

namespace {

constexpr std::uint32_t kWall = std::numeric_limits<std::uint32_t>::max();
// Random-stream ids: one per injected particle and one per sweep, so each random choice
// is tied to a work item.
constexpr std::uint64_t kInjectStream = 1ULL << 40;
constexpr std::uint64_t kSweepStream = 2ULL << 40;

// A particle on the label lattice. Voxel lists are linear lattice offsets taken at the
// last digitisation; `base` adds the translation since then (a pure lattice shift, so the
// lists stay exact without touching them).
struct Particle {
  int component = 0;
  Vec3 centreMm = Vec3::Zero();         // centre of mass at the last digitisation
  Quat q = Quat::Identity();            // orientation (body -> world)
  std::array<std::int64_t, 3> shift{};  // (k, j, i) voxel steps since the last digitisation
  std::int64_t base = 0;                // linear offset of `shift`
  std::vector<std::int64_t> voxels;     // all voxels
  std::array<std::vector<std::int64_t>, 6> faces;  // surface voxels out-facing -x,+x,..,+z
  bool alive = true;
};

class McPacker {
 public:
  McPacker(const std::vector<MixtureComponent>& mixture, const Container& container,
           const McOptions& options, std::uint64_t seed, Progress& progress,
           const McCheckpointing& checkpointing, const Bed* start)
      : mixture_(mixture),
        container_(container),
        o_(options),
        seed_(seed),
        progress_(progress),
        ckpt_(checkpointing),
        lastCheckpoint_(std::chrono::steady_clock::now()),
        start_(start) {}

  McResult run();

 private:
  // Where the run is: the control flow of run() as data, so a checkpoint can say where to
  // continue. Stages follow each other in this order (Inject and FillSettle alternate).
  enum class Stage { Inject, FillSettle, AfterFill, TapSweeps, TapSettle, Finish };
  // The settling test's running window (settle()).
  struct SettleState {
    std::vector<double> sum, prev;
    bool havePrev = false;
    double prevMean = 0;
    int inWindow = 0;
  };
  struct Cursor {
    Stage stage = Stage::Inject;
    McStatus status = McStatus::Settled;
    bool full = false;
    int tap = 0, tapSweep = 0;
    SettleState settle;
  };

  Vec3 centreOf(const Particle& p) const {
    const double h = o_.voxelSizeMm;
    return p.centreMm + Vec3(static_cast<double>(p.shift[2]) * h,
                             static_cast<double>(p.shift[1]) * h,
                             static_cast<double>(p.shift[0]) * h);
  }
  std::uint32_t idOf(std::size_t index) const { return static_cast<std::uint32_t>(index + 1); }

  bool digitiseFree(int component, const Vec3& c, const Quat& q, std::uint32_t id,
                    DigitalParticle& out) const;
  void adopt(Particle& p, const DigitalParticle& dp, const Vec3& c, const Quat& q) const;
  void writeLabels(const Particle& p, std::uint32_t value);
  bool isOccupied(std::int64_t off) const {
    const auto o = static_cast<std::uint64_t>(off);
    return (occupied_[o >> 6] >> (o & 63)) & 1u;
  }
  void setVoxel(std::int64_t off, std::uint32_t value) {
    const auto o = static_cast<std::uint64_t>(off);
    labels_[o] = value;
    const std::uint64_t bit = std::uint64_t{1} << (o & 63);
    if (value != 0)
      occupied_[o >> 6] |= bit;
    else
      occupied_[o >> 6] &= ~bit;
  }
  bool stepFree(const Particle& p, int axis, int sign) const;
  void applyStep(Particle& p, std::uint32_t id, int axis, int sign);
  void attemptMove(std::size_t index, RandomStream& rng, double pr);
  void sweep(double pr);
  McStatus settle(double pr, SettleState& st);
  void startSettle(SettleState& st) const;
  void sweepBoundary();
  nlohmann::json saveState() const;
  void restoreState(const nlohmann::json& state);
  nlohmann::json identity() const;
  void placeStartBed();
  std::int64_t injectBatch();
  int nextComponent();
  double highestCentreZ() const;
  void checkCancelled() const;
  void report();
  Bed buildBed() const;

  const std::vector<MixtureComponent>& mixture_;
  const Container& container_;
  McOptions o_;
  std::uint64_t seed_;
  Progress& progress_;

  Lattice lattice_;
  Grid<std::uint8_t> mask_;
  std::vector<std::uint32_t> labels_;
  // One bit per voxel, set where labels_ != 0. The step tests read only this: at 0.27 mm
  // the labels are 39 MB and every leading voxel is a cache miss, the bits are 1.2 MB.
  std::vector<std::uint64_t> occupied_;
  std::array<std::int64_t, 3> stride_{};  // linear stride of axis x, y, z
  std::vector<Particle> particles_;
  std::vector<double> fractions_;
  std::vector<std::int64_t> assigned_;
  BoundsMm bounds_;
  double diameterMm_ = 0;  // largest characteristic diameter of the mixture
  double maxBoundingMm_ = 0;
  int window_ = 20;
  McStats stats_;
  const McCheckpointing& ckpt_;
  std::chrono::steady_clock::time_point lastCheckpoint_;
  Cursor cursor_;
  const Bed* start_ = nullptr;   // pack --from: the bed the walk starts from
  std::int64_t startCount_ = 0;  // its particles (from the state when resuming)
};

bool McPacker::digitiseFree(int component, const Vec3& c, const Quat& q, std::uint32_t id,
                            DigitalParticle& out) const {
  out = digitise(*mixture_[static_cast<std::size_t>(component)].shape, c, q, lattice_,
                 DigitiseOptions{o_.supersample});
  if (out.voxels.empty()) return false;
  for (const Voxel& v : out.voxels) {
    // The outermost lattice layer is wall, so every particle voxel keeps all 26
    // neighbours inside the lattice and the step tests need no bounds checks.
    if (v.k < 1 || v.j < 1 || v.i < 1 || v.k >= lattice_.nz() - 1 || v.j >= lattice_.ny() - 1 ||
        v.i >= lattice_.nx() - 1)
      return false;
    const std::uint32_t l = labels_[lattice_.offset(v.k, v.j, v.i)];
    if (l != 0 && l != id) return false;
  }
  return true;
}

void McPacker::adopt(Particle& p, const DigitalParticle& dp, const Vec3& c, const Quat& q) const {
  p.centreMm = c;
  p.q = q;
  p.shift = {0, 0, 0};
  p.base = 0;
  p.voxels.resize(dp.voxels.size());
  for (std::size_t n = 0; n < dp.voxels.size(); ++n) {
    const Voxel& v = dp.voxels[n];
    p.voxels[n] = static_cast<std::int64_t>(lattice_.offset(v.k, v.j, v.i));
  }
  for (auto& f : p.faces) f.clear();
  for (std::size_t s = 0; s < dp.surface.size(); ++s) {
    const std::int64_t off = p.voxels[dp.surface[s]];
    const std::uint8_t bits = dp.surfaceFaces[s];
    for (int f = 0; f < 6; ++f)
      if (bits & (1u << f)) p.faces[static_cast<std::size_t>(f)].push_back(off);
  }
}

void McPacker::writeLabels(const Particle& p, std::uint32_t value) {
  for (const std::int64_t off : p.voxels) setVoxel(p.base + off, value);
}

// Only the leading surface (voxels whose face in the step direction is out-facing) can
// meet something new: their neighbours across that face are the voxels the step adds.
bool McPacker::stepFree(const Particle& p, int axis, int sign) const {
  const auto& lead = p.faces[static_cast<std::size_t>(2 * axis + (sign > 0 ? 1 : 0))];
  const std::int64_t d = p.base + sign * stride_[static_cast<std::size_t>(axis)];
  for (const std::int64_t off : lead)
    if (isOccupied(off + d)) return false;
  return true;
}

void McPacker::applyStep(Particle& p, std::uint32_t id, int axis, int sign) {
  const auto& lead = p.faces[static_cast<std::size_t>(2 * axis + (sign > 0 ? 1 : 0))];
  const auto& trail = p.faces[static_cast<std::size_t>(2 * axis + (sign > 0 ? 0 : 1))];
  const std::int64_t step = sign * stride_[static_cast<std::size_t>(axis)];
  for (const std::int64_t off : lead) setVoxel(p.base + off + step, id);
  for (const std::int64_t off : trail) setVoxel(p.base + off, 0);
  p.base += step;
  p.shift[static_cast<std::size_t>(2 - axis)] += sign;  // shift is (k, j, i); axis 0 is x
}

void McPacker::attemptMove(std::size_t index, RandomStream& rng, double pr) {
  Particle& p = particles_[index];
  const std::uint32_t id = idOf(index);
  if (rng.uniform() < o_.rotationProbability) {
    ++stats_.triedRotations;
    Vec3 axis(rng.normal(), rng.normal(), rng.normal());
    const double n = axis.norm();
    if (n < 1e-12) return;
    const double maxRad = o_.maxRotationDeg * std::numbers::pi / 180.0;
    const double angle = rng.uniform(-maxRad, maxRad);
    // Rotate the exact shape about its centre of mass and digitise it again: a voxel set
    // is never rotated (its volume would drift).
    const Quat q = (Quat(Eigen::AngleAxisd(angle, axis / n)) * p.q).normalized();
    const Vec3 c = centreOf(p);
    DigitalParticle dp;
    if (!digitiseFree(p.component, c, q, id, dp)) return;
    writeLabels(p, 0);
    adopt(p, dp, c, q);
    writeLabels(p, id);
    ++stats_.acceptedRotations;
    return;
  }
  ++stats_.triedMoves;
  // The 26 directions, (dx, dy, dz) each in {-1, 0, 1}, not all 0.
  int d = static_cast<int>(rng.below(26));
  if (d >= 13) ++d;  // skip the centre of the 3x3x3 block
  const std::array<int, 3> dir{d % 3 - 1, (d / 3) % 3 - 1, d / 9 - 1};
  if (dir[2] > 0 && !(rng.uniform() < pr)) return;  // upward: only with the rebound prob.
  std::array<int, 3> order{0, 1, 2};
  // A diagonal is 2-3 unit steps; their order is random so no axis is favoured.
  for (int a = 2; a > 0; --a)
    std::swap(order[static_cast<std::size_t>(a)],
              order[static_cast<std::size_t>(rng.below(static_cast<std::uint64_t>(a + 1)))]);
  std::array<int, 3> done{};
  int nDone = 0;
  for (const int axis : order) {
    const int sign = dir[static_cast<std::size_t>(axis)];
    if (sign == 0) continue;
    if (!stepFree(p, axis, sign)) {
      for (int u = nDone - 1; u >= 0; --u) {
        const int a = done[static_cast<std::size_t>(u)];
        applyStep(p, id, a, -dir[static_cast<std::size_t>(a)]);
      }
      return;
    }
    applyStep(p, id, axis, sign);
    done[static_cast<std::size_t>(nDone++)] = axis;
  }
  ++stats_.acceptedMoves;
}

void McPacker::sweep(double pr) {
  RandomStream rng(seed_, kSweepStream + static_cast<std::uint64_t>(stats_.sweeps));
  std::vector<std::size_t> order;
  order.reserve(particles_.size());
  for (std::size_t n = 0; n < particles_.size(); ++n)
    if (particles_[n].alive) order.push_back(n);
  std::shuffle(order.begin(), order.end(), rng);
  for (const std::size_t n : order) attemptMove(n, rng, pr);
  ++stats_.sweeps;
}

void McPacker::checkCancelled() const {
  if (progress_.cancelled()) throw Cancelled("Monte Carlo packing stopped");
}

void McPacker::report() {
  double f = 0;
  if (o_.count > 0)
    f = static_cast<double>(stats_.injected) / static_cast<double>(o_.count);
  else if (o_.fillHeightMm > 0)
    f = (highestCentreZ() - bounds_.min.z()) / o_.fillHeightMm;
  f = std::max(f, static_cast<double>(stats_.sweeps) / static_cast<double>(o_.maxSweeps));
  progress_.report("mc packing", std::clamp(f, 0.0, 1.0));
}

// Settled when, between two consecutive windows of K sweeps, (a) the mean particle height
// above the floor falls by less than tol * that height and (b) no particle's window-mean
// height falls by more than settleMaxFallDiameters * d. (a) alone misses a few particles
// still falling onto a large bed; (b) alone never ends under rattling at high p_r.
void McPacker::startSettle(SettleState& st) const {
  st = SettleState{};
  st.sum.assign(particles_.size(), 0.0);
  st.prev.assign(particles_.size(), 0.0);
}

McStatus McPacker::settle(double pr, SettleState& st) {
  const auto t0 = std::chrono::steady_clock::now();
  const std::size_t n = particles_.size();
  if (n == 0) return McStatus::Settled;
  std::vector<double>& sum = st.sum;
  std::vector<double>& prev = st.prev;
  bool& havePrev = st.havePrev;
  double& prevMean = st.prevMean;
  int& inWindow = st.inWindow;
  McStatus status = McStatus::CapReached;
  while (stats_.sweeps < o_.maxSweeps) {
    sweepBoundary();
    sweep(pr);
    for (std::size_t p = 0; p < n; ++p)
      if (particles_[p].alive) sum[p] += centreOf(particles_[p]).z() - bounds_.min.z();
    if (++inWindow < window_) continue;
    double mean = 0, maxFall = 0;
    std::size_t alive = 0;
    for (std::size_t p = 0; p < n; ++p) {
      if (!particles_[p].alive) continue;
      sum[p] /= window_;
      mean += sum[p];
      ++alive;
      if (havePrev) maxFall = std::max(maxFall, prev[p] - sum[p]);
    }
    mean /= static_cast<double>(std::max<std::size_t>(alive, 1));
    report();
    // The downward drift of the walk is proportional to 1 - p_r: at p_r = 1 there is
    // nothing to settle to, and a gas whose mean height has stopped falling would pass the
    // test by chance (seed 3 was called settled after 180 sweeps). Such a run ends by its cap.
    if (pr < 1.0 && havePrev && prevMean - mean < o_.settleTolerance * prevMean &&
        maxFall <= o_.settleMaxFallDiameters * diameterMm_) {
      status = McStatus::Settled;
      break;
    }
    havePrev = true;
    prevMean = mean;
    prev.swap(sum);
    std::fill(sum.begin(), sum.end(), 0.0);
    inWindow = 0;
  }
  stats_.walkSeconds +=
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return status;
}

// Largest-remainder quota: particle n takes the component furthest behind its share, so
// every prefix of the sequence follows the number fractions (exact for count mode).
int McPacker::nextComponent() {
  const double next = static_cast<double>(stats_.injected + 1);
  int best = 0;
  double bestLag = -std::numeric_limits<double>::infinity();
  for (std::size_t c = 0; c < fractions_.size(); ++c) {
    const double lag = fractions_[c] * next - static_cast<double>(assigned_[c]);
    if (lag > bestLag + 1e-12) {
      bestLag = lag;
      best = static_cast<int>(c);
    }
  }
  return best;
}

double McPacker::highestCentreZ() const {
  double z = bounds_.min.z();
  for (const Particle& p : particles_)
    if (p.alive) z = std::max(z, centreOf(p).z());
  return z;
}

// Injects particles at random free poses above the highest particle centre until the
// target is met or one particle finds no free pose in injectAttempts tries.
std::int64_t McPacker::injectBatch() {
  ++stats_.batches;
  const double zLow = highestCentreZ();
  double zHigh = bounds_.max.z();
  if (o_.fillHeightMm > 0)
    zHigh = std::min(zHigh, bounds_.min.z() + o_.fillHeightMm + 2.0 * maxBoundingMm_);
  zHigh = std::max(zHigh, zLow);
  std::int64_t added = 0;
  DigitalParticle dp;
  while (o_.count == 0 || stats_.injected < o_.count) {
    checkCancelled();
    const int component = nextComponent();
    const std::size_t index = particles_.size();
    const std::uint32_t id = idOf(index);
    RandomStream rng(seed_, kInjectStream + index);
    bool placed = false;
    for (int a = 0; a < o_.injectAttempts && !placed; ++a) {
      const Vec3 c(rng.uniform(bounds_.min.x(), bounds_.max.x()),
                   rng.uniform(bounds_.min.y(), bounds_.max.y()),
                   zLow + (zHigh - zLow) * rng.uniform());
      // Uniform random orientation (Shoemake's method).
      const double u1 = rng.uniform(), u2 = rng.uniform(), u3 = rng.uniform();
      const double twoPi = 2.0 * std::numbers::pi;
      // Normalised before digitising: the stored pose is exactly the one digitised, so a
      // checkpoint's re-digitisation reproduces the voxels bit for bit.
      const Quat q =
          Quat(std::sqrt(u1) * std::cos(twoPi * u3), std::sqrt(1 - u1) * std::sin(twoPi * u2),
               std::sqrt(1 - u1) * std::cos(twoPi * u2), std::sqrt(u1) * std::sin(twoPi * u3))
              .normalized();
      // Cheap pre-test of the centre voxel before a full digitisation.
      const Index3 ci = lattice_.nearestIndex(c);
      if (!lattice_.contains(ci.k, ci.j, ci.i) || labels_[lattice_.offset(ci.k, ci.j, ci.i)] != 0)
        continue;
      if (!digitiseFree(component, c, q, id, dp)) continue;
      Particle p;
      p.component = component;
      adopt(p, dp, c, q);
      particles_.push_back(std::move(p));
      writeLabels(particles_.back(), id);
      placed = true;
    }
    if (!placed) break;
    ++assigned_[static_cast<std::size_t>(component)];
    ++stats_.injected;
    ++added;
    if (particles_.size() >= kWall - 1) throw InputError("too many particles for 32-bit labels");
  }
  report();
  return added;
}

Bed McPacker::buildBed() const {
  Bed bed;
  bed.indicator = Grid<std::uint8_t>(lattice_, 1);
  Grid<std::uint32_t> labels(lattice_, 0);
  std::uint32_t next = 0;
  for (std::size_t n = 0; n < particles_.size(); ++n) {
    const Particle& p = particles_[n];
    if (!p.alive) continue;
    ++next;
    for (const std::int64_t off : p.voxels) {
      const auto o = static_cast<std::size_t>(p.base + off);
      // The walk's label lattice must agree with the particle's own voxel list.
      if (labels[o] != 0 || mask_[o] == 0 || labels_[o] != idOf(n) || !isOccupied(p.base + off))
        throw InternalError("Monte Carlo packer: overlapping or uncontained particle voxel");
      labels[o] = next;
      bed.indicator[o] = 0;
    }
    bed.particles.positionMm.push_back(centreOf(p));
    bed.particles.orientation.push_back(p.q);
    bed.particles.shape.push_back(mixture_[static_cast<std::size_t>(p.component)].shape->spec());
  }
  bed.mask = mask_;
  bed.labels = std::move(labels);
  return bed;
}

// Between two sweeps the whole state is particles, counters and the cursor: a
// checkpoint goes here, by the clock, and once more when the run is cancelled (so an
// interrupted run can be resumed from where it stopped).
void McPacker::sweepBoundary() {
  const bool writing = ckpt_.write && ckpt_.everySeconds > 0;
  if (progress_.cancelled()) {
    if (writing) ckpt_.write(saveState());
    throw Cancelled("Monte Carlo packing stopped");
  }
  if (!writing) return;
  const auto now = std::chrono::steady_clock::now();
  if (std::chrono::duration<double>(now - lastCheckpoint_).count() < ckpt_.everySeconds) return;
  ckpt_.write(saveState());
  lastCheckpoint_ = now;
}

nlohmann::json McPacker::identity() const {
  nlohmann::json mix = nlohmann::json::array();
  for (const auto& m : mixture_) mix.push_back({m.shape->spec(), m.fraction});
  nlohmann::json id = {{"options", toJson(o_)},
                       {"seed", seed_},
                       {"mixture", mix},
                       {"container", container_.spec()},
                       {"lattice", {lattice_.nz(), lattice_.ny(), lattice_.nx()}}};
  // Only a run started from a bed has the key, so earlier checkpoints keep their identity.
  if (startCount_ > 0) id["start_particles"] = startCount_;
  return id;
}

// pack --from: the bed's particles, each digitised again at its stored pose, become the
// first particles of the walk. The walk moves voxel sets, so they must give exactly the
// bed's own voxels (its labels, or its solid when it has none), on no wall and on no other
// particle: a bed whose poses do not rebuild its voxels (a DEM bed with overlaps, another
// lattice or supersampling) would be continued as another bed, so it is refused.
void McPacker::placeStartBed() {
  const Bed& b = *start_;
  const ParticleTable& t = b.particles;
  if (b.lattice().dims != lattice_.dims)
    throw InputError("the start bed: its lattice (" + std::to_string(b.lattice().nz()) + " x " +
                     std::to_string(b.lattice().ny()) + " x " + std::to_string(b.lattice().nx()) +
                     ") is not the walk's (" + std::to_string(lattice_.nz()) + " x " +
                     std::to_string(lattice_.ny()) + " x " + std::to_string(lattice_.nx()) + ")");
  if (t.empty() || t.orientation.size() != t.size() || t.shape.size() != t.size())
    throw InputError("the start bed: no particle table with orientations and shapes");
  DigitalParticle dp;
  for (std::size_t n = 0; n < t.size(); ++n) {
    int component = -1;
    for (std::size_t c = 0; c < mixture_.size() && component < 0; ++c)
      if (mixture_[c].shape->spec() == t.shape[n]) component = static_cast<int>(c);
    if (component < 0)
      throw InputError("the start bed: particle " + std::to_string(n + 1) + " has shape " +
                       t.shape[n] + ", which is not one of the scene's shapes");
    const std::uint32_t id = idOf(particles_.size());
    if (!digitiseFree(component, t.positionMm[n], t.orientation[n], id, dp))
      throw InputError("the start bed: particle " + std::to_string(n + 1) +
                       " digitised again at its stored pose overlaps another particle or the "
                       "wall layer; the walk cannot continue this bed");
    Particle p;
    p.component = component;
    adopt(p, dp, t.positionMm[n], t.orientation[n]);
    particles_.push_back(std::move(p));
    writeLabels(particles_.back(), id);
  }
  std::size_t differ = 0, first = 0;
  std::uint32_t firstBed = 0, firstMine = 0;
  for (std::size_t o = 0; o < lattice_.size(); ++o) {
    const std::uint32_t mine = labels_[o] == kWall ? 0 : labels_[o];
    const bool same = b.labels ? (*b.labels)[o] == mine : (b.indicator[o] == 0) == (mine != 0);
    if (same) continue;
    if (differ++ == 0) {
      first = o;
      firstBed = b.labels ? (*b.labels)[o] : (b.indicator[o] == 0 ? 1u : 0u);
      firstMine = mine;
    }
  }
  if (differ > 0) {
    const Index3 v = lattice_.indexOf(first);
    throw InputError("the start bed: " + std::to_string(differ) +
                     " voxels differ from the bed's own when its particles are digitised again "
                     "at their stored poses (first at voxel (k, j, i) = (" +
                     std::to_string(v.k) + ", " + std::to_string(v.j) + ", " + std::to_string(v.i) +
                     "): bed " + std::to_string(firstBed) + ", digitised " +
                     std::to_string(firstMine) + "); the walk cannot continue this bed");
  }
}

nlohmann::json McPacker::saveState() const {
  const Cursor& c = cursor_;
  nlohmann::json parts = nlohmann::json::array();
  for (const Particle& p : particles_)
    parts.push_back({p.component,
                     {p.centreMm.x(), p.centreMm.y(), p.centreMm.z()},
                     {p.q.w(), p.q.x(), p.q.y(), p.q.z()},
                     {p.shift[0], p.shift[1], p.shift[2]},
                     p.alive});
  const McStats& st = stats_;
  return {{"format", "voxpack-mc-state"},
          {"version", 1},
          {"identity", identity()},
          {"stage", static_cast<int>(c.stage)},
          {"status", static_cast<int>(c.status)},
          {"full", c.full},
          {"tap", c.tap},
          {"tap_sweep", c.tapSweep},
          {"settle",
           {{"sum", c.settle.sum},
            {"prev", c.settle.prev},
            {"have_prev", c.settle.havePrev},
            {"prev_mean", c.settle.prevMean},
            {"in_window", c.settle.inWindow}}},
          {"stats",
           {st.sweeps, st.triedMoves, st.acceptedMoves, st.triedRotations, st.acceptedRotations,
            st.batches, st.injected, st.removed}},
          {"assigned", assigned_},
          {"particles", parts}};
}

void McPacker::restoreState(const nlohmann::json& j) {
  try {
    if (j.at("format") != "voxpack-mc-state" || j.at("version") != 1)
      throw FormatError("checkpoint: not a Monte Carlo state of this version");
    if (j.at("identity") != identity())
      throw InputError(
          "checkpoint: it belongs to another run (options, seed, shapes, container or lattice "
          "differ)");
    Cursor c;
    const int stage = j.at("stage").get<int>(), status = j.at("status").get<int>();
    if (stage < 0 || stage > static_cast<int>(Stage::Finish) || status < 0 || status > 2)
      throw FormatError("checkpoint: bad stage or status");
    c.stage = static_cast<Stage>(stage);
    c.status = static_cast<McStatus>(status);
    c.full = j.at("full").get<bool>();
    c.tap = j.at("tap").get<int>();
    c.tapSweep = j.at("tap_sweep").get<int>();
    const auto& se = j.at("settle");
    c.settle.sum = se.at("sum").get<std::vector<double>>();
    c.settle.prev = se.at("prev").get<std::vector<double>>();
    c.settle.havePrev = se.at("have_prev").get<bool>();
    c.settle.prevMean = se.at("prev_mean").get<double>();
    c.settle.inWindow = se.at("in_window").get<int>();
    const auto st = j.at("stats").get<std::vector<std::int64_t>>();
    if (st.size() != 8) throw FormatError("checkpoint: bad stats");
    stats_.sweeps = st[0];
    stats_.triedMoves = st[1];
    stats_.acceptedMoves = st[2];
    stats_.triedRotations = st[3];
    stats_.acceptedRotations = st[4];
    stats_.batches = st[5];
    stats_.injected = st[6];
    stats_.removed = st[7];
    assigned_ = j.at("assigned").get<std::vector<std::int64_t>>();
    if (assigned_.size() != mixture_.size()) throw FormatError("checkpoint: bad mixture counts");
    const auto& parts = j.at("particles");
    if (parts.size() >= kWall - 1) throw FormatError("checkpoint: too many particles");
    particles_.clear();
    particles_.reserve(parts.size());
    for (const auto& e : parts) {
      const int comp = e.at(0).get<int>();
      if (comp < 0 || comp >= static_cast<int>(mixture_.size()))
        throw FormatError("checkpoint: bad particle component");
      const auto x = e.at(1).get<std::array<double, 3>>();
      const auto q = e.at(2).get<std::array<double, 4>>();
      const auto sh = e.at(3).get<std::array<std::int64_t, 3>>();
      const Vec3 cm(x[0], x[1], x[2]);
      const Quat qq(q[0], q[1], q[2], q[3]);
      const std::uint32_t id = idOf(particles_.size());
      // The same digitisation as when the pose was adopted, then its lattice shift; the
      // voxels must land inside the container and on no other particle.
      const DigitalParticle dp = digitise(*mixture_[static_cast<std::size_t>(comp)].shape, cm, qq,
                                          lattice_, DigitiseOptions{o_.supersample});
      Particle p;
      p.component = comp;
      adopt(p, dp, cm, qq);
      for (int a = 0; a < 3; ++a) {
        const std::int64_t n = sh[static_cast<std::size_t>(2 - a)];
        if (std::abs(n) > 2 * std::max({lattice_.nx(), lattice_.ny(), lattice_.nz()}))
          throw FormatError("checkpoint: particle shift out of the lattice");
        p.shift[static_cast<std::size_t>(2 - a)] = n;
        p.base += n * stride_[static_cast<std::size_t>(a)];
      }
      const auto total = static_cast<std::int64_t>(lattice_.size());
      for (const std::int64_t off : p.voxels) {
        const std::int64_t o = p.base + off;
        if (o < 0 || o >= total || labels_[static_cast<std::size_t>(o)] != 0)
          throw FormatError("checkpoint: particle " + std::to_string(particles_.size()) +
                            " overlaps another or leaves the container");
      }
      p.alive = e.at(4).get<bool>();
      particles_.push_back(std::move(p));
      writeLabels(particles_.back(), id);
    }
    if (c.settle.sum.size() != particles_.size() || c.settle.prev.size() != particles_.size())
      throw FormatError("checkpoint: settling window does not match the particles");
    cursor_ = std::move(c);
  } catch (const nlohmann::json::exception& e) {
    throw FormatError(std::string("checkpoint: malformed state (") + e.what() + ")");
  }
}

McResult McPacker::run() {
  const auto t0 = std::chrono::steady_clock::now();
  if (start_) startCount_ = static_cast<std::int64_t>(start_->particles.size());
  if (ckpt_.resume && ckpt_.resume->is_object() && ckpt_.resume->contains("identity") &&
      (*ckpt_.resume)["identity"].is_object())
    startCount_ = (*ckpt_.resume)["identity"].value("start_particles", std::int64_t{0});
  validate(o_, startCount_ > 0);
  if (mixture_.empty()) throw InputError("no particle shape given");
  double total = 0;
  for (const auto& m : mixture_) {
    if (!m.shape) throw InputError("null particle shape");
    require(finite(m.fraction) && m.fraction > 0, "shape fractions must be > 0");
    total += m.fraction;
    diameterMm_ = std::max(diameterMm_, m.shape->characteristicDiameterMm());
    maxBoundingMm_ = std::max(maxBoundingMm_, m.shape->boundingRadiusMm());
  }
  for (const auto& m : mixture_) fractions_.push_back(m.fraction / total);
  assigned_.assign(mixture_.size(), 0);
  window_ = settleWindowSweeps(o_, diameterMm_);
  stats_.settleWindow = window_;

  bounds_ = container_.boundsMm();
  if (o_.fillHeightMm > 0 && o_.fillHeightMm > bounds_.max.z() - bounds_.min.z() + 1e-9)
    throw InputError("--fill-height " + std::to_string(o_.fillHeightMm) +
                     " mm is above the container top");
  lattice_ = latticeForContainer(container_, o_.voxelSizeMm, 1);
  mask_ = containerMask(container_, lattice_, o_.supersample);
  labels_.assign(lattice_.size(), 0);
  occupied_.assign((lattice_.size() + 63) / 64, 0);
  stride_ = {1, lattice_.nx(), lattice_.nx() * lattice_.ny()};
  for (std::int64_t k = 0; k < lattice_.nz(); ++k)
    for (std::int64_t j = 0; j < lattice_.ny(); ++j)
      for (std::int64_t i = 0; i < lattice_.nx(); ++i) {
        const bool border = k == 0 || j == 0 || i == 0 || k == lattice_.nz() - 1 ||
                            j == lattice_.ny() - 1 || i == lattice_.nx() - 1;
        const std::size_t off = lattice_.offset(k, j, i);
        if (border || mask_[off] == 0) setVoxel(static_cast<std::int64_t>(off), kWall);
        if (border) mask_[off] = 0;
      }
  // A shape too small for the voxel digitises to nothing: refuse instead of packing void.
  for (const auto& m : mixture_) {
    const DigitalParticle dp = digitise(*m.shape, Vec3::Zero(), Quat::Identity(), lattice_,
                                        DigitiseOptions{o_.supersample});
    if (dp.voxels.empty())
      throw InputError("particle " + m.shape->spec() + " digitises to no voxel at voxel size " +
                       std::to_string(o_.voxelSizeMm) + " mm");
  }

  // A particle centre cannot come within about half a diameter of the lid, so a fill
  // height closer than one diameter to the top counts as reached when the bed gets there.
  const double fillGoalMm =
      std::min(o_.fillHeightMm, bounds_.max.z() - bounds_.min.z() - diameterMm_);
  if (start_ && !ckpt_.resume) {
    placeStartBed();
    // Nothing to add: the start bed goes straight to its taps (and is returned as it is
    // without them).
    if (o_.count == 0 && !(o_.fillHeightMm > 0)) cursor_.stage = Stage::AfterFill;
  }
  if (ckpt_.resume) restoreState(*ckpt_.resume);
  Cursor& c = cursor_;
  const int tapSweeps = o_.tapSweeps > 0 ? o_.tapSweeps : window_;
  while (c.stage != Stage::Finish) {
    switch (c.stage) {
      case Stage::Inject:
        if (injectBatch() == 0) {
          c.full = true;  // the previous settle's status stands
          c.stage = Stage::AfterFill;
          break;
        }
        startSettle(c.settle);
        c.stage = Stage::FillSettle;
        break;
      case Stage::FillSettle:
        c.status = settle(o_.reboundProbability, c.settle);
        c.stage = Stage::Inject;
        if (c.status == McStatus::CapReached || (o_.count > 0 && stats_.injected >= o_.count) ||
            (o_.fillHeightMm > 0 && highestCentreZ() - bounds_.min.z() >= fillGoalMm))
          c.stage = Stage::AfterFill;
        break;
      case Stage::AfterFill:
        if (c.full && c.status == McStatus::Settled) {
          // In fill mode a full container at the fill height is success, not a shortfall.
          const bool reached =
              o_.fillHeightMm > 0 && highestCentreZ() - bounds_.min.z() >= fillGoalMm - 1e-9;
          c.status = reached ? McStatus::Settled : McStatus::ContainerFull;
        }
        c.stage = Stage::TapSweeps;
        break;
      case Stage::TapSweeps: {
        if (c.tap >= o_.tapCycles || c.status == McStatus::CapReached) {
          c.stage = Stage::Finish;
          break;
        }
        // A tap: a phase of raised rebound probability loosens the bed, then it settles.
        const auto tt = std::chrono::steady_clock::now();
        while (c.tapSweep < tapSweeps && stats_.sweeps < o_.maxSweeps) {
          sweepBoundary();
          sweep(o_.tapReboundProbability);
          ++c.tapSweep;
        }
        stats_.walkSeconds +=
            std::chrono::duration<double>(std::chrono::steady_clock::now() - tt).count();
        startSettle(c.settle);
        c.stage = Stage::TapSettle;
        break;
      }
      case Stage::TapSettle:
        if (settle(o_.reboundProbability, c.settle) == McStatus::CapReached)
          c.status = McStatus::CapReached;
        ++c.tap;
        c.tapSweep = 0;
        c.stage = Stage::TapSweeps;
        break;
      case Stage::Finish:
        break;
    }
  }
  const McStatus status = c.status;
  if (o_.fillHeightMm > 0) {
    const double zMax = bounds_.min.z() + o_.fillHeightMm;
    for (Particle& p : particles_)
      if (p.alive && centreOf(p).z() > zMax) {
        p.alive = false;
        ++stats_.removed;
      }
  }

  McResult result;
  result.status = status;
  result.bed = buildBed();
  stats_.wallSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  result.stats = stats_;
  result.bed.provenance["mc"] = {
      {"options", toJson(o_)}, {"stats", toJson(stats_)}, {"status", toString(status)}};
  progress_.report("mc packing", 1.0);
  return result;
}

}  // namespace

McResult packMonteCarlo(const std::vector<MixtureComponent>& mixture, const Container& container,
                        const McOptions& options, std::uint64_t seed, Progress& progress,
                        const McCheckpointing& checkpointing, const Bed* start) {
  McPacker packer(mixture, container, options, seed, progress, checkpointing, start);
  return packer.run();
}

}  // namespace voxpack::packer
