// Rigid transforms named by the frames they connect: `a_from_b` maps points of frame b into
// frame a (p_a = R p_b + t). Metres and radians. See docs/conventions.md.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace svms {

struct Pose {
  Eigen::Vector3d rvec = Eigen::Vector3d::Zero();  // rotation vector (axis * angle, radians)
  Eigen::Vector3d tvec = Eigen::Vector3d::Zero();  // translation, metres

  Eigen::Matrix3d Rotation() const {
    const double angle = rvec.norm();
    if (angle < 1e-300) return Eigen::Matrix3d::Identity();
    return Eigen::AngleAxisd(angle, rvec / angle).toRotationMatrix();
  }
  static Pose FromRotation(const Eigen::Matrix3d& R, const Eigen::Vector3d& t) {
    const Eigen::AngleAxisd aa(R);
    return Pose{aa.axis() * aa.angle(), t};
  }
  Eigen::Vector3d operator*(const Eigen::Vector3d& p) const { return Rotation() * p + tvec; }
  // (a_from_b * b_from_c) = a_from_c
  Pose operator*(const Pose& other) const {
    const Eigen::Matrix3d R = Rotation();
    return FromRotation(R * other.Rotation(), R * other.tvec + tvec);
  }
  Pose Inverse() const {
    const Eigen::Matrix3d Rt = Rotation().transpose();
    return FromRotation(Rt, -Rt * tvec);
  }
};

// A 6x6 covariance of a pose, ordered [rotation(3), translation(3)]; the rotation part is a
// small angle about the axes of the frame named first in the pose (a for a_from_b).
using PoseCovariance = Eigen::Matrix<double, 6, 6>;

}  // namespace svms
