// CGAL Polygon Mesh Processing behind plain TriMesh types. Booleans and clipping use exact
// constructions (Epeck): chained corefinements with rounded constructions can create
// self-intersections that make the next one fail; the checks use exact predicates only.
#include "voxpack/export/cgal_ops.hpp"

#include <CGAL/Exact_predicates_exact_constructions_kernel.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/clip.h>
#include <CGAL/Polygon_mesh_processing/corefinement.h>
#include <CGAL/Polygon_mesh_processing/intersection.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Surface_mesh.h>

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
    out.vertices.emplace_back(CGAL::to_double(p.x()), CGAL::to_double(p.y()),
                              CGAL::to_double(p.z()));
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

TriMesh unionOf(const std::vector<TriMesh>& meshes) {
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
  return fromCgal<Exact>(level[0]);
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
