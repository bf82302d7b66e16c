// The per-particle and per-node functions of CrackOpening (sim/mpm/crack_opening.h), called in the
// order the solver's steps call them, on a 10 x 10 grid of unit cells with the quadratic kernel.
// Positions sit on quarter cells, where the kernel's weights are exact binary fractions: on node i,
// 1/8 3/4 1/8 at nodes i - 1, i, i + 1; a quarter cell below node i, 9/32 11/16 1/32 there.
#include "sim/mpm/crack_opening.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <utility>
#include <vector>

#include "sim/core/bspline.h"
#include "sim/core/stencil.h"

using namespace snowsim;

namespace {

using Cracks = CrackOpening<2, Real>;
using Kernel = QuadraticBSpline;
using V = Vec<2>;
using M = Mat<2>;
const GridGeometry<2> kGrid(IVec<2>(10, 10), 1);
constexpr Real kInertiaInverse = 4;  // MLS's D_p^-1 with the quadratic kernel: 4 / h^2
constexpr int kColours = 3;
constexpr int kBlocks = 1;  // still blocks: none here keeps its scatter

int node(int i, int j) {
  return kGrid.index(IVec<2>(i, j));
}

// The nodes of x's stencil with a weight.
std::vector<int> stencil(const V& x) {
  std::vector<int> nodes;
  forEachStencilNode<2, Kernel>(kGrid, x, [&](int k, Real w, const V&) {
    if (w > 0) nodes.push_back(k);
  });
  return nodes;
}

struct Damaged {
  V x;
  Real mass, damage;
  int colour;
};
struct Particle {
  V x;
  int colour;
};
constexpr int kParticles = 16;
constexpr int kFirstSpot = 8;  // the spots of damage are particles kFirstSpot on

std::vector<Real> zeroMass() {
  return std::vector<Real>(kGrid.nodeCount(), 0);
}
std::vector<V> zeroMomentum() {
  return std::vector<V>(kGrid.nodeCount(), V::Zero());
}

// Particle p's scatter, at x in colour c, of mass m, momentum m v (no affine part) and its
// damage, side 0's share into mass0 and momentum0.
void scatter(Cracks& cracks, const V& x, int p, Real damage, Real m, const V& v, int colour,
             std::vector<Real>& mass0, std::vector<V>& momentum0) {
  const Stencil<2, Kernel, Real> s(x, 1 / kGrid.h);
  const TensorStencil<2, Kernel, Real> t(kGrid, s, x);
  cracks.scatter(t, p, cracks.read(t, damage, kInertiaInverse), damage, m, V(m * v), M::Zero(),
                 mass0.data(), momentum0.data(), colour);
}

// Particle p's gather at x from side 0's velocities v0: v_p, and B.
V gather(const Cracks& cracks, const V& x, int p, const std::vector<V>& v0, M& B) {
  const Stencil<2, Kernel, Real> s(x, 1 / kGrid.h);
  return cracks.gather(TensorStencil<2, Kernel, Real>(kGrid, s, x), p, v0.data(), B);
}

// Two crack steps as the solver takes them, then the start of a third, the step under test: the
// spots' damage makes the damage field, which the next step reads; in it the particles' damage
// gradients make the nodes' references, which the third step reads. The particles are massless,
// so that the spots alone make the field.
void findSides(Cracks& cracks, const std::vector<Damaged>& damaged,
               const std::vector<Particle>& particles) {
  for (int step = 0; step < 2; ++step) {
    cracks.beginStep(true);
    std::vector<Real> mass0 = zeroMass();
    std::vector<V> momentum0 = zeroMomentum();
    for (int i = 0; i < static_cast<int>(damaged.size()); ++i) {
      const Damaged& d = damaged[i];
      scatter(cracks, d.x, kFirstSpot + i, d.damage, d.mass, V::Zero(), d.colour, mass0, momentum0);
    }
    for (int p = 0; p < static_cast<int>(particles.size()); ++p)
      scatter(cracks, particles[p].x, p, 0, 0, V::Zero(), particles[p].colour, mass0, momentum0);
    for (int k = 0; k < kGrid.nodeCount(); ++k) {
      V v = V::Zero();
      cracks.updateNode(k, mass0[k], v, 0, V::Zero(), [](V&) {});
    }
  }
  cracks.beginStep(true);
}

// The side a particle of gradient along +x or -x takes at node k.
int sideOfPlusX(const Cracks& cracks, int k) {
  return cracks.side(V(1, 0), false, k);
}
int sideOfMinusX(const Cracks& cracks, int k) {
  return cracks.side(V(-1, 0), false, k);
}

// One damaged particle at node (5, 5) gives its damage to the nodes (4..6, 4..6), the others none.
// a at (3.75, 5) reaches the damaged columns 4 and 5 on its right: gradient
// 4 (11/16 * 1/4 + 1/32 * 5/4) = 27/32 along +x. b at (6, 5) reaches columns 5 and 6 and the
// undamaged 7: 4 (1/8 * -1) = -1/2 along x. Both reach column 5, where a's larger gradient is the
// reference; columns 6 and 7 only b reaches. By default b is in the first colour, a in the last:
// the larger wins over the colour order.
struct TwoSides {
  static constexpr int a = 0, b = 1;
  const V xa = V(3.75, 5), xb = V(6, 5);
  const int k = node(5, 5);
  Cracks cracks;
  // Side 0's partial grid, the solver's.
  std::vector<Real> mass0 = std::vector<Real>(kGrid.nodeCount(), 0);
  std::vector<V> momentum0 = std::vector<V>(kGrid.nodeCount(), V::Zero());

  explicit TwoSides(Real friction = 0.1, int colour_a = 2, int colour_b = 0)
      : cracks(kGrid.nodeCount(), kColours, kParticles, kBlocks, friction) {
    findSides(cracks, {{V(5, 5), 1, 1, 0}}, {{xa, colour_a}, {xb, colour_b}});
  }
  // b's 2 kg at velocity v, no affine velocity, scattered into its sides.
  void scatterB(const V& v, bool failed = false) {
    scatter(cracks, xb, b, failed ? 1 : 0, 2, v, 0, mass0, momentum0);
    EXPECT_TRUE(cracks.takesSides(b));
  }
};

// The node velocities the collide callback sees, field by field (each field with mass, in order).
struct Seen {
  std::vector<V> velocities;
  auto collide() {
    return [this](V& v) { velocities.push_back(v); };
  }
};

}  // namespace

TEST(CrackOpeningParts, NodeDamageIsTheMassWeightedMeanOverEveryColour) {
  // Left of the probe at (5, 5), snow of damage 3/4 by mass (1 kg undamaged, 3 kg fully damaged,
  // in two colours); right of it, 1/4. Node 5 holds no snow: the probe's gradient is
  // 4 * 1/8 (3/4 * -1 + 1/4 * 1) = -1/4 along x, towards the more damaged side. An unweighted
  // mean (1/2 on both sides) or one colour alone (0 or 1 on both sides) would give no gradient,
  // and no reference.
  const auto spots = [](Real left_damage_mass, Real right_damage_mass) {
    return std::vector<Damaged>{{V(3, 5), 4 - left_damage_mass, 0, 0},
                                {V(3, 5), left_damage_mass, 1, 1},
                                {V(7, 5), 4 - right_damage_mass, 0, 0},
                                {V(7, 5), right_damage_mass, 1, 1}};
  };
  const V probe(5, 5), far(5, 1.5);
  Cracks cracks(kGrid.nodeCount(), kColours, kParticles, kBlocks, 0);
  findSides(cracks, spots(3, 1), {{probe, 2}, {far, 0}});
  // far's stencil, rows 1..2, reaches none of the damaged rows 4..6: no gradient, no reference.
  for (const int k : stencil(far)) EXPECT_EQ(sideOfMinusX(cracks, k), sideOfPlusX(cracks, k)) << k;
  for (const int k : stencil(probe)) {
    EXPECT_EQ(sideOfMinusX(cracks, k), 0) << k;
    EXPECT_EQ(sideOfPlusX(cracks, k), 1) << k;
  }
  // The next step, its damage mirrored: the node passes emptied the colours' sums, so the
  // reference turns to +x. Sums kept from the last step would balance both sides, and a kept
  // reference norm would keep -x.
  findSides(cracks, spots(1, 3), {{probe, 2}, {far, 0}});
  for (const int k : stencil(probe)) {
    EXPECT_EQ(sideOfPlusX(cracks, k), 0) << k;
    EXPECT_EQ(sideOfMinusX(cracks, k), 1) << k;
  }
}

TEST(CrackOpeningParts, EachNodesReferenceIsTheLargestGradientThatReachesIt) {
  // a and b in one colour (b found after a), a in the first colour, b in the first.
  for (const auto& [colour_a, colour_b] : {std::pair(0, 0), std::pair(0, 2), std::pair(2, 0)}) {
    const TwoSides s(0.1, colour_a, colour_b);
    SCOPED_TRACE(testing::Message() << "colours " << colour_a << " " << colour_b);
    for (int j = 4; j <= 6; ++j) {
      // Columns 3 to 5: a's +x (column 5 is b's too, whose gradient is smaller).
      for (int i = 3; i <= 5; ++i) {
        EXPECT_EQ(sideOfPlusX(s.cracks, node(i, j)), 0) << i << " " << j;
        EXPECT_EQ(sideOfMinusX(s.cracks, node(i, j)), 1) << i << " " << j;
      }
      // Columns 6 and 7: b's -x.
      for (int i = 6; i <= 7; ++i) {
        EXPECT_EQ(sideOfPlusX(s.cracks, node(i, j)), 1) << i << " " << j;
        EXPECT_EQ(sideOfMinusX(s.cracks, node(i, j)), 0) << i << " " << j;
      }
    }
    // No particle reaches column 9: no reference, side 0 whatever the gradient. Failed snow takes
    // the grains anywhere.
    EXPECT_EQ(sideOfPlusX(s.cracks, node(9, 5)), 0);
    EXPECT_EQ(sideOfMinusX(s.cracks, node(9, 5)), 0);
    EXPECT_EQ(s.cracks.side(V(1, 0), true, node(4, 5)), Cracks::grains);
    EXPECT_EQ(s.cracks.side(V(1, 0), true, node(9, 5)), Cracks::grains);
  }
}

// TwoSides' a and b about a spot of damage 1/2 (no grains): a takes side 0 at every node and keeps
// the plain transfers, b takes side 1 at column 5; snow far from damage keeps them unless it
// failed. Damage 1 (failed snow, grains) takes a off them too: it gives the grains its normals.
// A side is the step's: the next step's particle of that place takes its own.
TEST(CrackOpeningParts, OnlySnowTakingSide1OrNearGrainsLeavesThePlainTransfers) {
  const V xa(3.75, 5), xb(6, 5), far(5, 1.5);
  for (const Real damage : {0.5, 1.0}) {
    Cracks cracks(kGrid.nodeCount(), kColours, kParticles, kBlocks, 0);
    findSides(cracks, {{V(5, 5), 1, damage, 0}}, {{xa, 2}, {xb, 0}, {far, 1}});
    std::vector<Real> mass0 = zeroMass();
    std::vector<V> momentum0 = zeroMomentum();
    const Particle snow[] = {{xa, 2}, {xb, 0}, {far, 1}, {far, 1}};
    for (int p = 0; p < 4; ++p)
      scatter(cracks, snow[p].x, p, p == 3 ? 1 : 0, 1, V::Zero(), snow[p].colour, mass0, momentum0);
    EXPECT_EQ(cracks.takesSides(0), damage == 1) << damage;
    EXPECT_TRUE(cracks.takesSides(1)) << damage;
    EXPECT_FALSE(cracks.takesSides(2)) << damage;
    EXPECT_TRUE(cracks.takesSides(3)) << "failed snow";
    // A side taken in an earlier step reads as none.
    cracks.beginStep(true);
    EXPECT_FALSE(cracks.takesSides(1));
  }
}

TEST(CrackOpeningParts, ScatterPutsEachNodesShareIntoTheParticlesSideThere) {
  TwoSides s;
  const V v(1, 2);
  s.scatterB(v);
  // b's gradient -x opposes column 5's reference: its weight there, 1/8, goes to side 1; its
  // columns 6 and 7 (3/4 + 1/8) to side 0.
  Real mass = 0;
  V momentum = V::Zero();
  for (int k = 0; k < kGrid.nodeCount(); ++k) mass += s.mass0[k], momentum += s.momentum0[k];
  EXPECT_DOUBLE_EQ(mass, 2 * 0.875);
  EXPECT_NEAR((momentum - 2 * 0.875 * v).norm(), 0, 1e-12);
  for (int j = 4; j <= 6; ++j) EXPECT_EQ(s.mass0[node(5, j)], 0) << j;
  EXPECT_GT(s.mass0[node(6, 5)], 0);
  // Failed snow scatters into the grains alone, none of it into side 0.
  std::fill(s.mass0.begin(), s.mass0.end(), 0);
  s.scatterB(v, true);
  for (const Real m : s.mass0) EXPECT_EQ(m, 0);
}

TEST(CrackOpeningParts, ApproachingSidesLoseTheirNormalRelativeVelocityAndSlipWithFriction) {
  // Node (5, 5): side 1 holds b's 2 kg * 1/8 * 3/4 moving at vb; side 0 (the solver's grid) 9/16
  // kg moving along the reference +x into it, and up. Their centre of mass moves at
  // (9/16 - 3/16, 9/32) / (3/4) = (1/2, 3/8).
  const Real m0 = 0.5625, m1 = 0.1875;
  const V vb(-1, 0), centre(0.5, 0.375);
  for (const Real friction : {0.1, 1.0}) {
    TwoSides s(friction);
    s.scatterB(vb);
    V v0(1, 0.5);
    const V momentum = m0 * v0 + m1 * vb;
    Seen seen;
    s.cracks.updateNode(s.k, m0, v0, 0.1, V::Zero(), seen.collide());
    ASSERT_EQ(seen.velocities.size(), 2u);  // sides 0 and 1; the grains have no mass
    EXPECT_EQ(seen.velocities[0], v0);
    const V v1 = seen.velocities[1];
    EXPECT_NEAR((m0 * v0 + m1 * v1 - momentum).norm(), 0, 1e-12) << friction;
    // The normal velocities become the centre of mass's.
    EXPECT_NEAR(v0.x(), centre.x(), 1e-12) << friction;
    EXPECT_NEAR(v1.x(), centre.x(), 1e-12) << friction;
    if (friction < 1) {
      // Sticking would take 1/8 off side 0's slip; friction 0.1 allows 0.1 * 1/2 (its normal
      // change): side 0 slips up at 0.45, side 1 at 0 + 3 * 0.05 (the mass ratio).
      EXPECT_NEAR(v0.y(), 0.45, 1e-12);
      EXPECT_NEAR(v1.y(), 0.15, 1e-12);
    } else {
      // Friction 1 allows 1/2, more than sticking takes: both move with their centre of mass.
      EXPECT_NEAR(v0.y(), centre.y(), 1e-12);
      EXPECT_NEAR(v1.y(), centre.y(), 1e-12);
    }
  }
}

TEST(CrackOpeningParts, SeparatingSidesKeepTheirVelocitiesAndEachGathersItsOwn) {
  TwoSides s;
  const V vb(1, 0), gravity(0, -10);
  const Real dt = 0.1;
  s.scatterB(vb);
  // Side 0 moves along -x everywhere, away from side 1 across the reference +x: no contact.
  std::vector<V> v0(kGrid.nodeCount(), V(-1, 0));
  Seen seen;
  s.cracks.updateNode(s.k, 0.5, v0[s.k], dt, gravity, seen.collide());
  ASSERT_EQ(seen.velocities.size(), 2u);
  EXPECT_EQ(v0[s.k], V(-1, 0));
  // Side 1's velocity is b's, and the step's gravity (side 0's is the solver's to add).
  EXPECT_NEAR((seen.velocities[1] - (vb + dt * gravity)).norm(), 0, 1e-12);
  for (int k = 0; k < kGrid.nodeCount(); ++k)
    if (k != s.k) s.cracks.updateNode(k, s.mass0[k], v0[k], dt, gravity, [](V&) {});
  // b gathers side 1's velocity at column 5 (weight 1/8) and side 0's elsewhere (7/8).
  M B;
  const V v = gather(s.cracks, s.xb, TwoSides::b, v0, B);
  const V expected = 0.125 * (vb + dt * gravity) + 0.875 * V(-1, 0);
  EXPECT_NEAR((v - expected).norm(), 0, 1e-12);
}

TEST(CrackOpeningParts, GrainsMeetASideOnlyMovingIntoItAlongItsOutwardNormal) {
  // Intact snow at (4, 5) and failed snow at (6, 5), whose damage 1 alone makes the damage field:
  // both reach node (5, 5), the intact snow's side 0 there with outward normal +x (from the snow
  // to the node).
  for (const Real grain_speed : {-1.0, 1.0}) {
    Cracks cracks(kGrid.nodeCount(), kColours, kParticles, kBlocks, 0);
    const V xs(4, 5), xg(6, 5), vg(grain_speed, 0);
    findSides(cracks, {{xg, 1, 1, 1}}, {{xs, 0}});
    std::vector<Real> mass0 = zeroMass();
    std::vector<V> momentum0 = zeroMomentum();
    scatter(cracks, xs, 0, 0, 1, V::Zero(), 0, mass0, momentum0);
    scatter(cracks, xg, 1, 1, 1, vg, 1, mass0, momentum0);
    EXPECT_TRUE(cracks.takesSides(0)) << "snow near grains";
    EXPECT_TRUE(cracks.takesSides(1));
    const int k = node(5, 5);
    V v0 = V::Zero();
    Seen seen;
    cracks.updateNode(k, mass0[k], v0, 0.1, V::Zero(), seen.collide());
    ASSERT_EQ(seen.velocities.size(), 2u) << grain_speed;  // side 0 and the grains
    if (grain_speed < 0) {
      // Moving into the snow, grains of the snow's mass at the node: both take half the speed.
      EXPECT_NEAR((v0 - V(-0.5, 0)).norm(), 0, 1e-12);
      EXPECT_NEAR((seen.velocities[1] - V(-0.5, 0)).norm(), 0, 1e-12);
    } else {
      // Moving away: no contact.
      EXPECT_EQ(v0, V::Zero());
      EXPECT_NEAR((seen.velocities[1] - vg).norm(), 0, 1e-12);
    }
  }
}

TEST(CrackOpeningParts, CollisionsComeLastOnEveryFieldWithMass) {
  TwoSides s;
  s.scatterB(V(-1, 0));
  // A wall across x, met after the contact of the approaching test: side 0 keeps the contact's
  // upward 0.45. Met before, it would have stopped both sides along x, and no contact followed.
  V v0(1, 0.5);
  int fields = 0;
  s.cracks.updateNode(s.k, 0.5625, v0, 0.1, V::Zero(), [&](V& v) {
    v.x() = 0;
    ++fields;
  });
  EXPECT_EQ(fields, 2);
  EXPECT_NEAR((v0 - V(0, 0.45)).norm(), 0, 1e-12);
}

// The first step with damage makes its own field and references from the snow as it is: on snow
// that stays put, those of two lagged steps.
TEST(CrackOpeningParts, APrimedStepFindsTheReferencesOfTwoLaggedSteps) {
  const TwoSides lagged;
  Cracks primed(kGrid.nodeCount(), kColours, kParticles, kBlocks, 0.1);
  primed.beginStep(true);
  ASSERT_TRUE(primed.mustPrime());
  const auto rows = [](const V& x, auto&& f) {
    const Stencil<2, Kernel, Real> s(x, 1 / kGrid.h);
    f(TensorStencil<2, Kernel, Real>(kGrid, s, x));
  };
  rows(V(5, 5), [&](const auto& t) { primed.primeDamage(t, 1, 1, 0); });
  for (const V& x : {lagged.xa, lagged.xb})
    rows(x, [&](const auto& t) { primed.primeDamage(t, 0, 0, 1); });
  for (int k = 0; k < kGrid.nodeCount(); ++k) primed.sumPrimedDamage(k);
  for (const V& x : {lagged.xa, lagged.xb})
    rows(x, [&](const auto& t) { primed.primeReference(t, kInertiaInverse, 2); });
  for (int k = 0; k < kGrid.nodeCount(); ++k) primed.sumPrimedReference(k);
  for (int k = 0; k < kGrid.nodeCount(); ++k) {
    EXPECT_EQ(sideOfPlusX(primed, k), sideOfPlusX(lagged.cracks, k)) << k;
    EXPECT_EQ(sideOfMinusX(primed, k), sideOfMinusX(lagged.cracks, k)) << k;
  }
}

// A crack step without damage (the solver's last before plain steps) leaves no damage and no
// reference at any node, so plain steps in between leave nothing stale for the next crack step.
TEST(CrackOpeningParts, AStepWithoutDamageClearsEveryNode) {
  TwoSides s;
  s.cracks.beginStep(false);
  EXPECT_FALSE(s.cracks.mustPrime());
  std::vector<Real> mass0 = zeroMass();
  std::vector<V> momentum0 = zeroMomentum();
  scatter(s.cracks, s.xb, TwoSides::b, 0, 2, V::Zero(), 0, mass0, momentum0);
  for (int k = 0; k < kGrid.nodeCount(); ++k) {
    V v = V::Zero();
    s.cracks.updateNode(k, mass0[k], v, 0, V::Zero(), [](V&) {});
  }
  EXPECT_FALSE(s.cracks.holdsDamage());
  for (int k = 0; k < kGrid.nodeCount(); ++k)
    EXPECT_EQ(sideOfPlusX(s.cracks, k), sideOfMinusX(s.cracks, k)) << k;
  s.cracks.beginStep(true);
  EXPECT_TRUE(s.cracks.mustPrime());
  scatter(s.cracks, s.xb, TwoSides::b, 0, 2, V::Zero(), 0, mass0, momentum0);
  EXPECT_FALSE(s.cracks.takesSides(TwoSides::b));
}
