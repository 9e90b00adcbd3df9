// computeFlow: bed -> lattice (walls, reservoirs or mirror) -> solver -> physical numbers.
#include "voxpack/flow/flow.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>

#include "voxpack/core/errors.hpp"
#include "voxpack/core/json_util.hpp"
#include "voxpack/core/spec.hpp"
#include "voxpack/core/version.hpp"
#include "walls.hpp"

namespace voxpack::flow {
namespace {

constexpr double kDarcyMm2 = 9.869233e-7;  // 1 darcy = 9.869233e-13 m^2
// Automatic reservoir thickness in particle diameters: within 0.05 % of a 2 d reservoir's k
// on the DEM sphere bed at 10 and 30 voxels per d (docs/flow.md, "Reservoir thickness").
constexpr double kReservoirD = 0.6;
constexpr int kReservoirMinLayers = 4;
constexpr const char* kReservoirAutoName = "automatic: 0.6 d, at least 4";  // the two above
const char* kAxisName[3] = {"z", "y", "x"};

// Sample coordinates (k, j, i) of a C-order offset.
inline void unpack(std::uint64_t off, const std::array<std::int64_t, 3>& d, std::int64_t p[3]) {
  p[0] = static_cast<std::int64_t>(off) / (d[1] * d[2]);
  p[1] = (static_cast<std::int64_t>(off) / d[2]) % d[1];
  p[2] = static_cast<std::int64_t>(off) % d[2];
}

inline bool inMask(const Bed& bed, std::size_t off) { return !bed.mask || (*bed.mask)[off] != 0; }

// The two transverse axes of `axis` (array order).
inline void transverse(int axis, int& a1, int& a2) {
  a1 = axis == 0 ? 1 : 0;
  a2 = axis == 2 ? 1 : 2;
}

// Builds the solver lattice. Domain layer t along the axis maps to sample layer
// sampleLayer(t) (or -1 for a reservoir layer).
struct Built {
  LbmDomain domain;
  std::int64_t sampleStart = 0;
  std::int64_t sampleLength = 0;
  std::int64_t copies = 1;  // 2 for the mirror
};

Built buildDomain(const Bed& bed, const FlowOptions& o) {
  const auto sd = bed.lattice().dims;
  const int a = o.axis;
  const std::int64_t len = sd[static_cast<std::size_t>(a)];
  Built b;
  b.sampleLength = len;
  std::array<std::int64_t, 3> dd = sd;
  if (!o.periodic) {
    if (o.inflow == Inflow::Mirror) {
      dd[static_cast<std::size_t>(a)] = 2 * len;
      b.copies = 2;
    } else {
      dd[static_cast<std::size_t>(a)] = len + 2 * o.reservoirLayers;
      b.sampleStart = o.reservoirLayers;
    }
  }
  LbmDomain& dom = b.domain;
  dom.dims = dd;
  const std::size_t box = static_cast<std::size_t>(dd[0] * dd[1] * dd[2]);
  dom.fluid.assign(box, 0);
  const bool reservoirs = !o.periodic && o.inflow == Inflow::Reservoirs;
  if (reservoirs) dom.sample.assign(box, 0);
  dom.periodic = {true, true, true};
  if (!o.periodic) {
    int a1, a2;
    transverse(a, a1, a2);
    dom.periodic[static_cast<std::size_t>(a1)] = false;
    dom.periodic[static_cast<std::size_t>(a2)] = false;
  }
  const Lattice& sl = bed.lattice();
  for (std::size_t off = 0; off < box; ++off) {
    std::int64_t p[3];
    unpack(off, dd, p);
    std::int64_t t = p[a] - b.sampleStart;
    bool reservoir = false;
    if (t < 0) {
      t = 0;
      reservoir = true;
    } else if (t >= len) {
      if (b.copies == 2) {
        t = 2 * len - 1 - t;
      } else {
        t = len - 1;
        reservoir = true;
      }
    }
    std::int64_t q[3] = {p[0], p[1], p[2]};
    q[a] = t;
    const std::size_t so = sl.offset(q[0], q[1], q[2]);
    // A reservoir layer is fluid wherever the adjacent end layer is inside the mask.
    const bool fluid = reservoir ? inMask(bed, so) : (inMask(bed, so) && bed.indicator[so] != 0);
    dom.fluid[off] = fluid ? 1 : 0;
    if (reservoirs && !reservoir) dom.sample[off] = 1;
  }
  return b;
}

// The lattice restricted to the sample (for the connectivity check).
LbmDomain sampleDomain(const Bed& bed, const FlowOptions& o) {
  LbmDomain d;
  d.dims = bed.lattice().dims;
  d.fluid.resize(bed.indicator.size());
  for (std::size_t off = 0; off < d.fluid.size(); ++off)
    d.fluid[off] = (inMask(bed, off) && bed.indicator[off] != 0) ? 1 : 0;
  d.periodic = {o.periodic, o.periodic, o.periodic};
  return d;
}

// Column geometry across the flow: centroid and equivalent radius of the mask.
struct Column {
  bool present = false;
  double c1 = 0, c2 = 0, radius = 0;  // voxels
};

Column columnOf(const Bed& bed, int axis) {
  Column col;
  if (!bed.mask) return col;
  int a1, a2;
  transverse(axis, a1, a2);
  const auto d = bed.lattice().dims;
  double s1 = 0, s2 = 0, n = 0;
  for (std::size_t off = 0; off < bed.mask->size(); ++off) {
    if (!(*bed.mask)[off]) continue;
    std::int64_t p[3];
    unpack(off, d, p);
    s1 += static_cast<double>(p[a1]);
    s2 += static_cast<double>(p[a2]);
    n += 1;
  }
  if (n == 0) return col;
  col.present = true;
  col.c1 = s1 / n;
  col.c2 = s2 / n;
  const double area = n / static_cast<double>(d[static_cast<std::size_t>(axis)]);
  col.radius = std::sqrt(area / std::numbers::pi);
  return col;
}

double wallDistanceVox(const Column& col, const std::array<std::int64_t, 3>& d, int axis,
                       const std::int64_t p[3]) {
  int a1, a2;
  transverse(axis, a1, a2);
  if (col.present) {
    const double r =
        std::hypot(static_cast<double>(p[a1]) - col.c1, static_cast<double>(p[a2]) - col.c2);
    return col.radius - r;
  }
  const double x1 = static_cast<double>(p[a1]) + 0.5, x2 = static_cast<double>(p[a2]) + 0.5;
  return std::min({x1, static_cast<double>(d[static_cast<std::size_t>(a1)]) - x1, x2,
                   static_cast<double>(d[static_cast<std::size_t>(a2)]) - x2});
}

// The Sauter diameter 6V/S of the particles when the table holds one sphere ("sphere:d=")
// or cylinder ("cylinder:d=,l=") shape for every particle; 0 otherwise (mixed, meshes,
// no table). The surface measured on the voxels reads low at 10-20 voxels per d, so the
// exact shape is the better d for the correlations (docs/flow.md).
double sauterDiameterFromTable(const Bed& bed, std::string& kind) {
  double d = 0;
  for (const std::string& text : bed.particles.shape) {
    double v = 0;
    try {
      const ParsedSpec s = parseSpec(text, "particle shape");
      if (s.name == "sphere") {
        v = s.positive("d");
      } else if (s.name == "cylinder") {
        const double dc = s.positive("d"), l = s.positive("l");
        v = 3.0 * dc * l / (2.0 * l + dc);  // 6 (pi d^2 l / 4) / (pi d l + pi d^2 / 2)
      }
      kind = s.name;
    } catch (const InputError&) {
      return 0;
    }
    if (!(v > 0) || (d > 0 && std::abs(v - d) > 1e-9 * d)) return 0;
    d = v;
  }
  return d;
}

}  // namespace

FlowReport computeFlow(const Bed& bedIn, const FlowOptions& options, const MemoryBudget& budget,
                       Progress& progress) {
  const auto tStart = std::chrono::steady_clock::now();
  FlowOptions o = options;  // the reservoir's automatic thickness is resolved below
  bedIn.validate();
  // A packed column's end layers lie outside the mask (the container's floor and lid):
  // along z they are dropped, so the sample starts and ends with fluid-bearing layers.
  Bed trimmed;
  std::int64_t trimLo = 0, trimHi = 0;
  if (o.axis == 0 && bedIn.mask) {
    const Lattice& l = bedIn.lattice();
    const std::size_t plane = static_cast<std::size_t>(l.ny() * l.nx());
    auto layerInMask = [&](std::int64_t k) {
      const std::uint8_t* m = bedIn.mask->data() + static_cast<std::size_t>(k) * plane;
      return std::any_of(m, m + plane, [](std::uint8_t v) { return v != 0; });
    };
    std::int64_t k0 = 0, k1 = l.nz() - 1;
    while (k0 <= k1 && !layerInMask(k0)) ++k0;
    while (k1 >= k0 && !layerInMask(k1)) --k1;
    if (k0 <= k1 && (k0 > 0 || k1 < l.nz() - 1)) {
      const double z0 = l.originMm[0] + static_cast<double>(k0) * l.spacingMm[0];
      const double z1 = l.originMm[0] + static_cast<double>(k1) * l.spacingMm[0];
      trimmed = cropBedZ(bedIn, z0 - 1e-6 * l.spacingMm[0], z1 + 1e-6 * l.spacingMm[0]);
      trimLo = k0;
      trimHi = l.nz() - 1 - k1;
    }
  }
  const Bed& bed = trimLo + trimHi > 0 ? trimmed : bedIn;
  const Lattice& lat = bed.lattice();
  if (!lat.isIsotropic())
    throw InputError("flow: the lattice Boltzmann solver needs isotropic voxels (spacing " +
                     std::to_string(lat.spacingMm[0]) + ", " + std::to_string(lat.spacingMm[1]) +
                     ", " + std::to_string(lat.spacingMm[2]) + " mm)");
  if (o.axis < 0 || o.axis > 2) throw InputError("flow: axis must be z, y or x");
  const bool reservoirs = !o.periodic && o.inflow == Inflow::Reservoirs;
  if (reservoirs && o.reservoirLayers != 0 && o.reservoirLayers < 2)
    throw InputError("flow: --reservoir-layers must be 0 (automatic) or at least 2");
  const double h = lat.spacingMm[0];
  const BedSummary summary = summarize(bed);
  if (summary.emptyMask) throw InputError("flow: the mask selects no voxel");
  if (summary.voidVoxels == 0)
    throw InputError("flow: the bed is all solid inside the mask: there is no fluid to flow");
  const double eps = summary.porosity;
  const double sv = specificSurfaceMmInv(bed, o.periodic);  // 1/mm
  double dMm = o.particleDiameterMm;
  std::string dSource = "option";
  if (!(dMm > 0)) {
    std::string kind;
    dMm = sauterDiameterFromTable(bed, kind);
    dSource = "particle table: 6V/S of its " + kind;
  }
  if (!(dMm > 0) && sv > 0) {
    dMm = 6.0 * (1.0 - eps) / sv;
    dSource = "Sauter 6(1-eps)/S_v";
  }
  // The reservoirs let the flow leaving the sample's cut face spread before it re-enters the
  // other face. Thinner than about half a particle, they add the resistance of two faces'
  // pores lined up against each other: k -4.6 % with 4 layers at 30 voxels per d on the DEM
  // sphere bed (docs/flow.md, "Reservoir thickness"). So by default they are kReservoirD d
  // thick, and never under 4 layers.
  const bool autoReservoir = reservoirs && o.reservoirLayers == 0;
  if (autoReservoir) {
    // 1e-9: 0.6 d / h that is a whole number in decimal must not round up past it.
    const double layers = std::isfinite(dMm) && dMm > 0 ? kReservoirD * dMm / h - 1e-9 : 0.0;
    o.reservoirLayers = std::max(kReservoirMinLayers, static_cast<int>(std::ceil(layers)));
  }
  const Column col = columnOf(bed, o.axis);
  const double columnMm = col.present ? 2.0 * col.radius * h : 0.0;

  FlowReport rep;
  nlohmann::json& j = rep.json;
  j["voxpack_version"] = versionString();
  j["axis"] = kAxisName[o.axis];
  j["boundary"] = o.periodic                   ? "periodic"
                  : o.inflow == Inflow::Mirror ? "walls+mirror"
                                               : "walls+reservoirs";
  j["reservoir_layers"] = reservoirs ? nlohmann::json(o.reservoirLayers) : nlohmann::json(nullptr);
  j["reservoir_layers_source"] = !reservoirs     ? nlohmann::json(nullptr)
                                 : autoReservoir ? nlohmann::json(kReservoirAutoName)
                                                 : nlohmann::json("option");
  j["voxel_mm"] = h;
  j["dims"] = lat.dims;
  j["trimmed_layers"] = {trimLo, trimHi};  // end layers outside the mask, dropped
  j["porosity"] = eps;
  j["specific_surface_mm_inv"] = finiteOrNull(sv);
  j["specific_surface_method"] = "13-direction crossing counts (Cauchy-Crofton)";
  j["particle_diameter_mm"] = finiteOrNull(dMm);
  j["particle_diameter_source"] = dSource;
  j["column_diameter_mm"] = col.present ? nlohmann::json(columnMm) : nlohmann::json(nullptr);
  const bool interpolated = o.walls == Walls::Interpolated;
  j["walls"] = interpolated ? "interpolated" : "halfway";
  j["interpolated_links"] = 0;
  j["wall_geometry"] = nullptr;
  nlohmann::json warnings = nlohmann::json::array();
  auto warn = [&](const std::string& text) {
    warnings.push_back(text);
    progress.message("flow: warning: " + text);
  };
  if (interpolated && o.lbm.tauPlus > 1.0 + 1e-12)
    warn("interpolated walls are not tau-independent (+0.9 % on a tube at tau 2): keep --tau <= 1");
  j["warnings"] = warnings;

  // Memory before anything is allocated: the dense lattice flags (2 bytes a cell of the
  // padded box) plus the solver's own estimate (reservoir layers counted as all fluid).
  {
    const std::uint64_t len =
        static_cast<std::uint64_t>(lat.dims[static_cast<std::size_t>(o.axis)]);
    const std::uint64_t cross = lat.size() / len;
    std::uint64_t along = len, fluid = summary.voidVoxels;
    if (!o.periodic && o.inflow == Inflow::Mirror) along = 2 * len, fluid *= 2;
    if (!o.periodic && o.inflow == Inflow::Reservoirs) {
      const std::uint64_t extra = 2 * static_cast<std::uint64_t>(o.reservoirLayers);
      along = len + extra;
      fluid += extra * cross;
    }
    const std::uint64_t box = checkedProduct({cross, along}, "flow lattice");
    // Interpolated walls: the signed distance (a float per box cell); the wall links are
    // counted on the lattice once it is built (below).
    const std::uint64_t distance = interpolated ? detail::kDistanceBytesPerCell * box : 0;
    requireWithinBudget(
        2 * box + distance + estimateLbmBytes(box, fluid, o.lbm.precision, 0, o.lbm.streaming),
        budget, "flow (lattice Boltzmann)");
  }
  // Blocked: no path across the sample, reported at once (nothing to run).
  if (!percolates(sampleDomain(bed, o), o.axis)) {
    j["status"] = statusName(FlowStatus::Blocked);
    j["converged"] = false;
    j["permeability_mm2"] = 0.0;
    j["permeability_darcy"] = 0.0;
    j["superficial_velocity"] = 0.0;
    j["interstitial_velocity"] = 0.0;
    j["tortuosity_hydraulic"] = nullptr;
    j["reynolds"] = 0.0;
    j["steps"] = 0;
    j["residual"] = nullptr;
    j["mlups"] = 0.0;
    j["wall_s"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - tStart).count();
    j["radial_profile"] = nullptr;
    j["wall_flow_share"] = nullptr;
    j["pressure_gradient"] = nullptr;
    return rep;
  }

  Built built = buildDomain(bed, o);
  if (interpolated) {
    // Before the distance is allocated: the flags, the distance, the exact cuts and the
    // solver with every fluid-to-solid link interpolated must fit.
    const std::uint64_t box = built.domain.fluid.size();
    std::uint64_t fluid = 0;
    for (std::uint8_t f : built.domain.fluid) fluid += f != 0;
    const std::uint64_t links = detail::countWallLinks(built.domain, o.lbm.threads);
    requireWithinBudget((2 + detail::kDistanceBytesPerCell) * box + detail::kWallCutBytes * links +
                            estimateLbmBytes(box, fluid, o.lbm.precision, links),
                        budget, "flow (lattice Boltzmann, interpolated walls)");
    detail::DomainMap map;
    map.axis = o.axis;
    map.sampleStart = built.sampleStart;
    map.sampleLength = built.sampleLength;
    map.periodic = o.periodic;
    map.mirror = !o.periodic && o.inflow == Inflow::Mirror;
    map.reservoirs = !o.periodic && o.inflow == Inflow::Reservoirs;
    const detail::WallReport wr = detail::buildWallDistance(bed, map, built.domain, o.lbm.threads);
    nlohmann::json shapes = nlohmann::json::object();
    for (const auto& [spec, n] : wr.halfwayShapes) {
      shapes[spec] = n;
      warn(std::to_string(n) + " particle(s) of shape '" + spec +
           "' have no closed-form distance: halfway bounce-back on their surfaces");
    }
    if (wr.containerWalls.rfind("halfway", 0) == 0) warn("container walls: " + wr.containerWalls);
    j["warnings"] = warnings;
    j["wall_geometry"] = {{"particles", wr.particles},
                          {"particles_exact", wr.particlesExact},
                          {"particles_halfway", wr.particlesHalfway()},
                          {"halfway_shapes", shapes},
                          {"periodic_images", wr.imageParticles},
                          {"container", wr.container.empty() ? nlohmann::json(nullptr)
                                                             : nlohmann::json(wr.container)},
                          {"container_walls", wr.containerWalls},
                          {"distance_cells", wr.distanceCells},
                          {"candidate_links", links},
                          {"distance_s", wr.seconds}};
  }
  LbmOptions lo = o.lbm;
  lo.axis = o.axis;
  // Force from a Poiseuille estimate in pores of hydraulic diameter 4 eps / S_v, so the
  // mean pore velocity is about latticeVelocity (Stokes flow: k does not depend on it).
  const double nu = latticeViscosity(lo.tauPlus);
  double dh = sv > 0 ? 4.0 * eps / (sv * h) : static_cast<double>(lat.dims[1]);
  dh = std::clamp(dh, 2.0, 1e4);
  lo.force = 32.0 * nu * o.latticeVelocity / (dh * dh);
  rep.lbm = runLbm(built.domain, lo, budget, progress);
  std::vector<float>().swap(built.domain.signedDistance);  // the links hold what it gave
  std::vector<WallCut>().swap(built.domain.wallCuts);
  const LbmResult& r = rep.lbm;

  // Volumes: mask voxels of the sample (times the mirror copies).
  const double sampleVolume =
      static_cast<double>(summary.voxelsInMask) * static_cast<double>(built.copies);
  const double us = r.sumAxialVelocity / sampleVolume;
  const double ui = r.sampleFluidCells ? r.sumAxialVelocity / r.sampleFluidCells : 0.0;
  // Reservoirs: the pressure rises across the sample (the fluid returns through the
  // reservoirs down a gradient), so the effective drive is F - dp/dx measured between
  // the two reservoir layers next to the sample faces.
  double fEff = lo.force, dpdx = 0;
  if (!o.periodic && o.inflow == Inflow::Reservoirs) {
    const auto dd = built.domain.dims;
    // Mean pressure of each reservoir layer; the face pressures are extrapolated half a
    // layer from the two layers next to each face (the reservoir profile is linear).
    const std::int64_t r0 = built.sampleStart, r1 = built.sampleStart + built.sampleLength;
    std::vector<double> sum(static_cast<std::size_t>(dd[static_cast<std::size_t>(o.axis)]), 0.0),
        cnt(sum.size(), 0.0);
    for (std::size_t c = 0; c < r.fluidCells; ++c) {
      std::int64_t p[3];
      unpack(r.cellOffset[c], dd, p);
      const std::int64_t t = p[o.axis];
      if (t >= r0 && t < r1) continue;
      sum[static_cast<std::size_t>(t)] += r.fields.density[c] / 3.0;
      cnt[static_cast<std::size_t>(t)] += 1;
    }
    auto layer = [&](std::int64_t t) {
      const std::size_t i = static_cast<std::size_t>(t);
      return cnt[i] > 0 ? sum[i] / cnt[i] : 0.0;
    };
    const double pin = layer(r0 - 1) + 0.5 * (layer(r0 - 1) - layer(r0 - 2));
    const double pout = layer(r1) - 0.5 * (layer(r1 + 1) - layer(r1));
    dpdx = (pout - pin) / static_cast<double>(built.sampleLength);
    fEff = lo.force - dpdx;
  }
  const double kLat = fEff > 0 ? nu * us / fEff : 0.0;
  const double kMm2 = kLat * h * h;
  const double tort = r.sumAxialVelocity != 0 ? r.sumSpeed / r.sumAxialVelocity : 0.0;
  j["status"] = statusName(r.status);
  j["converged"] = r.status == FlowStatus::Converged;
  j["permeability_mm2"] = kMm2;
  j["permeability_darcy"] = kMm2 / kDarcyMm2;
  j["permeability_voxels2"] = kLat;
  j["permeability_over_d2"] =
      dMm > 0 ? nlohmann::json(kMm2 / (dMm * dMm)) : nlohmann::json(nullptr);
  // Velocities reported in mm/s at the user's superficial velocity (Stokes flow scales).
  rep.velocityScale = us != 0 ? o.velocityMmS / us : 0.0;
  j["superficial_velocity"] = o.velocityMmS;
  j["interstitial_velocity"] = ui * rep.velocityScale;
  j["velocity_unit"] = "mm/s (scaled to --velocity-mm-s; Stokes flow is linear)";
  j["superficial_velocity_lattice"] = us;
  j["interstitial_velocity_lattice"] = ui;
  j["tortuosity_hydraulic"] = finiteOrNull(tort);
  j["reynolds"] = dMm > 0 ? us * (dMm / h) / nu : us * dh / nu;
  j["reynolds_definition"] = "lattice run: u_superficial d / nu (Stokes regime when << 1)";
  j["steps"] = r.steps;
  j["interpolated_links"] = r.interpolatedLinks;
  j["residual"] = finiteOrNull(r.residual);
  j["mlups"] = r.mlups;
  j["fluid_cells"] = r.fluidCells;
  j["mass_relative_change"] =
      r.massInitial > 0 ? (r.massFinal - r.massInitial) / r.massInitial : 0.0;
  j["mass_correction_relative"] = r.massInitial > 0 ? r.massAdded / r.massInitial : 0.0;
  j["lattice"] = {{"tau_plus", lo.tauPlus},
                  {"magic", lo.magic},
                  {"force", lo.force},
                  {"pressure_gradient", dpdx},
                  {"check_interval", lo.checkInterval},
                  {"mass_correction", r.massCorrected},
                  {"tolerance", lo.tolerance},
                  {"max_steps", lo.maxSteps},
                  {"precision", lo.precision == Precision::Float ? "float32" : "float64"},
                  {"streaming", streamingName(r.streaming)}};
  nlohmann::json hist = nlohmann::json::array();
  for (const auto& [s, u] : r.history) hist.push_back({s, u});
  j["convergence_history"] = hist;

  // Radial profile of the axial velocity (superficial, solid counted as zero) against
  // the distance from the wall, one-voxel bins; share of the flow within 1 d of it.
  if (!o.periodic) {
    const double rmax = col.present
                            ? col.radius
                            : 0.5 * static_cast<double>(std::min(lat.dims[o.axis == 0 ? 1 : 0],
                                                                 lat.dims[o.axis == 2 ? 1 : 2]));
    const std::size_t nbins = static_cast<std::size_t>(std::ceil(std::max(rmax, 1.0)));
    std::vector<double> vol(nbins, 0), voidv(nbins, 0), flux(nbins, 0);
    const auto sd = lat.dims;
    for (std::size_t off = 0; off < bed.indicator.size(); ++off) {
      if (!inMask(bed, off)) continue;
      std::int64_t p[3];
      unpack(off, sd, p);
      const double w = std::max(0.0, wallDistanceVox(col, sd, o.axis, p));
      const std::size_t b = std::min(nbins - 1, static_cast<std::size_t>(w));
      vol[b] += 1;
      voidv[b] += bed.indicator[off] != 0;
    }
    const auto dd = built.domain.dims;
    double total = 0, nearWall = 0, nearVol = 0;
    const double dVox = dMm > 0 ? dMm / h : 0.0;
    for (std::size_t c = 0; c < r.fluidCells; ++c) {
      std::int64_t p[3];
      unpack(r.cellOffset[c], dd, p);
      p[o.axis] -= built.sampleStart;
      if (p[o.axis] < 0 || p[o.axis] >= built.sampleLength) continue;  // reservoir / mirror
      const double u = r.fields.velocity[o.axis][c];
      const double w = std::max(0.0, wallDistanceVox(col, sd, o.axis, p));
      flux[std::min(nbins - 1, static_cast<std::size_t>(w))] += u;
      total += u;
      if (w < dVox) nearWall += u;
    }
    for (std::size_t off = 0; off < bed.indicator.size() && dVox > 0; ++off) {
      if (!inMask(bed, off)) continue;
      std::int64_t p[3];
      unpack(off, sd, p);
      if (wallDistanceVox(col, sd, o.axis, p) < dVox) nearVol += 1;
    }
    nlohmann::json prof = nlohmann::json::object();
    std::vector<double> dist, urel, por;
    const double usSample = total / static_cast<double>(summary.voxelsInMask);
    for (std::size_t b = 0; b < nbins; ++b) {
      if (vol[b] == 0) continue;
      dist.push_back((static_cast<double>(b) + 0.5) * h);
      urel.push_back(usSample != 0 ? flux[b] / vol[b] / usSample : 0.0);
      por.push_back(voidv[b] / vol[b]);
    }
    prof["wall_distance_mm"] = finiteArray(dist);
    prof["axial_velocity_over_superficial"] = finiteArray(urel);
    prof["porosity"] = finiteArray(por);
    prof["wall"] = col.present ? "mask (column of equivalent radius)" : "box faces";
    j["radial_profile"] = prof;
    j["wall_flow_share"] =
        (dVox > 0 && total != 0) ? nlohmann::json(nearWall / total) : nlohmann::json(nullptr);
    j["wall_area_share"] =
        (dVox > 0) ? nlohmann::json(nearVol / summary.voxelsInMask) : nlohmann::json(nullptr);
  } else {
    j["radial_profile"] = nullptr;
    j["wall_flow_share"] = nullptr;
    j["wall_area_share"] = nullptr;
  }

  // Pressure gradient at the user's superficial velocity: Darcy from k, and the
  // correlations from the bed's porosity, d and D.
  {
    const double u = o.velocityMmS * 1e-3, mu = o.viscosityPaS, rho = o.densityKgM3;
    const double dM = dMm * 1e-3, DM = columnMm * 1e-3;
    nlohmann::json pg;
    pg["velocity_mm_s"] = o.velocityMmS;
    pg["viscosity_pa_s"] = mu;
    pg["density_kg_m3"] = rho;
    pg["darcy_pa_m"] = kMm2 > 0 ? nlohmann::json(mu * u / (kMm2 * 1e-6)) : nlohmann::json(nullptr);
    pg["ergun_pa_m"] = dM > 0 ? finiteOrNull(Correlations::ergun(eps, dM, mu, rho, u)) : nullptr;
    pg["eisfeld_schnitzlein_pa_m"] =
        dM > 0 ? finiteOrNull(Correlations::eisfeldSchnitzlein(eps, dM, DM, mu, rho, u)) : nullptr;
    pg["particle_reynolds"] = dM > 0 ? finiteOrNull(rho * u * dM / mu) : nullptr;
    j["pressure_gradient"] = pg;
    nlohmann::json pk;
    pk["kozeny_carman_mm2"] =
        dMm > 0 ? finiteOrNull(Correlations::kozenyCarman(eps, dMm)) : nullptr;
    pk["ergun_stokes_mm2"] =
        dMm > 0 ? finiteOrNull(Correlations::kozenyCarman(eps, dMm, 150.0)) : nullptr;
    pk["eisfeld_schnitzlein_stokes_mm2"] =
        dMm > 0 ? finiteOrNull(Correlations::eisfeldSchnitzleinPermeability(eps, dMm, columnMm))
                : nullptr;
    j["permeability_correlations"] = pk;
  }
  // Scale of the physical pressure: p_phys = p_lat * mu V / (nu u_s h).
  rep.pressureScale =
      us != 0 ? o.viscosityPaS * (o.velocityMmS * 1e-3) / (nu * us * h * 1e-3) : 0.0;
  rep.sampleStart = built.sampleStart;
  built.domain.sample.clear();
  rep.domain = std::move(built.domain);
  j["wall_s"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - tStart).count();
  j["solver_wall_s"] = r.wallS;
  return rep;
}

double Correlations::ergun(double eps, double d, double mu, double rho, double u) {
  const double e3 = eps * eps * eps;
  return 150.0 * mu * (1 - eps) * (1 - eps) * u / (e3 * d * d) +
         1.75 * rho * (1 - eps) * u * u / (e3 * d);
}

namespace {
// Eisfeld & Schnitzlein (2001) wall factors for spheres: K1 = 154, k1 = 1.15, k2 = 0.87.
void esFactors(double eps, double d, double column, double& aw, double& bw) {
  aw = 1.0, bw = 0.87 * 0.87;
  if (column > 0) {
    aw = 1.0 + 2.0 / (3.0 * (column / d) * (1.0 - eps));
    const double r = d / column;
    bw = std::pow(1.15 * r * r + 0.87, 2);
  }
}
}  // namespace

double Correlations::eisfeldSchnitzlein(double eps, double d, double column, double mu, double rho,
                                        double u) {
  double aw, bw;
  esFactors(eps, d, column, aw, bw);
  const double re = rho * u * d / mu, e3 = eps * eps * eps;
  const double psi =
      154.0 * aw * aw * (1 - eps) * (1 - eps) / (re * e3) + aw * (1 - eps) / (bw * e3);
  return psi * rho * u * u / d;
}

double Correlations::kozenyCarman(double eps, double d, double c) {
  return eps * eps * eps * d * d / (c * (1 - eps) * (1 - eps));
}

double Correlations::eisfeldSchnitzleinPermeability(double eps, double d, double column) {
  double aw, bw;
  esFactors(eps, d, column, aw, bw);
  return eps * eps * eps * d * d / (154.0 * aw * aw * (1 - eps) * (1 - eps));
}

}  // namespace voxpack::flow
