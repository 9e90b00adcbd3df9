// Bit-for-bit fingerprint of a DEM bed, for speed work that must not change the physics:
//   dem_bed_digest BED.h5
// Prints JSON: particle count and FNV-1a 64 of the particle table's exact bits (centres and
// orientations), of the labels and of the indicator. Two beds with the same digests hold the
// same particles at the same bits; the provenance (wall time, work counters) is ignored.
#include <cstdint>
#include <cstring>
#include <iostream>
#include <nlohmann/json.hpp>

#include "voxpack/core/bed_file.hpp"

namespace {

struct Fnv {
  std::uint64_t h = 1469598103934665603ull;
  void bytes(const void* p, std::size_t n) {
    const auto* c = static_cast<const unsigned char*>(p);
    for (std::size_t i = 0; i < n; ++i) {
      h ^= c[i];
      h *= 1099511628211ull;
    }
  }
  void real(double v) { bytes(&v, sizeof v); }
};

std::string hex(std::uint64_t v) {
  static const char* d = "0123456789abcdef";
  std::string s(16, '0');
  for (int i = 15; i >= 0; --i, v >>= 4) s[static_cast<std::size_t>(i)] = d[v & 15];
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: dem_bed_digest BED.h5\n";
    return 2;
  }
  try {
    const voxpack::Bed bed = voxpack::readBed(argv[1]);
    Fnv particles, labels, indicator;
    for (std::size_t i = 0; i < bed.particles.size(); ++i) {
      for (int a = 0; a < 3; ++a) particles.real(bed.particles.positionMm[i][a]);
      for (int a = 0; a < 4; ++a) particles.real(bed.particles.orientation[i].coeffs()[a]);
    }
    if (bed.labels) labels.bytes(bed.labels->data(), bed.labels->size() * sizeof(std::uint32_t));
    indicator.bytes(bed.indicator.data(), bed.indicator.size());
    nlohmann::json out = {{"particles", bed.particles.size()},
                          {"particle_table_fnv1a64", hex(particles.h)},
                          {"labels_fnv1a64", hex(labels.h)},
                          {"indicator_fnv1a64", hex(indicator.h)}};
    std::cout << out.dump() << "\n";
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
}
