#include "pending.hpp"

namespace voxpack::app {
std::unique_ptr<Command> makePhantomCommand() {
  return std::make_unique<PendingCommand>("phantom", "simulate an MRI or XMT image of a bed");
}
}  // namespace voxpack::app
