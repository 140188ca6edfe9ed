// Rotations: 3x3 rotation matrices and rotation vectors (axis times angle, radians). The
// exponential and logarithm of SO(3), the cross-product matrix, the left Jacobian, and the
// angle between two rotations. Conventions: docs/conventions.md.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

namespace svms {

// The cross-product matrix [v]x: Skew(v) * u = v.cross(u).
inline Eigen::Matrix3d Skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

// The rotation matrix of the rotation vector `w` (axis times angle, radians; any length):
// exp([w]x). The identity for |w| < 1e-300.
inline Eigen::Matrix3d Exp(const Eigen::Vector3d& w) {
  const double angle = w.norm();
  if (angle < 1e-300) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, w / angle).toRotationMatrix();
}

// The rotation vector of the rotation matrix `R` (axis times angle, angle in [0, pi] radians):
// Exp(Log(R)) = R. For a half turn the axis' sign is arbitrary.
inline Eigen::Vector3d Log(const Eigen::Matrix3d& R) {
  const Eigen::AngleAxisd aa(R);
  return aa.axis() * aa.angle();
}

// The left Jacobian of SO(3) at the rotation vector `w`: d(left rotation increment) /
// d(rotation vector), so that Exp(w + d) ~ Exp(LeftJacobian(w) d) Exp(w) for small d. It turns
// a rotation-vector covariance into the small-angle one of the conventions
// (Sigma_angle = J Sigma_rvec J^T).
inline Eigen::Matrix3d LeftJacobian(const Eigen::Vector3d& w) {
  const double theta = w.norm();
  const Eigen::Matrix3d K = Skew(w);
  if (theta < 1e-8) return Eigen::Matrix3d::Identity() + 0.5 * K;
  const double t2 = theta * theta;
  return Eigen::Matrix3d::Identity() + (1 - std::cos(theta)) / t2 * K +
         (theta - std::sin(theta)) / (t2 * theta) * K * K;
}

// The angle of the rotation between two rotations, |Log(a^T b)|: radians in [0, pi], symmetric
// in a and b, accurate for small angles (no arccosine of the trace).
inline double AngleBetweenRad(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return Eigen::AngleAxisd(a.transpose() * b).angle();
}
// The same in degrees, [0, 180].
inline double AngleBetweenDeg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return AngleBetweenRad(a, b) * 180 / M_PI;
}

// The same angle from the two rotations' unit quaternions, 2 acos(|a . b|): radians in [0, pi],
// whatever either quaternion's sign. A 4-term dot product and one arccosine, for loops over
// many pairs (about 12 ns a pair, against 20 for Eigen's angularDistance); the arccosine loses
// precision below about 1e-7 rad, so use it where the angle is compared with larger thresholds.
inline double AngleBetweenUnitQuaternionsRad(const Eigen::Quaterniond& a,
                                             const Eigen::Quaterniond& b) {
  return 2 * std::acos(std::min(1.0, std::abs(a.coeffs().dot(b.coeffs()))));
}

}  // namespace svms
