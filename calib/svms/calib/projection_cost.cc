#include "svms/calib/projection_cost.h"

#include <ceres/rotation.h>

#include <cmath>
#include <cstring>

extern "C" {
#include <mrcal/mrcal.h>
}

namespace svms {

static_assert(sizeof(mrcal_lensmodel_t) <= 64, "LensModel::storage_ too small");

std::shared_ptr<const LensModel> LensModel::Parse(const std::string& name) {
  mrcal_lensmodel_t m{};
  if (!mrcal_lensmodel_from_name(&m, name.c_str())) return nullptr;
  if (!mrcal_lensmodel_metadata(&m).has_gradients) return nullptr;
  auto lens = std::make_shared<LensModel>();
  std::memcpy(lens->storage_, &m, sizeof m);
  lens->num_params_ = mrcal_lensmodel_num_params(&m);
  lens->can_look_back_ = mrcal_lensmodel_metadata(&m).can_project_behind_camera;
  return lens;
}

bool LensModel::Project(const double* intrinsics, const Eigen::Vector3d& p_cam, Eigen::Vector2d* q,
                        double* dq_dp, double* dq_dintrinsics) const {
  if (!p_cam.allFinite()) return false;
  if (!can_look_back_ && !(p_cam.z() > 0)) return false;
  mrcal_lensmodel_t m;
  std::memcpy(&m, storage_, sizeof m);
  const mrcal_point3_t p = {{p_cam.x(), p_cam.y(), p_cam.z()}};
  mrcal_point2_t out;
  mrcal_point3_t grad[2];
  if (!mrcal_project(&out, dq_dp != nullptr ? grad : nullptr, dq_dintrinsics, &p, 1, &m,
                     intrinsics))
    return false;
  if (!std::isfinite(out.x) || !std::isfinite(out.y)) return false;
  *q = Eigen::Vector2d(out.x, out.y);
  if (dq_dp != nullptr) {
    for (int r = 0; r < 2; ++r)
      for (int c = 0; c < 3; ++c) dq_dp[3 * r + c] = grad[r].xyz[c];
  }
  return true;
}

ProjectionCost::ProjectionCost(std::shared_ptr<const LensModel> lens,
                               const Eigen::Vector3d& point_in_board,
                               const Eigen::Vector2d& observed_px, double weight, bool warp,
                               const BoardExtent& extent)
    : lens_(std::move(lens)),
      point_(point_in_board),
      observed_(observed_px),
      weight_(weight),
      warp_(warp),
      extent_(extent) {
  set_num_residuals(2);
  mutable_parameter_block_sizes()->push_back(lens_->num_params());
  mutable_parameter_block_sizes()->push_back(6);
  if (warp_) mutable_parameter_block_sizes()->push_back(2);
}

Eigen::Vector3d ProjectionCost::WarpedPoint(const Eigen::Vector3d& point_in_board,
                                            const double* warp, const BoardExtent& extent,
                                            Eigen::Vector3d* dp_dwarp0,
                                            Eigen::Vector3d* dp_dwarp1) {
  const Eigen::Vector2d r = extent.Scaled(point_in_board);
  const double a = 1 - r.x() * r.x(), b = 1 - r.y() * r.y();
  if (dp_dwarp0 != nullptr) *dp_dwarp0 = Eigen::Vector3d(0, 0, a);
  if (dp_dwarp1 != nullptr) *dp_dwarp1 = Eigen::Vector3d(0, 0, b);
  if (warp == nullptr) return point_in_board;
  return point_in_board + Eigen::Vector3d(0, 0, warp[0] * a + warp[1] * b);
}

bool ProjectionCost::Evaluate(double const* const* parameters, double* residuals,
                              double** jacobians) const {
  const double* intrinsics = parameters[0];
  const double* rt = parameters[1];
  Eigen::Vector3d dp0, dp1;
  const Eigen::Vector3d p_board =
      WarpedPoint(point_, warp_ ? parameters[2] : nullptr, extent_, &dp0, &dp1);

  // p_cam = R(r) p_board + t, and d(R p)/dr on dual numbers.
  using Jet3 = ceres::Jet<double, 3>;
  const Jet3 r[3] = {Jet3(rt[0], 0), Jet3(rt[1], 1), Jet3(rt[2], 2)};
  const Jet3 pb[3] = {Jet3(p_board.x()), Jet3(p_board.y()), Jet3(p_board.z())};
  Jet3 rp[3];
  ceres::AngleAxisRotatePoint(r, pb, rp);
  const Eigen::Vector3d p_cam(rp[0].a + rt[3], rp[1].a + rt[4], rp[2].a + rt[5]);

  const bool want = jacobians != nullptr;
  const int n = lens_->num_params();
  double dq_dp[6];
  Eigen::Vector2d q;
  double* dq_di = (want && jacobians[0] != nullptr) ? jacobians[0] : nullptr;
  if (!lens_->Project(intrinsics, p_cam, &q, want ? dq_dp : nullptr, dq_di)) return false;
  residuals[0] = weight_ * (q.x() - observed_.x());
  residuals[1] = weight_ * (q.y() - observed_.y());
  if (!want) return true;
  if (dq_di != nullptr) {
    for (int k = 0; k < 2 * n; ++k) dq_di[k] *= weight_;
  }
  const Eigen::Map<const Eigen::Matrix<double, 2, 3, Eigen::RowMajor>> J_p(dq_dp);
  if (jacobians[1] != nullptr) {
    Eigen::Matrix3d dp_dr;
    for (int i = 0; i < 3; ++i) dp_dr.row(i) = rp[i].v.transpose();
    Eigen::Map<Eigen::Matrix<double, 2, 6, Eigen::RowMajor>> J(jacobians[1]);
    J.leftCols<3>() = weight_ * J_p * dp_dr;
    J.rightCols<3>() = weight_ * J_p;
  }
  if (warp_ && jacobians[2] != nullptr) {
    double R[9];  // column-major
    ceres::AngleAxisToRotationMatrix(rt, R);
    const Eigen::Map<const Eigen::Matrix3d> Rm(R);
    Eigen::Map<Eigen::Matrix<double, 2, 2, Eigen::RowMajor>> J(jacobians[2]);
    J.col(0) = weight_ * J_p * (Rm * dp0);
    J.col(1) = weight_ * J_p * (Rm * dp1);
  }
  return true;
}

EdgeBiasedProjectionCost::EdgeBiasedProjectionCost(ProjectionCost* cost,
                                                   const Eigen::Vector2d& edge_shift, double weight)
    : cost_(cost), weighted_shift_(weight * edge_shift) {
  set_num_residuals(2);
  *mutable_parameter_block_sizes() = cost->parameter_block_sizes();
  mutable_parameter_block_sizes()->push_back(1);
}

bool EdgeBiasedProjectionCost::Evaluate(double const* const* parameters, double* residuals,
                                        double** jacobians) const {
  if (!cost_->Evaluate(parameters, residuals, jacobians)) return false;
  const size_t bias = cost_->parameter_block_sizes().size();
  residuals[0] += weighted_shift_.x() * parameters[bias][0];
  residuals[1] += weighted_shift_.y() * parameters[bias][0];
  if (jacobians != nullptr && jacobians[bias] != nullptr) {
    jacobians[bias][0] = weighted_shift_.x();
    jacobians[bias][1] = weighted_shift_.y();
  }
  return true;
}

IntrinsicsPrior::IntrinsicsPrior(int num_intrinsics, std::vector<int> index,
                                 std::vector<double> target, std::vector<double> weight)
    : n_(num_intrinsics),
      index_(std::move(index)),
      target_(std::move(target)),
      weight_(std::move(weight)) {
  set_num_residuals(static_cast<int>(index_.size()));
  mutable_parameter_block_sizes()->push_back(n_);
}

bool IntrinsicsPrior::Evaluate(double const* const* parameters, double* residuals,
                               double** jacobians) const {
  const int m = static_cast<int>(index_.size());
  for (int k = 0; k < m; ++k) residuals[k] = weight_[k] * (parameters[0][index_[k]] - target_[k]);
  if (jacobians != nullptr && jacobians[0] != nullptr) {
    std::fill(jacobians[0], jacobians[0] + m * n_, 0.0);
    for (int k = 0; k < m; ++k) jacobians[0][k * n_ + index_[k]] = weight_[k];
  }
  return true;
}

}  // namespace svms
