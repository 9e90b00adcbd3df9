// Slab-wise pieces of the streamed ingest: plane crops, the speck/hole clean-up with the
// count restricted to a slab's own planes, and the solid-chord sums of voxelsPerDiameter
// carried across slab boundaries. Each equals its whole-volume counterpart exactly on
// the planes it reports (the halo argument is in docs/scale_ingest.md).
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

std::size_t removeSmallComponentsCounted(Grid<std::uint8_t>& ind, std::uint8_t phase,
                                         std::size_t maxVoxels, std::int64_t countZ0,
                                         std::int64_t countZ1) {
  // The rule of segment.cpp's removeSmallComponents (face neighbours, components touching
  // the lattice border kept, size <= maxVoxels flipped); a flipped component is counted
  // when its first voxel in scan order lies in planes [countZ0, countZ1), so that every
  // component is counted by exactly one slab.
  if (maxVoxels == 0) return 0;
  const Lattice& l = ind.lattice();
  const std::int64_t nz = l.nz(), ny = l.ny(), nx = l.nx();
  const auto plane = static_cast<std::size_t>(ny * nx);
  std::vector<std::uint8_t> seen(ind.size(), 0);
  std::vector<std::size_t> stack, members;
  std::size_t flipped = 0;
  for (std::size_t start = 0; start < ind.size(); ++start) {
    if (seen[start] || ind[start] != phase) continue;
    stack.assign(1, start);
    seen[start] = 1;
    members.clear();
    std::size_t size = 0;
    bool border = false;
    while (!stack.empty()) {
      const std::size_t off = stack.back();
      stack.pop_back();
      ++size;
      if (size <= maxVoxels) members.push_back(off);
      const Index3 p = l.indexOf(off);
      if (p.k == 0 || p.j == 0 || p.i == 0 || p.k == nz - 1 || p.j == ny - 1 || p.i == nx - 1)
        border = true;
      const std::int64_t nb[6][3] = {{-1, 0, 0}, {1, 0, 0},  {0, -1, 0},
                                     {0, 1, 0},  {0, 0, -1}, {0, 0, 1}};
      for (const auto& d : nb) {
        const std::int64_t k = p.k + d[0], j = p.j + d[1], i = p.i + d[2];
        if (!l.contains(k, j, i)) continue;
        const std::size_t o = l.offset(k, j, i);
        if (!seen[o] && ind[o] == phase) {
          seen[o] = 1;
          stack.push_back(o);
        }
      }
    }
    if (size <= maxVoxels && !border) {
      for (std::size_t o : members) ind[o] = static_cast<std::uint8_t>(1 - phase);
      const auto k0 = static_cast<std::int64_t>(start / plane);
      if (k0 >= countZ0 && k0 < countZ1) ++flipped;
    }
  }
  return flipped;
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
