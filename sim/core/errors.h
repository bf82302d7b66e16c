// Errors the command line reports to the user, each with its own exit code.
#pragma once

#include <charconv>
#include <stdexcept>
#include <string>

namespace snowsim {

// Bad input: a malformed or invalid scene, a wrong option, an unwritable path. Exit code 2.
struct InputError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// A number as a message shows it: the shortest text that reads back as x (0.2, not
// std::to_string's 0.200000; 2.0000001, not a rounded 2 that would contradict the limit beside it).
inline std::string numberText(double x) {
  char text[32];
  return std::string(text, std::to_chars(text, text + sizeof text, x).ptr);
}

// The simulation blew up (a non-finite or runaway value). Exit code 3.
struct SimulationError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

}  // namespace snowsim
