#pragma once
/// \file version.hpp
/// The voxpack version string.

namespace voxpack {

/// "X.Y.Z" of this build.
const char* versionString();

}  // namespace voxpack
