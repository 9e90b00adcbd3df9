#pragma once
/// \file cgal_ops.hpp
/// Polygon-mesh booleans and checks (CGAL Polygon Mesh Processing, kept PRIVATE here).

#include <cstddef>
#include <vector>

#include "voxpack/export/trimesh.hpp"

namespace voxpack::exporter {

/// What weldAndRepair changed.
struct RepairReport {
  std::size_t verticesIn = 0;          ///< vertices before
  std::size_t trianglesIn = 0;         ///< triangles before
  std::size_t weldedVertices = 0;      ///< vertices merged into an earlier one
  std::size_t collapsedTriangles = 0;  ///< triangles with two vertices welded (dropped)
  std::size_t finTriangles = 0;        ///< coincident triangles (zero-volume fins, dropped)
  std::size_t degenerateRemoved = 0;   ///< zero-area triangles CGAL collapsed or flipped away
};

/// Welds vertices closer than `weldMm` (the first in index order stays), drops triangles
/// the weld collapses and coincident pairs, splits non-manifold vertices, re-orients, and
/// removes exactly degenerate triangles (CGAL). For the rounded output of exact booleans:
/// intersection points closer than a reader's resolution would otherwise fold slivers.
TriMesh weldAndRepair(const TriMesh& mesh, double weldMm, RepairReport* report = nullptr);

/// The union of closed meshes (CGAL corefinement with exact constructions, reduced as a
/// balanced tree), rounded to double and passed through weldAndRepair(weldMm). Throws
/// InternalError when CGAL cannot build it.
TriMesh unionOf(const std::vector<TriMesh>& meshes, double weldMm = 0.0,
                RepairReport* report = nullptr);

/// `mesh` clipped by the plane through `pointMm` with unit `normal`, keeping the side
/// normal . (x - point) <= 0 and closing the cut (a flat cap). Closed input -> closed output.
TriMesh clipByPlane(const TriMesh& mesh, const Vec3& pointMm, const Vec3& normal);

/// True when the two meshes' surfaces intersect or one lies inside the other (CGAL).
bool meshesIntersect(const TriMesh& a, const TriMesh& b);

/// True when some two triangles of `mesh` intersect (CGAL).
bool selfIntersects(const TriMesh& mesh);

}  // namespace voxpack::exporter
