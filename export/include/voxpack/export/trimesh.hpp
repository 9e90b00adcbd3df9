#pragma once
/// \file trimesh.hpp
/// An indexed triangle mesh (mm, double precision so that shared vertices stay shared
/// through transforms) and its STL / OBJ writers and STL reader.

#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "voxpack/core/lattice.hpp"

namespace voxpack::exporter {

/// Indexed triangles, counter-clockwise seen from outside.
struct TriMesh {
  std::vector<Vec3> vertices;                           ///< positions (x, y, z) mm
  std::vector<std::array<std::uint32_t, 3>> triangles;  ///< vertex indices
  /// Appends `other` (indices shifted).
  void append(const TriMesh& other);
};

/// A mesh with the name of its solid (STL `solid NAME`, OBJ `o NAME`).
struct NamedMesh {
  std::string name;  ///< solid name, no spaces
  TriMesh mesh;      ///< its triangles
};

/// Enclosed volume (mm^3): the sum of signed tetrahedra to the origin (divergence theorem).
double enclosedVolumeMm3(const TriMesh& mesh);

/// True when every undirected edge is used by exactly two triangles with opposite
/// orientations (closed, oriented, edge-manifold) and no triangle is degenerate by index.
bool isClosedManifold(const TriMesh& mesh);

/// Number of edge-connected components.
std::size_t connectedComponents(const TriMesh& mesh);

/// Reads an ASCII or binary STL and welds bit-identical vertices. Throws IoError /
/// FormatError naming the file.
TriMesh readStl(const std::filesystem::path& path);

/// Writes ASCII STL with one `solid NAME ... endsolid NAME` per mesh (snappyHexMesh reads
/// each as a region), `digits` significant digits (9 = float; 17 keeps every double, so
/// vertices of CGAL booleans that are closer than float resolution stay distinct). Atomic.
void writeStl(const std::vector<NamedMesh>& solids, const std::filesystem::path& out,
              int digits = 9);

/// Writes Wavefront OBJ with one `o NAME` object per mesh and shared vertices. Atomic.
void writeObj(const std::vector<NamedMesh>& solids, const std::filesystem::path& out,
              int digits = 9);

}  // namespace voxpack::exporter
