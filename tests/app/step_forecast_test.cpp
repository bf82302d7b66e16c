// The step an explicit MPM run comes down to once its snow hardens on impact, which the cost
// estimate counts its steps by (app/step_forecast.h).
#include "app/step_forecast.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <regex>

#include <nlohmann/json.hpp>

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
  // Its right side at x = 0.12 reaches the domain's end at 0.32 first.
  EXPECT_NEAR(forecast->impact_time, 0.2 / 3, 1e-9);
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
