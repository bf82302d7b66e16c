// Error metrics for the speed/accuracy study (docs/study.md): pure functions over sequences of
// Snapshots, the same for every solver, dimension, resolution and particle count.
//
// Particles are weighted equally (Snapshot carries no mass); for scenes whose bodies share one
// density that is the mass fraction.
#pragma once

#include <array>
#include <vector>

#include "sim/core/snapshot.h"

namespace snowsim {

using Frames = std::vector<Snapshot>;
using Point3 = std::array<double, 3>;

// --- (a) analytic answers ------------------------------------------------------------------

// Centre of mass of the particles (all of them, or the listed ones).
Point3 centreOfMass(const Snapshot& s);
Point3 centreOfMass(const Snapshot& s, const std::vector<int>& members);
Point3 meanVelocity(const Snapshot& s);

// Largest distance (m) between the centre of mass and the ballistic path
// x0 + v0 t + g t^2 / 2 (x0, v0 from the first frame) over the frames with time <= until.
double freeFallError(const Frames& frames, const Point3& gravity, double until);

// Largest |mean v(t) - mean v(0) - g t| (m/s) over the frames with time <= until: the drift of
// linear momentum per unit mass while only gravity acts.
double momentumDrift(const Frames& frames, const Point3& gravity, double until);

// Indices of the particles whose first-frame x is below / at or above split_x.
std::vector<int> membersLeftOf(const Snapshot& first, double split_x);
std::vector<int> membersRightOf(const Snapshot& first, double split_x);

// Time of the first frame at which the lowest listed particle is at or below ground_y + margin;
// -1 if never.
double landingTime(const Frames& frames, const std::vector<int>& members, double ground_y,
                   double margin);

// Frequency (Hz) of an oscillating signal from its crossings of its mean (linear interpolation
// between samples); 0 with fewer than two crossings. For the elastic bar's tip displacement.
double oscillationFrequency(const std::vector<double>& times, const std::vector<double>& values);

// --- (b) against a reference run -------------------------------------------------------------

// The common fine grid the density is rasterised on: it covers [0, extent] in each used axis.
struct FieldGrid {
  int dimension = 2;
  Point3 extent{};
  int cells_per_axis = 64;  // along the longest axis; the others keep the cells square
  std::array<int, 3> cells() const;
  double cellSize() const;
};

// Mass fraction per fine cell (sums to 1), each particle spread by a tent of half-width one fine
// cell (bilinear/trilinear deposit), so the field does not depend on the solver's grid.
std::vector<double> rasteriseDensity(const Snapshot& s, const FieldGrid& grid);

// Height (m) of the highest particle in each column of the fine grid (x in 2D, x-z in 3D);
// 0 where a column holds no particle.
std::vector<double> heightProfile(const Snapshot& s, const FieldGrid& grid);

// Half the L1 distance of the mass fractions, averaged over the frames: 0 identical, 1 disjoint.
double densityFieldError(const Frames& run, const Frames& reference, const FieldGrid& grid);

// Mean |h_run - h_ref| (m) over the columns where either has snow, averaged over the frames.
double heightProfileError(const Frames& run, const Frames& reference, const FieldGrid& grid);

// Mean distance (m) between the two centre-of-mass paths over the frames.
double centreOfMassPathError(const Frames& run, const Frames& reference);

// --- (c) the report's qualitative claims -----------------------------------------------------

// The thrown ball at the tower (the report's Fig. 2 and Fig. 8): how far (m) the ball's centre of
// mass ends, in the last frame, beyond the tower's far (right) face there; negative while the
// ball has not passed the tower (a tower pushed along with the ball still has the ball outside).
// The ball is the particles with first-frame x < tower_left_x, the tower the others. The same
// criterion as the report tests' (tests/sim/report/report_scenes_test.cpp); docs/study.md says why.
double ballPastTower(const Frames& frames, double tower_left_x);

// The report's Fig. 2 claim: the thrown ball does not pass through the tower.
bool thrownBallStaysOutside(const Frames& frames, double tower_left_x);

// Height (m) of a pile: the 90th percentile of the particles' heights (robust to strays).
double pileHeight(const Snapshot& s);

// The report's Fig. 6 claim: final pile height with critical density x2 > x4 > x8.
bool pileHeightsOrdered(const Snapshot& x2, const Snapshot& x4, const Snapshot& x8);

// --- (d) how snow breaks up: clumps against scattered particles ----------------------------

// Particles whose distance is at most link_distance belong to the same clump (connected
// components of that neighbour graph). With link_distance about 1.5 times the lattice spacing
// the particles were generated at, intact and compacted snow is one clump, and snow torn apart
// into single particles or pairs leaves it.
struct ClumpStats {
  int particles = 0;
  int clumps = 0;                // connected components, single particles included
  int largest = 0;               // particles in the largest clump
  int chunks = 0;                // clumps of at least min_size particles, the largest included
  double clumped_share = 0;      // share of the particles in clumps of at least min_size
  double single_share = 0;       // share of the particles with no neighbour within the link
  std::vector<int> clump_of;     // clump index of each particle (0 .. clumps - 1)
  std::vector<int> clump_sizes;  // particles per clump
};

// O(N): particles are hashed into cells of side link_distance, and each is linked to the
// particles of its own and the neighbouring cells by a union-find. Throws std::invalid_argument
// for link_distance <= 0 or min_size < 1.
ClumpStats findClumps(const Snapshot& s, double link_distance, int min_size);

// Any particle non-finite or outside [0, extent] (by more than `slack` m): escaped the domain.
bool anyNonFinite(const Snapshot& s);
bool anyOutside(const Snapshot& s, const Point3& extent, double slack);

}  // namespace snowsim
