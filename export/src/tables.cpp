// Particle tables out: CSV (spreadsheets, pose round trips) and legacy VTK points (ParaView
// glyphs), plus coordination numbers from the label field.
#include <algorithm>
#include <charconv>
#include <cmath>
#include <map>
#include <sstream>

#include "voxpack/core/atomic_file.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/export/formats.hpp"
#include "voxpack/packer/shape.hpp"

namespace voxpack::exporter {
namespace fs = std::filesystem;
namespace {

// Shortest round-trip text of a double (CSV poses must reproduce the bed exactly).
std::string num(double v) {
  if (!std::isfinite(v)) return "nan";
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

// Exact volume of each distinct spec (NaN when the shape cannot be built).
std::map<std::string, double> shapeVolumes(const ParticleTable& p) {
  std::map<std::string, double> v;
  for (const auto& s : p.shape) {
    if (v.count(s)) continue;
    try {
      v[s] = packer::parseShape(s)->volumeMm3();
    } catch (const Error&) {
      v[s] = std::nan("");
    }
  }
  return v;
}

std::string csvQuote(const std::string& s) {
  std::string q = "\"";
  for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}

}  // namespace

std::vector<int> labelCoordination(const Grid<std::uint32_t>& labels, std::size_t particles,
                                   int threads) {
  const Lattice& l = labels.lattice();
  // Pairs (a < b) from the three forward face neighbours of every voxel, per z slab; the
  // sorted, unique union is the same for any thread count.
  std::vector<std::vector<std::uint64_t>> perSlab(static_cast<std::size_t>(l.nz()));
#pragma omp parallel for schedule(dynamic, 4) num_threads(std::max(1, threads))
  for (std::int64_t k = 0; k < l.nz(); ++k) {
    auto& out = perSlab[static_cast<std::size_t>(k)];
    for (std::int64_t j = 0; j < l.ny(); ++j)
      for (std::int64_t i = 0; i < l.nx(); ++i) {
        const std::uint32_t a = labels(k, j, i);
        if (!a) continue;
        const std::uint32_t nb[3] = {i + 1 < l.nx() ? labels(k, j, i + 1) : 0u,
                                     j + 1 < l.ny() ? labels(k, j + 1, i) : 0u,
                                     k + 1 < l.nz() ? labels(k + 1, j, i) : 0u};
        for (std::uint32_t b : nb)
          if (b && b != a)
            out.push_back((static_cast<std::uint64_t>(std::min(a, b)) << 32) | std::max(a, b));
      }
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
  }
  std::vector<std::uint64_t> pairs;
  for (auto& s : perSlab) pairs.insert(pairs.end(), s.begin(), s.end());
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  std::vector<int> c(particles, 0);
  for (std::uint64_t p : pairs) {
    const std::uint64_t a = p >> 32, b = p & 0xffffffffu;
    if (a >= 1 && a <= particles) ++c[a - 1];
    if (b >= 1 && b <= particles) ++c[b - 1];
  }
  return c;
}

void writeParticleCsv(const ParticleTable& p, const fs::path& out) {
  if (p.empty())
    throw InputError("the bed has no particle table (/particles): nothing to write as CSV");
  const auto volumes = shapeVolumes(p);
  std::string s = "id,shape,x_mm,y_mm,z_mm,qw,qx,qy,qz,volume_mm3\n";
  s.reserve(p.size() * 160);
  for (std::size_t n = 0; n < p.size(); ++n) {
    const Vec3& c = p.positionMm[n];
    const Quat& q = p.orientation[n];
    const double v = volumes.at(p.shape[n]);
    s += std::to_string(n + 1) + ',' + csvQuote(p.shape[n]) + ',' + num(c.x()) + ',' + num(c.y()) +
         ',' + num(c.z()) + ',' + num(q.w()) + ',' + num(q.x()) + ',' + num(q.y()) + ',' +
         num(q.z()) + ',' + (std::isfinite(v) ? num(v) : std::string()) + '\n';
  }
  writeTextFileAtomic(out, s);
}

void writeParticleVtk(const ParticleTable& p, const ParticleFields& fields, const fs::path& out) {
  if (p.empty())
    throw InputError("the bed has no particle table (/particles): nothing to write as VTK");
  const std::size_t n = p.size();
  if ((!fields.coordinationLabels.empty() && fields.coordinationLabels.size() != n) ||
      (!fields.coordinationExact.empty() && fields.coordinationExact.size() != n))
    throw InternalError("writeParticleVtk: coordination arrays do not match the particles");
  const auto volumes = shapeVolumes(p);
  std::vector<std::string> specs;
  std::map<std::string, int> index;
  for (const auto& s : p.shape)
    if (index.emplace(s, static_cast<int>(specs.size())).second) specs.push_back(s);
  std::ostringstream f;
  f.precision(17);
  f << "# vtk DataFile Version 4.2\nvoxpack particles (centres, poses)\nASCII\nDATASET POLYDATA\n";
  // Shape specs as a dataset-level string array; VTK's legacy reader decodes %XX escapes.
  f << "FIELD FieldData 1\nshape_specs 1 " << specs.size() << " string\n";
  for (const auto& s : specs) {
    std::string e;
    for (char c : s) {
      if (c <= ' ' || c == '%') {
        char buf[4];
        std::snprintf(buf, sizeof buf, "%%%02X", static_cast<unsigned char>(c));
        e += buf;
      } else {
        e += c;
      }
    }
    f << e << '\n';
  }
  f << "POINTS " << n << " double\n";
  for (const auto& c : p.positionMm) f << c.x() << ' ' << c.y() << ' ' << c.z() << '\n';
  f << "VERTICES " << n << ' ' << 2 * n << '\n';
  for (std::size_t i = 0; i < n; ++i) f << "1 " << i << '\n';
  f << "POINT_DATA " << n << "\n";
  f << "SCALARS id int 1\nLOOKUP_TABLE default\n";
  for (std::size_t i = 0; i < n; ++i) f << i + 1 << '\n';
  f << "VECTORS axis double\n";
  for (const auto& q : p.orientation) {
    const Vec3 a = q.normalized() * Vec3::UnitZ();
    f << a.x() << ' ' << a.y() << ' ' << a.z() << '\n';
  }
  // The other arrays as point-data FIELD arrays: legacy readers load every FIELD array,
  // but only the first SCALARS block unless asked (vtkDataReader::ReadAllScalars).
  const int arrays = 3 + !fields.coordinationLabels.empty() + !fields.coordinationExact.empty();
  f << "FIELD PointArrays " << arrays << '\n';
  f << "shape 1 " << n << " int\n";
  for (const auto& s : p.shape) f << index[s] << '\n';
  f << "orientation 4 " << n << " double\n";
  for (const auto& q : p.orientation)
    f << q.w() << ' ' << q.x() << ' ' << q.y() << ' ' << q.z() << '\n';
  f << "volume_mm3 1 " << n << " double\n";
  for (const auto& s : p.shape) f << (std::isfinite(volumes.at(s)) ? volumes.at(s) : -1.0) << '\n';
  auto ints = [&](const char* name, const std::vector<int>& v) {
    if (v.empty()) return;
    f << name << " 1 " << n << " int\n";
    for (int c : v) f << c << '\n';
  };
  ints("coordination", fields.coordinationLabels);
  ints("coordination_exact", fields.coordinationExact);
  writeTextFileAtomic(out, f.str());
}

}  // namespace voxpack::exporter
