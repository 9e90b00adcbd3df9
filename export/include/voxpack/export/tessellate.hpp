#pragma once
/// \file tessellate.hpp
/// Closed triangle meshes of the exact shapes and containers, to a chord tolerance.

#include <string>

#include "voxpack/core/bed.hpp"
#include "voxpack/export/trimesh.hpp"

namespace voxpack::exporter {

/// Segments of a polygon approximating a circle of `radiusMm` whose inscribed chords
/// deviate at most `toleranceMm` (sagitta r (1 - cos(pi/n)) <= tol); at least 8.
int circleSegments(double radiusMm, double toleranceMm);

/// The closed mesh of a shape SPEC in its body frame (centre of mass at the origin, as
/// packer::parseShape). Curved parts are polygons of circleSegments(); the mesh is then
/// scaled about the origin (in the plane for prisms, in 3-D for spheres/ellipsoids) so
/// its enclosed volume equals the exact volume: the vertices lie just outside, the chord
/// midpoints just inside the exact surface, both within the tolerance. Mesh shapes are
/// the STL's triangles, scaled and centred. Throws InputError/IoError as parseShape.
/// `matchVolume = false` skips the final scale: the raw inscribed polygon mesh (tests).
TriMesh tessellateShape(const std::string& spec, double toleranceMm, bool matchVolume = true);

/// The closed mesh of a container SPEC (cylinder, box, mesh) in world mm, outward normals.
/// Cylinder walls are circumscribed polygons, so the wall mesh never cuts into a particle
/// that touches the exact wall. Returns an empty mesh for `mask:` containers (no surface).
TriMesh tessellateContainer(const std::string& spec, double toleranceMm);

/// `body` scaled by `scale` about the body origin, rotated by `q` and moved to `centreMm`.
TriMesh posed(const TriMesh& body, const Vec3& centreMm, const Quat& q, double scale = 1.0);

}  // namespace voxpack::exporter
