// One Gauss-Newton step on a camera pose: the one implementation shared by the single-marker
// fit (RefinePose, marker_pose.h) and the fused object pose (SolveObjectPose,
// fusion/object_pose.h). What differs between the two is what they linearise (one marker's
// corners, tip and edges, each point weighted by its sigma; many markers' points, whitened by
// their full covariances and weighted robustly) and when they stop, which the caller passes
// in: each keeps its own tolerances.
//
// The pose is cam_from_x = (R, t). H = J^T W J (6x6) and g = J^T W r are the normal equations
// at (R, t) of residuals r (pixels), with J taken against a left perturbation in camera axes,
// ordered [rotation (radians), translation (metres)]: the step d = -H^-1 g moves the pose to
// R <- Exp(d_rot) R, t <- t + d_trans. Internal to SVMS (not installed).
#pragma once

#include <Eigen/Core>

namespace svms {

// When a pose Gauss-Newton stops, and which rotation steps it applies.
struct PoseStepTolerances {
  // Converged when the rotation step is below `step` (radians) and the translation step below
  // step * (1 + |t|) (metres: relative to the range)...
  double step = 1e-12;
  // ...or when the step's squared length under H, d^T H d, is below `information` (the step is
  // a fraction sqrt(information) of the pose's own standard deviation); 0: not used.
  double information = 0;
  // A rotation step of at most this angle (radians) is not applied: below 1e-15 it would move R
  // by rounding only. 0: every nonzero rotation step is applied.
  double min_rotation = 0;
};

enum class PoseStep {
  kMoved,      // the step was applied; not converged yet
  kConverged,  // the step was applied and met the tolerances
  kFailed,     // the step is not finite (H singular or r not finite): (R, t) untouched
};

// Solves H d = -g (LDLT of H, whose lower triangle is read), applies d to (*R, *t) and tests
// the tolerances on d and the moved t.
PoseStep PoseGaussNewtonStep(const Eigen::Matrix<double, 6, 6>& H,
                             const Eigen::Matrix<double, 6, 1>& g, const PoseStepTolerances& tol,
                             Eigen::Matrix3d* R, Eigen::Vector3d* t);

}  // namespace svms
