// The world of one process, for a build without MPI.
#include "sim/distributed/rank_exchange.h"

namespace snowsim {

RankExchange& worldExchange() {
  return oneProcess();
}

bool builtWithMpi() {
  return false;
}

}  // namespace snowsim
