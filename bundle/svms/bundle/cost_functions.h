// The survey's Ceres cost functions. Parameter blocks (all double arrays):
//   cam_from_object[6]     rotation vector (radians) then translation (metres), one per image
//   object_from_marker[6]  same layout, one per marker
//   post_height[1]         metres, one per post (z of the tip in its marker's frame)
//   intrinsics[N]          mrcal's intrinsics of the camera, when refined
// Residuals are divided by their standard deviation (unitless), so that a robust loss and the
// a-posteriori variance factor 2 cost / (m - n) read in sigmas.
#pragma once

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <Eigen/Core>
#include <memory>
#include <vector>

#include "svms/bundle/survey_options.h"
#include "svms/camera/camera.h"

namespace svms {

// p_out = pose * p for a pose block [rvec(3), tvec(3)].
template <typename T>
void TransformPoint(const T* pose, const T* p, T* p_out) {
  ceres::AngleAxisRotatePoint(pose, p, p_out);
  p_out[0] += pose[3];
  p_out[1] += pose[4];
  p_out[2] += pose[5];
}

// The pixel of a marker point (a black-square corner, or the post tip) in one image.
//
// Why an analytic CostFunction and not a templated functor: the lens is mrcal's (any model:
// OpenCV8, splined, ...), whose C projection cannot be evaluated on Ceres Jets. mrcal_project
// does give analytic gradients with respect to the point and the intrinsics
// (CameraModel::Project), so this class computes the point in the camera frame and its
// Jacobian with respect to the pose blocks with Jets (a templated transform, exact), and
// chains them with mrcal's. The alternative, undistorting the detections to normalised
// coordinates once, would move the residuals out of the pixels where the detector's noise is
// stated (the noise becomes position-dependent and correlated), and could not refine the
// intrinsics; this way the residual stays in pixels and every lens model works unchanged.
//
// Parameter blocks, in order: cam_from_object[6], object_from_marker[6], then post_height[1]
// for a tip, then intrinsics[N] when `refine_intrinsics`. The point in the marker frame is
// `point_in_marker` for a corner; for a tip it is (tip_xy->x(), tip_xy->y(), post_height),
// where *tip_xy (owned by the caller, read at every evaluation) is the lateral offset of the
// visible part of a concave well's bottom (0 for a post). Residual: (projection - observed)
// / sigma_px, 2 values. Evaluate returns false when the point does not project (behind the
// camera), so that Ceres rejects the step.
class MarkerPointCost : public ceres::CostFunction {
 public:
  static MarkerPointCost* CreateCorner(const CameraModel* camera,
                                       const Eigen::Vector3d& point_in_marker,
                                       const Eigen::Vector2d& observed_px, double sigma_px,
                                       bool refine_intrinsics);
  static MarkerPointCost* CreateTip(const CameraModel* camera, const Eigen::Vector2d* tip_xy,
                                    const Eigen::Vector2d& observed_px, double sigma_px,
                                    bool refine_intrinsics);

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

  bool is_tip() const { return tip_xy_ != nullptr; }

 private:
  MarkerPointCost(const CameraModel* camera, const Eigen::Vector3d& point_in_marker,
                  const Eigen::Vector2d* tip_xy, const Eigen::Vector2d& observed_px,
                  double sigma_px, bool refine_intrinsics);

  const CameraModel* camera_;  // not owned; outlives the cost
  Eigen::Vector3d point_in_marker_;
  const Eigen::Vector2d* tip_xy_;  // not owned; nullptr for a corner
  Eigen::Vector2d observed_px_;
  double sigma_px_;
  bool refine_intrinsics_;
};

// cam_from_object of a camera on a rig: inverse(rig_from_cam) * rig_from_object, all three pose
// blocks [rvec(3), tvec(3)] (radians, metres). Templated, so that Jets give its Jacobian.
template <typename T>
void CamFromObjectOnRig(const T* rig_from_object, const T* rig_from_cam, T* cam_from_object) {
  T q_ro[4], q_rc[4], q_cr[4], q_co[4];
  ceres::AngleAxisToQuaternion(rig_from_object, q_ro);
  ceres::AngleAxisToQuaternion(rig_from_cam, q_rc);
  q_cr[0] = q_rc[0];
  for (int i = 1; i < 4; ++i) q_cr[i] = -q_rc[i];
  ceres::QuaternionProduct(q_cr, q_ro, q_co);
  ceres::QuaternionToAngleAxis(q_co, cam_from_object);
  // t_co = R_cr (t_ro - t_rc)
  const T d[3] = {rig_from_object[3] - rig_from_cam[3], rig_from_object[4] - rig_from_cam[4],
                  rig_from_object[5] - rig_from_cam[5]};
  ceres::UnitQuaternionRotatePoint(q_cr, d, cam_from_object + 3);
}

// A MarkerPointCost seen by a camera of a rig (the rig survey): its cam_from_object block is
// replaced by two, rig_from_object[6] and rig_from_cam[6], composed by CamFromObjectOnRig; the
// blocks after it are MarkerPointCost's own (object_from_marker[6], [post_height[1]],
// [intrinsics[N]]). The residual, its sigma and every other Jacobian are the wrapped cost's:
// one projection model for the survey and the rig survey. Owns `point`.
class RigMarkerPointCost : public ceres::CostFunction {
 public:
  explicit RigMarkerPointCost(MarkerPointCost* point);

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

  const MarkerPointCost& point() const { return *point_; }

 private:
  std::unique_ptr<MarkerPointCost> point_;
};

// A named point of the object, in the object frame: object_from_marker * point_in_marker,
// where point_in_marker is fixed, or the post tip (0, 0, h) with h the block `post_height`.
// `params` holds object_from_marker[6] then, for a tip, post_height[1].
template <typename T>
void NamedPointInObject(const NamedPoint& point, const Eigen::Vector3d& fixed_in_marker,
                        T const* const* params, T* p_object) {
  T p[3];
  if (point.kind == NamedPoint::Kind::kTip) {
    p[0] = T(0);
    p[1] = T(0);
    p[2] = params[1][0];
  } else {
    for (int i = 0; i < 3; ++i) p[i] = T(fixed_in_marker[i]);
  }
  TransformPoint(params[0], p, p_object);
}

// A measured distance between two named points on two different markers (a scale bar):
// residual (|a - b| - distance) / sigma. Blocks: object_from_marker_a[6], [post_height_a[1]
// for a tip], object_from_marker_b[6], [post_height_b[1]].
struct ScaleBarCost {
  ScaleBarCost(const ScaleBar& bar, const Eigen::Vector3d& a_in_marker,
               const Eigen::Vector3d& b_in_marker)
      : bar_(bar), a_(a_in_marker), b_(b_in_marker) {}

  template <typename T>
  bool operator()(T const* const* params, T* residual) const {
    const int na = bar_.a.kind == NamedPoint::Kind::kTip ? 2 : 1;
    T pa[3], pb[3];
    NamedPointInObject(bar_.a, a_, params, pa);
    NamedPointInObject(bar_.b, b_, params + na, pb);
    const T dx = pa[0] - pb[0], dy = pa[1] - pb[1], dz = pa[2] - pb[2];
    const T d = sqrt(dx * dx + dy * dy + dz * dz);
    residual[0] = (d - bar_.distance) / bar_.sigma;
    return true;
  }

  static ceres::CostFunction* Create(const ScaleBar& bar, const Eigen::Vector3d& a_in_marker,
                                     const Eigen::Vector3d& b_in_marker);

  ScaleBar bar_;
  Eigen::Vector3d a_, b_;
};

// A control point: residual (point_in_object(estimate) - known) / sigma, 3 values. Blocks:
// object_from_marker[6], [post_height[1] for a tip].
struct ControlPointCost {
  ControlPointCost(const ControlPoint& cp, const Eigen::Vector3d& in_marker)
      : cp_(cp), in_marker_(in_marker) {}

  template <typename T>
  bool operator()(T const* const* params, T* residual) const {
    T p[3];
    NamedPointInObject(cp_.point, in_marker_, params, p);
    for (int i = 0; i < 3; ++i) residual[i] = (p[i] - cp_.point_in_object[i]) / cp_.sigma;
    return true;
  }

  static ceres::CostFunction* Create(const ControlPoint& cp, const Eigen::Vector3d& in_marker);

  ControlPoint cp_;
  Eigen::Vector3d in_marker_;
};

// The drawing's post height as a prior: residual (h - drawn) / sigma, one value.
struct PostHeightPriorCost {
  PostHeightPriorCost(double drawn, double sigma) : drawn_(drawn), sigma_(sigma) {}
  template <typename T>
  bool operator()(const T* h, T* residual) const {
    residual[0] = (h[0] - drawn_) / sigma_;
    return true;
  }
  static ceres::CostFunction* Create(double drawn, double sigma) {
    return new ceres::AutoDiffCostFunction<PostHeightPriorCost, 1, 1>(
        new PostHeightPriorCost(drawn, sigma));
  }
  double drawn_, sigma_;
};

}  // namespace svms
