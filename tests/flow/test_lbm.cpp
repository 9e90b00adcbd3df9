// The solver against analytic Stokes flows (slit, tube), Zick & Homsy's simple-cubic
// sphere arrays, mass conservation, thread invariance and the statuses.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
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

// Hagen-Poiseuille in a tube of radius R = 10 (20 voxels across) with the wall placed
// exactly by the signed distance (Bouzidi linear interpolated bounce-back): flux against
// the continuous F pi R^4 / (8 nu) within 1 % (the nodal sum of the exact parabola over
// the fluid cells differs from it by 0.04 %, so the quadrature is not what is measured),
// for centres on and off the lattice and for several tau (measured: -0.6 .. +0.05 % at
// tau 0.8-1, +0.8 .. +1.0 % at tau 2: the linear interpolation is not exactly
// viscosity-independent under TRT, unlike halfway bounce-back).
TEST(FlowLbm, TubeMatchesHagenPoiseuille) {
  for (const auto& [box, radius] :
       {std::pair<std::int64_t, double>{22, 10.0}, {23, 10.0}, {22, 9.7}}) {
    for (double tau : {0.8, 1.0, 2.0}) {
      const LbmDomain d = tubeDomain(box, radius, true);
      const LbmOptions o = converging(tau);
      const LbmResult r = runLbm(d, o);
      ASSERT_EQ(r.status, FlowStatus::Converged);
      EXPECT_GT(r.interpolatedLinks, 0u);
      const double nu = latticeViscosity(o.tauPlus);
      const double fluxExact = o.force * std::numbers::pi * std::pow(radius, 4) / (8.0 * nu);
      EXPECT_NEAR(r.sumAxialVelocity / fluxExact, 1.0, 1e-2)
          << "box " << box << " R " << radius << " tau " << tau;
      // Profile u(r) = F (R^2 - r^2) / (4 nu): every cell within 1 % of the peak for
      // tau <= 1; linear interpolation moves the effective wall with tau (measured 1.1-1.2 %
      // at tau 2, flux +0.9 %), so 1.5 % there.
      const double umax = o.force * radius * radius / (4.0 * nu);
      const double c = 0.5 * static_cast<double>(box - 1);
      double err = 0;
      for (std::size_t cell = 0; cell < r.fluidCells; ++cell) {
        const double j = static_cast<double>(r.cellOffset[cell] / static_cast<std::uint64_t>(box)),
                     i = static_cast<double>(r.cellOffset[cell] % static_cast<std::uint64_t>(box));
        const double rr = (j - c) * (j - c) + (i - c) * (i - c);
        err = std::max(err, std::abs(r.fields.velocity[0][cell] -
                                     o.force * (radius * radius - rr) / (4.0 * nu)));
      }
      EXPECT_LT(err / umax, tau <= 1.0 ? 1e-2 : 1.5e-2)
          << "box " << box << " R " << radius << " tau " << tau;
      std::printf("tube box %lld R %.1f tau %.1f: flux/exact %.5f, max profile error %.4f\n",
                  static_cast<long long>(box), radius, tau, r.sumAxialVelocity / fluxExact,
                  err / umax);
    }
  }
}

// The same tube with halfway bounce-back on the staircase: the wall is where the voxels
// put it, so the flux is measured against the staircase's equivalent circle (area A,
// F A^2 / (8 pi nu)) and is 2.7 % low at 20 voxels across (1.6-2.7 % depending on how the
// circle falls on the lattice, docs/flow.md); pinned here so a change shows.
TEST(FlowLbm, TubeHalfwayBounceBackStaircase) {
  const LbmDomain d = tubeDomain(22, 10.0);
  const LbmOptions o = converging(1.0);
  const LbmResult r = runLbm(d, o);
  ASSERT_EQ(r.status, FlowStatus::Converged);
  EXPECT_EQ(r.interpolatedLinks, 0u);
  const double area = static_cast<double>(r.fluidCells);
  const double nu = latticeViscosity(o.tauPlus);
  const double fluxExact = o.force * area * area / (8.0 * std::numbers::pi * nu);
  EXPECT_NEAR(r.sumAxialVelocity / fluxExact, 0.973, 5e-3);
}

// A random porous box: mass is conserved by bounce-back and by the forcing, and the
// result is bitwise the same on 1 and 2 threads.
LbmDomain randomDomain(std::int64_t n = 0) {
  LbmDomain d;
  d.dims = n > 0 ? std::array<std::int64_t, 3>{n, n, n} : std::array<std::int64_t, 3>{16, 12, 12};
  d.fluid.resize(static_cast<std::size_t>(d.dims[0] * d.dims[1] * d.dims[2]));
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

// Bouzidi's links leak mass (docs/flow.md); the correction puts it back at every check as a
// uniform rest density. Without it the mass of an SC cell drifts in 3000 steps;
// with it the mass is the initial one to round-off, the added mass is the drift it replaced,
// and the flux does not move beyond that share.
TEST(FlowLbm, MassCorrectionHoldsTheMassOfInterpolatedWalls) {
  LbmDomain d;
  const double dia = test::scUnitCellExact(0.343, 16.0, d);
  ASSERT_GT(dia, 15.0);
  LbmOptions o;
  o.tauPlus = 1.0;
  o.force = 1e-4;
  o.tolerance = 1e-300;  // every step: the drift grows with them
  o.maxSteps = 3000;
  o.checkInterval = 100;
  o.precision = Precision::Double;
  o.massCorrection = false;
  const LbmResult off = runLbm(d, o);
  o.massCorrection = true;
  const LbmResult on = runLbm(d, o);
  ASSERT_GT(off.interpolatedLinks, 0u);
  const double driftOff = (off.massFinal - off.massInitial) / off.massInitial;
  std::printf("drift off %.3e, on %.3e, added %.3e, u %.9e / %.9e\n", driftOff,
              (on.massFinal - on.massInitial) / on.massInitial, on.massAdded / on.massInitial,
              off.meanAxialVelocity, on.meanAxialVelocity);
  EXPECT_GT(std::abs(driftOff), 1e-6);
  EXPECT_EQ(off.massAdded, 0.0);
  EXPECT_LT(std::abs(on.massFinal - on.massInitial) / on.massInitial, 1e-12);
  // Put back, and in the direction the uncorrected run lost (the leak depends on the state,
  // so the two totals need not be equal).
  EXPECT_GT(on.massAdded * -driftOff, 0.0);
  // A lighter fluid under the same force per volume flows faster: uncorrected, the velocity
  // rises as the mass falls, one for one.
  EXPECT_NEAR(on.meanAxialVelocity / off.meanAxialVelocity, 1.0 + driftOff,
              0.3 * std::abs(driftOff));
  // Halfway walls conserve mass already: the correction leaves them alone, to the bit.
  LbmDomain h;
  double hDia = 0;
  test::scUnitCell(0.343, 16.0, h, &hDia);
  o.maxSteps = 300;
  const LbmResult hOn = runLbm(h, o);
  o.massCorrection = false;
  const LbmResult hOff = runLbm(h, o);
  EXPECT_EQ(hOn.massAdded, 0.0);
  EXPECT_EQ(hOn.meanAxialVelocity, hOff.meanAxialVelocity);
  EXPECT_EQ(hOn.massFinal, hOff.massFinal);
}

// 48^3 at 70 % fluid: 77000 cells, 19 blocks, so two threads are really used (the solver
// gives each thread at least 8 blocks).
TEST(FlowLbm, OneAndTwoThreadsGiveIdenticalBits) {
  LbmOptions o = converging(1.0);
  o.maxSteps = 60;
  o.checkInterval = 20;
  o.threads = 1;
  const LbmResult a = runLbm(randomDomain(48), o);
  o.threads = 2;
  const LbmResult b = runLbm(randomDomain(48), o);
  EXPECT_EQ(a.threads, 1);
  EXPECT_EQ(b.threads, 2);
  ASSERT_EQ(a.fluidCells, b.fluidCells);
  EXPECT_EQ(a.steps, b.steps);
  EXPECT_EQ(a.sumAxialVelocity, b.sumAxialVelocity);
  EXPECT_EQ(a.residual, b.residual);
  for (int d = 0; d < 3; ++d)
    EXPECT_EQ(0, std::memcmp(a.fields.velocity[d].data(), b.fields.velocity[d].data(),
                             a.fluidCells * sizeof(float)));
}

// AA streaming updates one lattice in place and gives every collision the values the pull
// from a second lattice gives it: the same bits, after an even and after an odd number of
// steps (the odd state is read back through the AA index), in both precisions, and on 1 and
// 2 threads. Walls across y and solid cells exercise both bounce-back paths.
TEST(FlowLbm, AaAndTwoLatticesGiveIdenticalBits) {
  const LbmDomain dom = randomDomain(48);
  for (Precision p : {Precision::Float, Precision::Double})
    for (std::int64_t steps : {60, 61}) {
      LbmOptions o = converging(1.0);
      o.force = 1e-4;
      o.precision = p;
      o.maxSteps = steps;
      o.checkInterval = 20;
      o.streaming = Streaming::TwoLattice;
      const LbmResult two = runLbm(dom, o);
      EXPECT_EQ(two.streaming, Streaming::TwoLattice);
      for (int threads : {1, 2}) {
        o.streaming = Streaming::AA;
        o.threads = threads;
        const LbmResult aa = runLbm(dom, o);
        EXPECT_EQ(aa.streaming, Streaming::AA);
        ASSERT_EQ(aa.fluidCells, two.fluidCells);
        EXPECT_EQ(aa.steps, two.steps);
        EXPECT_EQ(aa.sumAxialVelocity, two.sumAxialVelocity);
        EXPECT_EQ(aa.residual, two.residual);
        EXPECT_EQ(aa.massInitial, two.massInitial);
        EXPECT_EQ(aa.massFinal, two.massFinal);
        EXPECT_EQ(0, std::memcmp(aa.fields.density.data(), two.fields.density.data(),
                                 aa.fluidCells * sizeof(float)));
        for (int d = 0; d < 3; ++d)
          EXPECT_EQ(0, std::memcmp(aa.fields.velocity[d].data(), two.fields.velocity[d].data(),
                                   aa.fluidCells * sizeof(float)));
      }
    }
}

// Auto picks AA without interpolated links and two lattices with them; AA asked for with
// links is refused; AA's estimate holds one lattice instead of two.
TEST(FlowLbm, StreamingChoiceAndItsMemory) {
  EXPECT_EQ(resolveStreaming(Streaming::Auto, 0), Streaming::AA);
  EXPECT_EQ(resolveStreaming(Streaming::Auto, 5), Streaming::TwoLattice);
  EXPECT_EQ(resolveStreaming(Streaming::TwoLattice, 0), Streaming::TwoLattice);
  EXPECT_THROW(resolveStreaming(Streaming::AA, 5), InputError);
  const std::uint64_t aa = estimateLbmBytes(1000000, 400000, Precision::Float, 0, Streaming::AA);
  const std::uint64_t two =
      estimateLbmBytes(1000000, 400000, Precision::Float, 0, Streaming::TwoLattice);
  EXPECT_EQ(two - aa, 400000u * 19u * 4u);
  LbmDomain d = randomDomain();  // solid cells inside the box: interpolated links exist
  d.signedDistance.assign(d.fluid.size(), 1.0f);
  for (std::size_t i = 0; i < d.fluid.size(); ++i)
    if (!d.fluid[i]) d.signedDistance[i] = -0.5f;
  LbmOptions o = converging();
  o.maxSteps = 4;
  o.streaming = Streaming::AA;
  EXPECT_THROW(runLbm(d, o), InputError);
  o.streaming = Streaming::Auto;
  EXPECT_EQ(runLbm(d, o).streaming, Streaming::TwoLattice);
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
