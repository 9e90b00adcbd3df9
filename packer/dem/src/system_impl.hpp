#pragma once
// The DEM integrator's state, shared by its files (one per concern): broad_phase.cpp,
// narrow_phase.cpp, contact_law.cpp, walls.cpp, forces.cpp, integration.cpp, sleeping.cpp,
// tapping.cpp; system.cpp holds set-up and the public accessors. docs/dem.md.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "constants.hpp"
#include "voxpack/packer/dem.hpp"

namespace voxpack::packer::dem {

/// Body-frame angular velocity of a body with world angular momentum L, rotation r
/// (principal -> world) and principal moments I.
inline Vec3 bodyRate(const Eigen::Matrix3d& r, const Vec3& L, const Vec3& I) {
  return (r.transpose() * L).cwiseQuotient(I);
}

/// World angular velocity (the only way the module computes it from L).
inline Vec3 worldRate(const Eigen::Matrix3d& r, const Vec3& L, const Vec3& I) {
  return r * bodyRate(r, L, I);
}

/// One penetrating node: where, how deep, which way it pushes body A, how stiff.
struct Hit {
  Vec3 p;
  Vec3 dir;
  double depth;
  double kw;                ///< face stiffness x area weight x side factor (g/s^2)
  double wallFraction = 0;  ///< depth / thinnest wall of the body the node is in (pairs)
};

/// Kinematics and inertia of one side of a contact (a wall has zero inverse mass).
struct Body {
  Vec3 x = Vec3::Zero();
  Vec3 v = Vec3::Zero();
  Vec3 w = Vec3::Zero();
  double invMass = 0;                    ///< 1/g
  Vec3 invInertia = Vec3::Zero();        ///< principal 1/(g mm^2)
  const Eigen::Matrix3d* rot = nullptr;  ///< principal -> world (null for a wall)
  /// Inverse effective mass for a normal impulse along n at the world point p:
  /// 1/m + sum_k ((R^T ((p - x) x n))_k)^2 / I_k (a push off the centre line also turns it).
  double inverseMassAlong(const Vec3& p, const Vec3& n) const {
    if (!rot) return invMass;
    const Vec3 rn = rot->transpose() * (p - x).cross(n);
    return invMass + rn.cwiseProduct(rn).dot(invInertia);
  }
  /// Inverse moment of inertia about the world unit axis u (0 for a wall).
  double inverseInertiaAbout(const Vec3& u) const {
    if (!rot) return 0;
    const Vec3 ru = rot->transpose() * u;
    return ru.cwiseProduct(ru).dot(invInertia);
  }
};

/// Result of one contact on body A.
struct ContactOut {
  Vec3 force = Vec3::Zero();    ///< on A
  Vec3 torqueA = Vec3::Zero();  ///< on A about xA
  Vec3 xi = Vec3::Zero();       ///< tangential spring after this step
  bool touching = false;
  double maxDepth = 0;
  double elastic = 0;
  double wallFraction = 0;  ///< deepest hit over the thinnest wall it is in (pairs)
};

/// Contact parameters of one kind of contact (particle-particle or particle-wall).
struct ContactLaw {
  double friction = 0;
  double rolling = 0;  ///< rolling resistance mu_r (0 = none)
  /// Damping ratio for F ~ delta^p, p = 1, 1.25, ..., 4 (a rim or an edge entering node by
  /// node grows faster than a sphere cap).
  std::array<double, 13> zeta{};
  /// Damping ratio for the local force law exponent p (linear interpolation in the table).
  double zetaFor(double p) const {
    const double top = static_cast<double>(zeta.size() - 1);
    const double u = std::clamp((p - 1.0) / 0.25, 0.0, top);
    const int i = std::min(static_cast<int>(top) - 1, static_cast<int>(u));
    const double f = u - i;
    return (1 - f) * zeta[static_cast<std::size_t>(i)] + f * zeta[static_cast<std::size_t>(i) + 1];
  }
  /// The table for restitution e (calibrated by integrating one impact per exponent).
  static ContactLaw calibrated(double friction, double restitution);
};

/// A template's surface nodes (principal frame) in float, one array per axis: the vector
/// loads of the listed-node filter (narrow_phase.cpp).
struct NodeCoords {
  std::vector<float> x, y, z;
};

/// Up to this many wall contact regions per particle (see DemContainer::wallRegion).
inline constexpr int kWallRegions = 6;

struct DemSystem::Impl {
  std::vector<ParticleTemplate> tmpl;
  std::shared_ptr<const DemContainer> container;
  DemOptions opt;
  double k = 0;     // face stiffness, g/(mm^2 s^2)
  double kCap = 0;  // contact stiffness ceiling, g/s^2 (0 = none)
  double dt = 0;    // s
  double tc = 0;    // s
  ContactLaw pairLaw, wallLaw;
  double t = 0;
  bool resolved = false;
  bool diverged = false;  // a non-finite or runaway state was met; stepping stops
  double speedBound = 0;  // mm/s: faster than this is a blow-up
  // Tapping.
  double tapStart = 0;
  int tapCycles = 0;
  // Particles.
  std::vector<Vec3> x, v, L, F, T, xBuild;
  std::vector<Quat> q;  // principal -> world
  std::vector<std::uint32_t> tid;
  std::vector<std::uint8_t> awake;
  std::vector<std::uint32_t> slowSteps;  // steps in the current rest window
  std::vector<Vec3> xRest;               // position at the start of the rest window
  std::vector<Quat> qRest;               // orientation at the start of the rest window
  std::vector<std::array<Vec3, kWallRegions>> wallXi;
  std::vector<Vec3> wallF, wallT;
  std::vector<double> wallElastic, wallDepth;
  std::vector<std::uint8_t> wallTouching;  // contacts with the walls, last step
  // Nodes of each side that were within the node skin of the other body when the list was
  // searched, and the relative pose (i's frame in j's) at that search. Signed distances are
  // 1-Lipschitz, so while no node has moved more than the skin relative to the other body,
  // every penetrating node is on the list.
  struct NodeList {
    std::vector<std::uint32_t> a, b;
    Eigen::Matrix3d m = Eigen::Matrix3d::Identity();
    Vec3 off = Vec3::Zero(), offT = Vec3::Zero();
    bool valid = false;
  };
  struct Pair {
    std::uint32_t i, j;
    Vec3 xi;
    NodeList nodes;
  };
  // The same for one particle against the walls (pose and wall lift at the search).
  struct WallList {
    std::vector<std::uint32_t> nodes;
    Eigen::Matrix3d r = Eigen::Matrix3d::Identity();
    Vec3 x = Vec3::Zero();
    double lift = 0;
    bool valid = false;
  };
  std::vector<WallList> wallLists;
  double nodeSkin = 0;  // mm
  // Per template: principal frame -> shape frame as a matrix (the shape's distance function
  // takes shape-frame points; folding this into the pair transform saves a rotation a node).
  std::vector<Eigen::Matrix3d> toShape;
  struct Analytic {
    int form = 0;
    double r = 0, hl = 0;
  };
  std::vector<Analytic> analytic;      // per template: DemShape::analyticForm
  std::vector<NodeCoords> nodeCoords;  // per template
  bool avx2 = false;                   // the CPU runs AVX2 (the filter's vector path)
  // The container as an upright column (DemContainer::uprightColumn): its wall nodes go
  // through the float filter first.
  struct Column {
    bool on = false;
    double cx = 0, cy = 0, r = 0, floorZ = 0;
  } column;
  std::vector<std::uint8_t> closedForm;  // per template: sphere contacts in closed form
  std::vector<double> invMass;           // per template: 1 / mass
  std::vector<Vec3> invInertia;          // per template: 1 / principal moments
  double workTotal = 0;                  // contact work units of all particles (threads)

  // Signed distance of template t's shape at a shape-frame point; the common shapes inline.
  double sdfShape(std::uint32_t t0, const Vec3& p) const {
    const Analytic& a = analytic[t0];
    if (a.form != 0) return analyticSignedDistanceMm(a.form, a.r, a.hl, p);
    return tmpl[t0].shape->signedDistanceMm(p);
  }
  // Per particle, refreshed at each force evaluation: rotation and angular velocity.
  std::vector<Eigen::Matrix3d> rot;
  std::vector<Vec3> omegaW;
  std::vector<Pair> pairs;
  // Pairs of each particle in pair order (CSR): the force sum per particle then adds its
  // contacts in the same order for any thread count.
  std::vector<std::uint32_t> adjStart, adj;
  // Each pair's contact of the last evaluation, read only where pairEvaluated is set (one
  // byte a pair, so a rebuild clears 1/100 of the memory it would clearing the contacts).
  std::vector<ContactOut> pairOut;
  std::vector<std::uint8_t> pairEvaluated;
  // The live set of a force evaluation (forces.cpp): once most of a bed sleeps, only awake
  // particles, the sleepers touching them and their pairs are visited, so a step costs what
  // moves, not the whole bed. liveMark bit 0: live in this evaluation; bit 1: in the last.
  bool liveAll = true;        // this evaluation visits everything (most are awake)
  bool liveAllNext = true;    // the next one must (a restored state)
  bool pairOutStale = false;  // pairEvaluated may be set outside livePairs
  std::vector<std::uint8_t> liveMark;
  std::vector<std::uint32_t> livePairs;  // pair indices with an awake end, ascending
  std::vector<std::uint32_t> liveList;   // particles with a liveMark bit, ascending
  std::vector<std::uint8_t> pairMark;    // selectLive scratch (all zero between calls)
  std::vector<std::uint8_t> fast;        // sleeping.cpp scratch: moving fast this step
  // The awake particles, ascending; kept by sleepUpdate while the live set is in use, so no
  // per-step pass costs the whole bed. Invalid after anything else sets awake flags.
  std::vector<std::uint32_t> awakeList;
  bool awakeListValid = false;
  // Particles integrated since the last neighbour build (the only ones whose centre can
  // differ from xBuild); movedAll when that is not known (a restored state, a full pass).
  std::vector<std::uint32_t> movedList;
  std::vector<std::uint8_t> movedMark;
  bool movedAll = true;
  // The last build's cell list (cell key, particle), ascending: a partial rebuild updates it.
  std::vector<std::pair<std::uint64_t, std::uint32_t>> cellKeys;
  std::vector<std::pair<std::uint64_t, std::uint32_t>> cellMerge;  // its update's scratch
  void selectLive();
  void listAwake();  // awakeList from the flags (a pass over all particles)
  bool forcesValid = false;
  bool needRebuild = true;
  double skin = 0;
  double elastic = 0;
  double maxDepth = 0;
  double sumDepth = 0;  // over touching contacts, last force evaluation
  std::uint64_t contactCount = 0;
  std::uint64_t interpenetrations = 0;      // pairs, last force evaluation
  double maxWallFraction = 0;               // pairs, last force evaluation
  double runMaxWallFraction = 0;            // pairs, every step of this process
  std::uint64_t interpenetratingSteps = 0;  // steps with an interpenetrating pair
  DemCounters counters;

  double rMaxMm = 0;      // largest bounding radius of the templates
  double dMinMm = 1e300;  // smallest volume-equivalent diameter of the templates
  double rMax() const;
  double dMin() const;
  int threadsFor(double items, double work) const;  // 1 below the parallel thresholds
  int particleThreads() const;  // threads of the per-particle passes (with the contacts')
  Body body(std::size_t i) const;

  // tapping.cpp
  double wallOffset(double time, double* velocity) const;
  double tapAmplitude() const;
  double tapEnd() const;
  bool wallLiftingAt(double time) const;
  bool wallMovingAt(double time) const;
  // contact_law.cpp
  ContactOut nodeContact(const std::vector<Hit>& hits, const Body& a, const Body& b,
                         const ContactLaw& law, const Vec3& xiOld) const;
  ContactOut closedContact(double volume, double area, double depth, const Vec3& n, const Vec3& cp,
                           const Body& a, const Body& b, const ContactLaw& law,
                           const Vec3& xiOld) const;
  void friction(const Vec3& n, const Vec3& cp, double fnMag, double kSum, double zetaC,
                double mStar, const Body& a, const Body& b, const ContactLaw& law,
                const Vec3& xiOld, ContactOut& out) const;
  void rolling(const Vec3& n, const Vec3& cp, double fnMag, const Body& a, const Body& b,
               const ContactLaw& law, ContactOut& out) const;
  // narrow_phase.cpp. nodeHit is forced inline at its call sites: as a call with ten arguments
  // it cost ~5 % of a pour (docs/dem.md, 2026-12-08).
  [[gnu::always_inline]] inline Hit nodeHit(const ParticleTemplate& ta, const ParticleTemplate& tb,
                                            std::uint32_t ni, const Vec3& nShape, double s,
                                            const Vec3& xa, const Eigen::Matrix3d& ra,
                                            const Eigen::Matrix3d& rbS, double factor,
                                            double sign) const;
  void searchNodes(std::size_t a, std::size_t b, const Eigen::Matrix3d& ra,
                   const Eigen::Matrix3d& rbS, const Eigen::Matrix3d& m, const Vec3& off,
                   double factor, double sign, std::vector<Hit>& hits,
                   std::vector<std::uint32_t>& list, std::uint64_t& evals) const;
  void listedNodes(std::size_t a, std::size_t b, const Eigen::Matrix3d& ra,
                   const Eigen::Matrix3d& rbS, const Eigen::Matrix3d& m, const Vec3& off,
                   double factor, double sign, std::vector<Hit>& hits,
                   const std::vector<std::uint32_t>& list, std::uint64_t& evals) const;
  void pairHits(Pair& p, std::vector<Hit>& hits, std::uint64_t& evals,
                std::uint64_t& searches) const;
  ContactOut spherePair(const Pair& p) const;
  // broad_phase.cpp
  void rebuildNeighbours();
  // walls.cpp
  void wallForces(std::size_t i, double zw, double vw, std::vector<Hit> (&hits)[kWallRegions],
                  std::uint64_t& evals, std::uint64_t& searches);
  // forces.cpp: the forces, then (kick > 0) v += kick F / m and L += kick T of the awake.
  void computeForces(double kick);
  // Scratch hit lists of each thread of the force loop (kept between steps).
  struct Scratch {
    std::vector<Hit> pair;
    std::vector<Hit> wall[kWallRegions];
  };
  std::vector<Scratch> scratch;
  // integration.cpp
  double kickDrift(double h);
  void stepOnce();
  // sleeping.cpp: returns the number of particles awake after the update.
  void restartWindow(std::size_t i);
  std::size_t sleepUpdate();
};

}  // namespace voxpack::packer::dem
