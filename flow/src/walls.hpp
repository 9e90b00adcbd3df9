#pragma once
// Interpolated walls from a bed's exact geometry (`voxpack flow --walls interpolated`):
// the signed distance of the particle table's shapes and of the container, in voxels at
// the cell centres of the solver lattice (LbmDomain::signedDistance), computed in a band
// around the fluid/solid interface with a cell list over the particles (docs/flow.md).
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "voxpack/core/bed.hpp"
#include "voxpack/flow/lbm.hpp"

namespace voxpack::flow::detail {

/// How the solver lattice maps onto the bed (the sample) along the flow axis.
struct DomainMap {
  int axis = 0;                   ///< flow axis in array order
  std::int64_t sampleStart = 0;   ///< reservoir layers before the sample (Reservoirs)
  std::int64_t sampleLength = 0;  ///< sample layers along the axis
  bool reservoirs = false;        ///< fluid layers before and after the sample
  bool mirror = false;            ///< the sample followed by its mirror image
  bool periodic = false;          ///< --periodic: every axis wraps (particle images)
};

/// What the distance was built from (FLOW.json "wall_geometry").
struct WallReport {
  std::size_t particles = 0;       ///< rows of the particle table
  std::size_t particlesExact = 0;  ///< with a closed-form distance (sphere, cylinder, ring, box)
  std::map<std::string, std::size_t> halfwayShapes;  ///< shape -> particles kept halfway
  std::string container;           ///< the container spec of the provenance, "" when none
  std::string containerWalls;      ///< "interpolated" or "halfway (why)"
  std::size_t distanceCells = 0;   ///< cells whose distance was computed (the band)
  std::size_t imageParticles = 0;  ///< periodic images added (--periodic)
  double seconds = 0;              ///< wall time of the distance
  /// Particles kept halfway (no closed form).
  std::size_t particlesHalfway() const {
    std::size_t n = 0;
    for (const auto& [s, c] : halfwayShapes) n += c;
    return n;
  }
};

/// Bytes of the distance field per box cell (float).
inline constexpr std::uint64_t kDistanceBytesPerCell = sizeof(float);
/// Bytes of one exact wall cut (LbmDomain::wallCuts) per interpolated link.
inline constexpr std::uint64_t kWallCutBytes = sizeof(WallCut);

/// Links from a fluid cell to a solid cell of `domain` (the solver's own count of wall
/// links that may become interpolated), for the memory estimate.
std::uint64_t countWallLinks(const LbmDomain& domain, int threads);

/// Fills domain.signedDistance (box cells, > 0 in fluid, voxels) and domain.wallCuts (the
/// exact cut of each link the solver interpolates) from the particle table and the
/// container of `bed`'s provenance. Cells within one D3Q19 link of a fluid/solid
/// interface get min(container, particles) evaluated at their centre; every other cell
/// +-3 by its flag. Solid cells no exact surface describes get a positive value, so the
/// solver keeps halfway bounce-back there.
WallReport buildWallDistance(const Bed& bed, const DomainMap& map, LbmDomain& domain, int threads);

/// Signed distance (mm, < 0 inside) of a shape spec at a body-frame point, when the shape
/// has a closed form (sphere, cylinder, ring, box); false otherwise. For tests.
bool shapeSignedDistanceMm(const std::string& spec, const Vec3& bodyMm, double& out);

}  // namespace voxpack::flow::detail
