// ROI cropping of a bed before its statistics (docs/stats.md, "ROI").
#include "voxpack/stats/crop.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <vector>

#include "voxpack/core/errors.hpp"

namespace voxpack::stats {
namespace {

using nlohmann::json;

const char* const kAxisName[3] = {"z", "y", "x"};

void checkRange(const std::optional<RangeMm>& r, const char* axis) {
  if (!r) return;
  if (!std::isfinite(r->lo) || !std::isfinite(r->hi))
    throw InputError(std::string("ROI: ") + axis + " bounds must be finite numbers");
  if (r->hi < r->lo)
    throw InputError(std::string("ROI: ") + axis + " range is reversed (" + std::to_string(r->lo) +
                     " > " + std::to_string(r->hi) + ")");
}

// Ranges in lattice axis order (z, y, x).
std::array<const std::optional<RangeMm>*, 3> rangesZyx(const CropOptions& o) {
  return {&o.zMm, &o.yMm, &o.xMm};
}

double parseNumber(const std::string& raw, const std::string& what) {
  std::string s = raw;
  s.erase(0, s.find_first_not_of(" \t"));
  s.erase(s.find_last_not_of(" \t") + 1);
  if (s.empty()) throw InputError("ROI: missing number in " + what);
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  if (end != s.c_str() + s.size() || errno == ERANGE)
    throw InputError("ROI: '" + s + "' is not a number (in " + what + ")");
  if (!std::isfinite(v)) throw InputError("ROI: bounds must be finite numbers (in " + what + ")");
  return v;
}

// "LO:HI" -> range; "" or ":" -> nullopt (axis whole).
std::optional<RangeMm> parseRange(const std::string& text, const char* axis, bool allowWhole) {
  const std::string what = std::string(axis) + " range '" + text + "'";
  const auto colon = text.find(':');
  if (allowWhole && text.find_first_not_of(" \t:") == std::string::npos &&
      std::count(text.begin(), text.end(), ':') <= 1)
    return std::nullopt;
  if (colon == std::string::npos || text.find(':', colon + 1) != std::string::npos)
    throw InputError("ROI: " + what + " must be LO:HI in mm");
  RangeMm r{parseNumber(text.substr(0, colon), what), parseNumber(text.substr(colon + 1), what)};
  std::optional<RangeMm> out = r;
  checkRange(out, axis);
  return out;
}

template <class T>
Grid<T> cropGrid(const Grid<T>& in, const Lattice& out, const CropBox& b) {
  Grid<T> g(out);
  const Lattice& l = in.lattice();
  const auto nx = static_cast<std::size_t>(b.dims[2]);
  for (std::int64_t k = 0; k < b.dims[0]; ++k)
    for (std::int64_t j = 0; j < b.dims[1]; ++j)
      std::copy_n(in.data() + l.offset(b.first[0] + k, b.first[1] + j, b.first[2]), nx,
                  g.data() + out.offset(k, j, 0));
  return g;
}

}  // namespace

CropBox cropBox(const Lattice& lattice, const CropOptions& options) {
  lattice.validate("bed");
  if (!(options.toleranceVoxels >= 0) || !std::isfinite(options.toleranceVoxels))
    throw InputError("ROI: tolerance must be finite and >= 0");
  const auto ranges = rangesZyx(options);
  CropBox box;
  box.inputDims = lattice.dims;
  for (int a = 0; a < 3; ++a) {
    checkRange(*ranges[a], kAxisName[a]);
    const std::int64_t n = lattice.dims[a];
    std::int64_t first = 0, last = n - 1;
    if (*ranges[a]) {
      const RangeMm& r = **ranges[a];
      const double o = lattice.originMm[a], s = lattice.spacingMm[a];
      const double lo = std::ceil((r.lo - o) / s - options.toleranceVoxels);
      const double hi = std::floor((r.hi - o) / s + options.toleranceVoxels);
      // Clamp in double first: a bound far outside the lattice must not overflow int64.
      first = static_cast<std::int64_t>(std::clamp(lo, 0.0, static_cast<double>(n)));
      last = static_cast<std::int64_t>(std::clamp(hi, -1.0, static_cast<double>(n - 1)));
      if (last < first) {
        std::ostringstream m;
        m << "ROI: no voxel centre has " << kAxisName[a] << " in [" << r.lo << ", " << r.hi
          << "] mm (voxel centres span " << o << " .. " << o + static_cast<double>(n - 1) * s
          << " mm)";
        throw InputError(m.str());
      }
    }
    box.first[a] = first;
    box.dims[a] = last - first + 1;
  }
  return box;
}

Bed cropBed(const Bed& bed, const CropOptions& options, CropBox* boxOut) {
  const Lattice& l = bed.lattice();
  const CropBox b = cropBox(l, options);
  if (boxOut) *boxOut = b;
  Lattice out = l;
  out.dims = b.dims;
  for (int a = 0; a < 3; ++a)
    out.originMm[a] = l.originMm[a] + static_cast<double>(b.first[a]) * l.spacingMm[a];

  Bed c;
  c.provenance = bed.provenance;
  c.indicator = cropGrid(bed.indicator, out, b);
  if (bed.mask) c.mask = cropGrid(*bed.mask, out, b);
  if (bed.labels) c.labels = cropGrid(*bed.labels, out, b);

  const ParticleTable& p = bed.particles;
  const std::size_t n = p.size();
  std::vector<std::uint8_t> keep(n, 0);
  bool relabel = false;
  if (c.labels && n > 0) {
    bool consistent = true;
    for (std::uint32_t v : c.labels->values()) {
      if (v == 0) continue;
      if (v > n) {
        consistent = false;
        break;
      }
      keep[v - 1] = 1;
    }
    // Labels beyond the table: the file does not tie labels to rows, so leave both as read.
    if (!consistent) {
      c.particles = p;
      return c;
    }
    relabel = true;
  } else {
    const auto ranges = rangesZyx(options);
    for (std::size_t q = 0; q < n; ++q) {
      const Vec3& x = p.positionMm[q];
      const double zyx[3] = {x.z(), x.y(), x.x()};
      bool in = true;
      for (int a = 0; a < 3 && in; ++a)
        if (*ranges[a]) {
          const double tol = options.toleranceVoxels * l.spacingMm[a];
          in = zyx[a] >= (*ranges[a])->lo - tol && zyx[a] <= (*ranges[a])->hi + tol;
        }
      keep[q] = in;
    }
  }
  std::vector<std::uint32_t> newLabel(n + 1, 0);
  for (std::size_t q = 0; q < n; ++q) {
    if (!keep[q]) continue;
    c.particles.positionMm.push_back(p.positionMm[q]);
    if (!p.orientation.empty()) c.particles.orientation.push_back(p.orientation[q]);
    if (!p.shape.empty()) c.particles.shape.push_back(p.shape[q]);
    newLabel[q + 1] = static_cast<std::uint32_t>(c.particles.size());
  }
  if (relabel)
    for (std::uint32_t& v : c.labels->values()) v = newLabel[v];
  return c;
}

CropOptions parseRoiZ(const std::string& text) {
  CropOptions o;
  o.zMm = parseRange(text, "z", false);
  return o;
}

CropOptions parseRoiBox(const std::string& text) {
  std::vector<std::string> parts;
  std::stringstream ss(text);
  for (std::string item; std::getline(ss, item, ',');) parts.push_back(item);
  if (!text.empty() && text.back() == ',') parts.emplace_back();
  if (parts.size() != 3)
    throw InputError("ROI: box '" + text + "' must be X0:X1,Y0:Y1,Z0:Z1 in mm");
  CropOptions o;
  o.xMm = parseRange(parts[0], "x", true);
  o.yMm = parseRange(parts[1], "y", true);
  o.zMm = parseRange(parts[2], "z", true);
  return o;
}

json roiJson(const CropOptions& options, const CropBox& box) {
  auto range = [](const std::optional<RangeMm>& r) {
    return r ? json::array({r->lo, r->hi}) : json(nullptr);
  };
  return {{"x", range(options.xMm)},
          {"y", range(options.yMm)},
          {"z", range(options.zMm)},
          {"first_voxel", {box.first[0], box.first[1], box.first[2]}},
          {"dims", {box.dims[0], box.dims[1], box.dims[2]}},
          {"input_dims", {box.inputDims[0], box.inputDims[1], box.inputDims[2]}}};
}

}  // namespace voxpack::stats
