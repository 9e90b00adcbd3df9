#include "pending.hpp"

namespace voxpack::app {
std::unique_ptr<Command> makeShapeCommand() {
  return std::make_unique<PendingCommand>("shape", "digitise one particle and report its digitisation error");
}
}  // namespace voxpack::app
