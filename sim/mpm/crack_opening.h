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
// The damage field and the references lag one step behind the snow: each step's scatter reads
// the last step's and scatters the next, so a crack step passes over the particles no more often
// than a plain one. The snow moves a fraction of a cell in a step, and its damage changes slowly.
//
// Side 0 is the solver's own grid (its partial grids and GridFields); this class holds the other
// two fields, the damage field and the nodes' reference directions, per colour of the scatter
// (summed in colour order, so the results do not depend on the thread count) and per node. The
// functions are per particle and per node; the solver's step schedules them (MpmSolver).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

#include "sim/core/grid.h"
#include "sim/core/lanes.h"
#include "sim/core/stencil.h"
#include "sim/mpm/auto_sleep.h"
#include "sim/mpm/mpm_particles.h"
#include "sim/mpm/snow_material.h"
#include "sim/parallel/still_blocks.h"
#include "sim/parallel/zero_page_allocator.h"

namespace snowsim {

template <int D, class T>
class CrackOpening {
 public:
  using V = Vec<D, T>;
  using M = Mat<D, T>;
  static constexpr int grains = 2;  // the field of failed snow; sides 0 and 1 are intact

  // colours: the scatter's; blocks: those of its still blocks (ParticleGridSchedule::blockCount);
  // friction: the Coulomb coefficient between the faces of a crack, and between grains and the
  // intact snow.
  CrackOpening(int nodes, int colours, int particles, int blocks, T friction)
      : partial_(colours),
        scratch_(colours),
        sides_(particles),
        side_bits_(particles),
        kept_(blocks),
        friction_(friction) {
    for (Partial& p : partial_) p.resize(nodes);
    for (Partial& p : scratch_) p.resize(nodes);
    node_.resize(nodes);
  }

  // A step with cracks begins; damaged: whether some snow holds damage now. The damage field and
  // the references this step reads are the last crack step's: zero everywhere after a step
  // without damage, so a step without cracks in between leaves nothing stale.
  void beginStep(bool damaged) {
    must_prime_ = damaged && !holds_damage_;
    holds_damage_ = damaged;
    ++step_;
  }
  // Whether the last crack step scattered damage, which the next step's sides read.
  bool holdsDamage() const { return holds_damage_; }

  // The first step with damage after none (snow that starts damaged, or damage that comes back)
  // has no last step's field to read: it makes its own from the snow as it is, first the damage
  // field (primeDamage for each particle, then sumPrimedDamage for each node), then the
  // references (primeReference, sumPrimedReference).
  bool mustPrime() const { return must_prime_; }
  template <class Rows>
  void primeDamage(const Rows& t, T m, T damage, int c) {
    Partial& g = partial(c);  // the mass and the grains' mass in the arrays of sides 1 and 2
    if (damage >= 1)
      t.scatterScalars({m, m, m}, {g.mass[0].data(), g.damage.data(), g.mass[1].data()});
    else if (damage > 0)
      t.scatterScalars({m, m * damage}, {g.mass[0].data(), g.damage.data()});
    else
      t.scatterScalars({m}, {g.mass[0].data()});
  }
  void sumPrimedDamage(int k) {
    T mass = 0, damage = 0, grains = 0;
    for (Partial& g : partial_) {
      mass += g.mass[0][k];
      damage += g.damage[k];
      grains += g.mass[1][k];
      if (g.mass[0][k] != 0 || g.damage[k] != 0 || g.mass[1][k] != 0)
        g.mass[0][k] = g.damage[k] = g.mass[1][k] = 0;
    }
    node_.damage[k] = mass > 0 ? damage / mass : T(0);
    node_.grains[k] = grains;
  }
  template <class Rows>
  void primeReference(const Rows& t, T inertia_inverse, int c) {
    if (!nearDamage(t)) return;
    const V gradient = damageGradient(t, inertia_inverse);
    const T norm = gradient.norm();
    if (!(norm > 0)) return;
    Partial& g = partial(c);
    t.forEachNode([&](int k, T w, const V&) { refer(g, k, w, gradient, norm); });
  }
  void sumPrimedReference(int k) { node_.reference[k] = largestReference(k); }

  // What a particle's scatter reads of the last step's damage field d_i, the damage field
  // lagging a step behind the snow: near damage (a node of the stencil with d_i > 0) its damage
  // gradient (damageGradient), and the sides it takes, side 0 of node i when the gradient points
  // the way of the node's reference direction r_i, else side 1; whether grains are near; and so
  // what it takes (takes_*, in the low bits of flags). A sleeping particle keeps its last.
  struct Reading {
    V gradient = V::Zero();
    std::uint64_t side_bits = 0;
    char flags = 0;  // takes_* | near_grains
  };
  template <class Rows>
  Reading read(const Rows& t, T damage, T inertia_inverse) const {
    static_assert(Rows::rows * Rows::row_nodes <= 64, "one bit a node");
    Reading r;
    const bool failed = damage >= 1;
    if (nearDamage(t)) {
      r.gradient = damageGradient(t, inertia_inverse);
      if (t.largest(node_.grains.data()) > 0) r.flags = near_grains;
      int n = 0;
      if (!failed)
        t.forEachNode([&](int k, T, const V&) {
          r.side_bits |= std::uint64_t(side(r.gradient, false, k)) << n++;
        });
    }
    r.flags |= failed ? takes_grains : (r.flags & near_grains) || r.side_bits ? takes_own_sides : 0;
    return r;
  }

  // Particle p's scatter, rows t of its stencil, in colour c, with what it read (read()): MLS's
  // scatter (the solver's scatterParticle), node i taking w m and w (m v + A (x_i - x_p)), into
  // the field of each node the particle takes; and its damage gradient goes into the next step's
  // r_i, the largest among the particles that reach the node. Failed snow (damage 1) takes the
  // grains everywhere; intact snow near grains also adds w m (x_i - x_p) to its side's outward
  // normal. The damage m d goes into the next field.
  template <class Rows>
  void scatter(const Rows& t, int p, const Reading& r, T damage, T m, const V& mv, const M& A,
               T* mass0, V* momentum0, int c) {
    Partial& g = partial(c);
    const bool failed = damage >= 1;
    const std::uint64_t bits = r.side_bits;
    char touched = damage > 0 ? touched_damage : 0;
    const T norm = r.gradient.norm();
    if (holds_damage_ && norm > 0) {
      touched |= touched_reference;
      t.forEachNode([&](int k, T w, const V&) { refer(g, k, w, r.gradient, norm); });
    }
    if (damage > 0) t.scatterScalars({m * damage}, {g.damage.data()});
    takeSides(p, r);
    if (!takesSides(p)) {
      t.scatterAffine(m, mv, A, mass0, momentum0);
      if (touched) t.forEachNode([&](int k, T, const V&) { g.touched[k] |= touched; });
      return;
    }
    T* const mass[3] = {mass0, g.mass[0].data(), g.mass[1].data()};
    V* const momentum[3] = {momentum0, g.momentum[0].data(), g.momentum[1].data()};
    const auto field = [&](int n) { return failed ? grains : int(bits >> n & 1); };
    t.scatterAffineSplit(m, mv, A, mass, momentum, field);
    const bool normals = !failed && (r.flags & near_grains);
    touched |= normals ? touched_sides | touched_normals : touched_sides;
    int n = 0;
    t.forEachNode([&](int k, T w, const V& dx) {
      g.touched[k] |= touched;
      if (normals) g.normal[field(n)][k] += (w * m) * dx;
      ++n;
    });
  }

  // Whether a node of the stencil t holds damage, and MLS's damage gradient there,
  // grad d_p = D_p^-1 sum_i w_ip d_i (x_i - x_p), in the last step's damage field.
  template <class Rows>
  bool nearDamage(const Rows& t) const {
    return t.largest(node_.damage.data()) > 0;
  }
  template <class Rows>
  V damageGradient(const Rows& t, T inertia_inverse) const {
    return inertia_inverse * t.gatherScalarMoment(node_.damage.data());
  }
  // Which field of node k snow of damage gradient `gradient` takes: the grains once it failed,
  // else the side the gradient lies on (side 0 where the node has no reference).
  int side(const V& gradient, bool failed, int k) const {
    return failed ? grains : int(gradient.dot(node_.reference[k]) < 0);
  }
  // Whether particle p scattered to the crack's fields this step (and gathers from them).
  bool takesSides(int p) const { return takes(p) != 0; }
  // Particle p takes this step the fields of reading r (a kept scatter's, which it skips).
  void takeSides(int p, const Reading& r) {
    sides_[p] = stamp() | (r.flags & takes_mask);
    side_bits_[p] = r.side_bits;
  }
  // The velocities particle p meets at its stencil's nodes: those of the fields it scattered to
  // this step (the grains' if it had failed then), else side 0's, v0.
  StencilVelocities<D, T> velocitiesOf(int p, const V* v0) const {
    const char t = takes(p);
    if (!t) return {v0};
    if (t == takes_grains) return {node_.velocity[1].data()};
    return {nullptr, {v0, node_.velocity[0].data()}, side_bits_[p]};
  }

  // MLS's gather with sides: v_p = sum_i w v_i and B_p = sum_i w v_i (x_i - x_p)^T, each node's
  // v_i that of the field particle p scattered to there (side 0's from v0, the solver's grid).
  template <class Rows>
  V gather(const Rows& t, int p, const V* v0, M& B) const {
    const V* const velocity[3] = {v0, node_.velocity[0].data(), node_.velocity[1].data()};
    const bool failed = takes(p) == takes_grains;
    const std::uint64_t sides = side_bits_[p];
    return t.gatherAffineSplit(
        velocity, [&](int n) { return failed ? grains : int(sides >> n & 1); }, B);
  }

  // Node k once the solver has its side 0 (v0 with gravity, before collisions; mass0 its mass):
  // the other fields summed over the colours with gravity; then the two sides, where they
  // approach each other, and the grains, where they move into either side, in contact with
  // Coulomb friction; last collide(v) on each field that has mass, so that no contact moves a
  // field into a collider. Then the next step's damage field, the mass-weighted mean damage of the
  // snow at the node, and reference direction, the largest over the colours in colour order
  // (ties keep the first).
  template <class Collide>
  void updateNode(int k, T mass0, V& v0, T dt, const V& gravity, Collide&& collide) {
    // A node that no particle with sides, damage or a damage gradient reached has side 0 alone, and
    // its other fields' partial sums are zero: no particle gathers from them there. Nor do the
    // colours no such particle reached hold anything there.
    char any = 0;
    for (const Partial& g : partial_) any |= g.touched[k];
    if (!any) {
      if (mass0 > 0) collide(v0);
      clearNode(k);
      return;
    }
    T mass[3] = {mass0, 0, 0};
    V* velocity[3] = {&v0, &node_.velocity[0][k], &node_.velocity[1][k]};
    V normal[2] = {V::Zero(), V::Zero()};
    T damage = 0;
    for (int f = 1; f < 3; ++f) velocity[f]->setZero();
    for (Partial& g : partial_) {
      const char touched = g.touched[k];
      if (!touched) continue;
      g.touched[k] = 0;
      if (touched & touched_sides)
        for (int f = 1; f < 3; ++f) {
          T& m = g.mass[f - 1][k];  // the partial arrays hold fields 1 and 2 only
          V& momentum = g.momentum[f - 1][k];
          mass[f] += m;
          *velocity[f] += momentum;
          m = 0;
          momentum.setZero();
        }
      if (touched & touched_normals)
        for (int side = 0; side < 2; ++side) {
          normal[side] += g.normal[side][k];
          g.normal[side][k].setZero();
        }
      if (touched & touched_damage) {
        damage += g.damage[k];
        g.damage[k] = 0;
      }
    }
    const V next_reference = largestReference(k);
    const T node_mass = mass[0] + mass[1] + mass[2];
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
    node_.damage[k] = node_mass > 0 ? damage / node_mass : T(0);
    node_.grains[k] = mass[grains];
    node_.reference[k] = next_reference;
  }

  // A still block's part of the scatter (ParticleGridSchedule::scatter with stillness): what its
  // still particles scattered into the scratch of `colour` (colours + its colour), taken out and
  // kept; and added, its momenta times `scale`, into the partial fields of `colour`.
  template <class Region>
  void keepBlock(int block, int colour, Region&& region);
  void addKeptBlock(int block, int colour, T scale);

  // Across MPI ranks, at the nodes a rank shares with a neighbour (RankState::exchangeRecords),
  // what the particles of each scattered there: of the crack step's scatter before its node update,
  // of the priming passes before their node passes. shareAt sums node k's partial fields over the
  // colours into the first colour's, in colour order as updateNode sums them, and returns the sum
  // (false when nothing is there); addShare adds a neighbour's. Both ranks then hold the same sums
  // (a + b == b + a), and the same reference: the larger, ties to the larger components.
  struct NodeShare {
    int k;
    char touched;
    T damage, reference_norm, mass[2];
    V reference, normal[2], momentum[2];
  };
  bool shareAt(int k, NodeShare& share) {
    share.k = k;
    share.touched = 0;
    share.damage = share.mass[0] = share.mass[1] = 0;
    for (int f = 0; f < 2; ++f) share.normal[f] = share.momentum[f] = V::Zero();
    share.reference = largestReference(k);
    share.reference_norm = share.reference.norm();
    for (Partial& g : partial_) {  // a side's momentum or normal comes with its touched bit
      if (!g.touched[k] && g.damage[k] == 0 && g.mass[0][k] == 0 && g.mass[1][k] == 0) continue;
      share.touched |= g.touched[k];
      share.damage += g.damage[k];
      for (int f = 0; f < 2; ++f) {
        share.mass[f] += g.mass[f][k];
        share.normal[f] += g.normal[f][k];
        share.momentum[f] += g.momentum[f][k];
      }
      clearPartial(g, k);
    }
    const bool any = share.touched || share.damage != 0 || share.reference_norm != 0 ||
                     share.mass[0] != 0 || share.mass[1] != 0;
    if (any) addShare(share);  // into the first colour's, emptied above
    return any;
  }
  void addShare(const NodeShare& share) {
    Partial& g = partial_[0];
    const int k = share.k;
    g.touched[k] |= share.touched;
    g.damage[k] += share.damage;
    for (int f = 0; f < 2; ++f) {
      g.mass[f][k] += share.mass[f];
      g.normal[f][k] += share.normal[f];
      g.momentum[f][k] += share.momentum[f];
    }
    const auto key = [](T norm, const V& r) {
      std::array<T, D + 1> key{norm};
      for (int a = 0; a < D; ++a) key[a + 1] = r[a];
      return key;
    };
    if (key(share.reference_norm, share.reference) > key(g.reference_norm[k], g.reference[k])) {
      g.reference_norm[k] = share.reference_norm;
      g.reference[k] = share.reference;
    }
  }
  // What the next step reads of node k, for a particle that migrates to another rank, whose own
  // particles may not have reached the node: false when it is all zero.
  struct NodeState {
    int k;
    T damage, grains;
    V reference;
  };
  bool stateAt(int k, NodeState& state) const {
    state = {k, node_.damage[k], node_.grains[k], node_.reference[k]};
    return state.damage != 0 || state.grains != 0 || !state.reference.isZero(0);
  }
  // Across MPI ranks, after a step that holds damage: the particles that left their slab move to
  // their new rank (RankState::migrateWithRecords), each bringing what the next step reads at its
  // stencil's nodes, which that rank's own particles may not have reached, from the nodes its old
  // rank's particles could reach. The new rank keeps its own values where its particles could
  // reach the node and its active box holds it. Returns whether this rank's particles changed.
  template <class Kernel, class Ranks, class P>
  bool migrate(Ranks& ranks, P& particles, const GridGeometry<D>& grid, const NodeBox<D>& active,
               long step);

  // What the next step reads of the nodes (the damage field, the grains' mass, the references),
  // for a checkpoint: the nodes where any is not zero, and back.
  template <class Writer>
  void save(Writer& out) const {
    std::vector<int> nodes;
    for (int k = 0; k < int(node_.damage.size()); ++k)
      if (node_.damage[k] != 0 || node_.grains[k] != 0 || !node_.reference[k].isZero(0))
        nodes.push_back(k);
    out.value(holds_damage_);
    out.array(nodes);
    for (const int k : nodes) {
      out.value(node_.damage[k]);
      out.value(node_.grains[k]);
      out.value(node_.reference[k]);
    }
  }
  template <class Reader>
  void load(Reader& in) {
    for (int k = 0; k < int(node_.damage.size()); ++k) clearNode(k);
    holds_damage_ = in.template value<bool>();
    std::vector<int> nodes;
    in.array(nodes);
    for (const int k : nodes) {
      if (k < 0 || k >= int(node_.damage.size())) in.fail("a crack node outside the grid");
      node_.damage[k] = in.template value<T>();
      node_.grains[k] = in.template value<T>();
      node_.reference[k] = in.template value<V>();
    }
  }

 private:
  // The step's stamp in sides_, above takes_*: a side taken in an earlier step (or by the
  // particle stored there before a sort) reads as none.
  std::uint32_t stamp() const { return std::uint32_t(step_) << 2; }
  char takes(int p) const {
    const std::uint32_t s = sides_[p];
    return (s & ~3u) == stamp() ? char(s & 3u) : 0;
  }
  void clearNode(int k) {
    if (node_.damage[k] != 0 || node_.grains[k] != 0) node_.damage[k] = node_.grains[k] = 0;
    if (!node_.reference[k].isZero(0)) node_.reference[k].setZero();
  }
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
  // What a particle scattered to this step: its sides or, failed, the grains.
  static constexpr char takes_own_sides = 1, takes_grains = 2;
  static constexpr char takes_mask = 3;
  static constexpr char near_grains = 4;  // Reading::flags: grains at a node of the stencil
  // Bits of Partial::touched, what particles scattered to the node: a particle with sides; one
  // near grains, its normal too; damaged snow, its damage; snow near damage, its gradient.
  static constexpr char touched_sides = 1, touched_normals = 2, touched_damage = 4,
                        touched_reference = 8;
  template <class U>
  using ZeroPageVector = std::vector<U, ZeroPageAllocator<U>>;
  // What one colour's rows scatter. Grid-sized, only the nodes near the snow take memory, and
  // each is zeroed by the node pass that sums it.
  struct Partial {
    ZeroPageVector<T> damage, reference_norm;
    ZeroPageVector<V> reference;
    ZeroPageVector<V> normal[2];  // each side's outward normal
    ZeroPageVector<T> mass[2];    // side 1, grains
    ZeroPageVector<V> momentum[2];
    ZeroPageVector<char> touched;  // touched_* bits
    void resize(int nodes) {
      for (auto* a : {&damage, &reference_norm, &mass[0], &mass[1]}) a->resize(nodes);
      for (auto* a : {&reference, &normal[0], &normal[1], &momentum[0], &momentum[1]})
        a->resize(nodes);
      touched.resize(nodes);
    }
  };
  struct Nodes {
    // The last crack step's: the damage field, the failed snow's mass, the reference directions.
    ZeroPageVector<T> damage, grains;
    ZeroPageVector<V> reference;
    ZeroPageVector<V> velocity[2];  // this step's side 1, grains
    void resize(int nodes) {
      damage.resize(nodes);
      grains.resize(nodes);
      for (auto* a : {&reference, &velocity[0], &velocity[1]}) a->resize(nodes);
    }
  };
  // Node k's state from a neighbour rank (migrate).
  void setState(const NodeState& state) {
    node_.damage[state.k] = state.damage;
    node_.grains[state.k] = state.grains;
    node_.reference[state.k] = state.reference;
  }
  static void clearPartial(Partial& g, int k) {
    g.touched[k] = 0;
    g.damage[k] = g.reference_norm[k] = g.mass[0][k] = g.mass[1][k] = 0;
    for (V* a :
         {&g.reference[k], &g.normal[0][k], &g.normal[1][k], &g.momentum[0][k], &g.momentum[1][k]})
      a->setZero();
  }
  // Gradient `gradient` of norm `norm` reaching node k with weight w, into colour g's largest.
  static void refer(Partial& g, int k, T w, const V& gradient, T norm) {
    if (w > 0 && norm > g.reference_norm[k]) {
      g.reference_norm[k] = norm;
      g.reference[k] = gradient;
    }
  }
  // The largest gradient over the colours that reached node k, in colour order (ties keep the
  // first), the colours' emptied.
  V largestReference(int k) {
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
    return reference;
  }
  // What a still block kept: its nodes' values of Partial where it touched them.
  struct KeptNode {
    int k;
    char touched;
    T damage, reference_norm, mass[2];
    V reference, normal[2], momentum[2];
  };
  using KeptBlock = std::vector<KeptNode>;
  // The partial fields of colour c, or for c = colours + c' the still blocks' scratch of c'.
  Partial& partial(int c) {
    const int colours = int(partial_.size());
    return c < colours ? partial_[c] : scratch_[c - colours];
  }
  std::vector<Partial> partial_, scratch_;
  Nodes node_;
  // Per particle, this step's: stamp() | takes_*, and bit n: side 1 at node n of the stencil (row
  // by row).
  std::vector<std::uint32_t> sides_;
  std::vector<std::uint64_t> side_bits_;
  std::vector<KeptBlock> kept_;  // per still block
  std::vector<int> carried_;     // migrate's scratch: the nodes the leaving particles reach
  T friction_;
  long step_ = 0;
  bool holds_damage_ = false, must_prime_ = false;
};

template <int D, class T>
template <class Region>
void CrackOpening<D, T>::keepBlock(int block, int colour, Region&& region) {
  KeptBlock& b = kept_[block];
  b.clear();
  Partial& s = partial(colour);
  region([&](int k) {
    const char touched = s.touched[k];
    if (!touched) return;
    b.push_back({k,
                 touched,
                 s.damage[k],
                 s.reference_norm[k],
                 {s.mass[0][k], s.mass[1][k]},
                 s.reference[k],
                 {s.normal[0][k], s.normal[1][k]},
                 {s.momentum[0][k], s.momentum[1][k]}});
    clearPartial(s, k);
  });
}
template <int D, class T>
void CrackOpening<D, T>::addKeptBlock(int block, int colour, T scale) {
  Partial& g = partial_[colour];
  for (const KeptNode& n : kept_[block]) {
    const int k = n.k;
    g.touched[k] |= n.touched;
    if (n.touched & touched_sides)
      for (int f = 0; f < 2; ++f) {
        g.mass[f][k] += n.mass[f];
        g.momentum[f][k] += scale * n.momentum[f];
      }
    if (n.touched & touched_normals)
      for (int side = 0; side < 2; ++side) g.normal[side][k] += n.normal[side];
    if (n.touched & touched_damage) g.damage[k] += n.damage;
    if (n.reference_norm > g.reference_norm[k]) {
      g.reference_norm[k] = n.reference_norm;
      g.reference[k] = n.reference;
    }
  }
}

template <int D, class T>
template <class Kernel, class Ranks, class P>
bool CrackOpening<D, T>::migrate(Ranks& ranks, P& particles, const GridGeometry<D>& grid,
                                 const NodeBox<D>& active, long step) {
  const auto& slabs = ranks.slabs();
  return ranks.template migrateWithRecords<NodeState>(
      particles, step,
      [&](const std::vector<int>& leaving, auto&& send) {
        carried_.clear();
        for (const int p : leaving)
          forEachStencilNode<D, Kernel>(grid, particles.x[p],
                                        [&](int k, T, const V&) { carried_.push_back(k); });
        std::sort(carried_.begin(), carried_.end());
        carried_.erase(std::unique(carried_.begin(), carried_.end()), carried_.end());
        NodeState state;
        std::memset(static_cast<void*>(&state), 0, sizeof state);  // its padding: the same bytes
        for (const int k : carried_)
          if (slabs.reachedInLastStep(k) && stateAt(k, state)) send(state);
      },
      [&](const NodeState& state) {
        const bool own = slabs.reachedInLastStep(state.k) && ranks.contains(active, state.k);
        if (!own) setState(state);
      });
}

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

  static constexpr std::string_view scatter_stage = "scatter";
  template <class Schedule, class Ranks>
  void prime(Schedule&, Ranks&) {}
  template <class Ranks>
  void sumShares(Ranks&, const NodeBox<D>&) {}
  NoOwnFields stillFields() const { return {}; }
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

// With mpm.open_cracks once some snow is damaged (and the step after, which clears the damage
// field): the scatter, the node update and the gather with CrackOpening's fields. MLS only.
template <int D, class T, class Kernel>
class OpenCracks {
 public:
  using V = Vec<D, T>;
  using M = Mat<D, T>;
  // The stage's name tells the cost estimate (app/cost_estimate.cpp) that the crack step ran.
  static constexpr std::string_view scatter_stage = "crack: scatter";

  // sleep_steps: auto-sleep's steps (AutoSleep::steps), with the particles' crack_* arrays to
  // keep their readings in, else -1.
  OpenCracks(CrackOpening<D, T>& cracks, MpmParticles<D, T>& particles,
             const SnowMaterial& material, const GridGeometry<D>& grid,
             const GridFields<D, T>& fields, T inertia_inverse, bool damaged, int sleep_steps)
      : cracks_(cracks),
        particles_(particles),
        material_(material),
        grid_(grid),
        fields_(fields),
        inertia_inverse_(inertia_inverse),
        sleep_steps_(sleep_steps),
        keeps_readings_(sleep_steps >= 0),
        isa_(vectorIsa()) {
    cracks_.beginStep(damaged);
  }

  // The damage field and the references of the first step with damage (CrackOpening::mustPrime),
  // over every particle, asleep or not, so that they see all the snow's mass and damage. ranks:
  // the solver's RankState.
  template <class Schedule, class Ranks>
  void prime(Schedule& schedule, Ranks& ranks) {
    if (!cracks_.mustPrime()) return;
    using PartialGrid = typename Schedule::PartialGrid;
    schedule.scatter(
        [&](int p, PartialGrid& g) {
          withRows(p, [&](const auto& t) {
            cracks_.primeDamage(t, particles_.mass[p], damage(p), g.colour);
          });
        },
        "crack: prime damage");
    overPrimedNodes(schedule, ranks, "crack: prime damage field",
                    [&](int k) { cracks_.sumPrimedDamage(k); });
    schedule.scatter(
        [&](int p, PartialGrid& g) {
          withRows(p,
                   [&](const auto& t) { cracks_.primeReference(t, inertia_inverse_, g.colour); });
        },
        "crack: prime references");
    overPrimedNodes(schedule, ranks, "crack: prime reference field",
                    [&](int k) { cracks_.sumPrimedReference(k); });
  }
  // Across MPI ranks, between the sum of the grids and the node update: the neighbours' shares of
  // the crack's partial fields at the nodes they share, added within this rank's active box.
  template <class Ranks>
  void sumShares(Ranks& ranks, const NodeBox<D>& active) {
    using Share = typename CrackOpening<D, T>::NodeShare;
    ranks.template exchangeRecords<Share>(
        active, [&](int k, Share& share) { return cracks_.shareAt(k, share); },
        [&](const Share& share) {
          if (ranks.contains(active, share.k)) cracks_.addShare(share);
        });
  }

  // 1 + 3: into each node's side, with what the particle reads of the damage field, or, asleep
  // since its last scatter, what it read then.
  template <class PartialGrid, class Plain>
  void scatter(int p, PartialGrid& g, T dt, Plain&&) const {
    withRows(p, [&](const auto& t) {
      const T d = damage(p);
      Reading r;
      if (sleptSinceLastScatter(p)) {
        r = kept(p);
      } else {
        r = cracks_.read(t, d, inertia_inverse_);
        if (keeps_readings_) keep(p, r);
      }
      const T m = particles_.mass[p];
      cracks_.scatter(t, p, r, d, m, V(m * particles_.v[p]),
                      mlsAffineMomentum(particles_, p, dt, inertia_inverse_), g.mass.data(),
                      g.momentum.data(), g.colour);
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
    withRows(p, [&](const auto& t) {
      M B;
      particles_.v[p] = cracks_.gather(t, p, fields_.velocity.data(), B);
      particles_.C[p] = inertia_inverse_ * B;
    });
  }
  // What still blocks keep of the crack's fields with their scatter (ParticleGridSchedule::scatter
  // with stillness). Asleep, a particle's damage does not change (J_P stays), nor what it read.
  class StillFields {
   public:
    explicit StillFields(const OpenCracks& opening) : o_(opening) {}
    template <class ForStill, class Region>
    void keep(int block, int colour, ForStill&&, Region&& region) const {
      o_.cracks_.keepBlock(block, colour, region);
    }
    template <class ForStill>
    void reuse(int, ForStill&& forStill) const {
      forStill([&](int p) { o_.cracks_.takeSides(p, o_.kept(p)); });
    }
    void add(int block, int colour, T scale) const {
      o_.cracks_.addKeptBlock(block, colour, scale);
    }

   private:
    const OpenCracks& o_;
  };
  StillFields stillFields() const { return StillFields(*this); }
  // The velocities particle p meets at its stencil's nodes: its fields'.
  StencilVelocities<D, T> velocitiesOf(int p) const {
    return cracks_.velocitiesOf(p, fields_.velocity.data());
  }

 private:
  // f(k) over the nodes a priming scatter reached, across ranks with the neighbours' shares.
  template <class Schedule, class Ranks, class F>
  void overPrimedNodes(Schedule& schedule, Ranks& ranks, std::string_view stage, F&& f) {
    if (!ranks.distributed()) return schedule.forScatteredNodes(stage, f);
    const NodeBox<D> active = schedule.activeNodes();
    schedule.timed("crack: prime exchange", [&] { sumShares(ranks, active); });
    schedule.forBoxNodes(stage, f);
  }
  // Damage d = 1 - strength left (SnowMaterial::fracture_strain) of particle p.
  T damage(int p) const { return 1 - strengthLeft<T>(material_, particles_.J_P[p]); }
  // f(rows of particle p's stencil), in the build for isa_.
  template <class F>
  void withRows(int p, F&& f) const {
    runFor(isa_, [&] {
      const V& x = particles_.x[p];
      const Stencil<D, Kernel, T> s(x, T(1 / grid_.h));
      f(TensorStencil<D, Kernel, T>(grid_, s, x));
    });
  }

  using Reading = typename CrackOpening<D, T>::Reading;
  // Asleep through the last particle pass (SleepStep::stillness 2): nothing of it changed since
  // its last scatter, and it keeps what it read then. (The first step with damage reads afresh.)
  bool sleptSinceLastScatter(int p) const {
    return keeps_readings_ && particles_.calm_steps[p] > sleep_steps_ && !cracks_.mustPrime();
  }
  Reading kept(int p) const {
    return {particles_.crack_gradient[p], particles_.crack_side_bits[p], particles_.crack_flags[p]};
  }
  void keep(int p, const Reading& r) const {
    particles_.crack_gradient[p] = r.gradient;
    particles_.crack_side_bits[p] = r.side_bits;
    particles_.crack_flags[p] = r.flags;
  }

  CrackOpening<D, T>& cracks_;
  MpmParticles<D, T>& particles_;
  const SnowMaterial& material_;
  const GridGeometry<D>& grid_;
  const GridFields<D, T>& fields_;  // side 0 of every node, the solver's grid
  T inertia_inverse_;
  int sleep_steps_;
  bool keeps_readings_;
  VectorIsa isa_;  // the build the per-particle passes run in (runFor)
};

}  // namespace snowsim
