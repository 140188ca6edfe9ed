#include "svms/geometry/so3.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "svms/geometry/pose.h"

namespace svms {
namespace {

std::vector<Eigen::Vector3d> RotationVectors() {
  return {Eigen::Vector3d(0.3, -0.2, 0.1), Eigen::Vector3d(2.5, 1.0, -0.5),
          Eigen::Vector3d(1e-9, 0, -2e-9), Eigen::Vector3d(0, 0, 0),
          Eigen::Vector3d(0, 3.1, 0),      Eigen::Vector3d(-1.2, 0.4, 2.2)};
}

TEST(So3, SkewIsTheCrossProduct) {
  const Eigen::Vector3d a(0.3, -1.7, 2.2), b(-0.4, 0.9, 1.3);
  EXPECT_LT((Skew(a) * b - a.cross(b)).norm(), 1e-15);
  EXPECT_EQ((Skew(a) + Skew(a).transpose()).norm(), 0);
}

TEST(So3, ExpIsRodriguesAndLogItsInverse) {
  for (const Eigen::Vector3d& w : RotationVectors()) {
    const Eigen::Matrix3d R = Exp(w);
    EXPECT_LT((R.transpose() * R - Eigen::Matrix3d::Identity()).norm(), 1e-15) << w.transpose();
    EXPECT_NEAR(R.determinant(), 1, 1e-15);
    // Rodrigues: I + sin(t)/t K + (1 - cos(t))/t^2 K^2.
    const double t = w.norm();
    const Eigen::Matrix3d K = Skew(w);
    const Eigen::Matrix3d rodrigues =
        t == 0 ? Eigen::Matrix3d::Identity()
               : Eigen::Matrix3d(Eigen::Matrix3d::Identity() + std::sin(t) / t * K +
                                 (1 - std::cos(t)) / (t * t) * K * K);
    EXPECT_LT((R - rodrigues).norm(), 1e-15) << w.transpose();
    // Round trips: Log(Exp(w)) = w for angles below pi, Exp(Log(R)) = R.
    EXPECT_LT((Log(R) - w).norm(), 1e-14) << w.transpose();
    EXPECT_LT((Exp(Log(R)) - R).norm(), 1e-15) << w.transpose();
  }
  // A half turn: the axis' sign is free, the rotation is not.
  const Eigen::Matrix3d half = Exp(Eigen::Vector3d(0, 0, M_PI));
  EXPECT_NEAR(Log(half).norm(), M_PI, 1e-12);
  EXPECT_LT((Exp(Log(half)) - half).norm(), 1e-12);
}

TEST(So3, LeftJacobianMapsRotationVectorIncrementsToLeftAngles) {
  for (const Eigen::Vector3d& w : RotationVectors()) {
    const Eigen::Vector3d d(1e-6, -2e-6, 1.5e-6);
    // Exp(w + d) Exp(w)^T = Exp(J d) to first order in d.
    const Eigen::Vector3d got = Log(Exp(w + d) * Exp(w).transpose());
    EXPECT_LT((got - LeftJacobian(w) * d).norm(), 1e-11) << w.transpose();
  }
}

TEST(So3, AngleBetweenRotations) {
  const Eigen::Matrix3d a = Exp(Eigen::Vector3d(0.4, -0.3, 1.1));
  for (double angle : {0.0, 1e-9, 1e-4, 0.3, 2.0, 3.1}) {
    const Eigen::Vector3d axis = Eigen::Vector3d(1, 2, -0.5).normalized();
    // Either side of a, in either order: the same angle.
    const Eigen::Matrix3d b = a * Exp(angle * axis), c = Exp(angle * axis) * a;
    EXPECT_NEAR(AngleBetweenRad(a, b), angle, 1e-15 + 1e-14 * angle);
    EXPECT_NEAR(AngleBetweenRad(b, a), angle, 1e-15 + 1e-14 * angle);
    EXPECT_NEAR(AngleBetweenRad(c, a), angle, 1e-15 + 1e-14 * angle);
    EXPECT_NEAR(AngleBetweenDeg(a, b), angle * 180 / M_PI, 1e-12);
    const Pose pa{Log(a), Eigen::Vector3d(1, 2, 3)}, pb{Log(b), Eigen::Vector3d::Zero()};
    EXPECT_NEAR(AngleBetweenRad(pa, pb), angle, 1e-14);
    EXPECT_NEAR(AngleBetweenDeg(pa, pb), angle * 180 / M_PI, 1e-12);
  }
  EXPECT_NEAR(AngleBetweenDeg(Eigen::Matrix3d::Identity(), Exp(Eigen::Vector3d(0, M_PI, 0))), 180,
              1e-12);
}

// The quaternions' angle is AngleBetweenRad's, to the arccosine's precision, for either sign of
// either quaternion; near a half turn too, where Eigen gives neighbouring rotations quaternions
// of opposite sign.
TEST(So3, AngleBetweenUnitQuaternionsIsTheAngleBetweenRotations) {
  const Eigen::Matrix3d a = Exp(Eigen::Vector3d(0.4, -0.3, 1.1));
  const Eigen::Vector3d axis = Eigen::Vector3d(1, 2, -0.5).normalized();
  for (double angle : {1e-3, 0.05, 0.3, 2.0, 3.1, M_PI - 1e-4}) {
    const Eigen::Matrix3d b = a * Exp(angle * axis);
    const Eigen::Quaterniond qa(a), qb(b);
    for (double sign : {1.0, -1.0}) {
      const Eigen::Quaterniond qs(sign * qb.coeffs());
      EXPECT_NEAR(AngleBetweenUnitQuaternionsRad(qa, qs), AngleBetweenRad(a, b), 1e-7) << angle;
    }
  }
  // Two rotations about 3e-3 rad apart, each nearly a half turn about (1, -1, 0): Eigen picks the
  // quaternion whose largest component is positive, x for one and y for the other.
  const Eigen::Vector3d half = Eigen::Vector3d(1, -1, 0).normalized();
  const Eigen::Matrix3d c = Exp((M_PI - 1e-3) * (half + Eigen::Vector3d(1e-3, 0, 0)).normalized());
  const Eigen::Matrix3d d = Exp((M_PI - 1e-3) * (half + Eigen::Vector3d(0, -1e-3, 0)).normalized());
  const Eigen::Quaterniond qc(c), qd(d);
  ASSERT_LT(qc.coeffs().dot(qd.coeffs()), 0);  // the case this checks
  EXPECT_NEAR(AngleBetweenUnitQuaternionsRad(qc, qd), AngleBetweenRad(c, d), 1e-7);
  EXPECT_LT(AngleBetweenRad(c, d), 4e-3);
}

TEST(So3, PoseUsesExpAndLog) {
  const Pose p{Eigen::Vector3d(0.2, -0.5, 0.7), Eigen::Vector3d(0.1, 0.2, 0.3)};
  EXPECT_EQ(p.Rotation(), Exp(p.rvec));
  const Pose q = Pose::FromRotation(p.Rotation(), p.tvec);
  EXPECT_LT((q.rvec - p.rvec).norm(), 1e-15);
  EXPECT_LT(AngleBetweenRad(p * p.Inverse(), Pose()), 1e-15);
}

}  // namespace
}  // namespace svms
