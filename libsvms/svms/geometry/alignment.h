// Best-fit rotations and rigid transforms between corresponding 3D points (Kabsch; Umeyama's
// method without scale), and the rotation nearest to a 3x3 matrix.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <vector>

#include "svms/geometry/pose.h"

namespace svms {

// The proper rotation (det +1) nearest to `M` in the Frobenius norm, i.e. the R maximising
// trace(R^T M): U diag(1, 1, sign det(U V^T)) V^T for the SVD M = U S V^T. Projects a sum of
// rotations onto SO(3) (their chordal mean), and is the core of FitRotation.
inline Eigen::Matrix3d NearestRotation(const Eigen::Matrix3d& M) {
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0) D(2, 2) = -1;
  return svd.matrixU() * D * svd.matrixV().transpose();
}

// The rotation R minimising sum_k |R from[k] - to[k]|^2 about the origin (no centring, no
// translation, no scale; e.g. directions from one centre): a proper rotation (det +1) even where
// the best orthogonal matrix would be a reflection. Fewer than 2 pairs, or sizes that differ,
// give the identity.
inline Eigen::Matrix3d FitRotation(const std::vector<Eigen::Vector3d>& from,
                                   const std::vector<Eigen::Vector3d>& to) {
  if (from.size() < 2 || from.size() != to.size()) return Eigen::Matrix3d::Identity();
  Eigen::Matrix3d cross = Eigen::Matrix3d::Zero();
  for (size_t k = 0; k < from.size(); ++k) cross += to[k] * from[k].transpose();
  return NearestRotation(cross);
}

// The rigid transform b_from_a minimising sum_k |b_from_a * in_a.col(k) - in_b.col(k)|^2
// (Kabsch-Umeyama without scale, Eigen::umeyama): the rotation is proper (det +1), the
// translation maps the centroid of in_a onto that of in_b. Unique when the points of in_a are
// not all on one line (3 or more). Empty sets, or sets of different sizes, give the identity.
inline Pose FitRigidTransform(const Eigen::Matrix3Xd& in_a, const Eigen::Matrix3Xd& in_b) {
  if (in_a.cols() == 0 || in_a.cols() != in_b.cols()) return Pose();
  const Eigen::Matrix4d b_from_a = Eigen::umeyama(in_a, in_b, false);
  return Pose::FromRotation(b_from_a.topLeftCorner<3, 3>(), b_from_a.topRightCorner<3, 1>());
}
inline Pose FitRigidTransform(const std::vector<Eigen::Vector3d>& in_a,
                              const std::vector<Eigen::Vector3d>& in_b) {
  if (in_a.empty() || in_a.size() != in_b.size()) return Pose();
  Eigen::Matrix3Xd a(3, in_a.size()), b(3, in_b.size());
  for (size_t k = 0; k < in_a.size(); ++k) {
    a.col(k) = in_a[k];
    b.col(k) = in_b[k];
  }
  return FitRigidTransform(a, b);
}

}  // namespace svms
