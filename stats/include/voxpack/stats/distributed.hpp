#pragma once
/// \file distributed.hpp
/// The statistics use the core Communicator (voxpack/core/communicator.hpp).

#include "voxpack/core/communicator.hpp"

namespace voxpack::stats {

/// The ranks a streamed statistic is spread over (voxpack::Communicator).
using Communicator = voxpack::Communicator;

}  // namespace voxpack::stats
