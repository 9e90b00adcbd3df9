// The packing driver: batch injection (a rain zone just above the bed), settling, tapping.
#include <algorithm>
#include <array>
#include <charconv>
#include <chrono>
#include <cmath>
#include <sstream>

#include "constants.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/core/random.hpp"
#include "voxpack/packer/dem.hpp"
#include "voxpack/packer/dem_geometry.hpp"
#include "voxpack/packer/shape.hpp"

namespace voxpack::packer::dem {
namespace {

// Interior area (mm^2) and perimeter (mm) of the container's horizontal cross-section at
// mid-height, sampled on a 96 x 96 grid over the bounds. The perimeter comes from the band
// within eps of the wall, whose area is P eps - pi eps^2 for a convex section (Steiner).
struct CrossSection {
  double areaMm2 = 0, perimeterMm = 0;
};
CrossSection crossSection(const DemContainer& c) {
  const Vec3 lo = c.minMm(), hi = c.maxMm();
  const double z = 0.5 * (lo.z() + hi.z());
  const int n = 96;
  const double hx = (hi.x() - lo.x()) / n, hy = (hi.y() - lo.y()) / n;
  const double eps = 3 * std::max(hx, hy);
  int in = 0, band = 0;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const Vec3 p(lo.x() + (i + 0.5) * (hi.x() - lo.x()) / n,
                   lo.y() + (j + 0.5) * (hi.y() - lo.y()) / n, z);
      const double d = c.wallDistanceMm(p);
      in += d > 0 ? 1 : 0;
      band += d > 0 && d <= eps ? 1 : 0;
    }
  CrossSection cs;
  cs.areaMm2 = (hi.x() - lo.x()) * (hi.y() - lo.y()) * in / (n * n);
  cs.perimeterMm = (hx * hy * band + kPi * eps * eps) / eps;
  return cs;
}

// Depth below which the auto stiffness stops adding the bed's weight. Janssen (1895): where
// the walls carry friction mu_w, the vertical stress in a column saturates at rho g lambda,
// lambda = A / (P K mu_w), within a few lambda of the surface; layers deeper down carry no
// more. We take the full weight down to 3 lambda with K = 0.4 (the low end of the values
// measured for granular beds), three times the saturated stress: a margin for a lower K, for
// force chains and for the load of pouring. A bed shallower than that (the paper's: 3 lambda
// = 810 mm at mu_w 0.1) is unchanged; a 1 m tube at D/d 5 would otherwise need a time step
// three times shorter than a 10 cm one for a load it never feels. 0 = no cap (no friction).
double janssenLoadDepthMm(const CrossSection& cs, double wallFriction) {
  constexpr double kJanssenK = 0.4;
  if (!(wallFriction > 0) || !(cs.perimeterMm > 0)) return 0;
  return 3 * cs.areaMm2 / (cs.perimeterMm * kJanssenK * wallFriction);
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

// The identity of a run: what a checkpoint must share with the run that resumes it.
nlohmann::json runIdentity(const DemScene& scene, const DemOptions& options, const DemSystem& sys,
                           std::int64_t count, std::int64_t initialCount, double bedHeightMm) {
  nlohmann::json shapes = nlohmann::json::array();
  for (std::size_t s = 0; s < scene.shapes.size(); ++s)
    shapes.push_back(
        {scene.shapes[s]->spec(), s < scene.fractions.size() ? scene.fractions[s] : 1.0});
  const Vec3 lo = scene.container->minMm(), hi = scene.container->maxMm();
  nlohmann::json id = {{"options", toJson(options)},
                       {"seed", scene.seed},
                       {"shapes", shapes},
                       {"voxel_size_mm", scene.voxelSizeMm},
                       {"count", count},
                       {"fill_height_mm", scene.fillHeightMm},
                       {"initial_particles", initialCount},
                       {"container_bounds_mm", {lo.x(), lo.y(), lo.z(), hi.x(), hi.y(), hi.z()}},
                       {"bed_height_mm", bedHeightMm},
                       {"stiffness_n_mm3", sys.stiffnessNPerMm3()},
                       {"time_step_s", sys.timeStepS()}};
  // Only when set, so the identity of a run without one is what it was before.
  if (!scene.sizes.none()) id["sizes"] = toJson(scene.sizes);
  return id;
}

// Diameter of new particle `index` of a size distribution: the second and later draws of
// its injection stream (the first picks the shape), so they are the draws the pour makes.
double particleDiameterMm(const DemScene& scene, std::uint64_t index) {
  RandomStream rs(scene.seed, index);
  rs.uniform();
  return drawDiameterMm(scene.sizes, rs);
}

// A sphere of diameter d as the geometry module spells it (shortest round-trip text, so
// the bed's particle table holds the exact diameter the run used).
std::shared_ptr<const DemShape> sphereOfDiameter(double d) {
  std::array<char, 64> buf{};
  const auto r = std::to_chars(buf.data(), buf.data() + buf.size(), d);
  return demShape(parseShape("sphere:d=" + std::string(buf.data(), r.ptr)));
}

}  // namespace

DemResult runDem(const DemScene& scene, const DemOptions& requested, Progress& progress,
                 const DemCheckpointing& checkpointing) {
  DemOptions options = requested;
  const auto wallStart = std::chrono::steady_clock::now();
  if (scene.shapes.empty()) throw InputError("dem: no shape");
  if (!scene.container) throw InputError("dem: no container");
  const nlohmann::json* resume = checkpointing.resume;
  if (resume) {
    try {
      if (!resume->is_object() || resume->value("format", "") != "voxpack-dem-state" ||
          resume->value("version", 0) != 1)
        throw FormatError("checkpoint: not a DEM state of version 1");
    } catch (const nlohmann::json::exception& e) {
      throw FormatError(std::string("checkpoint: malformed DEM state (") + e.what() + ")");
    }
  }
  // Particles at the start: from the bed (--from), or those a resumed run started with
  // (its state holds them all; only their number and volume sized the stiffness).
  std::int64_t initialCount = static_cast<std::int64_t>(scene.initial.size());
  if (resume) {
    const auto& id = resume->at("identity");
    if (!id.is_object() || !id.contains("initial_particles") ||
        !id["initial_particles"].is_number_integer())
      throw FormatError("checkpoint: DEM state without its identity");
    initialCount = id["initial_particles"].get<std::int64_t>();
  }
  if (scene.count < 0 || (scene.count == 0 && !(scene.fillHeightMm > 0) && initialCount == 0))
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
  const bool sized = !scene.sizes.none();
  if (sized) {
    checkSizeDistribution(scene.sizes, "dem: size distribution");
    double r0 = 0, hl0 = 0;
    if (scene.shapes.size() != 1 || scene.shapes[0]->analyticForm(r0, hl0) != 1)
      throw InputError(
          "dem: a size distribution needs exactly one shape, a sphere (its diameter is drawn "
          "per particle)");
  }

  std::vector<ParticleTemplate> templates;
  double vMean = 0, dMax = 0, rMax = 0, massMean = 0;
  // The contact nodes may be coarser than the lattice the bed is digitised on.
  const double nodeSpacingMm =
      options.contactVoxelMm > 0 ? options.contactVoxelMm : scene.voxelSizeMm;
  for (std::size_t s = 0; s < scene.shapes.size(); ++s) {
    templates.push_back(buildTemplate(scene.shapes[s], nodeSpacingMm, options.densityGPerCm3));
    const double f = (cum[s] - (s ? cum[s - 1] : 0)) / total;
    vMean += f * scene.shapes[s]->volumeMm3();
    massMean += f * templates.back().massG;
    dMax = std::max(dMax, templates.back().diameterMm);
    rMax = std::max(rMax, templates.back().radiusMm);
  }
  const DemContainer& box = *scene.container;
  const CrossSection section = crossSection(box);
  const double area = section.areaMm2;
  if (!(area > 0)) throw InputError("dem: the container has no interior cross-section");
  const Vec3 lo = box.minMm(), hi = box.maxMm();
  // The starting particles by template (their spec must be one of the scene's shapes).
  std::vector<std::size_t> initialTemplate;
  double initialVolume = 0;
  for (std::size_t i = 0; i < scene.initial.size(); ++i) {
    std::size_t t = templates.size();
    for (std::size_t s = 0; s < scene.shapes.size() && t == templates.size(); ++s)
      if (scene.shapes[s]->spec() == scene.initial.shape[i]) t = s;
    if (t == templates.size())
      throw InputError("dem: starting particle " + std::to_string(i) + " has shape " +
                       scene.initial.shape[i] + ", which is not one of the scene's shapes");
    initialTemplate.push_back(t);
    initialVolume += scene.shapes[t]->volumeMm3();
  }
  std::int64_t count = scene.count;
  // A size distribution: each new particle's diameter from its own stream, and its own
  // template (the base sphere scaled; a closed-form sphere needs no surface nodes). With a
  // fill height, particles are drawn until their volume fills it at the guessed density.
  std::vector<double> diameters;
  if (sized) {
    if (count == 0 && scene.fillHeightMm > 0) {
      const double want = scene.fillHeightMm * area * options.fillHeightPhiGuess - initialVolume;
      for (double v = 0; v < want && diameters.size() < 100000000;) {
        diameters.push_back(particleDiameterMm(scene, diameters.size()));
        v += kPi / 6 * std::pow(diameters.back(), 3);
      }
    } else {
      for (std::int64_t i = 0; i < count; ++i)
        diameters.push_back(particleDiameterMm(scene, static_cast<std::uint64_t>(i)));
    }
    count = static_cast<std::int64_t>(diameters.size());
    double r0 = 0, hl0 = 0;
    scene.shapes[0]->analyticForm(r0, hl0);
    const bool nodes = options.contact != ContactModel::kLevelSet;
    // New particle i is template i; the scene's sphere stays (after them) only when the
    // starting bed uses it, so its nominal diameter sizes neither the stiffness nor the step.
    std::vector<ParticleTemplate> own;
    own.reserve(diameters.size() + 1);
    double v = 0, m = 0;
    for (const double d : diameters) {
      own.push_back(scaledTemplate(templates[0], sphereOfDiameter(d), 0.5 * d / r0, nodes));
      v += kPi / 6 * d * d * d;
      m += own.back().massG;
    }
    if (!diameters.empty()) {
      vMean = v / static_cast<double>(count);
      massMean = m / static_cast<double>(count);
      dMax = *std::max_element(diameters.begin(), diameters.end());
      rMax = 0.5 * dMax;
    }
    if (!initialTemplate.empty()) {
      for (auto& t : initialTemplate) t += own.size();
      own.push_back(templates[0]);
    }
    templates = std::move(own);
  }
  if (count == 0 && scene.fillHeightMm > 0 && !sized)
    count = std::max<std::int64_t>(
        0, static_cast<std::int64_t>(std::ceil(
               (scene.fillHeightMm * area * options.fillHeightPhiGuess - initialVolume) / vMean)));
  // The auto stiffness follows the weight of the whole bed, the starting one included.
  double bedHeight = (static_cast<double>(count) * vMean + initialVolume) / (0.6 * area);
  if (resume) bedHeight = resume->at("identity").value("bed_height_mm", -1.0);
  // Rain height 0: one batch, a cloud tall enough to hold every particle at the rain
  // fraction (as LIGGGHTS's insert/pack fills its region); its height in d is then what the
  // run reports and what sizes the deepest impact for the stiffness ceiling.
  if (options.rainHeightDiameters == 0)
    options.rainHeightDiameters =
        (static_cast<double>(count) * vMean / (options.rainVolumeFraction * area) + dMax) / dMax;

  const double loadDepthCap = janssenLoadDepthMm(
      section, options.wallFriction >= 0 ? options.wallFriction : options.friction);
  const double loadHeight = loadDepthCap > 0 ? std::min(bedHeight, loadDepthCap) : bedHeight;

  DemSystem sys(templates, scene.container, options);
  DemResult result;
  result.loadHeightMm = loadHeight;
  const std::string warning = sys.resolve(loadHeight);
  if (!warning.empty()) {
    result.messages.push_back(warning);
    progress.message(warning);
  }
  const nlohmann::json identity = runIdentity(scene, options, sys, count, initialCount, bedHeight);
  const double dt = sys.timeStepS();
  {
    std::ostringstream m;
    m << "dem: " << count << " particles";
    if (initialCount > 0) m << " poured onto " << initialCount << " of the starting bed";
    if (requested.rainHeightDiameters == 0)
      m << " from one cloud " << options.rainHeightDiameters * dMax << " mm tall";
    if (loadHeight < bedHeight)
      m << ", stiffness for the weight of the top " << loadHeight << " mm of a " << bedHeight
        << " mm bed (the walls carry the rest: Janssen)";
    m << ", face stiffness " << sys.stiffnessNPerMm3() << " N/mm^3, contact time t_c "
      << sys.contactTimeS() << " s, time step " << dt << " s (t_c/" << sys.contactTimeS() / dt
      << "), nodes per particle " << templates.front().nodeP.size();
    result.messages.push_back(m.str());
    progress.message(m.str());
  }

  const double g = options.gravityMmPerS2;
  const double keLimit = options.settleKinetic * massMean * std::max(g, 1.0) * dMax;
  const double vLimit = options.settleVelocity * std::sqrt(std::max(g, 1.0) * dMax);
  const double settleSpeed = options.settleSpeed < 0 ? options.settleVelocity : options.settleSpeed;
  const double vSettle = settleSpeed * std::sqrt(std::max(g, 1.0) * dMax);
  const double zoneHeight = std::max(options.rainHeightDiameters * dMax, 2.2 * rMax);
  const std::int64_t batch = std::max<std::int64_t>(
      1, static_cast<std::int64_t>(options.rainVolumeFraction * area * zoneHeight / vMean));
  const std::size_t checkSteps = static_cast<std::size_t>(std::max(1.0, std::round(0.002 / dt)));

  // The driver's own state; with the system's, all a checkpoint needs.
  std::int64_t inserted = 0;
  double lastInsertS = 0;
  const double batchIntervalS = g > 0 ? std::sqrt(2 * zoneHeight / g) : 0.05;
  bool tapped = false;
  double nextStatus = 0.25;
  if (resume) {
    try {
      if (resume->at("identity") != identity)
        throw InputError(
            "checkpoint: it belongs to another DEM run (options, seed, shapes, count, container "
            "or voxel size differ)");
      const auto& d = resume->at("driver");
      inserted = d.at("inserted").get<std::int64_t>();
      lastInsertS = d.at("last_insert_s").get<double>();
      tapped = d.at("tapped").get<bool>();
      result.settleTimeS = d.at("settle_time_s").get<double>();
      nextStatus = d.at("next_status_s").get<double>();
      if (inserted < 0 || inserted > count)
        throw FormatError("checkpoint: DEM injection count out of range");
      sys.restoreState(resume->at("system"));
      if (static_cast<std::int64_t>(sys.size()) < initialCount + inserted)
        throw FormatError("checkpoint: DEM state holds fewer particles than it injected");
    } catch (const nlohmann::json::exception& e) {
      throw FormatError(std::string("checkpoint: malformed DEM state (") + e.what() + ")");
    }
  } else {
    for (std::size_t i = 0; i < scene.initial.size(); ++i)
      sys.addParticle(initialTemplate[i], scene.initial.positionMm[i],
                      scene.initial.orientation[i]);
  }
  auto saveState = [&] {
    return nlohmann::json{{"format", "voxpack-dem-state"},
                          {"version", 1},
                          {"identity", identity},
                          {"driver",
                           {{"inserted", inserted},
                            {"last_insert_s", lastInsertS},
                            {"tapped", tapped},
                            {"settle_time_s", result.settleTimeS},
                            {"next_status_s", nextStatus}}},
                          {"system", sys.saveState()}};
  };
  const bool checkpointing_on = checkpointing.write && checkpointing.everySeconds > 0;
  auto lastCheckpoint = std::chrono::steady_clock::now();
  GoodState lastGood;
  if (resume) keepGoodState(sys, lastGood);
  DemStatus status = DemStatus::kTimeCap;
  while (true) {
    // Inject the next batch once the previous one has left its zone.
    if (inserted < count) {
      double maxTop = -1e300;
      for (std::size_t i = 0; i < sys.size(); ++i)
        maxTop = std::max(maxTop, sys.position(i).z() + templates[sys.templateOf(i)].radiusMm);
      // A batch falls its zone height in sqrt(2 H / g); the next one then starts above
      // everything, so a pour never drops particles from more than ~H + d/2.
      if (inserted == 0 || sys.timeS() - lastInsertS >= batchIntervalS) {
        const double base = sys.size() == 0 ? lo.z() + 0.05 * dMax : maxTop + 0.5 * dMax;
        std::vector<std::pair<Vec3, double>> placed;
        const std::int64_t want = std::min(batch, count - inserted);
        for (std::int64_t b = 0; b < want; ++b) {
          RandomStream rs(scene.seed, static_cast<std::uint64_t>(inserted));
          const double u = rs.uniform() * total;
          const std::size_t ti =
              static_cast<std::size_t>(std::upper_bound(cum.begin(), cum.end(), u) - cum.begin());
          std::size_t tIndex = std::min(ti, templates.size() - 1);
          if (sized) {
            drawDiameterMm(scene.sizes, rs);  // the diameter's draw, already in its template
            tIndex = static_cast<std::size_t>(inserted);
          }
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
      if (ke < keLimit && (settleSpeed == 0 || vMax < vSettle)) {
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
    // Here, between two checks, the driver and the system are the whole state: a
    // checkpoint by the clock, and one when the run is cancelled.
    if (progress.cancelled()) {
      if (checkpointing_on) checkpointing.write(saveState());
      status = DemStatus::kCancelled;
      break;
    }
    if (checkpointing_on) {
      const auto now = std::chrono::steady_clock::now();
      if (std::chrono::duration<double>(now - lastCheckpoint).count() >=
          checkpointing.everySeconds) {
        checkpointing.write(saveState());
        lastCheckpoint = now;
      }
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
  result.interpenetrations = sys.interpenetrationCount();
  result.maxOverlapWallFraction = sys.maxOverlapWallFraction();
  result.maxOverlapWallFractionRun = sys.runMaxOverlapWallFraction();
  result.interpenetratingSteps = sys.interpenetratingSteps();
  // At the end, or once during the run at the medial surface, where the level-set normal
  // turns and pushes a node on through: either may have left a particle through another's
  // wall. A depth cannot pass half the thinnest wall (beyond it the far face is nearer), so
  // "at" is within a tenth of that half: 0.45.
  constexpr double kMedialWallFraction = 0.45;
  if (result.interpenetrations > 0 || result.maxOverlapWallFractionRun >= kMedialWallFraction) {
    std::ostringstream m;
    m << "dem: " << result.interpenetrations
      << " particle pairs interpenetrate at the end (an overlap past "
      << kInterpenetrationWallFraction << " of the thinnest wall; deepest "
      << result.maxOverlapWallFraction << "), deepest during the run "
      << result.maxOverlapWallFractionRun << " of the thinnest wall in "
      << result.interpenetratingSteps << " steps with one: try a stiffer --stiffness or a "
      << "smaller --target-overlap";
    result.messages.push_back(m.str());
    progress.message("warning: " + m.str());
  }
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
