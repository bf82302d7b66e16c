// What one simulation split across processes (MPI ranks) asks of the others: a few collective
// operations on bytes, from which the slab decomposition (slab_decomposition.h) builds its halo
// sums, particle migration, reductions and output gathers. A single process is the world of one
// rank, where each operation returns what it was given. MPI is included in one unit only
// (mpi_exchange.cpp, built with SNOWSIM_MPI).
#pragma once

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

namespace snowsim {

class RankExchange {
 public:
  virtual ~RankExchange() = default;
  virtual int rank() const = 0;
  virtual int ranks() const = 0;
  // Every rank calls it with its bytes; each gets all ranks' bytes, in rank order.
  virtual std::vector<std::string> allGather(std::string_view mine) = 0;
  // The same, but rank 0 alone gets them (the others an empty vector): for what rank 0 alone
  // writes, which the others need not hold.
  virtual std::vector<std::string> gatherToFirst(std::string_view mine) = 0;
  // Every rank calls it with to[r], the bytes for rank r; returns from[r], what rank r sent this
  // one.
  virtual std::vector<std::string> allToAll(const std::vector<std::string>& to) = 0;
  // Ends every rank's process with this exit code: for an error one rank meets alone, which
  // would leave the others waiting in their next exchange.
  [[noreturn]] virtual void abortAll(int exit_code) = 0;

  // The largest of every rank's value, on every rank.
  long maxOverRanks(long value) {
    long largest = value;
    for (const std::string& bytes :
         allGather(std::string_view(reinterpret_cast<const char*>(&value), sizeof value))) {
      long theirs;
      std::memcpy(&theirs, bytes.data(), sizeof theirs);
      largest = std::max(largest, theirs);
    }
    return largest;
  }
};

// Every rank's value of a plain type, in rank order, on every rank: each rank calls it at once.
template <class V>
std::vector<V> gatherEach(RankExchange& world, const V& mine) {
  static_assert(std::is_trivially_copyable_v<V>, "sent as its bytes");
  std::vector<V> all;
  for (const std::string& bytes :
       world.allGather(std::string_view(reinterpret_cast<const char*>(&mine), sizeof mine))) {
    V theirs;
    std::memcpy(static_cast<void*>(&theirs), bytes.data(), sizeof theirs);
    all.push_back(theirs);
  }
  return all;
}

// The world of one process: each operation returns what it was given.
class SingleProcess final : public RankExchange {
 public:
  int rank() const override { return 0; }
  int ranks() const override { return 1; }
  std::vector<std::string> allGather(std::string_view mine) override { return {std::string(mine)}; }
  std::vector<std::string> gatherToFirst(std::string_view mine) override {
    return {std::string(mine)};
  }
  std::vector<std::string> allToAll(const std::vector<std::string>& to) override { return to; }
  [[noreturn]] void abortAll(int exit_code) override { std::exit(exit_code); }
};

// A world of one process, for what runs alone (studies, figures, tests) even under mpirun.
inline RankExchange& oneProcess() {
  static SingleProcess one;
  return one;
}

// The processes this one was launched with: MPI_COMM_WORLD when snowsim is built with MPI and
// started by mpirun (MPI initialised on first use, finalised at exit), else a world of one.
RankExchange& worldExchange();
// Whether snowsim was built with MPI (SNOWSIM_MPI).
bool builtWithMpi();

}  // namespace snowsim
