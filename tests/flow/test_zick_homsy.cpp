// Zick & Homsy (JFM 115, 1982) simple-cubic sphere arrays, periodic unit cell at 24
// voxels per d (a few seconds each in Release; labelled no_sanitizer).
#include <gtest/gtest.h>

#include <cstdio>

#include "flow_fixtures.hpp"
#include "voxpack/flow/lbm.hpp"

namespace voxpack::flow {
namespace {

using test::scUnitCell;

// Zick & Homsy (1982): drag K of a simple-cubic array; k/d^2 = 1/(18 phi K).
double zickHomsyPermeabilityOverD2(double phi, double k) { return 1.0 / (18.0 * phi * k); }

void expectZickHomsy(double phi, double dragK) {
  LbmDomain d;
  double diameter = 0;
  const double phiDigital = scUnitCell(phi, 24.0, d, &diameter);
  ASSERT_NEAR(phiDigital, phi, 1e-3);
  LbmOptions o;
  o.axis = 0;
  o.tauPlus = 2.0;  // large tau: fast convergence, k unchanged (TRT)
  o.force = 1e-6;
  o.tolerance = 1e-6;
  o.maxSteps = 100000;
  o.checkInterval = 100;
  o.threads = 2;
  const LbmResult r = runLbm(d, o);
  ASSERT_EQ(r.status, FlowStatus::Converged);
  const double box = static_cast<double>(d.fluid.size());
  const double us = r.sumAxialVelocity / box;
  const double k = latticeViscosity(o.tauPlus) * us / o.force;
  const double expected = zickHomsyPermeabilityOverD2(phi, dragK);
  EXPECT_NEAR(k / (diameter * diameter) / expected, 1.0, 0.05) << "phi " << phi;
  std::printf("phi %.3f: k/d^2 %.5f, Zick-Homsy %.5f, ratio %.4f, %lld steps\n", phi,
              k / (diameter * diameter), expected, k / (diameter * diameter) / expected,
              static_cast<long long>(r.steps));
}

TEST(FlowLbm, SimpleCubicArrayPhi0125MatchesZickHomsy) { expectZickHomsy(0.125, 4.292); }
TEST(FlowLbm, SimpleCubicArrayPhi0343MatchesZickHomsy) { expectZickHomsy(0.343, 15.4); }

}  // namespace
}  // namespace voxpack::flow
