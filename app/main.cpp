// voxpack: dispatches to one command and maps exceptions to exit codes (SPEC.md):
// 0 success, 2 bad input or usage (one "error: ..." line), 1 internal failure.
#include <exception>
#include <iostream>

#include "command.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/core/version.hpp"

namespace {

std::string joinArgs(int argc, char** argv) {
  std::string s;
  for (int a = 0; a < argc; ++a) {
    if (a) s += ' ';
    s += argv[a];
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

int main(int argc, char** argv) {
  using namespace voxpack;
  CLI::App app{"voxpack: digital packing of particles in columns, and comparison with images"};
  app.set_version_flag("--version", std::string("voxpack ") + versionString());
  app.require_subcommand(1);
  app::GlobalOptions global;
  global.commandLine = joinArgs(argc, argv);
  app.add_option("--threads", global.threads, "worker threads (0 = all cores)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_flag("--quiet,-q", global.quiet, "no progress output");
  app.fallthrough();

  auto commands = app::allCommands();
  std::vector<std::pair<CLI::App*, app::Command*>> subs;
  for (auto& cmd : commands) {
    CLI::App* sub = app.add_subcommand(cmd->name(), cmd->description());
    sub->fallthrough();
    cmd->addSwitches(*sub);
    subs.emplace_back(sub, cmd.get());
  }

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    return fail(2, e.what());
  }

  try {
    for (auto& [sub, cmd] : subs)
      if (sub->parsed()) return cmd->execute(global);
    return fail(2, "no command given (see --help)");
  } catch (const InputError& e) {
    return fail(2, e.what());
  } catch (const IoError& e) {
    return fail(2, e.what());
  } catch (const CLI::ParseError& e) {
    return fail(2, e.what());
  } catch (const Cancelled& e) {
    return fail(1, std::string("cancelled: ") + e.what());
  } catch (const std::bad_alloc&) {
    return fail(1, "out of memory");
  } catch (const std::exception& e) {
    return fail(1, std::string("internal: ") + e.what());
  }
}
