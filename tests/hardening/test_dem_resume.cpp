// Issue 14, "long runs survive interruption" for DEM: a run resumed from any of its
// checkpoints gives the particle table of the uninterrupted run bit for bit, for any
// thread count; a checkpoint of another run is refused.
#include <gtest/gtest.h>

#include <cstring>

#include "hardening_support.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/packer/container.hpp"
#include "voxpack/packer/dem.hpp"
#include "voxpack/packer/dem_geometry.hpp"
#include "voxpack/packer/shape.hpp"

using namespace voxpack;
using namespace voxpack::packer;

namespace {

dem::DemScene scene(std::uint64_t seed) {
  dem::DemScene s;
  s.shapes = {dem::demShape(parseShape("sphere:d=2")),
              dem::demShape(parseShape("cylinder:d=1.8,l=1.2"))};
  s.fractions = {2, 1};
  s.container = dem::demContainer(parseContainer("cylinder:d=8,h=10"), 2.0);
  s.voxelSizeMm = 0.4;
  s.count = 8;
  s.seed = seed;
  return s;
}

dem::DemOptions options(int threads) {
  dem::DemOptions o;
  o.maxTimeS = 0.1;
  // In the identity; the pour does not settle within 0.1 s, so no tap starts (settling
  // and tapping 8 particles takes ~0.5 s simulated, 5x these steps).
  o.tapCycles = 1;
  o.tapRestS = 0.02;
  o.threads = threads;
  if (threads > 1) {
    // Parallel regions even on this small scene. Not at one thread: a region per step
    // costs more than the step here (tuning only: the bits do not depend on it).
    o.parallelMinItems = 1;
    o.parallelMinNodeWork = 1;
  }
  return o;
}

void expectSameTable(const dem::DemResult& a, const dem::DemResult& b) {
  EXPECT_EQ(a.status, b.status);
  EXPECT_EQ(a.counters.steps, b.counters.steps);
  EXPECT_EQ(a.counters.nodeEvaluations, b.counters.nodeEvaluations);
  test::expectSameParticles(a.particles, b.particles);
}

}  // namespace

TEST(DemResume, ResumeFromAnyCheckpointEqualsUninterruptedRun) {
  std::vector<nlohmann::json> states;
  dem::DemCheckpointing save;
  save.everySeconds = 1e-9;  // a state at every check
  save.write = [&](const nlohmann::json& s) { states.push_back(s); };
  const dem::DemResult full = dem::runDem(scene(5), options(1), nullProgress(), save);
  ASSERT_GT(states.size(), 10u);
  const dem::DemResult plain = dem::runDem(scene(5), options(1), nullProgress());
  expectSameTable(full, plain);  // checkpointing itself changes nothing
  // From the first, a middle and the last states at one thread; from the last two at two
  // threads with a parallel region in every step (one costs more than a step of this
  // scene, 42 s for the whole run on the shared machine, so only the last steps).
  const std::size_t n = states.size();
  for (const auto& [k, threads] : std::vector<std::pair<std::size_t, int>>{
           {0, 1}, {n / 3, 1}, {2 * n / 3, 1}, {n - 1, 1}, {n - 2, 2}, {n - 1, 2}}) {
    const nlohmann::json state = nlohmann::json::parse(states[k].dump());  // as the file
    SCOPED_TRACE("state " + std::to_string(k) + " of " + std::to_string(n) + ", threads " +
                 std::to_string(threads));
    dem::DemCheckpointing resume;
    resume.resume = &state;
    const dem::DemResult r = dem::runDem(scene(5), options(threads), nullProgress(), resume);
    expectSameTable(r, full);
  }
}

TEST(DemResume, CheckpointOfAnotherRunRefused) {
  std::vector<nlohmann::json> states;
  dem::DemCheckpointing save;
  save.everySeconds = 1e-9;
  save.write = [&](const nlohmann::json& s) {
    if (states.empty()) states.push_back(s);
  };
  dem::DemOptions o = options(1);
  o.maxTimeS = 0.01;
  dem::runDem(scene(5), o, nullProgress(), save);
  ASSERT_FALSE(states.empty());
  dem::DemCheckpointing resume;
  resume.resume = &states.front();
  EXPECT_THROW(dem::runDem(scene(6), o, nullProgress(), resume), InputError);
  dem::DemOptions other = o;
  other.friction = 0.3;
  EXPECT_THROW(dem::runDem(scene(5), other, nullProgress(), resume), InputError);
  nlohmann::json broken = states.front();
  broken["format"] = "something";
  resume.resume = &broken;
  EXPECT_THROW(dem::runDem(scene(5), o, nullProgress(), resume), FormatError);
}
