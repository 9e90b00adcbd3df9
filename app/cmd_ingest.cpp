#include "pending.hpp"

namespace voxpack::app {
std::unique_ptr<Command> makeIngestCommand() {
  return std::make_unique<PendingCommand>("ingest", "segment an imaged volume into a bed file");
}
}  // namespace voxpack::app
