#pragma once
/// \file cli.hpp
/// The whole `voxpack` command line as a library call, so that the binary and the
/// Python module run exactly the same parsing and the same commands.

#include <string>
#include <vector>

#include "voxpack/core/progress.hpp"

namespace voxpack::app {

/// Parses `args` (args[0] is the program name) and runs the chosen command. Library
/// exceptions propagate (InputError, IoError, UsageError, ...); CLI11 parse errors are
/// rethrown as UsageError. Returns the command's exit code; --help/--version print and
/// return 0.
int runCommandLine(const std::vector<std::string>& args);

/// runCommandLine with an extra progress/cancel hook (the Python module's callback).
int runCommandLine(const std::vector<std::string>& args, Progress* progress);

/// main(): runCommandLine with every exception mapped to an exit code and one
/// `error: ...` line on stderr (0 success, 2 bad input or usage, 1 internal failure).
int runMain(int argc, char** argv);

}  // namespace voxpack::app
