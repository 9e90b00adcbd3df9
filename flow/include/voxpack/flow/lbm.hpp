#pragma once
/// \file lbm.hpp
/// D3Q19 two-relaxation-time lattice Boltzmann solver for Stokes flow driven by a body
/// force, on fluid cells only (indirect addressing). Derivations: docs/flow.md.

#include <array>
#include <cstdint>
#include <vector>

#include "voxpack/core/memory.hpp"
#include "voxpack/core/progress.hpp"

namespace voxpack::flow {

/// How a solver run ended.
enum class FlowStatus {
  Converged,     ///< the mean velocity changed by less than the tolerance per check
  NotConverged,  ///< reached maxSteps first (the residual says how far it was)
  Blocked        ///< no fluid path along the flow axis: nothing was run
};

/// Text of a status: "converged", "not_converged", "blocked".
const char* statusName(FlowStatus s);

/// Floating-point type of the stored populations.
enum class Precision {
  Float,  ///< float32 populations (deviation from rest equilibrium) and collision; double sums
  Double  ///< float64 populations (the reference the float results are measured against)
};

/// How the populations stream from one step to the next (docs/flow.md, "AA or two lattices").
enum class Streaming {
  Auto,       ///< AA when there is no interpolated wall link, else two lattices
  AA,         ///< one lattice updated in place (Bailey et al. 2009): half the memory and traffic
  TwoLattice  ///< pull from one lattice into a second (needed by interpolated walls)
};

/// Text of a streaming scheme: "auto", "aa", "two_lattice".
const char* streamingName(Streaming s);

/// Where the link from fluid cell `cell` (C-order offset) along D3Q19 velocity `direction`
/// (towards the solid neighbour) meets the wall: at `q` of its length, in (0, 1].
struct WallCut {
  std::uint64_t cell = 0;       ///< C-order offset of the fluid cell in the box
  std::uint32_t direction = 0;  ///< D3Q19 velocity index pointing from the fluid into the solid
  float q = 0.5f;               ///< wall position along the link, in link lengths
  /// Order of the list (cell, then direction).
  bool operator<(const WallCut& o) const {
    return cell != o.cell ? cell < o.cell : direction < o.direction;
  }
};

/// The lattice the solver runs on: a box of cells in C order (z, y, x), fluid or solid.
struct LbmDomain {
  std::array<std::int64_t, 3> dims{0, 0, 0};  ///< (nz, ny, nx) cells
  std::vector<std::uint8_t> fluid;            ///< 1 = fluid, 0 = solid (bounce-back), C order
  /// 1 = cell is in the measured sample (body force acts, averages count it); empty = all.
  std::vector<std::uint8_t> sample;
  std::array<bool, 3> periodic{true, true, true};  ///< per axis (z, y, x); false = wall
  /// Optional signed distance to the wall at each cell centre (voxels; > 0 in fluid,
  /// <= 0 in solid), C order. When given, a link from a fluid cell into a solid cell
  /// cuts the wall at q = phi_f / (phi_f - phi_s) of its length and the solver uses
  /// Bouzidi's linear interpolated bounce-back there instead of halfway bounce-back
  /// (docs/flow.md); links leaving a wall-bounded box face stay halfway. Empty = halfway.
  std::vector<float> signedDistance;
  /// Optional exact wall cuts, sorted by (cell, direction): where a link has one, its q
  /// replaces the ratio of the two centre distances above, which is exact at a plane but
  /// not at an edge, where the distance outside is rounded (docs/flow.md).
  std::vector<WallCut> wallCuts;
};

/// Solver settings (lattice units: spacing 1, time step 1, rest density 1).
struct LbmOptions {
  int axis = 0;                      ///< flow axis in array order: 0 = z, 1 = y, 2 = x
  double tauPlus = 1.0;              ///< symmetric relaxation time (> 0.5): viscosity (tau-1/2)/3
  double magic = 3.0 / 16.0;         ///< TRT Lambda = (tau+ - 1/2)(tau- - 1/2)
  double force = 1e-5;               ///< body force per unit volume along the axis (lattice units)
  double tolerance = 1e-5;           ///< stop when |du|/|u| per check interval is below this
  std::int64_t maxSteps = 200000;    ///< stop here at the latest
  std::int64_t checkInterval = 100;  ///< steps between convergence checks (>= 1)
  std::int64_t minSteps = 0;         ///< never stop before this many steps
  Precision precision = Precision::Float;  ///< stored population type
  int threads = 1;                         ///< OpenMP threads (results are identical for any count)
  /// Streaming scheme; AA and two lattices give the same bits (a test checks it).
  Streaming streaming = Streaming::Auto;
  /// With interpolated walls, restore the initial mass at every check by a uniform rest
  /// density (Bouzidi's links do not conserve mass); halfway walls conserve it and are untouched.
  bool massCorrection = true;
};

/// Macroscopic fields on the fluid cells, in cell order (see LbmResult::cellOffset).
struct LbmFields {
  std::vector<float> density;                  ///< rho - 1 per fluid cell
  std::array<std::vector<float>, 3> velocity;  ///< (uz, uy, ux) per fluid cell
};

/// Result of a run (lattice units).
struct LbmResult {
  FlowStatus status = FlowStatus::NotConverged;  ///< how the run ended
  std::int64_t steps = 0;                        ///< time steps done
  double residual = 0.0;         ///< last relative change of the mean axial velocity
  double meanAxialVelocity = 0;  ///< sum of u_axis over sample fluid cells / sample cells
  double sumAxialVelocity = 0;   ///< sum of u_axis over sample fluid cells
  double sumSpeed = 0;           ///< sum of |u| over sample fluid cells
  double massInitial = 0;        ///< sum of rho over all fluid cells at the start
  double massFinal = 0;          ///< sum of rho over all fluid cells at the end
  double massAdded = 0;  ///< mass the correction put back in total (LbmOptions::massCorrection)
  bool massCorrected = false;         ///< the correction ran (interpolated links and the option)
  std::size_t fluidCells = 0;         ///< cells updated per step
  std::size_t sampleFluidCells = 0;   ///< fluid cells in the sample
  std::size_t interpolatedLinks = 0;  ///< wall links with interpolated bounce-back
  int threads = 1;  ///< threads the kernel ran on (<= options; >= 8 blocks of 4096 cells each)
  Streaming streaming = Streaming::AA;    ///< the scheme that ran (never Auto)
  double wallS = 0;                       ///< wall time of the time loop
  double mlups = 0;                       ///< million fluid-cell updates per second
  std::vector<std::uint64_t> cellOffset;  ///< C-order offset of each fluid cell in the box
  LbmFields fields;                       ///< final density and velocity (cell order)
  std::vector<std::pair<std::int64_t, double>> history;  ///< (step, mean axial velocity)
};

/// Bytes the solver needs for `boxCells` cells of which `fluidCells` are fluid, with
/// `wallLinks` interpolated wall links (LbmDomain::signedDistance) and `streaming`.
std::uint64_t estimateLbmBytes(std::uint64_t boxCells, std::uint64_t fluidCells,
                               Precision precision, std::uint64_t wallLinks = 0,
                               Streaming streaming = Streaming::Auto);

/// The scheme `requested` resolves to for a run with `wallLinks` interpolated links.
/// Throws InputError for AA with interpolated links.
Streaming resolveStreaming(Streaming requested, std::uint64_t wallLinks);

/// Runs the solver to convergence or maxSteps. Throws InputError (no fluid cell, bad
/// options), ResourceError (over `budget`), Cancelled (progress asked to stop).
LbmResult runLbm(const LbmDomain& domain, const LbmOptions& options,
                 const MemoryBudget& budget = {}, Progress& progress = nullProgress());

/// True when a fluid path (18-neighbour links, as the D3Q19 streaming sees them) joins
/// the first and the last layer of `domain` along `axis` without wrapping along it.
bool percolates(const LbmDomain& domain, int axis);

/// Kinematic viscosity (tau+ - 1/2)/3 of the lattice.
inline double latticeViscosity(double tauPlus) { return (tauPlus - 0.5) / 3.0; }

}  // namespace voxpack::flow
