// snowsim clumps DIR: how a run's snow broke up, frame by frame: the share of the particles in
// clumps (connected at packing distance) against the share scattered as single particles, and the
// mass of the largest chunks, so that chunks are a distribution and not one share.
#include <algorithm>
#include <cstdio>
#include <functional>
#include <memory>
#include <string>
#include <vector>

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

constexpr int kLargestChunks = 10;  // the chunks whose mass shares each row gives

// The particles of s whose J_P is below `limit`, their positions and masses.
Snapshot intactOf(const Snapshot& s, double limit, const std::string& file) {
  if (s.plastic_j.empty())
    throw InputError(file +
                     ": --intact-below: the frame has no plastic_j (only MPM runs write it)");
  Snapshot kept;
  for (int p = 0; p < s.size(); ++p)
    if (s.plastic_j[p] < limit) {
      kept.position.push_back(s.position[p]);
      if (!s.mass.empty()) kept.mass.push_back(s.mass[p]);
    }
  return kept;
}

// The mass shares of the kLargestChunks heaviest chunks of `measured` (clumps of at least
// min_size particles), largest first, of the whole snow's mass `total`; 0 where there are fewer.
// A frame without masses counts each particle as one.
std::vector<double> largestChunkShares(const Snapshot& measured, const ClumpStats& c, int min_size,
                                       double total) {
  std::vector<double> mass(c.clumps, 0.0);
  for (int p = 0; p < measured.size(); ++p)
    mass[c.clump_of[p]] += measured.mass.empty() ? 1.0 : double(measured.mass[p]);
  std::vector<double> chunks;
  for (int k = 0; k < c.clumps; ++k)
    if (c.clump_sizes[k] >= min_size) chunks.push_back(mass[k]);
  std::sort(chunks.begin(), chunks.end(), std::greater<>());
  std::vector<double> shares(kLargestChunks, 0.0);
  for (int i = 0; i < kLargestChunks && i < int(chunks.size()); ++i)
    shares[i] = total > 0 ? chunks[i] / total : 0.0;
  return shares;
}

void reportClumps(const ClumpsOptions& options) {
  if (!(options.link > 0)) throw InputError("--link: must be > 0 (particle spacings)");
  if (options.min_size < 1) throw InputError("--min-size: must be at least 1");
  if (!(options.intact_below >= 0))
    throw InputError("--intact-below: must be a J_P above 1 (or 0: every particle counts)");
  // Printed once every frame has been read, so that a bad frame leaves no partial CSV behind.
  std::string csv =
      "frame,time_s,particles,clumps,chunks,largest_share,other_chunks_share,clumped_share,"
      "single_share,left_out_share";
  for (int i = 1; i <= kLargestChunks; ++i) csv += ",chunk" + std::to_string(i) + "_mass_share";
  csv += "\n";
  for (const std::string& file : plyFramesIn(options.frames)) {
    const Snapshot s = readPly(file);
    if (!(s.grid.particle_spacing > 0))
      throw InputError(file + ": records no particle spacing (not written by snowsim run)");
    const double link = options.link * s.grid.particle_spacing;
    const Snapshot intact =
        options.intact_below > 0 ? intactOf(s, options.intact_below, file) : Snapshot();
    const Snapshot& measured = options.intact_below > 0 ? intact : s;
    const ClumpStats c = findClumps(measured, link, options.min_size);
    double total_mass = 0;
    for (int p = 0; p < s.size(); ++p) total_mass += s.mass.empty() ? 1.0 : double(s.mass[p]);
    // Shares of all the particles, those left out included.
    const double of_all = s.size() > 0 ? double(c.particles) / s.size() : 0.0;
    const double largest = s.size() > 0 ? double(c.largest) / s.size() : 0.0;
    char line[256];
    std::snprintf(line, sizeof line, "%d,%.4f,%d,%d,%d,%.4f,%.4f,%.4f,%.4f,%.4f", s.frame, s.time,
                  s.size(), c.clumps, c.chunks, largest, c.clumped_share * of_all - largest,
                  c.clumped_share * of_all, c.single_share * of_all, 1 - of_all);
    csv += line;
    for (const double share : largestChunkShares(measured, c, options.min_size, total_mass)) {
      std::snprintf(line, sizeof line, ",%.4f", share);
      csv += line;
    }
    csv += "\n";
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
      "neighbour within the link), and of those --intact-below left out; then the mass shares "
      "of the ten heaviest chunks, largest first, of the whole snow's mass (0 where there are "
      "fewer). "
      "docs/snow-at-scale.md.\n"
      "Exit codes: 0 done, 2 bad input.");
  cmd->callback([options] { reportClumps(*options); });
}

}  // namespace snowsim
