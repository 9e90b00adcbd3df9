#pragma once
// Constants shared by the DEM's source files.

namespace voxpack::packer::dem {

/// pi, the one definition of the DEM module.
inline constexpr double kPi = 3.14159265358979323846;

}  // namespace voxpack::packer::dem
