#pragma once
/// \file interrupt.hpp
/// SIGINT/SIGTERM as a cancellation request. The flag is the one process-wide state in
/// voxpack: a signal handler can reach nothing else. Commands poll it via Progress.

namespace voxpack {

/// Seconds a command has, after SIGINT/SIGTERM, to reach a poll and stop cleanly before
/// the process exits anyway (128 + signal, with no clean-up of temporaries).
inline constexpr unsigned kInterruptGraceSeconds = 10;

/// Installs SIGINT and SIGTERM handlers that set the interrupt flag; a second signal, or
/// kInterruptGraceSeconds without a clean stop, exits at once with 128 + signal.
void installInterruptHandlers();

/// True once SIGINT or SIGTERM arrived (after installInterruptHandlers).
bool interruptRequested();

/// The signal that arrived (SIGINT or SIGTERM), 0 when none.
int interruptSignal();

}  // namespace voxpack
