// What a run will take in memory, said before it allocates, and the runs that cannot fit refused:
// the program as loaded, the simulation as its scene describes it (sim/simulation_memory.h) and
// the rendering of its frames, against the memory the machine has free or --max-memory.
#pragma once

#include <optional>
#include <stdexcept>
#include <string>

#include "sim/scene/scene.h"
#include "sim/simulation_memory.h"

namespace snowsim {

// An allocation that failed during a run: what the run was doing, and its estimate. Exit code 5.
struct OutOfMemory : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// "8G", "500M", "1.5G", "64K", "2T": powers of 1024, the unit's letter in either case; InputError
// naming `option` otherwise.
double parseMemorySize(const std::string& text, const std::string& option);

// "340 MiB", "6.1 GiB", "10.5 TiB".
std::string memoryText(double bytes);

// MemAvailable of /proc/meminfo, else the free pages sysconf reports; none if neither says.
std::optional<double> availableMemory();

struct RunMemory {
  std::string scene_name;
  double program = 0;  // this process's resident size now: the program and its libraries
  SimulationMemory simulation;
  double frames = 0;     // drawing and encoding the frames, where the run draws them
  double bytes() const;  // the peak
  double most() const;   // the peak once the snow has reached every node of its grid
  // "program 107 MiB, particles 41 MiB, grid 69 MiB, snapshot 10 MiB, frames 247 MiB"
  std::string parts() const;
  // "NAME: memory: about 480 MiB at its peak (PARTS), up to 575 MiB if the snow spreads over its
  // grid"
  std::string line() const;
};

// Which frames a run draws, for the memory the drawing takes: an image of width x height pixels
// per frame to PNG files and/or an MP4 video.
struct FrameOutput {
  bool png = false, mp4 = false;
  int width = 0, height = 0;
};

RunMemory runMemory(const Scene& scene, long particles, const FrameOutput& output);

// Throws InputError with both figures when the run's estimate is more than `max_memory` (given
// as --max-memory TEXT) or the memory available, or when its grid has more nodes than it can
// index.
void refuseWhatCannotFit(const RunMemory& memory, std::optional<double> max_memory,
                         const std::string& max_memory_text);

}  // namespace snowsim
