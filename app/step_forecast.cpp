#include "app/step_forecast.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <tuple>
#include <vector>

#include <Eigen/Core>

namespace snowsim {

namespace {

// Fitted: the mean wave speed after impact over the shipped scenes' runs, against v / theta_c at
// xi = 10 (the one-cell 2D balls of the paper's material table harden less than 3D snow does).
constexpr double kHardenedWave2d = 0.8;
constexpr double kHardenedWave3d = 1.3;

using Vector = Eigen::Vector3d;

Vector vector(const Vec3& v) {
  return {v[0], v[1], v[2]};
}

struct Box {
  Vector lo, hi;
};

Box bodyBox(const Body& body) {
  switch (body.shape) {
    case BodyShape::Ball:
    case BodyShape::HalfBall:
      return {vector(body.center).array() - body.radius, vector(body.center).array() + body.radius};
    case BodyShape::Box:
      return {vector(body.center) - vector(body.size) / 2,
              vector(body.center) + vector(body.size) / 2};
    case BodyShape::Mesh: {
      const auto b = body.mesh.placedAt(body.center).bounds();
      return {{b[0][0], b[0][1], b[0][2]}, {b[1][0], b[1][1], b[1][2]}};
    }
    case BodyShape::Points:
      break;
  }
  // Points come from another run's frame: snow that has met its obstacle already.
  return {vector(body.center), vector(body.center)};
}

bool moves(const ColliderParams& c) {
  return !c.keyframes.empty() || vector(c.velocity).norm() > 0 ||
         vector(c.angular_velocity).norm() > 0;
}

// The earliest time a body (box b, velocity v) reaches the domain's bounds along an axis it moves
// along, gravity bending its fall.
double timeToBounds(const Box& b, const Vector& v, const Vector& gravity, const Vector& extent,
                    int dimension) {
  double earliest = std::numeric_limits<double>::infinity();
  for (int a = 0; a < dimension; ++a) {
    // x(t) = x0 + v t + g t^2 / 2 reaching 0 from lo or the extent from hi.
    for (const auto& [gap, speed, accel] : {std::tuple{b.lo[a], -v[a], -gravity[a]},
                                            std::tuple{extent[a] - b.hi[a], v[a], gravity[a]}}) {
      if (gap <= 0) return 0;
      const double disc = speed * speed + 2 * accel * gap;
      if (accel != 0 && disc >= 0) {
        const double t = (std::sqrt(disc) - speed) / accel;
        if (t >= 0) earliest = std::min(earliest, t);
      } else if (accel == 0 && speed > 0) {
        earliest = std::min(earliest, gap / speed);
      }
    }
  }
  return earliest;
}

}  // namespace

std::optional<StepForecast> forecastStep(const Scene& scene, const StepLimit& start) {
  if (scene.solver != SolverType::Mpm || !scene.mpm.adaptive_dt ||
      scene.mpm.integrator != MpmIntegrator::Explicit || start.wave_speed <= 0 ||
      !std::isfinite(start.step))
    return std::nullopt;
  StepForecast forecast;
  forecast.driven = std::any_of(scene.colliders.begin(), scene.colliders.end(), moves);
  const Vector extent = vector(scene.extent()), gravity = vector(scene.gravity);
  const double g = gravity.norm();
  const Vector down = g > 0 ? Vector(gravity / g) : Vector::Zero();
  double impact_time = std::numeric_limits<double>::infinity();
  std::vector<Box> boxes;
  for (const Body& body : scene.bodies) {
    const Box b = bodyBox(body);
    boxes.push_back(b);
    // The height it falls to the domain's floor; a moving collider can lift snow to the top.
    double fall = 0;
    for (int a = 0; a < scene.dimension; ++a)
      fall += forecast.driven ? std::abs(down[a]) * extent[a]
              : down[a] <= 0  ? -down[a] * b.lo[a]
                              : down[a] * (extent[a] - b.hi[a]);
    fall = std::max(0.0, fall);
    const Vector velocity = vector(body.velocity);
    const double v = std::sqrt(velocity.squaredNorm() + 2 * g * fall);
    forecast.impact_speed = std::max(forecast.impact_speed, v);
    impact_time =
        std::min(impact_time, timeToBounds(b, velocity, gravity, extent, scene.dimension));
  }
  // Two bodies closing on each other meet when the gap between their boxes closes.
  for (size_t i = 0; i < boxes.size(); ++i)
    for (size_t j = i + 1; j < boxes.size(); ++j) {
      const Vector closing = vector(scene.bodies[i].velocity) - vector(scene.bodies[j].velocity);
      for (int a = 0; a < scene.dimension; ++a) {
        const double gap_ij = boxes[j].lo[a] - boxes[i].hi[a],
                     gap_ji = boxes[i].lo[a] - boxes[j].hi[a];
        if (gap_ij > 0 && closing[a] > 0) impact_time = std::min(impact_time, gap_ij / closing[a]);
        if (gap_ji > 0 && closing[a] < 0) impact_time = std::min(impact_time, gap_ji / -closing[a]);
      }
    }
  forecast.impact_time = impact_time;  // infinite: nothing in its path
  const SnowMaterial& m = scene.material;
  const double fit = scene.dimension == 2 ? kHardenedWave2d : kHardenedWave3d;
  const double c0 = start.wave_speed / std::sqrt(start.hardening);
  const double hardened = std::min(
      c0 * std::sqrt(double(m.hardening_max)),
      std::max(c0, fit * forecast.impact_speed * std::sqrt(double(m.xi) / 10) / m.theta_c));
  // A resumed run's snow may have hardened past the forecast already.
  const double wave = std::max(hardened, double(start.wave_speed));
  forecast.hardened_step =
      std::min(scene.dt, start.step * (start.wave_speed + start.particle_speed) /
                             (wave + forecast.impact_speed));
  return forecast;
}

}  // namespace snowsim
