// Cracks that open (mpm.open_cracks; docs/snow-at-scale.md, "Cracks that open in the solver"). With
// one velocity a node, snow on either side of a crack shares the nodes across it and the crack
// never opens. Here a node near damaged snow keeps two velocities, one for each side of the damage,
// as in the damage-field-gradient partitioning of Homel and Herbold 2017 ("Field-gradient
// partitioning for fracture and frictional contact in the material point method", IJNME 109): a
// particle takes side 0 of a node when its damage gradient points the way of the largest damage
// gradient among the particles that reach the node, else side 1, and the two sides share one
// velocity only while they approach. Snow with no strength left (SnowMaterial::fracture_strain)
// moves in a third field of loose grains, which meets either side only while moving into it along
// that side's outward normal at the node. Fields that meet are in contact with Coulomb friction
// (mpm.crack_friction).
//
// Side 0 is the solver's own grid (its partial grids and GridFields); this class holds the other
// two fields, the damage field and the nodes' reference directions, per colour of the scatter
// (summed in colour order, so the results do not depend on the thread count) and per node. The
// functions are per particle and per node; the solver's step schedules them (MpmSolver).
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include "sim/core/grid.h"
#include "sim/core/lanes.h"
#include "sim/core/stencil.h"
#include "sim/mpm/auto_sleep.h"
#include "sim/mpm/mpm_particles.h"
#include "sim/mpm/snow_material.h"
#include "sim/parallel/zero_page_allocator.h"

namespace snowsim {

template <int D, class T>
class CrackOpening {
 public:
  using V = Vec<D, T>;
  using M = Mat<D, T>;
  static constexpr int grains = 2;  // the field of failed snow; sides 0 and 1 are intact

  // friction: the Coulomb coefficient between the faces of a crack, and between grains and the
  // intact snow.
  CrackOpening(int nodes, int colours, int particles, T friction)
      : partial_(colours),
        gradient_(particles),
        near_damage_(particles),
        grains_near_(particles),
        takes_sides_(particles),
        side_bits_(particles),
        friction_(friction) {
    for (Partial& p : partial_) p.resize(nodes);
    node_.resize(nodes);
  }

  // The damage field: each particle's mass and damage d = 1 - strength left into colour c, then
  // per node their mass-weighted mean; and the mass of the failed snow (d = 1), the grains'.
  template <class Kernel>
  void scatterDamage(const GridGeometry<D>& grid, const V& x, T mass, T damage, int c) {
    Partial& g = partial_[c];
    withStencil<Kernel>(grid, x, [&](const auto& t) {
      if (damage >= 1)
        t.scatterScalars({mass, mass, mass},
                         {g.damage_mass.data(), g.damage.data(), g.grains.data()});
      else if (damage > 0)
        t.scatterScalars({mass, mass * damage}, {g.damage_mass.data(), g.damage.data()});
      else
        t.scatterScalars({mass}, {g.damage_mass.data()});
    });
  }
  void sumDamage(int k) {
    T mass = 0, damage = 0, grains = 0;
    for (Partial& g : partial_) {
      mass += g.damage_mass[k];
      damage += g.damage[k];
      grains += g.grains[k];
      if (g.damage_mass[k] != 0 || g.damage[k] != 0 || g.grains[k] != 0)
        g.damage_mass[k] = g.damage[k] = g.grains[k] = 0;
    }
    node_.damage[k] = mass > 0 ? damage / mass : T(0);
    node_.grains[k] = grains;
  }

  // Particle p's damage gradient, MLS's grad d_p = D_p^-1 sum_i w_ip d_i (x_i - x_p), and the
  // largest of them among the particles that reach each node, into colour c; then per node, the
  // largest over the colours in colour order (ties keep the first): its reference direction.
  template <class Kernel>
  void findGradient(const GridGeometry<D>& grid, const V& x, T inertia_inverse, int p, int c) {
    withStencil<Kernel>(grid, x, [&](const auto& t) {
      const bool near = t.largest(node_.damage.data()) > 0;
      near_damage_[p] = near;
      grains_near_[p] = near && t.largest(node_.grains.data()) > 0;
      // Until decideSides, which a kept still block's snow (far from damage) skips.
      takes_sides_[p] = 0;
      const V gradient =
          near ? V(inertia_inverse * t.gatherScalarMoment(node_.damage.data())) : V::Zero();
      gradient_[p] = gradient;
      const T norm = gradient.norm();
      if (!(norm > 0)) return;
      Partial& g = partial_[c];
      t.forEachNode([&](int k, T w, const V&) {
        if (w > 0 && norm > g.reference_norm[k]) {
          g.reference_norm[k] = norm;
          g.reference[k] = gradient;
        }
      });
    });
  }
  void sumReference(int k) {
    T largest = 0;
    V reference = V::Zero();
    for (Partial& g : partial_) {
      if (g.reference_norm[k] > largest) {
        largest = g.reference_norm[k];
        reference = g.reference[k];
      }
      if (g.reference_norm[k] != 0) {
        g.reference_norm[k] = 0;
        g.reference[k].setZero();
      }
    }
    node_.reference[k] = reference;
  }

  // Whether a node of particle p's stencil holds damage.
  bool nearDamage(int p) const { return near_damage_[p]; }

  // Whether particle p scatters to and gathers from the crack's fields: failed snow does, and so
  // does intact snow that reaches grains (it gives them its outward normals) or takes side 1 at a
  // node. The rest takes side 0 of every node, and the solver's own scatter and gather do for it.
  // Decided before the scatter, once the nodes' references are known, with the side of each node
  // kept for the scatter and the gather.
  template <class Kernel>
  bool decideSides(const GridGeometry<D>& grid, const V& x, int p, bool failed) {
    static_assert(Stencil<D, Kernel, T>::nodes <= 64, "one bit a node");
    std::uint64_t bits = 0;
    if (!failed && near_damage_[p]) {
      const V gradient = gradient_[p];
      int n = 0;
      forEachNode<Kernel>(grid, x, [&](int k, T, const V&) {
        bits |= std::uint64_t(side(gradient, false, k)) << n++;
      });
    }
    side_bits_[p] = bits;
    takes_sides_[p] = failed ? takes_grains : grains_near_[p] || bits != 0 ? takes_own_sides : 0;
    return takes_sides_[p];
  }
  bool takesSides(int p) const { return takes_sides_[p]; }
  // The velocities particle p meets at its stencil's nodes: those of the fields it scattered to
  // this step (the grains' if it had failed then), else side 0's, v0.
  StencilVelocities<D, T> velocitiesOf(int p, const V* v0) const {
    if (!takes_sides_[p]) return {v0};
    if (takes_sides_[p] == takes_grains) return {node_.velocity[1].data()};
    return {nullptr, {v0, node_.velocity[0].data()}, side_bits_[p]};
  }

  // Which field of node k particle p scatters to and gathers from: the grains once it failed,
  // else the side its damage gradient lies on (side 0 where the node has no reference).
  int side(const V& gradient, bool failed, int k) const {
    return failed ? grains : int(gradient.dot(node_.reference[k]) < 0);
  }

  // MLS's scatter (the solver's scatterParticle) with sides, after decideSides: node k of the
  // stencil takes w m and w (m v + A (x_i - x_p)) into its side, side 0 being mass0 and momentum0
  // (the solver's partial grid of colour c); intact snow near grains also adds w m (x_i - x_p) to
  // its side's outward normal.
  template <class Kernel>
  void scatter(const GridGeometry<D>& grid, const V& x, int p, bool failed, T m, const V& mv,
               const M& A, T* mass0, V* momentum0, int c) {
    Partial& g = partial_[c];
    T* const mass[3] = {mass0, g.mass[0].data(), g.mass[1].data()};
    V* const momentum[3] = {momentum0, g.momentum[0].data(), g.momentum[1].data()};
    const std::uint64_t sides = side_bits_[p];
    const auto field = [&](int n) { return failed ? grains : int(sides >> n & 1); };
    const bool normals = !failed && grains_near_[p];
    withStencil<Kernel>(grid, x, [&](const auto& t) {
      t.scatterAffineSplit(m, mv, A, mass, momentum, field);
      int n = 0;
      t.forEachNode([&](int k, T w, const V& dx) {
        g.touched[k] |= normals ? touched_sides | touched_normals : touched_sides;
        if (normals) g.normal[field(n)][k] += (w * m) * dx;
        ++n;
      });
    });
  }

  // Node k once the solver has its side 0 (v0 with gravity, before collisions; mass0 its mass):
  // the other fields summed over the colours with gravity; then the two sides, where they
  // approach each other, and the grains, where they move into either side, in contact with
  // Coulomb friction; last collide(v) on each field that has mass, so that no contact moves a
  // field into a collider.
  template <class Collide>
  void updateNode(int k, T mass0, V& v0, T dt, const V& gravity, Collide&& collide) {
    // A node that no particle with sides reached has side 0 alone, and its other fields' partial
    // sums are zero: no particle gathers from them there. Nor do the colours no such particle
    // reached hold anything there, nor their normals where none near grains did.
    char any = 0;
    for (const Partial& g : partial_) any |= g.touched[k];
    if (!any) {
      if (mass0 > 0) collide(v0);
      return;
    }
    T mass[3] = {mass0, 0, 0};
    V* velocity[3] = {&v0, &node_.velocity[0][k], &node_.velocity[1][k]};
    V normal[2] = {V::Zero(), V::Zero()};
    for (int f = 1; f < 3; ++f) velocity[f]->setZero();
    for (Partial& g : partial_) {
      const char touched = g.touched[k];
      if (!touched) continue;
      g.touched[k] = 0;
      for (int f = 1; f < 3; ++f) {
        T& m = g.mass[f - 1][k];  // the partial arrays hold fields 1 and 2 only
        V& momentum = g.momentum[f - 1][k];
        mass[f] += m;
        *velocity[f] += momentum;
        if (m != 0) {
          m = 0;
          momentum.setZero();
        }
      }
      if (!(touched & touched_normals)) continue;
      for (int side = 0; side < 2; ++side) {
        normal[side] += g.normal[side][k];
        g.normal[side][k].setZero();
      }
    }
    for (int f = 1; f < 3; ++f)
      *velocity[f] = mass[f] > 0 ? V(*velocity[f] / mass[f] + dt * gravity) : V::Zero();
    // Side 0 lies behind the reference direction r: the sides approach while (v0 - v1).r > 0.
    const V& r = node_.reference[k];
    if (mass[0] > 0 && mass[1] > 0 && (v0 - *velocity[1]).dot(r) > 0)
      touch(mass[0], v0, mass[1], *velocity[1], r);
    // The grains move into side s while (v_s - v_g).n_s > 0, n_s the side's outward normal.
    for (int side = 0; side < 2; ++side)
      if (mass[grains] > 0 && mass[side] > 0 &&
          (*velocity[side] - *velocity[grains]).dot(normal[side]) > 0)
        touch(mass[side], *velocity[side], mass[grains], *velocity[grains], normal[side]);
    for (int f = 0; f < 3; ++f)
      if (mass[f] > 0) collide(*velocity[f]);
  }

  // MLS's gather with sides: v_p = sum_i w v_i and B_p = sum_i w v_i (x_i - x_p)^T, each node's
  // v_i that of particle p's field there (side 0's from v0, the solver's grid).
  template <class Kernel>
  V gather(const GridGeometry<D>& grid, const V& x, int p, bool failed, const V* v0, M& B) const {
    const V* const velocity[3] = {v0, node_.velocity[0].data(), node_.velocity[1].data()};
    const std::uint64_t sides = side_bits_[p];
    V v;
    withStencil<Kernel>(grid, x, [&](const auto& t) {
      v = t.gatherAffineSplit(
          velocity, [&](int n) { return failed ? grains : int(sides >> n & 1); }, B);
    });
    return v;
  }

 private:
  // Fields a and b in contact across a surface of normal n (from a to b, any length), a moving
  // into b: their normal velocities become their centre of mass's, and the slip along the surface
  // slows by at most friction times that normal change, stopping if that suffices (Coulomb
  // friction, as in Bardenhagen et al. 2001's multi-field contact). Momentum is kept.
  void touch(T m_a, V& v_a, T m_b, V& v_b, const V& n) const {
    const V unit = n.normalized();
    const V stick = (m_a * v_a + m_b * v_b) / (m_a + m_b) - v_a;  // a's change to move with b
    const T normal_change = stick.dot(unit);
    const V slip = stick - normal_change * unit;
    const T slip_norm = slip.norm(), most = friction_ * std::abs(normal_change);
    const V change = slip_norm > most ? V(normal_change * unit + (most / slip_norm) * slip) : stick;
    v_a += change;
    v_b -= (m_a / m_b) * change;
  }
  // f(t) with the stencil at x as rows (TensorStencil).
  template <class Kernel, class F>
  static void withStencil(const GridGeometry<D>& grid, const V& x, F&& f) {
    const Stencil<D, Kernel, T> s(x, T(1 / grid.h));
    f(TensorStencil<D, Kernel, T>(grid, s, x));
  }
  // f(k, w, x_i - x_p) for each node k of the stencil at x.
  template <class Kernel, class F>
  static void forEachNode(const GridGeometry<D>& grid, const V& x, F&& f) {
    withStencil<Kernel>(grid, x, [&](const auto& t) { t.forEachNode(f); });
  }
  // takes_sides_: the particle scattered to its sides (or, intact near grains, gave them its
  // normals), or it had failed and scattered to the grains.
  static constexpr char takes_own_sides = 1, takes_grains = 2;
  // Bits of Partial::touched: a particle with sides scattered to the node; one near grains, its
  // normal too.
  static constexpr char touched_sides = 1, touched_normals = 2;
  template <class U>
  using ZeroPageVector = std::vector<U, ZeroPageAllocator<U>>;
  // What one colour's rows scatter. Grid-sized, only the nodes near the snow take memory, and
  // each is zeroed by the node pass that sums it.
  struct Partial {
    ZeroPageVector<T> damage_mass, damage, grains, reference_norm;
    ZeroPageVector<V> reference;
    ZeroPageVector<V> normal[2];  // each side's outward normal
    ZeroPageVector<T> mass[2];    // side 1, grains
    ZeroPageVector<V> momentum[2];
    ZeroPageVector<char> touched;  // what particles with sides scattered here (touched_*)
    void resize(int nodes) {
      for (auto* a : {&damage_mass, &damage, &grains, &reference_norm, &mass[0], &mass[1]})
        a->resize(nodes);
      for (auto* a : {&reference, &normal[0], &normal[1], &momentum[0], &momentum[1]})
        a->resize(nodes);
      touched.resize(nodes);
    }
  };
  struct Nodes {
    ZeroPageVector<T> damage, grains;  // grains: the failed snow's mass
    ZeroPageVector<V> reference;
    ZeroPageVector<V> velocity[2];  // side 1, grains
    void resize(int nodes) {
      damage.resize(nodes);
      grains.resize(nodes);
      for (auto* a : {&reference, &velocity[0], &velocity[1]}) a->resize(nodes);
    }
  };
  std::vector<Partial> partial_;
  Nodes node_;
  // Per particle, this step's: the damage gradient; whether damage, grains are near; whether it
  // takes sides (decideSides).
  std::vector<V> gradient_;
  std::vector<char> near_damage_, grains_near_, takes_sides_;
  std::vector<std::uint64_t> side_bits_;  // bit n: side 1 at node n of the stencil (row by row)
  T friction_;
};

// MLS's affine momentum of particle p, which its scatter spreads with m_p v_p:
// A_p = m_p C_p + dt D^-1 (-V_p^0 tau_p), the affine part of APIC and the force of eq. 8 in one
// (Hu et al. 2018, section 5.1).
template <int D, class T>
Mat<D, T> mlsAffineMomentum(const MpmParticles<D, T>& particles, int p, T dt, T inertia_inverse) {
  const T V0 = particles.volume[p];
  const Mat<D, T> stress = V0 > 0 ? Mat<D, T>(-V0 * particles.tau[p].matrix()) : Mat<D, T>::Zero();
  return particles.mass[p] * particles.C[p] + (dt * inertia_inverse) * stress;
}

// How a step transfers to and from the grid's nodes, as a part of the step (MpmSolver::stepWith).
// One velocity a node: every particle scatters and gathers with the plain transfers, and each node
// meets the colliders.
template <int D, class T>
struct OneVelocityPerNode {
  using V = Vec<D, T>;
  const GridFields<D, T>& fields;

  template <class Schedule>
  void findSides(Schedule&) {}
  bool scattersFresh(int) const { return false; }
  template <class PartialGrid, class Plain>
  void scatter(int p, PartialGrid& g, T, Plain&& plain) const {
    plain(p, g);
  }
  // 5 for node k of mass m and velocity v.
  template <class Collide>
  void collide(int, T m, V& v, T, const V&, Collide&& collide) const {
    if (m > 0) collide(v);
  }
  template <class Plain>
  void gather(int p, Plain&& plain) const {
    plain(p);
  }
  // The velocities particle p meets at its stencil's nodes: the nodes'.
  StencilVelocities<D, T> velocitiesOf(int) const { return {fields.velocity.data()}; }
};

// With mpm.open_cracks once some snow is damaged: the damage field and the sides first; then near
// damage the scatter, the node update and the gather with CrackOpening's fields, elsewhere the
// plain transfers. MLS only.
template <int D, class T, class Kernel>
class OpenCracks {
 public:
  using V = Vec<D, T>;
  using M = Mat<D, T>;

  OpenCracks(CrackOpening<D, T>& cracks, MpmParticles<D, T>& particles,
             const SnowMaterial& material, const GridGeometry<D>& grid,
             const GridFields<D, T>& fields, T inertia_inverse)
      : cracks_(cracks),
        particles_(particles),
        material_(material),
        grid_(grid),
        fields_(fields),
        inertia_inverse_(inertia_inverse),
        isa_(vectorIsa()) {}

  // The damage field, then each particle's damage gradient and each node's reference direction,
  // which decide the sides of the scatter and the gather. Both passes take every particle, asleep
  // or not, so that the sides see all the snow's mass and damage. The stages named "crack: ..."
  // tell the cost estimate (app/cost_estimate.cpp) that these passes ran.
  template <class Schedule>
  void findSides(Schedule& schedule) {
    using PartialGrid = typename Schedule::PartialGrid;
    schedule.scatter(
        [&](int p, PartialGrid& g) {
          runFor(isa_, [&] {
            cracks_.template scatterDamage<Kernel>(grid_, particles_.x[p], particles_.mass[p],
                                                   1 - strength(p), g.colour);
          });
        },
        "crack: damage");
    schedule.forScatteredNodes("crack: damage field", [&](int k) { cracks_.sumDamage(k); });
    schedule.scatter(
        [&](int p, PartialGrid& g) {
          runFor(isa_, [&] {
            cracks_.template findGradient<Kernel>(grid_, particles_.x[p], inertia_inverse_, p,
                                                  g.colour);
          });
        },
        "crack: gradients");
    schedule.forScatteredNodes("crack: sides", [&](int k) { cracks_.sumReference(k); });
  }

  // 1 + 3: into each node's side.
  template <class PartialGrid, class Plain>
  void scatter(int p, PartialGrid& g, T dt, Plain&& plain) const {
    bool sides = false;
    runFor(isa_, [&] {
      sides = cracks_.template decideSides<Kernel>(grid_, particles_.x[p], p, failed(p));
    });
    if (!sides) return plain(p, g);
    runFor(isa_, [&] {
      const T m = particles_.mass[p];
      const M A = mlsAffineMomentum(particles_, p, dt, inertia_inverse_);
      cracks_.template scatter<Kernel>(grid_, particles_.x[p], p, failed(p), m,
                                       V(m * particles_.v[p]), A, g.mass.data(), g.momentum.data(),
                                       g.colour);
    });
  }
  // 4, 5 after side 0's velocity and gravity: the other fields', the fields' contact where they
  // approach, then the collisions.
  template <class Collide>
  void collide(int k, T m, V& v, T dt, const V& gravity, Collide&& collide) {
    cracks_.updateNode(k, m, v, dt, gravity, collide);
  }
  // 8: from each node's side.
  template <class Plain>
  void gather(int p, Plain&& plain) {
    if (!cracks_.takesSides(p)) return plain(p);
    runFor(isa_, [&] {
      M B;
      particles_.v[p] = cracks_.template gather<Kernel>(grid_, particles_.x[p], p, failed(p),
                                                        fields_.velocity.data(), B);
      particles_.C[p] = inertia_inverse_ * B;
    });
  }
  // Whether particle p, asleep or not, must scatter afresh: near damage it may take sides, which a
  // still block's kept scatter does not. (Asleep, its damage does not change: J_P stays.)
  bool scattersFresh(int p) const { return cracks_.nearDamage(p); }
  // The velocities particle p meets at its stencil's nodes: its fields'.
  StencilVelocities<D, T> velocitiesOf(int p) const {
    return cracks_.velocitiesOf(p, fields_.velocity.data());
  }

 private:
  T strength(int p) const { return strengthLeft<T>(material_, particles_.J_P[p]); }
  bool failed(int p) const { return strength(p) <= 0; }  // no strength left

  CrackOpening<D, T>& cracks_;
  MpmParticles<D, T>& particles_;
  const SnowMaterial& material_;
  const GridGeometry<D>& grid_;
  const GridFields<D, T>& fields_;  // side 0 of every node, the solver's grid
  T inertia_inverse_;
  VectorIsa isa_;  // the build the per-particle passes run in (runFor)
};

}  // namespace snowsim
