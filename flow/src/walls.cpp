// Signed distance of a bed's exact walls (particle table + container) on the solver lattice.
//
// The fluid is inside the container and outside every particle, so its signed distance is
// min(container, min over particles); only the sign and the value in the band next to the
// interface matter to the solver (a link's wall cut q = phi_f / (phi_f - phi_s)), so only
// cells within one D3Q19 link of a fluid/solid interface are evaluated, each against the
// particles of its cell-list bin. Reservoir layers hold no particle: there each particle is
// clipped to the sample slab (max of the two distances), so a link from a reservoir cell into
// a particle cut by the sample face meets the face at least halfway.
#include "walls.hpp"

#include <omp.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>

#include "d3q19.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/core/spec.hpp"

namespace voxpack::flow::detail {
namespace {

constexpr float kFar = 3.0f;   // |distance| outside the band (any value of the right sign)
constexpr double kBand = 2.0;  // voxels: particles farther than this from a cell are skipped
constexpr double kInf = std::numeric_limits<double>::infinity();

enum class Kind : std::uint8_t { Sphere, Cylinder, Ring, Box };

// A shape with a closed-form signed distance, sizes in the units of the points given.
struct ExactShape {
  Kind kind = Kind::Sphere;
  double a = 0, b = 0, c = 0;  // sphere r; cylinder r, l/2; ring r_o, r_i, l/2; box half x, y, z
  double bound = 0;            // radius of the enclosing sphere
};

// The signed distance (< 0 inside) of a rectangle |u| <= hu, |v| <= hv in 2-D.
inline double rect2(double u, double v, double hu, double hv) {
  const double du = std::abs(u) - hu, dv = std::abs(v) - hv;
  return std::min(std::max(du, dv), 0.0) + std::hypot(std::max(du, 0.0), std::max(dv, 0.0));
}

double exactDistance(const ExactShape& s, const Vec3& p) {
  switch (s.kind) {
    case Kind::Sphere:
      return p.norm() - s.a;
    case Kind::Cylinder:  // finite cylinder along body z: a rectangle in (rho, z)
      return rect2(std::hypot(p.x(), p.y()), p.z(), s.a, s.b);
    case Kind::Ring:  // hollow cylinder: the rectangle r_i <= rho <= r_o, |z| <= l/2
      return rect2(std::hypot(p.x(), p.y()) - 0.5 * (s.a + s.b), p.z(), 0.5 * (s.a - s.b), s.c);
    case Kind::Box: {
      const Vec3 d = p.cwiseAbs() - Vec3(s.a, s.b, s.c);
      return std::min(d.maxCoeff(), 0.0) + d.cwiseMax(0.0).norm();
    }
  }
  return kInf;
}

// The closed-form shape of a spec in mm; false for shapes without one (ellipsoid, trilobe,
// mesh) or a spec that does not parse.
bool parseExact(const std::string& spec, ExactShape& s) {
  try {
    const ParsedSpec p = parseSpec(spec, "particle shape");
    if (p.name == "sphere") {
      s = {Kind::Sphere, 0.5 * p.positive("d"), 0, 0, 0};
      s.bound = s.a;
    } else if (p.name == "cylinder") {
      s = {Kind::Cylinder, 0.5 * p.positive("d"), 0.5 * p.positive("l"), 0, 0};
      s.bound = std::hypot(s.a, s.b);
    } else if (p.name == "ring") {
      s = {Kind::Ring, 0.5 * p.positive("d"), 0.5 * p.positive("di"), 0.5 * p.positive("l"), 0};
      if (!(s.b < s.a)) return false;
      s.bound = std::hypot(s.a, s.c);
    } else if (p.name == "box") {
      s = {Kind::Box, 0.5 * p.positive("x"), 0.5 * p.positive("y"), 0.5 * p.positive("z"), 0};
      s.bound = Vec3(s.a, s.b, s.c).norm();
    } else {
      return false;
    }
  } catch (const InputError&) {
    return false;
  }
  return true;
}

// A particle (or a periodic image) on the lattice: everything in voxels of the sample's
// continuous index (x, y, z) = (i, j, k).
struct Posed {
  ExactShape shape;        // sizes in voxels
  Vec3 centre;             // continuous index
  Eigen::Matrix3d toBody;  // world -> body rotation
};

// The container's distance (voxels, > 0 inside) from its walls parallel to the flow axis;
// the walls across the axis are the sample's ends (reservoirs, mirror or periodic), not walls.
struct ContainerWall {
  enum class Kind { None, Cylinder, Box } kind = Kind::None;
  double cx = 0, cy = 0, cz = 0;  // centre (continuous index); cz: the box's mid-height
  double r = 0;                   // cylinder radius (voxels)
  Vec3 half = Vec3::Zero();       // box half sizes (voxels)
  int axis = 0;                   // flow axis (array order)
  double distance(const Vec3& x) const {
    if (kind == Kind::Cylinder) return r - std::hypot(x.x() - cx, x.y() - cy);
    if (kind == Kind::Box) {
      Vec3 d = (x - Vec3(cx, cy, cz)).cwiseAbs() - half;
      d[2 - axis] = -kInf;  // array axis a is component 2 - a of (x, y, z)
      if (d.maxCoeff() <= 0) return -d.maxCoeff();
      return -d.cwiseMax(0.0).norm();
    }
    return kInf;
  }
};

ContainerWall containerWall(const Bed& bed, int axis, WallReport& rep) {
  ContainerWall w;
  w.axis = axis;
  const auto& p = bed.provenance;
  if (p.is_object() && p.contains("scene") && p["scene"].is_object() &&
      p["scene"].contains("container") && p["scene"]["container"].is_string())
    rep.container = p["scene"]["container"].get<std::string>();
  if (!bed.mask) {
    rep.containerWalls = "none (no mask)";
    return w;
  }
  if (rep.container.empty()) {
    rep.containerWalls = "halfway (no container in the provenance)";
    return w;
  }
  const Lattice& l = bed.lattice();
  const double h = l.spacingMm[0];
  // The container frame is the bed's world frame (the packer places the lattice on it).
  const Vec3 origin = l.continuousIndex(Vec3::Zero());
  try {
    const ParsedSpec s = parseSpec(rep.container, "container");
    if (s.name == "cylinder") {
      if (axis != 0) {
        rep.containerWalls = "halfway (the cylinder's axis is not the flow axis)";
        return w;
      }
      w.kind = ContainerWall::Kind::Cylinder;
      w.cx = origin.x();
      w.cy = origin.y();
      w.r = 0.5 * s.positive("d") / h;
    } else if (s.name == "box") {
      w.kind = ContainerWall::Kind::Box;
      w.cx = origin.x();
      w.cy = origin.y();
      w.cz = origin.z() + 0.5 * s.positive("z") / h;
      w.half = Vec3(s.positive("x"), s.positive("y"), s.positive("z")) * (0.5 / h);
    } else {
      rep.containerWalls = "halfway (no closed-form distance for '" + s.name + "')";
      return w;
    }
  } catch (const InputError&) {
    rep.containerWalls = "halfway (unreadable container spec)";
    return w;
  }
  rep.containerWalls = "interpolated";
  return w;
}

// Particles binned by cell: each particle is listed in every bin its bounding sphere
// (plus the band) overlaps.
struct CellList {
  Vec3 lo = Vec3::Zero();
  double size = 1;
  std::array<std::int64_t, 3> n{1, 1, 1};  // bins along x, y, z
  std::vector<std::uint32_t> start;        // CSR
  std::vector<std::uint32_t> items;
  const std::uint32_t* begin(const Vec3& x, const std::uint32_t*& end) const {
    std::int64_t b[3];
    for (int a = 0; a < 3; ++a) {
      b[a] = static_cast<std::int64_t>(std::floor((x[a] - lo[a]) / size));
      if (b[a] < 0 || b[a] >= n[static_cast<std::size_t>(a)]) {
        end = nullptr;
        return nullptr;
      }
    }
    const std::size_t bin = static_cast<std::size_t>((b[2] * n[1] + b[1]) * n[0] + b[0]);
    end = items.data() + start[bin + 1];
    return items.data() + start[bin];
  }
};

CellList binParticles(const std::vector<Posed>& ps, const Vec3& lo, const Vec3& hi) {
  CellList cl;
  double maxBound = 0;
  for (const Posed& p : ps) maxBound = std::max(maxBound, p.shape.bound);
  cl.size = std::max(4.0, maxBound);
  cl.lo = lo;
  for (int a = 0; a < 3; ++a)
    cl.n[static_cast<std::size_t>(a)] =
        std::max<std::int64_t>(1, static_cast<std::int64_t>(std::ceil((hi[a] - lo[a]) / cl.size)));
  const std::size_t bins = static_cast<std::size_t>(cl.n[0] * cl.n[1] * cl.n[2]);
  auto range = [&](const Posed& p, int a, std::int64_t& b0, std::int64_t& b1) {
    const double r = p.shape.bound + kBand;
    b0 = std::max<std::int64_t>(
        0, static_cast<std::int64_t>(std::floor((p.centre[a] - r - cl.lo[a]) / cl.size)));
    b1 = std::min<std::int64_t>(
        cl.n[static_cast<std::size_t>(a)] - 1,
        static_cast<std::int64_t>(std::floor((p.centre[a] + r - cl.lo[a]) / cl.size)));
  };
  std::vector<std::uint32_t> count(bins + 1, 0);
  for (int pass = 0; pass < 2; ++pass) {
    for (std::size_t id = 0; id < ps.size(); ++id) {
      std::int64_t b0[3], b1[3];
      for (int a = 0; a < 3; ++a) range(ps[id], a, b0[a], b1[a]);
      for (std::int64_t z = b0[2]; z <= b1[2]; ++z)
        for (std::int64_t y = b0[1]; y <= b1[1]; ++y)
          for (std::int64_t x = b0[0]; x <= b1[0]; ++x) {
            const std::size_t bin = static_cast<std::size_t>((z * cl.n[1] + y) * cl.n[0] + x);
            if (pass == 0)
              ++count[bin + 1];
            else
              cl.items[count[bin]++] = static_cast<std::uint32_t>(id);
          }
    }
    if (pass == 0) {
      for (std::size_t b = 0; b < bins; ++b) count[b + 1] += count[b];
      cl.start = count;
      cl.items.resize(count[bins]);
    }
  }
  return cl;
}

inline bool neighbourOf(const std::array<std::int64_t, 3>& dims, const std::array<bool, 3>& per,
                        std::int64_t p[3], const int c[3]) {
  for (int a = 0; a < 3; ++a) {
    p[a] += c[a];
    const std::int64_t n = dims[static_cast<std::size_t>(a)];
    if (p[a] < 0 || p[a] >= n) {
      if (!per[static_cast<std::size_t>(a)]) return false;
      p[a] = (p[a] + n) % n;
    }
  }
  return true;
}

}  // namespace

bool shapeSignedDistanceMm(const std::string& spec, const Vec3& bodyMm, double& out) {
  ExactShape s;
  if (!parseExact(spec, s)) return false;
  out = exactDistance(s, bodyMm);
  return true;
}

std::uint64_t countWallLinks(const LbmDomain& dom, int threads) {
  const auto& d = dom.dims;
  std::uint64_t links = 0;
#pragma omp parallel for schedule(static) reduction(+ : links) num_threads(std::max(1, threads))
  for (std::int64_t k = 0; k < d[0]; ++k)
    for (std::int64_t j = 0; j < d[1]; ++j)
      for (std::int64_t i = 0; i < d[2]; ++i) {
        if (!dom.fluid[static_cast<std::size_t>((k * d[1] + j) * d[2] + i)]) continue;
        for (int q = 1; q < kQ; ++q) {
          std::int64_t p[3] = {k, j, i};
          if (neighbourOf(d, dom.periodic, p, kC[q]) &&
              !dom.fluid[static_cast<std::size_t>((p[0] * d[1] + p[1]) * d[2] + p[2])])
            ++links;
        }
      }
  return links;
}

WallReport buildWallDistance(const Bed& bed, const DomainMap& map, LbmDomain& dom, int threads) {
  const auto t0 = std::chrono::steady_clock::now();
  WallReport rep;
  const Lattice& l = bed.lattice();
  const double h = l.spacingMm[0];
  const int ax = map.axis;
  const int cax = 2 - ax;  // the axis as a component of (x, y, z)
  const ContainerWall wall = containerWall(bed, ax, rep);

  // The sample's continuous-index box, the reservoirs included.
  Vec3 lo(-0.5, -0.5, -0.5),
      hi(static_cast<double>(l.nx()) - 0.5, static_cast<double>(l.ny()) - 0.5,
         static_cast<double>(l.nz()) - 0.5);
  if (map.reservoirs) {
    lo[cax] -= static_cast<double>(map.sampleStart);
    hi[cax] += static_cast<double>(map.sampleStart);
  }
  const Vec3 period = hi - lo;

  // The particles with a closed form, in voxels; periodic images when every axis wraps.
  std::vector<Posed> posed;
  const ParticleTable& pt = bed.particles;
  rep.particles = pt.size();
  std::map<std::string, std::pair<bool, ExactShape>> shapes;
  for (std::size_t id = 0; id < pt.size(); ++id) {
    auto it = shapes.find(pt.shape[id]);
    if (it == shapes.end()) {
      ExactShape s;
      const bool ok = parseExact(pt.shape[id], s);
      it = shapes.emplace(pt.shape[id], std::make_pair(ok, s)).first;
    }
    if (!it->second.first) {
      ++rep.halfwayShapes[pt.shape[id]];
      continue;
    }
    ++rep.particlesExact;
    Posed p;
    p.shape = it->second.second;
    p.shape.a /= h, p.shape.b /= h, p.shape.c /= h, p.shape.bound /= h;
    p.centre = l.continuousIndex(pt.positionMm[id]);
    p.toBody = id < pt.orientation.size()
                   ? Eigen::Matrix3d(pt.orientation[id].normalized().toRotationMatrix().transpose())
                   : Eigen::Matrix3d::Identity();
    const double r = p.shape.bound + kBand;
    for (int sz = -1; sz <= 1; ++sz)
      for (int sy = -1; sy <= 1; ++sy)
        for (int sx = -1; sx <= 1; ++sx) {
          if (!map.periodic && (sx || sy || sz)) continue;
          Posed img = p;
          img.centre += Vec3(sx * period.x(), sy * period.y(), sz * period.z());
          bool overlaps = true;
          for (int a = 0; a < 3; ++a)
            overlaps = overlaps && img.centre[a] + r >= lo[a] && img.centre[a] - r <= hi[a];
          if (!overlaps) continue;
          if (sx || sy || sz) ++rep.imageParticles;
          posed.push_back(img);
        }
  }
  const CellList cells = binParticles(posed, lo, hi);

  const auto& d = dom.dims;
  const std::size_t box = static_cast<std::size_t>(d[0] * d[1] * d[2]);
  dom.signedDistance.assign(box, 0.0f);
  const double len = static_cast<double>(map.sampleLength);
  // A point of the solver lattice's continuous index (z, y, x in array order) as a point of
  // the sample (x, y, z): reservoir points lie outside [-1/2, len - 1/2) along the axis,
  // mirror points map back onto the sample (about its last face).
  auto toSample = [&](const double at[3]) {
    double s[3] = {at[0], at[1], at[2]};
    s[ax] -= static_cast<double>(map.sampleStart);
    if (map.mirror && s[ax] > len - 0.5) s[ax] = 2 * len - 1 - s[ax];
    return Vec3(s[2], s[1], s[0]);
  };
  // The exact distance (voxels) at sample point x, with the particles of the cell-list bin of
  // `binAt`, a point within one link of x (the particles are binned with a band of 2 voxels).
  auto distanceAt = [&](const Vec3& x, const Vec3& binAt) {
    // Outside the sample slab (reservoirs), the particles are cut by its faces.
    const double slab = map.reservoirs ? std::max(-0.5 - x[cax], x[cax] - (len - 0.5)) : -kInf;
    double phi = wall.distance(x);
    const std::uint32_t *it, *end;
    it = cells.begin(binAt, end);
    for (; it && it != end; ++it) {
      const Posed& p = posed[*it];
      const Vec3 rel = x - p.centre;
      const double reach = p.shape.bound + kBand;
      if (rel.squaredNorm() > reach * reach) continue;
      phi = std::min(phi, std::max(exactDistance(p.shape, p.toBody * rel), slab));
    }
    return phi;
  };
  std::size_t band = 0;
#pragma omp parallel for schedule(dynamic, 1) reduction(+ : band) num_threads(std::max(1, threads))
  for (std::int64_t k = 0; k < d[0]; ++k)
    for (std::int64_t j = 0; j < d[1]; ++j)
      for (std::int64_t i = 0; i < d[2]; ++i) {
        const std::size_t off = static_cast<std::size_t>((k * d[1] + j) * d[2] + i);
        const bool fluid = dom.fluid[off] != 0;
        bool edge = false;
        for (int q = 1; q < kQ && !edge; ++q) {
          std::int64_t p[3] = {k, j, i};
          if (neighbourOf(d, dom.periodic, p, kC[q]))
            edge = (dom.fluid[static_cast<std::size_t>((p[0] * d[1] + p[1]) * d[2] + p[2])] != 0) !=
                   fluid;
        }
        if (!edge) {
          dom.signedDistance[off] = fluid ? kFar : -kFar;
          continue;
        }
        ++band;
        const double at[3] = {static_cast<double>(k), static_cast<double>(j),
                              static_cast<double>(i)};
        const Vec3 x = toSample(at);
        // No exact surface within the band: a value of the fluid's sign (a solid cell that
        // no exact surface describes then keeps halfway bounce-back).
        dom.signedDistance[off] = static_cast<float>(std::clamp(distanceAt(x, x), -3.0, 3.0));
      }

  // The exact cut of every link the solver will interpolate (fluid centre > 0, solid centre
  // <= 0): the ratio of the two centre distances is exact at a plane, but beside an edge (a
  // cylinder's rim, a box's) the distance outside is rounded, larger than the plane's, and
  // the ratio puts the wall too far into the solid; that error lives on the edges' cells
  // (a share ~1/N of the surface) and showed as first-order convergence of k on a tilted
  // cylinder. So the first sign change along the link is bracketed on 4 sub-intervals and
  // refined by false position (Illinois) on the same union distance.
  std::vector<std::vector<WallCut>> perLayer(static_cast<std::size_t>(d[0]));
#pragma omp parallel for schedule(dynamic, 1) num_threads(std::max(1, threads))
  for (std::int64_t k = 0; k < d[0]; ++k) {
    auto& cuts = perLayer[static_cast<std::size_t>(k)];
    for (std::int64_t j = 0; j < d[1]; ++j)
      for (std::int64_t i = 0; i < d[2]; ++i) {
        const std::size_t off = static_cast<std::size_t>((k * d[1] + j) * d[2] + i);
        if (!dom.fluid[off] || !(dom.signedDistance[off] > 0)) continue;
        const double at[3] = {static_cast<double>(k), static_cast<double>(j),
                              static_cast<double>(i)};
        const Vec3 binAt = toSample(at);
        for (int q = 1; q < kQ; ++q) {
          std::int64_t p[3] = {k, j, i};
          if (!neighbourOf(d, dom.periodic, p, kC[q])) continue;
          const std::size_t so = static_cast<std::size_t>((p[0] * d[1] + p[1]) * d[2] + p[2]);
          if (dom.fluid[so] || !(dom.signedDistance[so] <= 0)) continue;
          auto phiAt = [&](double t) {
            const double x[3] = {at[0] + t * kC[q][0], at[1] + t * kC[q][1], at[2] + t * kC[q][2]};
            return distanceAt(toSample(x), binAt);
          };
          double a = 0, fa = phiAt(0), b = 1, fb = phiAt(1);
          if (!(fa > 0) || !(fb <= 0)) continue;  // the centres disagree: the ratio stays
          for (int s = 1; s < 4; ++s) {           // the first sign change
            const double t = 0.25 * s, ft = phiAt(t);
            if (ft <= 0) {
              b = t, fb = ft;
              break;
            }
            a = t, fa = ft;
          }
          int side = 0;
          for (int it = 0; it < 40 && b - a > 1e-6; ++it) {
            const double t = std::clamp((a * fb - b * fa) / (fb - fa), a, b);
            const double ft = phiAt(t);
            if (ft > 0) {
              a = t, fa = ft;
              if (side == 1) fb *= 0.5;
              side = 1;
            } else {
              b = t, fb = ft;
              if (side == -1) fa *= 0.5;
              side = -1;
            }
            if (ft == 0) a = b = t;
          }
          cuts.push_back({off, static_cast<std::uint32_t>(q), static_cast<float>(0.5 * (a + b))});
        }
      }
  }
  std::size_t nCuts = 0;
  for (const auto& c : perLayer) nCuts += c.size();
  dom.wallCuts.clear();
  dom.wallCuts.reserve(nCuts);
  for (auto& c : perLayer) {
    dom.wallCuts.insert(dom.wallCuts.end(), c.begin(), c.end());
    std::vector<WallCut>().swap(c);
  }
  rep.distanceCells = band;
  rep.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return rep;
}

}  // namespace voxpack::flow::detail
