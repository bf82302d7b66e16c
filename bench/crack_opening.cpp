// Can a crack open in MPM snow? An experiment beside the solver (docs/snow-at-scale.md, "Letting
// the cracks open"), single-threaded and in double like the reference step (sim/mpm/
// reference_step.h), with two changes to the model it steps:
//  - snow past J_P = 1 softens to nothing at a fracture strain eps_f: its hardened Lamé pair and
//    its damper's viscosity are scaled by s = max(0, 1 - ln J_P / eps_f), and d = 1 - s is its
//    damage;
//  - with --split, a grid node near damaged snow keeps two velocities, one for each side of the
//    damage, as in the damage-field-gradient partitioning of Homel and Herbold 2017
//    ("Field-gradient partitioning for fracture and frictional contact in the material point
//    method", IJNME 109): a particle goes to side 0 of a node when its damage gradient points the
//    same way as the node's largest nearby damage gradient, else to side 1; the two sides share one
//    velocity (their centre of mass's) only while they approach each other;
//  - with --free-grains, snow with no strength left (s = 0) moves in a third field of its own at
//    each node, as loose grains: it shares the intact snow's velocity only while the two approach
//    (along the intact snow's outward normal at the node), so failed snow no longer ties the
//    intact pieces on either side of it together.
// Prints, per frame, the clump shares of `snowsim clumps`, and writes the frames as PLY into OUT
// with the colliders' colliders.json (`snowsim render OUT` draws them).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "app/collider_json.h"
#include "sim/core/errors.h"
#include "sim/io/files.h"
#include "sim/io/ply.h"
#include "sim/scene/sampling.h"
#include "sim/simulation.h"
#include "study/metrics.h"
#include "tests/support/reference_step.h"

namespace snowsim {
namespace {

constexpr int D = 3;
using V = Vec<D>;
using M = Mat<D>;

// The grid: per node, each field's mass and velocity (sides 0 and 1 of the intact snow, and the
// failed snow's grains), the mean damage, the largest damage gradient of the particles that reach
// it (the side's reference direction), and the intact snow's outward normal (unnormalised).
constexpr int kGrains = 2;
struct TwoSidedGrid {
  std::vector<Real> mass[3], damage;
  std::vector<V> velocity[3], reference, intact_normal;
  std::vector<Real> reference_norm;

  explicit TwoSidedGrid(int nodes) {
    for (int field = 0; field < 3; ++field)
      mass[field].assign(nodes, 0), velocity[field].assign(nodes, V::Zero());
    damage.assign(nodes, 0), reference.assign(nodes, V::Zero()), reference_norm.assign(nodes, 0);
    intact_normal.assign(nodes, V::Zero());
  }
  void clear() {
    for (int field = 0; field < 3; ++field) {
      std::fill(mass[field].begin(), mass[field].end(), Real(0));
      std::fill(velocity[field].begin(), velocity[field].end(), V::Zero());
    }
    std::fill(intact_normal.begin(), intact_normal.end(), V::Zero());
    std::fill(damage.begin(), damage.end(), Real(0));
    std::fill(reference.begin(), reference.end(), V::Zero());
    std::fill(reference_norm.begin(), reference_norm.end(), Real(0));
  }
};

struct Experiment {
  ReferenceState<D> s;
  TwoSidedGrid grid;
  std::vector<V> damage_gradient;  // per particle
  std::vector<Real> density;       // per particle, from the nodes' mass
  // Per particle, from the last return mapping: F_E's polar rotation, which the next scatter's
  // stress needs.
  std::vector<M> rotation;
  std::vector<char> failed;  // per particle, this step: no strength left, moved as a grain
  // The scene's material with the experiment's fracture strain, for strengthLeft only: the
  // reference step's hardened Lamé pair stays the one without it, softened below.
  SnowMaterial failing;
  bool split, free_grains;

  int sideOf(int p, int i) const {
    if (failed[p]) return kGrains;
    if (!split || grid.reference_norm[i] <= 0) return 0;
    return damage_gradient[p].dot(grid.reference[i]) >= 0 ? 0 : 1;
  }

  // The damage on the nodes (mass-weighted), each particle's damage gradient from them (MLS's
  // grad w_ip = w_ip D^-1 (x_i - x_p)), and each node's reference direction.
  void findSides(Real D_inv) {
    const int n = s.x.size();
    for (int p = 0; p < n; ++p) {
      const Real d = 1 - strengthLeft(failing, s.J_P[p]);
      forEachReferenceNode<D>(s.grid, s.x[p], [&](int i, Real w, const V&) {
        grid.mass[0][i] += w * s.m[p];
        grid.damage[i] += w * s.m[p] * d;
      });
    }
    for (size_t i = 0; i < grid.damage.size(); ++i)
      if (grid.mass[0][i] > 0) grid.damage[i] /= grid.mass[0][i];
    for (int p = 0; p < n; ++p) {
      V gradient = V::Zero();
      forEachReferenceNode<D>(s.grid, s.x[p], [&](int i, Real w, const V& dx) {
        gradient += w * grid.damage[i] * D_inv * dx;
      });
      damage_gradient[p] = gradient;
      const Real norm = gradient.norm();
      forEachReferenceNode<D>(s.grid, s.x[p], [&](int i, Real w, const V&) {
        if (w > 0 && norm > grid.reference_norm[i])
          grid.reference_norm[i] = norm, grid.reference[i] = gradient;
      });
    }
    std::fill(grid.mass[0].begin(), grid.mass[0].end(), Real(0));
  }

  // One explicit MLS-MPM step as referenceStep takes it, each node side by side.
  void step(Real dt) {
    const Real h = s.grid.h, D_inv = 4 / (h * h);
    const int n = s.x.size();
    placeColliders(s.colliders, s.time);
    grid.clear();
    for (int p = 0; p < n; ++p) failed[p] = free_grains && strengthLeft(failing, s.J_P[p]) <= 0;
    if (split) findSides(D_inv);
    for (int p = 0; p < n; ++p) {
      const Real left = strengthLeft(failing, s.J_P[p]);
      Lame lame = hardenedLame(s.material, s.J_P[p]);
      lame.mu *= left, lame.lambda *= left;
      M tau = fixedCorotatedKirchhoff<D>(s.F_E[p], rotation[p], lame);
      tau += s.material.viscosity * left * (s.C[p] + s.C[p].transpose());
      const M A = s.m[p] * s.C[p] + dt * D_inv * (-s.V0[p] * tau);
      forEachReferenceNode<D>(s.grid, s.x[p], [&](int i, Real w, const V& dx) {
        const int side = sideOf(p, i);
        grid.mass[side][i] += w * s.m[p];
        grid.velocity[side][i] += w * (s.m[p] * s.v[p] + A * dx);
        if (side != kGrains) grid.intact_normal[i] += w * s.m[p] * dx;
      });
    }
    for (int i = 0; i < s.grid.nodeCount(); ++i) {
      const V x_i = s.grid.position(s.grid.coords(i));
      for (int side = 0; side < 3; ++side) {
        V& v = grid.velocity[side][i];
        if (grid.mass[side][i] <= 0) {
          v.setZero();
          continue;
        }
        v = v / grid.mass[side][i] + dt * s.g;
        for (const Collider<D>& c : s.colliders) c.collide(x_i, v);
      }
      // Side 0 lies behind the reference direction: the sides approach while (v0 - v1).n > 0.
      const Real m0 = grid.mass[0][i], m1 = grid.mass[1][i];
      V& v0 = grid.velocity[0][i];
      V& v1 = grid.velocity[1][i];
      if (m0 > 0 && m1 > 0 && (v0 - v1).dot(grid.reference[i]) > 0)
        v0 = v1 = (m0 * v0 + m1 * v1) / (m0 + m1);
      // Grains meet the intact snow (both sides as one body) only while moving into it.
      const Real m_g = grid.mass[kGrains][i];
      if (m_g > 0 && m0 + m1 > 0) {
        V& v_g = grid.velocity[kGrains][i];
        const V v_intact = (m0 * v0 + m1 * v1) / (m0 + m1);
        if ((v_g - v_intact).dot(grid.intact_normal[i]) < 0) {
          const V common = (m_g * v_g + m0 * v0 + m1 * v1) / (m_g + m0 + m1);
          v_g = common;
          if (m0 > 0) v0 = common;
          if (m1 > 0) v1 = common;
        }
      }
    }
    const M I = M::Identity();
    for (int p = 0; p < n; ++p) {
      V v = V::Zero();
      M B = M::Zero();
      Real node_mass = 0;
      forEachReferenceNode<D>(s.grid, s.x[p], [&](int i, Real w, const V& dx) {
        const V& v_i = grid.velocity[sideOf(p, i)][i];
        v += w * v_i;
        B += w * v_i * dx.transpose();
        node_mass += w * (grid.mass[0][i] + grid.mass[1][i] + grid.mass[kGrains][i]);
      });
      density[p] = node_mass / (h * h * h);
      s.v[p] = v;
      s.C[p] = D_inv * B;
      s.F_E[p] = (I + dt * s.C[p]) * s.F_E[p];
      s.J_P[p] = plasticReturnMappingJ(s.material, s.F_E[p], s.J_P[p], rotation[p]);
      for (const Collider<D>& c : s.colliders) c.collide(s.x[p], s.v[p]);
      s.x[p] += dt * s.v[p];
      for (const Collider<D>& c : s.colliders) c.pushOut(s.x[p]);
      s.x[p] = s.x[p].cwiseMax(V::Zero()).cwiseMin(s.grid.extent());
    }
    s.time += dt;
  }
};

SnowMaterial failingMaterial(SnowMaterial m, Real eps_f) {
  m.fracture_strain = eps_f;
  return m;
}

struct Options {
  std::string scene, out;
  std::vector<std::string> overrides;
  double dt = 0, eps_f = 0.2;
  bool split = false, free_grains = false;
};

void run(const Options& o) {
  const Scene scene = loadScene(o.scene, o.overrides);
  if (scene.dimension != 3) throw InputError(o.scene + ": the experiment is 3D only");
  if (!(o.eps_f > 0)) throw InputError("--fracture-strain: must be > 0");
  if (!(o.dt > 0)) throw InputError("--dt: must be > 0");
  const Particles<D> particles = sampleBodies<D>(scene);
  // The frames' format (grid, colliders, masses, radii) from the solver's own first frame.
  Snapshot frame = makeSimulation(scene, 1)->snapshot(0);
  Experiment e{makeReferenceState<D>(scene, particles),  TwoSidedGrid(0), {},           {}, {}, {},
               failingMaterial(scene.material, o.eps_f), o.split,         o.free_grains};
  e.grid = TwoSidedGrid(e.s.grid.nodeCount());
  e.damage_gradient.assign(e.s.x.size(), V::Zero());
  e.density.assign(e.s.x.size(), 0);
  e.failed.assign(e.s.x.size(), 0);
  for (const M& F_E : e.s.F_E) e.rotation.push_back(polarRotation<D>(F_E));
  for (int p = 0; p < frame.size(); ++p)  // the same particles in the same order
    for (int a = 0; a < 3; ++a)
      if (std::abs(frame.position[p][a] - e.s.x[p][a]) > 1e-6)
        throw InputError("the solver's first frame and the sampled particles differ");
  prepareOutputDirectory(o.out);
  const int frames = scene.frameCount();
  const int steps_per_frame = std::max(1, int(std::lround(1 / (scene.fps * o.dt))));
  // First, so that the frames of a run still going (or stopped) show the wall too.
  if (!scene.colliders.empty())
    writeFileAtomically(o.out + "/colliders.json",
                        colliderFramesJson(scene, frames + 1).dump(1) + "\n");
  std::printf("frame,time_s,largest_share,other_chunks_share,single_share\n");
  for (int f = 0; f <= frames; ++f) {
    if (f > 0)
      for (int k = 0; k < steps_per_frame; ++k) e.step(1 / scene.fps / steps_per_frame);
    for (int p = 0; p < frame.size(); ++p) {
      for (int a = 0; a < 3; ++a) {
        frame.position[p][a] = float(e.s.x[p][a]);
        frame.velocity[p][a] = float(e.s.v[p][a]);
      }
      frame.plastic_j[p] = float(e.s.J_P[p]);
      if (f > 0) frame.density[p] = float(e.density[p]);
    }
    frame.frame = f;
    frame.time = e.s.time;
    char name[32];
    std::snprintf(name, sizeof name, "/frame_%05d.ply", f);
    writePly(o.out + name, frame);
    const ClumpStats c = findClumps(frame, 1.5 * frame.grid.particle_spacing, 8);
    const double largest = double(c.largest) / c.particles;
    std::printf("%d,%.4f,%.4f,%.4f,%.4f\n", f, e.s.time, largest, c.clumped_share - largest,
                c.single_share);
    std::fflush(stdout);
  }
}

}  // namespace
}  // namespace snowsim

int main(int argc, char** argv) {
  snowsim::Options o;
  CLI::App app{"An MPM snow smash whose cracks may open (docs/snow-at-scale.md)"};
  app.add_option("scene", o.scene, "3D scene file")->required();
  app.add_option("-o,--out", o.out, "Output directory for the PLY frames")->required();
  app.add_option("--set", o.overrides, "Override a scene field, as for snowsim run");
  app.add_option("--dt", o.dt, "Fixed time step (s); frames land on whole steps")->required();
  app.add_option("--fracture-strain", o.eps_f, "ln J_P at which snow has no strength left")
      ->capture_default_str();
  app.add_flag("--split", o.split, "Two velocities a node across damaged snow");
  app.add_flag("--free-grains", o.free_grains,
               "Snow with no strength left moves as loose grains, a field of its own");
  CLI11_PARSE(app, argc, argv);
  try {
    snowsim::run(o);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "crack_opening: %s\n", e.what());
    return 2;
  }
}
