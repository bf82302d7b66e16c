// The world of MPI_COMM_WORLD: the only unit that includes MPI.
#include <mpi.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <thread>

#include "sim/core/errors.h"
#include "sim/distributed/rank_exchange.h"

namespace snowsim {

namespace {

// Whether a launcher (OpenMPI's mpirun, a PMI or PMIx one) started this process: only then is MPI
// initialised, so a plain `snowsim run` neither waits for nor warns about a missing launcher.
bool launchedByMpi() {
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_RANK"})
    if (std::getenv(name)) return true;
  return false;
}

void finalise() {
  int finalised = 0;
  MPI_Finalized(&finalised);
  if (!finalised) MPI_Finalize();
}

int byteCount(size_t bytes) {
  if (bytes > static_cast<size_t>(std::numeric_limits<int>::max()))
    throw SimulationError("a message between MPI ranks exceeds 2 GiB");
  return static_cast<int>(bytes);
}

// Where each rank's bytes start in the whole; the sums in 64 bits, so that a whole past 2 GiB is
// refused (byteCount) rather than overflowing.
std::vector<int> displacements(const std::vector<int>& counts) {
  std::vector<int> at(counts.size(), 0);
  size_t sum = 0;
  for (size_t r = 0; r + 1 < counts.size(); ++r) {
    sum += static_cast<size_t>(counts[r]);
    at[r + 1] = byteCount(sum);
  }
  return at;
}

class MpiWorld final : public RankExchange {
 public:
  MpiWorld() {
    // Only the thread that calls the solver talks to MPI; the team's workers never do.
    int provided = 0;
    MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided);
    std::atexit(finalise);
    MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
    MPI_Comm_size(MPI_COMM_WORLD, &ranks_);
  }
  int rank() const override { return rank_; }
  int ranks() const override { return ranks_; }

  std::vector<std::string> allGather(std::string_view mine) override {
    std::vector<int> counts(ranks_);
    const int count = byteCount(mine.size());
    MPI_Allgather(&count, 1, MPI_INT, counts.data(), 1, MPI_INT, MPI_COMM_WORLD);
    const std::vector<int> at = displacements(counts);
    std::string all(byteCount(size_t(at.back()) + counts.back()), '\0');
    MPI_Allgatherv(mine.data(), count, MPI_BYTE, all.data(), counts.data(), at.data(), MPI_BYTE,
                   MPI_COMM_WORLD);
    std::vector<std::string> from(ranks_);
    for (int r = 0; r < ranks_; ++r) from[r] = all.substr(at[r], counts[r]);
    return from;
  }

  std::vector<std::string> gatherToFirst(std::string_view mine) override {
    std::vector<int> counts(rank_ == 0 ? ranks_ : 0);
    const int count = byteCount(mine.size());
    MPI_Gather(&count, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, MPI_COMM_WORLD);
    if (rank_ != 0) {
      MPI_Gatherv(mine.data(), count, MPI_BYTE, nullptr, nullptr, nullptr, MPI_BYTE, 0,
                  MPI_COMM_WORLD);
      return {};
    }
    const std::vector<int> at = displacements(counts);
    std::string all(byteCount(size_t(at.back()) + counts.back()), '\0');
    MPI_Gatherv(mine.data(), count, MPI_BYTE, all.data(), counts.data(), at.data(), MPI_BYTE, 0,
                MPI_COMM_WORLD);
    std::vector<std::string> from(ranks_);
    for (int r = 0; r < ranks_; ++r) from[r] = all.substr(at[r], counts[r]);
    return from;
  }

  [[noreturn]] void abortAll(int exit_code) override {
    // The launcher forwards each rank's output from a pipe; MPI_Abort tears the job down at once
    // and could drop the error message just written (2 runs in 40 under load, none after a pause).
    std::fflush(nullptr);
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
    MPI_Abort(MPI_COMM_WORLD, exit_code);
    std::exit(exit_code);  // MPI_Abort does not return; this says so to the compiler
  }
  std::vector<std::string> allToAll(const std::vector<std::string>& to) override {
    std::vector<int> send_counts(ranks_), receive_counts(ranks_);
    for (int r = 0; r < ranks_; ++r) send_counts[r] = byteCount(to[r].size());
    MPI_Alltoall(send_counts.data(), 1, MPI_INT, receive_counts.data(), 1, MPI_INT, MPI_COMM_WORLD);
    std::string sent;
    for (const std::string& bytes : to) sent += bytes;
    const std::vector<int> send_at = displacements(send_counts),
                           receive_at = displacements(receive_counts);
    std::string received(byteCount(size_t(receive_at.back()) + receive_counts.back()), '\0');
    MPI_Alltoallv(sent.data(), send_counts.data(), send_at.data(), MPI_BYTE, received.data(),
                  receive_counts.data(), receive_at.data(), MPI_BYTE, MPI_COMM_WORLD);
    std::vector<std::string> from(ranks_);
    for (int r = 0; r < ranks_; ++r) from[r] = received.substr(receive_at[r], receive_counts[r]);
    return from;
  }

 private:
  int rank_ = 0, ranks_ = 1;
};

}  // namespace

RankExchange& worldExchange() {
  if (!launchedByMpi()) return oneProcess();
  static MpiWorld world;
  return world;
}

bool builtWithMpi() {
  return true;
}

}  // namespace snowsim
