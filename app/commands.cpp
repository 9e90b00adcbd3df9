#include "command.hpp"

namespace voxpack::app {

std::vector<std::unique_ptr<Command>> allCommands() {
  std::vector<std::unique_ptr<Command>> v;
  v.push_back(makeInfoCommand());
  v.push_back(makeShapeCommand());
  v.push_back(makePackCommand());
  v.push_back(makeIngestCommand());
  v.push_back(makePhantomCommand());
  v.push_back(makeStatsCommand());
  v.push_back(makeCompareCommand());
  v.push_back(makeFlowCommand());
  v.push_back(makeExportCommand());
  return v;
}

}  // namespace voxpack::app
