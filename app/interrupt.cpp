#include "app/interrupt.h"

#include <csignal>

namespace snowsim {

namespace {
volatile std::sig_atomic_t received_signal = 0;
void recordSignal(int sig) {
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
