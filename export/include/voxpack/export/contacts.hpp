#pragma once
/// \file contacts.hpp
/// Particle-particle and particle-wall contacts of a packed bed from the exact signed
/// distances of the shapes at their poses.

#include <cstdint>
#include <memory>
#include <vector>

#include "voxpack/core/bed.hpp"
#include "voxpack/export/trimesh.hpp"
#include "voxpack/packer/container.hpp"
#include "voxpack/packer/shape.hpp"

namespace voxpack::exporter {

/// Which part of the container wall a wall contact touches. A particle gets at most one
/// contact per part, so a particle in the corner of floor and round wall gets both.
enum class WallPart : std::uint8_t {
  None,   ///< not a wall contact (particle pair)
  Side,   ///< the round wall of a cylinder, or one of the four vertical faces of a box
  Floor,  ///< the bottom (z = min)
  Lid,    ///< the top (z = max)
  Whole   ///< a container without planar parts (mesh): its nearest wall point
};

/// Which wall parts take contacts.
enum class WallContacts {
  All,   ///< side, floor and lid
  Side,  ///< the side wall only (open-ended columns for CFD: inlet and outlet are not walls)
  None   ///< no wall contacts
};

/// Parses "all" | "side" | "none"; UsageError otherwise.
WallContacts parseWallContacts(const std::string& name);

/// One contact (or near contact within the tolerance).
struct Contact {
  std::int64_t a = 0;              ///< particle index (0-based)
  std::int64_t b = -1;             ///< other particle index, or -1 for the container wall
  WallPart wall = WallPart::None;  ///< the wall part when b == -1
  Vec3 pointMm = Vec3::Zero();     ///< midpoint of the closest pair of surface points
  Vec3 normal = Vec3::UnitZ();     ///< unit, from a towards b (towards the wall)
  double gapMm = 0;                ///< surface separation; < 0 when the exact shapes overlap
};

/// Options of findContacts.
struct ContactOptions {
  double toleranceMm = 0.0;  ///< a pair is in contact when its gap <= this (>= 0)
  int threads = 1;           ///< worker threads
  WallContacts wallContacts = WallContacts::All;  ///< which wall parts take contacts
};

/// The particles posed in world coordinates: shape, pose and a surface mesh whose vertices
/// seed the closest-point search.
struct PosedParticle {
  std::shared_ptr<const packer::Shape> shape;  ///< exact shape (body frame)
  Vec3 centreMm = Vec3::Zero();                ///< centre of mass (world)
  Quat orientation = Quat::Identity();         ///< body -> world
  TriMesh surface;                             ///< world-frame mesh of the exact surface
};

/// Exact signed distance (mm) of world point p to a posed particle (< 0 inside).
double signedDistanceMm(const PosedParticle& p, const Vec3& xMm);

/// Contacts among `particles` (pairs a < b, sorted) and with `wall` (may be null; one
/// contact per wall part: cylinders and boxes split into side, floor and lid): the
/// closest pair is seeded by the mesh vertex of one particle deepest in the other's exact
/// signed distance, then refined by alternating projections onto both exact surfaces.
std::vector<Contact> findContacts(const std::vector<PosedParticle>& particles,
                                  const packer::Container* wall, const ContactOptions& options);

}  // namespace voxpack::exporter
