#pragma once
/// \file cgal_ops.hpp
/// Polygon-mesh booleans and checks (CGAL Polygon Mesh Processing, kept PRIVATE here).

#include <vector>

#include "voxpack/export/trimesh.hpp"

namespace voxpack::exporter {

/// The union of closed meshes (CGAL corefinement with exact constructions, reduced as a
/// balanced tree). Throws InternalError when CGAL cannot build it.
TriMesh unionOf(const std::vector<TriMesh>& meshes);

/// `mesh` clipped by the plane through `pointMm` with unit `normal`, keeping the side
/// normal . (x - point) <= 0 and closing the cut (a flat cap). Closed input -> closed output.
TriMesh clipByPlane(const TriMesh& mesh, const Vec3& pointMm, const Vec3& normal);

/// True when the two meshes' surfaces intersect or one lies inside the other (CGAL).
bool meshesIntersect(const TriMesh& a, const TriMesh& b);

/// True when some two triangles of `mesh` intersect (CGAL).
bool selfIntersects(const TriMesh& mesh);

}  // namespace voxpack::exporter
