// Mesh shapes and mesh containers: STL reading, CGAL closedness/volume/area, inside tests
// (Side_of_triangle_mesh) and distances (AABB tree). CGAL stays inside this file.
#include <CGAL/AABB_face_graph_triangle_primitive.h>
#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/compute_normal.h>
#include <CGAL/Polygon_mesh_processing/measure.h>
#include <CGAL/Polygon_mesh_processing/orient_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/orientation.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Side_of_triangle_mesh.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/boost/graph/helpers.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>
#include <vector>

#include "mesh_internal.hpp"
#include "voxpack/core/errors.hpp"

namespace voxpack::packer {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using Mesh = CGAL::Surface_mesh<Point>;
using Side = CGAL::Side_of_triangle_mesh<Mesh, Kernel>;
using Tree = Side::AABB_tree;
namespace PMP = CGAL::Polygon_mesh_processing;

using Triangle = std::array<Vec3, 3>;

// Reads an ASCII or binary STL into triangles. A binary file is recognised by its size
// (84 + 50 n bytes); anything else must be ASCII "solid ... facet ... vertex x y z".
// Largest STL read (bytes): 10 M binary triangles, far more than CGAL handles in seconds.
constexpr std::uintmax_t kMaxStlBytes = std::uintmax_t{512} << 20;

std::vector<Triangle> readStl(const std::string& path) {
  // A device or FIFO (mesh:/dev/zero) would be read forever: regular files only, and a
  // size cap checked before reading.
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    throw IoError("mesh '" + path + "': no such regular file");
  const std::uintmax_t bytes = std::filesystem::file_size(path, ec);
  if (ec) throw IoError("mesh '" + path + "': cannot read its size");
  if (bytes > kMaxStlBytes)
    throw InputError("mesh '" + path + "': " + std::to_string(bytes) +
                     " bytes, more than the STL limit of 512 MiB");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw IoError("mesh '" + path + "': cannot open the file");
  std::string data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw IoError("mesh '" + path + "': read error");
  std::vector<Triangle> tris;
  if (data.size() >= 84) {
    std::uint32_t n = 0;
    std::memcpy(&n, data.data() + 80, 4);
    if (data.size() == 84 + 50 * static_cast<std::size_t>(n)) {
      tris.resize(n);
      for (std::uint32_t t = 0; t < n; ++t) {
        const char* rec = data.data() + 84 + 50 * static_cast<std::size_t>(t) + 12;
        for (int v = 0; v < 3; ++v) {
          float xyz[3];
          std::memcpy(xyz, rec + 12 * v, 12);
          tris[t][v] = Vec3(xyz[0], xyz[1], xyz[2]);
        }
      }
      return tris;
    }
  }
  const auto first = data.find_first_not_of(" \t\r\n");
  if (first == std::string::npos || data.compare(first, 5, "solid") != 0)
    throw InputError("mesh '" + path +
                     "': not an STL file (neither binary of the right size nor ASCII 'solid')");
  std::istringstream text(data);
  std::string word;
  std::vector<Vec3> verts;
  while (text >> word) {
    if (word != "vertex") continue;
    double x, y, z;
    if (!(text >> x >> y >> z))
      throw InputError("mesh '" + path + "': malformed ASCII STL (bad 'vertex' line)");
    verts.emplace_back(x, y, z);
  }
  if (verts.size() % 3 != 0)
    throw InputError("mesh '" + path + "': malformed ASCII STL (vertex count " +
                     std::to_string(verts.size()) + " is not a multiple of 3)");
  for (std::size_t v = 0; v + 2 < verts.size(); v += 3)
    tris.push_back({verts[v], verts[v + 1], verts[v + 2]});
  return tris;
}

// A closed, outward-oriented triangle mesh with its AABB tree and inside tester.
class MeshModel {
 public:
  MeshModel(const std::string& path, double scale, const Vec3& shift) : path_(path) {
    std::vector<Triangle> tris = readStl(path);
    if (tris.empty()) throw InputError("mesh '" + path + "': no triangles");
    std::vector<Point> points;
    std::vector<std::array<std::size_t, 3>> soup;
    std::map<std::array<double, 3>, std::size_t> index;
    for (const auto& t : tris) {
      std::array<std::size_t, 3> f{};
      for (int v = 0; v < 3; ++v) {
        const Vec3 p = t[v] * scale;
        if (!p.allFinite())
          throw InputError("mesh '" + path + "': a vertex coordinate is not finite");
        const std::array<double, 3> key{p.x(), p.y(), p.z()};
        const auto [it, fresh] = index.try_emplace(key, points.size());
        if (fresh) points.emplace_back(p.x(), p.y(), p.z());
        f[v] = it->second;
      }
      // Triangles that collapsed to an edge or point add no area and no volume.
      if (f[0] != f[1] && f[1] != f[2] && f[0] != f[2]) soup.push_back(f);
    }
    if (soup.empty()) throw InputError("mesh '" + path + "': every triangle is degenerate");
    if (!PMP::is_polygon_soup_a_polygon_mesh(soup)) PMP::orient_polygon_soup(points, soup);
    if (!PMP::is_polygon_soup_a_polygon_mesh(soup))
      throw InputError("mesh '" + path + "': not a manifold surface (edges shared by more than " +
                       "two triangles or inconsistent orientation)");
    PMP::polygon_soup_to_polygon_mesh(points, soup, mesh_);
    std::size_t border = 0;
    for (const auto h : halfedges(mesh_)) border += is_border(h, mesh_) ? 1 : 0;
    if (border > 0 || !CGAL::is_closed(mesh_))
      throw InputError("mesh '" + path + "': the surface is not closed (" + std::to_string(border) +
                       " border edges); a solid needs a closed mesh");
    if (!PMP::is_outward_oriented(mesh_)) PMP::reverse_face_orientations(mesh_);
    volume_ = PMP::volume(mesh_);
    area_ = PMP::area(mesh_);
    if (!(volume_ > 0) || !std::isfinite(volume_))
      throw InputError("mesh '" + path + "': encloses no volume");
    computeMoments();
    const Vec3 move = shift.allFinite() ? shift : Vec3(-centroid_);
    if (move != Vec3::Zero()) {
      for (const auto v : vertices(mesh_)) {
        const Point& p = mesh_.point(v);
        mesh_.point(v) = Point(p.x() + move.x(), p.y() + move.y(), p.z() + move.z());
      }
      centroid_ += move;
    }
    bounds_.min = Vec3::Constant(std::numeric_limits<double>::infinity());
    bounds_.max = -bounds_.min;
    radius_ = 0;
    for (const auto v : vertices(mesh_)) {
      const Point& p = mesh_.point(v);
      const Vec3 q(p.x(), p.y(), p.z());
      bounds_.min = bounds_.min.cwiseMin(q);
      bounds_.max = bounds_.max.cwiseMax(q);
      radius_ = std::max(radius_, q.norm());
    }
    tree_ = std::make_unique<Tree>(faces(mesh_).first, faces(mesh_).second, mesh_);
    tree_->build();
    tree_->accelerate_distance_queries();
    side_ = std::make_unique<Side>(*tree_);
  }

  const std::string& path() const { return path_; }
  double volume() const { return volume_; }
  double area() const { return area_; }
  double radius() const { return radius_; }
  const BoundsMm& bounds() const { return bounds_; }
  const Vec3& centroid() const { return centroid_; }
  const Eigen::Matrix3d& inertiaAboutCentroid() const { return inertia_; }

  bool inside(const Vec3& p) const {
    return (*side_)(Point(p.x(), p.y(), p.z())) != CGAL::ON_UNBOUNDED_SIDE;
  }
  // Unsigned distance and the closest surface point.
  double distance(const Vec3& p, Vec3& closest) const {
    const Point q(p.x(), p.y(), p.z());
    const Point c = tree_->closest_point(q);
    closest = Vec3(c.x(), c.y(), c.z());
    return (closest - p).norm();
  }
  double signedDistance(const Vec3& p) const {
    Vec3 c;
    const double d = distance(p, c);
    return inside(p) ? -d : d;
  }
  // Outward normal: away from the closest surface point, or the face normal on it.
  Vec3 outwardNormal(const Vec3& p) const {
    const Point q(p.x(), p.y(), p.z());
    const auto [c, face] = tree_->closest_point_and_primitive(q);
    const Vec3 cv(c.x(), c.y(), c.z());
    const Vec3 d = p - cv;
    const double n = d.norm();
    if (n > 1e-12 * std::max(radius_, 1.0)) return inside(p) ? Vec3(-d / n) : Vec3(d / n);
    const auto fn = PMP::compute_face_normal(face, mesh_);
    return Vec3(fn.x(), fn.y(), fn.z()).normalized();
  }

  // Row classification: the inside state only changes where the line crosses the
  // surface, so one inside query per run of samples between crossings suffices.
  void insideRow(const Vec3& p0, const Vec3& step, int n, std::uint8_t* out) const {
    if (n <= 0) return;
    // The segment runs from outside the (slightly grown) mesh box to outside it, so the
    // crossings' parity gives the inside state wherever every crossing is a clean
    // transversal hit (one triangle, a point, well separated from the others).
    double tLo = -1, tHi = n;
    const Vec3 grow = Vec3::Constant(1e-3 * std::max(radius_, 1e-9));
    bool clean = true;
    for (int ax = 0; ax < 3; ++ax) {
      const double lo = bounds_.min[ax] - grow[ax], hi = bounds_.max[ax] + grow[ax];
      if (std::abs(step[ax]) < 1e-300) {
        if (p0[ax] < lo || p0[ax] > hi) {
          std::fill(out, out + n, std::uint8_t{0});  // the row misses the mesh box
          return;
        }
        continue;
      }
      double u = (lo - p0[ax]) / step[ax], v = (hi - p0[ax]) / step[ax];
      if (u > v) std::swap(u, v);
      tLo = std::min(tLo, u - 1);
      tHi = std::max(tHi, v + 1);
    }
    const Vec3 a = p0 + tLo * step, b = p0 + tHi * step;
    const double len2 = (b - a).squaredNorm();
    std::vector<double> breaks;
    if (len2 > 0) {
      using Segment = Kernel::Segment_3;
      const Segment seg(Point(a.x(), a.y(), a.z()), Point(b.x(), b.y(), b.z()));
      using Hit = Tree::Intersection_and_primitive_id<Segment>::Type;
      std::vector<boost::optional<Hit>> hits;
      tree_->all_intersections(seg, std::back_inserter(hits));
      const auto toSample = [&](const Point& q) {
        const Vec3 v(q.x() - a.x(), q.y() - a.y(), q.z() - a.z());
        return tLo + v.dot(b - a) / len2 * (tHi - tLo);
      };
      for (const auto& h : hits) {
        if (!h) continue;
        if (const Point* q = boost::get<Point>(&h->first)) {
          breaks.push_back(toSample(*q));
        } else if (const Segment* sg = boost::get<Segment>(&h->first)) {
          breaks.push_back(toSample(sg->source()));
          breaks.push_back(toSample(sg->target()));
          clean = false;  // the line runs inside a triangle's plane
        }
      }
      std::sort(breaks.begin(), breaks.end());
    } else {
      clean = false;
    }
    const double eps = 1e-6;
    // Hits on shared edges or vertices appear twice (or tangentially): no parity then.
    for (std::size_t k = 1; k < breaks.size() && clean; ++k)
      if (breaks[k] - breaks[k - 1] <= eps) clean = false;
    const auto classify = [&](int s) {
      return inside(p0 + static_cast<double>(s) * step) ? std::uint8_t{1} : std::uint8_t{0};
    };
    std::size_t bi = 0;
    int s = 0;
    while (s < n) {
      while (bi < breaks.size() && breaks[bi] < s - eps) ++bi;
      if (bi < breaks.size() && std::abs(breaks[bi] - s) <= eps) {
        out[s] = classify(s);  // a sample on the surface itself
        ++s;
        continue;
      }
      int e = n - 1;
      if (bi < breaks.size()) e = std::min(e, static_cast<int>(std::ceil(breaks[bi] - eps)) - 1);
      e = std::max(e, s);
      // bi crossings lie before sample s (none within eps of it).
      const std::uint8_t v = clean ? static_cast<std::uint8_t>(bi & 1) : classify(s + (e - s) / 2);
      std::fill(out + s, out + e + 1, v);
      s = e + 1;
    }
  }

 private:
  // Volume integrals over the tetrahedra (origin, a, b, c) of the outward faces.
  void computeMoments() {
    double vol = 0;
    Vec3 first = Vec3::Zero();
    Eigen::Matrix3d second = Eigen::Matrix3d::Zero();
    for (const auto f : faces(mesh_)) {
      std::array<Vec3, 3> v;
      int n = 0;
      for (const auto x : vertices_around_face(halfedge(f, mesh_), mesh_)) {
        const Point& p = mesh_.point(x);
        v[static_cast<std::size_t>(n++)] = Vec3(p.x(), p.y(), p.z());
      }
      const double tv = v[0].dot(v[1].cross(v[2])) / 6;
      const Vec3 sum = v[0] + v[1] + v[2];
      vol += tv;
      first += tv * sum / 4;
      second += tv / 20 *
                (v[0] * v[0].transpose() + v[1] * v[1].transpose() + v[2] * v[2].transpose() +
                 sum * sum.transpose());
    }
    centroid_ = first / vol;
    const Eigen::Matrix3d c = second - vol * centroid_ * centroid_.transpose();
    inertia_ = c.trace() * Eigen::Matrix3d::Identity() - c;
  }

  std::string path_;
  Mesh mesh_;
  double volume_ = 0, area_ = 0, radius_ = 0;
  BoundsMm bounds_;
  Vec3 centroid_ = Vec3::Zero();
  Eigen::Matrix3d inertia_ = Eigen::Matrix3d::Zero();
  std::unique_ptr<Tree> tree_;
  std::unique_ptr<Side> side_;
};

class MeshShape final : public Shape {
 public:
  MeshShape(const std::string& path, double scale)
      : model_(path, scale, Vec3::Constant(std::numeric_limits<double>::quiet_NaN())),
        scale_(scale) {}
  std::string spec() const override {
    return "mesh:" + model_.path() + (scale_ != 1.0 ? ",scale=" + formatNumber(scale_) : "");
  }
  double volumeMm3() const override { return model_.volume(); }
  double surfaceMm2() const override { return model_.area(); }
  double boundingRadiusMm() const override { return model_.radius(); }
  bool inside(const Vec3& p) const override { return model_.inside(p); }
  void insideRow(const Vec3& p0, const Vec3& step, int n, std::uint8_t* out) const override {
    model_.insideRow(p0, step, n, out);
  }
  double signedDistanceMm(const Vec3& p) const override { return model_.signedDistance(p); }
  Vec3 normal(const Vec3& p) const override { return model_.outwardNormal(p); }
  Eigen::Matrix3d inertiaPerDensity() const override { return model_.inertiaAboutCentroid(); }
  double characteristicDiameterMm() const override {
    return (model_.bounds().max - model_.bounds().min).maxCoeff();
  }
  BoundsMm bodyBoundsMm() const override { return model_.bounds(); }

 private:
  MeshModel model_;
  double scale_;
};

class MeshContainer final : public Container {
 public:
  MeshContainer(const std::string& path, double scale)
      : model_(path, scale, Vec3::Zero()), scale_(scale) {}
  std::string spec() const override {
    return "mesh:" + model_.path() + (scale_ != 1.0 ? ",scale=" + formatNumber(scale_) : "");
  }
  bool inside(const Vec3& p) const override { return model_.inside(p); }
  void insideRow(const Vec3& p0, const Vec3& step, int n, std::uint8_t* out) const override {
    model_.insideRow(p0, step, n, out);
  }
  double wallDistanceMm(const Vec3& p) const override { return -model_.signedDistance(p); }
  Vec3 inwardNormal(const Vec3& p) const override { return -model_.outwardNormal(p); }
  BoundsMm boundsMm() const override { return model_.bounds(); }
  double volumeMm3() const override { return model_.volume(); }

 private:
  MeshModel model_;
  double scale_;
};

}  // namespace

std::shared_ptr<const Shape> meshShape(const std::string& stlPath, double scale) {
  if (!(scale > 0) || !std::isfinite(scale))
    throw InputError("mesh '" + stlPath + "': scale must be a positive number");
  return std::make_shared<MeshShape>(stlPath, scale);
}

std::shared_ptr<const Container> makeMeshContainer(const std::string& stlPath, double scale) {
  if (!(scale > 0) || !std::isfinite(scale))
    throw InputError("mesh '" + stlPath + "': scale must be a positive number");
  return std::make_shared<MeshContainer>(stlPath, scale);
}

}  // namespace voxpack::packer
