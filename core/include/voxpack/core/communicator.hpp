#pragma once
/// \file communicator.hpp
/// The ranks a streamed command (stats, info, ingest) is spread over: MPI_COMM_WORLD in an MPI
/// build started by mpirun, else one process. Only sums of integer counts are reduced (and a carry
/// of integers passed from rank to rank), so the result is the same for any number of ranks
/// (docs/scale.md).

#include <cstddef>
#include <cstdint>
#include <vector>

namespace voxpack {

/// One process, or the ranks of an MPI run.
class Communicator {
 public:
  /// The world: initialises MPI (once, finalised at exit) when this is an MPI build run
  /// under mpirun/srun with more than one process... or a single rank otherwise.
  static Communicator& world();
  int rank() const { return rank_; }  ///< this rank (0 on one process)
  int size() const { return size_; }  ///< number of ranks (1 on one process)
  /// True when the file should be opened through parallel HDF5 (MPI active).
  bool parallel() const { return mpi_; }
  /// Element-wise sum over ranks, in place on every rank.
  void sum(std::vector<double>& values) const;
  /// Element-wise sum over ranks, in place on every rank.
  void sum(std::vector<std::uint64_t>& values) const;
  /// Logical AND over ranks.
  bool allTrue(bool value) const;
  /// Largest value over ranks.
  std::int64_t max(std::int64_t value) const;
  /// Fills `values` (its size is the count) from rank − 1; rank 0 leaves it as it is.
  /// With sendToNext, passes a carry along the ranks in order (chord runs along z).
  void receiveFromPrevious(std::vector<std::uint64_t>& values) const;
  /// Sends `values` to rank + 1; the last rank sends nothing.
  void sendToNext(const std::vector<std::uint64_t>& values) const;
  /// Smallest value over ranks.
  double min(double value) const;
  /// Largest value over ranks.
  double max(double value) const;
  /// Sends `bytes` bytes to rank `to` (blocking; any size).
  void sendBytes(int to, const void* data, std::size_t bytes) const;
  /// Receives `bytes` bytes from rank `from` (blocking; any size).
  void receiveBytes(int from, void* data, std::size_t bytes) const;
  /// Ends every rank with `code` after one rank failed (no rank is left waiting).
  [[noreturn]] void abort(int code) const;

 private:
  Communicator() = default;
  int rank_ = 0, size_ = 1;
  bool mpi_ = false;
};

}  // namespace voxpack
