#pragma once
/// \file convert.hpp
/// Conversions between the core types and Python objects for the voxpack module:
/// JSON <-> dict/list, numpy arrays <-> Grid, Bed <-> the dict the Python package wraps.

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <nlohmann/json.hpp>

#include "voxpack/core/bed.hpp"

namespace voxpack::python {

namespace py = pybind11;

/// JSON value as Python objects (null -> None, object -> dict, array -> list).
py::object jsonToPython(const nlohmann::json& j);

/// Python value (None, bool, int, float, str, list/tuple, dict, numpy scalars and arrays)
/// as JSON. Throws InputError for anything else.
nlohmann::json pythonToJson(py::handle h);

/// Lattice from a 3-D shape and (z, y, x) spacing/origin; validated (InputError).
Lattice makeLattice(const std::array<std::int64_t, 3>& dims, const std::array<double, 3>& spacingMm,
                    const std::array<double, 3>& originMm);

/// Copies a 3-D numpy array of exactly element type T (any strides: C, Fortran or a view)
/// into a C-order Grid over `lattice`. Throws InputError on a wrong dtype or shape.
/// Runs without the GIL for the copy itself (the caller keeps `array` alive).
template <class T>
Grid<T> gridFromArray(const py::array& array, const Lattice& lattice, const char* what);

/// The Bed described by the Python package's dict (indicator, mask, labels, spacing_mm,
/// origin_mm, particles, provenance). Arrays are copied into the Bed's grids.
Bed bedFromDict(const py::dict& d);

/// The dict of `bed` for the Python package. Volumes are moved, not copied: each numpy
/// array owns the storage vector of its Grid through a capsule.
py::dict bedToDict(Bed&& bed);

}  // namespace voxpack::python
