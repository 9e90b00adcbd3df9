#pragma once
// Scaffolding: a command whose implementation has not landed yet. Removed once every
// command is implemented.
#include "command.hpp"
#include "voxpack/core/errors.hpp"

namespace voxpack::app {
class PendingCommand final : public Command {
 public:
  PendingCommand(std::string n, std::string d) : n_(std::move(n)), d_(std::move(d)) {}
  std::string name() const override { return n_; }
  std::string description() const override { return d_; }
  void addSwitches(CLI::App& sub) override { sub.allow_extras(); }
  int execute(const GlobalOptions&) override {
    throw InternalError("voxpack " + n_ + " is not available in this build yet");
  }

 private:
  std::string n_, d_;
};
}  // namespace voxpack::app
