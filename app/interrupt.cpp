#include "app/interrupt.h"

#include <unistd.h>

#include <csignal>

#include "sim/io/files.h"

namespace snowsim {

namespace {
volatile std::sig_atomic_t received_signal = 0;
void recordSignal(int sig) {
  if (received_signal != 0) {  // the second: stop at once, leaving only complete files
    removeUnfinishedFiles();
    ::_exit(128 + sig);
  }
  received_signal = sig;
}
}  // namespace

void catchInterrupts() {
  std::signal(SIGINT, recordSignal);
  std::signal(SIGTERM, recordSignal);
}

int interruptSignal() {
  return received_signal;
}

}  // namespace snowsim
