// The step an explicit MPM run comes down to once its snow hardens on impact, which the cost
// estimate counts its steps by (app/step_forecast.h).
#include "app/step_forecast.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <regex>

#include <nlohmann/json.hpp>

#include "sim/io/ply.h"
#include "sim/mpm/snow_material.h"
#include "tests/support/run_snowsim.h"

namespace {

using snowsim::forecastStep;
using snowsim::loadScene;
using snowsim::StepLimit;
using namespace snowsim_test;

// The scene's first step as the solver gives it: unhardened snow at its initial speed.
StepLimit firstStep(const snowsim::Scene& scene, double speed) {
  StepLimit limit;
  limit.wave_speed =
      snowsim::pWaveSpeed(snowsim::unhardenedLame<double>(scene.material), scene.bodies[0].density);
  limit.particle_speed = speed;
  limit.step = scene.mpm.cfl * scene.cell_size / (limit.wave_speed + speed);
  return limit;
}

TEST(StepForecast, ABallThrownAtAWallHardensByItsImpactSpeed) {
  const snowsim::Scene wall = loadScene(scene("mpm_snowball_wall"));
  const StepLimit start = firstStep(wall, std::hypot(3.0, 0.5));
  const auto forecast = forecastStep(wall, start);
  ASSERT_TRUE(forecast);
  // 3 m/s along x and 0.5 up, the ball's bottom 6 cm above the floor it could fall to.
  EXPECT_NEAR(forecast->impact_speed, std::sqrt(9 + 0.25 + 2 * 9.81 * 0.06), 1e-9);
  // Its right side at x = 0.12 reaches the wall's face at 0.28 first.
  EXPECT_NEAR(forecast->impact_time, 0.16 / 3, 1e-9);
  EXPECT_FALSE(forecast->driven);
  const double hardened_wave = 1.3 * forecast->impact_speed / wall.material.theta_c;
  EXPECT_NEAR(forecast->hardened_step,
              start.step * (start.wave_speed + start.particle_speed) /
                  (hardened_wave + forecast->impact_speed),
              1e-12);

  // Bounded hardening caps the wave speed at c_0 sqrt(hardening_max).
  const snowsim::Scene bounded =
      loadScene(scene("mpm_snowball_wall"), {"material.hardening_max=5"});
  const auto capped = forecastStep(bounded, start);
  ASSERT_TRUE(capped);
  EXPECT_NEAR(capped->hardened_step,
              start.step * (start.wave_speed + start.particle_speed) /
                  (start.wave_speed * std::sqrt(5.0) + capped->impact_speed),
              1e-12);
}

TEST(StepForecast, OnlyForAnExplicitAdaptiveMpmStep) {
  const StepLimit start{1e-3, 0, 20, 1, 1};
  EXPECT_FALSE(forecastStep(loadScene(scene("snowball_drop")), start));
  EXPECT_FALSE(
      forecastStep(loadScene(scene("mpm_snowball_wall"), {"mpm.integrator=semi_implicit"}), start));
  EXPECT_FALSE(
      forecastStep(loadScene(scene("mpm_snowball_wall"), {"mpm.adaptive_dt=false"}), start));
  // A collider that moves (the drum turns) can lift snow to the top and drop it.
  const snowsim::Scene drum = loadScene(scene("mpm_drum"));
  const auto driven = forecastStep(drum, firstStep(drum, 0));
  ASSERT_TRUE(driven);
  EXPECT_TRUE(driven->driven);
  EXPECT_NEAR(driven->impact_speed, std::sqrt(2 * 9.81 * drum.extent()[1]), 1e-9);
}

// The forecast of mpm_snowball_drop_3d's ball (at rest, its bottom at 0.115 m) with one collider.
snowsim::StepForecast dropOnto(const std::string& collider) {
  const snowsim::Scene s =
      loadScene(scene("mpm_snowball_drop_3d"), {"colliders=[" + collider + "]"});
  const auto forecast = forecastStep(s, firstStep(s, 0));
  EXPECT_TRUE(forecast);
  return forecast.value_or(snowsim::StepForecast{});
}

// A ball falling onto a box, or a tilted plane, inside the domain meets it before the floor: it
// falls the gap to it, and no further.
TEST(StepForecast, ABallMeetsAColliderInsideTheDomainBeforeTheFloor) {
  // The box's top at 0.065 m: a 5 cm fall.
  const auto box =
      dropOnto(R"({"shape": "box", "position": [0.1, 0.04, 0.1], "size": [0.1, 0.05, 0.1]})");
  EXPECT_NEAR(box.impact_speed, std::sqrt(2 * 9.81 * 0.05), 1e-9);
  EXPECT_NEAR(box.impact_time, std::sqrt(2 * 0.05 / 9.81), 1e-9);
  // A box off to the side is not in its way: the floor, 11.5 cm down, is.
  const auto floor =
      dropOnto(R"({"shape": "box", "position": [0.03, 0.04, 0.1], "size": [0.04, 0.05, 0.1]})");
  EXPECT_NEAR(floor.impact_speed, std::sqrt(2 * 9.81 * 0.115), 1e-9);
  // A plane through the domain's centre, its normal tilted 30 degrees from up: the ball's lowest
  // corner (0.055, 0.115) lies d above it along the normal, d / cos 30 over it along gravity.
  const auto tilted = dropOnto(
      R"({"shape": "half_space", "position": [0.1, 0.04, 0.1], "normal": [0.5, 0.8660254037844386, 0]})");
  const double d = 0.5 * (0.055 - 0.1) + 0.8660254037844386 * (0.115 - 0.04);
  EXPECT_NEAR(tilted.impact_speed, std::sqrt(2 * 9.81 * d / 0.8660254037844386), 1e-6);
}

// Points from another run's frame move at their mean velocity and meet as fast as their fastest.
TEST(StepForecast, PointsBodiesMoveAsTheirFrameDoes) {
  const std::string out = freshDir("forecast_points").string();
  const Result r = runSnowsim("run " + scene("mpm_snowball_drop_3d") + " -o " + out +
                              " --no-png --no-mp4 --set time.duration=0.02 --set time.fps=50");
  ASSERT_EQ(r.code, 0) << r.output;
  const snowsim::Scene points =
      loadScene(scene("mpm_snowball_drop_3d"),
                {R"(bodies=[{"shape": "points", "file": ")" + out + R"(/frame_00001.ply"}])"});
  const auto forecast = forecastStep(points, firstStep(points, 0.2));
  ASSERT_TRUE(forecast);
  // The frame's lowest particle falls to the floor from its mean velocity, meeting it as fast as
  // its fastest particle falls that far.
  const snowsim::Snapshot frame = snowsim::readPly(out + "/frame_00001.ply");
  double lowest = 1, mean_vy = 0, fastest = 0;
  for (int i = 0; i < frame.size(); ++i) {
    lowest = std::min(lowest, double(frame.position[i][1]));
    mean_vy += frame.velocity[i][1] / frame.size();
    const auto& v = frame.velocity[i];
    fastest = std::max(fastest, std::sqrt(double(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])));
  }
  ASSERT_LT(mean_vy, -0.1) << "falling";
  const double g = 9.81;
  EXPECT_NEAR(forecast->impact_time, (std::sqrt(mean_vy * mean_vy + 2 * g * lowest) + mean_vy) / g,
              1e-6);
  EXPECT_NEAR(forecast->impact_speed, std::sqrt(fastest * fastest + 2 * g * lowest), 1e-6);
}

// The steps the run says it will take, against the steps it took: within a factor of two, where
// the first step alone counted a seventh of them.
TEST(StepForecast, TheEstimatedStepsHoldForAShortSmash) {
  const std::string out = freshDir("forecast").string();
  const Result r = runSnowsim("run " + scene("mpm_snowball_wall") + " -o " + out +
                              " --no-png --no-mp4 --no-ply --set time.duration=0.15");
  ASSERT_EQ(r.code, 0) << r.output;
  std::smatch said;
  ASSERT_TRUE(std::regex_search(r.output, said, std::regex("about ([0-9]+) steps"))) << r.output;
  const double estimated = std::stod(said[1]);
  const double taken =
      nlohmann::json::parse(std::ifstream(out + "/run.json"))["steps"].get<double>();
  EXPECT_GT(estimated, taken / 2) << r.output;
  EXPECT_LT(estimated, taken * 2) << r.output;
  EXPECT_GT(taken, 3 * 0.15 / firstStep(loadScene(scene("mpm_snowball_wall")), 3.04).step);
}

// A run of no duration takes no step, hardened or not (not "-0").
TEST(StepForecast, NoDurationTakesNoStep) {
  const Result r =
      runSnowsim("run " + scene("mpm_snowball_wall") + " -o " + freshDir("forecast_zero").string() +
                 " --estimate --set time.duration=0");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("about 0 steps, 0 particle-steps"), std::string::npos) << r.output;
}

}  // namespace
