// The DEM integrator: broad phase on a cell list, narrow phase on surface nodes, spring-
// dashpot contacts with Coulomb friction, velocity Verlet, sleeping. docs/dem.md.
#include <omp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>

#include "voxpack/core/errors.hpp"
#include "voxpack/packer/dem.hpp"

namespace voxpack::packer::dem {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int kWallClasses = 6;  // wall contacts per particle, by the wall normal's main axis

// One penetrating node: where, how deep, which way it pushes body A, how stiff.
struct Hit {
  Vec3 p;
  Vec3 dir;
  double depth;
  double kw;  // face stiffness x area weight x side factor (g/s^2)
};

// Kinematics of one side of a contact (the wall is a body with infinite mass).
struct Kin {
  Vec3 x = Vec3::Zero();
  Vec3 v = Vec3::Zero();
  Vec3 w = Vec3::Zero();
};

struct ContactOut {
  Vec3 force = Vec3::Zero();    // on A
  Vec3 torqueA = Vec3::Zero();  // on A about xA
  Vec3 xi = Vec3::Zero();       // tangential spring after this step
  bool touching = false;
  double maxDepth = 0;
  double elastic = 0;
};

Vec3 quatStep(const Quat& q, const Vec3& theta, Quat& out) {
  const double a = theta.norm();
  Quat dq = Quat::Identity();
  if (a > 0) dq = Quat(Eigen::AngleAxisd(a, theta / a));
  out = (q * dq).normalized();
  return theta;
}

// Restitution of one impact with F = delta^p, damping 2 zeta sqrt(K), K = dF/d(delta),
// unit mass and unit approach speed (the result does not depend on either).
double powerLawRestitution(double zeta, double p) {
  double x = 0, v = 1;
  const double h = 1e-3;
  for (int s = 0; s < 200000; ++s) {
    const double xp = std::max(x, 0.0);
    const double f = -std::pow(xp, p) - 2 * zeta * std::sqrt(p * std::pow(xp, p - 1)) * v;
    v += h * f;
    x += h * v;
    if (x <= 0 && v < 0) return -v;
  }
  return 0;
}

// Damping ratio that gives restitution e for the law F ~ delta^p (bisection).
double calibratedZeta(double e, double p) {
  if (e >= 1) return 0;
  const double target = std::max(e, 1e-3);
  double lo = 0, hi = 4;
  for (int it = 0; it < 30; ++it) {
    const double mid = 0.5 * (lo + hi);
    (powerLawRestitution(mid, p) > target ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

}  // namespace

const char* statusName(DemStatus s) {
  switch (s) {
    case DemStatus::kSettled:
      return "settled";
    case DemStatus::kTimeCap:
      return "time_cap";
    case DemStatus::kCancelled:
      return "cancelled";
  }
  return "unknown";
}

struct DemSystem::Impl {
  std::vector<ParticleTemplate> tmpl;
  std::shared_ptr<const DemContainer> container;
  DemOptions opt;
  double k = 0;                       // face stiffness, g/(mm^2 s^2)
  double kCap = 0;                    // contact stiffness ceiling, g/s^2 (0 = none)
  double dt = 0;                      // s
  double tc = 0;                      // s
  double zeta = 0;                    // damping ratio from restitution (linear law)
  std::array<double, 7> zetaTable{};  // damping ratio for F ~ delta^p, p = 1, 1.25, ..., 2.5

  double zetaFor(double p) const {
    const double u = std::clamp((p - 1.0) / 0.25, 0.0, 6.0);
    const int i = std::min(5, static_cast<int>(u));
    const double f = u - i;
    return (1 - f) * zetaTable[static_cast<std::size_t>(i)] +
           f * zetaTable[static_cast<std::size_t>(i) + 1];
  }
  double t = 0;
  bool resolved = false;
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
  std::vector<std::array<Vec3, kWallClasses>> wallXi;
  std::vector<Vec3> wallF, wallT;
  std::vector<double> wallElastic, wallDepth;
  // Pairs.
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
  std::vector<Analytic> analytic;  // per template: DemShape::analyticForm
  double nodeTotal = 0;            // surface nodes of all particles (thread threshold)

  // Signed distance of template t's shape at a shape-frame point; the common shapes inline.
  double sdfShape(std::uint32_t t, const Vec3& p) const {
    const Analytic& a = analytic[t];
    if (a.form != 0) return analyticSignedDistanceMm(a.form, a.r, a.hl, p);
    return tmpl[t].shape->signedDistanceMm(p);
  }
  // Per particle, refreshed at each force evaluation: rotation and angular velocity.
  std::vector<Eigen::Matrix3d> rot;
  std::vector<Vec3> omegaW;
  std::vector<Pair> pairs;
  struct PairOut {
    ContactOut c;
    bool evaluated = false;
  };
  std::vector<PairOut> pairOut;
  bool forcesValid = false;
  bool needRebuild = true;
  double skin = 0;
  double elastic = 0;
  double maxDepth = 0;
  DemCounters counters;

  double rMax() const {
    double r = 0;
    for (const auto& t0 : tmpl) r = std::max(r, t0.radiusMm);
    return r;
  }
  double dMin() const {
    double d = 1e300;
    for (const auto& t0 : tmpl) d = std::min(d, t0.diameterMm);
    return d;
  }

  double wallOffset(double time, double* velocity) const {
    if (velocity) *velocity = 0;
    if (tapCycles <= 0 || time < tapStart) return 0;
    const double f = opt.tapFrequencyHz;
    const double period = 1.0 / f + opt.tapRestS;
    const double tau = time - tapStart;
    const int cycle = static_cast<int>(std::floor(tau / period));
    if (cycle >= tapCycles) return 0;
    const double local = tau - cycle * period;
    if (local >= 1.0 / f) return 0;
    const double a = tapAmplitude();
    const double w = 2 * kPi * f;
    // Smooth lift and return: z = A/2 (1 - cos wt); peak acceleration A/2 w^2.
    if (velocity) *velocity = 0.5 * a * w * std::sin(w * local);
    return 0.5 * a * (1 - std::cos(w * local));
  }
  double tapAmplitude() const { return opt.tapAmplitudeMm > 0 ? opt.tapAmplitudeMm : 0.3 * dMin(); }
  double tapEnd() const { return tapStart + tapCycles * (1.0 / opt.tapFrequencyHz + opt.tapRestS); }

  Vec3 omega(std::size_t i) const {
    const ParticleTemplate& tp = tmpl[tid[i]];
    const Eigen::Matrix3d r = q[i].toRotationMatrix();
    const Vec3 lb = r.transpose() * L[i];
    return r * Vec3(lb.x() / tp.inertiaG.x(), lb.y() / tp.inertiaG.y(), lb.z() / tp.inertiaG.z());
  }

  // Spring-dashpot over the hits of one contact, plus the tangential spring of the contact.
  ContactOut contact(const std::vector<Hit>& hits, const Kin& a, const Kin& b, double mStar,
                     const Vec3& xiOld) const {
    ContactOut out;
    if (hits.empty()) return out;
    out.touching = true;
    double wd = 0;
    Vec3 spring = Vec3::Zero(), cp = Vec3::Zero();
    for (const Hit& h : hits) {
      spring += h.kw * h.depth * h.dir;
      cp += h.kw * h.depth * h.p;
      wd += h.kw * h.depth;
      out.maxDepth = std::max(out.maxDepth, h.depth);
      out.elastic += 0.5 * h.kw * h.depth * h.depth;
    }
    cp /= wd;
    const double springMag = spring.norm();
    const Vec3 nHat = springMag > 0 ? Vec3(spring / springMag) : Vec3(0, 0, 1);
    // Tangent stiffness K = dF/d(delta) of the contact: node stiffnesses projected on the
    // contact normal (a voxel face across the normal adds no normal stiffness).
    double kSum = 0;
    for (const Hit& h : hits) kSum += h.kw * std::abs(h.dir.dot(nHat));
    if (!(kSum > 0)) return out;
    // Stiffness ceiling: a wide flat contact (face on face) would otherwise be far stiffer
    // than the curved contacts the time step is made for; it saturates at kCap instead.
    const double scale = kCap > 0 && kSum > kCap ? kCap / kSum : 1.0;
    kSum *= scale;
    out.elastic *= scale;
    // Local force law F ~ delta^p (p = 1 flat faces, 2 sphere caps) picks the damping
    // ratio that gives the requested restitution for that law (calibrated at start-up).
    const double p = springMag > 0 ? kSum * out.maxDepth / springMag : 1.0;
    const double zetaC = zetaFor(p);
    // Contact damping 2 zeta sqrt(m* K), shared among the nodes like their stiffness.
    const double eta = 2 * zetaC * std::sqrt(mStar * kSum);
    const double etaPerK = eta / kSum;
    Vec3 force = Vec3::Zero(), torque = Vec3::Zero();
    for (const Hit& h : hits) {
      const Vec3 vrel = a.v + a.w.cross(h.p - a.x) - b.v - b.w.cross(h.p - b.x);
      const double c = std::abs(h.dir.dot(nHat));
      const double fn = scale * h.kw * (h.depth - c * etaPerK * vrel.dot(h.dir));
      const Vec3 f = fn * h.dir;
      force += f;
      torque += (h.p - a.x).cross(f);
    }
    Vec3 xi = Vec3::Zero();
    if (springMag > 0) {
      const Vec3& n = nHat;
      const double fnMag = std::max(0.0, force.dot(n));
      const Vec3 vrel = a.v + a.w.cross(cp - a.x) - b.v - b.w.cross(cp - b.x);
      const Vec3 vt = vrel - vrel.dot(n) * n;
      // Keep the spring in the current tangent plane with its length (contact rotation).
      xi = xiOld - xiOld.dot(n) * n;
      const double oldLen = xiOld.norm(), newLen = xi.norm();
      if (newLen > 0) xi *= oldLen / newLen;
      xi += vt * dt;
      const double kt = opt.tangentialStiffnessRatio * kSum;
      const double etaT = 2 * zetaC * std::sqrt(mStar * kt);
      Vec3 ft = -kt * xi - etaT * vt;
      const double ftMag = ft.norm();
      const double limit = opt.friction * fnMag;
      if (ftMag > limit) {
        ft = ftMag > 0 ? Vec3(ft * (limit / ftMag)) : Vec3::Zero();
        xi = kt > 0 ? Vec3(-(ft + etaT * vt) / kt) : Vec3::Zero();
      }
      force += ft;
      torque += (cp - a.x).cross(ft);
    }
    out.force = force;
    out.torqueA = torque;
    out.xi = xi;
    return out;
  }

  // A penetrating node ni of a (position pb in b's shape frame) as a hit on a; rbS maps b's
  // shape frame to the world.
  Hit nodeHit(const ParticleTemplate& ta, const ParticleTemplate& tb, std::uint32_t ni,
              const Vec3& pb, double s, const Vec3& xa, const Eigen::Matrix3d& ra,
              const Eigen::Matrix3d& rbS, double factor, double sign) const {
    Hit h;
    h.p = xa + ra * ta.nodeP[ni];
    h.depth = -s;
    if (opt.contact == ContactModel::kVoxel) {
      h.dir = -(ra * ta.nodeFace[ni]);
      h.kw = k * ta.nodeArea[ni] * factor;
    } else {
      h.dir = rbS * tb.shape->normal(pb);
      h.kw = k * ta.nodeLsArea[ni] * factor;
    }
    h.dir *= sign;
    return h;
  }

  // Nodes of a inside b, searched through a's cluster hierarchy; nodes within the node skin
  // of b go to `list`. m, off map a's body frame into b's shape frame, rbS b's shape frame
  // to the world. Force direction on a times sign.
  void searchNodes(std::size_t a, std::size_t b, const Eigen::Matrix3d& ra,
                   const Eigen::Matrix3d& rbS, const Eigen::Matrix3d& m, const Vec3& off,
                   double factor, double sign, std::vector<Hit>& hits,
                   std::vector<std::uint32_t>& list, std::uint64_t& evals) const {
    const ParticleTemplate& ta = tmpl[tid[a]];
    const ParticleTemplate& tb = tmpl[tid[b]];
    const double rb0 = tb.radiusMm + nodeSkin;
    // b's bounding sphere in a's frame: the cheap first test, no rotation per cluster.
    const Vec3 cba = ra.transpose() * (x[b] - x[a]);
    list.clear();
    for (const auto& c : ta.coarse) {
      const double reachC = rb0 + c.radius;
      if ((c.centre - cba).squaredNorm() > reachC * reachC) continue;
      ++evals;
      if (sdfShape(tid[b], m * c.centre + off) > c.radius + nodeSkin) continue;
      for (std::uint32_t fi = c.begin; fi < c.end; ++fi) {
        const auto& f = ta.fine[fi];
        const double reachF = rb0 + f.radius;
        if ((f.centre - cba).squaredNorm() > reachF * reachF) continue;
        ++evals;
        if (sdfShape(tid[b], m * f.centre + off) > f.radius + nodeSkin) continue;
        for (std::uint32_t ni = f.begin; ni < f.end; ++ni) {
          if ((ta.nodeP[ni] - cba).squaredNorm() > rb0 * rb0) continue;
          const Vec3 pb = m * ta.nodeP[ni] + off;
          ++evals;
          const double s = sdfShape(tid[b], pb);
          if (s >= nodeSkin) continue;
          list.push_back(ni);
          if (s >= 0) continue;
          const Hit h = nodeHit(ta, tb, ni, pb, s, x[a], ra, rbS, factor, sign);
          if (h.kw > 0) hits.push_back(h);
        }
      }
    }
  }

  // Nodes of a inside b among the listed ones (same order as the search found them).
  void listedNodes(std::size_t a, std::size_t b, const Eigen::Matrix3d& ra,
                   const Eigen::Matrix3d& rbS, const Eigen::Matrix3d& m, const Vec3& off,
                   double factor, double sign, std::vector<Hit>& hits,
                   const std::vector<std::uint32_t>& list, std::uint64_t& evals) const {
    const ParticleTemplate& ta = tmpl[tid[a]];
    const ParticleTemplate& tb = tmpl[tid[b]];
    evals += list.size();
    for (const std::uint32_t ni : list) {
      const Vec3 pb = m * ta.nodeP[ni] + off;
      const double s = sdfShape(tid[b], pb);
      if (s >= 0) continue;
      const Hit h = nodeHit(ta, tb, ni, pb, s, x[a], ra, rbS, factor, sign);
      if (h.kw > 0) hits.push_back(h);
    }
  }

  // Hits of pair p (nodes of i in j, then nodes of j in i), from its node lists when the
  // relative pose has not moved more than the skin since they were searched.
  void pairHits(Pair& p, std::vector<Hit>& hits, std::uint64_t& evals,
                std::uint64_t& searches) const {
    const Eigen::Matrix3d& ri = rot[p.i];
    const Eigen::Matrix3d& rj = rot[p.j];
    const Eigen::Matrix3d m = rj.transpose() * ri;  // i's frame -> j's frame
    const Vec3 off = rj.transpose() * (x[p.i] - x[p.j]);
    const Vec3 offT = ri.transpose() * (x[p.j] - x[p.i]);  // i's frame: j's centre
    NodeList& nl = p.nodes;
    bool fresh = nl.valid;
    if (fresh) {
      // A node at radius r moves by at most |dm|_F r + |d off| (Frobenius bounds the 2-norm);
      // the inverse transform has the same |dm|_F.
      const double dm = (m - nl.m).norm();
      const double moveI = dm * tmpl[tid[p.i]].radiusMm + (off - nl.off).norm();
      const double moveJ = dm * tmpl[tid[p.j]].radiusMm + (offT - nl.offT).norm();
      fresh = std::max(moveI, moveJ) < nodeSkin;
    }
    // Into the other body's shape frame, where its distance function is defined.
    const Eigen::Matrix3d& si = toShape[tid[p.i]];
    const Eigen::Matrix3d& sj = toShape[tid[p.j]];
    const Eigen::Matrix3d mIJ = sj * m, mJI = si * m.transpose();
    const Vec3 offIJ = sj * off, offJI = si * offT;
    const Eigen::Matrix3d rjS = rj * sj.transpose(), riS = ri * si.transpose();
    if (fresh) {
      listedNodes(p.i, p.j, ri, rjS, mIJ, offIJ, 0.5, 1.0, hits, nl.a, evals);
      listedNodes(p.j, p.i, rj, riS, mJI, offJI, 0.5, -1.0, hits, nl.b, evals);
      return;
    }
    ++searches;
    searchNodes(p.i, p.j, ri, rjS, mIJ, offIJ, 0.5, 1.0, hits, nl.a, evals);
    searchNodes(p.j, p.i, rj, riS, mJI, offJI, 0.5, -1.0, hits, nl.b, evals);
    nl.m = m;
    nl.off = off;
    nl.offT = offT;
    nl.valid = true;
  }

  void rebuildNeighbours() {
    ++counters.neighbourRebuilds;
    const std::size_t n = x.size();
    const double cell = 2 * rMax() + skin;
    std::vector<std::pair<std::uint64_t, std::uint32_t>> keys(n);
    auto cellIndex = [&](const Vec3& p) {
      std::array<std::int64_t, 3> c{};
      for (int a = 0; a < 3; ++a) c[a] = static_cast<std::int64_t>(std::floor(p[a] / cell));
      return c;
    };
    auto pack = [](std::int64_t cx, std::int64_t cy, std::int64_t cz) {
      return (static_cast<std::uint64_t>(cz + (1 << 20)) << 42) |
             (static_cast<std::uint64_t>(cy + (1 << 20)) << 21) |
             static_cast<std::uint64_t>(cx + (1 << 20));
    };
    for (std::size_t i = 0; i < n; ++i) {
      const auto c = cellIndex(x[i]);
      keys[i] = {pack(c[0], c[1], c[2]), static_cast<std::uint32_t>(i)};
    }
    std::sort(keys.begin(), keys.end());
    std::vector<Pair> fresh;
    for (std::size_t i = 0; i < n; ++i) {
      const auto c = cellIndex(x[i]);
      const double ri = tmpl[tid[i]].radiusMm;
      for (int dz = -1; dz <= 1; ++dz)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            const std::uint64_t key = pack(c[0] + dx, c[1] + dy, c[2] + dz);
            auto it =
                std::lower_bound(keys.begin(), keys.end(), std::make_pair(key, std::uint32_t{0}));
            for (; it != keys.end() && it->first == key; ++it) {
              const std::uint32_t j = it->second;
              if (j <= i) continue;
              const double reach = ri + tmpl[tid[j]].radiusMm + skin;
              if ((x[i] - x[j]).squaredNorm() < reach * reach)
                fresh.push_back({static_cast<std::uint32_t>(i), j, Vec3::Zero(), NodeList{}});
            }
          }
    }
    std::sort(fresh.begin(), fresh.end(),
              [](const Pair& a, const Pair& b) { return a.i != b.i ? a.i < b.i : a.j < b.j; });
    // Carry the tangential springs of surviving pairs over (both lists are sorted).
    std::size_t o = 0;
    for (Pair& p : fresh) {
      while (o < pairs.size() && (pairs[o].i < p.i || (pairs[o].i == p.i && pairs[o].j < p.j))) ++o;
      if (o < pairs.size() && pairs[o].i == p.i && pairs[o].j == p.j) {
        p.xi = pairs[o].xi;
        p.nodes = std::move(pairs[o].nodes);
      }
    }
    pairs.swap(fresh);
    pairOut.assign(pairs.size(), PairOut{});
    xBuild = x;
    needRebuild = false;
  }

  void computeForces() {
    const std::size_t n = x.size();
    const int threads = std::max(1, opt.threads);
    double vw = 0;
    const double zw = wallOffset(t, &vw);
    const Vec3 wallShift(0, 0, zw);
    const double meanNodes = nodeTotal / std::max<double>(1.0, static_cast<double>(n));
    rot.resize(n);
    omegaW.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      rot[i] = q[i].toRotationMatrix();
      const ParticleTemplate& tp = tmpl[tid[i]];
      const Vec3 lb = rot[i].transpose() * L[i];
      omegaW[i] = rot[i] * lb.cwiseQuotient(tp.inertiaG);
    }
    // Pairs: each writes only its own slot, then a serial sum in pair order keeps the
    // result independent of the thread count.
    std::uint64_t evalsTotal = 0, evaluated = 0, searches = 0;
    const std::int64_t np = static_cast<std::int64_t>(pairs.size());
    // Small systems run serial: a parallel region costs more than it saves there, and far
    // more on an oversubscribed machine.
    const bool worthIt = np >= opt.parallelMinItems &&
                         static_cast<double>(np) * meanNodes >= opt.parallelMinNodeWork;
    const int pairThreads = worthIt ? threads : 1;
#pragma omp parallel num_threads(pairThreads) reduction(+ : evalsTotal, evaluated, searches)
    {
      std::vector<Hit> hits;
#pragma omp for schedule(dynamic, 32)
      for (std::int64_t pi = 0; pi < np; ++pi) {
        Pair& p = pairs[static_cast<std::size_t>(pi)];
        PairOut& po = pairOut[static_cast<std::size_t>(pi)];
        po = PairOut{};
        if (!awake[p.i] && !awake[p.j]) continue;
        const double reach = tmpl[tid[p.i]].radiusMm + tmpl[tid[p.j]].radiusMm;
        if ((x[p.i] - x[p.j]).squaredNorm() >= reach * reach) continue;
        ++evaluated;
        po.evaluated = true;
        hits.clear();
        std::uint64_t evals = 0;
        // Both surfaces probe each other at half stiffness: symmetric, and a flat contact
        // of area A and overlap delta carries k A delta as against a wall.
        pairHits(p, hits, evals, searches);
        evalsTotal += evals;
        Kin a{x[p.i], v[p.i], omegaW[p.i]}, b{x[p.j], v[p.j], omegaW[p.j]};
        const double mi = tmpl[tid[p.i]].massG, mj = tmpl[tid[p.j]].massG;
        po.c = contact(hits, a, b, mi * mj / (mi + mj), p.xi);
      }
    }
    // Walls: per particle, six contact classes.
    std::uint64_t wallEvals = 0, wallSearches = 0;
    const int wallThreads = static_cast<std::int64_t>(n) >= 4 * opt.parallelMinItems &&
                                    static_cast<double>(n) * meanNodes >= opt.parallelMinNodeWork
                                ? threads
                                : 1;
#pragma omp parallel num_threads(wallThreads) reduction(+ : wallEvals, wallSearches)
    {
      std::array<std::vector<Hit>, kWallClasses> hits;
#pragma omp for schedule(dynamic, 16)
      for (std::int64_t si = 0; si < static_cast<std::int64_t>(n); ++si) {
        const std::size_t i = static_cast<std::size_t>(si);
        wallF[i].setZero();
        wallT[i].setZero();
        wallElastic[i] = 0;
        wallDepth[i] = 0;
        if (!awake[i]) continue;
        const ParticleTemplate& tp = tmpl[tid[i]];
        ++wallEvals;
        if (container->wallDistanceMm(x[i] - wallShift) > tp.radiusMm) {
          for (auto& xi : wallXi[i]) xi.setZero();
          continue;
        }
        for (auto& h : hits) h.clear();
        const Eigen::Matrix3d& r = rot[i];
        const bool voxel = opt.contact == ContactModel::kVoxel;
        WallList& wl = wallLists[i];
        bool fresh = wl.valid;
        if (fresh) {
          const double move =
              (r - wl.r).norm() * tp.radiusMm + (x[i] - wl.x).norm() + std::abs(zw - wl.lift);
          fresh = move < nodeSkin;
        }
        auto probe = [&](std::uint32_t ni, const Vec3& p, double s) {
          const Vec3 nw = container->inwardNormal(p - wallShift);
          int axis = 0;
          nw.cwiseAbs().maxCoeff(&axis);
          const int cls = 2 * axis + (nw[axis] > 0 ? 1 : 0);
          Hit h;
          h.p = p;
          h.depth = -s;
          if (voxel) {
            h.dir = -(r * tp.nodeFace[ni]);
            h.kw = k * tp.nodeArea[ni];
          } else {
            h.dir = nw;
            h.kw = k * tp.nodeLsArea[ni];
          }
          if (h.kw > 0) hits[static_cast<std::size_t>(cls)].push_back(h);
        };
        if (fresh) {
          wallEvals += wl.nodes.size();
          for (const std::uint32_t ni : wl.nodes) {
            const Vec3 p = x[i] + r * tp.nodeP[ni];
            const double s = container->wallDistanceMm(p - wallShift);
            if (s < 0) probe(ni, p, s);
          }
        } else {
          ++wallSearches;
          wl.nodes.clear();
          for (const auto& c : tp.coarse) {
            ++wallEvals;
            if (container->wallDistanceMm(x[i] + r * c.centre - wallShift) > c.radius + nodeSkin)
              continue;
            for (std::uint32_t fi = c.begin; fi < c.end; ++fi) {
              const auto& f = tp.fine[fi];
              ++wallEvals;
              if (container->wallDistanceMm(x[i] + r * f.centre - wallShift) > f.radius + nodeSkin)
                continue;
              for (std::uint32_t ni = f.begin; ni < f.end; ++ni) {
                const Vec3 p = x[i] + r * tp.nodeP[ni];
                ++wallEvals;
                const double s = container->wallDistanceMm(p - wallShift);
                if (s >= nodeSkin) continue;
                wl.nodes.push_back(ni);
                if (s < 0) probe(ni, p, s);
              }
            }
          }
          wl.r = r;
          wl.x = x[i];
          wl.lift = zw;
          wl.valid = true;
        }
        const Kin a{x[i], v[i], omegaW[i]};
        Kin b;
        b.x = x[i];
        b.v = Vec3(0, 0, vw);
        for (int cls = 0; cls < kWallClasses; ++cls) {
          const ContactOut c = contact(hits[cls], a, b, tp.massG, wallXi[i][cls]);
          wallXi[i][cls] = c.touching ? c.xi : Vec3::Zero();
          wallF[i] += c.force;
          wallT[i] += c.torqueA;
          wallElastic[i] += c.elastic;
          wallDepth[i] = std::max(wallDepth[i], c.maxDepth);
        }
      }
    }
    counters.nodeEvaluations += evalsTotal + wallEvals;
    counters.nodeListRebuilds += searches + wallSearches;
    counters.pairChecks += pairs.size();
    counters.pairEvaluations += evaluated;

    elastic = 0;
    maxDepth = 0;
    for (std::size_t i = 0; i < n; ++i) {
      F[i] = Vec3(0, 0, -opt.gravityMmPerS2 * tmpl[tid[i]].massG);
      T[i].setZero();
    }
    for (std::size_t pi = 0; pi < pairs.size(); ++pi) {
      Pair& p = pairs[pi];
      const PairOut& po = pairOut[pi];
      if (!po.evaluated) {
        // A pair of sleeping particles keeps its spring; separated pairs lose it.
        if (awake[p.i] || awake[p.j]) p.xi.setZero();
        continue;
      }
      p.xi = po.c.touching ? po.c.xi : Vec3::Zero();
      if (!po.c.touching) continue;
      F[p.i] += po.c.force;
      T[p.i] += po.c.torqueA;
      F[p.j] -= po.c.force;
      T[p.j] -= po.c.torqueA + (x[p.i] - x[p.j]).cross(po.c.force);
      elastic += po.c.elastic;
      maxDepth = std::max(maxDepth, po.c.maxDepth);
    }
    for (std::size_t i = 0; i < n; ++i) {
      F[i] += wallF[i];
      T[i] += wallT[i];
      elastic += wallElastic[i];
      maxDepth = std::max(maxDepth, wallDepth[i]);
    }
    forcesValid = true;
  }

  void kick(double h) {
    const std::int64_t n = static_cast<std::int64_t>(x.size());
    for (std::int64_t si = 0; si < n; ++si) {
      const std::size_t i = static_cast<std::size_t>(si);
      if (!awake[i]) continue;
      v[i] += (h / tmpl[tid[i]].massG) * F[i];
      L[i] += h * T[i];
    }
  }

  void drift() {
    const std::int64_t n = static_cast<std::int64_t>(x.size());
    for (std::int64_t si = 0; si < n; ++si) {
      const std::size_t i = static_cast<std::size_t>(si);
      if (!awake[i]) continue;
      x[i] += dt * v[i];
      // Rotation with fixed angular momentum: midpoint body rate, principal axes.
      const ParticleTemplate& tp = tmpl[tid[i]];
      auto bodyRate = [&](const Quat& qq) {
        const Vec3 lb = qq.conjugate() * L[i];
        return Vec3(lb.x() / tp.inertiaG.x(), lb.y() / tp.inertiaG.y(), lb.z() / tp.inertiaG.z());
      };
      Quat mid;
      quatStep(q[i], 0.5 * dt * bodyRate(q[i]), mid);
      quatStep(q[i], dt * bodyRate(mid), q[i]);
    }
  }

  // Sleeping: a particle falls asleep when, over a window of sleepTime, it never moved
  // faster than vWake and its net displacement (centre plus rotation at its bounding radius)
  // stayed below vSleep x window. The net displacement, not the instantaneous speed, is what
  // matters: contact forces leave a few particles of a bed jittering about a fixed place
  // (~1e-5 mm at a few kHz), which a speed test never lets sleep, and those few then keep
  // the whole bed from meeting the settling thresholds.
  void restartWindow(std::size_t i) {
    slowSteps[i] = 0;
    xRest[i] = x[i];
    qRest[i] = q[i];
  }

  void sleepUpdate() {
    const std::size_t n = x.size();
    if (!opt.sleeping) return;  // everyone stays awake; rest windows are never read
    // Sleeping is allowed in the rests between taps (every lift wakes all again).
    if (wallLiftingAt(t)) {
      for (std::size_t i = 0; i < n; ++i) {
        awake[i] = 1;
        restartWindow(i);
      }
      return;
    }
    const double vSleep = opt.settleVelocity * std::sqrt(opt.gravityMmPerS2 * dMin());
    const double vWake = 10 * vSleep;
    const std::uint32_t need =
        static_cast<std::uint32_t>(std::max(1.0, std::ceil(opt.sleepTimeS / dt)));
    std::vector<double> speed(n, 0);
    for (std::size_t i = 0; i < n; ++i) {
      if (!awake[i]) continue;
      speed[i] = v[i].norm() + omega(i).norm() * tmpl[tid[i]].radiusMm;
      if (speed[i] < vWake)
        ++slowSteps[i];
      else
        restartWindow(i);
    }
    for (const Pair& p : pairs) {
      if (speed[p.i] >= vWake) {
        restartWindow(p.j);
        if (!awake[p.j]) awake[p.j] = 2;  // woken this step
      }
      if (speed[p.j] >= vWake) {
        restartWindow(p.i);
        if (!awake[p.i]) awake[p.i] = 2;
      }
    }
    for (std::size_t i = 0; i < n; ++i) {
      if (awake[i] == 2) {
        awake[i] = 1;
        restartWindow(i);
      } else if (awake[i] && slowSteps[i] >= need) {
        const double turn =
            2 * std::asin(std::min(1.0, (qRest[i].conjugate() * q[i]).vec().norm()));
        const double moved = (x[i] - xRest[i]).norm() + turn * tmpl[tid[i]].radiusMm;
        if (moved < vSleep * static_cast<double>(slowSteps[i]) * dt) {
          awake[i] = 0;
          v[i].setZero();
          L[i].setZero();
        } else {
          restartWindow(i);
        }
      }
    }
  }

  // Inside the lift of a tap (not its rest).
  bool wallLiftingAt(double time) const {
    if (!wallMovingAt(time)) return false;
    const double period = 1.0 / opt.tapFrequencyHz + opt.tapRestS;
    const double local = std::fmod(time - tapStart, period);
    return local < 1.0 / opt.tapFrequencyHz;
  }

  bool wallMovingAt(double time) const {
    return tapCycles > 0 && time >= tapStart && time < tapEnd();
  }

  void stepOnce() {
    if (!resolved) throw InternalError("DemSystem::step before resolve()");
    const std::size_t n = x.size();
    if (needRebuild) rebuildNeighbours();
    if (!forcesValid) computeForces();
    kick(0.5 * dt);
    drift();
    t += dt;
    double maxMove2 = 0;
    for (std::size_t i = 0; i < n; ++i)
      maxMove2 = std::max(maxMove2, (x[i] - xBuild[i]).squaredNorm());
    if (4 * maxMove2 > skin * skin) rebuildNeighbours();
    computeForces();
    kick(0.5 * dt);
    sleepUpdate();
    ++counters.steps;
    counters.particleSteps += n;
    for (std::size_t i = 0; i < n; ++i) counters.integratedParticleSteps += awake[i] ? 1 : 0;
  }
};

DemSystem::DemSystem(std::vector<ParticleTemplate> templates,
                     std::shared_ptr<const DemContainer> container, const DemOptions& options)
    : impl_(std::make_unique<Impl>()) {
  if (templates.empty()) throw InputError("dem: no particle template");
  if (!container) throw InputError("dem: no container");
  const DemOptions& o = options;
  if (!(o.friction >= 0) || !std::isfinite(o.friction))
    throw InputError("--friction must be >= 0 (got " + std::to_string(o.friction) + ")");
  if (!(o.restitution >= 0 && o.restitution <= 1))
    throw InputError("--restitution must be in 0..1 (got " + std::to_string(o.restitution) + ")");
  if (!(o.stiffnessNPerMm3 >= 0) || !std::isfinite(o.stiffnessNPerMm3))
    throw InputError("--stiffness must be >= 0 (0 = auto)");
  if (!(o.contactStiffnessCap >= 0) || !std::isfinite(o.contactStiffnessCap))
    throw InputError("--contact-stiffness-cap must be >= 0 (0 = none)");
  if (!(o.targetOverlap > 0 && o.targetOverlap < 0.2))
    throw InputError("--target-overlap must be in (0, 0.2)");
  if (!(o.timeStepS >= 0) || !std::isfinite(o.timeStepS))
    throw InputError("--time-step must be >= 0 (0 = auto)");
  if (!(o.timeStepFraction > 0 && o.timeStepFraction <= 0.1))
    throw InputError("--time-step-fraction must be in (0, 0.1]");
  if (o.tapCycles < 0) throw InputError("--tap-cycles must be >= 0");
  if (!(o.tapFrequencyHz > 0) || !(o.tapAmplitudeMm >= 0) || !(o.tapRestS >= 0))
    throw InputError("--tap-frequency must be > 0, --tap-amplitude and --tap-rest >= 0");
  if (!(o.maxTimeS > 0)) throw InputError("--max-time must be > 0");
  if (!(o.gravityMmPerS2 >= 0)) throw InputError("dem: gravity must be >= 0");
  impl_->tmpl = std::move(templates);
  impl_->container = std::move(container);
  impl_->opt = options;
  const double e = o.restitution;
  // zeta = -ln e / sqrt(pi^2 + ln^2 e); e = 0 is the critically damped limit.
  impl_->zeta = e <= 0 ? 1.0 : (e >= 1 ? 0.0 : -std::log(e) / std::hypot(kPi, std::log(e)));
  impl_->skin = 0.1 * impl_->rMax();
  if (!(o.nodeSkinDiameters >= 0) || !std::isfinite(o.nodeSkinDiameters))
    throw InputError("dem: node skin must be >= 0");
  impl_->nodeSkin = o.nodeSkinDiameters * impl_->dMin();
  for (const auto& tp : impl_->tmpl) {
    impl_->toShape.push_back(tp.principalToShape.toRotationMatrix());
    Impl::Analytic a;
    a.form = tp.shape->analyticForm(a.r, a.hl);
    impl_->analytic.push_back(a);
  }
  impl_->zetaTable[0] = impl_->zeta;
  for (std::size_t i = 1; i < impl_->zetaTable.size(); ++i)
    impl_->zetaTable[i] = calibratedZeta(e, 1.0 + 0.25 * static_cast<double>(i));
}

DemSystem::~DemSystem() = default;

std::string DemSystem::resolve(double bedHeightMm) {
  Impl& s = *impl_;
  const DemOptions& o = s.opt;
  const double rho = o.densityGPerCm3 * 1e-3;
  const double g = o.gravityMmPerS2;
  double d = 0, mStar = 1e300, flat = 0;
  for (const auto& tp : s.tmpl) {
    d = std::max(d, tp.diameterMm);
    // A contact off the centre line also turns the particle: 1/m_eff = 1/m + |r x n|^2 / I
    // at the worst surface node (a sphere's normal forces have no lever: m_eff = m).
    double lever = 0;
    for (std::size_t n = 0; n < tp.nodeP.size(); ++n) {
      const Vec3 rn = tp.nodeP[n].cross(tp.nodeNormal[n]);
      lever = std::max(lever, rn.cwiseProduct(rn).cwiseQuotient(tp.inertiaG).sum());
    }
    const double mEff = 1.0 / (1.0 / tp.massG + lever);
    mStar = std::min(mStar, 0.5 * mEff);
    flat = std::max(flat, tp.flatAreaMm2);
  }
  const double dRef = s.dMin();
  if (o.stiffnessNPerMm3 > 0) {
    s.k = o.stiffnessNPerMm3 * 1e6;
  } else {
    // Load on one of ~3 supporting contacts of a particle at the bottom of the bed, carried
    // by the curved contact law F = k pi (d/4) delta^2 at delta = targetOverlap * d.
    const double h = std::max(bedHeightMm, 2 * dRef);
    const double load = rho * std::max(g, 1.0) * 0.6 * h * (kPi * dRef * dRef / 4) / 3;
    const double delta = o.targetOverlap * dRef;
    s.k = load / (kPi * (dRef / 4) * delta * delta);
  }
  // Deepest expected overlap: a particle falling from one injection zone height.
  const double fall = (o.rainHeightDiameters + 1) * d;
  const double v2 = 2 * g * fall + o.rainSpeedMmPerS * o.rainSpeedMmPerS;
  const double deltaImpact = std::cbrt(3 * mStar * v2 / (2 * s.k * kPi * dRef / 4));
  const double deltaMax = std::max(5 * o.targetOverlap * dRef, deltaImpact);
  const double kCurved = 2 * s.k * kPi * (dRef / 4) * deltaMax;
  s.kCap = o.contactStiffnessCap > 0 ? o.contactStiffnessCap * kCurved : 0;
  const double kContact =
      s.kCap > 0 ? std::min(s.kCap, std::max(s.k * flat, kCurved)) : std::max(s.k * flat, kCurved);
  s.tc = kPi * std::sqrt(mStar / kContact);
  std::string warning;
  const double dtMax = s.tc / 10;
  if (o.timeStepS > 0) {
    s.dt = o.timeStepS;
    if (s.dt > dtMax) {
      std::ostringstream w;
      w << "warning: --time-step " << o.timeStepS
        << " s is above the stability limit t_c/10 = " << dtMax << " s; clamped to " << dtMax;
      warning = w.str();
      s.dt = dtMax;
    }
  } else {
    s.dt = o.timeStepFraction * s.tc;
  }
  s.resolved = true;
  return warning;
}

std::size_t DemSystem::addParticle(std::size_t templateIndex, const Vec3& positionMm,
                                   const Quat& qShape, const Vec3& velocity,
                                   const Vec3& angularVelocity) {
  Impl& s = *impl_;
  if (templateIndex >= s.tmpl.size()) throw InputError("dem: bad template index");
  const ParticleTemplate& tp = s.tmpl[templateIndex];
  const Quat qp = (qShape.normalized() * tp.principalToShape).normalized();
  s.x.push_back(positionMm);
  s.v.push_back(velocity);
  s.q.push_back(qp);
  const Eigen::Matrix3d r = qp.toRotationMatrix();
  const Vec3 wb = r.transpose() * angularVelocity;
  s.L.push_back(r * tp.inertiaG.cwiseProduct(wb));
  s.F.push_back(Vec3::Zero());
  s.T.push_back(Vec3::Zero());
  s.tid.push_back(static_cast<std::uint32_t>(templateIndex));
  s.awake.push_back(1);
  s.slowSteps.push_back(0);
  s.xRest.push_back(positionMm);
  s.qRest.push_back(qp);
  s.wallXi.push_back({});
  for (auto& xi : s.wallXi.back()) xi.setZero();
  s.wallF.push_back(Vec3::Zero());
  s.wallT.push_back(Vec3::Zero());
  s.wallElastic.push_back(0);
  s.wallDepth.push_back(0);
  s.wallLists.emplace_back();
  s.nodeTotal += static_cast<double>(tp.nodeP.size());
  s.xBuild.push_back(positionMm);
  s.needRebuild = true;
  s.forcesValid = false;
  return s.x.size() - 1;
}

void DemSystem::step(std::size_t n) {
  for (std::size_t s = 0; s < n; ++s) impl_->stepOnce();
}

std::size_t DemSystem::size() const { return impl_->x.size(); }
Vec3 DemSystem::position(std::size_t i) const { return impl_->x.at(i); }
Vec3 DemSystem::velocity(std::size_t i) const { return impl_->v.at(i); }
Vec3 DemSystem::angularVelocity(std::size_t i) const { return impl_->omega(i); }
Quat DemSystem::orientation(std::size_t i) const {
  return (impl_->q.at(i) * impl_->tmpl[impl_->tid[i]].principalToShape.conjugate()).normalized();
}
std::size_t DemSystem::templateOf(std::size_t i) const { return impl_->tid.at(i); }
bool DemSystem::asleep(std::size_t i) const { return !impl_->awake.at(i); }
double DemSystem::kineticEnergy() const {
  const Impl& s = *impl_;
  double e = 0;
  for (std::size_t i = 0; i < s.x.size(); ++i) {
    e += 0.5 * s.tmpl[s.tid[i]].massG * s.v[i].squaredNorm();
    e += 0.5 * s.L[i].dot(s.omega(i));
  }
  return e;
}
double DemSystem::potentialEnergy() const {
  const Impl& s = *impl_;
  double e = 0;
  for (std::size_t i = 0; i < s.x.size(); ++i)
    e += s.tmpl[s.tid[i]].massG * s.opt.gravityMmPerS2 * s.x[i].z();
  return e;
}
double DemSystem::elasticEnergy() const { return impl_->elastic; }
double DemSystem::maxOverlapMm() const { return impl_->maxDepth; }
double DemSystem::timeStepS() const { return impl_->dt; }
double DemSystem::contactTimeS() const { return impl_->tc; }
double DemSystem::stiffnessNPerMm3() const { return impl_->k * 1e-6; }
double DemSystem::contactStiffnessCapNPerMm() const { return impl_->kCap * 1e-6; }
double DemSystem::timeS() const { return impl_->t; }
const DemCounters& DemSystem::counters() const { return impl_->counters; }
const DemOptions& DemSystem::options() const { return impl_->opt; }
const std::vector<ParticleTemplate>& DemSystem::templates() const { return impl_->tmpl; }
void DemSystem::setWallMotion(double startS, int cycles) {
  impl_->tapStart = startS;
  impl_->tapCycles = cycles;
}
bool DemSystem::wallMoving() const { return impl_->wallMovingAt(impl_->t); }
void DemSystem::motionMeasures(double& maxSpeed, double& meanKinetic) const {
  const Impl& s = *impl_;
  maxSpeed = 0;
  double e = 0;
  for (std::size_t i = 0; i < s.x.size(); ++i) {
    if (!s.awake[i]) continue;
    maxSpeed = std::max(maxSpeed, s.v[i].norm());
    e += 0.5 * s.tmpl[s.tid[i]].massG * s.v[i].squaredNorm() + 0.5 * s.L[i].dot(s.omega(i));
  }
  meanKinetic = s.x.empty() ? 0 : e / static_cast<double>(s.x.size());
}
void DemSystem::wakeAll() {
  for (auto& a : impl_->awake) a = 1;
  for (std::size_t i = 0; i < impl_->x.size(); ++i) impl_->restartWindow(i);
}

}  // namespace voxpack::packer::dem
