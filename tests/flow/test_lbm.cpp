// The solver against analytic Stokes flows (slit, tube), Zick & Homsy's simple-cubic
// sphere arrays, mass conservation, thread invariance and the statuses.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <numbers>

#include "flow_fixtures.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/flow/lbm.hpp"

namespace voxpack::flow {
namespace {

using test::slitDomain;
using test::tubeDomain;

LbmOptions converging(double tau = 1.0) {
  LbmOptions o;
  o.axis = 0;
  o.tauPlus = tau;
  o.force = 1e-6;
  o.tolerance = 1e-7;
  o.checkInterval = 50;
  o.maxSteps = 100000;
  return o;
}

// Plane Poiseuille: u(y) = F (y + 1/2)(W - y - 1/2) / (2 nu) with the walls halfway
// between the last fluid cell and the first wall cell; mean F W^2 / (12 nu).
TEST(FlowLbm, SlitMatchesPoiseuilleProfileAndFlux) {
  const std::int64_t w = 20;
  for (double tau : {0.8, 1.0, 2.0}) {
    const LbmOptions o = converging(tau);
    const LbmResult r = runLbm(slitDomain(w), o);
    ASSERT_EQ(r.status, FlowStatus::Converged) << tau;
    const double nu = latticeViscosity(tau);
    // The mean of the nodal values of the parabola: F (W^2 + 1/2) / (12 nu) (midpoint
    // sum of a quadratic), i.e. the continuous F W^2 / (12 nu) plus 1/(2 W^2).
    const double meanExact = o.force * (static_cast<double>(w * w) + 0.5) / (12.0 * nu);
    // TRT with Lambda = 3/16 puts the wall exactly halfway: the parabola is exact, so
    // the 1 % the issue asks for is met with room (float storage, convergence 1e-7).
    EXPECT_NEAR(r.meanAxialVelocity / meanExact, 1.0, 1e-4) << tau;
    double umax = 0, err = 0;
    for (std::int64_t j = 0; j < w; ++j) {
      const double y = static_cast<double>(j) + 0.5;
      const double exact = o.force * y * (static_cast<double>(w) - y) / (2.0 * nu);
      umax = std::max(umax, exact);
      err = std::max(err, std::abs(r.fields.velocity[0][static_cast<std::size_t>(j)] - exact));
    }
    EXPECT_LT(err / umax, 1e-2) << tau;
  }
}

// Permeability does not depend on the viscosity chosen (the point of TRT's magic 3/16).
TEST(FlowLbm, SlitPermeabilityIndependentOfTau) {
  double k08 = 0, k3 = 0;
  for (double tau : {0.8, 3.0}) {
    const LbmOptions o = converging(tau);
    const LbmResult r = runLbm(slitDomain(8), o);
    const double k = latticeViscosity(tau) * r.meanAxialVelocity / o.force;
    (tau < 1 ? k08 : k3) = k;
  }
  EXPECT_NEAR(k3 / k08, 1.0, 1e-3);
}

// Hagen-Poiseuille in a digitised tube of 20 voxels across: flux F A^2 / (8 pi nu) with
// A the digitised cross-section (the staircase wall's equivalent circle). Halfway
// bounce-back on a staircase is the limit here: measured 1.6-2.7 % low at 20-21 voxels
// across depending on how the circle falls on the lattice (docs/flow.md), so 3 %.
TEST(FlowLbm, TubeMatchesHagenPoiseuille) {
  const LbmDomain d = tubeDomain(22, 10.0);
  const LbmOptions o = converging(1.0);
  const LbmResult r = runLbm(d, o);
  ASSERT_EQ(r.status, FlowStatus::Converged);
  const double area = static_cast<double>(r.fluidCells);
  const double nu = latticeViscosity(o.tauPlus);
  const double fluxExact = o.force * area * area / (8.0 * std::numbers::pi * nu);
  EXPECT_NEAR(r.sumAxialVelocity / fluxExact, 1.0, 3e-2);
  // Profile: u(r) = F (R^2 - r^2) / (4 nu), R^2 = A / pi; within 5 % of the peak (the
  // staircase moves the wall locally by up to half a voxel).
  const double r2 = area / std::numbers::pi, umax = o.force * r2 / (4.0 * nu);
  const double c = 0.5 * 21.0;
  double err = 0;
  for (std::size_t cell = 0; cell < r.fluidCells; ++cell) {
    const double j = static_cast<double>(r.cellOffset[cell] / 22),
                 i = static_cast<double>(r.cellOffset[cell] % 22);
    const double rr = (j - c) * (j - c) + (i - c) * (i - c);
    err = std::max(err, std::abs(r.fields.velocity[0][cell] - o.force * (r2 - rr) / (4.0 * nu)));
  }
  EXPECT_LT(err / umax, 5e-2);
}

// A random porous box: mass is conserved by bounce-back and by the forcing, and the
// result is bitwise the same on 1 and 2 threads.
LbmDomain randomDomain() {
  LbmDomain d;
  d.dims = {16, 12, 12};
  d.fluid.resize(16 * 12 * 12);
  std::uint32_t s = 12345;
  for (auto& f : d.fluid) {
    s = s * 1664525u + 1013904223u;
    f = (s >> 24) % 10 < 7 ? 1 : 0;  // 70 % fluid
  }
  d.periodic = {true, false, true};
  return d;
}

TEST(FlowLbm, MassIsConserved) {
  LbmOptions o = converging(1.0);
  o.maxSteps = 400;
  o.force = 1e-4;
  for (Precision p : {Precision::Float, Precision::Double}) {
    o.precision = p;
    const LbmResult r = runLbm(randomDomain(), o);
    EXPECT_GT(std::abs(r.meanAxialVelocity), 0.0);
    // Float: each stored deviation (~1e-4) rounds at ~1e-11; summed over 1e6 updates
    // the drift stays far below 1e-9 of the mass (2300 cells, 400 steps). Double: round-off only.
    EXPECT_LT(std::abs(r.massFinal - r.massInitial) / r.massInitial,
              p == Precision::Float ? 1e-9 : 1e-13);
  }
}

TEST(FlowLbm, OneAndTwoThreadsGiveIdenticalBits) {
  LbmOptions o = converging(1.0);
  o.maxSteps = 300;
  o.threads = 1;
  const LbmResult a = runLbm(randomDomain(), o);
  o.threads = 2;
  const LbmResult b = runLbm(randomDomain(), o);
  ASSERT_EQ(a.fluidCells, b.fluidCells);
  EXPECT_EQ(a.steps, b.steps);
  EXPECT_EQ(a.sumAxialVelocity, b.sumAxialVelocity);
  EXPECT_EQ(a.residual, b.residual);
  for (int d = 0; d < 3; ++d)
    EXPECT_EQ(0, std::memcmp(a.fields.velocity[d].data(), b.fields.velocity[d].data(),
                             a.fluidCells * sizeof(float)));
}

TEST(FlowLbm, NotConvergedReportsResidual) {
  LbmOptions o = converging(1.0);
  o.maxSteps = 40;
  o.checkInterval = 10;
  const LbmResult r = runLbm(slitDomain(20), o);
  EXPECT_EQ(r.status, FlowStatus::NotConverged);
  EXPECT_EQ(r.steps, 40);
  EXPECT_GT(r.residual, o.tolerance);
  EXPECT_TRUE(std::isfinite(r.residual));
}

TEST(FlowLbm, RefusesAllSolidAndBadOptions) {
  LbmDomain d = slitDomain(4);
  std::fill(d.fluid.begin(), d.fluid.end(), 0);
  EXPECT_THROW(runLbm(d, converging()), InputError);
  LbmOptions o = converging();
  o.tauPlus = 0.5;
  EXPECT_THROW(runLbm(slitDomain(4), o), InputError);
  MemoryBudget tiny{1000};
  EXPECT_THROW(runLbm(slitDomain(64), converging(), tiny), ResourceError);
}

TEST(FlowLbm, PercolationAlongTheAxis) {
  LbmDomain d;
  d.dims = {6, 4, 4};
  d.fluid.assign(96, 1);
  d.periodic = {false, false, false};
  EXPECT_TRUE(percolates(d, 0));
  for (int c = 0; c < 16; ++c) d.fluid[3 * 16 + static_cast<std::size_t>(c)] = 0;  // layer 3
  EXPECT_FALSE(percolates(d, 0));
  EXPECT_TRUE(percolates(d, 1));
  // One hole joined by an edge (D3Q19 link) is a path.
  d.fluid[3 * 16 + 5] = 1;
  EXPECT_TRUE(percolates(d, 0));
}

}  // namespace
}  // namespace voxpack::flow
