// Slab-wise pieces of the streamed ingest: plane crops and the solid-chord sums of
// voxelsPerDiameter carried across slab boundaries. Each equals its whole-volume counterpart
// exactly on the planes it reports (the halo argument is in docs/scale.md).
#include <algorithm>

#include "stream_detail.hpp"

namespace voxpack::ingest::stream_detail {

Grid<std::uint8_t> cropPlanes(const Grid<std::uint8_t>& g, std::int64_t from, std::int64_t to) {
  const Lattice& l = g.lattice();
  Lattice sub = l;
  sub.dims[0] = to - from;
  sub.originMm[0] = l.originMm[0] + static_cast<double>(from) * l.spacingMm[0];
  Grid<std::uint8_t> out(sub);
  const auto plane = static_cast<std::size_t>(l.ny() * l.nx());
  std::copy(g.data() + static_cast<std::size_t>(from) * plane,
            g.data() + static_cast<std::size_t>(to) * plane, out.data());
  return out;
}

Grid<float> cropPlanes(const Grid<float>& g, std::int64_t from, std::int64_t to) {
  const Lattice& l = g.lattice();
  Lattice sub = l;
  sub.dims[0] = to - from;
  sub.originMm[0] = l.originMm[0] + static_cast<double>(from) * l.spacingMm[0];
  Grid<float> out(sub);
  const auto plane = static_cast<std::size_t>(l.ny() * l.nx());
  std::copy(g.data() + static_cast<std::size_t>(from) * plane,
            g.data() + static_cast<std::size_t>(to) * plane, out.data());
  return out;
}

void ChordSums::addInPlane(const Grid<std::uint8_t>& ind, const Grid<std::uint8_t>* region) {
  // Runs along x and y lie inside one plane: quality.cpp's loop over those two axes.
  const Lattice& l = ind.lattice();
  const std::int64_t dims[3] = {l.nz(), l.ny(), l.nx()};
  for (int axis = 1; axis < 3; ++axis) {
    const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
    for (std::int64_t u = 0; u < dims[a1]; ++u)
      for (std::int64_t v = 0; v < dims[a2]; ++v) {
        std::int64_t run = 0;
        bool open = false;
        for (std::int64_t w = 0; w < dims[axis]; ++w) {
          std::int64_t idx[3];
          idx[axis] = w;
          idx[a1] = u;
          idx[a2] = v;
          const std::size_t o = l.offset(idx[0], idx[1], idx[2]);
          const bool in = !region || (*region)[o];
          if (!in) {
            run = 0;
            open = false;
            continue;
          }
          if (ind[o] == 0) {
            ++run;
          } else {
            if (open && run > 0) {
              total += static_cast<double>(run);
              count += 1;
            }
            run = 0;
            open = true;
          }
        }
      }
  }
}

void ChordSums::addAlongZ(const Grid<std::uint8_t>& ind, const Grid<std::uint8_t>* region) {
  // Runs along z continue from the previous slab: (run, open) per column is the state.
  const Lattice& l = ind.lattice();
  const auto plane = static_cast<std::size_t>(l.ny() * l.nx());
  if (run.empty()) {
    run.assign(plane, 0);
    open.assign(plane, 0);
  }
  for (std::int64_t k = 0; k < l.nz(); ++k)
    for (std::size_t p = 0; p < plane; ++p) {
      const std::size_t o = static_cast<std::size_t>(k) * plane + p;
      const bool in = !region || (*region)[o];
      if (!in) {
        run[p] = 0;
        open[p] = 0;
        continue;
      }
      if (ind[o] == 0) {
        ++run[p];
      } else {
        if (open[p] && run[p] > 0) {
          total += static_cast<double>(run[p]);
          count += 1;
        }
        run[p] = 0;
        open[p] = 1;
      }
    }
}

}  // namespace voxpack::ingest::stream_detail
