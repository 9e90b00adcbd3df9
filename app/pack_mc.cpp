// Placeholder until the mc packing mode lands.
#include "pack_modes.hpp"
#include "voxpack/core/errors.hpp"

namespace voxpack::app {
namespace {
class PendingMc final : public PackMode {
 public:
  std::string name() const override { return "mc"; }
  void addSwitches(CLI::App&) override {}
  int run(const PackScene&, const toml::table*, const CLI::App&, const GlobalOptions&) override {
    throw InternalError("pack --mode mc is not available in this build yet");
  }
};
}  // namespace
std::unique_ptr<PackMode> makeMcMode() { return std::make_unique<PendingMc>(); }
}  // namespace voxpack::app
