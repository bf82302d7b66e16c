// The yardstick of issue-sized 2D targets: the same MLS-MPM snow step the compact single-file
// programs of the MLS-MPM paper's kind take (Hu et al. 2018; one scalar loop per stage, single
// precision, a closed-form polar decomposition for the stress and 2x2 SVD for the plasticity, no
// threads), written here from the paper's formulas, on
// mpm_bench's "2D large" workload: a 0.6 m block of the reference snow (Stomakhin et al. 2013)
// at 4 particles a cell of 1/128 m thrown at the ground at 3 m/s, the step half the CFL limit,
// separating walls. Prints particle-steps per second (median of repetitions), to be run in turn
// with `mpm_bench STEPS REPS 2d-large float one-thread`; "small" runs the "2D small" workload
// instead (a 0.44 m block at 1/64 m, about the size of the compact programs' own scenes).
// Usage: compact_mls_bench [steps=100] [repetitions=3] [large | small] (default large)
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "sim/mpm/snow_material.h"

namespace {

struct Vec2 {
  float x, y;
};
struct Mat2 {  // [a b; c d]
  float a, b, c, d;
};
Mat2 operator*(const Mat2& p, const Mat2& q) {
  return {p.a * q.a + p.b * q.c, p.a * q.b + p.b * q.d, p.c * q.a + p.d * q.c,
          p.c * q.b + p.d * q.d};
}
Mat2 transpose(const Mat2& m) {
  return {m.a, m.c, m.b, m.d};
}

// The polar rotation R of F = R S, in closed form.
Mat2 polarRotation(const Mat2& F) {
  const float x = F.a + F.d, y = F.c - F.b, r = std::sqrt(x * x + y * y);
  const float cr = r > 0 ? x / r : 1, sr = r > 0 ? y / r : 0;
  return {cr, -sr, sr, cr};
}

// F = U diag(s) V^T: the polar rotation R, then one Jacobi rotation of the symmetric R^T F.
void svd(const Mat2& F, Mat2& U, float& s0, float& s1, Mat2& V) {
  const Mat2 R = polarRotation(F);
  const Mat2 S = transpose(R) * F;
  float c = 1, s = 0;
  if (std::abs(S.b) > 1e-6f) {
    const float tau = 0.5f * (S.a - S.d), w = std::sqrt(tau * tau + S.b * S.b);
    const float t = tau > 0 ? S.b / (tau + w) : S.b / (tau - w);
    c = 1 / std::sqrt(t * t + 1);
    s = -t * c;
  }
  s0 = c * c * S.a - 2 * c * s * S.b + s * s * S.d;
  s1 = s * s * S.a + 2 * c * s * S.b + c * c * S.d;
  V = {c, s, -s, c};
  U = R * V;
}

// The quadratic B-spline stencil of a particle: its lowest node (bx, by), the particle's offset
// from it in cells and the weights along each axis.
struct Stencil {
  int bx, by;
  float fx, fy, wx[3], wy[3];
  Stencil(Vec2 x, float inv_h)
      : bx(int(x.x * inv_h - 0.5f)),
        by(int(x.y * inv_h - 0.5f)),
        fx(x.x * inv_h - bx),
        fy(x.y * inv_h - by),
        wx{0.5f * (1.5f - fx) * (1.5f - fx), 0.75f - (fx - 1) * (fx - 1),
           0.5f * (fx - 0.5f) * (fx - 0.5f)},
        wy{0.5f * (1.5f - fy) * (1.5f - fy), 0.75f - (fy - 1) * (fy - 1),
           0.5f * (fy - 0.5f) * (fy - 0.5f)} {}
};

struct Particle {
  Vec2 x, v;
  Mat2 F{1, 0, 0, 1}, C{0, 0, 0, 0};
  float J_P = 1;
};

struct World {
  int n;
  float h, inv_h, dt, mass, volume, mu0, lambda0, xi, lo, hi;
  std::vector<Particle> particles;
  std::vector<float> grid_m;
  std::vector<Vec2> grid_v;  // momentum, then velocity

  void step() {
    std::fill(grid_m.begin(), grid_m.end(), 0.f);
    std::fill(grid_v.begin(), grid_v.end(), Vec2{0, 0});
    const float inertia = 4 * inv_h * inv_h;  // D_p^-1 of quadratic weights
    for (const Particle& p : particles) {     // P2G
      const Stencil st(p.x, inv_h);
      const float e = std::exp(xi * (1 - p.J_P)), mu = mu0 * e, lambda = lambda0 * e;
      // The stress needs R and J only: no SVD here, as in the compact programs.
      const Mat2 R = polarRotation(p.F);
      const float J = p.F.a * p.F.d - p.F.b * p.F.c;
      const Mat2 FmR{p.F.a - R.a, p.F.b - R.b, p.F.c - R.c, p.F.d - R.d};
      Mat2 tau = FmR * transpose(p.F);  // Kirchhoff stress
      tau = {2 * mu * tau.a + lambda * (J - 1) * J, 2 * mu * tau.b, 2 * mu * tau.c,
             2 * mu * tau.d + lambda * (J - 1) * J};
      const float k = -dt * volume * inertia;
      const Mat2 A{k * tau.a + mass * p.C.a, k * tau.b + mass * p.C.b, k * tau.c + mass * p.C.c,
                   k * tau.d + mass * p.C.d};
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
          const float dx = (i - st.fx) * h, dy = (j - st.fy) * h, w = st.wx[i] * st.wy[j];
          const int g = (st.bx + i) * (n + 1) + st.by + j;
          grid_m[g] += w * mass;
          grid_v[g].x += w * (mass * p.v.x + A.a * dx + A.b * dy);
          grid_v[g].y += w * (mass * p.v.y + A.c * dx + A.d * dy);
        }
    }
    for (int i = 0; i <= n; ++i)  // grid velocities, gravity, separating walls
      for (int j = 0; j <= n; ++j) {
        const int g = i * (n + 1) + j;
        if (grid_m[g] <= 0) continue;
        Vec2& v = grid_v[g];
        v = {v.x / grid_m[g], v.y / grid_m[g] - dt * 9.81f};
        if ((i < 2 && v.x < 0) || (i > n - 2 && v.x > 0)) v.x = 0;
        if ((j < 2 && v.y < 0) || (j > n - 2 && v.y > 0)) v.y = 0;
      }
    for (Particle& p : particles) {  // G2P, F_E, plasticity, advection
      const Stencil st(p.x, inv_h);
      Vec2 v{0, 0};
      Mat2 B{0, 0, 0, 0};
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
          const float dx = (i - st.fx) * h, dy = (j - st.fy) * h, w = st.wx[i] * st.wy[j];
          const Vec2 gv = grid_v[(st.bx + i) * (n + 1) + st.by + j];
          v = {v.x + w * gv.x, v.y + w * gv.y};
          B = {B.a + w * gv.x * dx, B.b + w * gv.x * dy, B.c + w * gv.y * dx, B.d + w * gv.y * dy};
        }
      p.v = v;
      p.C = {inertia * B.a, inertia * B.b, inertia * B.c, inertia * B.d};
      p.x = {p.x.x + dt * v.x, p.x.y + dt * v.y};
      const Mat2 G{1 + dt * p.C.a, dt * p.C.b, dt * p.C.c, 1 + dt * p.C.d};
      const Mat2 F = G * p.F;
      Mat2 U, V;
      float s0, s1;
      svd(F, U, s0, s1, V);
      const float c0 = std::clamp(s0, lo, hi), c1 = std::clamp(s1, lo, hi);
      p.J_P *= (s0 * s1) / (c0 * c1);
      p.F = U * Mat2{c0, 0, 0, c1} * transpose(V);
    }
  }
};

}  // namespace

int main(int argc, char** argv) {
  const int steps = argc > 1 ? std::atoi(argv[1]) : 100;
  const int reps = argc > 2 ? std::atoi(argv[2]) : 3;
  const std::string workload = argc > 3 ? argv[3] : "large";
  if (argc > 4 || steps < 1 || reps < 1 || (workload != "large" && workload != "small")) {
    std::fprintf(stderr,
                 "usage: compact_mls_bench [steps >= 1, default 100] [repetitions >= 1, default "
                 "3] [large | small, default large]\n");
    return 2;
  }
  const snowsim::SnowMaterial material;    // the paper's reference snow
  const bool small = workload == "small";  // mpm_bench's cases: 64 cells and 0.44 m, or 128, 0.6
  const int n = small ? 64 : 128;
  const float h = 1.f / n, box = small ? 0.44f : 0.6f, density = 400, spacing = h / 2;
  std::vector<double> rates;
  for (int rep = 0; rep < reps; ++rep) {
    World world{n,
                h,
                1 / h,
                0,
                density * spacing * spacing,
                spacing * spacing,
                float(material.mu0()),
                float(material.lambda0()),
                float(material.xi),
                float(1 - material.theta_c),
                float(1 + material.theta_s),
                {},
                std::vector<float>((n + 1) * (n + 1)),
                std::vector<Vec2>((n + 1) * (n + 1))};
    // The block's lattice: 4 particles a cell, its bottom one cell above the ground.
    const float x0 = 0.5f - box / 2, y0 = h;
    const int count = int(std::lround(box / spacing));
    for (int i = 0; i < count; ++i)
      for (int j = 0; j < count; ++j) {
        Particle p;
        p.x = {x0 + (i + 0.5f) * spacing, y0 + (j + 0.5f) * spacing};
        p.v = {0, -3};
        world.particles.push_back(p);
      }
    const float wave = std::sqrt(float(material.lambda0() + 2 * material.mu0()) / density);
    world.dt = 0.5f * 0.9f * h / (wave + 3);  // half the CFL limit, as mpm_bench
    const auto t0 = std::chrono::steady_clock::now();
    for (int k = 0; k < steps; ++k) world.step();
    const double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    rates.push_back(double(world.particles.size()) * steps / sec);
    float top = 0;  // the block's top after the steps: it lands and compacts
    bool finite = true;
    for (const Particle& p : world.particles) {
      top = std::max(top, p.x.y);
      finite = finite && std::isfinite(p.x.x) && std::isfinite(p.x.y);
    }
    if (rep == 0)
      std::printf("%zu particles, dt %.3g s; after %d steps the top at %.4f m (from %.4f)%s\n",
                  world.particles.size(), world.dt, steps, top, y0 + box,
                  finite ? "" : ", NOT FINITE");
  }
  std::nth_element(rates.begin(), rates.begin() + reps / 2, rates.end());
  std::printf("compact 2D MLS, float, 1 thread: %.2f M particle-steps/s\n", rates[reps / 2] / 1e6);
}
