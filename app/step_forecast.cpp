#include "app/step_forecast.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "sim/core/rigid_motion.h"

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

Box boxOf(const std::array<std::array<double, 3>, 2>& bounds) {
  return {{bounds[0][0], bounds[0][1], bounds[0][2]}, {bounds[1][0], bounds[1][1], bounds[1][2]}};
}

Box bodyBox(const Body& body) {
  switch (body.shape) {
    case BodyShape::Ball:
    case BodyShape::HalfBall:
      return {vector(body.center).array() - body.radius, vector(body.center).array() + body.radius};
    case BodyShape::Box:
      return {vector(body.center) - vector(body.size) / 2,
              vector(body.center) + vector(body.size) / 2};
    case BodyShape::Mesh:
      return boxOf(body.mesh.placedAt(body.center).bounds());
    case BodyShape::Points:
      break;
  }
  // A points body without particles: its centre (moverOf reads a frame's particles).
  return {vector(body.center), vector(body.center)};
}

// A body as the forecast moves it: its box at the start, the velocity the box moves at, and the
// fastest speed of its snow.
struct Mover {
  Box box;
  Vector velocity;
  double fastest = 0;
};

Mover moverOf(const Body& body) {
  if (body.shape != BodyShape::Points || !body.points || body.points->size() == 0)
    return {bodyBox(body), vector(body.velocity), vector(body.velocity).norm()};
  // Another run's frame: the box of its particles, moving at their mean velocity.
  const Snapshot& points = *body.points;
  Mover m{{Vector::Constant(std::numeric_limits<double>::infinity()),
           Vector::Constant(-std::numeric_limits<double>::infinity())},
          Vector::Zero()};
  for (int i = 0; i < points.size(); ++i) {
    const Vector x = Eigen::Vector3f(points.position[i].data()).cast<double>();
    const Vector v = Eigen::Vector3f(points.velocity[i].data()).cast<double>();
    m.box.lo = m.box.lo.cwiseMin(x);
    m.box.hi = m.box.hi.cwiseMax(x);
    m.velocity += v / points.size();
    m.fastest = std::max(m.fastest, v.norm());
  }
  return m;
}

bool moves(const ColliderParams& c) {
  return !c.keyframes.empty() || vector(c.velocity).norm() > 0 ||
         vector(c.angular_velocity).norm() > 0;
}

// When a gap closes at speed `speed` and acceleration `accel` towards it: gap = s t + a t^2 / 2;
// infinite if it never does.
double timeToClose(double gap, double speed, double accel) {
  if (gap <= 0) return 0;
  const double disc = speed * speed + 2 * accel * gap;
  if (accel != 0 && disc >= 0) {
    const double t = (std::sqrt(disc) - speed) / accel;
    if (t >= 0) return t;
  } else if (accel == 0 && speed > 0) {
    return gap / speed;
  }
  return std::numeric_limits<double>::infinity();
}

// The earliest time a body (box b, velocity v) reaches the domain's bounds along an axis it moves
// along, gravity bending its fall.
double timeToBounds(const Box& b, const Vector& v, const Vector& gravity, const Vector& extent,
                    int dimension) {
  double earliest = std::numeric_limits<double>::infinity();
  for (int a = 0; a < dimension; ++a)
    earliest = std::min({earliest, timeToClose(b.lo[a], -v[a], -gravity[a]),
                         timeToClose(extent[a] - b.hi[a], v[a], gravity[a])});
  return earliest;
}

// An obstacle inside the domain that stays where it is: a half space (a plane and its outward
// normal) or the world box of a sphere, a box or a mesh. Moving colliders and drums are left to
// the driven forecast.
struct Obstacle {
  bool plane = false;
  Vector point, normal;  // plane
  Box box;               // otherwise
};

std::optional<Obstacle> obstacleOf(const ColliderParams& c) {
  if (moves(c) || c.shape == ColliderShape::Drum) return std::nullopt;
  const Eigen::Matrix3d turn = RigidMotion(c).at(0).rotation.toRotationMatrix();
  const Vector at = vector(c.position);
  Obstacle o;
  if (c.shape == ColliderShape::HalfSpace) {
    o.plane = true;
    o.point = at;
    o.normal = (turn * vector(c.normal)).normalized();
    return o;
  }
  // The local box, turned: its world box spans |R| times its half size about its centre.
  Box local;
  if (c.shape == ColliderShape::Sphere) {
    local = {Vector::Constant(-c.radius), Vector::Constant(c.radius)};
  } else if (c.shape == ColliderShape::Box) {
    local = {-vector(c.size) / 2, vector(c.size) / 2};
  } else {
    local = boxOf(c.mesh.placedAt({0, 0, 0}).bounds());
  }
  const Vector centre = at + turn * (local.lo + local.hi) / 2;
  const Vector half = turn.cwiseAbs() * (local.hi - local.lo) / 2;
  o.box = {centre - half, centre + half};
  return o;
}

// How far a body's box lies from an obstacle's box along axis a, ahead of it or behind, when the
// obstacle is in its way: the boxes overlap across the other axes. Infinite when it is not.
double gapAlong(const Box& b, const Obstacle& o, int a, int dimension, bool ahead) {
  constexpr double none = std::numeric_limits<double>::infinity();
  for (int other = 0; other < dimension; ++other)
    if (other != a && (b.hi[other] < o.box.lo[other] || b.lo[other] > o.box.hi[other])) return none;
  const double gap = ahead ? o.box.lo[a] - b.hi[a] : b.lo[a] - o.box.hi[a];
  return gap >= 0 ? gap : none;
}

// The least distance from the plane of any corner of b (negative where a corner is behind it).
double gapToPlane(const Box& b, const Obstacle& o, int dimension) {
  double nearest = std::numeric_limits<double>::infinity();
  for (int corner = 0; corner < (1 << dimension); ++corner) {
    Vector x = b.lo;
    for (int a = 0; a < dimension; ++a)
      if (corner & (1 << a)) x[a] = b.hi[a];
    double distance = 0;
    for (int a = 0; a < dimension; ++a) distance += o.normal[a] * (x[a] - o.point[a]);
    nearest = std::min(nearest, distance);
  }
  return nearest;
}

// When the body meets the obstacle and how far it falls to it (infinite where it does not lie
// below).
std::pair<double, double> meeting(const Mover& m, const Obstacle& o, const Vector& gravity,
                                  const Vector& down, int dimension) {
  constexpr double none = std::numeric_limits<double>::infinity();
  if (o.plane) {
    const double gap = std::max(0.0, gapToPlane(m.box, o, dimension));
    const double facing = -o.normal.dot(down);
    return {timeToClose(gap, -o.normal.dot(m.velocity), -o.normal.dot(gravity)),
            facing > 0 ? gap / facing : none};
  }
  double earliest = none, fall = none;
  for (int a = 0; a < dimension; ++a)
    for (const bool ahead : {true, false}) {
      const double gap = gapAlong(m.box, o, a, dimension, ahead), sign = ahead ? 1 : -1;
      earliest = std::min(earliest, timeToClose(gap, sign * m.velocity[a], sign * gravity[a]));
      if (sign * down[a] > 0) fall = std::min(fall, gap / (sign * down[a]));
    }
  return {earliest, fall};
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
  std::vector<Obstacle> obstacles;
  for (const ColliderParams& c : scene.colliders)
    if (const auto o = obstacleOf(c)) obstacles.push_back(*o);
  double impact_time = std::numeric_limits<double>::infinity();
  std::vector<Mover> movers;
  for (const Body& body : scene.bodies) movers.push_back(moverOf(body));
  for (const Mover& m : movers) {
    const Box& b = m.box;
    // The height it falls to the domain's floor or an obstacle under it; a moving collider can
    // lift snow to the top.
    double fall = 0;
    for (int a = 0; a < scene.dimension; ++a)
      fall += forecast.driven ? std::abs(down[a]) * extent[a]
              : down[a] <= 0  ? -down[a] * b.lo[a]
                              : down[a] * (extent[a] - b.hi[a]);
    double time = timeToBounds(b, m.velocity, gravity, extent, scene.dimension);
    for (const Obstacle& o : obstacles) {
      const auto [meets, falls] = meeting(m, o, gravity, down, scene.dimension);
      time = std::min(time, meets);
      if (!forecast.driven) fall = std::min(fall, falls);
    }
    fall = std::max(0.0, fall);
    const double v = std::sqrt(m.fastest * m.fastest + 2 * g * fall);
    forecast.impact_speed = std::max(forecast.impact_speed, v);
    impact_time = std::min(impact_time, time);
  }
  // Two bodies closing on each other meet when the gap between their boxes closes.
  for (size_t i = 0; i < movers.size(); ++i)
    for (size_t j = i + 1; j < movers.size(); ++j) {
      const Vector closing = movers[i].velocity - movers[j].velocity;
      for (int a = 0; a < scene.dimension; ++a) {
        const double gap_ij = movers[j].box.lo[a] - movers[i].box.hi[a],
                     gap_ji = movers[i].box.lo[a] - movers[j].box.hi[a];
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
