// Rigid transforms named by the frames they connect: `a_from_b` maps points of frame b into
// frame a (p_a = R p_b + t). Metres and radians. See docs/conventions.md.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "svms/geometry/so3.h"

namespace svms {

struct Pose {
  Eigen::Vector3d rvec = Eigen::Vector3d::Zero();  // rotation vector (axis * angle, radians)
  Eigen::Vector3d tvec = Eigen::Vector3d::Zero();  // translation, metres

  Eigen::Matrix3d Rotation() const { return Exp(rvec); }
  static Pose FromRotation(const Eigen::Matrix3d& R, const Eigen::Vector3d& t) {
    return Pose{Log(R), t};
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

// The angle between two poses' rotations (AngleBetweenRad of their rotation matrices, so3.h):
// radians in [0, pi], or degrees in [0, 180]. The translations play no part.
inline double AngleBetweenRad(const Pose& a, const Pose& b) {
  return AngleBetweenRad(a.Rotation(), b.Rotation());
}
inline double AngleBetweenDeg(const Pose& a, const Pose& b) {
  return AngleBetweenDeg(a.Rotation(), b.Rotation());
}

}  // namespace svms
