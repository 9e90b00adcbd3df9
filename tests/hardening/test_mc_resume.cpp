// Issue 14, "long runs survive interruption" for Monte Carlo: a run resumed from any of
// its checkpoints gives the bed of the uninterrupted run, byte for byte (every dataset and
// the particle table; only wall times differ in the provenance).
#include <gtest/gtest.h>

#include <csignal>
#include <cstring>

#include "cli_runner.hpp"
#include "hardening_support.hpp"
#include "voxpack/core/bed_file.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/packer/container.hpp"
#include "voxpack/packer/mc.hpp"
#include "voxpack/packer/shape.hpp"

using namespace voxpack;
using namespace voxpack::packer;
using namespace voxpack::test;

namespace {

McOptions scene() {
  McOptions o;
  o.voxelSizeMm = 0.3;
  o.count = 12;
  o.reboundProbability = 0.1;
  o.maxSweeps = 3000;
  o.tapCycles = 1;  // the state machine's tap stages are crossed too
  return o;
}

}  // namespace

TEST(McResume, ResumeFromAnyCheckpointEqualsUninterruptedRun) {
  const std::vector<MixtureComponent> mix{{parseShape("sphere:d=2"), 2.0},
                                          {parseShape("cylinder:d=1.8,l=1.2"), 1.0}};
  const auto box = parseContainer("cylinder:d=7,h=9");
  std::vector<nlohmann::json> states;
  McCheckpointing save;
  save.everySeconds = 1e-9;  // a state at every sweep boundary
  save.write = [&](const nlohmann::json& s) { states.push_back(s); };
  const McResult full = packMonteCarlo(mix, *box, scene(), 11, nullProgress(), save);
  ASSERT_GT(states.size(), 10u);
  const McResult plain = packMonteCarlo(mix, *box, scene(), 11);
  expectSameBed(full.bed, plain.bed);  // checkpointing itself changes nothing
  for (const std::size_t k :
       {std::size_t{0}, states.size() / 3, states.size() / 2, states.size() - 1}) {
    // Through text, as the file holds it.
    const nlohmann::json state = nlohmann::json::parse(states[k].dump());
    McCheckpointing resume;
    resume.resume = &state;
    const McResult r = packMonteCarlo(mix, *box, scene(), 11, nullProgress(), resume);
    SCOPED_TRACE("state " + std::to_string(k) + " of " + std::to_string(states.size()));
    EXPECT_EQ(r.status, full.status);
    EXPECT_EQ(r.stats.sweeps, full.stats.sweeps);
    expectSameBed(r.bed, full.bed);
  }
}

TEST(McResume, CheckpointOfAnotherRunRefused) {
  const std::vector<MixtureComponent> mix{{parseShape("sphere:d=2"), 1.0}};
  const auto box = parseContainer("cylinder:d=7,h=9");
  std::vector<nlohmann::json> states;
  McCheckpointing save;
  save.everySeconds = 1e-9;
  save.write = [&](const nlohmann::json& s) { states.push_back(s); };
  packMonteCarlo(mix, *box, scene(), 11, nullProgress(), save);
  ASSERT_FALSE(states.empty());
  McCheckpointing resume;
  resume.resume = &states.front();
  EXPECT_THROW(packMonteCarlo(mix, *box, scene(), 12, nullProgress(), resume), InputError);
  nlohmann::json broken = states.front();
  broken["particles"][0][1] = "x";
  resume.resume = &broken;
  EXPECT_THROW(packMonteCarlo(mix, *box, scene(), 11, nullProgress(), resume), FormatError);
}
