// Errors the command line reports to the user, each with its own exit code.
#pragma once

#include <sstream>
#include <stdexcept>
#include <string>

namespace snowsim {

// Bad input: a malformed or invalid scene, a wrong option, an unwritable path. Exit code 2.
struct InputError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// A number as a message shows it: 0.2, not std::to_string's 0.200000.
inline std::string numberText(double x) {
  std::ostringstream s;
  s << x;
  return s.str();
}

// The simulation blew up (a non-finite or runaway value). Exit code 3.
struct SimulationError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

}  // namespace snowsim
