#include "svms/bundle/cost_functions.h"

#include <ceres/dynamic_autodiff_cost_function.h>

#include <algorithm>
#include <array>

namespace svms {

MarkerPointCost::MarkerPointCost(const CameraModel* camera, const Eigen::Vector3d& point_in_marker,
                                 const Eigen::Vector2d* tip_xy, const Eigen::Vector2d& observed_px,
                                 double sigma_px, bool refine_intrinsics)
    : camera_(camera),
      point_in_marker_(point_in_marker),
      tip_xy_(tip_xy),
      observed_px_(observed_px),
      sigma_px_(sigma_px),
      refine_intrinsics_(refine_intrinsics) {
  set_num_residuals(2);
  std::vector<int32_t>* sizes = mutable_parameter_block_sizes();
  sizes->push_back(6);
  sizes->push_back(6);
  if (tip_xy_) sizes->push_back(1);
  if (refine_intrinsics_) sizes->push_back(static_cast<int32_t>(camera_->intrinsics().size()));
}

MarkerPointCost* MarkerPointCost::CreateCorner(const CameraModel* camera,
                                               const Eigen::Vector3d& point_in_marker,
                                               const Eigen::Vector2d& observed_px, double sigma_px,
                                               bool refine_intrinsics) {
  return new MarkerPointCost(camera, point_in_marker, nullptr, observed_px, sigma_px,
                             refine_intrinsics);
}

MarkerPointCost* MarkerPointCost::CreateTip(const CameraModel* camera,
                                            const Eigen::Vector2d* tip_xy,
                                            const Eigen::Vector2d& observed_px, double sigma_px,
                                            bool refine_intrinsics) {
  return new MarkerPointCost(camera, Eigen::Vector3d::Zero(), tip_xy, observed_px, sigma_px,
                             refine_intrinsics);
}

bool MarkerPointCost::Evaluate(double const* const* parameters, double* residuals,
                               double** jacobians) const {
  const int n_intrinsics = static_cast<int>(camera_->intrinsics().size());
  const double* cam_from_object = parameters[0];
  const double* object_from_marker = parameters[1];
  const double* post_height = tip_xy_ ? parameters[2] : nullptr;
  const double* intrinsics = refine_intrinsics_ ? parameters[tip_xy_ ? 3 : 2] : nullptr;

  // Project through the intrinsics being evaluated. In the survey an EvaluationCallback keeps
  // *camera_ in step with the intrinsics block, so the copy below happens only when the cost
  // is evaluated on its own (GradientChecker).
  const CameraModel* camera = camera_;
  CameraModel local;
  if (intrinsics &&
      !std::equal(intrinsics, intrinsics + n_intrinsics, camera_->intrinsics().begin())) {
    if (!CameraModel::Create(camera_->lensmodel(),
                             std::vector<double>(intrinsics, intrinsics + n_intrinsics),
                             camera_->width(), camera_->height(), &local))
      return false;
    camera = &local;
  }

  // The point in the camera frame and its Jacobian with respect to [cam(6), marker(6), h(1)].
  using Jet = ceres::Jet<double, 13>;
  Jet cam[6], marker[6], p_marker[3], p_object[3], p_cam[3];
  for (int i = 0; i < 6; ++i) {
    cam[i] = Jet(cam_from_object[i], i);
    marker[i] = Jet(object_from_marker[i], 6 + i);
  }
  if (tip_xy_) {
    p_marker[0] = Jet(tip_xy_->x());
    p_marker[1] = Jet(tip_xy_->y());
    p_marker[2] = Jet(post_height[0], 12);
  } else {
    for (int i = 0; i < 3; ++i) p_marker[i] = Jet(point_in_marker_[i]);
  }
  TransformPoint(marker, p_marker, p_object);
  TransformPoint(cam, p_object, p_cam);
  const Eigen::Vector3d p(p_cam[0].a, p_cam[1].a, p_cam[2].a);

  Eigen::Vector2d px;
  Eigen::Matrix<double, 2, 3> dpx_dp;
  Eigen::Matrix<double, 2, Eigen::Dynamic> dpx_dintrinsics;
  const bool want_intrinsics = jacobians && intrinsics && jacobians[tip_xy_ ? 3 : 2];
  if (!camera->Project(p, &px, jacobians ? &dpx_dp : nullptr,
                       want_intrinsics ? &dpx_dintrinsics : nullptr))
    return false;
  residuals[0] = (px.x() - observed_px_.x()) / sigma_px_;
  residuals[1] = (px.y() - observed_px_.y()) / sigma_px_;
  if (!jacobians) return true;

  Eigen::Matrix<double, 3, 13> dp_dparams;
  for (int r = 0; r < 3; ++r) dp_dparams.row(r) = p_cam[r].v.transpose();
  const Eigen::Matrix<double, 2, 13> J = dpx_dp * dp_dparams / sigma_px_;
  using Block6 = Eigen::Matrix<double, 2, 6, Eigen::RowMajor>;
  if (jacobians[0]) {
    Eigen::Map<Block6> d_cam(jacobians[0]);
    d_cam = J.leftCols<6>();
  }
  if (jacobians[1]) {
    Eigen::Map<Block6> d_marker(jacobians[1]);
    d_marker = J.middleCols<6>(6);
  }
  if (tip_xy_ && jacobians[2]) {
    jacobians[2][0] = J(0, 12);
    jacobians[2][1] = J(1, 12);
  }
  if (want_intrinsics) {
    Eigen::Map<Eigen::Matrix<double, 2, Eigen::Dynamic, Eigen::RowMajor>> d_intrinsics(
        jacobians[tip_xy_ ? 3 : 2], 2, n_intrinsics);
    d_intrinsics = dpx_dintrinsics / sigma_px_;
  }
  return true;
}

RigMarkerPointCost::RigMarkerPointCost(MarkerPointCost* point) : point_(point) {
  set_num_residuals(2);
  std::vector<int32_t>* sizes = mutable_parameter_block_sizes();
  sizes->push_back(6);
  const std::vector<int32_t>& inner = point_->parameter_block_sizes();
  sizes->insert(sizes->end(), inner.begin(), inner.end());
}

bool RigMarkerPointCost::Evaluate(double const* const* parameters, double* residuals,
                                  double** jacobians) const {
  const size_t n_inner = point_->parameter_block_sizes().size();
  // cam_from_object and its Jacobian with respect to [rig_from_object(6), rig_from_cam(6)].
  using Jet = ceres::Jet<double, 12>;
  Jet ro[6], rc[6], co[6];
  for (int i = 0; i < 6; ++i) {
    ro[i] = Jet(parameters[0][i], i);
    rc[i] = Jet(parameters[1][i], 6 + i);
  }
  CamFromObjectOnRig(ro, rc, co);
  double cam_from_object[6];
  for (int i = 0; i < 6; ++i) cam_from_object[i] = co[i].a;
  // The wrapped cost's blocks: cam_from_object, then this cost's blocks from the third on.
  std::array<const double*, 4> inner_params{};
  std::array<double*, 4> inner_jacobians{};
  inner_params[0] = cam_from_object;
  for (size_t b = 1; b < n_inner; ++b) inner_params[b] = parameters[b + 1];
  const bool pose_jacobian = jacobians && (jacobians[0] || jacobians[1]);
  Eigen::Matrix<double, 2, 6, Eigen::RowMajor> d_cam;
  if (jacobians) {
    inner_jacobians[0] = pose_jacobian ? d_cam.data() : nullptr;
    for (size_t b = 1; b < n_inner; ++b) inner_jacobians[b] = jacobians[b + 1];
  }
  if (!point_->Evaluate(inner_params.data(), residuals,
                        jacobians ? inner_jacobians.data() : nullptr))
    return false;
  if (!pose_jacobian) return true;
  Eigen::Matrix<double, 6, 12> dco;
  for (int r = 0; r < 6; ++r) dco.row(r) = co[r].v.transpose();
  using Block6 = Eigen::Matrix<double, 2, 6, Eigen::RowMajor>;
  if (jacobians[0]) {
    Eigen::Map<Block6> d_rig_from_object(jacobians[0]);
    d_rig_from_object = d_cam * dco.leftCols<6>();
  }
  if (jacobians[1]) {
    Eigen::Map<Block6> d_rig_from_cam(jacobians[1]);
    d_rig_from_cam = d_cam * dco.rightCols<6>();
  }
  return true;
}

ceres::CostFunction* ScaleBarCost::Create(const ScaleBar& bar, const Eigen::Vector3d& a_in_marker,
                                          const Eigen::Vector3d& b_in_marker) {
  auto* cost = new ceres::DynamicAutoDiffCostFunction<ScaleBarCost, 7>(
      new ScaleBarCost(bar, a_in_marker, b_in_marker));
  cost->AddParameterBlock(6);
  if (bar.a.kind == NamedPoint::Kind::kTip) cost->AddParameterBlock(1);
  cost->AddParameterBlock(6);
  if (bar.b.kind == NamedPoint::Kind::kTip) cost->AddParameterBlock(1);
  cost->SetNumResiduals(1);
  return cost;
}

ceres::CostFunction* ControlPointCost::Create(const ControlPoint& cp,
                                              const Eigen::Vector3d& in_marker) {
  auto* cost = new ceres::DynamicAutoDiffCostFunction<ControlPointCost, 7>(
      new ControlPointCost(cp, in_marker));
  cost->AddParameterBlock(6);
  if (cp.point.kind == NamedPoint::Kind::kTip) cost->AddParameterBlock(1);
  cost->SetNumResiduals(3);
  return cost;
}

}  // namespace svms
