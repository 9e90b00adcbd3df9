// voxpack export: placeholder until its module lands (owned by the export work).
#include "command.hpp"
#include "voxpack/core/errors.hpp"

namespace voxpack::app {
namespace {

class ExportCommand final : public Command {
 public:
  std::string name() const override { return "export"; }
  std::string description() const override { return "export (not built yet)"; }
  void addSwitches(CLI::App& sub) override { sub.allow_extras(); }
  int execute(const GlobalOptions&) override { throw UsageError("export: not built yet"); }
};

}  // namespace

std::unique_ptr<Command> makeExportCommand() { return std::make_unique<ExportCommand>(); }

}  // namespace voxpack::app
