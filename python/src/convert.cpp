// Conversions between core types and Python objects (convert.hpp). Volumes cross the
// boundary at most once: numpy -> Grid is one strided copy (core Grids own a std::vector,
// so a caller's buffer cannot be adopted), Grid -> numpy is a move of the vector into a
// capsule (no copy).
#include "convert.hpp"

#include <pybind11/stl.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "voxpack/core/errors.hpp"

namespace voxpack::python {

py::object jsonToPython(const nlohmann::json& j) {
  switch (j.type()) {
    case nlohmann::json::value_t::null:
    case nlohmann::json::value_t::discarded:
      return py::none();
    case nlohmann::json::value_t::boolean:
      return py::bool_(j.get<bool>());
    case nlohmann::json::value_t::number_integer:
      return py::int_(j.get<std::int64_t>());
    case nlohmann::json::value_t::number_unsigned:
      return py::int_(j.get<std::uint64_t>());
    case nlohmann::json::value_t::number_float:
      return py::float_(j.get<double>());
    case nlohmann::json::value_t::string:
      return py::str(j.get_ref<const std::string&>());
    case nlohmann::json::value_t::array: {
      py::list out;
      for (const auto& e : j) out.append(jsonToPython(e));
      return out;
    }
    case nlohmann::json::value_t::object: {
      py::dict out;
      for (const auto& [k, v] : j.items()) out[py::str(k)] = jsonToPython(v);
      return out;
    }
    case nlohmann::json::value_t::binary:
      break;
  }
  throw InternalError("jsonToPython: binary JSON values are not produced by voxpack");
}

nlohmann::json pythonToJson(py::handle h) {
  if (h.is_none()) return nullptr;
  if (py::isinstance<py::bool_>(h)) return h.cast<bool>();
  if (py::isinstance<py::int_>(h)) {
    // Python ints are unbounded: int64, then uint64, else refused (no silent rounding).
    try {
      return h.cast<std::int64_t>();
    } catch (const py::cast_error&) {
    }
    try {
      return h.cast<std::uint64_t>();
    } catch (const py::cast_error&) {
    }
    throw InputError("integer " + py::str(h).cast<std::string>() + " does not fit 64 bits");
  }
  if (py::isinstance<py::float_>(h)) return h.cast<double>();
  if (py::isinstance<py::str>(h)) return h.cast<std::string>();
  if (py::isinstance<py::bytes>(h)) return h.cast<std::string>();
  if (py::isinstance<py::dict>(h)) {
    nlohmann::json out = nlohmann::json::object();
    for (auto [k, v] : h.cast<py::dict>()) out[py::str(k).cast<std::string>()] = pythonToJson(v);
    return out;
  }
  if (py::isinstance<py::list>(h) || py::isinstance<py::tuple>(h)) {
    nlohmann::json out = nlohmann::json::array();
    for (auto v : h) out.push_back(pythonToJson(v));
    return out;
  }
  // numpy scalars and arrays: through their Python equivalents.
  if (py::hasattr(h, "tolist")) return pythonToJson(h.attr("tolist")());
  throw InputError("cannot store a " +
                   py::str(py::type::handle_of(h).attr("__name__")).cast<std::string>() +
                   " in JSON (use None, bool, int, float, str, list or dict)");
}

Lattice makeLattice(const std::array<std::int64_t, 3>& dims, const std::array<double, 3>& spacingMm,
                    const std::array<double, 3>& originMm) {
  Lattice l;
  l.dims = dims;
  l.spacingMm = spacingMm;
  l.originMm = originMm;
  l.validate("array lattice");
  return l;
}

template <class T>
Grid<T> gridFromArray(const py::array& array, const Lattice& lattice, const char* what) {
  if (!py::isinstance<py::array_t<T>>(array))
    throw InputError(std::string(what) + ": expected dtype " +
                     py::str(py::dtype::of<T>()).cast<std::string>() + ", got " +
                     py::str(array.dtype()).cast<std::string>());
  if (array.ndim() != 3)
    throw InputError(std::string(what) + ": expected a 3-D array [z][y][x], got " +
                     std::to_string(array.ndim()) + " dimensions");
  for (int a = 0; a < 3; ++a)
    if (array.shape(a) != lattice.dims[static_cast<std::size_t>(a)])
      throw InputError(std::string(what) + ": shape differs from the indicator's");
  Grid<T> g(lattice);
  const char* base = static_cast<const char*>(array.data());
  const std::array<py::ssize_t, 3> st{array.strides(0), array.strides(1), array.strides(2)};
  const bool contiguous = (array.flags() & py::array::c_style) != 0;
  const auto nz = lattice.nz(), ny = lattice.ny(), nx = lattice.nx();
  T* out = g.data();
  py::gil_scoped_release nogil;
  if (contiguous) {
    std::memcpy(out, base, g.size() * sizeof(T));
    return g;
  }
  // Any strides (Fortran order, slices, negative steps): element by element, rows of
  // unit stride by memcpy.
  for (std::int64_t k = 0; k < nz; ++k)
    for (std::int64_t j = 0; j < ny; ++j) {
      const char* row = base + k * st[0] + j * st[1];
      T* dst = out + lattice.offset(k, j, 0);
      if (st[2] == static_cast<py::ssize_t>(sizeof(T))) {
        std::memcpy(dst, row, static_cast<std::size_t>(nx) * sizeof(T));
      } else {
        for (std::int64_t i = 0; i < nx; ++i) std::memcpy(dst + i, row + i * st[2], sizeof(T));
      }
    }
  return g;
}

template Grid<std::uint8_t> gridFromArray(const py::array&, const Lattice&, const char*);
template Grid<std::uint32_t> gridFromArray(const py::array&, const Lattice&, const char*);

namespace {

std::array<double, 3> triple(py::handle h, const char* what) {
  const auto v = h.cast<std::vector<double>>();
  if (v.size() != 3) throw InputError(std::string(what) + ": expected 3 numbers (z, y, x)");
  return {v[0], v[1], v[2]};
}

// numpy array that owns `values` (moved onto the heap; the capsule frees it).
template <class T>
py::array ownedArray(std::vector<T>&& values, const std::vector<py::ssize_t>& shape) {
  auto* heap = new std::vector<T>(std::move(values));
  py::capsule owner(heap, [](void* p) { delete static_cast<std::vector<T>*>(p); });
  return py::array_t<T>(shape, heap->data(), owner);
}

template <class T>
py::array volume(Grid<T>&& g) {
  const Lattice l = g.lattice();
  return ownedArray(std::move(g.values()), {l.dims[0], l.dims[1], l.dims[2]});
}

py::array_t<double> matrixColumns(py::handle h, py::ssize_t cols, const char* what) {
  auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(h);
  if (!a || a.ndim() != 2 || a.shape(1) != cols)
    throw InputError(std::string(what) + ": expected an array of shape [N," + std::to_string(cols) +
                     "]");
  return a;
}

}  // namespace

Bed bedFromDict(const py::dict& d) {
  const py::array indicator = d["indicator"].cast<py::array>();
  if (indicator.ndim() != 3)
    throw InputError("indicator: expected a 3-D array [z][y][x], got " +
                     std::to_string(indicator.ndim()) + " dimensions");
  const Lattice lattice =
      makeLattice({indicator.shape(0), indicator.shape(1), indicator.shape(2)},
                  triple(d["spacing_mm"], "spacing_mm"), triple(d["origin_mm"], "origin_mm"));
  Bed bed;
  bed.indicator = gridFromArray<std::uint8_t>(indicator, lattice, "indicator");
  if (d.contains("mask") && !d["mask"].is_none())
    bed.mask = gridFromArray<std::uint8_t>(d["mask"].cast<py::array>(), lattice, "mask");
  if (d.contains("labels") && !d["labels"].is_none())
    bed.labels = gridFromArray<std::uint32_t>(d["labels"].cast<py::array>(), lattice, "labels");
  if (d.contains("particles") && !d["particles"].is_none()) {
    const py::dict p = d["particles"].cast<py::dict>();
    if (p.contains("position_mm")) {
      const auto pos = matrixColumns(p["position_mm"], 3, "particles['position_mm']");
      const auto r = pos.unchecked<2>();
      for (py::ssize_t n = 0; n < r.shape(0); ++n)
        bed.particles.positionMm.emplace_back(r(n, 0), r(n, 1), r(n, 2));
    }
    if (p.contains("orientation")) {
      const auto q = matrixColumns(p["orientation"], 4, "particles['orientation']");
      const auto r = q.unchecked<2>();
      for (py::ssize_t n = 0; n < r.shape(0); ++n)
        bed.particles.orientation.emplace_back(r(n, 0), r(n, 1), r(n, 2), r(n, 3));
    }
    if (p.contains("shape"))
      for (auto s : p["shape"]) bed.particles.shape.push_back(py::str(s).cast<std::string>());
  }
  if (d.contains("provenance") && !d["provenance"].is_none())
    bed.provenance = pythonToJson(d["provenance"]);
  bed.validate();
  return bed;
}

py::dict bedToDict(Bed&& bed) {
  py::dict d;
  const Lattice l = bed.lattice();
  d["spacing_mm"] = py::make_tuple(l.spacingMm[0], l.spacingMm[1], l.spacingMm[2]);
  d["origin_mm"] = py::make_tuple(l.originMm[0], l.originMm[1], l.originMm[2]);
  d["indicator"] = volume(std::move(bed.indicator));
  d["mask"] = bed.mask ? py::object(volume(std::move(*bed.mask))) : py::none();
  d["labels"] = bed.labels ? py::object(volume(std::move(*bed.labels))) : py::none();
  py::dict particles;
  const auto& p = bed.particles;
  if (!p.empty()) {
    const auto n = static_cast<py::ssize_t>(p.size());
    std::vector<double> pos;
    pos.reserve(p.size() * 3);
    for (const Vec3& v : p.positionMm) pos.insert(pos.end(), {v.x(), v.y(), v.z()});
    particles["position_mm"] = ownedArray(std::move(pos), {n, 3});
    if (!p.orientation.empty()) {
      std::vector<double> q;
      q.reserve(p.size() * 4);
      for (const Quat& o : p.orientation) q.insert(q.end(), {o.w(), o.x(), o.y(), o.z()});
      particles["orientation"] = ownedArray(std::move(q), {n, 4});
    }
    if (!p.shape.empty()) particles["shape"] = py::cast(p.shape);
  }
  d["particles"] = particles;
  d["provenance"] = jsonToPython(bed.provenance);
  return d;
}

}  // namespace voxpack::python
