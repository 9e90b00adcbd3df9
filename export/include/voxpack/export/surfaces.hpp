#pragma once
/// \file surfaces.hpp
/// Surface exports of a bed (`voxpack export --format stl|obj`): the exact particle
/// surfaces with contact treatment and the container wall, or a smoothed iso-surface of
/// an imaged bed's indicator.

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "voxpack/core/bed.hpp"
#include "voxpack/core/progress.hpp"
#include "voxpack/export/contacts.hpp"
#include "voxpack/export/trimesh.hpp"

namespace voxpack::exporter {

/// Contact treatment of touching particles (meshing needs the point contacts removed).
enum class ContactTreatment {
  None,     ///< exact surfaces, touching at points
  Gap,      ///< every particle shrunk about its centre by (1 - size)
  Overlap,  ///< every particle grown by (1 + size); the bed is written as one union solid
  Bridge,   ///< a cylinder of diameter size*d across each contact; one union solid
  Cap       ///< each particle cut flat at each contact (flat of diameter size*d on a sphere)
};

/// Parses "none" | "gap" | "overlap" | "bridge" | "cap"; UsageError otherwise.
ContactTreatment parseContactTreatment(const std::string& name);

/// Options of particleSurfaces.
struct SurfaceOptions {
  double toleranceMm = 0.0;  ///< chord tolerance; 0 = d / 500 (d of the largest shape)
  ContactTreatment contacts = ContactTreatment::None;  ///< contact treatment
  double contactSize = -1.0;       ///< in units of d; < 0 = default (gap/overlap 0.01,
                                   ///< bridge 0.2, cap 0.2)
  double contactToleranceMm = -1;  ///< gap counted as contact; < 0 = the largest voxel size
  bool wall = true;                ///< write the container wall as its own solid
  WallContacts wallContacts = WallContacts::All;  ///< wall parts that take contacts
  double weldMm = -1;  ///< bridge/overlap union weld distance; < 0 = max(1e-3 tol, 1e-6 extent)
  int threads = 1;     ///< worker threads
};

/// The solids and what was done.
struct SurfaceResult {
  std::vector<NamedMesh> solids;  ///< particle_N ... (or bed), then wall
  nlohmann::json report;          ///< counts, sizes, tolerances (for the command's JSON)
};

/// The particle surfaces of a packed bed (needs the particle table). Throws InputError
/// when the bed has no particles.
SurfaceResult particleSurfaces(const Bed& bed, const SurfaceOptions& options,
                               Progress& progress = nullProgress());

/// Options of indicatorSurface.
struct IsoSurfaceOptions {
  double smoothingVoxels = 1.0;  ///< Gaussian sigma (voxels) applied to the solid fraction
  int taubinIterations = 10;     ///< Taubin (lambda|mu) smoothing passes (no shrinkage)
  int threads = 1;               ///< worker threads
};

/// A closed iso-surface (level 0.5) of the smoothed solid field of an imaged bed, by
/// marching tetrahedra on the voxel centres (the lattice is padded with void so the surface
/// closes), inside the mask when present. One solid "bed".
SurfaceResult indicatorSurface(const Bed& bed, const IsoSurfaceOptions& options,
                               Progress& progress = nullProgress());

}  // namespace voxpack::exporter
