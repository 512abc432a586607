// The Communicator on Open MPI (MPI_COMM_WORLD), or — in a build without MPI (mk/mpi.mk did not
// find mpicxx) — a launch_communicator() that says how to get it. Only this file includes mpi.h,
// so the rest of the tools and the runtime never depend on MPI.
#include "tools/train/communicator.h"

#include <cstdio>
#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <new>

#include "tools/common/error.h"

namespace dp::train {

bool launched_by_mpi_launcher() {
  // Open MPI's mpirun, then PMIx/PMI launchers (Slurm srun, Hydra): each exports the job size.
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMIX_SIZE", "PMI_SIZE", "SLURM_NTASKS"}) {
    if (std::strcmp(name, "SLURM_NTASKS") == 0 && std::getenv("PMI_RANK") == nullptr &&
        std::getenv("PMIX_RANK") == nullptr)
      continue;  // inside an sbatch allocation but not a task started by srun
    const char* v = std::getenv(name);
    if (v && std::atoi(v) > 1) return true;
  }
  return false;
}

int run_maybe_distributed(const std::string& tool, int argc, char** argv,
                          int (*main)(int argc, char** argv, Communicator* comm)) {
  bool distributed = launched_by_mpi_launcher();
  for (int i = 1; i < argc; ++i) distributed = distributed || std::strcmp(argv[i], "--distributed") == 0;
  if (!distributed) return main(argc, argv, nullptr);
  std::unique_ptr<Communicator> comm = launch_communicator(tool);
  try {
    return main(argc, argv, comm.get());
  } catch (const std::bad_alloc&) {
    comm->abort(tool + ": out of memory (this rank's share of the work must fit in its machine's memory)");
  } catch (const std::exception& e) {
    comm->abort(tool + ": " + e.what());
  }
  return 1;  // not reached: abort() ends the process
}

}  // namespace dp::train

#if defined(DP_HAVE_MPI)
#include <mpi.h>

namespace dp::train {
namespace {

class MpiCommunicator final : public Communicator {
 public:
  MpiCommunicator() {
    int initialized = 0;
    MPI_Initialized(&initialized);
    if (!initialized) {
      // FUNNELED: only the calling thread makes MPI calls; the worker threads only compute.
      int provided = 0;
      MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided);
      owns_init_ = true;
    }
    MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
    MPI_Comm_size(MPI_COMM_WORLD, &size_);
  }
  ~MpiCommunicator() override {
    if (owns_init_) MPI_Finalize();
  }
  int rank() const override { return rank_; }
  int size() const override { return size_; }
  void sum(uint32_t* data, size_t count) override { reduce(data, count, MPI_UINT32_T); }
  void sum(int64_t* data, size_t count) override { reduce(data, count, MPI_INT64_T); }

  std::vector<std::vector<uint8_t>> gather(const std::vector<uint8_t>& mine) override {
    if (mine.size() > size_t(std::numeric_limits<int>::max()))
      abort("a gathered message of " + std::to_string(mine.size()) + " bytes exceeds MPI's int count");
    const int n = static_cast<int>(mine.size());
    std::vector<int> sizes(rank_ == 0 ? size_ : 0), displs(sizes.size());
    MPI_Gather(&n, 1, MPI_INT, sizes.data(), 1, MPI_INT, 0, MPI_COMM_WORLD);
    std::vector<uint8_t> all;
    if (rank_ == 0) {
      size_t total = 0;
      for (int r = 0; r < size_; ++r) {
        displs[r] = static_cast<int>(total);
        total += size_t(sizes[r]);
      }
      if (total > size_t(std::numeric_limits<int>::max()))
        abort("gathered messages of " + std::to_string(total) + " bytes exceed MPI's int displacements");
      all.resize(total);
    }
    MPI_Gatherv(mine.data(), n, MPI_BYTE, all.data(), sizes.data(), displs.data(), MPI_BYTE, 0, MPI_COMM_WORLD);
    std::vector<std::vector<uint8_t>> out;
    for (int r = 0; rank_ == 0 && r < size_; ++r)
      out.emplace_back(all.begin() + displs[r], all.begin() + displs[r] + sizes[r]);
    return out;
  }

  void broadcast(std::vector<uint8_t>& data) override {
    if (data.size() > size_t(std::numeric_limits<int>::max()))
      abort("a broadcast of " + std::to_string(data.size()) + " bytes exceeds MPI's int count");
    int n = static_cast<int>(data.size());
    MPI_Bcast(&n, 1, MPI_INT, 0, MPI_COMM_WORLD);
    data.resize(size_t(n));
    MPI_Bcast(data.data(), n, MPI_BYTE, 0, MPI_COMM_WORLD);
  }
  void barrier() override { MPI_Barrier(MPI_COMM_WORLD); }

  std::vector<std::vector<uint8_t>> exchange(const std::vector<std::vector<uint8_t>>& parts) override {
    if (parts.size() != size_t(size_))
      abort("exchange() got " + std::to_string(parts.size()) + " parts for " + std::to_string(size_) + " ranks");
    const auto start = std::chrono::steady_clock::now();
    std::vector<int> send_counts(size_), send_displs(size_), recv_counts(size_), recv_displs(size_);
    std::vector<uint8_t> sent = concatenate(parts, send_counts, send_displs);
    for (int r = 0; r < size_; ++r)
      if (r != rank_) bytes_exchanged_ += parts[r].size();
    MPI_Alltoall(send_counts.data(), 1, MPI_INT, recv_counts.data(), 1, MPI_INT, MPI_COMM_WORLD);
    size_t total = 0;
    for (int r = 0; r < size_; ++r) {
      if (total + size_t(recv_counts[r]) > size_t(std::numeric_limits<int>::max()))
        abort("exchanged messages of more than 2^31 bytes exceed MPI's int displacements");
      recv_displs[r] = static_cast<int>(total);
      total += size_t(recv_counts[r]);
    }
    std::vector<uint8_t> received(total);
    MPI_Alltoallv(sent.data(), send_counts.data(), send_displs.data(), MPI_BYTE, received.data(), recv_counts.data(),
                  recv_displs.data(), MPI_BYTE, MPI_COMM_WORLD);
    std::vector<std::vector<uint8_t>> out(size_);
    for (int r = 0; r < size_; ++r)
      out[r].assign(received.begin() + recv_displs[r], received.begin() + recv_displs[r] + recv_counts[r]);
    seconds_reducing_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return out;
  }

  [[noreturn]] void abort(const std::string& message) override {
    std::fprintf(stderr, "depthpose: rank %d of %d: %s\n", rank_, size_, message.c_str());
    std::fflush(stderr);
    MPI_Abort(MPI_COMM_WORLD, 1);
    std::_Exit(1);  // MPI_Abort does not return; this keeps [[noreturn]] honest if it did
  }

 private:
  // The parts one after another, with MPI's int counts and displacements (refused beyond 2^31 − 1).
  std::vector<uint8_t> concatenate(const std::vector<std::vector<uint8_t>>& parts, std::vector<int>& counts,
                                   std::vector<int>& displs) {
    size_t total = 0;
    for (size_t r = 0; r < parts.size(); ++r) {
      if (total + parts[r].size() > size_t(std::numeric_limits<int>::max()))
        abort("exchanged messages of more than 2^31 bytes exceed MPI's int displacements");
      counts[r] = static_cast<int>(parts[r].size());
      displs[r] = static_cast<int>(total);
      total += parts[r].size();
    }
    std::vector<uint8_t> all;
    all.reserve(total);
    for (const std::vector<uint8_t>& p : parts) all.insert(all.end(), p.begin(), p.end());
    return all;
  }

  template <class T>
  void reduce(T* data, size_t count, MPI_Datatype type) {
    bytes_reduced_ += count * sizeof(T);
    const auto start = std::chrono::steady_clock::now();
    const size_t step = size_t(1) << 28;  // MPI counts are int: reduce in pieces of 2^28 elements
    for (size_t i = 0; i < count; i += step) {
      const int n = static_cast<int>(std::min(step, count - i));
      MPI_Allreduce(MPI_IN_PLACE, data + i, n, type, MPI_SUM, MPI_COMM_WORLD);
    }
    seconds_reducing_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }

  int rank_ = 0, size_ = 1;
  bool owns_init_ = false;
};

}  // namespace

bool mpi_available() { return true; }

std::unique_ptr<Communicator> launch_communicator(const std::string&) {
  return std::make_unique<MpiCommunicator>();
}

}  // namespace dp::train

#else

namespace dp::train {

bool mpi_available() { return false; }

std::unique_ptr<Communicator> launch_communicator(const std::string& tool) {
  tools::fail("asked to run " + tool + " distributed (launched by mpirun/srun or --distributed), but this depthpose was "
              "built without MPI. Install Open MPI (Debian: apt install openmpi-bin libopenmpi-dev) and rebuild "
              "with make; mk/mpi.mk then compiles the MPI transport in.");
}

}  // namespace dp::train

#endif
