// Mesh shapes and containers (CGAL). Stub until the CGAL part lands.
#include "mesh_internal.hpp"
#include "voxpack/core/errors.hpp"

namespace voxpack::packer {

std::shared_ptr<const Shape> meshShape(const std::string& stlPath, double) {
  throw InputError("mesh shape '" + stlPath + "': STL meshes are not supported yet");
}

std::shared_ptr<const Container> makeMeshContainer(const std::string& stlPath, double) {
  throw InputError("mesh container '" + stlPath + "': STL meshes are not supported yet");
}

}  // namespace voxpack::packer
