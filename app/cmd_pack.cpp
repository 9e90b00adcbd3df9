#include "pending.hpp"

namespace voxpack::app {
std::unique_ptr<Command> makePackCommand() {
  return std::make_unique<PendingCommand>("pack", "pack a bed (Monte Carlo or digital DEM)");
}
}  // namespace voxpack::app
