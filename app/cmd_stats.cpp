#include "pending.hpp"

namespace voxpack::app {
std::unique_ptr<Command> makeStatsCommand() {
  return std::make_unique<PendingCommand>("stats", "structure statistics of a bed");
}
}  // namespace voxpack::app
