// Processes that train (or render) one job together: the collective operations the data-parallel
// trainer needs (docs/training.md "Distributed training"), behind an interface so that the
// trainer does not depend on MPI. tools/train/mpi_communicator.cc implements it on Open MPI when
// the build finds MPI (mk/mpi.mk); without MPI, launch_communicator() refuses distributed runs
// with a message saying how to get it.
//
// Every collective must be called by every rank, in the same order, with the same counts; the
// trainer derives each call from values that are identical on all ranks (global node counts,
// options), never from rank-local data.
#pragma once
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace dp::train {

class Communicator {
 public:
  virtual ~Communicator() = default;
  virtual int rank() const = 0;  // 0 .. size() − 1
  virtual int size() const = 0;  // ≥ 1
  // Element-wise sums over all ranks, in place; every rank receives the result. Integer sums are
  // exact whatever the reduction order, which is what keeps forests independent of the rank count.
  virtual void sum(uint32_t* data, size_t count) = 0;
  virtual void sum(int64_t* data, size_t count) = 0;
  // Rank 0 receives every rank's bytes in rank order (the others receive an empty list).
  virtual std::vector<std::vector<uint8_t>> gather(const std::vector<uint8_t>& mine) = 0;
  // Rank 0's `data` replaces every other rank's (sizes may differ beforehand).
  virtual void broadcast(std::vector<uint8_t>& data) = 0;
  // All to all: this rank sends parts[r] to rank r (parts.size() == size(); parts[rank()] is
  // delivered to itself) and receives what each rank sent it, indexed by the sender. The node-
  // parallel deep levels move pixel features to the rank that owns a node this way.
  virtual std::vector<std::vector<uint8_t>> exchange(const std::vector<std::vector<uint8_t>>& parts) = 0;
  virtual void barrier() = 0;
  // Ends every rank of the job with exit status 1 after printing "depthpose: rank R of N: message"
  // on stderr. For errors on one rank that the others cannot see (they would wait forever).
  [[noreturn]] virtual void abort(const std::string& message) = 0;

  // Payload bytes this rank has handed to sum() so far (a level's traffic is the difference).
  uint64_t bytes_reduced() const { return bytes_reduced_; }
  // Bytes this rank has sent to other ranks through exchange() so far (its own part excluded).
  uint64_t bytes_exchanged() const { return bytes_exchanged_; }
  // Wall seconds this rank has spent inside sum() and exchange() (waiting for the slowest rank
  // included).
  double seconds_reducing() const { return seconds_reducing_; }

 protected:
  uint64_t bytes_reduced_ = 0;
  uint64_t bytes_exchanged_ = 0;
  double seconds_reducing_ = 0;
};

// True when this process was started by an MPI launcher (mpirun/mpiexec of Open MPI, or Slurm's
// srun with PMI/PMIx) for a job of more than one process, from the environment alone.
bool launched_by_mpi_launcher();
// Whether this build has MPI (mk/mpi.mk found mpicxx).
bool mpi_available();

// Initializes MPI and returns the world communicator, or throws ToolError when this build has no
// MPI ("install openmpi-bin libopenmpi-dev and rebuild"). Called once per process; MPI is
// finalized when the returned object is destroyed. `tool` names the command in messages.
std::unique_ptr<Communicator> launch_communicator(const std::string& tool);

// The entry point of a command that can run as one rank of an MPI job (train, synth): calls
// main(argc, argv, comm) with comm null when the process was neither launched by an MPI launcher
// nor given `--distributed`, else with the world communicator; then any exception on any rank ends
// the whole job through comm->abort, naming the rank and the error, instead of leaving the other
// ranks waiting in a collective call. `tool` names the command in messages.
int run_maybe_distributed(const std::string& tool, int argc, char** argv,
                          int (*main)(int argc, char** argv, Communicator* comm));

// The half-open range [begin, end) of `count` items that rank `rank` of `size` owns: contiguous
// and balanced (sizes differ by at most one), in rank order, so concatenating the ranks' ranges
// gives 0 .. count − 1.
inline std::pair<size_t, size_t> rank_share(size_t count, int rank, int size) {
  return {count * size_t(rank) / size_t(size), count * size_t(rank + 1) / size_t(size)};
}

}  // namespace dp::train
