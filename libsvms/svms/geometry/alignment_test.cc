#include "svms/geometry/alignment.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "svms/base/random_draws.h"
#include "svms/geometry/so3.h"

namespace svms {
namespace {

TEST(NearestRotation, IsTheRotationClosestToAMatrix) {
  const Eigen::Matrix3d Q = Exp(Eigen::Vector3d(0.3, -1.1, 0.6));
  EXPECT_LT((NearestRotation(Q) - Q).norm(), 1e-15);
  EXPECT_LT((NearestRotation(2.5 * Q) - Q).norm(), 1e-15);  // scale does not matter
  // A rotation plus a small non-orthogonal part: the nearest rotation is within that part and
  // closer to the matrix than the rotation it was made from.
  Eigen::Matrix3d E;
  E << 0.01, -0.02, 0.005, 0.0, 0.015, -0.01, 0.02, 0.0, -0.01;
  const Eigen::Matrix3d R = NearestRotation(Q + E);
  EXPECT_NEAR(R.determinant(), 1, 1e-14);
  EXPECT_LT((R.transpose() * R - Eigen::Matrix3d::Identity()).norm(), 1e-14);
  EXPECT_LT((R - Q).norm(), E.norm());
  EXPECT_LE((R - (Q + E)).norm(), (Q - (Q + E)).norm());
  // A reflection's nearest rotation is proper.
  const Eigen::Matrix3d mirror = Eigen::Vector3d(1, 1, -1).asDiagonal();
  EXPECT_NEAR(NearestRotation(mirror * Q).determinant(), 1, 1e-14);
}

// Nearly planar directions mirrored through their plane: the best orthogonal matrix is that
// mirror, a reflection; the best rotation is close to the identity.
TEST(FitRotation, NeverReturnsAReflection) {
  std::vector<Eigen::Vector3d> from, to;
  for (int k = 0; k < 20; ++k) {
    const double a = 0.3 * k;
    from.push_back(Eigen::Vector3d(std::cos(a), std::sin(a), 0.01 * ((k % 3) - 1)).normalized());
    to.push_back(Eigen::Vector3d(from.back().x(), from.back().y(), -from.back().z()));
  }
  const Eigen::Matrix3d R = FitRotation(from, to);
  EXPECT_NEAR(R.determinant(), 1, 1e-12);
  EXPECT_LT((R.transpose() * R - Eigen::Matrix3d::Identity()).norm(), 1e-12);
  EXPECT_LT(AngleBetweenRad(R, Eigen::Matrix3d::Identity()), 0.05);
  // A known rotation is recovered exactly; mismatched inputs give the identity.
  const Eigen::Matrix3d Q =
      Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, -2, 0.5).normalized()).toRotationMatrix();
  std::vector<Eigen::Vector3d> rotated;
  for (const Eigen::Vector3d& v : from) rotated.push_back(Q * v);
  EXPECT_LT((FitRotation(from, rotated) - Q).norm(), 1e-12);
  EXPECT_EQ(FitRotation(from, {}), Eigen::Matrix3d::Identity());
}

// The rotation is about the origin: points shifted off it are not centred first.
TEST(FitRotation, DoesNotCentre) {
  const Eigen::Matrix3d Q = Exp(Eigen::Vector3d(0, 0, 0.4));
  std::vector<Eigen::Vector3d> from, to;
  for (int k = 0; k < 8; ++k) {
    from.push_back(Eigen::Vector3d(std::cos(k), std::sin(k), 0.3 * (k % 2)));
    to.push_back(Q * from.back());
  }
  EXPECT_LT((FitRotation(from, to) - Q).norm(), 1e-14);
  // Shifting both sets by the same vector changes the rotation about the origin.
  for (auto* v : {&from, &to})
    for (Eigen::Vector3d& p : *v) p += Eigen::Vector3d(5, 0, 0);
  EXPECT_GT(AngleBetweenRad(FitRotation(from, to), Q), 0.1);
}

TEST(FitRigidTransform, RecoversAKnownTransform) {
  const Pose b_from_a{Eigen::Vector3d(0.2, -0.9, 1.4), Eigen::Vector3d(0.5, -1.5, 3.0)};
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-0.5, 0.5);
  std::normal_distribution<double> noise(0, 1e-3);
  const int n = 200;
  std::vector<Eigen::Vector3d> in_a, in_b, noisy_b;
  for (int k = 0; k < n; ++k) {
    in_a.push_back(DrawVector3(u, rng));
    in_b.push_back(b_from_a * in_a.back());
    noisy_b.push_back(in_b.back() + DrawVector3(noise, rng));
  }
  // Exact points: exact to rounding.
  const Pose exact = FitRigidTransform(in_a, in_b);
  EXPECT_LT(AngleBetweenRad(exact, b_from_a), 1e-14);
  EXPECT_LT((exact.tvec - b_from_a.tvec).norm(), 1e-14);
  // 1 mm noise on 200 points spread over a 1 m cube (RMS 0.29 m from the centroid per axis):
  // rotation sigma about 1e-3 / (0.29 * sqrt(2 * 200)) = 1.7e-4 rad per axis, translation
  // sigma 1e-3 / sqrt(200) = 7.1e-5 m per axis (a's origin is near the points' centroid, so the
  // rotation's error adds little). Measured: 4.4e-4 rad, 1.5e-4 m.
  const Pose fit = FitRigidTransform(in_a, noisy_b);
  EXPECT_LT(AngleBetweenRad(fit, b_from_a), 5 * std::sqrt(3.0) * 1.7e-4);
  EXPECT_LT((fit.tvec - b_from_a.tvec).norm(), 5 * std::sqrt(3.0) * 7.1e-5);
  EXPECT_GT(AngleBetweenRad(fit, b_from_a), 0);
  // The fit leaves a smaller residual than the truth does (it is the least-squares optimum).
  double ss_fit = 0, ss_truth = 0;
  for (int k = 0; k < n; ++k) {
    ss_fit += (fit * in_a[k] - noisy_b[k]).squaredNorm();
    ss_truth += (b_from_a * in_a[k] - noisy_b[k]).squaredNorm();
  }
  EXPECT_LT(ss_fit, ss_truth);
  // The matrix form gives the same.
  Eigen::Matrix3Xd A(3, n), B(3, n);
  for (int k = 0; k < n; ++k) A.col(k) = in_a[k], B.col(k) = noisy_b[k];
  const Pose same = FitRigidTransform(A, B);
  EXPECT_EQ(same.rvec, fit.rvec);
  EXPECT_EQ(same.tvec, fit.tvec);
}

// Points in a plane (as control points on a board): the rotation is still proper and exact.
TEST(FitRigidTransform, PlanarPointsGiveAProperRotation) {
  const Pose b_from_a{Eigen::Vector3d(2.9, 0.3, -0.2), Eigen::Vector3d(-0.1, 0.2, 0.05)};
  std::vector<Eigen::Vector3d> in_a, in_b;
  for (const Eigen::Vector3d& p : {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(0.3, 0, 0),
                                   Eigen::Vector3d(0, 0.2, 0), Eigen::Vector3d(0.3, 0.2, 0)}) {
    in_a.push_back(p);
    in_b.push_back(b_from_a * p);
  }
  const Pose fit = FitRigidTransform(in_a, in_b);
  EXPECT_NEAR(fit.Rotation().determinant(), 1, 1e-14);
  EXPECT_LT(AngleBetweenRad(fit, b_from_a), 1e-13);
  EXPECT_LT((fit.tvec - b_from_a.tvec).norm(), 1e-14);
  EXPECT_EQ(FitRigidTransform(in_a, {}).rvec, Eigen::Vector3d::Zero());
}

}  // namespace
}  // namespace svms
