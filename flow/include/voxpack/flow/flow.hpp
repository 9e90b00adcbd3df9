#pragma once
/// \file flow.hpp
/// Permeability, pressure drop and hydraulic tortuosity of a bed by lattice Boltzmann:
/// builds the lattice from the bed (walls, reservoirs or mirror), runs the solver and
/// reports physical numbers with the packed-bed correlations beside them (docs/flow.md).

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "voxpack/core/bed.hpp"
#include "voxpack/flow/lbm.hpp"

namespace voxpack::flow {

/// How the ends of the sample along the flow axis are closed.
enum class Inflow {
  Reservoirs,  ///< fluid layers before and after the sample, periodic through them
  Mirror       ///< the sample followed by its mirror image, periodic along the axis
};

/// The walls the solver sees.
enum class Walls {
  Halfway,      ///< halfway bounce-back on the voxels (the staircase)
  Interpolated  ///< Bouzidi links cut at the exact surfaces of the particle table and container
};

/// Options of computeFlow.
struct FlowOptions {
  int axis = 0;           ///< flow axis in array order: 0 = z, 1 = y, 2 = x
  bool periodic = false;  ///< every axis periodic (unit cells); else walls across the flow
  Inflow inflow = Inflow::Reservoirs;  ///< ends along the axis when not periodic
  int reservoirLayers = 0;  ///< fluid layers at each end (Reservoirs): 0 = 0.6 d (>= 4), else >= 2
  LbmOptions lbm;           ///< solver settings (axis and force are set by computeFlow)
  double latticeVelocity = 1e-3;  ///< target mean pore velocity (lattice units) for the force
  double velocityMmS = 1.0;       ///< superficial velocity for the pressure-gradient block
  double viscosityPaS = 1.0e-3;   ///< fluid dynamic viscosity (water at 20 C)
  double densityKgM3 = 998.0;     ///< fluid density (water at 20 C)
  double particleDiameterMm = 0;  ///< d for the correlations; 0 = 6(1-eps)/S_v (Sauter)
  /// Interpolated: the signed distance of the particle table's shapes with a closed form
  /// (sphere, cylinder, ring, box) and of a cylinder or box container (provenance
  /// scene.container) sets the wall cut of each link; other surfaces stay halfway.
  Walls walls = Walls::Halfway;
};

/// The result of computeFlow: the JSON record and the solver state for field output.
struct FlowReport {
  nlohmann::json json;           ///< every FLOW.json key (docs/flow.md)
  LbmResult lbm;                 ///< solver result (fields on fluid cells, cell offsets)
  LbmDomain domain;              ///< the lattice the solver ran on (fluid flags only kept)
  std::int64_t sampleStart = 0;  ///< first layer of the sample along the axis in domain
  double velocityScale = 0;      ///< mm/s per lattice velocity unit at --velocity-mm-s
  double pressureScale = 0;      ///< Pa per lattice pressure unit at --velocity-mm-s
};

/// Runs the flow analysis of `bed` (void inside the mask is fluid). Throws InputError
/// (all solid, anisotropic voxels, bad options), ResourceError (over `budget`).
/// A bed without a fluid path along the axis returns status "blocked" without running.
FlowReport computeFlow(const Bed& bed, const FlowOptions& options, const MemoryBudget& budget,
                       Progress& progress = nullProgress());

/// Writes `bed` plus /velocity (nz, ny, nx, 3: x, y, z components, mm/s) and /pressure
/// (nz, ny, nx, Pa, reduced pressure incl. the driving gradient) as an HDF5 bed file,
/// and an XDMF file beside it (same stem, .xdmf) that ParaView opens.
void writeFlowField(const std::filesystem::path& path, const Bed& bed, const FlowReport& report);

/// Writes radial_profile.csv and convergence.csv of a FLOW.json record into `dir`.
void writeFlowCsv(const nlohmann::json& flow, const std::filesystem::path& dir);

/// Specific surface (interface area per volume inside the mask, 1/mm) from the
/// crossing counts along the 13 lattice directions (Cauchy-Crofton): unbiased for
/// isotropic structures, unlike the voxel-face count (+50 %). `periodic`: pairs wrap.
double specificSurfaceMmInv(const Bed& bed, bool periodic = false);

/// Parses "Z0:Z1" (mm); throws UsageError.
std::pair<double, double> parseRoiMm(const std::string& text);

/// The layers of `bed` whose centre z lies in [z0, z1] mm (indicator and mask; labels and
/// particle table dropped). Throws InputError when no layer is selected.
Bed cropBedZ(const Bed& bed, double z0Mm, double z1Mm);

/// Packed-bed correlations (SI units in, SI out) used beside the simulation.
struct Correlations {
  /// Ergun pressure gradient (Pa/m) at superficial velocity u (m/s).
  static double ergun(double eps, double dM, double muPaS, double rhoKgM3, double uMS);
  /// Eisfeld-Schnitzlein (2001) pressure gradient (Pa/m); columnM <= 0: no wall term.
  static double eisfeldSchnitzlein(double eps, double dM, double columnM, double muPaS,
                                   double rhoKgM3, double uMS);
  /// Kozeny-Carman permeability eps^3 d^2 / (C (1-eps)^2).
  static double kozenyCarman(double eps, double d, double c = 180.0);
  /// Stokes limit of Eisfeld-Schnitzlein: eps^3 d^2 / (K1 A_w^2 (1-eps)^2).
  static double eisfeldSchnitzleinPermeability(double eps, double d, double column);
};

}  // namespace voxpack::flow
