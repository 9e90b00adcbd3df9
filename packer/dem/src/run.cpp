// The packing driver: batch injection (a rain zone just above the bed), settling, tapping.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>

#include "constants.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/core/random.hpp"
#include "voxpack/packer/dem.hpp"

namespace voxpack::packer::dem {
namespace {

// Interior area of the container's horizontal cross-section at mid-height (mm^2), by
// sampling on a 96 x 96 grid over the bounds.
double crossSectionMm2(const DemContainer& c) {
  const Vec3 lo = c.minMm(), hi = c.maxMm();
  const double z = 0.5 * (lo.z() + hi.z());
  const int n = 96;
  int in = 0;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const Vec3 p(lo.x() + (i + 0.5) * (hi.x() - lo.x()) / n,
                   lo.y() + (j + 0.5) * (hi.y() - lo.y()) / n, z);
      if (c.wallDistanceMm(p) > 0) ++in;
    }
  return (hi.x() - lo.x()) * (hi.y() - lo.y()) * in / (n * n);
}

// Uniformly distributed rotation (Shoemake 1992).
Quat randomRotation(RandomStream& rs) {
  const double u1 = rs.uniform(), u2 = 2 * kPi * rs.uniform(), u3 = 2 * kPi * rs.uniform();
  const double a = std::sqrt(1 - u1), b = std::sqrt(u1);
  return Quat(a * std::sin(u2), a * std::cos(u2), b * std::sin(u3), b * std::cos(u3)).normalized();
}

// The state at the last check that was finite: what a run that blows up returns.
struct GoodState {
  std::vector<Vec3> x;
  std::vector<Quat> q;
  double timeS = 0;
};

void keepGoodState(const DemSystem& sys, GoodState& g) {
  g.x.resize(sys.size());
  g.q.resize(sys.size());
  for (std::size_t i = 0; i < sys.size(); ++i) {
    g.x[i] = sys.position(i);
    g.q[i] = sys.orientation(i);
  }
  g.timeS = sys.timeS();
}

}  // namespace

DemResult runDem(const DemScene& scene, const DemOptions& options, Progress& progress) {
  const auto wallStart = std::chrono::steady_clock::now();
  if (scene.shapes.empty()) throw InputError("dem: no shape");
  if (!scene.container) throw InputError("dem: no container");
  if (scene.count < 0 || (scene.count == 0 && !(scene.fillHeightMm > 0)))
    throw InputError("dem: give --count N > 0 or --fill-height MM > 0");
  std::vector<double> cum;
  double total = 0;
  for (std::size_t s = 0; s < scene.shapes.size(); ++s) {
    const double f = s < scene.fractions.size() ? scene.fractions[s] : 1.0;
    if (!(f >= 0)) throw InputError("dem: shape fractions must be >= 0");
    total += f;
    cum.push_back(total);
  }
  if (!(total > 0)) throw InputError("dem: shape fractions sum to 0");

  std::vector<ParticleTemplate> templates;
  double vMean = 0, dMax = 0, rMax = 0, massMean = 0;
  for (std::size_t s = 0; s < scene.shapes.size(); ++s) {
    templates.push_back(buildTemplate(scene.shapes[s], scene.voxelSizeMm, options.densityGPerCm3));
    const double f = (cum[s] - (s ? cum[s - 1] : 0)) / total;
    vMean += f * scene.shapes[s]->volumeMm3();
    massMean += f * templates.back().massG;
    dMax = std::max(dMax, templates.back().diameterMm);
    rMax = std::max(rMax, templates.back().radiusMm);
  }
  const DemContainer& box = *scene.container;
  const double area = crossSectionMm2(box);
  if (!(area > 0)) throw InputError("dem: the container has no interior cross-section");
  const Vec3 lo = box.minMm(), hi = box.maxMm();
  std::int64_t count = scene.count;
  if (count == 0)
    count = static_cast<std::int64_t>(
        std::ceil(scene.fillHeightMm * area * options.fillHeightPhiGuess / vMean));
  const double bedHeight = static_cast<double>(count) * vMean / (0.6 * area);

  DemSystem sys(templates, scene.container, options);
  DemResult result;
  const std::string warning = sys.resolve(bedHeight);
  if (!warning.empty()) {
    result.messages.push_back(warning);
    progress.message(warning);
  }
  const double dt = sys.timeStepS();
  {
    std::ostringstream m;
    m << "dem: " << count << " particles, face stiffness " << sys.stiffnessNPerMm3()
      << " N/mm^3, contact time t_c " << sys.contactTimeS() << " s, time step " << dt << " s (t_c/"
      << sys.contactTimeS() / dt << "), nodes per particle " << templates.front().nodeP.size();
    result.messages.push_back(m.str());
    progress.message(m.str());
  }

  const double g = options.gravityMmPerS2;
  const double keLimit = options.settleKinetic * massMean * std::max(g, 1.0) * dMax;
  const double vLimit = options.settleVelocity * std::sqrt(std::max(g, 1.0) * dMax);
  const double zoneHeight = std::max(options.rainHeightDiameters * dMax, 2.2 * rMax);
  const std::int64_t batch = std::max<std::int64_t>(
      1, static_cast<std::int64_t>(options.rainVolumeFraction * area * zoneHeight / vMean));
  const std::size_t checkSteps = static_cast<std::size_t>(std::max(1.0, std::round(0.002 / dt)));

  std::int64_t inserted = 0;
  double lastInsertS = 0;
  const double batchIntervalS = g > 0 ? std::sqrt(2 * zoneHeight / g) : 0.05;
  bool tapped = false;
  GoodState lastGood;
  DemStatus status = DemStatus::kTimeCap;
  double nextStatus = 0.25;
  while (true) {
    // Inject the next batch once the previous one has left its zone.
    if (inserted < count) {
      double maxTop = -1e300;
      for (std::size_t i = 0; i < sys.size(); ++i)
        maxTop = std::max(maxTop, sys.position(i).z() + templates[sys.templateOf(i)].radiusMm);
      // A batch falls its zone height in sqrt(2 H / g); the next one then starts above
      // everything, so a pour never drops particles from more than ~H + d/2.
      if (inserted == 0 || sys.timeS() - lastInsertS >= batchIntervalS) {
        const double base = inserted == 0 ? lo.z() + 0.05 * dMax : maxTop + 0.5 * dMax;
        std::vector<std::pair<Vec3, double>> placed;
        const std::int64_t want = std::min(batch, count - inserted);
        for (std::int64_t b = 0; b < want; ++b) {
          RandomStream rs(scene.seed, static_cast<std::uint64_t>(inserted));
          const double u = rs.uniform() * total;
          const std::size_t ti =
              static_cast<std::size_t>(std::upper_bound(cum.begin(), cum.end(), u) - cum.begin());
          const std::size_t tIndex = std::min(ti, templates.size() - 1);
          const double r = templates[tIndex].radiusMm;
          const Quat q = randomRotation(rs);
          bool ok = false;
          Vec3 p;
          for (int attempt = 0; attempt < 400 && !ok; ++attempt) {
            p = Vec3(rs.uniform(lo.x(), hi.x()), rs.uniform(lo.y(), hi.y()),
                     base + r + rs.uniform() * std::max(0.0, zoneHeight - 2 * r));
            if (box.wallDistanceMm(p) <= r * 1.001) continue;
            ok = true;
            for (const auto& [pp, rr] : placed)
              if ((pp - p).squaredNorm() < (r + rr) * (r + rr)) {
                ok = false;
                break;
              }
          }
          if (!ok) break;  // zone full: the rest waits for the next batch
          placed.emplace_back(p, r);
          sys.addParticle(tIndex, p, q, Vec3(0, 0, -options.rainSpeedMmPerS));
          ++inserted;
        }
        if (placed.empty())
          throw InputError(
              "dem: cannot place a particle in the container (is it narrower "
              "than the particle?)");
        lastInsertS = sys.timeS();
      }
    }
    sys.step(checkSteps);
    const double t = sys.timeS();
    if (sys.diverged()) {
      status = DemStatus::kDiverged;
      break;
    }
    keepGoodState(sys, lastGood);
    if (progress.cancelled()) {
      status = DemStatus::kCancelled;
      break;
    }
    if (t >= nextStatus) {
      nextStatus += 0.25;
      double vMax = 0, ke = 0;
      sys.motionMeasures(vMax, ke);
      std::size_t awake = 0;
      for (std::size_t i = 0; i < sys.size(); ++i) awake += sys.asleep(i) ? 0 : 1;
      std::ostringstream m;
      m << "dem: t " << t << " s, " << inserted << "/" << count << " injected, " << awake
        << " awake, max |v| " << vMax / vLimit << " x limit, mean KE " << ke / keLimit
        << " x limit, wall "
        << std::chrono::duration<double>(std::chrono::steady_clock::now() - wallStart).count()
        << " s";
      progress.message(m.str());
    }
    progress.report("dem", inserted < count
                               ? 0.5 * static_cast<double>(inserted) / static_cast<double>(count)
                               : 0.5 + 0.5 * std::min(1.0, t / options.maxTimeS));
    if (inserted >= count && !sys.wallMoving()) {
      double vMax = 0, ke = 0;
      sys.motionMeasures(vMax, ke);
      if (ke < keLimit && vMax < vLimit) {
        if (!tapped && options.tapCycles > 0) {
          result.settleTimeS = t;
          sys.setWallMotion(t, options.tapCycles);
          sys.wakeAll();
          tapped = true;
        } else {
          if (!tapped) result.settleTimeS = t;
          status = DemStatus::kSettled;
          break;
        }
      }
    }
    if (t >= options.maxTimeS) {
      status = DemStatus::kTimeCap;
      break;
    }
  }

  result.status = status;
  if (status == DemStatus::kDiverged) {
    std::ostringstream m;
    m << "dem: the run blew up at t " << sys.timeS()
      << " s (non-finite or runaway state); the bed is the last good state, t " << lastGood.timeS
      << " s; try a smaller --time-step-fraction or a softer --stiffness";
    result.messages.push_back(m.str());
    progress.message("warning: " + m.str());
  }
  const std::size_t kept = status == DemStatus::kDiverged ? lastGood.x.size() : sys.size();
  for (std::size_t i = 0; i < kept; ++i) {
    const bool good = status == DemStatus::kDiverged;
    const Vec3 p = good ? lastGood.x[i] : sys.position(i);
    const Quat q = good ? lastGood.q[i] : sys.orientation(i);
    if (scene.fillHeightMm > 0 && p.z() > lo.z() + scene.fillHeightMm) continue;
    result.particles.positionMm.push_back(p);
    result.particles.orientation.push_back(q);
    result.particles.shape.push_back(templates[sys.templateOf(i)].shape->spec());
  }
  result.timeStepS = dt;
  result.contactTimeS = sys.contactTimeS();
  result.stiffnessNPerMm3 = sys.stiffnessNPerMm3();
  result.simulatedTimeS = sys.timeS();
  sys.measureAllContacts();
  result.maxOverlapMm = sys.maxOverlapMm();
  result.meanOverlapMm = sys.meanOverlapMm();
  result.contacts = sys.contactCount();
  result.counters = sys.counters();
  result.wallTimeS =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wallStart).count();
  {
    const auto& c = result.counters;
    std::ostringstream m;
    m << "dem: " << statusName(status) << " after " << result.simulatedTimeS << " s simulated ("
      << c.steps << " steps) in " << result.wallTimeS << " s; integrated "
      << c.integratedParticleSteps << " of " << c.particleSteps << " particle-steps ("
      << (c.particleSteps ? 100.0 * static_cast<double>(c.integratedParticleSteps) /
                                static_cast<double>(c.particleSteps)
                          : 0.0)
      << " %), narrow phase on " << c.pairEvaluations << " of " << c.pairChecks
      << " pair-steps; overlap mean " << result.meanOverlapMm / dMax << " d, max "
      << result.maxOverlapMm / dMax << " d over " << result.contacts << " contacts";
    result.messages.push_back(m.str());
    progress.message(m.str());
  }
  return result;
}

}  // namespace voxpack::packer::dem
