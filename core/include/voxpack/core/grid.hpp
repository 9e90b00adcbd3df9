#pragma once
/// \file grid.hpp
/// Grid<T>: a dense voxel array over a Lattice, C-order [z][y][x].

#include <algorithm>
#include <span>
#include <vector>

#include "voxpack/core/lattice.hpp"

namespace voxpack {

/// Dense voxel array with its lattice geometry.
template <class T>
class Grid {
 public:
  Grid() = default;
  /// A grid over `lattice` with every voxel set to `fill`.
  explicit Grid(const Lattice& lattice, T fill = T{})
      : lattice_(lattice), data_(lattice.size(), fill) {}

  const Lattice& lattice() const { return lattice_; }  ///< geometry
  /// Replaces spacing/origin (dims must agree).
  void setLattice(const Lattice& l);
  std::size_t size() const { return data_.size(); }  ///< number of voxels
  bool empty() const { return data_.empty(); }       ///< true when no voxel

  T& operator()(std::int64_t k, std::int64_t j, std::int64_t i) {
    return data_[lattice_.offset(k, j, i)];
  }  ///< voxel (k, j, i)
  const T& operator()(std::int64_t k, std::int64_t j, std::int64_t i) const {
    return data_[lattice_.offset(k, j, i)];
  }  ///< voxel (k, j, i)
  T& operator[](std::size_t off) { return data_[off]; }              ///< by linear offset
  const T& operator[](std::size_t off) const { return data_[off]; }  ///< by linear offset

  T* data() { return data_.data(); }              ///< raw C-order storage
  const T* data() const { return data_.data(); }  ///< raw C-order storage
  std::vector<T>& values() { return data_; }      ///< the storage vector
  const std::vector<T>& values() const { return data_; }  ///< the storage vector
  void fill(T v) { std::fill(data_.begin(), data_.end(), v); }  ///< sets every voxel

 private:
  Lattice lattice_;
  std::vector<T> data_;
};

template <class T>
void Grid<T>::setLattice(const Lattice& l) {
  if (l.dims != lattice_.dims) throw std::logic_error("Grid::setLattice: dims differ");
  lattice_ = l;
}

}  // namespace voxpack
