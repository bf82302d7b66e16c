#include "app/memory_budget.h"

#include <unistd.h>

#include <cctype>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>

#include "sim/core/errors.h"

namespace snowsim {

namespace {

// A value of /proc/meminfo or /proc/self/status in bytes ("MemAvailable:  123456 kB"); none when
// the file or the key is missing.
std::optional<double> procValue(const char* file, const std::string& key) {
  std::ifstream in(file);
  std::string line;
  while (std::getline(in, line))
    if (line.rfind(key + ":", 0) == 0) {
      std::istringstream fields(line.substr(key.size() + 1));
      double kib = 0;
      if (fields >> kib) return kib * 1024;
    }
  return std::nullopt;
}

// Drawing the frames takes a fixed share (the software rasteriser's threads and tiles) and bytes
// per pixel: the colour, depth, shadow and occlusion buffers and the PNG writer's queue, and the
// video encoder's frames, which its look-ahead holds a few dozen of. Measured with /usr/bin/time
// on this renderer and encoder (docs/performance.md, "Memory").
constexpr double kDrawingFixed = 36.0 * (1 << 20);
double drawingBytesPerPixel(int dimension, bool mp4) {
  return dimension == 2 ? (mp4 ? 180 : 55) : (mp4 ? 240 : 120);
}

}  // namespace

double parseMemorySize(const std::string& text, const std::string& option) {
  const std::string allowed = option + " " + text +
                              ": allowed: a size such as 500M, 8G or 1.5T (K, M, G, T: "
                              "powers of 1024)";
  size_t end = 0;
  double value = 0;
  try {
    value = std::stod(text, &end);
  } catch (const std::exception&) {
    throw InputError(allowed);
  }
  if (end + 1 != text.size() || !std::isfinite(value) || value <= 0) throw InputError(allowed);
  const std::string units = "KMGT";
  const size_t unit = units.find(static_cast<char>(std::toupper(text.back())));
  if (unit == std::string::npos) throw InputError(allowed);
  return value * std::pow(1024.0, unit + 1);
}

std::string memoryText(double bytes) {
  char text[32];
  const double mib = bytes / (1 << 20);
  if (mib >= 1024 * 1024)
    std::snprintf(text, sizeof text, "%.1f TiB", mib / (1024 * 1024));
  else if (mib >= 1024)
    std::snprintf(text, sizeof text, "%.1f GiB", mib / 1024);
  else
    std::snprintf(text, sizeof text, "%.0f MiB", std::max(1.0, std::round(mib)));
  return text;
}

std::optional<double> availableMemory() {
  if (const auto bytes = procValue("/proc/meminfo", "MemAvailable")) return bytes;
  const long pages = sysconf(_SC_AVPHYS_PAGES), size = sysconf(_SC_PAGESIZE);
  if (pages > 0 && size > 0) return double(pages) * double(size);
  return std::nullopt;
}

double RunMemory::bytes() const {
  return program + simulation.peak(frames);
}

double RunMemory::most() const {
  return program + simulation.peak(frames + simulation.spread);
}

std::string RunMemory::parts() const {
  const SimulationMemory& s = simulation;
  std::string text = "program " + memoryText(program) + ", particles " + memoryText(s.state) +
                     ", grid " + memoryText(s.dense + s.touched) + ", snapshot " +
                     memoryText(s.snapshot);
  if (frames > 0) text += ", frames " + memoryText(frames);
  if (s.setup > s.touched + s.snapshot + frames)
    text += "; while it is built, the sampled particles' " + memoryText(s.setup) +
            " instead of the grid's pages near the snow, the snapshot and the frames";
  return text;
}

std::string RunMemory::line() const {
  const std::string about = memoryText(bytes()), up_to = memoryText(most());
  return scene_name + ": memory: about " + about + " at its peak (" + parts() + ")" +
         (up_to == about ? "" : ", up to " + up_to + " if the snow spreads over its grid");
}

RunMemory runMemory(const Scene& scene, long particles, const FrameOutput& output) {
  RunMemory m;
  m.scene_name = scene.name;
  m.program = procValue("/proc/self/status", "VmRSS").value_or(0);
  m.simulation = simulationMemory(scene, particles);
  if (output.png || output.mp4)
    m.frames = kDrawingFixed + double(output.width) * output.height *
                                   drawingBytesPerPixel(scene.dimension, output.mp4);
  return m;
}

void refuseWhatCannotFit(const RunMemory& memory, std::optional<double> max_memory,
                         const std::string& max_memory_text) {
  refuseGridTooLarge(memory.scene_name, memory.simulation.nodes);
  const double needed = memory.bytes();
  const std::optional<double> available = availableMemory();
  std::string limit;
  if (max_memory && needed > *max_memory)
    limit = "--max-memory " + max_memory_text + " (" + memoryText(*max_memory) + ")";
  else if (available && needed > *available)
    limit = "the " + memoryText(*available) + " of memory available (MemAvailable)";
  if (limit.empty()) return;
  throw InputError(memory.scene_name + ": the run needs about " + memoryText(needed) +
                   " of memory at its peak (" + memory.parts() + "), more than " + limit +
                   "; refused before it allocates; a smaller --scale or grid.cells, or fewer "
                   "particles_per_cell, take less");
}

}  // namespace snowsim
