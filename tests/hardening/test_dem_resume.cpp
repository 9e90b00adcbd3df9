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
  // In the identity; the pour has not settled by 0.1 s (nor by 0.2 s: status time_cap),
  // so no tap starts.
  o.tapCycles = 1;
  o.tapRestS = 0.02;
  // Tuning thresholds left at their defaults: this scene is too small for a parallel region
  // even at two threads. Forcing one into every step made a 2-thread run of ~100 steps take
  // 0.3-24 s on the shared 2-core machine (load 10: each barrier waits for a descheduled
  // thread). Bitwise 1 vs 2 threads with parallel regions: DemPack.IdenticalForAnyThreadCount.
  o.threads = threads;
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
  // From the first, a middle, two-thirds and the last states at one thread, and from the
  // last at two (the thread count is not part of a run's identity).
  const std::size_t n = states.size();
  for (const auto& [k, threads] : std::vector<std::pair<std::size_t, int>>{
           {0, 1}, {n / 3, 1}, {2 * n / 3, 1}, {n - 1, 1}, {n - 1, 2}}) {
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
