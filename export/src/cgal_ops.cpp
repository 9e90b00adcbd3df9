// CGAL Polygon Mesh Processing behind plain TriMesh types. Booleans and clipping use exact
// constructions (Epeck): chained corefinements with rounded constructions can create
// self-intersections that make the next one fail; the checks use exact predicates only.
#include "voxpack/export/cgal_ops.hpp"

#include <CGAL/Exact_predicates_exact_constructions_kernel.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/clip.h>
#include <CGAL/Polygon_mesh_processing/corefinement.h>
#include <CGAL/Polygon_mesh_processing/intersection.h>
#include <CGAL/Polygon_mesh_processing/orient_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/repair.h>
#include <CGAL/Polygon_mesh_processing/repair_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Surface_mesh.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <type_traits>
#include <unordered_map>

#include "voxpack/core/errors.hpp"

namespace voxpack::exporter {
namespace {

namespace PMP = CGAL::Polygon_mesh_processing;
using Exact = CGAL::Exact_predicates_exact_constructions_kernel;
using Inexact = CGAL::Exact_predicates_inexact_constructions_kernel;
template <class K>
using SM = CGAL::Surface_mesh<typename K::Point_3>;

template <class K>
SM<K> toCgal(const TriMesh& m) {
  SM<K> out;
  std::vector<typename SM<K>::Vertex_index> v;
  v.reserve(m.vertices.size());
  for (const Vec3& p : m.vertices)
    v.push_back(out.add_vertex(typename K::Point_3(p.x(), p.y(), p.z())));
  for (const auto& t : m.triangles)
    if (out.add_face(v[t[0]], v[t[1]], v[t[2]]) == SM<K>::null_face())
      throw InternalError("mesh is not a 2-manifold (CGAL refused a face)");
  return out;
}

template <class K>
TriMesh fromCgal(const SM<K>& m) {
  TriMesh out;
  std::vector<std::uint32_t> index(m.number_of_vertices() + m.number_of_removed_vertices(), 0);
  for (auto v : m.vertices()) {
    index[v.idx()] = static_cast<std::uint32_t>(out.vertices.size());
    const auto& p = m.point(v);
    if constexpr (std::is_same_v<K, Exact>) {
      // to_double of a lazy exact number returns its interval approximation, which
      // depends on what was evaluated before (not reproducible run to run); the exact
      // value rounds to the nearest double, the same bytes every run.
      out.vertices.emplace_back(CGAL::to_double(CGAL::exact(p.x())),
                                CGAL::to_double(CGAL::exact(p.y())),
                                CGAL::to_double(CGAL::exact(p.z())));
    } else {
      out.vertices.emplace_back(p.x(), p.y(), p.z());
    }
  }
  for (auto f : m.faces()) {
    std::array<std::uint32_t, 3> t{};
    int c = 0;
    for (auto v : CGAL::vertices_around_face(m.halfedge(f), m)) {
      if (c < 3) t[c] = index[v.idx()];
      ++c;
    }
    if (c != 3) throw InternalError("CGAL returned a non-triangle face");
    out.triangles.push_back(t);
  }
  return out;
}

}  // namespace

TriMesh weldAndRepair(const TriMesh& in, double weldMm, RepairReport* report) {
  RepairReport rep;
  rep.verticesIn = in.vertices.size();
  rep.trianglesIn = in.triangles.size();
  // 1. Weld: vertices closer than weldMm become one (the first in index order, so the
  //    result does not depend on threads). A hash grid of cell weldMm finds candidates.
  std::vector<std::uint32_t> remap(in.vertices.size());
  TriMesh out;
  if (weldMm > 0) {
    struct CellHash {
      std::size_t operator()(const std::array<std::int64_t, 3>& c) const {
        return static_cast<std::size_t>(c[0] * 73856093LL ^ c[1] * 19349663LL ^ c[2] * 83492791LL);
      }
    };
    std::unordered_map<std::array<std::int64_t, 3>, std::vector<std::uint32_t>, CellHash> grid;
    grid.reserve(in.vertices.size());
    auto cellOf = [&](const Vec3& p) {
      return std::array<std::int64_t, 3>{static_cast<std::int64_t>(std::floor(p.x() / weldMm)),
                                         static_cast<std::int64_t>(std::floor(p.y() / weldMm)),
                                         static_cast<std::int64_t>(std::floor(p.z() / weldMm))};
    };
    for (std::size_t i = 0; i < in.vertices.size(); ++i) {
      const Vec3& p = in.vertices[i];
      const auto c = cellOf(p);
      std::int64_t found = -1;
      for (int dz = -1; dz <= 1 && found < 0; ++dz)
        for (int dy = -1; dy <= 1 && found < 0; ++dy)
          for (int dx = -1; dx <= 1 && found < 0; ++dx) {
            auto it = grid.find({c[0] + dx, c[1] + dy, c[2] + dz});
            if (it == grid.end()) continue;
            for (std::uint32_t j : it->second)
              if ((out.vertices[j] - p).norm() <= weldMm) {
                found = j;
                break;
              }
          }
      if (found >= 0) {
        remap[i] = static_cast<std::uint32_t>(found);
        ++rep.weldedVertices;
      } else {
        remap[i] = static_cast<std::uint32_t>(out.vertices.size());
        grid[c].push_back(remap[i]);
        out.vertices.push_back(p);
      }
    }
  } else {
    for (std::size_t i = 0; i < in.vertices.size(); ++i) remap[i] = static_cast<std::uint32_t>(i);
    out.vertices = in.vertices;
  }
  // 2. Polygon soup: faces collapsed by the weld are dropped, then CGAL's soup repair
  //    removes duplicated faces and splits non-manifold vertices, and the soup is oriented
  //    and turned back into a mesh.
  std::vector<Inexact::Point_3> points;
  points.reserve(out.vertices.size());
  for (const Vec3& p : out.vertices) points.emplace_back(p.x(), p.y(), p.z());
  std::vector<std::vector<std::size_t>> faces;
  faces.reserve(in.triangles.size());
  for (const auto& t : in.triangles) {
    const std::size_t a = remap[t[0]], b = remap[t[1]], c = remap[t[2]];
    if (a == b || b == c || a == c) {
      ++rep.collapsedTriangles;
      continue;
    }
    faces.push_back({a, b, c});
  }
  // Pairs of the same triangle with opposite orientation are a zero-volume fin: both go.
  {
    std::map<std::array<std::size_t, 3>, std::vector<std::size_t>> byKey;
    for (std::size_t f = 0; f < faces.size(); ++f) {
      std::array<std::size_t, 3> k{faces[f][0], faces[f][1], faces[f][2]};
      std::sort(k.begin(), k.end());
      byKey[k].push_back(f);
    }
    std::vector<char> drop(faces.size(), 0);
    for (const auto& [k, fs] : byKey)
      if (fs.size() > 1)
        for (std::size_t f : fs) drop[f] = 1;
    std::vector<std::vector<std::size_t>> kept;
    kept.reserve(faces.size());
    for (std::size_t f = 0; f < faces.size(); ++f)
      if (drop[f])
        ++rep.finTriangles;
      else
        kept.push_back(std::move(faces[f]));
    faces = std::move(kept);
  }
  PMP::repair_polygon_soup(points, faces);
  PMP::orient_polygon_soup(points, faces);
  SM<Inexact> sm;
  PMP::polygon_soup_to_polygon_mesh(points, faces, sm);
  // 3. Zero-area triangles with distinct vertices (exactly collinear after rounding):
  //    CGAL collapses or flips them away.
  const std::size_t before = sm.number_of_faces();
  PMP::remove_degenerate_faces(sm);
  sm.collect_garbage();
  rep.degenerateRemoved = before > sm.number_of_faces() ? before - sm.number_of_faces() : 0;
  TriMesh result = fromCgal<Inexact>(sm);
  if (report) *report = rep;
  return result;
}

TriMesh unionOf(const std::vector<TriMesh>& meshes, double weldMm, RepairReport* report) {
  if (meshes.empty()) return {};
  std::vector<SM<Exact>> level;
  level.reserve(meshes.size());
  for (const auto& m : meshes) level.push_back(toCgal<Exact>(m));
  // Balanced reduction: every mesh takes part in about log2(N) corefinements of similar
  // size, instead of N corefinements against one growing mesh.
  while (level.size() > 1) {
    std::vector<SM<Exact>> next;
    next.reserve((level.size() + 1) / 2);
    for (std::size_t i = 0; i + 1 < level.size(); i += 2) {
      SM<Exact> out;
      if (!PMP::corefine_and_compute_union(level[i], level[i + 1], out))
        throw InternalError("CGAL corefinement union failed (non-manifold result)");
      next.push_back(std::move(out));
    }
    if (level.size() % 2) next.push_back(std::move(level.back()));
    level = std::move(next);
  }
  return weldAndRepair(fromCgal<Exact>(level[0]), weldMm, report);
}

TriMesh clipByPlane(const TriMesh& mesh, const Vec3& p, const Vec3& n) {
  SM<Exact> m = toCgal<Exact>(mesh);
  const Exact::Plane_3 plane(Exact::Point_3(p.x(), p.y(), p.z()),
                             Exact::Vector_3(n.x(), n.y(), n.z()));
  if (!PMP::clip(m, plane, PMP::parameters::clip_volume(true)))
    throw InternalError("CGAL plane clip failed");
  return fromCgal<Exact>(m);
}

bool meshesIntersect(const TriMesh& a, const TriMesh& b) {
  const SM<Inexact> ca = toCgal<Inexact>(a), cb = toCgal<Inexact>(b);
  return PMP::do_intersect(ca, cb, PMP::parameters::do_overlap_test_of_bounded_sides(true),
                           PMP::parameters::all_default());
}

bool selfIntersects(const TriMesh& mesh) { return PMP::does_self_intersect(toCgal<Inexact>(mesh)); }

}  // namespace voxpack::exporter
