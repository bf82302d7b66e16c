// MpmSolver against the plain reference step (tests/support/reference_step.h): the same particles,
// the same fixed dt, the same positions and velocities to round-off. The two sum the same terms in
// different orders (the solver by sorted blocks and axis by axis), so they differ by round-off,
// which stable steps carry along without amplifying it much.
#include "tests/support/reference_step.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "sim/core/errors.h"
#include "sim/mpm/mpm_solver.h"
#include "sim/scene/sampling.h"

using namespace snowsim;

namespace {

// Largest differences between the solver and the reference, relative to the largest position
// and the largest speed of the reference; how many particles of each have |J_P - 1| > 1e-3
// (plastic); the step and the lowest CFL limit the solver met.
struct Difference {
  Real x = 0, v = 0;
  int plastic_reference = 0, plastic_solver = 0;
  int particles = 0;
  Real dt = 0, lowest_limit = 0;
};

// T: the solver's precision (mpm.precision); the reference is in double.
template <int D, class T = Real>
Difference runBoth(const Scene& scene, int steps) {
  const Particles<D> particles = sampleBodies<D>(scene);
  MpmSolver<D, T> solver(scene, particles, 1);
  ReferenceState<D> reference = makeReferenceState<D>(scene, particles);
  Difference d;
  // Fixed, and meant to stay within the CFL limit throughout: the impact hardens the snow (mu =
  // mu0 e^{xi (1 - J_P)}), which lowers the limit several times over. A step beyond it, though it
  // does not blow up, can grow a mode that amplifies round-off: at half the initial limit, twice
  // the hardened one, a 2D ball like the one below parted from its reference by 1e-6 within 40
  // steps of its impact.
  d.dt = 0.15 * solver.cflTimeStep();
  d.lowest_limit = solver.cflTimeStep();
  for (int n = 0; n < steps; ++n) {
    solver.step(d.dt);
    referenceStep(reference, d.dt);
    d.lowest_limit = std::min(d.lowest_limit, solver.cflTimeStep());
  }
  const Particles<D>& p = solver.particles();
  d.particles = p.size();
  Real x_max = 0, v_max = 0, dx = 0, dv = 0;
  for (int i = 0; i < p.size(); ++i) {
    const int id = p.id[i];  // the solver stores its particles in its own order
    x_max = std::max(x_max, reference.x[id].norm());
    v_max = std::max(v_max, reference.v[id].norm());
    dx = std::max(dx, (p.x[i] - reference.x[id]).norm());
    dv = std::max(dv, (p.v[i] - reference.v[id]).norm());
    d.plastic_reference += std::abs(reference.J_P[id] - 1) > 1e-3;
    d.plastic_solver += std::abs(solver.plasticJ()[i] - 1) > 1e-3;
  }
  d.x = dx / x_max;
  d.v = dv / v_max;
  return d;
}

// Round-off carried over the steps: measured 1e-15 to 1e-14 (each test prints its line below); a
// term missing from the step is off by percents.
constexpr Real kTolerance = 1e-10;
// The float solver against the double reference: float round-off (6e-8) carried over the
// steps, measured 2e-6 to 5e-6 in positions and 2e-5 to 6e-5 in velocities; a term missing from
// the step is still off by percents.
constexpr Real kSingleTolerance = 5e-4;

// Prints the measures and checks them.
void check(const char* name, int steps, const Difference& d, Real tolerance = kTolerance) {
  std::printf(
      "%s, %d particles, %d steps of %.3g s (CFL limit down to %.3g s): max |x - x_ref| / max "
      "|x_ref| = %.2e, max |v - v_ref| / max |v_ref| = %.2e; |J_P - 1| > 1e-3 for %d (reference), "
      "%d (solver)\n",
      name, d.particles, steps, d.dt, d.lowest_limit, d.x, d.v, d.plastic_reference,
      d.plastic_solver);
  EXPECT_LE(d.dt, d.lowest_limit) << "beyond the CFL limit: lower dt";
  EXPECT_LT(d.x, tolerance);
  EXPECT_LT(d.v, tolerance);
  // Not vacuous: the impact made much of the ball plastic, in both.
  EXPECT_GT(d.plastic_reference, d.particles / 10);
  EXPECT_GT(d.plastic_solver, d.particles / 10);
}

// The solver's defaults: MLS, quadratic, explicit, lattice volumes, separating walls with
// friction 0.2.
const std::vector<std::string> kDefaultMpm = {"mpm={}"};

// A ball of the reference snow, larger and denser in particles than the scene's, thrown down
// and sideways from low enough to hit the ground within the steps and be compacted there.
Scene ballThrownAtTheGround() {
  std::vector<std::string> overrides = kDefaultMpm;
  overrides.push_back("particles_per_cell=16");
  overrides.push_back("bodies.0.radius=0.02");
  overrides.push_back("bodies.0.center=[0.05, 0.025]");
  overrides.push_back("bodies.0.velocity=[0.5, -1.5]");
  // A sphere rising out of the ground under it, a moving collider. The grid's nodes meet the
  // colliders inside them (mpm.collider_inset), so the snow reaches their surfaces and the
  // particle collisions (Stomakhin et al. 2013, section 4 step 9) and the push-out act there.
  overrides.push_back(R"(colliders=[{"shape": "sphere", "position": [0.05, -0.005], "radius": 0.012,
                                     "velocity": [0, 0.3]}])");
  return loadScene(SNOWSIM_SOURCE_DIR "/scenes/mpm_reference.json", overrides);
}

// A snowball smashed into the domain's right wall, from closer than the scene's to hit it within
// the steps.
Scene snowballSmashedIntoAWall(std::vector<std::string> overrides = kDefaultMpm) {
  overrides.push_back("bodies.0.center=[0.08, 0.05, 0.04]");
  return loadScene(SNOWSIM_SOURCE_DIR "/scenes/study_smash_3d.json", overrides);
}

TEST(ReferenceStep, SolverMatchesTheReferenceIn2D) {
  const int steps = 400;
  check("2D", steps, runBoth<2>(ballThrownAtTheGround(), steps));
}

TEST(ReferenceStep, SolverMatchesTheReferenceIn3D) {
  const int steps = 300;
  check("3D", steps, runBoth<3>(snowballSmashedIntoAWall(), steps));
}

TEST(ReferenceStep, SinglePrecisionSolverMatchesTheReferenceIn2D) {
  const int steps = 400;
  check("2D float", steps, runBoth<2, float>(ballThrownAtTheGround(), steps), kSingleTolerance);
}

TEST(ReferenceStep, SinglePrecisionSolverMatchesTheReferenceIn3D) {
  const int steps = 300;
  // Snow pressed onto the wall's surface meets the particle collision, a yes or no on phi <= 0
  // that float round-off flips; with the grid's nodes on the surface (inset 0) no particle
  // reaches it, and float and double part by round-off alone.
  std::vector<std::string> overrides = kDefaultMpm;
  overrides.push_back("mpm.collider_inset=0");
  check("3D float", steps, runBoth<3, float>(snowballSmashedIntoAWall(overrides), steps),
        kSingleTolerance);
}

// The reference computes one configuration; it refuses the others.
TEST(ReferenceStep, RefusesAnotherTransferOrKernel) {
  const Scene scene = loadScene(SNOWSIM_SOURCE_DIR "/scenes/mpm_reference.json");  // PIC/FLIP
  EXPECT_THROW(makeReferenceState<2>(scene, sampleBodies<2>(scene)), InputError);
}

}  // namespace
