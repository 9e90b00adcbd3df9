#include "voxpack/core/version.hpp"

#ifndef VOXPACK_VERSION
#error "VOXPACK_VERSION must be defined by the build"
#endif

namespace voxpack {

const char* versionString() { return VOXPACK_VERSION; }

}  // namespace voxpack
