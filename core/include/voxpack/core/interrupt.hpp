#pragma once
/// \file interrupt.hpp
/// SIGINT/SIGTERM as a cancellation request. The flag is the one process-wide state in
/// voxpack: a signal handler can reach nothing else. Commands poll it via Progress.

namespace voxpack {

/// Installs SIGINT and SIGTERM handlers that only set the interrupt flag.
void installInterruptHandlers();

/// True once SIGINT or SIGTERM arrived (after installInterruptHandlers).
bool interruptRequested();

/// The signal that arrived (SIGINT or SIGTERM), 0 when none.
int interruptSignal();

}  // namespace voxpack
