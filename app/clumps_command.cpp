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
  double intact_below = 0;  // > 0: particles of J_P at or above it are left out
};

// The particles of s whose J_P is below `limit`, positions only (all findClumps reads).
Snapshot intactOf(const Snapshot& s, double limit, const std::string& file) {
  if (s.plastic_j.empty())
    throw InputError(file +
                     ": --intact-below: the frame has no plastic_j (only MPM runs write it)");
  Snapshot kept;
  for (int p = 0; p < s.size(); ++p)
    if (s.plastic_j[p] < limit) kept.position.push_back(s.position[p]);
  return kept;
}

void reportClumps(const ClumpsOptions& options) {
  if (!(options.link > 0)) throw InputError("--link: must be > 0 (particle spacings)");
  if (options.min_size < 1) throw InputError("--min-size: must be at least 1");
  if (!(options.intact_below >= 0))
    throw InputError("--intact-below: must be a J_P above 1 (or 0: every particle counts)");
  // Printed once every frame has been read, so that a bad frame leaves no partial CSV behind.
  std::string csv =
      "frame,time_s,particles,clumps,chunks,largest_share,other_chunks_share,clumped_share,"
      "single_share,left_out_share\n";
  for (const std::string& file : plyFramesIn(options.frames)) {
    const Snapshot s = readPly(file);
    if (!(s.grid.particle_spacing > 0))
      throw InputError(file + ": records no particle spacing (not written by snowsim run)");
    const double link = options.link * s.grid.particle_spacing;
    const ClumpStats c =
        options.intact_below > 0
            ? findClumps(intactOf(s, options.intact_below, file), link, options.min_size)
            : findClumps(s, link, options.min_size);
    // Shares of all the particles, those left out included.
    const double of_all = s.size() > 0 ? double(c.particles) / s.size() : 0.0;
    const double largest = s.size() > 0 ? double(c.largest) / s.size() : 0.0;
    char line[256];
    std::snprintf(line, sizeof line, "%d,%.4f,%d,%d,%d,%.4f,%.4f,%.4f,%.4f,%.4f\n", s.frame, s.time,
                  s.size(), c.clumps, c.chunks, largest, c.clumped_share * of_all - largest,
                  c.clumped_share * of_all, c.single_share * of_all, 1 - of_all);
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
  cmd->add_option("--intact-below", options->intact_below,
                  "Leave out the particles of J_P at or above this (snow torn loose: for a "
                  "softening model, e^eps_f) and measure the pieces of the rest; the shares stay "
                  "of all the particles, left_out_share those left out");
  cmd->footer(
      "Prints CSV, one line per frame: the particles; the connected groups (clumps, single "
      "particles included) and those of at least --min-size (chunks); the share of the "
      "particles in the largest group, in the other chunks, in all chunks, and alone (no "
      "neighbour within the link), and of those --intact-below left out. "
      "docs/snow-at-scale.md.\n"
      "Exit codes: 0 done, 2 bad input.");
  cmd->callback([options] { reportClumps(*options); });
}

}  // namespace snowsim
