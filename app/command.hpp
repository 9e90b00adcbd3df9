#pragma once
/// \file command.hpp
/// One small class per `voxpack` subcommand (PDAL kernel style): addSwitches registers
/// the options on the CLI11 subcommand, execute() runs it after parsing and returns the
/// exit code. Library errors propagate to main as exceptions.

#include <CLI/CLI.hpp>
#include <exception>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "voxpack/core/communicator.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/core/memory.hpp"
#include "voxpack/core/progress.hpp"

namespace voxpack::app {

/// Options every command shares (registered on the top-level app).
struct GlobalOptions {
  int threads = 0;               ///< --threads N (0 = all hardware threads)
  bool quiet = false;            ///< --quiet: no progress, no messages
  std::string commandLine;       ///< the whole command line, for provenance
  MemoryBudget memory;           ///< --memory-limit SIZE (default 75 % of the memory available)
  Progress* progress = nullptr;  ///< extra progress/cancel hook (the Python module), or null
};

/// The progress of one command: the stderr bar plus the caller's hook, cancelled by
/// the hook or by SIGINT/SIGTERM.
class CommandProgress final : public Progress {
 public:
  /// Progress for a command run with `global`.
  explicit CommandProgress(const GlobalOptions& global);
  void report(std::string_view stage, double fraction) override;
  bool cancelled() const override;
  void message(std::string_view text) override;

 private:
  StderrProgress stderr_;
  Progress* external_;
};

/// Progress that turns every stage start into a poll: once a stop was asked (SIGINT or
/// SIGTERM, or the caller's hook), report() throws Cancelled. ingest, stats and compare call
/// library code that polls in a few stages only; without this a signal in another stage let
/// the command run on and write its output, or end by the grace alarm.
class StopAtStageProgress final : public Progress {
 public:
  /// Forwards reports, messages and the stop request to `inner`.
  explicit StopAtStageProgress(Progress& inner) : inner_(inner) {}
  void report(std::string_view stage, double fraction) override {
    poll(stage);
    inner_.report(stage, fraction);
  }
  bool cancelled() const override { return inner_.cancelled(); }
  void message(std::string_view text) override { inner_.message(text); }
  /// Throws Cancelled naming `what` when a stop was asked (call it before writing output).
  void poll(std::string_view what) const {
    if (inner_.cancelled()) throw Cancelled(std::string(what));
  }

 private:
  Progress& inner_;
};

/// A voxpack subcommand.
class Command {
 public:
  virtual ~Command() = default;
  /// Subcommand name, e.g. "info".
  virtual std::string name() const = 0;
  /// One-line description for --help.
  virtual std::string description() const = 0;
  /// Registers options on `sub`.
  virtual void addSwitches(CLI::App& sub) = 0;
  /// Runs the command; returns the process exit code (0 success).
  virtual int execute(const GlobalOptions& global) = 0;
};

std::unique_ptr<Command> makeInfoCommand();     ///< voxpack info
std::unique_ptr<Command> makeShapeCommand();    ///< voxpack shape
std::unique_ptr<Command> makePackCommand();     ///< voxpack pack
std::unique_ptr<Command> makeIngestCommand();   ///< voxpack ingest
std::unique_ptr<Command> makePhantomCommand();  ///< voxpack phantom
std::unique_ptr<Command> makeStatsCommand();    ///< voxpack stats
std::unique_ptr<Command> makeCompareCommand();  ///< voxpack compare
std::unique_ptr<Command> makeFlowCommand();     ///< voxpack flow
std::unique_ptr<Command> makeExportCommand();   ///< voxpack export

/// Every command, in --help order.
std::vector<std::unique_ptr<Command>> allCommands();

/// Runs `run()` on this rank. Under mpirun a rank that fails prints its `error:` line and
/// aborts every rank (exit 2 for bad input and I/O), so no rank is left waiting for it.
template <class Run>
int runOnRanks(const Communicator& comm, Run run) {
  if (comm.size() <= 1) return run();
  try {
    return run();
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << '\n';
    comm.abort(dynamic_cast<const InputError*>(&e) || dynamic_cast<const IoError*>(&e) ? 2 : 1);
  }
}

}  // namespace voxpack::app
