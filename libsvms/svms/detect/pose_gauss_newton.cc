#include "svms/detect/pose_gauss_newton.h"

#include "svms/geometry/pose_matrix.h"
#include "svms/geometry/so3.h"

namespace svms {

PoseStep PoseGaussNewtonStep(const Eigen::Matrix<double, 6, 6>& H,
                             const Eigen::Matrix<double, 6, 1>& g, const PoseStepTolerances& tol,
                             Eigen::Matrix3d* R, Eigen::Vector3d* t) {
  // An H that is not positive definite still gives its LDLT's step; a non-finite one fails below.
  Vector6d step;
  SolveLdlt(H, Vector6d(-g), &step);
  if (!step.allFinite()) return PoseStep::kFailed;
  const double angle = step.head<3>().norm();
  if (angle > tol.min_rotation) *R = Exp(step.head<3>()) * *R;
  *t += step.tail<3>();
  const bool small_step =
      step.head<3>().norm() < tol.step && step.tail<3>().norm() < tol.step * (1 + t->norm());
  const bool informed = tol.information > 0 && step.dot(H * step) < tol.information;
  return small_step || informed ? PoseStep::kConverged : PoseStep::kMoved;
}

}  // namespace svms
