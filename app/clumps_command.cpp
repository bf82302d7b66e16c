// snowsim clumps DIR: how a run's snow broke up, frame by frame: the share of the particles in
// clumps (connected at packing distance) against the share scattered as single particles.
#include <cstdio>
#include <memory>
#include <string>

#include "app/commands.h"
#include "sim/core/errors.h"
#include "sim/io/ply.h"
#include "study/metrics.h"

namespace snowsim {

namespace {

struct ClumpsOptions {
  std::string frames;
  double link = 1.5;
  int min_size = 8;
};

void reportClumps(const ClumpsOptions& options) {
  if (!(options.link > 0)) throw InputError("--link: must be > 0 (particle spacings)");
  if (options.min_size < 1) throw InputError("--min-size: must be at least 1");
  // Printed once every frame has been read, so that a bad frame leaves no partial CSV behind.
  std::string csv =
      "frame,time_s,particles,clumps,chunks,largest_share,other_chunks_share,clumped_share,"
      "single_share\n";
  for (const std::string& file : plyFramesIn(options.frames)) {
    const Snapshot s = readPly(file);
    if (!(s.grid.particle_spacing > 0))
      throw InputError(file + ": records no particle spacing (not written by snowsim run)");
    const ClumpStats c = findClumps(s, options.link * s.grid.particle_spacing, options.min_size);
    const double largest = c.particles > 0 ? double(c.largest) / c.particles : 0.0;
    char line[256];
    std::snprintf(line, sizeof line, "%d,%.4f,%d,%d,%d,%.4f,%.4f,%.4f,%.4f\n", s.frame, s.time,
                  c.particles, c.clumps, c.chunks, largest, c.clumped_share - largest,
                  c.clumped_share, c.single_share);
    csv += line;
  }
  std::fputs(csv.c_str(), stdout);
}

}  // namespace

void addClumpsCommand(CLI::App& app) {
  auto options = std::make_shared<ClumpsOptions>();
  CLI::App* cmd = app.add_subcommand(
      "clumps", "Measure how saved PLY frames broke up: snow in clumps against single particles");
  cmd->add_option("frames", options->frames, "Directory holding frame_NNNNN.ply files")
      ->required()
      ->check(CLI::ExistingDirectory);
  cmd->add_option("--link", options->link,
                  "Particles closer than this many particle spacings (the lattice spacing the "
                  "run seeded its bodies at) are connected")
      ->capture_default_str();
  cmd->add_option("--min-size", options->min_size,
                  "Particles a connected group needs to count as a clump")
      ->capture_default_str();
  cmd->footer(
      "Prints CSV, one line per frame: the particles; the connected groups (clumps, single "
      "particles included) and those of at least --min-size (chunks); the share of the "
      "particles in the largest group, in the other chunks, in all chunks, and alone (no "
      "neighbour within the link). docs/snow-at-scale.md.\n"
      "Exit codes: 0 done, 2 bad input.");
  cmd->callback([options] { reportClumps(*options); });
}

}  // namespace snowsim
