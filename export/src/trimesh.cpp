// Indexed triangle meshes: volume, closedness, components, STL/OBJ input and output.
#include "voxpack/export/trimesh.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <numeric>
#include <sstream>
#include <unordered_map>

#include "voxpack/core/atomic_file.hpp"
#include "voxpack/core/errors.hpp"

namespace voxpack::exporter {
namespace fs = std::filesystem;

void TriMesh::append(const TriMesh& other) {
  const auto base = static_cast<std::uint32_t>(vertices.size());
  vertices.insert(vertices.end(), other.vertices.begin(), other.vertices.end());
  for (const auto& t : other.triangles)
    triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
}

double enclosedVolumeMm3(const TriMesh& m) {
  // Signed tetrahedra to the first vertex (not the origin) keeps the terms small.
  if (m.vertices.empty()) return 0.0;
  const Vec3 o = m.vertices[0];
  double v = 0;
  for (const auto& t : m.triangles) {
    const Vec3 a = m.vertices[t[0]] - o, b = m.vertices[t[1]] - o, c = m.vertices[t[2]] - o;
    v += a.dot(b.cross(c));
  }
  return v / 6.0;
}

bool isClosedManifold(const TriMesh& m) {
  // Every directed edge once, and its reverse once.
  std::vector<std::uint64_t> directed;
  directed.reserve(m.triangles.size() * 3);
  for (const auto& t : m.triangles) {
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) return false;
    for (int e = 0; e < 3; ++e)
      directed.push_back((static_cast<std::uint64_t>(t[e]) << 32) | t[(e + 1) % 3]);
  }
  std::sort(directed.begin(), directed.end());
  if (std::adjacent_find(directed.begin(), directed.end()) != directed.end()) return false;
  for (std::uint64_t e : directed) {
    const std::uint64_t rev = (e << 32) | (e >> 32);
    if (!std::binary_search(directed.begin(), directed.end(), rev)) return false;
  }
  return !m.triangles.empty();
}

std::size_t connectedComponents(const TriMesh& m) {
  std::vector<std::uint32_t> parent(m.vertices.size());
  std::iota(parent.begin(), parent.end(), 0u);
  auto find = [&](std::uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (const auto& t : m.triangles)
    for (int e = 1; e < 3; ++e) parent[find(t[e])] = find(t[0]);
  std::vector<char> used(m.vertices.size(), 0);
  for (const auto& t : m.triangles) used[t[0]] = 1;
  std::size_t n = 0;
  for (std::uint32_t v = 0; v < parent.size(); ++v)
    if (used[v] && find(v) == v) ++n;
  return n;
}

namespace {

struct FloatKey {
  float x, y, z;
  bool operator==(const FloatKey& o) const { return x == o.x && y == o.y && z == o.z; }
};
struct FloatKeyHash {
  std::size_t operator()(const FloatKey& k) const {
    std::uint32_t a, b, c;
    std::memcpy(&a, &k.x, 4);
    std::memcpy(&b, &k.y, 4);
    std::memcpy(&c, &k.z, 4);
    return (static_cast<std::size_t>(a) * 73856093u) ^ (static_cast<std::size_t>(b) * 19349663u) ^
           (static_cast<std::size_t>(c) * 83492791u);
  }
};

TriMesh weld(const std::vector<std::array<float, 9>>& soup) {
  TriMesh m;
  std::unordered_map<FloatKey, std::uint32_t, FloatKeyHash> index;
  for (const auto& t : soup) {
    std::array<std::uint32_t, 3> tri{};
    for (int c = 0; c < 3; ++c) {
      const FloatKey k{t[3 * c], t[3 * c + 1], t[3 * c + 2]};
      auto it = index.find(k);
      if (it == index.end()) {
        it = index.emplace(k, static_cast<std::uint32_t>(m.vertices.size())).first;
        m.vertices.emplace_back(k.x, k.y, k.z);
      }
      tri[c] = it->second;
    }
    if (tri[0] != tri[1] && tri[1] != tri[2] && tri[0] != tri[2]) m.triangles.push_back(tri);
  }
  return m;
}

}  // namespace

TriMesh readStl(const fs::path& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw IoError(path.string() + ": cannot open");
  std::string bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  std::vector<std::array<float, 9>> soup;
  bool binary = false;
  if (bytes.size() >= 84) {
    std::uint32_t n = 0;
    std::memcpy(&n, bytes.data() + 80, 4);
    binary = bytes.size() == 84 + 50ull * n;
    if (binary) {
      soup.resize(n);
      for (std::uint32_t t = 0; t < n; ++t)
        std::memcpy(soup[t].data(), bytes.data() + 84 + 50ull * t + 12, 36);
    }
  }
  if (!binary) {
    std::istringstream in(bytes);
    std::string word;
    std::array<float, 9> tri{};
    int corner = 0;
    while (in >> word) {
      if (word != "vertex") continue;
      float x, y, z;
      if (!(in >> x >> y >> z)) throw FormatError(path.string() + ": bad vertex line");
      tri[3 * corner] = x;
      tri[3 * corner + 1] = y;
      tri[3 * corner + 2] = z;
      if (++corner == 3) {
        soup.push_back(tri);
        corner = 0;
      }
    }
  }
  if (soup.empty()) throw FormatError(path.string() + ": no triangles");
  return weld(soup);
}

namespace {

void writeFloat(std::string& s, double v, int digits) {
  char buf[40];
  const int n = std::snprintf(buf, sizeof buf, "%.*g", digits, v);
  s.append(buf, static_cast<std::size_t>(n));
}

void flush(std::ofstream& f, std::string& buf, const fs::path& p) {
  f.write(buf.data(), static_cast<std::streamsize>(buf.size()));
  if (!f) throw IoError(p.string() + ": write failed");
  buf.clear();
}

}  // namespace

void writeStl(const std::vector<NamedMesh>& solids, const fs::path& out, int digits) {
  AtomicOutput atomic(out);
  std::ofstream f(atomic.tempPath(), std::ios::binary);
  if (!f) throw IoError(out.string() + ": cannot create");
  std::string buf;
  buf.reserve(1 << 20);
  for (const auto& s : solids) {
    buf += "solid " + s.name + '\n';
    for (const auto& t : s.mesh.triangles) {
      const Vec3& a = s.mesh.vertices[t[0]];
      const Vec3& b = s.mesh.vertices[t[1]];
      const Vec3& c = s.mesh.vertices[t[2]];
      Vec3 nrm = (b - a).cross(c - a);
      const double len = nrm.norm();
      if (len > 0) nrm /= len;
      buf += "facet normal ";
      for (int d = 0; d < 3; ++d) {
        writeFloat(buf, nrm[d], 9);
        buf += d < 2 ? ' ' : '\n';
      }
      buf += "outer loop\n";
      for (const Vec3* v : {&a, &b, &c}) {
        buf += "vertex ";
        for (int d = 0; d < 3; ++d) {
          writeFloat(buf, (*v)[d], digits);
          buf += d < 2 ? ' ' : '\n';
        }
      }
      buf += "endloop\nendfacet\n";
      if (buf.size() > (1 << 20)) flush(f, buf, out);
    }
    buf += "endsolid " + s.name + '\n';
  }
  flush(f, buf, out);
  f.close();
  if (!f) throw IoError(out.string() + ": write failed");
  atomic.commit();
}

void writeObj(const std::vector<NamedMesh>& solids, const fs::path& out, int digits) {
  AtomicOutput atomic(out);
  std::ofstream f(atomic.tempPath(), std::ios::binary);
  if (!f) throw IoError(out.string() + ": cannot create");
  std::string buf = "# voxpack export: one object per solid, mm\n";
  std::size_t base = 1;
  for (const auto& s : solids) {
    buf += "o " + s.name + '\n';
    for (const Vec3& v : s.mesh.vertices) {
      buf += "v ";
      for (int d = 0; d < 3; ++d) {
        writeFloat(buf, v[d], digits);
        buf += d < 2 ? ' ' : '\n';
      }
      if (buf.size() > (1 << 20)) flush(f, buf, out);
    }
    for (const auto& t : s.mesh.triangles) {
      buf += "f " + std::to_string(t[0] + base) + ' ' + std::to_string(t[1] + base) + ' ' +
             std::to_string(t[2] + base) + '\n';
      if (buf.size() > (1 << 20)) flush(f, buf, out);
    }
    base += s.mesh.vertices.size();
  }
  flush(f, buf, out);
  f.close();
  if (!f) throw IoError(out.string() + ": write failed");
  atomic.commit();
}

}  // namespace voxpack::exporter
