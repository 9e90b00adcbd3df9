#pragma once
/// \file command.hpp
/// One small class per `voxpack` subcommand (PDAL kernel style): addSwitches registers
/// the options on the CLI11 subcommand, execute() runs it after parsing and returns the
/// exit code. Library errors propagate to main as exceptions.

#include <CLI/CLI.hpp>
#include <memory>
#include <string>
#include <vector>

namespace voxpack::app {

/// Options every command shares (registered on the top-level app).
struct GlobalOptions {
  int threads = 0;      ///< --threads N (0 = all hardware threads)
  bool quiet = false;   ///< --quiet: no progress, no messages
  std::string commandLine;  ///< the whole command line, for provenance
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

/// Every command, in --help order.
std::vector<std::unique_ptr<Command>> allCommands();

}  // namespace voxpack::app
