#include "svms/bundle/rig_survey.h"

#include <ceres/ceres.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Sparse>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <map>
#include <memory>

#include "svms/base/statistics.h"
#include "svms/bundle/cost_functions.h"
#include "svms/bundle/view_graph.h"
#include "svms/detect/marker_pose.h"
#include "svms/geometry/pose_matrix.h"
#include "svms/geometry/so3.h"

namespace svms {
namespace {

// Floor on the noise's variance factor: the 1 % quantile of chi2(dof) / dof, what honest
// sigmas give by chance once in a hundred surveys. A chi2 below what the detector's sigmas and
// the layout's and calibration's stated errors would give says those are overstated, not that
// the frames are noiseless; shrinking the measurements' share further for it would make the
// rig file over-confident (a floor of 1 instead biases every survey conservative).
double MinNoiseVarianceFactor(int dof) { return ChiSquareQuantile(0.01, dof) / dof; }

using Block6 = std::array<double, 6>;
using Mat6 = Eigen::Matrix<double, 6, 6>;

Block6 ToBlock(const Pose& p) {
  return {p.rvec(0), p.rvec(1), p.rvec(2), p.tvec(0), p.tvec(1), p.tvec(2)};
}
Pose FromBlock(const Block6& b) {
  return Pose{Eigen::Vector3d(b[0], b[1], b[2]), Eigen::Vector3d(b[3], b[4], b[5])};
}

// d [left rotation perturbation, translation] / d [rvec, tvec] of a pose block.
Mat6 TangentFromBlock(const Block6& b) {
  Mat6 T = Mat6::Identity();
  T.topLeftCorner<3, 3>() = LeftJacobian(Eigen::Vector3d(b[0], b[1], b[2]));
  return T;
}

// A marker pose of the layout (one per distinct object_from_marker), constant in the solve.
struct LayoutBlock {
  Block6 pose;
  double height = 0;  // its post's height (metres), when it has a post
  bool has_post = false;
  // The covariance in the block's own coordinates [rvec, tvec] (the layout's is about the object
  // axes); zero when the layout gives none.
  Mat6 covariance = Mat6::Zero();
  bool has_covariance = false;
  double height_sigma = 0;  // 0: none
};

// One corner (0-3) or tip (4) of one marker observation.
struct PointObs {
  int frame = 0, camera = 0, observation = 0, point = 0;
  int layout = 0;                                       // index into the layout blocks
  Eigen::Vector3d in_marker = Eigen::Vector3d::Zero();  // a corner's
  Eigen::Vector2d px = Eigen::Vector2d::Zero();
  double sigma = 1;
  Eigen::Vector2d tip_xy = Eigen::Vector2d::Zero();  // a concave well's visible bottom
  bool rejected = false;
  double norm = 0;  // |residual| / sigma at the last evaluation
  ceres::ResidualBlockId id = nullptr;
};

class Solver {
 public:
  Solver(const std::vector<RigCameraView>& cameras, const std::vector<RigSurveyFrame>& frames,
         const RigSurveyOptions& options, RigSurveyResult* result)
      : cameras_(cameras), frames_(frames), o_(options), R_(*result), S_(result->summary) {}

  Status Run();

 private:
  Status Fail(const std::string& m) {
    S_.success = false;
    S_.message = m;
    return Status::Error(m);
  }
  Status CollectPoints();
  Status Initialise();
  void UpdateTipOffsets();
  void BuildProblem(bool robust);
  Status Solve(bool robust);
  void EvaluatePoints();
  void RejectOutliers();
  Status ComputeCovariance();
  void FillResult();
  std::string CameraName(int c) const {
    return static_cast<size_t>(c) < o_.camera_names.size() ? "camera '" + o_.camera_names[c] + "'"
                                                           : "camera " + std::to_string(c);
  }

  const std::vector<RigCameraView>& cameras_;
  const std::vector<RigSurveyFrame>& frames_;
  const RigSurveyOptions& o_;
  RigSurveyResult& R_;
  RigSurveySummary& S_;

  std::vector<LayoutBlock> layout_;
  std::vector<PointObs> points_;
  std::vector<Block6> rig_from_cam_;     // per camera
  std::vector<Block6> rig_from_object_;  // per frame
  std::vector<bool> frame_used_;
  std::vector<std::vector<double>> intrinsics_;  // per camera, constant
  std::vector<bool> calibration_;                // camera's calibration covariance is used
  std::unique_ptr<ceres::Problem> problem_;
};

Status Solver::CollectPoints() {
  const int n = static_cast<int>(cameras_.size());
  // Independent corners, each with the sigma the fusion gives an independent corner.
  ObjectPoseOptions measurement = o_.measurement;
  measurement.corner_covariance_from_fit = false;
  std::map<Block6, int> layout_index;
  for (size_t f = 0; f < frames_.size(); ++f) {
    const std::vector<MarkerObservation>& obs = frames_[f].observations;
    for (size_t i = 0; i < obs.size(); ++i) {
      const MarkerObservation& m = obs[i];
      if (m.camera < 0 || m.camera >= n || !cameras_[m.camera].camera)
        return Fail("frame " + std::to_string(f) + ", observation " + std::to_string(i) +
                    " (marker " + std::to_string(m.id) + ") names camera " +
                    std::to_string(m.camera) + "; expected one of the rig's " + std::to_string(n) +
                    " cameras");
      const Block6 key = ToBlock(m.object_from_marker);
      auto [it, inserted] = layout_index.emplace(key, static_cast<int>(layout_.size()));
      if (inserted) {
        LayoutBlock b;
        b.pose = key;
        if (m.layout_covariance) {
          // Left perturbation about the object axes -> the block's rvec: d rvec = J_l^-1 d.
          const Mat6 T_inv = TangentFromBlock(key).inverse();
          b.covariance = T_inv * *m.layout_covariance * T_inv.transpose();
          b.has_covariance = !m.layout_covariance->isZero();
        }
        layout_.push_back(b);
      }
      // A dual's inner marker may share its outer marker's entry without carrying the post.
      LayoutBlock& entry = layout_[it->second];
      if (m.model.post && !entry.has_post) {
        entry.height = m.model.post->height;
        entry.has_post = true;
        if (m.post_height_sigma && *m.post_height_sigma > 0)
          entry.height_sigma = *m.post_height_sigma;
      }
      const auto corners = m.model.Corners();
      for (int k = 0; k < 4; ++k) {
        PointObs p;
        p.frame = static_cast<int>(f);
        p.camera = m.camera;
        p.observation = static_cast<int>(i);
        p.point = k;
        p.layout = it->second;
        p.in_marker = corners[k];
        p.px = m.corners[k];
        p.sigma = CornerPixelSigma(measurement, m, k);
        points_.push_back(p);
      }
      if (o_.measurement.use_tips && m.tip && m.model.post) {
        PointObs p;
        p.frame = static_cast<int>(f);
        p.camera = m.camera;
        p.observation = static_cast<int>(i);
        p.point = 4;
        p.layout = it->second;
        p.px = m.tip->pixel;
        p.sigma = TipPixelSigma(measurement, m);
        points_.push_back(p);
      }
    }
  }
  if (points_.empty()) return Fail("no marker of the layout was seen in any frame");
  return Status::Ok();
}

Status Solver::Initialise() {
  const int n = static_cast<int>(cameras_.size());
  const size_t nf = frames_.size();
  // 1. Each camera's own fused pose per frame.
  std::vector<std::vector<std::optional<Pose>>> cam_from_object(
      nf, std::vector<std::optional<Pose>>(n));
  std::vector<MarkerObservation> mine;
  for (size_t f = 0; f < nf; ++f) {
    for (int c = 0; c < n; ++c) {
      mine.clear();
      for (const MarkerObservation& m : frames_[f].observations)
        if (m.camera == c) mine.push_back(m);
      if (mine.empty()) continue;
      const ObjectPose pose = SolveObjectPose(*cameras_[c].camera, mine, o_.measurement);
      if (pose.valid) cam_from_object[f][c] = pose.cam_from_object;
    }
  }
  // 2. The cameras reached from the reference, the best-connected first.
  std::vector<std::optional<Pose>> rig_from_cam(n);
  rig_from_cam[o_.reference_camera] = cameras_[o_.reference_camera].rig_from_cam;
  const double angle = o_.init_inlier_angle_deg * M_PI / 180;
  for (;;) {
    int best = -1;
    std::vector<Pose> best_samples;
    for (int k = 0; k < n; ++k) {
      if (rig_from_cam[k]) continue;
      std::vector<Pose> samples;
      for (size_t f = 0; f < nf; ++f) {
        if (!cam_from_object[f][k]) continue;
        // One sample per frame: from the first placed camera that saw the object then.
        for (int j = 0; j < n; ++j) {
          if (!rig_from_cam[j] || !cam_from_object[f][j]) continue;
          samples.push_back(*rig_from_cam[j] * *cam_from_object[f][j] *
                            cam_from_object[f][k]->Inverse());
          break;
        }
      }
      if (samples.size() > best_samples.size()) {
        best = k;
        best_samples = std::move(samples);
      }
    }
    if (best < 0) break;
    rig_from_cam[best] = RobustAverage(best_samples, angle, o_.init_inlier_distance).a_from_b;
  }
  std::vector<int> lost;
  for (int c = 0; c < n; ++c)
    if (!rig_from_cam[c]) lost.push_back(c);
  if (!lost.empty()) {
    std::string names;
    for (int c : lost) names += (names.empty() ? "" : ", ") + CameraName(c);
    return Fail(names + (lost.size() == 1 ? " sees" : " see") +
                " the object in no frame together with the reference camera (" +
                CameraName(o_.reference_camera) +
                ") or a camera placed from it, so its rig_from_cam is not determined");
  }
  rig_from_cam_.resize(n);
  intrinsics_.resize(n);
  calibration_.assign(n, false);
  for (int c = 0; c < n; ++c) {
    rig_from_cam_[c] = ToBlock(*rig_from_cam[c]);
    R_.initial_rig_from_cam.push_back(*rig_from_cam[c]);
    intrinsics_[c] = cameras_[c].camera->intrinsics();
    calibration_[c] = o_.measurement.use_calibration_covariance &&
                      cameras_[c].camera->intrinsics_covariance_factor().size() > 0;
  }
  // Each frame's rig_from_object: the average of its cameras'.
  rig_from_object_.assign(nf, Block6{});
  frame_used_.assign(nf, false);
  for (size_t f = 0; f < nf; ++f) {
    std::vector<Pose> samples;
    for (int c = 0; c < n; ++c)
      if (cam_from_object[f][c]) samples.push_back(*rig_from_cam[c] * *cam_from_object[f][c]);
    if (samples.empty()) continue;
    rig_from_object_[f] = ToBlock(PlainAverage(samples));
    frame_used_[f] = true;
  }
  for (PointObs& p : points_)
    if (!frame_used_[p.frame]) p.rejected = true;
  UpdateTipOffsets();
  return Status::Ok();
}

// The visible point of each tip at the current poses (a concave well's bottom slides with the
// view); a well whose bottom is not seen at all gives no tip.
void Solver::UpdateTipOffsets() {
  for (PointObs& p : points_) {
    if (p.point != 4 || !frame_used_[p.frame]) continue;
    const MarkerObservation& m = frames_[p.frame].observations[p.observation];
    const Pose cam_from_marker = FromBlock(rig_from_cam_[p.camera]).Inverse() *
                                 FromBlock(rig_from_object_[p.frame]) * m.object_from_marker;
    double fraction = 0;
    const Eigen::Vector3d tip = VisibleTipPoint(m.model, cam_from_marker.Inverse().tvec, &fraction);
    p.tip_xy = tip.head<2>();
    if (m.model.post->concave() && fraction <= 0) p.rejected = true;
  }
}

void Solver::BuildProblem(bool robust) {
  problem_ = std::make_unique<ceres::Problem>();
  for (PointObs& p : points_) {
    p.id = nullptr;
    if (p.rejected) continue;
    const CameraModel* camera = cameras_[p.camera].camera;
    const bool intrinsics = calibration_[p.camera];
    MarkerPointCost* point =
        p.point == 4
            ? MarkerPointCost::CreateTip(camera, &p.tip_xy, p.px, p.sigma, intrinsics)
            : MarkerPointCost::CreateCorner(camera, p.in_marker, p.px, p.sigma, intrinsics);
    std::vector<double*> blocks = {rig_from_object_[p.frame].data(), rig_from_cam_[p.camera].data(),
                                   layout_[p.layout].pose.data()};
    if (p.point == 4) blocks.push_back(&layout_[p.layout].height);
    if (intrinsics) blocks.push_back(intrinsics_[p.camera].data());
    p.id =
        problem_->AddResidualBlock(new RigMarkerPointCost(point),
                                   robust ? new ceres::CauchyLoss(o_.loss_scale) : nullptr, blocks);
  }
  double* reference = rig_from_cam_[o_.reference_camera].data();
  if (!problem_->HasParameterBlock(reference)) problem_->AddParameterBlock(reference, 6);
  problem_->SetParameterBlockConstant(reference);
  for (LayoutBlock& b : layout_) {
    if (problem_->HasParameterBlock(b.pose.data()))
      problem_->SetParameterBlockConstant(b.pose.data());
    if (problem_->HasParameterBlock(&b.height)) problem_->SetParameterBlockConstant(&b.height);
  }
  for (std::vector<double>& v : intrinsics_)
    if (!v.empty() && problem_->HasParameterBlock(v.data()))
      problem_->SetParameterBlockConstant(v.data());
}

Status Solver::Solve(bool robust) {
  BuildProblem(robust);
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_SCHUR;
  auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
  std::vector<double*> all;
  problem_->GetParameterBlocks(&all);
  for (double* b : all) ordering->AddElementToGroup(b, 1);
  for (size_t f = 0; f < rig_from_object_.size(); ++f)
    if (problem_->HasParameterBlock(rig_from_object_[f].data()))
      ordering->AddElementToGroup(rig_from_object_[f].data(), 0);
  so.linear_solver_ordering = ordering;
  so.max_num_iterations = o_.max_iterations;
  so.function_tolerance = 1e-10;
  so.gradient_tolerance = 1e-12;
  so.parameter_tolerance = 1e-10;
  so.num_threads = o_.num_threads;
  so.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(so, problem_.get(), &summary);
  S_.iterations += static_cast<int>(summary.iterations.size()) - 1;
  if (robust) S_.initial_cost = summary.initial_cost;
  S_.final_cost = summary.final_cost;
  if (!summary.IsSolutionUsable() || summary.termination_type == ceres::FAILURE)
    return Fail("the rig survey's solve failed: " + summary.message);
  return Status::Ok();
}

void Solver::EvaluatePoints() {
  for (PointObs& p : points_) {
    if (!p.id) continue;
    double r[2];
    double cost = 0;
    if (!problem_->EvaluateResidualBlock(p.id, false, &cost, r, nullptr)) {
      p.norm = std::numeric_limits<double>::infinity();
      continue;
    }
    p.norm = std::hypot(r[0], r[1]);
  }
}

void Solver::RejectOutliers() {
  EvaluatePoints();
  std::vector<double> norms;
  for (const PointObs& p : points_)
    if (p.id) norms.push_back(p.norm);
  if (norms.empty()) return;
  std::nth_element(norms.begin(), norms.begin() + norms.size() / 2, norms.end());
  // The median of |r| of a 2D standard normal is 1.1774.
  const double scale = norms[norms.size() / 2] / 1.1774;
  const double threshold = o_.outlier_sigmas * std::max(scale, 1.0);
  std::map<std::pair<int, int>, int> rejected_in;  // (frame, observation) -> points rejected
  for (PointObs& p : points_) {
    if (p.id && p.norm > threshold) {
      p.rejected = true;
      ++rejected_in[{p.frame, p.observation}];
    }
  }
  // Two or more bad points: the marker itself is wrong (a misread ID, a flipped corner order).
  for (PointObs& p : points_)
    if (auto it = rejected_in.find({p.frame, p.observation});
        it != rejected_in.end() && it->second >= 2)
      p.rejected = true;
}

Status Solver::ComputeCovariance() {
  const int n = static_cast<int>(cameras_.size());
  // The columns: time steps, estimated cameras, then the fixed errors' blocks, evaluated as
  // variables for their Jacobian.
  ceres::Problem::EvaluateOptions eo;
  std::vector<int> frame_col;
  for (size_t f = 0; f < rig_from_object_.size(); ++f)
    if (problem_->HasParameterBlock(rig_from_object_[f].data())) {
      frame_col.push_back(static_cast<int>(f));
      eo.parameter_blocks.push_back(rig_from_object_[f].data());
    }
  std::vector<int> cams;
  for (int c = 0; c < n; ++c) {
    if (c == o_.reference_camera) continue;
    if (!problem_->HasParameterBlock(rig_from_cam_[c].data()))
      return Fail(CameraName(c) + " has no point left after outlier rejection");
    cams.push_back(c);
    eo.parameter_blocks.push_back(rig_from_cam_[c].data());
  }
  // Fixed errors: (block, size, covariance in the block's coordinates).
  struct Fixed {
    double* block;
    int size;
    Eigen::MatrixXd covariance;
  };
  std::vector<Fixed> fixed;
  if (o_.measurement.use_layout_covariance) {
    for (LayoutBlock& b : layout_) {
      if (b.has_covariance && problem_->HasParameterBlock(b.pose.data())) {
        fixed.push_back({b.pose.data(), 6, b.covariance});
        S_.layout_in_covariance = true;
      }
      if (b.height_sigma > 0 && problem_->HasParameterBlock(&b.height)) {
        fixed.push_back(
            {&b.height, 1, Eigen::MatrixXd::Constant(1, 1, b.height_sigma * b.height_sigma)});
        S_.layout_in_covariance = true;
      }
    }
  }
  for (int c = 0; c < n; ++c) {
    if (!calibration_[c] || !problem_->HasParameterBlock(intrinsics_[c].data())) continue;
    const Eigen::MatrixXd& L = cameras_[c].camera->intrinsics_covariance_factor();
    fixed.push_back(
        {intrinsics_[c].data(), static_cast<int>(intrinsics_[c].size()), L * L.transpose()});
    S_.calibration_in_covariance = true;
  }
  for (const Fixed& f : fixed) {
    eo.parameter_blocks.push_back(f.block);
    problem_->SetParameterBlockVariable(f.block);
  }
  ceres::CRSMatrix crs;
  const bool evaluated = problem_->Evaluate(eo, nullptr, nullptr, nullptr, &crs);
  for (const Fixed& f : fixed) problem_->SetParameterBlockConstant(f.block);
  if (!evaluated) return Fail("the Jacobian at the optimum could not be evaluated");

  Eigen::SparseMatrix<double, Eigen::RowMajor> J(crs.num_rows, crs.num_cols);
  {
    std::vector<Eigen::Triplet<double>> t;
    t.reserve(crs.values.size());
    for (int r = 0; r < crs.num_rows; ++r)
      for (int k = crs.rows[r]; k < crs.rows[r + 1]; ++k)
        t.emplace_back(r, crs.cols[k], crs.values[k]);
    J.setFromTriplets(t.begin(), t.end());
  }
  const Eigen::SparseMatrix<double> Jc = J;
  const Eigen::SparseMatrix<double> H = Jc.transpose() * Jc;
  const int nt = 6 * static_cast<int>(frame_col.size());
  const int nc = 6 * static_cast<int>(cams.size());
  const int nr = crs.num_cols - nt;
  // The time steps eliminated: S = H_rr - sum_t H_rt A_t^-1 H_tr over the rest (cameras and
  // fixed-error blocks).
  const Eigen::MatrixXd D = Eigen::MatrixXd(H.rightCols(nr));
  Eigen::MatrixXd S = D.bottomRows(nr);
  for (size_t i = 0; i < frame_col.size(); ++i) {
    const int o = 6 * static_cast<int>(i);
    const Mat6 A = Eigen::MatrixXd(H.block(o, o, 6, 6));
    const Eigen::Matrix<double, 6, Eigen::Dynamic> B = D.middleRows(o, 6);
    Eigen::Matrix<double, 6, Eigen::Dynamic> A_inv_B;
    Vector6d d;
    if (!SolveLdlt(A, B, &A_inv_B, &d) || d.minCoeff() <= 1e-12 * d.maxCoeff())
      return Fail("frame " + std::to_string(frame_col[i]) +
                  ": rig_from_object is not determined by its points");
    S.noalias() -= B.transpose() * A_inv_B;
  }
  const Eigen::MatrixXd Scc = 0.5 * (S.topLeftCorner(nc, nc) + S.topLeftCorner(nc, nc).transpose());
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(Scc);
  const Eigen::VectorXd ev = es.eigenvalues();
  if (nc > 0 && !(ev(0) > 1e-12 * ev(nc - 1))) {
    // The least determined direction: which camera it moves most.
    const Eigen::VectorXd v = es.eigenvectors().col(0);
    int worst = 0;
    for (int i = 0; i < nc; ++i)
      if (std::abs(v(i)) > std::abs(v(worst))) worst = i;
    return Fail("the extrinsics are not determined: " + CameraName(cams[worst / 6]) +
                "'s rig_from_cam has a direction the frames do not constrain (check that it sees "
                "the object at several poses together with another camera)");
  }
  const Eigen::MatrixXd Scc_inv =
      es.eigenvectors() * ev.cwiseInverse().asDiagonal() * es.eigenvectors().transpose();
  // Each fixed error e_p moves the cameras by d x = -S_cc^-1 S_cp e_p (the implicit function
  // theorem at the optimum); its share M Sigma_p M^T is not the frames' noise and is not scaled.
  // What the fit cannot absorb of it stays in the residuals: its expected chi-square,
  // tr((S_pp - S_pc S_cc^-1 S_cp) Sigma_p), is taken out of chi2 before the noise's variance
  // factor is estimated, so that the layout's and calibration's errors are not counted twice.
  const int np = nr - nc;
  const Eigen::MatrixXd M = Scc_inv * S.topRightCorner(nc, np);
  const Eigen::MatrixXd S_pp = S.bottomRightCorner(np, np) - S.bottomLeftCorner(np, nc) * M;
  Eigen::MatrixXd fixed_share = Eigen::MatrixXd::Zero(nc, nc);
  S_.fixed_chi2 = 0;
  int col = 0;
  for (const Fixed& f : fixed) {
    const Eigen::MatrixXd Mb = M.middleCols(col, f.size);
    fixed_share.noalias() += Mb * f.covariance * Mb.transpose();
    S_.fixed_chi2 += (S_pp.block(col, col, f.size, f.size) * f.covariance).trace();
    col += f.size;
  }
  S_.variance_factor = S_.dof > 0 ? S_.chi2 / S_.dof : 1.0;
  S_.noise_variance_factor =
      S_.dof > 0 ? std::max(MinNoiseVarianceFactor(S_.dof), (S_.chi2 - S_.fixed_chi2) / S_.dof)
                 : 1.0;
  S_.covariance_scaled = o_.scale_covariance && S_.dof > 0;
  const Eigen::MatrixXd C =
      (S_.covariance_scaled ? S_.noise_variance_factor : 1.0) * Scc_inv + fixed_share;
  const Block6& ref = rig_from_cam_[o_.reference_camera];
  const std::optional<PoseCovariance>& ref_cov =
      cameras_[o_.reference_camera].rig_from_cam_covariance;
  S_.reference_in_covariance = o_.use_reference_covariance && ref_cov.has_value();
  for (size_t i = 0; i < cams.size(); ++i) {
    const int c = cams[i];
    const Mat6 T = TangentFromBlock(rig_from_cam_[c]);
    PoseCovariance cov = T * C.block<6, 6>(6 * i, 6 * i) * T.transpose();
    if (S_.reference_in_covariance) {
      // rig_from_cam_c = rig_from_ref ref_from_cam_c: the reference's error e = [e_rot, e_trans]
      // moves camera c by [e_rot, e_trans - [t_c - t_ref]x e_rot].
      Mat6 A = Mat6::Identity();
      A.bottomLeftCorner<3, 3>() =
          -Skew(Eigen::Vector3d(rig_from_cam_[c][3] - ref[3], rig_from_cam_[c][4] - ref[4],
                                rig_from_cam_[c][5] - ref[5]));
      cov += A * *ref_cov * A.transpose();
    }
    R_.cameras[c].covariance = 0.5 * (cov + cov.transpose());
  }
  R_.cameras[o_.reference_camera].covariance = ref_cov;
  return Status::Ok();
}

void Solver::FillResult() {
  const int n = static_cast<int>(cameras_.size());
  R_.cameras.assign(n, RigSurveyCamera{});
  std::vector<std::vector<bool>> camera_frames(n, std::vector<bool>(frames_.size(), false));
  std::vector<std::map<std::pair<int, int>, bool>> markers(n);
  std::vector<double> ss_px(n, 0), ss(n, 0);
  for (const PointObs& p : points_) {
    RigSurveyCamera& c = R_.cameras[p.camera];
    if (!p.id) {
      if (p.rejected && frame_used_[p.frame]) ++c.points_rejected;
      continue;
    }
    ++c.points;
    camera_frames[p.camera][p.frame] = true;
    markers[p.camera][{p.frame, p.observation}] = true;
    ss[p.camera] += p.norm * p.norm;
    ss_px[p.camera] += p.norm * p.sigma * p.norm * p.sigma;
  }
  for (int c = 0; c < n; ++c) {
    RigSurveyCamera& out = R_.cameras[c];
    out.rig_from_cam = FromBlock(rig_from_cam_[c]);
    out.reference = c == o_.reference_camera;
    out.frames =
        static_cast<int>(std::count(camera_frames[c].begin(), camera_frames[c].end(), true));
    out.markers = static_cast<int>(markers[c].size());
    if (out.points > 0) {
      out.rms_px = std::sqrt(ss_px[c] / (2.0 * out.points));
      out.rms_normalised = std::sqrt(ss[c] / (2.0 * out.points));
    }
  }
  R_.rig_from_object.assign(frames_.size(), std::nullopt);
  S_.frames_used = 0;
  for (size_t f = 0; f < frames_.size(); ++f)
    if (problem_->HasParameterBlock(rig_from_object_[f].data())) {
      R_.rig_from_object[f] = FromBlock(rig_from_object_[f]);
      ++S_.frames_used;
    }
  S_.residuals = 0;
  S_.chi2 = 0;
  for (const PointObs& p : points_)
    if (p.id) {
      S_.residuals += 2;
      S_.chi2 += p.norm * p.norm;
    }
  S_.parameters = 6 * S_.frames_used + 6 * (n - 1);
  S_.dof = S_.residuals - S_.parameters;
  S_.rms_normalised = S_.residuals > 0 ? std::sqrt(S_.chi2 / S_.residuals) : 0;
  S_.variance_factor = S_.dof > 0 ? S_.chi2 / S_.dof : 1.0;
}

Status Solver::Run() {
  const auto start = std::chrono::steady_clock::now();
  if (Status s = CollectPoints(); !s) return s;
  if (Status s = Initialise(); !s) return s;
  if (Status s = Solve(true); !s) return s;
  if (o_.reject_outliers) {
    RejectOutliers();
    UpdateTipOffsets();
  }
  if (Status s = Solve(false); !s) return s;
  EvaluatePoints();
  FillResult();
  if (Status s = ComputeCovariance(); !s) return s;
  S_.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  S_.success = true;
  return Status::Ok();
}

}  // namespace

Status RigSurveyOptions::Check() const {
  if (reference_camera < 0) return Status::Error("reference_camera: expected 0 or more");
  if (!(loss_scale > 0)) return Status::Error("loss_scale: expected a positive number");
  if (!(outlier_sigmas > 0)) return Status::Error("outlier_sigmas: expected a positive number");
  if (!(init_inlier_angle_deg > 0) || !(init_inlier_distance > 0))
    return Status::Error("init_inlier_angle_deg, init_inlier_distance: expected positive numbers");
  if (max_iterations < 1 || num_threads < 1)
    return Status::Error("max_iterations, num_threads: expected 1 or more");
  return Status::Ok();
}

Status SurveyRig(const std::vector<RigCameraView>& cameras,
                 const std::vector<RigSurveyFrame>& frames, const RigSurveyOptions& options,
                 RigSurveyResult* result) {
  *result = RigSurveyResult{};
  auto fail = [&](const std::string& m) {
    result->summary.message = m;
    return Status::Error(m);
  };
  if (Status s = options.Check(); !s) return fail(s.message());
  if (cameras.size() < 2)
    return fail("the rig has " + std::to_string(cameras.size()) +
                " camera(s): a survey of its extrinsics needs at least 2 (one is the reference)");
  if (options.reference_camera >= static_cast<int>(cameras.size()))
    return fail("reference_camera " + std::to_string(options.reference_camera) + ": the rig has " +
                std::to_string(cameras.size()) + " cameras");
  for (size_t c = 0; c < cameras.size(); ++c)
    if (!cameras[c].camera) return fail("camera " + std::to_string(c) + " has no camera model");
  Solver solver(cameras, frames, options, result);
  return solver.Run();
}

RigSurveyFrame RigSurveyFrameFromImages(const RigPoseEstimator& estimator,
                                        const std::vector<cv::Mat>& images, double timestamp) {
  RigSurveyFrame frame;
  frame.timestamp = timestamp;
  FrameResult detected;
  for (size_t c = 0; c < images.size() && c < estimator.num_cameras(); ++c) {
    if (images[c].empty()) continue;
    estimator.camera(c).Estimate(images[c], timestamp, &detected);
    for (MarkerObservation& m :
         ObservationsFromDetections(detected.detections, estimator.layouts()[0])) {
      m.camera = static_cast<int>(c);
      frame.observations.push_back(std::move(m));
    }
  }
  return frame;
}

std::vector<RigCameraView> RigSurveyViews(const RigPoseEstimator& estimator) {
  std::vector<RigCameraView> views(estimator.num_cameras());
  for (size_t c = 0; c < views.size(); ++c) {
    const RigCamera& rc = estimator.rig().cameras[c];
    views[c] = {&estimator.camera(c).camera(), rc.rig_from_cam, rc.rig_from_cam_covariance};
  }
  return views;
}

}  // namespace svms
