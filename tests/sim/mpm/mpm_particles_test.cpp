// MpmParticles must name every per-particle array in forEachArray: the sort permutes only those,
// and an array left out would keep its old order while the others move.
#include "sim/mpm/mpm_particles.h"

#include <gtest/gtest.h>

#include <vector>

namespace snowsim {
namespace {

template <int D>
int arraysNamed() {
  MpmParticles<D> particles;
  int named = 0;
  particles.forEachArray([&](auto&) { ++named; });
  return named;
}

// Every member is a std::vector, and all std::vectors have one size: the struct holds exactly as
// many as forEachArray names.
TEST(MpmParticles, ForEachArrayNamesEveryMember) {
  EXPECT_EQ(arraysNamed<2>() * sizeof(std::vector<char>), sizeof(MpmParticles<2>));
  EXPECT_EQ(arraysNamed<3>() * sizeof(std::vector<char>), sizeof(MpmParticles<3>));
}

TEST(MpmParticles, StartUnstrained) {
  Particles<3> p;
  p.add(Vec<3>(0.1, 0.2, 0.3), Vec<3>(1, 0, 0), 0.01, 0);
  p.add(Vec<3>(0.2, 0.2, 0.3), Vec<3>(0, 1, 0), 0.01, 0);
  const SnowMaterial material;
  MpmParticles<3> mpm(p, material);
  // Every array but the auto-sleep state and what sleeping snow keeps of an open crack, which
  // stay empty until a solver turns them on.
  mpm.forEachArray([&](auto& array) {
    const void* a = &array;
    const bool sleep_state = a == &mpm.calm_steps || a == &mpm.crack_gradient ||
                             a == &mpm.crack_side_bits || a == &mpm.crack_flags;
    EXPECT_EQ(array.size(), sleep_state ? 0u : 2u);
  });
  EXPECT_EQ(mpm.F_E[1], Mat<3>::Identity());
  EXPECT_EQ(mpm.J_P[0], 1);
  EXPECT_EQ(mpm.hardening[0], 1);
  EXPECT_EQ(mpm.x[1], p.x[1]);
}

}  // namespace
}  // namespace snowsim
