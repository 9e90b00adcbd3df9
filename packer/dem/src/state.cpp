// The DEM's exact state for checkpoints (docs/dem.md, "Checkpoints"): every field of the
// integrator that the next step reads, as JSON numbers (nlohmann writes the shortest text
// that reads back to the same double, so the bits survive the file).
#include <algorithm>
#include <string>

#include "system_impl.hpp"
#include "voxpack/core/errors.hpp"

namespace voxpack::packer::dem {
namespace {

using nlohmann::json;

// Flat arrays: 3 doubles a vector, 4 a quaternion (w, x, y, z), 9 a matrix (column major).
void put(json& a, const Vec3& v) {
  for (int c = 0; c < 3; ++c) a.push_back(v[c]);
}
void put(json& a, const Quat& q) {
  a.push_back(q.w());
  a.push_back(q.x());
  a.push_back(q.y());
  a.push_back(q.z());
}
void put(json& a, const Eigen::Matrix3d& m) {
  for (int c = 0; c < 9; ++c) a.push_back(m.data()[c]);
}

// Reads the flat arrays back, checking lengths (a state is input: it may be damaged).
class Reader {
 public:
  Reader(const json& a, std::size_t n, const char* what) : a_(a) {
    if (!a_.is_array() || a_.size() != n)
      throw FormatError(std::string("checkpoint: DEM state field ") + what +
                        " has the wrong length");
  }
  double real() { return a_.at(pos_++).get<double>(); }
  Vec3 vec() {
    Vec3 v;
    for (int c = 0; c < 3; ++c) v[c] = real();
    return v;
  }
  Quat quat() {
    const double w = real(), x = real(), y = real(), z = real();
    return Quat(w, x, y, z);
  }
  Eigen::Matrix3d mat() {
    Eigen::Matrix3d m;
    for (int c = 0; c < 9; ++c) m.data()[c] = real();
    return m;
  }

 private:
  const json& a_;
  std::size_t pos_ = 0;
};

std::vector<std::uint32_t> indices(const json& a, std::size_t limit, const char* what) {
  auto v = a.get<std::vector<std::uint32_t>>();
  for (const std::uint32_t i : v)
    if (i >= limit)
      throw FormatError(std::string("checkpoint: DEM state ") + what + " index out of range");
  return v;
}

}  // namespace

json toJson(const DemOptions& o) {
  return {{"friction", o.friction},
          {"restitution", o.restitution},
          {"density_g_cm3", o.densityGPerCm3},
          {"stiffness_n_mm3", o.stiffnessNPerMm3},
          {"contact_stiffness_cap", o.contactStiffnessCap},
          {"target_overlap", o.targetOverlap},
          {"time_step_s", o.timeStepS},
          {"time_step_fraction", o.timeStepFraction},
          {"contact", o.contact == ContactModel::kVoxel ? "voxel" : "levelset"},
          {"gravity_mm_s2", o.gravityMmPerS2},
          {"tangential_stiffness_ratio", o.tangentialStiffnessRatio},
          {"wall_friction", o.wallFriction},
          {"wall_restitution", o.wallRestitution},
          {"rolling_friction", o.rollingFriction},
          {"tap_cycles", o.tapCycles},
          {"tap_amplitude_mm", o.tapAmplitudeMm},
          {"tap_frequency_hz", o.tapFrequencyHz},
          {"tap_rest_s", o.tapRestS},
          {"sleeping", o.sleeping},
          {"sleep_time_s", o.sleepTimeS},
          {"settle_kinetic", o.settleKinetic},
          {"settle_velocity", o.settleVelocity},
          {"settle_speed", o.settleSpeed},
          {"max_time_s", o.maxTimeS},
          {"rain_height_d", o.rainHeightDiameters},
          {"rain_volume_fraction", o.rainVolumeFraction},
          {"rain_speed_mm_s", o.rainSpeedMmPerS},
          {"fill_height_phi_guess", o.fillHeightPhiGuess},
          {"node_skin_d", o.nodeSkinDiameters},
          {"contact_voxel_mm", o.contactVoxelMm}};
}

DemOptions optionsFromJson(const json& j) {
  DemOptions o;
  try {
    o.friction = j.at("friction").get<double>();
    o.restitution = j.at("restitution").get<double>();
    o.densityGPerCm3 = j.at("density_g_cm3").get<double>();
    o.stiffnessNPerMm3 = j.at("stiffness_n_mm3").get<double>();
    o.contactStiffnessCap = j.at("contact_stiffness_cap").get<double>();
    o.targetOverlap = j.at("target_overlap").get<double>();
    o.timeStepS = j.at("time_step_s").get<double>();
    o.timeStepFraction = j.at("time_step_fraction").get<double>();
    const std::string c = j.at("contact").get<std::string>();
    if (c != "voxel" && c != "levelset") throw FormatError("checkpoint: bad DEM contact model");
    o.contact = c == "voxel" ? ContactModel::kVoxel : ContactModel::kLevelSet;
    o.gravityMmPerS2 = j.at("gravity_mm_s2").get<double>();
    o.tangentialStiffnessRatio = j.at("tangential_stiffness_ratio").get<double>();
    o.wallFriction = j.at("wall_friction").get<double>();
    o.wallRestitution = j.at("wall_restitution").get<double>();
    o.rollingFriction = j.value("rolling_friction", 0.0);  // absent in states before it existed
    o.tapCycles = j.at("tap_cycles").get<int>();
    o.tapAmplitudeMm = j.at("tap_amplitude_mm").get<double>();
    o.tapFrequencyHz = j.at("tap_frequency_hz").get<double>();
    o.tapRestS = j.at("tap_rest_s").get<double>();
    o.sleeping = j.at("sleeping").get<bool>();
    o.sleepTimeS = j.at("sleep_time_s").get<double>();
    o.settleKinetic = j.at("settle_kinetic").get<double>();
    o.settleSpeed = j.value("settle_speed", -1.0);  // absent in states before it existed
    o.settleVelocity = j.at("settle_velocity").get<double>();
    o.maxTimeS = j.at("max_time_s").get<double>();
    o.rainHeightDiameters = j.at("rain_height_d").get<double>();
    o.rainVolumeFraction = j.at("rain_volume_fraction").get<double>();
    o.rainSpeedMmPerS = j.at("rain_speed_mm_s").get<double>();
    o.fillHeightPhiGuess = j.at("fill_height_phi_guess").get<double>();
    o.nodeSkinDiameters = j.at("node_skin_d").get<double>();
    o.contactVoxelMm = j.value("contact_voxel_mm", 0.0);  // absent in states before it existed
  } catch (const json::exception& e) {
    throw FormatError(std::string("checkpoint: malformed DEM options (") + e.what() + ")");
  }
  return o;
}

json DemSystem::saveState() const {
  const Impl& s = *impl_;
  if (!s.resolved || s.diverged)
    throw InternalError("DemSystem::saveState of a system not stepping");
  const std::size_t n = s.x.size();
  json tid = s.tid, awake = s.awake, slow = s.slowSteps;
  json x = json::array(), v = json::array(), L = json::array(), F = json::array(),
       T = json::array(), xb = json::array(), xr = json::array(), q = json::array(),
       qr = json::array(), wxi = json::array();
  for (std::size_t i = 0; i < n; ++i) {
    put(x, s.x[i]);
    put(v, s.v[i]);
    put(L, s.L[i]);
    put(F, s.F[i]);
    put(T, s.T[i]);
    put(xb, s.xBuild[i]);
    put(xr, s.xRest[i]);
    put(q, s.q[i]);
    put(qr, s.qRest[i]);
    for (const Vec3& xi : s.wallXi[i]) put(wxi, xi);
  }
  json walls = json::array();
  for (const auto& wl : s.wallLists) {
    json pose = json::array();
    put(pose, wl.r);
    put(pose, wl.x);
    pose.push_back(wl.lift);
    walls.push_back({{"valid", wl.valid}, {"nodes", wl.nodes}, {"pose", pose}});
  }
  json pairs = json::array();
  for (const auto& p : s.pairs) {
    json xi = json::array(), pose = json::array();
    put(xi, p.xi);
    put(pose, p.nodes.m);
    put(pose, p.nodes.off);
    put(pose, p.nodes.offT);
    pairs.push_back({{"i", p.i},
                     {"j", p.j},
                     {"xi", xi},
                     {"valid", p.nodes.valid},
                     {"a", p.nodes.a},
                     {"b", p.nodes.b},
                     {"pose", pose}});
  }
  const DemCounters& c = s.counters;
  return {{"format", "voxpack-dem-system"},
          {"version", 1},
          {"particles", n},
          {"time_s", s.t},
          {"speed_bound", s.speedBound},
          {"tap_start_s", s.tapStart},
          {"tap_cycles", s.tapCycles},
          {"need_rebuild", s.needRebuild},
          {"forces_valid", s.forcesValid},
          {"last", {s.elastic, s.maxDepth, s.sumDepth}},
          {"contact_count", s.contactCount},
          {"work_total", s.workTotal},
          {"counters",
           {c.steps, c.particleSteps, c.integratedParticleSteps, c.pairChecks, c.pairEvaluations,
            c.nodeEvaluations, c.neighbourRebuilds, c.nodeListRebuilds, c.partialRebuilds}},
          {"template", tid},
          {"awake", awake},
          {"slow_steps", slow},
          {"x", x},
          {"v", v},
          {"L", L},
          {"F", F},
          {"T", T},
          {"x_build", xb},
          {"x_rest", xr},
          {"q", q},
          {"q_rest", qr},
          {"wall_xi", wxi},
          {"wall_lists", walls},
          {"pairs", pairs}};
}

void DemSystem::restoreState(const json& j) {
  Impl& s = *impl_;
  if (!s.resolved) throw InternalError("DemSystem::restoreState before resolve()");
  try {
    if (j.at("format") != "voxpack-dem-system" || j.at("version") != 1)
      throw FormatError("checkpoint: not a DEM system state of version 1");
    const std::size_t n = j.at("particles").get<std::size_t>();
    if (n > (std::size_t{1} << 31)) throw FormatError("checkpoint: too many DEM particles");
    // Particles first, through addParticle (it sizes every per-particle array), then the
    // exact values over them.
    const auto tid = j.at("template").get<std::vector<std::uint32_t>>();
    if (tid.size() != n) throw FormatError("checkpoint: DEM state template list length");
    const double speedBound = s.speedBound;
    s.x.clear();
    s.v.clear();
    s.L.clear();
    s.F.clear();
    s.T.clear();
    s.xBuild.clear();
    s.q.clear();
    s.tid.clear();
    s.awake.clear();
    s.slowSteps.clear();
    s.xRest.clear();
    s.qRest.clear();
    s.wallXi.clear();
    s.wallF.clear();
    s.wallT.clear();
    s.wallElastic.clear();
    s.wallDepth.clear();
    s.wallTouching.clear();
    s.wallLists.clear();
    s.pairs.clear();
    s.workTotal = 0;
    for (const std::uint32_t t0 : tid) {
      if (t0 >= s.tmpl.size()) throw FormatError("checkpoint: DEM particle of an unknown shape");
      addParticle(t0, Vec3::Zero(), Quat::Identity());
    }
    s.speedBound = speedBound;
    Reader x(j.at("x"), 3 * n, "x"), v(j.at("v"), 3 * n, "v"), L(j.at("L"), 3 * n, "L"),
        F(j.at("F"), 3 * n, "F"), T(j.at("T"), 3 * n, "T"), xb(j.at("x_build"), 3 * n, "x_build"),
        xr(j.at("x_rest"), 3 * n, "x_rest"), q(j.at("q"), 4 * n, "q"),
        qr(j.at("q_rest"), 4 * n, "q_rest"), wxi(j.at("wall_xi"), 3 * kWallRegions * n, "wall_xi");
    const auto awake = j.at("awake").get<std::vector<std::uint8_t>>();
    const auto slow = j.at("slow_steps").get<std::vector<std::uint32_t>>();
    const json& walls = j.at("wall_lists");
    if (awake.size() != n || slow.size() != n || !walls.is_array() || walls.size() != n)
      throw FormatError("checkpoint: DEM state per-particle lists differ in length");
    for (std::size_t i = 0; i < n; ++i) {
      s.x[i] = x.vec();
      s.v[i] = v.vec();
      s.L[i] = L.vec();
      s.F[i] = F.vec();
      s.T[i] = T.vec();
      s.xBuild[i] = xb.vec();
      s.xRest[i] = xr.vec();
      s.q[i] = q.quat();
      s.qRest[i] = qr.quat();
      for (Vec3& xi : s.wallXi[i]) xi = wxi.vec();
      if (awake[i] > 1) throw FormatError("checkpoint: bad DEM sleeping flag");
      s.awake[i] = awake[i];
      s.slowSteps[i] = slow[i];
      const json& w = walls[i];
      auto& wl = s.wallLists[i];
      wl.valid = w.at("valid").get<bool>();
      wl.nodes = indices(w.at("nodes"), s.tmpl[s.tid[i]].nodeP.size(), "wall node");
      Reader pose(w.at("pose"), 13, "wall list pose");
      wl.r = pose.mat();
      wl.x = pose.vec();
      wl.lift = pose.real();
    }
    for (const auto& p : j.at("pairs")) {
      Impl::Pair pr{};
      pr.i = p.at("i").get<std::uint32_t>();
      pr.j = p.at("j").get<std::uint32_t>();
      if (pr.i >= pr.j || pr.j >= n) throw FormatError("checkpoint: bad DEM pair");
      if (!s.pairs.empty() &&
          (s.pairs.back().i > pr.i || (s.pairs.back().i == pr.i && s.pairs.back().j >= pr.j)))
        throw FormatError("checkpoint: DEM pairs out of order");
      Reader xi(p.at("xi"), 3, "pair spring");
      pr.xi = xi.vec();
      pr.nodes.valid = p.at("valid").get<bool>();
      pr.nodes.a = indices(p.at("a"), s.tmpl[s.tid[pr.i]].nodeP.size(), "pair node");
      pr.nodes.b = indices(p.at("b"), s.tmpl[s.tid[pr.j]].nodeP.size(), "pair node");
      Reader pose(p.at("pose"), 15, "pair list pose");
      pr.nodes.m = pose.mat();
      pr.nodes.off = pose.vec();
      pr.nodes.offT = pose.vec();
      s.pairs.push_back(std::move(pr));
    }
    // The per-particle pair index (CSR), as rebuildNeighbours() makes it.
    s.pairOut.assign(s.pairs.size(), ContactOut{});
    s.pairEvaluated.assign(s.pairs.size(), 0);
    s.pairOutStale = false;
    s.liveAllNext = true;  // the first evaluation visits all, as before the save
    s.awakeListValid = false;
    s.movedMark.assign(n, 0);
    s.movedList.clear();
    s.movedAll = true;
    s.adjStart.assign(n + 1, 0);
    for (const auto& p : s.pairs) {
      ++s.adjStart[p.i + 1];
      ++s.adjStart[p.j + 1];
    }
    for (std::size_t i = 0; i < n; ++i) s.adjStart[i + 1] += s.adjStart[i];
    s.adj.resize(2 * s.pairs.size());
    std::vector<std::uint32_t> fill(s.adjStart.begin(), s.adjStart.end() - 1);
    for (std::size_t pi = 0; pi < s.pairs.size(); ++pi) {
      s.adj[fill[s.pairs[pi].i]++] = static_cast<std::uint32_t>(pi);
      s.adj[fill[s.pairs[pi].j]++] = static_cast<std::uint32_t>(pi);
    }
    s.t = j.at("time_s").get<double>();
    s.speedBound = j.at("speed_bound").get<double>();
    s.tapStart = j.at("tap_start_s").get<double>();
    s.tapCycles = j.at("tap_cycles").get<int>();
    s.needRebuild = j.at("need_rebuild").get<bool>();
    s.forcesValid = j.at("forces_valid").get<bool>();
    Reader last(j.at("last"), 3, "last");
    s.elastic = last.real();
    s.maxDepth = last.real();
    s.sumDepth = last.real();
    s.contactCount = j.at("contact_count").get<std::uint64_t>();
    s.workTotal = j.at("work_total").get<double>();
    const auto c = j.at("counters").get<std::vector<std::uint64_t>>();
    // Eight counters before the partial rebuilds were counted.
    if (c.size() != 8 && c.size() != 9) throw FormatError("checkpoint: bad DEM counters");
    s.counters =
        DemCounters{c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7], c.size() > 8 ? c[8] : 0};
    s.diverged = false;
    // The per-particle rotation cache is refreshed by every force evaluation; size it.
    s.rot.assign(n, Eigen::Matrix3d::Identity());
    s.omegaW.assign(n, Vec3::Zero());
    for (std::size_t i = 0; i < n; ++i) {
      s.rot[i] = s.q[i].toRotationMatrix();
      s.omegaW[i] = worldRate(s.rot[i], s.L[i], s.tmpl[s.tid[i]].inertiaG);
    }
  } catch (const json::exception& e) {
    throw FormatError(std::string("checkpoint: malformed DEM state (") + e.what() + ")");
  }
}

}  // namespace voxpack::packer::dem
