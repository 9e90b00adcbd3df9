// computeFlow on beds: columns and ducts against analytic permeabilities, boundary
// modes agreeing on straight channels, blocked/refused beds, specific surface, ROI crop.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <numbers>

#include "flow_fixtures.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/flow/flow.hpp"

namespace voxpack::flow {
namespace {

// An empty column: a cylinder mask of `radius` voxels, every voxel inside void.
Bed emptyColumn(std::int64_t nz, std::int64_t box, double radius, double voxelMm) {
  Bed bed;
  bed.indicator = Grid<std::uint8_t>(Lattice::isotropic(nz, box, box, voxelMm), 1);
  bed.mask = Grid<std::uint8_t>(bed.indicator.lattice(), 0);
  const double c = 0.5 * static_cast<double>(box - 1);
  for (std::int64_t k = 0; k < nz; ++k)
    for (std::int64_t j = 0; j < box; ++j)
      for (std::int64_t i = 0; i < box; ++i)
        (*bed.mask)(k, j, i) =
            std::hypot(static_cast<double>(j) - c, static_cast<double>(i) - c) < radius ? 1 : 0;
  return bed;
}

FlowOptions quick() {
  FlowOptions o;
  o.lbm.tolerance = 1e-6;
  o.lbm.checkInterval = 50;
  o.lbm.tauPlus = 1.0;
  o.lbm.threads = 2;
  return o;
}

// Rectangular duct a x b (a <= b): Q = G a^3 b / (12 mu) [1 - 192 a/(pi^5 b) sum_odd
// tanh(n pi b / (2a)) / n^5]; superficial k = Q mu / (G a b).
double ductPermeability(double a, double b) {
  double s = 0;
  for (int n = 1; n < 200; n += 2)
    s += std::tanh(n * std::numbers::pi * b / (2 * a)) / std::pow(n, 5);
  return a * a / 12.0 * (1.0 - 192.0 * a / (std::pow(std::numbers::pi, 5) * b) * s);
}

TEST(FlowBed, EmptyColumnMatchesHagenPoiseuille) {
  const double h = 0.5;
  const Bed bed = emptyColumn(8, 22, 10.0, h);
  const FlowReport rep = computeFlow(bed, quick(), {});
  ASSERT_EQ(rep.json["status"], "converged");
  const double area = static_cast<double>(summarize(bed).voxelsInMask) / 8.0;
  const double expected = area / (8.0 * std::numbers::pi) * h * h;  // superficial k, mm^2
  // 2.7 % low: the staircase tube of FlowLbm.TubeMatchesHagenPoiseuille (same lattice).
  EXPECT_NEAR(rep.json["permeability_mm2"].get<double>() / expected, 0.973, 5e-3);
  EXPECT_NEAR(rep.json["porosity"].get<double>(), 1.0, 1e-12);
  // Straight channel: every streamline is axial, so the hydraulic tortuosity is 1.
  EXPECT_NEAR(rep.json["tortuosity_hydraulic"].get<double>(), 1.0, 1e-3);
  // Poiseuille: the velocity peaks on the axis, the outermost bin is the slowest.
  const auto& u = rep.json["radial_profile"]["axial_velocity_over_superficial"];
  ASSERT_GT(u.size(), 5u);
  EXPECT_LT(u.front().get<double>(), u.back().get<double>());
  EXPECT_NEAR(u.back().get<double>(), 2.0, 0.15);  // centre of a parabola: twice the mean
  EXPECT_TRUE(rep.json["reynolds"].get<double>() < 1.0);
  // Equal reservoir and sample lengths of the same tube: half the force is spent
  // driving the fluid back through the reservoirs, seen as a pressure rise F/2.
  EXPECT_NEAR(rep.json["lattice"]["pressure_gradient"].get<double>() /
                  rep.json["lattice"]["force"].get<double>(),
              0.5, 0.01);
}

TEST(FlowBed, DuctAgreesAcrossBoundaryModes) {
  Bed bed;
  bed.indicator = Grid<std::uint8_t>(Lattice::isotropic(6, 10, 20, 1.0), 1);
  const double expected = ductPermeability(10, 20);
  for (int mode = 0; mode < 2; ++mode) {
    FlowOptions o = quick();
    o.inflow = mode == 0 ? Inflow::Reservoirs : Inflow::Mirror;
    const FlowReport rep = computeFlow(bed, o, {});
    ASSERT_EQ(rep.json["status"], "converged");
    EXPECT_NEAR(rep.json["permeability_mm2"].get<double>() / expected, 1.0, 1e-2) << mode;
  }
}

TEST(FlowBed, PeriodicSphereArrayMatchesTheSolver) {
  LbmDomain d;
  double diameter = 0;
  test::scUnitCell(0.216, 16.0, d, &diameter);
  const Bed bed = test::bedFromDomain(d, 0.1);
  FlowOptions o = quick();
  o.periodic = true;
  o.lbm.tauPlus = 2.0;
  o.lbm.tolerance = 1e-6;
  o.particleDiameterMm = diameter * 0.1;
  const FlowReport rep = computeFlow(bed, o, {});
  ASSERT_EQ(rep.json["status"], "converged");
  // Zick & Homsy at 0.216: K = 7.442; 16 voxels per d is coarse, so 8 %.
  const double expected = 1.0 / (18.0 * 0.216 * 7.442);
  EXPECT_NEAR(rep.json["permeability_over_d2"].get<double>() / expected, 1.0, 0.08);
  EXPECT_GT(rep.json["tortuosity_hydraulic"].get<double>(), 1.0);
  EXPECT_TRUE(rep.json["radial_profile"].is_null());
  EXPECT_GT(rep.json["mlups"].get<double>(), 0.0);
  // Specific surface of the array within 5 % of the digitised sphere's 6 phi / d.
  EXPECT_NEAR(rep.json["specific_surface_mm_inv"].get<double>() / (6 * 0.216 / (diameter * 0.1)),
              1.0, 0.05);
}

TEST(FlowBed, BlockedBedReturnsAtOnce) {
  Bed bed = emptyColumn(40, 30, 14.0, 1.0);
  bed.mask.reset();  // a box: the first and last layers across x hold fluid too
  for (std::int64_t j = 0; j < 30; ++j)
    for (std::int64_t i = 0; i < 30; ++i) bed.indicator(20, j, i) = 0;  // a solid plate
  const auto t0 = std::chrono::steady_clock::now();
  const FlowReport rep = computeFlow(bed, quick(), {});
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_EQ(rep.json["status"], "blocked");
  EXPECT_EQ(rep.json["permeability_mm2"].get<double>(), 0.0);
  EXPECT_EQ(rep.json["steps"].get<int>(), 0);
  EXPECT_LT(s, 5.0);
  // Across the plate (x) the same bed flows.
  FlowOptions o = quick();
  o.axis = 2;
  o.lbm.maxSteps = 10;
  EXPECT_NE(computeFlow(bed, o, {}).json["status"], "blocked");
}

TEST(FlowBed, RefusesAllSolidAnisotropicAndOverBudget) {
  Bed bed = emptyColumn(4, 10, 4.0, 1.0);
  bed.indicator.fill(0);
  EXPECT_THROW(computeFlow(bed, quick(), {}), InputError);
  Bed aniso = emptyColumn(4, 10, 4.0, 1.0);
  Lattice l = aniso.indicator.lattice();
  l.spacingMm = {2.0, 1.0, 1.0};
  aniso.indicator.setLattice(l);
  aniso.mask->setLattice(l);
  EXPECT_THROW(computeFlow(aniso, quick(), {}), InputError);
  EXPECT_THROW(computeFlow(emptyColumn(4, 10, 4.0, 1.0), quick(), MemoryBudget{4096}),
               ResourceError);
}

TEST(FlowBed, SpecificSurfaceOfASphereIsUnbiased) {
  LbmDomain d;
  test::sphereCells(40, 12.0, &d);
  const Bed bed = test::bedFromDomain(d, 0.5);
  const double exact = 4 * std::numbers::pi * 144.0 / (40.0 * 40 * 40) / 0.5;  // 1/mm
  EXPECT_NEAR(specificSurfaceMmInv(bed, true) / exact, 1.0, 0.02);
  // The voxel-face count is 3/2 of it (the paper's +50 %): crossings along the axes only.
  std::size_t faces = 0;
  for (std::int64_t k = 0; k + 1 < 40; ++k)
    for (std::int64_t j = 0; j + 1 < 40; ++j)
      for (std::int64_t i = 0; i + 1 < 40; ++i)
        faces += (bed.indicator(k, j, i) != bed.indicator(k + 1, j, i)) +
                 (bed.indicator(k, j, i) != bed.indicator(k, j + 1, i)) +
                 (bed.indicator(k, j, i) != bed.indicator(k, j, i + 1));
  EXPECT_NEAR(static_cast<double>(faces) / (40.0 * 40 * 40) / 0.5 / exact, 1.5, 0.05);
}

TEST(FlowBed, CorrelationsReduceToTheirKnownForms) {
  // Stokes limit of Ergun: 150 mu (1-eps)^2 u / (eps^3 d^2) as u -> 0.
  const double eps = 0.4, d = 1e-3, mu = 1e-3, rho = 1000, u = 1e-6;
  const double viscous = 150 * mu * 0.36 * u / (0.064 * d * d);
  EXPECT_NEAR(Correlations::ergun(eps, d, mu, rho, u) / viscous, 1.0, 1e-3);
  // Eisfeld-Schnitzlein without a wall: K1 = 154 in place of 150.
  EXPECT_NEAR(Correlations::eisfeldSchnitzlein(eps, d, 0, mu, rho, u) / viscous, 154.0 / 150.0,
              2e-3);
  // A narrow column raises the viscous term by A_w^2.
  const double aw = 1 + 2.0 / (3 * 5 * 0.6);
  EXPECT_NEAR(Correlations::eisfeldSchnitzleinPermeability(eps, d, 5 * d) /
                  Correlations::eisfeldSchnitzleinPermeability(eps, d, 0),
              1 / (aw * aw), 1e-12);
  EXPECT_NEAR(Correlations::kozenyCarman(0.4, 1.0), 0.064 / (180 * 0.36), 1e-15);
}

// The correlations' d comes from the particle table when every particle is the same sphere
// or cylinder: 6V/S = 3 d l / (2 l + d) for a cylinder (2 x 1 mm: 1.5 mm); mixed shapes fall
// back to the measured surface.
TEST(FlowBed, SauterDiameterFromTheParticleTable) {
  Bed bed = emptyColumn(6, 12, 5.0, 0.5);
  bed.indicator(3, 6, 6) = 0;  // one solid voxel, so the measured surface is not empty
  bed.particles.positionMm = {Vec3(0, 0, 1), Vec3(0, 0, 2)};
  bed.particles.shape = {"cylinder:d=2,l=1", "cylinder:d=2,l=1"};
  FlowOptions o = quick();
  o.lbm.maxSteps = 50;
  const FlowReport cyl = computeFlow(bed, o, {});
  EXPECT_NEAR(cyl.json["particle_diameter_mm"].get<double>(), 1.5, 1e-12);
  EXPECT_EQ(cyl.json["particle_diameter_source"], "particle table: 6V/S of its cylinder");
  bed.particles.shape = {"sphere:d=3", "sphere:d=3"};
  EXPECT_NEAR(computeFlow(bed, o, {}).json["particle_diameter_mm"].get<double>(), 3.0, 1e-12);
  bed.particles.shape = {"sphere:d=3", "cylinder:d=2,l=1"};
  EXPECT_EQ(computeFlow(bed, o, {}).json["particle_diameter_source"], "Sauter 6(1-eps)/S_v");
}

// The reservoirs' automatic thickness: 0.6 d in layers, at least 4 (docs/flow.md, "Reservoir
// thickness"); a given count is kept; a small d gives the floor of 4; periodic runs have none.
TEST(FlowBed, ReservoirThicknessFollowsTheParticleDiameter) {
  Bed bed = emptyColumn(6, 12, 5.0, 0.5);
  bed.indicator(3, 6, 6) = 0;
  bed.particles.positionMm = {Vec3(0, 0, 1)};
  FlowOptions o = quick();
  o.lbm.maxSteps = 50;
  auto layers = [&](const char* shape, int asked) {
    bed.particles.shape = {shape};
    o.reservoirLayers = asked;
    const FlowReport r = computeFlow(bed, o, {});
    return std::make_pair(r.json["reservoir_layers"], r.json["reservoir_layers_source"]);
  };
  // 0.6 x 7.5 / 0.5 = 9 exactly: not rounded up to 10.
  EXPECT_EQ(layers("sphere:d=7.5", 0).first.get<int>(), 9);
  EXPECT_EQ(layers("sphere:d=7.5", 0).second, "automatic: 0.6 d, at least 4");
  EXPECT_EQ(layers("sphere:d=7.6", 0).first.get<int>(), 10);
  EXPECT_EQ(layers("sphere:d=1", 0).first.get<int>(), 4);  // 1.2 layers: the floor of 4
  EXPECT_EQ(layers("sphere:d=7.5", 3).first.get<int>(), 3);
  EXPECT_EQ(layers("sphere:d=7.5", 3).second, "option");
  EXPECT_THROW(layers("sphere:d=7.5", 1), InputError);
  EXPECT_THROW(layers("sphere:d=7.5", -2), InputError);
  o.periodic = true;
  EXPECT_TRUE(layers("sphere:d=7.5", 0).first.is_null());
  EXPECT_TRUE(layers("sphere:d=7.5", 0).second.is_null());
}

TEST(FlowBed, CropKeepsTheSelectedLayers) {
  Bed bed = emptyColumn(10, 8, 3.0, 0.5);
  bed.indicator(4, 3, 3) = 0;
  const Bed c = cropBedZ(bed, 1.9, 3.1);  // centres 2.0, 2.5, 3.0 mm: layers 4..6
  EXPECT_EQ(c.lattice().nz(), 3);
  EXPECT_DOUBLE_EQ(c.lattice().originMm[0], 2.0);
  EXPECT_EQ(c.indicator(0, 3, 3), 0);
  EXPECT_THROW(cropBedZ(bed, 50, 60), InputError);
  EXPECT_THROW(parseRoiMm("3:1"), UsageError);
  EXPECT_THROW(parseRoiMm("a:b"), UsageError);
  EXPECT_EQ(parseRoiMm("-1:2.5").second, 2.5);
}

}  // namespace
}  // namespace voxpack::flow
