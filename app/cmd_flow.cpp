// voxpack flow: placeholder until its module lands (owned by the flow work).
#include "command.hpp"
#include "voxpack/core/errors.hpp"

namespace voxpack::app {
namespace {

class FlowCommand final : public Command {
 public:
  std::string name() const override { return "flow"; }
  std::string description() const override { return "flow (not built yet)"; }
  void addSwitches(CLI::App& sub) override { sub.allow_extras(); }
  int execute(const GlobalOptions&) override { throw UsageError("flow: not built yet"); }
};

}  // namespace

std::unique_ptr<Command> makeFlowCommand() { return std::make_unique<FlowCommand>(); }

}  // namespace voxpack::app
