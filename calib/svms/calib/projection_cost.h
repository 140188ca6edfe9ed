// The residual of one observed board point in a calibration: observed pixel minus the pixel
// mrcal_project predicts for the point, seen through the board pose and the (optionally warped)
// board, times a weight. Analytic Jacobians: mrcal_project's own gradients with respect to the
// camera-frame point and the intrinsics, chained through the board pose (rotation vector
// derivative by Ceres' AngleAxisRotatePoint on dual numbers) and the warp.
//
// Parameter blocks, in order:
//   intrinsics      N doubles, mrcal's order: fx, fy, cx, cy, then the distortion;
//   cam_from_board  6 doubles: rotation vector (radians), translation (metres);
//   warp            2 doubles (only if the cost was made with a warp): mrcal's board flatness
//                   deviation, metres: the point moves along the board's z by
//                   warp[0] * (1 - xr^2) + warp[1] * (1 - yr^2), where xr, yr in [-1, 1] are the
//                   point's x and y scaled over the board's extent (BoardExtent).
// Residuals: 2, weight * (predicted - observed), pixels times weight.
#pragma once

#include <ceres/ceres.h>

#include <Eigen/Core>
#include <memory>
#include <vector>

namespace svms {

// The rectangle in the board's z = 0 plane that the warp is scaled over (metres).
struct BoardExtent {
  double x_min = -1, x_max = 1, y_min = -1, y_max = 1;
  // xr, yr for a point (in [-1, 1] inside the rectangle).
  Eigen::Vector2d Scaled(const Eigen::Vector3d& p) const {
    return {2 * (p.x() - x_min) / (x_max - x_min) - 1, 2 * (p.y() - y_min) / (y_max - y_min) - 1};
  }
};

// An mrcal lens model parsed once, shared by every cost of a problem (kept opaque here).
class LensModel {
 public:
  // Parses an mrcal lens model name (canonical form); nullptr if mrcal rejects it.
  static std::shared_ptr<const LensModel> Parse(const std::string& name);
  int num_params() const { return num_params_; }
  // mrcal_project for one point. dq_dp (2x3, row-major) and dq_dintrinsics (2xN, row-major)
  // may be null. False if mrcal fails, the point is behind a camera that cannot look back, or
  // the result is not finite.
  bool Project(const double* intrinsics, const Eigen::Vector3d& p_cam, Eigen::Vector2d* q,
               double* dq_dp, double* dq_dintrinsics) const;
  const void* mrcal() const { return storage_; }

 private:
  alignas(8) unsigned char storage_[64] = {};
  int num_params_ = 0;
  bool can_look_back_ = false;
};

class ProjectionCost : public ceres::CostFunction {
 public:
  // `warp` says whether the cost has the third (warp) parameter block.
  ProjectionCost(std::shared_ptr<const LensModel> lens, const Eigen::Vector3d& point_in_board,
                 const Eigen::Vector2d& observed_px, double weight, bool warp,
                 const BoardExtent& extent);
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

  // The point in the board frame after the warp (metres).
  static Eigen::Vector3d WarpedPoint(const Eigen::Vector3d& point_in_board, const double* warp,
                                     const BoardExtent& extent, Eigen::Vector3d* dp_dwarp0,
                                     Eigen::Vector3d* dp_dwarp1);

 private:
  std::shared_ptr<const LensModel> lens_;
  Eigen::Vector3d point_;
  Eigen::Vector2d observed_;
  double weight_;
  bool warp_;
  BoardExtent extent_;
};

// A ProjectionCost whose observation is also moved by an edge bias b (one more parameter
// block, 1 double, pixels, after the cost's own): the point is expected at the projection plus
// b * edge_shift (PointObservation::edge_shift), so the residual is
// weight * (predicted + b * edge_shift - observed). It takes up what moves every marker side
// out of (b > 0) or into its black square by the same amount in pixels: a response curve a
// little off makes a blurred edge's linearised profile lopsided, and its fitted line moves
// toward the dark or the bright side by a share of the blur (calibrate.h).
class EdgeBiasedProjectionCost : public ceres::CostFunction {
 public:
  // Takes ownership of `cost`.
  EdgeBiasedProjectionCost(ProjectionCost* cost, const Eigen::Vector2d& edge_shift, double weight);
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  std::unique_ptr<ProjectionCost> cost_;
  Eigen::Vector2d weighted_shift_;
};

// A linear prior on intrinsics: residual k = weight * (intrinsics[index[k]] - target[k]).
// Used to regularise splined lens models as mrcal does (their control points toward zero,
// their centre toward the image centre).
class IntrinsicsPrior : public ceres::CostFunction {
 public:
  IntrinsicsPrior(int num_intrinsics, std::vector<int> index, std::vector<double> target,
                  std::vector<double> weight);
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  int n_;
  std::vector<int> index_;
  std::vector<double> target_, weight_;
};

}  // namespace svms
