// The particle surfaces of a packed bed with contact treatment (docs/export.md):
// tessellate each distinct shape once, pose it per particle, find contacts from the exact
// signed distances, then shrink / grow / bridge / cap, and add the container wall.
#include "voxpack/export/surfaces.hpp"

#include <algorithm>
#include <cmath>
#include <map>

#include "voxpack/core/errors.hpp"
#include "voxpack/core/spec.hpp"
#include "voxpack/export/cgal_ops.hpp"
#include "voxpack/export/contacts.hpp"
#include "voxpack/export/tessellate.hpp"

namespace voxpack::exporter {
namespace {

const char* treatmentName(ContactTreatment t) {
  switch (t) {
    case ContactTreatment::None:
      return "none";
    case ContactTreatment::Gap:
      return "gap";
    case ContactTreatment::Overlap:
      return "overlap";
    case ContactTreatment::Bridge:
      return "bridge";
    case ContactTreatment::Cap:
      return "cap";
  }
  return "none";
}

double defaultContactSize(ContactTreatment t) {
  switch (t) {
    case ContactTreatment::Gap:
    case ContactTreatment::Overlap:
      return 0.01;
    case ContactTreatment::Bridge:
    case ContactTreatment::Cap:
      return 0.2;
    case ContactTreatment::None:
      return 0.0;
  }
  return 0.0;
}

// A closed cylinder of radius r from a to b.
TriMesh cylinderBetween(const Vec3& a, const Vec3& b, double r, double tol) {
  const Vec3 axis = b - a;
  const double len = axis.norm();
  TriMesh m = tessellateShape(
      "cylinder:d=" + packer::formatNumber(2 * r) + ",l=" + packer::formatNumber(len),
      std::max(tol, 1e-6));
  const Quat q = Quat::FromTwoVectors(Vec3::UnitZ(), axis / len);
  return posed(m, 0.5 * (a + b), q);
}

// Depth below the tangent plane of a sphere of radius R at distance a from the contact.
double sagitta(double R, double a) { return a < R ? R - std::sqrt(R * R - a * a) : R; }

std::string containerSpec(const Bed& bed) {
  const auto& p = bed.provenance;
  if (p.is_object() && p.contains("scene") && p["scene"].is_object() &&
      p["scene"].contains("container") && p["scene"]["container"].is_string())
    return p["scene"]["container"].get<std::string>();
  return {};
}

}  // namespace

ContactTreatment parseContactTreatment(const std::string& name) {
  if (name == "none") return ContactTreatment::None;
  if (name == "gap") return ContactTreatment::Gap;
  if (name == "overlap") return ContactTreatment::Overlap;
  if (name == "bridge") return ContactTreatment::Bridge;
  if (name == "cap") return ContactTreatment::Cap;
  throw UsageError("--contacts: unknown treatment '" + name +
                   "' (expected none, gap, overlap, bridge, cap)");
}

SurfaceResult particleSurfaces(const Bed& bed, const SurfaceOptions& o, Progress& progress) {
  const ParticleTable& pt = bed.particles;
  if (pt.empty())
    throw InputError("the bed has no particle table (/particles): use --surface for an imaged bed");
  // Distinct shapes, their exact models and the largest characteristic diameter d.
  std::map<std::string, std::shared_ptr<const packer::Shape>> shapes;
  double d = 0;
  for (const auto& s : pt.shape)
    if (!shapes.count(s)) {
      auto shape = packer::parseShape(s);
      d = std::max(d, shape->characteristicDiameterMm());
      shapes[s] = shape;
    }
  const double tol = o.toleranceMm > 0 ? o.toleranceMm : d / 500;
  const double size = o.contactSize >= 0 ? o.contactSize : defaultContactSize(o.contacts);
  if ((o.contacts == ContactTreatment::Gap && !(size < 1)) || size > 1)
    throw UsageError("--contact-size must lie in [0, 1) (in units of d)");
  const Lattice& lat = bed.lattice();
  const double contactTol = o.contactToleranceMm >= 0
                                ? o.contactToleranceMm
                                : std::max({lat.spacingMm[0], lat.spacingMm[1], lat.spacingMm[2]});
  std::map<std::string, TriMesh> bodies;
  for (const auto& [spec, shape] : shapes) bodies[spec] = tessellateShape(spec, tol);

  const auto n = static_cast<std::int64_t>(pt.size());
  std::vector<PosedParticle> posedParticles(pt.size());
#pragma omp parallel for schedule(static) num_threads(std::max(1, o.threads))
  for (std::int64_t i = 0; i < n; ++i) {
    const auto u = static_cast<std::size_t>(i);
    auto& p = posedParticles[u];
    p.shape = shapes.at(pt.shape[u]);
    p.centreMm = pt.positionMm[u];
    p.orientation = pt.orientation[u].normalized();
    p.surface = posed(bodies.at(pt.shape[u]), p.centreMm, p.orientation);
  }
  progress.report("export: surfaces", 0.2);

  const std::string wallSpec = containerSpec(bed);
  std::shared_ptr<const packer::Container> wall;
  if (!wallSpec.empty() && wallSpec.rfind("mask:", 0) != 0) {
    try {
      wall = packer::parseContainer(wallSpec);
    } catch (const Error& e) {
      progress.message(std::string("export: no container wall (") + e.what() + ")");
    }
  }
  std::vector<Contact> contacts;
  if (o.contacts != ContactTreatment::None)
    contacts = findContacts(posedParticles, wall.get(), {contactTol, o.threads, o.wallContacts});
  progress.report("export: surfaces", 0.4);
  if (progress.cancelled()) throw Cancelled("export cancelled");

  SurfaceResult r;
  std::size_t wallContacts = 0, pairContacts = 0, unresolved = 0;
  std::size_t sideContacts = 0, floorContacts = 0, lidContacts = 0;
  for (const auto& c : contacts) {
    (c.b < 0 ? wallContacts : pairContacts)++;
    sideContacts += c.wall == WallPart::Side;
    floorContacts += c.wall == WallPart::Floor;
    lidContacts += c.wall == WallPart::Lid;
  }
  const double a = size * d / 2;  // bridge radius / cap flat radius
  std::vector<TriMesh> pieces;
  // Weld distance of the union: corefinement's exact intersection points, rounded to double,
  // can lie closer than a float STL reader (snappyHexMesh, VTK) resolves and fold slivers.
  // 1e-6 of the bed's extent is ~8 float ulps; 1e-3 of the chord tolerance keeps the weld
  // far below the tessellation error.
  double extent = 0;
  for (const auto& c : pt.positionMm) extent = std::max(extent, c.cwiseAbs().maxCoeff() + d);
  const double weldMm = o.weldMm >= 0 ? o.weldMm : std::max(1e-3 * tol, 1e-6 * extent);
  RepairReport repair;
  auto particleName = [](std::int64_t i) { return "particle_" + std::to_string(i + 1); };

  switch (o.contacts) {
    case ContactTreatment::None:
      for (std::int64_t i = 0; i < n; ++i)
        r.solids.push_back(
            {particleName(i), std::move(posedParticles[static_cast<std::size_t>(i)].surface)});
      break;
    case ContactTreatment::Gap:
    case ContactTreatment::Overlap: {
      const double k = o.contacts == ContactTreatment::Gap ? 1 - size : 1 + size;
      for (std::int64_t i = 0; i < n; ++i) {
        const auto u = static_cast<std::size_t>(i);
        pieces.push_back(
            posed(bodies.at(pt.shape[u]), pt.positionMm[u], pt.orientation[u].normalized(), k));
      }
      // Shrinking by (1 - s) about both centres opens a touching pair by about s * (ra + rb)
      // (exact for spheres); a pair overlapping deeper than that stays overlapped.
      for (const auto& c : contacts) {
        if (c.b < 0) continue;
        const double ra =
            posedParticles[static_cast<std::size_t>(c.a)].shape->characteristicDiameterMm() / 2;
        const double rb =
            posedParticles[static_cast<std::size_t>(c.b)].shape->characteristicDiameterMm() / 2;
        if (o.contacts == ContactTreatment::Gap && c.gapMm + size * std::min(ra, rb) * 2 <= 0)
          ++unresolved;
      }
      if (o.contacts == ContactTreatment::Gap) {
        for (std::int64_t i = 0; i < n; ++i)
          r.solids.push_back({particleName(i), std::move(pieces[static_cast<std::size_t>(i)])});
      } else {
        progress.message("export: union of " + std::to_string(pieces.size()) +
                         " grown particles (CGAL)");
        r.solids.push_back({"bed", unionOf(pieces, weldMm, &repair)});
      }
      break;
    }
    case ContactTreatment::Bridge: {
      for (std::int64_t i = 0; i < n; ++i)
        pieces.push_back(posedParticles[static_cast<std::size_t>(i)].surface);
      const double margin = 0.02 * d;
      for (const auto& c : contacts) {
        const double Ra =
            posedParticles[static_cast<std::size_t>(c.a)].shape->characteristicDiameterMm() / 2;
        const double inA = std::max(0.0, c.gapMm) / 2 + sagitta(Ra, a) + margin;
        double inB;
        if (c.b >= 0) {
          const double Rb =
              posedParticles[static_cast<std::size_t>(c.b)].shape->characteristicDiameterMm() / 2;
          inB = std::max(0.0, c.gapMm) / 2 + sagitta(Rb, a) + margin;
        } else {
          inB = std::max(0.0, c.gapMm) / 2 + margin;  // through the wall, outside the fluid
        }
        pieces.push_back(
            cylinderBetween(c.pointMm - inA * c.normal, c.pointMm + inB * c.normal, a, tol));
      }
      progress.message("export: union of " + std::to_string(n) + " particles and " +
                       std::to_string(contacts.size()) + " bridges (CGAL)");
      r.solids.push_back({"bed", unionOf(pieces, weldMm, &repair)});
      break;
    }
    case ContactTreatment::Cap: {
      std::vector<std::vector<std::pair<Vec3, Vec3>>> planes(pt.size());
      for (const auto& c : contacts) {
        const double Ra =
            posedParticles[static_cast<std::size_t>(c.a)].shape->characteristicDiameterMm() / 2;
        planes[static_cast<std::size_t>(c.a)].push_back(
            {c.pointMm - sagitta(Ra, a) * c.normal, c.normal});
        if (c.b >= 0) {
          const double Rb =
              posedParticles[static_cast<std::size_t>(c.b)].shape->characteristicDiameterMm() / 2;
          planes[static_cast<std::size_t>(c.b)].push_back(
              {c.pointMm + sagitta(Rb, a) * c.normal, -c.normal});
        }
      }
      for (std::int64_t i = 0; i < n; ++i) {
        const auto u = static_cast<std::size_t>(i);
        TriMesh m = std::move(posedParticles[u].surface);
        for (const auto& [p, nrm] : planes[u]) m = clipByPlane(m, p, nrm);
        r.solids.push_back({particleName(i), std::move(m)});
        if (progress.cancelled()) throw Cancelled("export cancelled");
        progress.report("export: caps",
                        0.4 + 0.5 * static_cast<double>(i + 1) / static_cast<double>(n));
      }
      break;
    }
  }
  if (o.wall && !wallSpec.empty()) {
    TriMesh w = tessellateContainer(wallSpec, tol);
    if (!w.triangles.empty()) r.solids.push_back({"wall", std::move(w)});
  }
  bool unionSolid =
      o.contacts == ContactTreatment::Bridge || o.contacts == ContactTreatment::Overlap;
  std::size_t tris = 0, verts = 0;
  for (const auto& s : r.solids) {
    tris += s.mesh.triangles.size();
    verts += s.mesh.vertices.size();
  }
  r.report = {{"particles", pt.size()},
              {"contacts", treatmentName(o.contacts)},
              {"contact_size_d", size},
              {"d_mm", d},
              {"tolerance_mm", tol},
              {"contact_tolerance_mm", contactTol},
              {"particle_contacts", pairContacts},
              {"wall_contacts", wallContacts},
              {"wall_contacts_by_part",
               {{"side", sideContacts}, {"floor", floorContacts}, {"lid", lidContacts}}},
              {"wall_contacts_parts", o.wallContacts == WallContacts::All    ? "all"
                                      : o.wallContacts == WallContacts::Side ? "side"
                                                                             : "none"},
              {"gap_unresolved_pairs", unresolved},
              {"solids", r.solids.size()},
              {"triangles", tris},
              {"vertices", verts},
              {"container", wallSpec}};
  if (unionSolid) {
    // Checked on the welded mesh as written (9 digits resolve the weld distance).
    r.report["self_intersecting"] = selfIntersects(r.solids[0].mesh);
    r.report["closed_manifold"] = isClosedManifold(r.solids[0].mesh);
    r.report["weld_mm"] = weldMm;
    r.report["repair"] = {{"welded_vertices", repair.weldedVertices},
                          {"collapsed_triangles", repair.collapsedTriangles},
                          {"fin_triangles", repair.finTriangles},
                          {"degenerate_removed", repair.degenerateRemoved}};
  }
  progress.report("export: surfaces", 1.0);
  return r;
}

}  // namespace voxpack::exporter
