// Communicator: MPI_COMM_WORLD behind VOXPACK_MPI, one process otherwise (docs/scale.md).
#include "voxpack/core/communicator.hpp"

#include <algorithm>
#include <climits>
#include <cstdlib>

#ifdef VOXPACK_WITH_MPI
// The C API only (as hdf5.h does): OpenMPI's C++ bindings need libmpi_cxx.
#define OMPI_SKIP_MPICXX 1
#define MPICH_SKIP_MPICXX 1
#include <mpi.h>
#endif

namespace voxpack {

namespace {
#ifdef VOXPACK_WITH_MPI
// Started by a launcher: OpenMPI, PMIx or Slurm set these; a plain run stays one process
// and never touches MPI (no singleton start-up cost for the ordinary binary).
bool underLauncher() {
  for (const char* v : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_SIZE", "SLURM_NTASKS"})
    if (std::getenv(v)) return true;
  return false;
}
void finalizeAtExit() {
  int finalized = 0;
  MPI_Finalized(&finalized);
  if (!finalized) MPI_Finalize();
}
#endif
}  // namespace

Communicator& Communicator::world() {
  static Communicator c = [] {
    Communicator w;
#ifdef VOXPACK_WITH_MPI
    if (underLauncher()) {
      int initialized = 0;
      MPI_Initialized(&initialized);
      if (!initialized) {
        int provided = 0;
        MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided);
        std::atexit(finalizeAtExit);
      }
      MPI_Comm_rank(MPI_COMM_WORLD, &w.rank_);
      MPI_Comm_size(MPI_COMM_WORLD, &w.size_);
      w.mpi_ = true;
    }
#endif
    return w;
  }();
  return c;
}

void Communicator::sum(std::vector<double>& values) const {
#ifdef VOXPACK_WITH_MPI
  if (mpi_ && size_ > 1 && !values.empty())
    MPI_Allreduce(MPI_IN_PLACE, values.data(), static_cast<int>(values.size()), MPI_DOUBLE, MPI_SUM,
                  MPI_COMM_WORLD);
#else
  (void)values;
#endif
}

void Communicator::sum(std::vector<std::uint64_t>& values) const {
#ifdef VOXPACK_WITH_MPI
  if (mpi_ && size_ > 1 && !values.empty())
    MPI_Allreduce(MPI_IN_PLACE, values.data(), static_cast<int>(values.size()), MPI_UINT64_T,
                  MPI_SUM, MPI_COMM_WORLD);
#else
  (void)values;
#endif
}

bool Communicator::allTrue(bool value) const {
#ifdef VOXPACK_WITH_MPI
  if (mpi_ && size_ > 1) {
    int v = value ? 1 : 0;
    MPI_Allreduce(MPI_IN_PLACE, &v, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
    return v != 0;
  }
#endif
  return value;
}

std::int64_t Communicator::max(std::int64_t value) const {
#ifdef VOXPACK_WITH_MPI
  if (mpi_ && size_ > 1) {
    long long v = value;
    MPI_Allreduce(MPI_IN_PLACE, &v, 1, MPI_LONG_LONG, MPI_MAX, MPI_COMM_WORLD);
    return v;
  }
#endif
  return value;
}

void Communicator::receiveFromPrevious(std::vector<std::uint64_t>& values) const {
#ifdef VOXPACK_WITH_MPI
  if (mpi_ && rank_ > 0)
    MPI_Recv(values.data(), static_cast<int>(values.size()), MPI_UINT64_T, rank_ - 1, 0,
             MPI_COMM_WORLD, MPI_STATUS_IGNORE);
#else
  (void)values;
#endif
}

void Communicator::sendToNext(const std::vector<std::uint64_t>& values) const {
#ifdef VOXPACK_WITH_MPI
  if (mpi_ && rank_ + 1 < size_)
    MPI_Send(values.data(), static_cast<int>(values.size()), MPI_UINT64_T, rank_ + 1, 0,
             MPI_COMM_WORLD);
#else
  (void)values;
#endif
}

double Communicator::min(double value) const {
#ifdef VOXPACK_WITH_MPI
  if (mpi_ && size_ > 1)
    MPI_Allreduce(MPI_IN_PLACE, &value, 1, MPI_DOUBLE, MPI_MIN, MPI_COMM_WORLD);
#endif
  return value;
}

double Communicator::max(double value) const {
#ifdef VOXPACK_WITH_MPI
  if (mpi_ && size_ > 1)
    MPI_Allreduce(MPI_IN_PLACE, &value, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
#endif
  return value;
}

// Messages go in pieces below INT_MAX bytes (MPI counts are int); both ends cut alike.
void Communicator::sendBytes(int to, const void* data, std::size_t bytes) const {
#ifdef VOXPACK_WITH_MPI
  const auto* p = static_cast<const char*>(data);
  for (std::size_t done = 0; mpi_ && done < bytes;) {
    const std::size_t n = std::min<std::size_t>(bytes - done, INT_MAX / 2);
    MPI_Send(p + done, static_cast<int>(n), MPI_BYTE, to, 1, MPI_COMM_WORLD);
    done += n;
  }
#else
  (void)to, (void)data, (void)bytes;
#endif
}

void Communicator::receiveBytes(int from, void* data, std::size_t bytes) const {
#ifdef VOXPACK_WITH_MPI
  auto* p = static_cast<char*>(data);
  for (std::size_t done = 0; mpi_ && done < bytes;) {
    const std::size_t n = std::min<std::size_t>(bytes - done, INT_MAX / 2);
    MPI_Recv(p + done, static_cast<int>(n), MPI_BYTE, from, 1, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    done += n;
  }
#else
  (void)from, (void)data, (void)bytes;
#endif
}

void Communicator::abort(int code) const {
#ifdef VOXPACK_WITH_MPI
  if (mpi_) MPI_Abort(MPI_COMM_WORLD, code);
#endif
  std::_Exit(code);
}

}  // namespace voxpack
