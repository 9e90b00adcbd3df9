// The command-line dispatcher shared by the binary (main.cpp) and the Python module:
// one CLI11 app, one command class per subcommand, exceptions mapped once (docs/interfaces.md):
// 0 success, 2 bad input or usage (one "error: ..." line), 1 internal failure.
#include "cli.hpp"

#include <algorithm>
#include <exception>
#include <iostream>

#include "command.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/core/interrupt.hpp"
#include "voxpack/core/version.hpp"

namespace voxpack::app {
namespace {

std::string joinArgs(const std::vector<std::string>& args) {
  std::string s;
  for (std::size_t a = 0; a < args.size(); ++a) {
    if (a) s += ' ';
    s += args[a];
  }
  return s;
}

int fail(int code, const std::string& what) {
  std::string line = what;
  for (char& c : line)
    if (c == '\n') c = ' ';
  std::cerr << "error: " << line << '\n';
  return code;
}

}  // namespace

CommandProgress::CommandProgress(const GlobalOptions& global)
    : stderr_(global.quiet), external_(global.progress) {}

void CommandProgress::report(std::string_view stage, double fraction) {
  stderr_.report(stage, fraction);
  if (external_) external_->report(stage, fraction);
}

bool CommandProgress::cancelled() const {
  return interruptRequested() || (external_ && external_->cancelled());
}

void CommandProgress::message(std::string_view text) {
  stderr_.message(text);
  if (external_) external_->message(text);
}

int runCommandLine(const std::vector<std::string>& args) { return runCommandLine(args, nullptr); }

int runCommandLine(const std::vector<std::string>& args, Progress* progress) {
  CLI::App app{"voxpack: digital packing of particles in columns, and comparison with images"};
  app.set_version_flag("--version", std::string("voxpack ") + versionString());
  app.require_subcommand(1);
  GlobalOptions global;
  global.commandLine = joinArgs(args);
  app.add_option("--threads", global.threads, "worker threads (0 = all cores)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_flag("--quiet,-q", global.quiet, "no progress output");
  std::string memoryLimit;
  app.add_option("--memory-limit", memoryLimit,
                 "memory budget, e.g. 512M or 8G (default: 75 % of the memory available now)");
  global.progress = progress;
  app.fallthrough();

  auto commands = allCommands();
  std::vector<std::pair<CLI::App*, Command*>> subs;
  for (auto& cmd : commands) {
    CLI::App* sub = app.add_subcommand(cmd->name(), cmd->description());
    sub->fallthrough();
    cmd->addSwitches(*sub);
    subs.emplace_back(sub, cmd.get());
  }

  // CLI11 parses argv from the back; keep the strings alive for the whole parse.
  std::vector<std::string> rest(args.begin() + (args.empty() ? 0 : 1), args.end());
  std::reverse(rest.begin(), rest.end());
  try {
    app.parse(rest);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    throw UsageError(e.what());
  }
  global.memory = memoryLimit.empty() ? defaultMemoryBudget()
                                      : MemoryBudget{parseMemorySize(memoryLimit)};
  for (auto& [sub, cmd] : subs)
    if (sub->parsed()) {
      try {
        return cmd->execute(global);
      } catch (const CLI::ParseError& e) {
        throw UsageError(e.what());
      }
    }
  throw UsageError("no command given (see --help)");
}

int runMain(int argc, char** argv) {
  installInterruptHandlers();
  try {
    return runCommandLine(std::vector<std::string>(argv, argv + argc));
  } catch (const InputError& e) {
    return fail(2, e.what());
  } catch (const IoError& e) {
    return fail(2, e.what());
  } catch (const Cancelled& e) {
    // Interrupted by a signal: the shell convention 128 + signal (130 SIGINT, 143 SIGTERM).
    if (const int sig = interruptSignal())
      return fail(128 + sig, std::string("interrupted (signal ") + std::to_string(sig) +
                                 "): no output written");
    return fail(1, std::string("cancelled: ") + e.what());
  } catch (const std::bad_alloc&) {
    return fail(1, "out of memory");
  } catch (const std::exception& e) {
    return fail(1, std::string("internal: ") + e.what());
  }
}

}  // namespace voxpack::app
