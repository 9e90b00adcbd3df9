// Placeholder until the dem packing mode lands.
#include "pack_modes.hpp"
#include "voxpack/core/errors.hpp"

namespace voxpack::app {
namespace {
class PendingDem final : public PackMode {
 public:
  std::string name() const override { return "dem"; }
  void addSwitches(CLI::App&) override {}
  int run(const PackScene&, const toml::table*, const CLI::App&, const GlobalOptions&) override {
    throw InternalError("pack --mode dem is not available in this build yet");
  }
};
}  // namespace
std::unique_ptr<PackMode> makeDemMode() { return std::make_unique<PendingDem>(); }
}  // namespace voxpack::app
