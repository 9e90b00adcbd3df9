#include "pending.hpp"

namespace voxpack::app {
std::unique_ptr<Command> makeCompareCommand() {
  return std::make_unique<PendingCommand>("compare", "compare simulated beds with a reference bed");
}
}  // namespace voxpack::app
