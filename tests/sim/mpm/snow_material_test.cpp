#include "sim/mpm/snow_material.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <cstring>
#include <limits>
#include <numeric>
#include <random>
#include <span>
#include <type_traits>
#include <vector>

using namespace snowsim;

TEST(SnowMaterial, LameFromYoungAndPoisson) {
  const SnowMaterial m;
  EXPECT_NEAR(m.mu0(), 1.4e5 / 2.4, 1e-9);
  EXPECT_NEAR(m.lambda0(), 1.4e5 * 0.2 / (1.2 * 0.6), 1e-9);
  const Lame compacted = hardenedLame(m, 0.9);
  EXPECT_NEAR(compacted.mu, m.mu0() * std::exp(1.0), 1e-6);
}

// The hardening factor e^{xi (1 - J_P)} is clamped to the material's bounds, in either precision;
// inside them it is the paper's eq. 8.
TEST(SnowMaterial, HardeningStaysWithinItsBounds) {
  SnowMaterial m;
  m.hardening_min = 0.2;
  m.hardening_max = 5;
  EXPECT_NEAR(hardenedLame(m, 1.02).mu, m.mu0() * std::exp(-0.2), 1e-9);  // inside
  EXPECT_NEAR(hardenedLame(m, 3.0).mu, 0.2 * m.mu0(), 1e-9);              // stretched: e^-20
  EXPECT_NEAR(hardenedLame(m, 3.0).lambda, 0.2 * m.lambda0(), 1e-9);
  EXPECT_NEAR(hardenedLame(m, 0.5).mu, 5 * m.mu0(), 1e-9);  // compacted: e^5 = 148
  EXPECT_NEAR(hardenedLame<float>(m, 3.0f).mu, 0.2f * float(m.mu0()), 1e-2f);
  EXPECT_NEAR(hardenedLame<float>(m, 0.5f).lambda, 5 * float(m.lambda0()), 1e-1f);
  // Unbounded by default, as in the paper: J_P = 0.5 hardens e^5 times.
  EXPECT_NEAR(hardenedLame(SnowMaterial{}, 0.5).mu, SnowMaterial{}.mu0() * std::exp(5.0), 1e-6);
}

TEST(SnowMaterial, TwoByTwoSvdReconstructs) {
  Mat<2> F;
  F << 1.1, 0.3, -0.2, 0.7;
  Mat<2> U, V;
  Vec<2> s;
  signedSvd<2>(F, U, s, V);
  EXPECT_LT((U * s.asDiagonal() * V.transpose() - F).norm(), 1e-12);
  EXPECT_NEAR(U.determinant(), 1, 1e-12);
  EXPECT_NEAR(V.determinant(), 1, 1e-12);
  const Mat<2> R = polarRotation<2>(F);
  const Mat<2> S = R.transpose() * F;
  EXPECT_NEAR(S(0, 1), S(1, 0), 1e-12);
}

TEST(SnowMaterial, StressVanishesAtRestAndForRotations) {
  const Lame lame = hardenedLame(SnowMaterial{}, 1);
  EXPECT_LT(fixedCorotatedPiola<3>(Mat<3>::Identity(), lame).norm(), 1e-9);
  const Mat<3> R = Eigen::AngleAxisd(0.7, Vec<3>(1, 2, 3).normalized()).toRotationMatrix();
  EXPECT_LT(fixedCorotatedPiola<3>(R, lame).norm(), 1e-6);
}

TEST(SnowMaterial, PiolaIsTheEnergyGradient) {
  // Central differences of Psi = mu ||F - R||^2 + lambda/2 (J - 1)^2 (paper eq. 6).
  const Lame lame{2.0, 3.0};
  Mat<2> F;
  F << 1.05, 0.1, -0.04, 0.93;
  auto psi = [&](const Mat<2>& G) {
    const Real J = G.determinant();
    return lame.mu * (G - polarRotation<2>(G)).squaredNorm() +
           0.5 * lame.lambda * (J - 1) * (J - 1);
  };
  const Mat<2> P = fixedCorotatedPiola<2>(F, lame);
  const Real eps = 1e-6;
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) {
      Mat<2> Fp = F, Fm = F;
      Fp(i, j) += eps;
      Fm(i, j) -= eps;
      EXPECT_NEAR((psi(Fp) - psi(Fm)) / (2 * eps), P(i, j), 1e-7);
    }
  EXPECT_LT((fixedCorotatedKirchhoff<2>(F, polarRotation<2>(F), lame) - P * F.transpose()).norm(),
            1e-12);
  EXPECT_LT(
      (fixedCorotatedKirchhoffUpper<2>(F, polarRotation<2>(F), lame).matrix() - P * F.transpose())
          .norm(),
      1e-12);
}

// The stress the particles keep is the upper triangle of P F_E^T, which is symmetric: the full
// matrix from the packed one must be P F_E^T itself, lower triangle included.
TEST(SnowMaterial, KirchhoffStressKeptByItsUpperTriangleIsPFTranspose) {
  const SnowMaterial m;
  const Lame lame = hardenedLame<Real>(m, 0.9);
  Mat<3> F;
  F << 1.02, 0.07, -0.03, -0.05, 0.96, 0.04, 0.02, -0.06, 1.01;
  const Mat<3> tau = fixedCorotatedPiola<3>(F, lame) * F.transpose();
  EXPECT_LT((tau - tau.transpose()).norm(), 1e-9 * tau.norm());
  EXPECT_LT((fixedCorotatedKirchhoffUpper<3>(F, polarRotation<3>(F), lame).matrix() - tau).norm(),
            1e-12 * tau.norm());
  EXPECT_GT(tau.norm(), 1e3);  // a stress of the material's size, not a zero that matches anything
}

TEST(SnowMaterial, ReturnMappingClampsAndKeepsTotalDeformation) {
  const SnowMaterial m;
  Mat<3> F_E;
  F_E << 0.9, 0.05, 0, 0.02, 1.04, 0.01, 0, 0.03, 0.97;
  Mat<3> F_P = Mat<3>::Identity();
  const Mat<3> F = F_E * F_P;
  const Real J_P = plasticReturnMapping<3>(m, F_E, F_P);
  const Eigen::JacobiSVD<Mat<3>> svd(F_E);
  for (int a = 0; a < 3; ++a) {
    EXPECT_GE(svd.singularValues()[a], 1 - m.theta_c - 1e-12);
    EXPECT_LE(svd.singularValues()[a], 1 + m.theta_s + 1e-12);
  }
  EXPECT_LT((F_E * F_P - F).norm(), 1e-12);
  EXPECT_NEAR(J_P, F_P.determinant(), 1e-12);
  Mat<3> F_E2 = F, R_E;
  EXPECT_NEAR(plasticReturnMappingJ(m, F_E2, 1.0, R_E), J_P, 1e-12);
  EXPECT_LT((R_E - polarRotation<3>(F_E2)).norm(), 1e-12) << "the rotation of the new F_E";
  EXPECT_LT(J_P, 1);  // compressed overall: compaction goes into J_P
}

// Checks what a return mapping made of F starting from J_P = 0.8 (F_E, J_P, R_E) against the SVD
// definition: clamp U sigma V^T, J_P' = J_P det F / det F_E', R_E = U V^T; F_E kept bit for bit
// when nothing is clamped. Returns whether nothing was.
template <int D>
bool expectSvdDefinition(const SnowMaterial& m, const Mat<D>& F, const Mat<D>& F_E, Real J_P,
                         const Mat<D>& R_E, Real tolerance) {
  Mat<D> U, V;
  Vec<D> sigma;
  signedSvd<D>(F, U, sigma, V);
  const Vec<D> clamped = sigma.cwiseMax(1 - m.theta_c).cwiseMin(1 + m.theta_s);
  const Mat<D> expected_F_E = U * clamped.asDiagonal() * V.transpose();
  const Real expected_J_P = 0.8 * F.determinant() / expected_F_E.determinant();
  EXPECT_LT((F_E - expected_F_E).norm(), tolerance) << F;
  EXPECT_NEAR(J_P, expected_J_P, tolerance) << F;
  EXPECT_LT((R_E - U * V.transpose()).norm(), tolerance) << F;
  const bool unclamped = clamped == sigma;
  if (unclamped) {
    EXPECT_EQ(F_E, F) << "unclamped F_E is kept bit for bit";
  }
  return unclamped;
}

// The 2D return mapping works through the polar decomposition instead of the SVD: it must give
// what the SVD definition gives (clamp U sigma V^T, J_P' = J_P det F_E / det F_E'), including
// inverted and unstrained F.
TEST(SnowMaterial, TwoDimensionalReturnMappingMatchesTheSvdDefinition) {
  const SnowMaterial m;
  std::mt19937 random(5);
  std::normal_distribution<double> noise(0, 1);
  std::vector<Mat<2>> cases = {Mat<2>::Identity(), Mat<2>::Identity() * 0.9,
                               Mat<2>(Eigen::Rotation2Dd(0.3)) * Vec<2>(1.005, 0.99).asDiagonal(),
                               Mat<2>(Eigen::Rotation2Dd(0.7)) * Vec<2>(1.2, 0.95).asDiagonal()};
  for (int k = 0; k < 300; ++k) {
    Mat<2> F = Eigen::Rotation2Dd(3 * noise(random)).toRotationMatrix();
    F += (k % 3 == 0 ? 0.5 : 0.03) * Mat<2>::Random();
    cases.push_back(F);
  }
  Mat<2> inverted;
  inverted << 1, 0, 0, -0.5;
  cases.push_back(inverted);
  for (const Mat<2>& F : cases) {
    Mat<2> F_E = F, R_E;
    const Real J_P = plasticReturnMappingJ(m, F_E, 0.8, R_E);
    expectSvdDefinition<2>(m, F, F_E, J_P, R_E, 1e-13);
  }
}

// The 3D return mapping takes the polar rotation by Newton's iteration and skips the SVD when the
// singular values are inside the bounds: on either path it must give what the SVD definition
// gives, for unstrained, elastic (within bounds), plastic (beyond) and inverted F.
// What the 3D return mapping meets: unstrained, elastic (within bounds), plastic (beyond), near
// the bounds and inverted F.
static std::vector<Mat<3>> returnMappingCases(const SnowMaterial& m) {
  std::mt19937 random(9);
  std::normal_distribution<double> noise(0, 1);
  auto rotation = [&] {
    return Mat<3>(Eigen::AngleAxisd(
        3 * noise(random), Vec<3>(noise(random), noise(random), noise(random)).normalized()));
  };
  std::vector<Mat<3>> cases = {Mat<3>::Identity(), Mat<3>::Identity() * 0.99,
                               rotation() * Vec<3>(1.005, 0.98, 1.0).asDiagonal() * rotation(),
                               rotation() * Vec<3>(1.2, 0.95, 0.9).asDiagonal() * rotation()};
  for (int k = 0; k < 300; ++k) {
    const Real spread = k % 3 == 0 ? 0.3 : 0.004;  // two in three stay elastic
    cases.push_back(rotation() * (Mat<3>::Identity() + spread * Mat<3>::Random()));
  }
  // Singular values around the bounds, a little inside or a little beyond.
  std::uniform_real_distribution<double> near_bounds(1 - m.theta_c - 0.01, 1 + m.theta_s + 0.01);
  for (int k = 0; k < 300; ++k)
    cases.push_back(
        rotation() *
        Vec<3>(near_bounds(random), near_bounds(random), near_bounds(random)).asDiagonal() *
        rotation());
  cases.push_back(Vec<3>(1, 1, -0.5).asDiagonal());  // inverted
  return cases;
}

TEST(SnowMaterial, ThreeDimensionalReturnMappingMatchesTheSvdDefinition) {
  const SnowMaterial m;
  const std::vector<Mat<3>> cases = returnMappingCases(m);
  int elastic = 0;
  for (const Mat<3>& F : cases) {
    Mat<3> F_E = F, R_E;
    const Real J_P = plasticReturnMappingJ(m, F_E, 0.8, R_E);
    if (expectSvdDefinition<3>(m, F, F_E, J_P, R_E, 1e-12)) {
      ++elastic;
      EXPECT_EQ(J_P, 0.8);
    }
  }
  EXPECT_GT(elastic, 200) << "the elastic path was exercised";
}

// The 3D return mapping runs particles eight at a time in vector lanes, and those beyond their
// bounds gathered into lanes of their own: whatever batch a particle is in, and on whichever build
// of the lanes, it must get what it gets alone on the baseline build, bit for bit (each lane
// iterates until its own particle converges). The Lamé parameters it hardens anew and the stress
// it leaves for the scatter must be those of the new J_P and F_E (P F_E^T, to round-off relative
// to the stress and to mu), the same bits on every build.
template <class T>
void expectBatchesMatchOneAtATime() {
  const SnowMaterial m;
  std::vector<Mat<3, T>> F;
  for (const Mat<3>& c : returnMappingCases(m)) F.push_back(c.cast<T>());
  const int n = int(F.size());
  std::vector<Mat<3, T>> F_alone = F, R_alone(n);
  std::vector<T> J_alone(n, T(0.8));
  const VectorIsa best = vectorIsa();
  vectorIsa() = VectorIsa::baseline;
  for (int p = 0; p < n; ++p)
    J_alone[p] = plasticReturnMappingJ<T>(m, F_alone[p], J_alone[p], R_alone[p]);
  vectorIsa() = best;
  std::vector<Symmetric<3, T>> first_tau;
  for (const VectorIsa isa : {VectorIsa::baseline, VectorIsa::avx2, VectorIsa::avx512}) {
    if (isa > best) continue;
    std::vector<Mat<3, T>> F_E = F, R_E(n);
    std::vector<T> J_P(n, T(0.8));
    std::vector<T> hardening(n, hardeningFactor<T>(m, T(0.8)));
    std::vector<Symmetric<3, T>> tau(n);
    std::vector<int> order(n);
    std::iota(order.begin(), order.end(), 0);
    std::shuffle(order.begin(), order.end(), std::mt19937(int(isa)));
    constexpr int sizes[] = {1, 5, 8, 13, returnMappingBatch, 30, 2, 2 * returnMappingBatch + 3};
    for (int first = 0, k = 0; first < n; first += sizes[k], k = (k + 1) % std::size(sizes)) {
      const std::span<const int> batch(order.data() + first, std::min(sizes[k], n - first));
      std::vector<Mat<3, T>> rotations(batch.size());  // in the batch's order
      plasticReturnMappingJ<T>(m, batch, F_E.data(), J_P.data(), rotations.data(), hardening.data(),
                               tau.data(), isa);
      for (size_t i = 0; i < batch.size(); ++i) R_E[batch[i]] = rotations[i];
    }
    const double tolerance = std::is_same_v<T, float> ? 1e-5 : 1e-12;
    for (int p = 0; p < n; ++p) {
      EXPECT_EQ(F_E[p], F_alone[p]) << "case " << p << ", build " << int(isa);
      EXPECT_EQ(J_P[p], J_alone[p]) << "case " << p << ", build " << int(isa);
      EXPECT_EQ(R_E[p], R_alone[p]) << "case " << p << ", build " << int(isa);
      EXPECT_EQ(hardening[p], hardeningFactor<T>(m, J_P[p]))
          << "case " << p << ", build " << int(isa);
      const LameOf<T> hardened = hardenedLame<T>(m, J_P[p]);
      const Mat<3> F_new = F_E[p].template cast<double>();
      const Lame L{double(hardened.mu), double(hardened.lambda)};
      const Mat<3> expected = fixedCorotatedPiola<3>(F_new, L) * F_new.transpose();
      EXPECT_LT((tau[p].matrix().template cast<double>() - expected).norm(),
                tolerance * (expected.norm() + L.mu))
          << "case " << p << ", build " << int(isa);
      if (!first_tau.empty()) {
        EXPECT_EQ(tau[p].upper, first_tau[p].upper) << "case " << p;
      }
    }
    if (first_tau.empty()) first_tau = tau;
  }
  // Asked for no rotations (as the solver asks), the rest comes out the same on every build.
  for (const VectorIsa isa : {VectorIsa::baseline, VectorIsa::avx2, VectorIsa::avx512}) {
    if (isa > best) continue;
    std::vector<Mat<3, T>> F_E = F;
    std::vector<T> J_P(n, T(0.8));
    std::vector<T> hardening(n, hardeningFactor<T>(m, T(0.8)));
    std::vector<Symmetric<3, T>> tau(n);
    std::vector<int> all(n);
    std::iota(all.begin(), all.end(), 0);
    plasticReturnMappingJ<T>(m, all, F_E.data(), J_P.data(), nullptr, hardening.data(), tau.data(),
                             isa);
    for (int p = 0; p < n; ++p) {
      EXPECT_EQ(F_E[p], F_alone[p]) << "case " << p << ", no rotations, build " << int(isa);
      EXPECT_EQ(J_P[p], J_alone[p]) << "case " << p << ", no rotations, build " << int(isa);
      EXPECT_EQ(tau[p].upper, first_tau[p].upper) << "case " << p << ", no rotations";
    }
  }
}

TEST(SnowMaterial, ReturnMappingInLanesMatchesOneAtATime) {
  expectBatchesMatchOneAtATime<double>();
  expectBatchesMatchOneAtATime<float>();
}

// The 2D return mapping runs particles eight at a time in vector lanes, selecting per lane what
// the scalar closed form branches on (no rotation to speak of, a scaled rotation, singular values
// within their bounds): on every build and in any batch, each particle's F_E, J_P, Lamé
// parameters and stress must be the scalar code's bit for bit, that stress being
// fixedCorotatedKirchhoffUpper of the rotation the scalar call returns.
template <class T>
void expect2dBatchesMatchTheScalarMapping() {
  const SnowMaterial m;
  std::mt19937 random(4);
  std::normal_distribution<double> noise(0, 1);
  std::uniform_real_distribution<double> near_bounds(1 - m.theta_c - 0.01, 1 + m.theta_s + 0.01);
  auto rotation = [&] { return Mat<2>(Eigen::Rotation2Dd(3 * noise(random))); };
  std::vector<Mat<2>> cases = {Mat<2>::Identity(),
                               Mat<2>::Zero(),
                               (Mat<2>() << 0.5, 0.2, 0.2, -0.5).finished(),  // r = 0
                               1.2 * rotation(),
                               0.99 * rotation(),
                               Vec<2>(1, -0.5).asDiagonal(),
                               Mat<2>::Constant(std::numeric_limits<double>::quiet_NaN()),
                               Mat<2>::Identity() * std::numeric_limits<double>::infinity()};
  for (int k = 0; k < 300; ++k) {
    const Real spread = k % 3 == 0 ? 0.3 : 0.004;
    cases.push_back(rotation() * (Mat<2>::Identity() + spread * Mat<2>::Random()));
    cases.push_back(rotation() * Vec<2>(near_bounds(random), near_bounds(random)).asDiagonal() *
                    rotation());
  }
  std::vector<Mat<2, T>> F;
  for (const Mat<2>& c : cases) F.push_back(c.cast<T>());
  const int n = int(F.size());
  std::vector<Mat<2, T>> F_alone = F;
  std::vector<T> J_alone(n, T(0.8));
  std::vector<T> hardening_alone(n);
  std::vector<Symmetric<2, T>> tau_alone(n);
  int elastic = 0;
  for (int p = 0; p < n; ++p) {
    Mat<2, T> R;
    J_alone[p] = plasticReturnMappingJ<T>(m, F_alone[p], J_alone[p], R);
    elastic += J_alone[p] == T(0.8);
    hardening_alone[p] = hardeningFactor<T>(m, J_alone[p]);
    tau_alone[p] = fixedCorotatedKirchhoffUpper<2, T>(F_alone[p], R, lameOf(m, hardening_alone[p]));
  }
  EXPECT_GT(elastic, 100) << "both paths exercised";
  EXPECT_LT(elastic, n - 100) << "both paths exercised";
  const VectorIsa best = vectorIsa();
  for (const VectorIsa isa : {VectorIsa::baseline, VectorIsa::avx2, VectorIsa::avx512}) {
    if (isa > best) continue;
    std::vector<Mat<2, T>> F_E = F;
    std::vector<T> J_P(n, T(0.8));
    std::vector<T> hardening(n, hardeningFactor<T>(m, T(0.8)));
    std::vector<Symmetric<2, T>> tau(n);
    std::vector<int> order(n);
    std::iota(order.begin(), order.end(), 0);
    std::shuffle(order.begin(), order.end(), std::mt19937(int(isa)));
    constexpr int sizes[] = {1, 5, 8, 13, 64, 3};
    for (int first = 0, k = 0; first < n; first += sizes[k], k = (k + 1) % std::size(sizes))
      plasticReturnMappingJ<T>(
          m, std::span<const int>(order.data() + first, std::min(sizes[k], n - first)), F_E.data(),
          J_P.data(), hardening.data(), tau.data(), isa);
    // Bit patterns, so that -0 against +0 and NaN against NaN count too.
    const auto same = [](const auto& a, const auto& b) {
      return std::memcmp(&a, &b, sizeof a) == 0;
    };
    for (int p = 0; p < n; ++p) {
      EXPECT_TRUE(same(F_E[p], F_alone[p])) << "case " << p << ", build " << int(isa);
      EXPECT_TRUE(same(J_P[p], J_alone[p])) << "case " << p << ", build " << int(isa);
      EXPECT_TRUE(same(hardening[p], hardening_alone[p])) << "case " << p << ", build " << int(isa);
      EXPECT_TRUE(same(tau[p], tau_alone[p])) << "case " << p << ", build " << int(isa);
    }
  }
}

TEST(SnowMaterial, TwoDimensionalReturnMappingInLanesMatchesTheScalarOne) {
  expect2dBatchesMatchTheScalarMapping<double>();
  expect2dBatchesMatchTheScalarMapping<float>();
}

// Degenerate F (rank one, rank two, zero) takes the lanes' SVD path with its special cases: the
// result must still be a rotation R_E, an F_E whose singular values lie within the bounds, and a
// finite J_P, in either precision, whatever the batch.
template <class T>
void expectDegenerateMappedSanely() {
  const SnowMaterial m;
  const Vec<3, T> u(T(0.6), T(0), T(0.8)), v(T(0), T(1), T(0)), w(T(0), T(0), T(1));
  const std::vector<Mat<3, T>> cases = {
      Mat<3, T>::Zero(),
      T(1.2) * u * v.transpose(),                      // rank one
      T(0.9) * w * w.transpose(),                      // rank one along z
      u * v.transpose() + T(0.5) * w * u.transpose(),  // rank two
      T(0.97) * Mat<3, T>::Identity(),                 // elastic, in the same batch
  };
  const int n = int(cases.size());
  std::vector<Mat<3, T>> F_E = cases, R_E(n);
  std::vector<T> J_P(n, T(0.8));
  std::vector<int> all(n);
  std::iota(all.begin(), all.end(), 0);
  std::vector<T> hardening(n, hardeningFactor<T>(m, T(0.8)));
  std::vector<Symmetric<3, T>> tau(n);
  plasticReturnMappingJ<T>(m, all, F_E.data(), J_P.data(), R_E.data(), hardening.data(), tau.data(),
                           vectorIsa());
  const double tolerance = std::is_same_v<T, float> ? 1e-5 : 1e-12;
  for (int p = 0; p < n; ++p) {
    EXPECT_TRUE(std::isfinite(J_P[p])) << "case " << p;
    EXPECT_LT((R_E[p].transpose() * R_E[p] - Mat<3, T>::Identity()).norm(), tolerance)
        << "case " << p;
    EXPECT_NEAR(R_E[p].determinant(), 1, tolerance) << "case " << p;
    const Eigen::JacobiSVD<Mat<3, T>> svd(F_E[p]);
    for (int a = 0; a < 3; ++a) {
      EXPECT_GE(svd.singularValues()[a], T(1 - m.theta_c) - tolerance) << "case " << p;
      EXPECT_LE(svd.singularValues()[a], T(1 + m.theta_s) + tolerance) << "case " << p;
    }
  }
  EXPECT_EQ(J_P[0], 0) << "F = 0: all of it plastic";
}

TEST(SnowMaterial, DegenerateDeformationMapsToRotationAndBounds) {
  expectDegenerateMappedSanely<double>();
  expectDegenerateMappedSanely<float>();
}

// The 3x3 SVD on what snow meets: near rotations (nearly equal singular values), stretches,
// reflections and a rank-one matrix. U and V are rotations, the product rebuilds F, and the
// singular values match Eigen's JacobiSVD up to the sign of the last.
TEST(SnowMaterial, ThreeByThreeSvdReconstructs) {
  std::mt19937 random(7);
  std::normal_distribution<double> noise(0, 1);
  auto randomMatrix = [&](double scale) {
    Mat<3> M;
    for (int i = 0; i < 9; ++i) M(i / 3, i % 3) = scale * noise(random);
    return M;
  };
  std::vector<Mat<3>> cases;
  for (int k = 0; k < 200; ++k) {
    const Eigen::Quaterniond q(noise(random), noise(random), noise(random), noise(random));
    const Mat<3> R = q.normalized().toRotationMatrix();
    cases.push_back(R * (Mat<3>::Identity() + randomMatrix(1e-9)));  // near a rotation
    cases.push_back(R * (Mat<3>::Identity() + randomMatrix(0.02)));  // plastic-range strain
    cases.push_back(randomMatrix(1));                                // anything
  }
  cases.push_back(Vec<3>(1, 2, 3) * Vec<3>(0.5, -1, 2).transpose());  // rank one
  cases.push_back(Mat<3>::Identity());
  auto check = [](const Mat<3>& F, const Mat<3>& U, const Vec<3>& s, const Mat<3>& V) {
    const double scale = std::max(1.0, F.norm());
    EXPECT_LT((U * s.asDiagonal() * V.transpose() - F).norm(), 1e-12 * scale) << F;
    EXPECT_LT((U.transpose() * U - Mat<3>::Identity()).norm(), 1e-12) << F;
    EXPECT_LT((V.transpose() * V - Mat<3>::Identity()).norm(), 1e-12) << F;
    EXPECT_NEAR(U.determinant(), 1, 1e-12);
    EXPECT_NEAR(V.determinant(), 1, 1e-12);
    const Vec<3> reference = Eigen::JacobiSVD<Mat<3>>(F).singularValues();
    EXPECT_LT((s.cwiseAbs() - reference).norm(), 1e-10 * scale) << F;
  };
  for (const Mat<3>& F : cases) {
    Mat<3> U, V;
    Vec<3> s;
    signedSvd<3>(F, U, s, V);
    check(F, U, s, V);
  }
}
