// Ctrl-C and SIGTERM during a long run: the run stops at the end of the current step, the sinks
// finish (the MP4 gets its trailer and still plays) and snowsim exits with 128 + the signal
// number. A second signal ends snowsim at once with that code, after removing the files being
// written (sim/io/files.h, UnfinishedFile): what is left is complete.
#pragma once

#include <stdexcept>
#include <string>

namespace snowsim {

// Installs the SIGINT/SIGTERM handlers: the first only records the signal, the second exits.
void catchInterrupts();

// The signal received since catchInterrupts(), or 0.
int interruptSignal();

// Thrown after the sinks have finished; main() turns it into exit code 128 + signal.
struct Interrupted : std::runtime_error {
  int signal;
  Interrupted(int sig, const std::string& what) : std::runtime_error(what), signal(sig) {}
};

}  // namespace snowsim
