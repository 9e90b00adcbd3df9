// libFuzzer target: the STL reader and mesh checks (binary or ASCII), then one
// digitisation of an accepted mesh at a voxel of 1/8 of its bounding radius.
#include "fuzz_common.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/packer/digitise.hpp"
#include "voxpack/packer/shape.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = voxpack::fuzz::writeScratch("mesh.stl", data, size);
  try {
    const auto shape = voxpack::packer::meshShape(path.string());
    const double r = shape->boundingRadiusMm();
    if (r > 1e-6 && r < 1e6) {
      const voxpack::Lattice l = voxpack::Lattice::isotropic(1, 1, 1, r / 8);
      (void)voxpack::packer::digitise(*shape, voxpack::Vec3::Zero(), voxpack::Quat::Identity(), l);
    }
  } catch (const voxpack::Error&) {
  }
  return 0;
}
