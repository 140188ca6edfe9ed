#include "svms/calib/calibrate.h"

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <opencv2/calib3d.hpp>

#include "svms/base/memory_limit.h"
#include "svms/camera/camera_covariance.h"

namespace svms {
namespace {

constexpr double kDeg = M_PI / 180;

std::string Fmt(const char* format, double a, double b = 0, double c = 0) {
  char buf[256];
  std::snprintf(buf, sizeof buf, format, a, b, c);
  return buf;
}

bool IsSplined(const std::string& name) {
  return name.rfind("LENSMODEL_SPLINED_STEREOGRAPHIC", 0) == 0;
}

// The state of the optimisation.
struct State {
  std::vector<double> intrinsics;
  std::vector<std::array<double, 6>> rt;  // cam_from_board per used view
  std::array<double, 2> warp{0, 0};
  double edge_bias = 0;  // pixels (CalibrationOptions::edge_bias)
};

struct Problem {
  const std::vector<const ViewObservations*>& views;
  const CalibrationOptions& options;
  std::shared_ptr<const LensModel> lens;
  BoardExtent extent;
  bool splined = false;
  double f_seed = 0;
};

// Splined models: control points toward zero (as pixels: f_seed * value), centre toward the
// image centre.
std::unique_ptr<IntrinsicsPrior> SplinePrior(const Problem& p) {
  const int n = p.lens->num_params();
  std::vector<int> index;
  std::vector<double> target, weight;
  const double w = p.options.spline_prior_weight;
  index.push_back(2), target.push_back(0.5 * (p.options.width - 1)), weight.push_back(w);
  index.push_back(3), target.push_back(0.5 * (p.options.height - 1)), weight.push_back(w);
  for (int k = 4; k < n; ++k)
    index.push_back(k), target.push_back(0), weight.push_back(w * p.f_seed);
  return std::make_unique<IntrinsicsPrior>(n, index, target, weight);
}

double Weight(const PointObservation& o, double ref_sigma) { return ref_sigma / o.sigma_px; }

// One Ceres solve over the inliers. core_only holds the distortion (and warp) constant.
ceres::Solver::Summary Solve(const Problem& p, const std::vector<std::vector<bool>>& outlier,
                             bool core_only, bool robust, double ref_sigma, State* s) {
  ceres::Problem::Options po;
  po.cost_function_ownership = ceres::TAKE_OWNERSHIP;
  po.loss_function_ownership = ceres::TAKE_OWNERSHIP;
  ceres::Problem problem(po);
  const int n = p.lens->num_params();
  const bool warp = p.options.board_warp && !core_only;
  const bool edge_bias = p.options.edge_bias && !core_only;
  problem.AddParameterBlock(s->intrinsics.data(), n);
  for (size_t v = 0; v < p.views.size(); ++v) {
    problem.AddParameterBlock(s->rt[v].data(), 6);
    for (size_t i = 0; i < p.views[v]->points.size(); ++i) {
      if (outlier[v][i]) continue;
      const PointObservation& o = p.views[v]->points[i];
      auto* cost = new ProjectionCost(p.lens, o.point_in_board, o.pixel, Weight(o, ref_sigma), warp,
                                      p.extent);
      ceres::LossFunction* loss = robust ? new ceres::HuberLoss(p.options.huber_px) : nullptr;
      std::vector<double*> blocks = {s->intrinsics.data(), s->rt[v].data()};
      if (warp) blocks.push_back(s->warp.data());
      if (edge_bias) {
        blocks.push_back(&s->edge_bias);
        problem.AddResidualBlock(
            new EdgeBiasedProjectionCost(cost, o.edge_shift, Weight(o, ref_sigma)), loss, blocks);
      } else {
        problem.AddResidualBlock(cost, loss, blocks);
      }
    }
  }
  if (p.splined) problem.AddResidualBlock(SplinePrior(p).release(), nullptr, s->intrinsics.data());
  if (core_only && n > 4) {
    std::vector<int> fixed;
    for (int k = 4; k < n; ++k) fixed.push_back(k);
    problem.SetManifold(s->intrinsics.data(), new ceres::SubsetManifold(n, fixed));
  }
  // Schur elimination of the board poses: the reduced system is the intrinsics (and the warp
  // and the edge bias).
  auto* ordering = new ceres::ParameterBlockOrdering;
  for (auto& rt : s->rt) ordering->AddElementToGroup(rt.data(), 0);
  ordering->AddElementToGroup(s->intrinsics.data(), 1);
  if (warp) ordering->AddElementToGroup(s->warp.data(), 1);
  if (edge_bias) ordering->AddElementToGroup(&s->edge_bias, 1);
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_SCHUR;
  so.linear_solver_ordering.reset(ordering);
  so.max_num_iterations = p.options.max_iterations;
  so.function_tolerance = 1e-12;
  so.gradient_tolerance = 1e-14;
  so.parameter_tolerance = 1e-12;
  so.num_threads = p.options.threads;
  so.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  return summary;
}

// Residuals (predicted - observed, unweighted pixels, the prediction moved by the edge bias) of
// every point; false if one fails.
bool Residuals(const Problem& p, const State& s, std::vector<std::vector<Eigen::Vector2d>>* out) {
  out->assign(p.views.size(), {});
  bool ok = true;
  for (size_t v = 0; v < p.views.size(); ++v) {
    for (const PointObservation& o : p.views[v]->points) {
      ProjectionCost cost(p.lens, o.point_in_board, o.pixel, 1.0, true, p.extent);
      const double* params[3] = {s.intrinsics.data(), s.rt[v].data(), s.warp.data()};
      double r[2];
      if (!cost.Evaluate(params, r, nullptr)) {
        r[0] = r[1] = 1e6;
        ok = false;
      }
      (*out)[v].push_back(Eigen::Vector2d(r[0], r[1]) + s.edge_bias * o.edge_shift);
    }
  }
  return ok;
}

void Log(const CalibrationOptions& o, const std::string& line) {
  if (o.verbose) std::cerr << "calibrate: " << line << "\n";
}

// The views a calibration can use (result->views: their indices) and their points on the
// board's z = 0 plane (at least min_points_per_view, enough for a homography); the others go
// to result->skipped with the reason. Fails if fewer than min_views are left.
Status SelectViews(const std::vector<ViewObservations>& all_views, const CalibrationOptions& o,
                   CalibrationResult* result, std::vector<const ViewObservations*>* views,
                   std::vector<std::vector<cv::Point3f>>* object_points,
                   std::vector<std::vector<cv::Point2f>>* image_points) {
  for (size_t v = 0; v < all_views.size(); ++v) {
    std::vector<cv::Point3f> obj;
    std::vector<cv::Point2f> img;
    for (const PointObservation& p : all_views[v].points) {
      if (std::abs(p.point_in_board.z()) > 1e-9) continue;
      obj.emplace_back(p.point_in_board.x(), p.point_in_board.y(), 0.f);
      img.emplace_back(p.pixel.x(), p.pixel.y());
    }
    if (static_cast<int>(obj.size()) < o.min_points_per_view) {
      result->skipped.emplace_back(
          v, all_views[v].name + ": " + std::to_string(all_views[v].markers) + " board markers, " +
                 std::to_string(obj.size()) + " points; expected at least " +
                 std::to_string(o.min_points_per_view) + " points");
      continue;
    }
    views->push_back(&all_views[v]);
    result->views.push_back(static_cast<int>(v));
    object_points->push_back(std::move(obj));
    image_points->push_back(std::move(img));
  }
  if (static_cast<int>(views->size()) < o.min_views) {
    return Status::Error("too few views: " + std::to_string(views->size()) + " of " +
                         std::to_string(all_views.size()) +
                         " images show enough of the board (at least " +
                         std::to_string(o.min_points_per_view) + " points); expected at least " +
                         std::to_string(o.min_views) + " such views");
  }
  return Status::Ok();
}

// How far from the image centre the observed points go, as a fraction of the half diagonal.
double ImageReach(const std::vector<std::vector<cv::Point2f>>& image_points,
                  const Eigen::Vector2d& centre) {
  const double half_diagonal = centre.norm();
  double reach = 0;
  for (const auto& img : image_points)
    for (const cv::Point2f& q : img)
      reach = std::max(reach, (Eigen::Vector2d(q.x, q.y) - centre).norm() / half_diagonal);
  return reach;
}

// The seed camera matrix *K: Zhang's closed form from the views' homographies, principal point
// at the image centre. Fails on views that give no usable focal length.
Status SeedCameraMatrix(const std::vector<std::vector<cv::Point3f>>& object_points,
                        const std::vector<std::vector<cv::Point2f>>& image_points,
                        const CalibrationOptions& o, const Eigen::Vector2d& centre, cv::Mat* K) {
  const cv::Size size(o.width, o.height);
  try {
    *K = cv::initCameraMatrix2D(object_points, image_points, size, 1.0);
  } catch (const cv::Exception& e) {
    return Status::Error(
        std::string("cannot seed the focal length from the views' homographies (") + e.what() +
        ")");
  }
  const double f0 = K->at<double>(0, 0);
  if (!(std::isfinite(f0) && f0 > 0.05 * o.width && f0 < 100.0 * o.width)) {
    return Status::Error(
        "degenerate views: the homographies give no usable focal length (" + Fmt("%g", f0) +
        " px); expected views with the board tilted by 20 to 45 degrees, not all fronto-parallel");
  }
  K->at<double>(0, 2) = centre.x(), K->at<double>(1, 2) = centre.y();
  return Status::Ok();
}

// The seed cam_from_board of each view (s->rt) from its points and the seed camera matrix K
// (solvePnP, IPPE). Fails if one cannot be seeded, or if every board is within min_tilt_deg
// of fronto-parallel (the focal length cannot then be told from the distance).
Status SeedBoardPoses(const std::vector<const ViewObservations*>& views,
                      const std::vector<std::vector<cv::Point3f>>& object_points,
                      const std::vector<std::vector<cv::Point2f>>& image_points, const cv::Mat& K,
                      const CalibrationOptions& o, State* s) {
  s->rt.resize(views.size());
  double max_tilt = 0;
  for (size_t v = 0; v < views.size(); ++v) {
    cv::Mat rvec, tvec;
    bool ok = false;
    try {
      ok = cv::solvePnP(object_points[v], image_points[v], K, cv::noArray(), rvec, tvec, false,
                        cv::SOLVEPNP_IPPE);
    } catch (const cv::Exception&) {
      ok = false;
    }
    if (!ok)
      return Status::Error(views[v]->name + ": cannot seed the board pose (solvePnP failed)");
    for (int k = 0; k < 3; ++k)
      s->rt[v][k] = rvec.at<double>(k), s->rt[v][3 + k] = tvec.at<double>(k);
    const Pose pose{Eigen::Vector3d(s->rt[v][0], s->rt[v][1], s->rt[v][2]),
                    Eigen::Vector3d::Zero()};
    const double tilt = std::acos(std::min(1.0, std::abs(pose.Rotation()(2, 2))));
    max_tilt = std::max(max_tilt, tilt);
  }
  if (max_tilt < o.min_tilt_deg * kDeg) {
    return Status::Error(
        Fmt("degenerate views: every board is within %.1f degrees of fronto-parallel, so the "
            "focal length cannot be told from the distance; expected some views tilted by 20 to "
            "45 degrees",
            max_tilt / kDeg));
  }
  return Status::Ok();
}

// The rectangle the board's points on its z = 0 plane cover (the warp's extent); the default
// extent if they span no area.
BoardExtent PlaneExtent(const std::vector<std::vector<cv::Point3f>>& object_points) {
  BoardExtent e;
  e.x_min = e.y_min = 1e300, e.x_max = e.y_max = -1e300;
  for (const auto& obj : object_points)
    for (const cv::Point3f& q : obj) {
      e.x_min = std::min<double>(e.x_min, q.x), e.x_max = std::max<double>(e.x_max, q.x);
      e.y_min = std::min<double>(e.y_min, q.y), e.y_max = std::max<double>(e.y_max, q.y);
    }
  if (!(e.x_max > e.x_min && e.y_max > e.y_min)) e = BoardExtent();
  return e;
}

// The solve in stages from the seed in *s: the core intrinsics (distortion held), then all,
// both robust (Huber); then outlier rejection (points beyond outlier_threshold sigmas of the
// weighted residuals, at least min_outlier_px) and robust re-solves until the outliers no
// longer change (at most max_outlier_rounds); then a final least-squares solve. *outlier:
// per view and point. Returns the final solve's summary; result->outlier_rounds, ->iterations
// and ->report are set.
ceres::Solver::Summary SolveInStages(const Problem& p, double ref_sigma, State* s,
                                     std::vector<std::vector<bool>>* outlier_io,
                                     CalibrationResult* result) {
  const CalibrationOptions& o = p.options;
  const std::vector<const ViewObservations*>& views = p.views;
  std::vector<std::vector<bool>>& outlier = *outlier_io;
  int iterations = 0;
  auto run = [&](const char* stage, bool core_only, bool robust) {
    const ceres::Solver::Summary sum = Solve(p, outlier, core_only, robust, ref_sigma, s);
    iterations += static_cast<int>(sum.iterations.size());
    Log(o, std::string(stage) + ": " + sum.BriefReport());
    return sum;
  };
  run("stage 1 (core)", true, true);
  run("stage 2 (all)", false, true);

  // Outlier rejection and re-solve.
  std::vector<std::vector<Eigen::Vector2d>> res;
  auto stats = [&](double* sigma) {
    double sum2 = 0;
    int count = 0;
    for (size_t v = 0; v < views.size(); ++v)
      for (size_t i = 0; i < res[v].size(); ++i)
        if (!outlier[v][i])
          sum2 += res[v][i].squaredNorm() * std::pow(Weight(views[v]->points[i], ref_sigma), 2),
              ++count;
    *sigma = count > 0 ? std::sqrt(sum2 / (2.0 * count)) : 0;
  };
  for (int round = 0; round < o.max_outlier_rounds; ++round) {
    Residuals(p, *s, &res);
    double sigma = 0;
    stats(&sigma);
    const double threshold = std::max(o.outlier_threshold * sigma, o.min_outlier_px);
    bool changed = false;
    int count = 0;
    for (size_t v = 0; v < views.size(); ++v)
      for (size_t i = 0; i < res[v].size(); ++i) {
        const double r = res[v][i].norm() * Weight(views[v]->points[i], ref_sigma);
        const bool out = r > threshold;
        changed |= out != outlier[v][i];
        outlier[v][i] = out;
        count += out;
      }
    result->outlier_rounds = round + 1;
    Log(o, Fmt("outliers: %.0f beyond %.3f px", count, threshold));
    if (!changed) break;
    run("re-solve", false, true);
  }
  const ceres::Solver::Summary final_summary = run("final (least squares)", false, false);
  result->report = final_summary.BriefReport();
  result->iterations = iterations;
  return final_summary;
}

// The residuals of the solution (result->residuals, ->outlier) and their statistics over the
// inliers: RMS, worst, the per-axis sigma about their mean, the counts.
void ResidualStatistics(const std::vector<std::vector<Eigen::Vector2d>>& res,
                        const std::vector<std::vector<bool>>& outlier, CalibrationResult* result) {
  result->residuals = res;
  result->outlier = outlier;
  double sum2 = 0, worst = 0, sumc = 0;
  int inliers = 0;
  for (size_t v = 0; v < res.size(); ++v)
    for (size_t i = 0; i < res[v].size(); ++i) {
      if (outlier[v][i]) {
        ++result->num_outliers;
        continue;
      }
      ++inliers;
      sum2 += res[v][i].squaredNorm();
      sumc += res[v][i].x() + res[v][i].y();
      worst = std::max(worst, res[v][i].norm());
    }
  result->num_inliers = inliers;
  result->rms_px = inliers > 0 ? std::sqrt(sum2 / inliers) : 0;
  result->worst_px = worst;
  const double mean_c = inliers > 0 ? sumc / (2.0 * inliers) : 0;
  result->sigma_px =
      inliers > 0 ? std::sqrt(std::max(0.0, sum2 / (2.0 * inliers) - mean_c * mean_c)) : 0;
}

// J^T J of the state [intrinsics, 6 per view (cam_from_board), warp (2, with board_warp), edge
// bias (1, with edge_bias)] at
// the solution, from the analytic Jacobian of the inliers' weighted residuals (*JotJo) and
// with the splined models' prior added (*JtJ).
void StateInformation(const Problem& p, const State& s,
                      const std::vector<std::vector<bool>>& outlier, double ref_sigma,
                      Eigen::MatrixXd* JtJ, Eigen::MatrixXd* JotJo) {
  const std::vector<const ViewObservations*>& views = p.views;
  const bool warp = p.options.board_warp;
  const bool edge_bias = p.options.edge_bias;
  const int n = p.lens->num_params();
  const int nv = static_cast<int>(views.size());
  const int nstate = n + 6 * nv + (warp ? 2 : 0) + (edge_bias ? 1 : 0);
  *JotJo = Eigen::MatrixXd::Zero(nstate, nstate);
  std::vector<double> ji(2 * n);
  double jrt[12], jw[4], r[2];
  // Each point touches the intrinsics, its view's pose, the warp and the edge bias: accumulate
  // the outer product of that compact row into those blocks only.
  const int m = n + 6 + (warp ? 2 : 0) + (edge_bias ? 1 : 0);
  Eigen::MatrixXd row(2, m);
  std::vector<int> index(m);
  for (int v = 0; v < nv; ++v) {
    for (int k = 0; k < n; ++k) index[k] = k;
    for (int k = 0; k < 6; ++k) index[n + k] = n + 6 * v + k;
    if (warp) index[n + 6] = n + 6 * nv, index[n + 7] = n + 6 * nv + 1;
    if (edge_bias) index[m - 1] = nstate - 1;
    Eigen::MatrixXd block = Eigen::MatrixXd::Zero(m, m);
    for (size_t i = 0; i < views[v]->points.size(); ++i) {
      if (outlier[v][i]) continue;
      const PointObservation& ob = views[v]->points[i];
      ProjectionCost cost(p.lens, ob.point_in_board, ob.pixel, Weight(ob, ref_sigma), warp,
                          p.extent);
      const double* params[3] = {s.intrinsics.data(), s.rt[v].data(), s.warp.data()};
      double* jac[3] = {ji.data(), jrt, jw};
      if (!cost.Evaluate(params, r, jac)) continue;
      for (int a = 0; a < 2; ++a) {
        for (int k = 0; k < n; ++k) row(a, k) = ji[a * n + k];
        for (int k = 0; k < 6; ++k) row(a, n + k) = jrt[a * 6 + k];
        if (warp) row(a, n + 6) = jw[a * 2], row(a, n + 7) = jw[a * 2 + 1];
        if (edge_bias) row(a, m - 1) = Weight(ob, ref_sigma) * ob.edge_shift(a);
      }
      block.noalias() += row.transpose() * row;
    }
    for (int a = 0; a < m; ++a)
      for (int b = 0; b < m; ++b) (*JotJo)(index[a], index[b]) += block(a, b);
  }
  *JtJ = *JotJo;
  if (p.splined) {
    std::unique_ptr<IntrinsicsPrior> prior = SplinePrior(p);
    const int mp = prior->num_residuals();
    std::vector<double> rr(mp), jj(mp * n);
    const double* params[1] = {s.intrinsics.data()};
    double* jac[1] = {jj.data()};
    prior->Evaluate(params, rr.data(), jac);
    const Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> Jr(
        jj.data(), mp, n);
    JtJ->topLeftCorner(n, n) += Jr.transpose() * Jr;
  }
}

// The covariance of the state, mrcal's formula, from the analytic Jacobian at the optimum: a
// pseudo-inverse of J^T J scaled to unit diagonal (rational and splined models have directions
// in their distortion that the data barely see and that do not move any projection; what
// matters, the focal length and the projections, is checked on its own), times the
// a-posteriori noise sigma^2. Sets result->noise_sigma_px, ->covariance_factor and
// ->covariance.
void StateCovariance(const Problem& p, const State& s,
                     const std::vector<std::vector<bool>>& outlier,
                     const std::vector<std::vector<Eigen::Vector2d>>& res, double ref_sigma,
                     CalibrationResult* result) {
  const std::vector<const ViewObservations*>& views = p.views;
  const int nv = static_cast<int>(views.size());
  Eigen::MatrixXd JtJ, JotJo;
  StateInformation(p, s, outlier, ref_sigma, &JtJ, &JotJo);
  const int nstate = static_cast<int>(JtJ.rows());
  // Scale to unit diagonal before inverting (the parameters' units differ widely).
  const Eigen::VectorXd d = JtJ.diagonal().cwiseMax(1e-300).cwiseSqrt().cwiseInverse();
  const Eigen::MatrixXd A = d.asDiagonal() * JtJ * d.asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(A);
  const double lmax = eig.eigenvalues()(nstate - 1);
  Eigen::VectorXd inv = eig.eigenvalues();
  for (int k = 0; k < nstate; ++k) inv(k) = inv(k) > 1e-15 * lmax ? 1 / inv(k) : 0.0;
  // sigma of the weighted residuals (mrcal's observed_pixel_uncertainty, in units of the
  // reference sigma's pixels): the a-posteriori estimate of the corner noise, over the
  // residuals' degrees of freedom (2 per inlier, less the state's dimension).
  double sum_w2 = 0;
  for (int v = 0; v < nv; ++v)
    for (size_t i = 0; i < res[v].size(); ++i)
      if (!outlier[v][i])
        sum_w2 += res[v][i].squaredNorm() * std::pow(Weight(views[v]->points[i], ref_sigma), 2);
  const int dof = 2 * result->num_inliers - nstate;
  const double sigma = dof > 0 ? std::sqrt(sum_w2 / dof) : 0;
  result->noise_sigma_px = sigma;
  // The covariance is kept as a factor F (covariance = F F^t), so that everything propagated
  // from it is positive semi-definite by construction: the rational and splined models have
  // directions the data barely see (condition numbers near 1e15), and a dense product
  // Ainv B Ainv then loses its positivity to round-off.
  Eigen::VectorXd inv_sqrt(nstate);
  for (int k = 0; k < nstate; ++k) inv_sqrt(k) = std::sqrt(inv(k));
  Eigen::MatrixXd F;
  if (!p.splined) {
    // No prior: J_obs = J, so Ainv B Ainv = Ainv = V diag(1/l) V^t.
    F = d.asDiagonal() * eig.eigenvectors() * inv_sqrt.asDiagonal();
  } else {
    const Eigen::MatrixXd B = d.asDiagonal() * JotJo * d.asDiagonal();
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eb(B);
    const Eigen::VectorXd b_sqrt = eb.eigenvalues().cwiseMax(0.0).cwiseSqrt();
    const Eigen::MatrixXd Ainv =
        eig.eigenvectors() * inv.asDiagonal() * eig.eigenvectors().transpose();
    F = d.asDiagonal() * Ainv * eb.eigenvectors() * b_sqrt.asDiagonal();
  }
  result->covariance_factor = sigma * F;
  result->covariance = result->covariance_factor * result->covariance_factor.transpose();
}

}  // namespace

Status CalibrationOptions::Check() const {
  if (width <= 0 || height <= 0)
    return Status::Error("image size: expected positive width and height, got " +
                         std::to_string(width) + "x" + std::to_string(height));
  if (!(huber_px > 0) || !(outlier_threshold > 1) || !(min_outlier_px >= 0))
    return Status::Error("options: expected huber_px > 0, outlier_threshold > 1");
  if (min_views < 2) return Status::Error("options: expected min_views >= 2");
  if (min_points_per_view < 4) return Status::Error("options: expected min_points_per_view >= 4");
  if (max_iterations < 1 || threads < 1)
    return Status::Error("options: expected max_iterations >= 1 and threads >= 1");
  return Status::Ok();
}

Status CheckCalibrationRequest(const std::string& lensmodel, int num_views) {
  int n = 0;
  bool gradients = false;
  // The bare splined name is resolved from the images (ResolveLensModel): 16 x 12 or so.
  const std::string name = lensmodel == "LENSMODEL_SPLINED_STEREOGRAPHIC"
                               ? "LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=16_Ny=16_fov_x_deg=100"
                               : lensmodel;
  if (Status s = CameraModel::CheckLensModelName(name, &n, &gradients); !s) return s;
  if (!gradients)
    return Status::Error("lensmodel: '" + lensmodel +
                         "' gives no gradients in mrcal 2.2, which the calibration needs; "
                         "expected e.g. LENSMODEL_PINHOLE, LENSMODEL_OPENCV8, "
                         "LENSMODEL_SPLINED_STEREOGRAPHIC");
  const double nstate = n + 6.0 * std::max(num_views, 1) + 3;
  return CheckMemory("a calibration of " + lensmodel + " (" + std::to_string(n) +
                         " intrinsics) over " + std::to_string(num_views) + " views",
                     12 * 8 * nstate * nstate);
}

Status Calibrate(const std::vector<ViewObservations>& all_views, const CalibrationOptions& o,
                 CalibrationResult* result) {
  if (Status s = o.Check(); !s) return s;
  *result = CalibrationResult();

  // Usable views: enough points on the object's z = 0 plane for a homography.
  std::vector<const ViewObservations*> views;
  std::vector<std::vector<cv::Point3f>> object_points;
  std::vector<std::vector<cv::Point2f>> image_points;
  if (Status s = SelectViews(all_views, o, result, &views, &object_points, &image_points); !s)
    return s;
  const Eigen::Vector2d centre(0.5 * (o.width - 1), 0.5 * (o.height - 1));
  const double reach = ImageReach(image_points, centre);

  // Seed: Zhang's closed form from the homographies, then each board's pose.
  cv::Mat K;
  if (Status s = SeedCameraMatrix(object_points, image_points, o, centre, &K); !s) return s;
  const double f0 = K.at<double>(0, 0);
  Log(o, Fmt("seed focal length %.1f px from %.0f views", f0, views.size()));
  State s;
  if (Status st = SeedBoardPoses(views, object_points, image_points, K, o, &s); !st) return st;

  // The lens model and its seed.
  const std::string lensmodel = ResolveLensModel(o.lensmodel, o.width, o.height, f0);
  Problem p{views, o, LensModel::Parse(lensmodel), {}, IsSplined(lensmodel), f0};
  if (p.lens == nullptr) {
    return Status::Error("lensmodel: '" + lensmodel +
                         "' is not an mrcal lens model with gradients; expected e.g. "
                         "LENSMODEL_PINHOLE, LENSMODEL_OPENCV8, LENSMODEL_SPLINED_STEREOGRAPHIC");
  }
  const int n = p.lens->num_params();
  if (Status st = CheckCalibrationRequest(lensmodel, static_cast<int>(views.size())); !st)
    return st;
  const bool has_distortion = n > 4;
  if (has_distortion && reach < o.min_reach) {
    return Status::Error(
        Fmt("degenerate views: every observed point lies within %.0f %% of the half diagonal of "
            "the image centre, so the lens distortion cannot be determined; expected points out "
            "to at least %.0f %% (put the board near the edges and corners of the image)",
            100 * reach, 100 * o.min_reach));
  }
  s.intrinsics.assign(n, 0.0);
  s.intrinsics[0] = s.intrinsics[1] = f0;
  s.intrinsics[2] = centre.x(), s.intrinsics[3] = centre.y();
  p.extent = PlaneExtent(object_points);
  result->extent = p.extent;

  // The solve, with outlier rejection.
  const double ref_sigma = views[0]->points[0].sigma_px;
  result->reference_sigma_px = ref_sigma;
  std::vector<std::vector<bool>> outlier(views.size());
  for (size_t v = 0; v < views.size(); ++v) outlier[v].assign(views[v]->points.size(), false);
  const ceres::Solver::Summary final_summary = SolveInStages(p, ref_sigma, &s, &outlier, result);

  // Results.
  std::vector<std::vector<Eigen::Vector2d>> res;
  Residuals(p, s, &res);
  ResidualStatistics(res, outlier, result);
  for (const auto& rt : s.rt)
    result->cam_from_board.push_back(
        Pose{Eigen::Vector3d(rt[0], rt[1], rt[2]), Eigen::Vector3d(rt[3], rt[4], rt[5])});
  result->warp = Eigen::Vector2d(s.warp[0], s.warp[1]);
  result->edge_bias_px = s.edge_bias;
  if (Status st = CameraModel::Create(lensmodel, s.intrinsics, o.width, o.height, &result->camera);
      !st)
    return Status::Error("the solve gave an invalid camera model: " + st.message());
  if (final_summary.termination_type != ceres::CONVERGENCE) {
    return Status::Error("the solve did not converge (" + final_summary.BriefReport() +
                         "); no model written" +
                         RationalDistortionValleyHint(lensmodel, s.intrinsics));
  }
  if (!(result->rms_px <= o.max_rms_px)) {
    return Status::Error(
        Fmt("the board does not match the images: RMS residual %.2f px after the solve, expected "
            "at most %.2f px (wrong board file, wrong marker size or spacing?)",
            result->rms_px, o.max_rms_px));
  }

  // Covariance of the state. The camera carries its intrinsics' marginal uncertainty (what a
  // pose in this camera's frame inherits: unlike ProjectionCovariance, nothing is absorbed into
  // the board poses here).
  StateCovariance(p, s, outlier, res, ref_sigma, result);
  if (Status st = result->camera.set_intrinsics_covariance_factor(
          CompactFactor(result->covariance_factor.topRows(n)));
      !st) {
    return st;
  }
  if (o.edge_bias) {
    const int last = static_cast<int>(result->covariance.rows()) - 1;
    result->edge_bias_sigma_px = std::sqrt(std::max(0.0, result->covariance(last, last)));
    Log(o, Fmt("edge bias %+.5f +- %.5f px", s.edge_bias, result->edge_bias_sigma_px));
  }
  const double rel = std::sqrt(result->covariance(0, 0)) / s.intrinsics[0];
  if (!(rel <= o.max_focal_rel_sigma)) {
    return Status::Error(
        Fmt("degenerate views: the focal length is undetermined (predicted "
            "sigma %.2g %% of fx); expected views tilted 20 to 45 degrees in "
            "several directions",
            100 * rel));
  }
  return Status::Ok();
}

std::string RationalDistortionValleyHint(const std::string& lensmodel,
                                         const std::vector<double>& intrinsics) {
  if (lensmodel != "LENSMODEL_OPENCV8" && lensmodel != "LENSMODEL_OPENCV12") return "";
  if (intrinsics.size() < 10) return "";
  const double k1 = intrinsics[4], k4 = intrinsics[9];
  // Both grown: a wide lens may need one of them large, the valley moves both.
  if (!(std::abs(k1) > 10 && std::abs(k4) > 10)) return "";
  return "; " + lensmodel +
         "'s rational distortion may be creeping along a valley where its numerator and "
         "denominator grow together (now " +
         Fmt("k1 = %.4g, k4 = %.4g", k1, k4) +
         "); LENSMODEL_OPENCV5 and the splined models have no such valley";
}

std::string ResolveLensModel(const std::string& lensmodel, int width, int height, double focal_px) {
  if (lensmodel != "LENSMODEL_SPLINED_STEREOGRAPHIC") return lensmodel;
  const int nx = 16, ny = std::max(4, static_cast<int>(std::lround(16.0 * height / width)));
  const double fov = 1.3 * 2 * std::atan(0.5 * width / focal_px) / kDeg;
  return "LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=" + std::to_string(nx) +
         "_Ny=" + std::to_string(ny) +
         "_fov_x_deg=" + std::to_string(static_cast<int>(std::ceil(fov)));
}

bool ProjectionCovariance(const CalibrationResult& r, const Eigen::Vector2d& px, double range,
                          Eigen::Matrix2d* covariance) {
  const CameraModel& cam = r.camera;
  const int n = static_cast<int>(cam.intrinsics().size());
  const int nv = static_cast<int>(r.cam_from_board.size());
  if (cam.empty() || nv == 0 || r.covariance_factor.rows() < n + 6 * nv) return false;
  Eigen::Vector3d dir;
  if (!cam.Unproject(px, &dir)) return false;
  const Eigen::Vector3d p_cam = range * dir;
  // The point in each board's frame, mapped back through that board's (perturbed) pose; the
  // camera-frame point is the mean.
  const int nstate = static_cast<int>(r.covariance_factor.rows());
  Eigen::MatrixXd dpmean_db = Eigen::MatrixXd::Zero(3, nstate);
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (int v = 0; v < nv; ++v) {
    const Pose& cb = r.cam_from_board[v];
    const Eigen::Vector3d p_board = cb.Inverse() * p_cam;
    using Jet3 = ceres::Jet<double, 3>;
    const Jet3 rv[3] = {Jet3(cb.rvec.x(), 0), Jet3(cb.rvec.y(), 1), Jet3(cb.rvec.z(), 2)};
    const Jet3 pb[3] = {Jet3(p_board.x()), Jet3(p_board.y()), Jet3(p_board.z())};
    Jet3 rp[3];
    ceres::AngleAxisRotatePoint(rv, pb, rp);
    for (int i = 0; i < 3; ++i) {
      mean(i) += (rp[i].a + cb.tvec(i)) / nv;
      dpmean_db.block(i, n + 6 * v, 1, 3) = rp[i].v.transpose() / nv;
      dpmean_db(i, n + 6 * v + 3 + i) = 1.0 / nv;
    }
  }
  Eigen::Vector2d q;
  Eigen::Matrix<double, 2, 3> dq_dp;
  Eigen::Matrix<double, 2, Eigen::Dynamic> dq_di;
  if (!cam.Project(mean, &q, &dq_dp, &dq_di)) return false;
  Eigen::MatrixXd G = dq_dp * dpmean_db;
  G.leftCols(n) += dq_di;
  const Eigen::MatrixXd GF = G * r.covariance_factor;  // PSD by construction
  *covariance = GF * GF.transpose();
  return covariance->allFinite();
}

bool AlignedProjectionError(const CalibrationResult& r, const CameraModel& true_camera,
                            const std::vector<Pose>& true_cam_from_board, const Eigen::Vector2d& px,
                            double range, Eigen::Vector2d* error) {
  const size_t nv = r.cam_from_board.size();
  if (nv == 0 || true_cam_from_board.size() != nv) return false;
  Eigen::Vector3d dir;
  if (!true_camera.Unproject(px, &dir)) return false;
  const Eigen::Vector3d p_true = range * dir;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (size_t v = 0; v < nv; ++v)
    mean += r.cam_from_board[v] * (true_cam_from_board[v].Inverse() * p_true) / nv;
  Eigen::Vector2d q;
  if (!r.camera.Project(mean, &q)) return false;
  *error = q - px;
  return true;
}

}  // namespace svms
