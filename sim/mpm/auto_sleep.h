// Auto-sleep (mpm.auto_sleep, docs/mpm.md): a particle whose surroundings rest skips its gather,
// its F_E update and its advection. It falls asleep after `steps` steps in a row in which it and
// every node of its stencil moved slower than `speed`, and wakes when a node of its stencil moves
// faster or a moving collider comes within a cell. With open cracks, a node's velocity is that of
// the particle's own field there.
// The step takes the part as a template parameter: NoSleep when it is off, whose calls compile to
// nothing.
#pragma once

#include <cstdint>
#include <string_view>
#include <vector>

#include "sim/core/collider.h"
#include "sim/core/grid.h"
#include "sim/core/solver_statistics.h"
#include "sim/core/stencil.h"
#include "sim/scene/scene.h"

namespace snowsim {

// The velocities a particle meets at the nodes of its stencil: one field's, or node by node side
// 0's or side 1's of an open crack (bit n of `sides` for the n-th node, row by row).
template <int D, class T>
struct StencilVelocities {
  const Vec<D, T>* one = nullptr;
  const Vec<D, T>* side[2] = {};
  std::uint64_t sides = 0;
};

// The particles' calm steps count to the sleep steps while one rests awake, and are one more once
// it slept through a step. A step takes the part as SleepStep, over the solver's arrays.
template <int D, class T>
class SleepStep {
 public:
  using V = Vec<D, T>;

  SleepStep(const AutoSleep& params, std::vector<int>& calm_steps, const GridGeometry<D>& grid,
            const std::vector<Collider<D>>& colliders, bool colliders_move)
      : speed_(T(params.speed)),
        steps_(params.steps),
        calm_(calm_steps),
        grid_(grid),
        colliders_(colliders),
        colliders_move_(colliders_move) {}

  // For the scatter with stillness (ParticleGridSchedule::scatter): 0 while particle p moves; 1
  // once it fell asleep (no velocity, no affine velocity, a deformation that stays); 2 once it
  // also slept through the last particle pass, so that nothing of it changed since the last
  // scatter.
  int stillness(int p) const {
    const int calm = calm_[p];
    return calm > steps_ ? 2 : calm == steps_ ? 1 : 0;
  }

  // 1 + 3 with resting snow: its momentum is dt times its stress's share, which unit(p, g)
  // scatters at dt = 1, so a block of still particles keeps what it scattered, and with it what
  // it scattered into the fields of the step's own, `own` (ParticleGridSchedule::scatter). stage:
  // the scatter's name among the step's stages.
  template <class Schedule, class Scatter, class Unit, class Own>
  void scatter(Schedule& schedule, std::string_view stage, Scatter&& scatter, Unit&& unit,
               Own&& own, T dt) const {
    schedule.scatter(
        scatter, [&](int p) { return stillness(p); }, unit, own, dt, stage);
  }

  // Whether particle p, at x, sleeps through this step, waking it if a collider or its stencil,
  // at the velocities it meets there, moves. Asleep, it scattered its mass and its stress, both
  // unchanged while it sleeps; it has no velocity to gather and no deformation to update while
  // its stencil rests.
  template <class Kernel>
  bool sleepsThrough(int p, const V& x, const StencilVelocities<D, T>& velocities) {
    int& calm = calm_[p];
    if (calm < steps_) return false;
    if (!stencilMoves<Kernel>(x, velocities) && !touchedByMovingCollider(x)) {
      calm = steps_ + 1;  // slept through a step: see stillness()
      return true;
    }
    calm = 0;  // wakes, and moves this very step
    return false;
  }

  // A batch of the particle pass: where its awake particles were before they moved.
  template <int most>
  struct Batch {
    V x_before[most];
    void remember(int a, const V& x) { x_before[a] = x; }
  };

  // After particle p, the batch's awake particle a, moved at velocity v (velocities as in
  // sleepsThrough): whether it has rested long enough to fall asleep, when fallAsleep() stops its
  // velocity and what feeds the grid from it.
  template <class Kernel, class PassBatch, class FallAsleep>
  void restOrStir(int p, const V& v, const PassBatch& batch, int a,
                  const StencilVelocities<D, T>& velocities, FallAsleep&& fallAsleep) {
    int& calm = calm_[p];
    const bool resting =
        v.squaredNorm() < speed_ * speed_ && !stencilMoves<Kernel>(batch.x_before[a], velocities);
    calm = resting ? calm + 1 : 0;
    if (calm >= steps_) fallAsleep();
  }

 private:
  // Whether a node of the stencil at x moves faster than the sleep speed.
  template <class Kernel>
  bool stencilMoves(const V& x, const StencilVelocities<D, T>& velocities) const {
    const T limit = speed_ * speed_;
    const Stencil<D, Kernel, T> s(x, T(1 / grid_.h));
    const TensorStencil<D, Kernel, T> rows(grid_, s, x);
    if (velocities.one) return rows.largestSquaredNorm(velocities.one) > limit;
    bool moves = false;  // every node read, no early exit: the loop stays branch-free
    int n = 0;
    rows.forEachNode([&](int k, T, const V&) {
      moves |= velocities.side[velocities.sides >> n++ & 1][k].squaredNorm() > limit;
    });
    return moves;
  }
  // Whether a moving collider is within a cell of x. No screen: it clears only contact.
  bool touchedByMovingCollider(const V& x) const {
    if (!colliders_move_) return false;
    const Vec<D> at = x.template cast<Real>();
    for (const Collider<D>& collider : colliders_) {
      const bool moves = !collider.velocity.isZero(0) || !collider.spin.isZero(0);
      if (moves && collider.phi(at) < grid_.h) return true;
    }
    return false;
  }

  T speed_;
  int steps_;
  std::vector<int>& calm_;
  const GridGeometry<D>& grid_;
  const std::vector<Collider<D>>& colliders_;
  bool colliders_move_;
};

// Auto-sleep on: its settings and what it counted over the run.
class AutoSleeper {
 public:
  explicit AutoSleeper(const AutoSleep& params) : params_(params) {}

  bool asleep(int calm_steps) const { return calm_steps >= params_.steps; }
  // The part this step takes, over the solver's arrays.
  template <int D, class T>
  SleepStep<D, T> step(std::vector<int>& calm_steps, const GridGeometry<D>& grid,
                       const std::vector<Collider<D>>& colliders, bool colliders_move) const {
    return SleepStep<D, T>(params_, calm_steps, grid, colliders, colliders_move);
  }
  // After each step's particle pass: asleep of the total particles slept through it.
  void count(long asleep, long particles) {
    tally_.asleep_now = asleep;
    tally_.asleep_steps += asleep;
    tally_.particle_steps += particles;
    tally_.particles = particles;
  }
  const SleepTally& tally() const { return tally_; }
  void restore(const SleepTally& tally) { tally_ = tally; }  // from a checkpoint

 private:
  AutoSleep params_;
  SleepTally tally_;
};

// Auto-sleep off: every particle moves every step.
template <int D, class T>
struct NoSleep {
  using V = Vec<D, T>;
  template <class Schedule, class Scatter, class Unit, class Own>
  void scatter(Schedule& schedule, std::string_view stage, Scatter&& scatter, Unit&&, Own&&,
               T) const {
    schedule.scatter(scatter, stage);
  }
  template <class Kernel>
  bool sleepsThrough(int, const V&, const StencilVelocities<D, T>&) const {
    return false;
  }
  template <int most>
  struct Batch {
    void remember(int, const V&) {}
  };
  template <class Kernel, class PassBatch, class FallAsleep>
  void restOrStir(int, const V&, const PassBatch&, int, const StencilVelocities<D, T>&,
                  FallAsleep&&) const {}
};

}  // namespace snowsim
