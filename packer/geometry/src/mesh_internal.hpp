#pragma once
// Mesh containers live in mesh.cpp with the CGAL code; container.cpp reaches them here.
#include <memory>
#include <string>

#include "voxpack/packer/container.hpp"

namespace voxpack::packer {

/// A container bounded by a closed STL mesh in the file's coordinates, scaled by `scale`.
std::shared_ptr<const Container> makeMeshContainer(const std::string& stlPath, double scale);

}  // namespace voxpack::packer
