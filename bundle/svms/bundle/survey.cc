#include "svms/bundle/survey.h"

#include <ceres/ceres.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <map>
#include <memory>
#include <set>
#include <sstream>

#include "svms/bundle/cost_functions.h"
#include "svms/bundle/view_graph.h"
#include "svms/detect/marker_pose.h"
#include "svms/geometry/alignment.h"
#include "svms/geometry/pose_matrix.h"
#include "svms/geometry/quad_sides.h"
#include "svms/geometry/so3.h"

namespace svms {
namespace {

using Clock = std::chrono::steady_clock;
double Seconds(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double>(b - a).count();
}

constexpr const char* kPointNames[5] = {"tl", "tr", "br", "bl", "tip"};

// A marker of the survey (an outer marker, or the inner marker of a dual).
struct MarkerInfo {
  MarkerModel model;    // for an inner marker: InnerModel()
  int post_owner = -1;  // ID of the marker whose frame holds the post, -1 without a post
  int outer_id = -1;    // for an inner marker
};

// One observed point: a corner (0-3) or the tip (4) of a marker in an image.
struct PointObs {
  int image = 0;
  int marker_id = -1;    // the marker whose frame the point is in (for a tip: the post owner)
  int detected_id = -1;  // the detection it came from (differs for an inner marker's tip)
  int detection = 0;     // global index of the detection
  int point = 0;
  Eigen::Vector2d px;
  double sigma = 1;
  Eigen::Vector2d tip_xy = Eigen::Vector2d::Zero();  // concave well offset, see MarkerPointCost
  // SurveyOptions::corner_repeat_px_grey: the corner's outward direction in the image (unit:
  // from the detection's centre through it) and the sigma of the marker's repeated shift in
  // this view, corner_repeat_px_grey / this detection's contrast (pixels); 0 for a tip or a
  // detection without grey levels.
  Eigen::Vector2d outward = Eigen::Vector2d::Zero();
  double repeat_px = 0;
  bool rejected = false;
  double residual = 0;  // |r| / sigma after the last solve
};

using Block6 = std::array<double, 6>;

Block6 ToBlock(const Pose& p) {
  return {p.rvec(0), p.rvec(1), p.rvec(2), p.tvec(0), p.tvec(1), p.tvec(2)};
}
Pose FromBlock(const Block6& b) {
  return Pose{Eigen::Vector3d(b[0], b[1], b[2]), Eigen::Vector3d(b[3], b[4], b[5])};
}

// Keeps the camera the costs project through in step with the intrinsics block.
class IntrinsicsSync : public ceres::EvaluationCallback {
 public:
  IntrinsicsSync(CameraModel* camera, const std::vector<double>* intrinsics)
      : camera_(camera), intrinsics_(intrinsics) {}
  void PrepareForEvaluation(bool, bool new_point) override {
    if (!new_point || *intrinsics_ == camera_->intrinsics()) return;
    CameraModel updated;
    if (CameraModel::Create(camera_->lensmodel(), *intrinsics_, camera_->width(), camera_->height(),
                            &updated))
      *camera_ = updated;
  }

 private:
  CameraModel* camera_;
  const std::vector<double>* intrinsics_;
};

std::string Join(const std::vector<int>& v) {
  std::string s;
  for (size_t i = 0; i < v.size(); ++i) s += (i ? " " : "") + std::to_string(v[i]);
  return s;
}

// Everything the solve works on.
class Solver {
 public:
  Solver(const std::vector<SurveyImage>& images, const CameraModel& camera,
         const SurveyOptions& options, const SurveyConfig& config, SurveyResult* result)
      : images_(images), options_(options), config_(config), R_(*result), S_(result->summary) {
    work_camera_ = camera;
    intrinsics_ = camera.intrinsics();
    calibration_term_ = !config_.refine_intrinsics && options_.use_calibration_covariance &&
                        camera.intrinsics_covariance_factor().size() > 0;
  }

  Status Run(const std::vector<MarkerModel>& models);

 private:
  Status Fail(const std::string& m) {
    S_.success = false;
    S_.message = m;
    return Status::Error(m);
  }
  Status SetUpMarkers(const std::vector<MarkerModel>& models);
  Status CollectObservations();
  Status Initialise();
  // Adds the residuals of the points not rejected; `robust` selects the first solve's loss.
  void BuildProblem(bool robust);
  Status Solve(bool robust, double* cost, int* iterations, std::string* report);
  void UpdateTipOffsets();
  void EvaluatePoints();
  void RejectOutliers();
  Status ComputeCovariance();
  // The parameters other than the camera poses, in the order of the reduced system.
  struct ReducedParam {
    const double* block;
    int size;
    std::string name;
  };
  // The reduced (camera-eliminated) system: see RankDeficiency().
  struct ReducedSystem {
    std::vector<ReducedParam> params;
    std::map<const double*, int> offset;  // block -> first row in the reduced system
    // (J^T J)^-1 restricted to `params`, in the residuals' sigma units (not yet scaled by the
    // variance factor); empty when the system is rank deficient.
    Eigen::MatrixXd covariance;
    // With the calibration term: S L, S = d params / d intrinsics (the rows of `params`), L the
    // camera's intrinsics covariance factor; S L L^T S^T is the calibration's share.
    Eigen::MatrixXd calibration;
    // With the repeated corner error (SurveyOptions::corner_repeat_px_grey): S = d params /
    // d shifts, one column per marker with a repeat_px (its shift, of unit variance, moves its
    // corners in each view by that view's repeat_px); S S^T is that error's share.
    Eigen::MatrixXd repeat;
  };
  std::string RankDeficiency(ReducedSystem* reduced);
  // RankDeficiency's steps. The Jacobian it reduces, and what it knows of its rows and columns.
  struct ReducedJacobian {
    ceres::CRSMatrix crs;
    bool calibration = false;       // the calibration term's intrinsics columns follow the reduced
    int nt = 0;                     // its number of columns (0 without it)
    std::map<int, int> repeat_col;  // marker ID -> its shift column after the intrinsics'
    int nb = 0;                     // number of shift columns
    std::vector<std::pair<int, int>> row_of;  // row -> (index in points_, axis); points only
  };
  // J^T J over the cameras and the reduced parameters: per camera H_cc and its coupling H_rc
  // (reduced row -> row of H), S = H_rr (nr x nr), and the couplings to the intrinsics and
  // shifts: H_rt (nr x (nt + nb)), H_ct per camera.
  struct ReducedNormal {
    using Row6 = Eigen::Matrix<double, 1, 6>;
    int nr = 0;
    std::vector<Eigen::Matrix<double, 6, 6>> Hcc;
    std::vector<std::map<int, Row6>> Hrc;
    Eigen::MatrixXd S, Hrt;
    std::vector<Eigen::MatrixXd> Hct;
  };
  void ReducedParams(std::vector<ReducedParam>* cams, ReducedSystem* reduced);
  bool EvaluateReducedJacobian(const std::vector<ReducedParam>& cams,
                               const std::vector<ReducedParam>& rest, ReducedJacobian* jac);
  void AccumulateReducedNormal(const ReducedJacobian& jac, int ncams, ReducedNormal* h) const;
  static void EliminateCameras(const std::vector<ReducedParam>& cams, ReducedNormal* h,
                               std::vector<std::string>* found);
  static void NullDirections(const std::vector<ReducedParam>& rest, ReducedNormal* h,
                             Eigen::VectorXd* d, Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>* es,
                             std::vector<std::string>* found);
  void FillResult();
  bool Resolve(const NamedPoint& p, int* marker, double** h, Eigen::Vector3d* in_marker,
               std::string* why);

  const std::vector<SurveyImage>& images_;
  const SurveyOptions& options_;
  const SurveyConfig& config_;
  SurveyResult& R_;
  SurveySummary& S_;

  std::vector<MarkerModel> models_;           // as given, in order
  std::map<int, MarkerInfo> markers_;         // every ID (outer and inner) with a model
  std::set<int> surveyed_;                    // IDs surveyed
  std::map<int, Block6> object_from_marker_;  // per surveyed ID
  std::map<int, double> post_height_;         // per post owner (surveyed)
  std::map<int, double> post_drawn_;          // per post owner
  std::vector<Block6> cam_from_object_;       // per image
  std::vector<bool> image_used_;
  std::vector<ImageSightings> sightings_;  // per image, surveyed markers only
  std::vector<PointObs> points_;           // stable after CollectObservations
  std::vector<int> detection_image_;       // global detection index -> image
  CameraModel work_camera_;
  std::vector<double> intrinsics_;
  // The intrinsics are a constant parameter block of the problem, there for the Jacobian of the
  // calibration's share of the covariance (SurveyOptions::use_calibration_covariance).
  bool calibration_term_ = false;
  int root_ = -1;

  std::unique_ptr<IntrinsicsSync> sync_;
  std::unique_ptr<ceres::LossFunction> loss_;
  std::unique_ptr<ceres::Problem> problem_;
  std::vector<ceres::ResidualBlockId> point_blocks_;  // per point (nullptr when rejected)
};

Status Solver::SetUpMarkers(const std::vector<MarkerModel>& models) {
  models_ = models;
  for (const MarkerModel& m : models) {
    if (Status s = m.Validate("marker " + std::to_string(m.id) + ": "); !s)
      return Fail(s.message());
    MarkerInfo outer;
    outer.model = m;
    outer.model.inner.reset();
    if (m.post) outer.post_owner = m.id;
    if (!markers_.emplace(m.id, outer).second)
      return Fail("markers: ID " + std::to_string(m.id) + " appears twice; expected unique IDs");
    if (m.post) post_drawn_[m.id] = m.post->height;
    if (m.inner) {
      MarkerInfo inner;
      inner.model = *m.InnerModel();
      inner.outer_id = m.id;
      if (m.post) inner.post_owner = m.id;
      if (!markers_.emplace(m.inner->id, inner).second)
        return Fail("markers: ID " + std::to_string(m.inner->id) +
                    " appears twice; expected unique IDs");
    }
  }
  if (config_.gauge == SurveyConfig::Gauge::kReferenceMarker &&
      !markers_.count(config_.reference_id))
    return Fail("reference marker " + std::to_string(config_.reference_id) +
                " has no model; expected one of the markers given");
  for (int id : config_.fixed_markers)
    if (!markers_.count(id)) return Fail("fixed marker " + std::to_string(id) + " has no model");
  auto check_point = [&](const NamedPoint& p, const std::string& what) -> Status {
    auto it = markers_.find(p.marker_id);
    if (it == markers_.end())
      return Fail(what + " " + p.name + ": marker " + std::to_string(p.marker_id) +
                  " has no model");
    if (p.kind == NamedPoint::Kind::kTip && it->second.post_owner < 0)
      return Fail(what + " " + p.name + ": marker " + std::to_string(p.marker_id) + " has no post");
    return Status::Ok();
  };
  for (const ControlPoint& c : config_.control_points)
    if (Status s = check_point(c.point, "control point"); !s) return s;
  for (const ScaleBar& b : config_.scale_bars) {
    if (Status s = check_point(b.a, "scale bar end"); !s) return s;
    if (Status s = check_point(b.b, "scale bar end"); !s) return s;
  }
  return Status::Ok();
}

Status Solver::CollectObservations() {
  const int n = static_cast<int>(images_.size());
  S_.images_total = n;
  // Images per marker (detections with a model and a single-marker pose).
  std::map<int, std::set<int>> images_of;
  for (int i = 0; i < n; ++i)
    for (const Detection& d : images_[i].detections)
      if (markers_.count(d.id) && d.cam_from_marker) images_of[d.id].insert(i);
  for (const auto& [id, info] : markers_) {
    const int k = images_of.count(id) ? static_cast<int>(images_of[id].size()) : 0;
    if (k >= 2)
      surveyed_.insert(id);
    else
      S_.left_out.emplace_back(id, "seen in " + std::to_string(k) +
                                       (k == 1 ? " image" : " images") + "; at least 2 are needed");
  }
  sightings_.assign(n, {});
  for (int i = 0; i < n; ++i)
    for (const Detection& d : images_[i].detections)
      if (surveyed_.count(d.id) && d.cam_from_marker)
        sightings_[i].push_back(
            MarkerSighting{d.id, *d.cam_from_marker, d.side_px(), d.pose_ambiguous});

  // The view graph.
  S_.components = ConnectedComponents(sightings_);
  if (S_.components.empty())
    return Fail("nothing to survey: no marker with a model is seen in two or more images");
  if (config_.gauge == SurveyConfig::Gauge::kReferenceMarker) {
    root_ = config_.reference_id;
    if (!surveyed_.count(root_)) {
      const int k = images_of.count(root_) ? static_cast<int>(images_of[root_].size()) : 0;
      return Fail("reference marker " + std::to_string(root_) + " is seen in " + std::to_string(k) +
                  (k == 1 ? " image" : " images") + "; at least 2 are needed");
    }
  }
  if (S_.components.size() > 1) {
    const std::string desc = DescribeComponents(S_.components, sightings_);
    if (!config_.drop_disconnected)
      return Fail("the view graph is disconnected: " + std::to_string(S_.components.size()) +
                  " groups of markers are never seen together in one image: " + desc +
                  "; add images that see markers of both groups (or drop the others)");
    // Keep the reference's component (control points: the largest).
    size_t keep = 0;
    for (size_t c = 0; c < S_.components.size(); ++c)
      if (std::count(S_.components[c].begin(), S_.components[c].end(), root_)) keep = c;
    for (size_t c = 0; c < S_.components.size(); ++c) {
      if (c == keep) continue;
      for (int id : S_.components[c]) {
        surveyed_.erase(id);
        S_.left_out.emplace_back(
            id, "not seen together with the reference's group {" + Join(S_.components[keep]) + "}");
      }
    }
    for (ImageSightings& im : sightings_)
      im.erase(
          std::remove_if(im.begin(), im.end(),
                         [&](const MarkerSighting& s) { return !surveyed_.count(s.marker_id); }),
          im.end());
  }
  if (root_ < 0) {  // control points: the most seen marker roots the initial layout
    size_t most = 0;
    for (int id : surveyed_)
      if (images_of[id].size() > most) {
        most = images_of[id].size();
        root_ = id;
      }
  }
  for (const ControlPoint& c : config_.control_points) {
    const int owner = c.point.kind == NamedPoint::Kind::kTip
                          ? markers_.at(c.point.marker_id).post_owner
                          : c.point.marker_id;
    if (!surveyed_.count(owner))
      return Fail("control point " + c.point.name + ": marker " + std::to_string(owner) +
                  " is not surveyed (left out)");
  }
  for (const ScaleBar& b : config_.scale_bars)
    for (const NamedPoint* p : {&b.a, &b.b}) {
      const int owner =
          p->kind == NamedPoint::Kind::kTip ? markers_.at(p->marker_id).post_owner : p->marker_id;
      if (!surveyed_.count(owner))
        return Fail("scale bar end " + p->name + ": marker " + std::to_string(owner) +
                    " is not surveyed (left out)");
    }

  // Points.
  int detection = 0;
  for (int i = 0; i < n; ++i) {
    std::set<int> tip_seen;  // post owners whose tip this image already gave
    for (const Detection& d : images_[i].detections) {
      if (!surveyed_.count(d.id) || !d.cam_from_marker) continue;
      const MarkerInfo& info = markers_.at(d.id);
      // In the image's own grey levels: its integer steps are what the shift comes from.
      const double repeat_px = options_.corner_repeat_px_grey > 0 && d.white > d.black
                                   ? options_.corner_repeat_px_grey / (d.white - d.black)
                                   : 0.0;
      const Eigen::Vector2d centre = QuadCentroid(d.corners);
      for (int k = 0; k < 4; ++k) {
        PointObs p;
        p.image = i;
        p.marker_id = p.detected_id = d.id;
        p.detection = detection;
        p.point = k;
        p.px = d.corners[k];
        if ((p.px - centre).norm() > 0) p.outward = (p.px - centre).normalized();
        p.repeat_px = repeat_px;
        p.sigma = options_.corner_sigma_from_fit && d.corner_sigma[k] > 0
                      ? std::max(options_.min_corner_sigma_px,
                                 options_.corner_fit_scale * d.corner_sigma[k])
                      : options_.corner_sigma_px;
        points_.push_back(p);
      }
      if (d.tip && info.post_owner >= 0 && surveyed_.count(info.post_owner) &&
          tip_seen.insert(info.post_owner).second) {
        PointObs p;
        p.image = i;
        p.marker_id = info.post_owner;
        p.detected_id = d.id;
        p.detection = detection;
        p.point = 4;
        p.px = d.tip->pixel;
        p.sigma = std::max(options_.min_tip_sigma_px, d.tip->sigma_px);
        points_.push_back(p);
      }
      detection_image_.push_back(i);
      ++detection;
    }
  }
  S_.detections_used = detection;
  for (int id : surveyed_)
    if (markers_.at(id).post_owner == id) post_height_[id] = post_drawn_.at(id);
  return Status::Ok();
}

bool Solver::Resolve(const NamedPoint& p, int* marker, double** h, Eigen::Vector3d* in_marker,
                     std::string* why) {
  const MarkerInfo& info = markers_.at(p.marker_id);
  *h = nullptr;
  if (p.kind == NamedPoint::Kind::kTip) {
    *marker = info.post_owner;
    *h = &post_height_.at(info.post_owner);
    *in_marker = Eigen::Vector3d(0, 0, **h);
    return true;
  }
  *marker = p.marker_id;
  return NamedPointInMarker(p, info.model, in_marker) || (*why = "no such point", false);
}

Status Solver::Initialise() {
  const double deg = M_PI / 180;
  std::map<int, Pose> layout = SpanningTreeLayout(
      sightings_, root_, options_.init_inlier_angle_deg * deg, options_.init_inlier_distance);
  for (int id : std::set<int>(surveyed_))
    if (!layout.count(id)) {  // cannot happen for a connected graph; kept for safety
      surveyed_.erase(id);
      S_.left_out.emplace_back(id, "not reached by the spanning tree");
    }
  // Control points: move the initial layout onto them.
  Pose object_from_root;
  if (config_.gauge == SurveyConfig::Gauge::kControlPoints) {
    std::vector<Eigen::Vector3d> a, b;
    for (const ControlPoint& c : config_.control_points) {
      int marker;
      double* h;
      Eigen::Vector3d in_marker;
      std::string why;
      Resolve(c.point, &marker, &h, &in_marker, &why);
      a.push_back(layout.at(marker) * in_marker);
      b.push_back(c.point_in_object);
    }
    object_from_root = FitRigidTransform(a, b);
  }
  for (auto& [id, pose] : layout) {
    pose = object_from_root * pose;
    object_from_marker_[id] = ToBlock(pose);
  }
  cam_from_object_.assign(images_.size(), Block6{});
  image_used_.assign(images_.size(), false);
  for (size_t i = 0; i < images_.size(); ++i) {
    Pose cam;
    if (InitialCameraPose(sightings_[i], layout, &cam)) {
      cam_from_object_[i] = ToBlock(cam);
      image_used_[i] = true;
    }
  }
  R_.initial_layout.name = "initial";
  for (const auto& [id, pose] : layout)
    R_.initial_layout.markers.push_back(
        LayoutEntry{markers_.at(id).model, pose, std::nullopt, std::nullopt});
  UpdateTipOffsets();
  return Status::Ok();
}

void Solver::UpdateTipOffsets() {
  for (PointObs& p : points_) {
    if (p.point != 4) continue;
    MarkerModel m = markers_.at(p.marker_id).model;
    if (!m.post || !m.post->concave()) continue;
    m.post->height = post_height_.at(p.marker_id);
    const Pose cam_from_marker =
        FromBlock(cam_from_object_[p.image]) * FromBlock(object_from_marker_.at(p.marker_id));
    double fraction = 0;
    p.tip_xy = VisibleTipPoint(m, cam_from_marker.Inverse().tvec, &fraction).head<2>();
  }
}

void Solver::BuildProblem(bool robust) {
  ceres::Problem::Options po;
  po.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  po.enable_fast_removal = false;
  if (config_.refine_intrinsics) {
    sync_ = std::make_unique<IntrinsicsSync>(&work_camera_, &intrinsics_);
    po.evaluation_callback = sync_.get();
  }
  problem_ = std::make_unique<ceres::Problem>(po);
  loss_.reset();
  if (robust && options_.loss == "cauchy")
    loss_ = std::make_unique<ceres::CauchyLoss>(options_.loss_scale);
  else if (robust && options_.loss == "huber")
    loss_ = std::make_unique<ceres::HuberLoss>(options_.loss_scale);
  ceres::Problem& P = *problem_;
  const bool intrinsics_block = config_.refine_intrinsics || calibration_term_;
  point_blocks_.assign(points_.size(), nullptr);
  for (size_t k = 0; k < points_.size(); ++k) {
    PointObs& p = points_[k];
    if (p.rejected || !image_used_[p.image]) continue;
    std::vector<double*> blocks = {cam_from_object_[p.image].data(),
                                   object_from_marker_.at(p.marker_id).data()};
    MarkerPointCost* cost;
    if (p.point == 4) {
      cost = MarkerPointCost::CreateTip(&work_camera_, &p.tip_xy, p.px, p.sigma, intrinsics_block);
      blocks.push_back(&post_height_.at(p.marker_id));
    } else {
      cost = MarkerPointCost::CreateCorner(&work_camera_,
                                           markers_.at(p.marker_id).model.Corners()[p.point], p.px,
                                           p.sigma, intrinsics_block);
    }
    if (intrinsics_block) blocks.push_back(intrinsics_.data());
    point_blocks_[k] = P.AddResidualBlock(cost, loss_.get(), blocks);
  }
  if (calibration_term_ && P.HasParameterBlock(intrinsics_.data()))
    P.SetParameterBlockConstant(intrinsics_.data());
  for (auto& [id, h] : post_height_) {
    P.AddResidualBlock(
        PostHeightPriorCost::Create(post_drawn_.at(id), options_.post_height_prior_sigma), nullptr,
        &h);
    if (!config_.estimate_post_heights) P.SetParameterBlockConstant(&h);
  }
  for (const ScaleBar& b : config_.scale_bars) {
    int ma, mb;
    double *ha, *hb;
    Eigen::Vector3d pa, pb;
    std::string why;
    Resolve(b.a, &ma, &ha, &pa, &why);
    Resolve(b.b, &mb, &hb, &pb, &why);
    std::vector<double*> blocks = {object_from_marker_.at(ma).data()};
    if (ha) blocks.push_back(ha);
    blocks.push_back(object_from_marker_.at(mb).data());
    if (hb) blocks.push_back(hb);
    P.AddResidualBlock(ScaleBarCost::Create(b, pa, pb), nullptr, blocks);
  }
  for (const ControlPoint& c : config_.control_points) {
    int m;
    double* h;
    Eigen::Vector3d in_marker;
    std::string why;
    Resolve(c.point, &m, &h, &in_marker, &why);
    std::vector<double*> blocks = {object_from_marker_.at(m).data()};
    if (h) blocks.push_back(h);
    P.AddResidualBlock(ControlPointCost::Create(c, in_marker), nullptr, blocks);
  }
  if (config_.gauge == SurveyConfig::Gauge::kReferenceMarker)
    P.SetParameterBlockConstant(object_from_marker_.at(root_).data());
  for (int id : config_.fixed_markers)
    if (object_from_marker_.count(id) && P.HasParameterBlock(object_from_marker_.at(id).data()))
      P.SetParameterBlockConstant(object_from_marker_.at(id).data());
}

Status Solver::Solve(bool robust, double* cost, int* iterations, std::string* report) {
  BuildProblem(robust);
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::SPARSE_SCHUR;
  if (ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::SUITE_SPARSE))
    so.sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
  auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
  for (size_t i = 0; i < cam_from_object_.size(); ++i)
    if (problem_->HasParameterBlock(cam_from_object_[i].data()))
      ordering->AddElementToGroup(cam_from_object_[i].data(), 0);
  for (auto& [id, b] : object_from_marker_)
    if (problem_->HasParameterBlock(b.data())) ordering->AddElementToGroup(b.data(), 1);
  for (auto& [id, h] : post_height_)
    if (problem_->HasParameterBlock(&h)) ordering->AddElementToGroup(&h, 1);
  if (problem_->HasParameterBlock(intrinsics_.data()))
    ordering->AddElementToGroup(intrinsics_.data(), 1);
  so.linear_solver_ordering = ordering;
  so.max_num_iterations = options_.max_iterations;
  so.function_tolerance = options_.function_tolerance;
  so.gradient_tolerance = options_.gradient_tolerance;
  so.parameter_tolerance = options_.parameter_tolerance;
  so.num_threads = options_.num_threads;
  so.minimizer_progress_to_stdout = false;
  so.logging_type = options_.verbose ? ceres::PER_MINIMIZER_ITERATION : ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(so, problem_.get(), &summary);
  *report = summary.BriefReport();
  *iterations = static_cast<int>(summary.iterations.size()) - 1;
  *cost = summary.final_cost;
  if (robust) S_.initial_cost = summary.initial_cost;
  if (!summary.IsSolutionUsable() || summary.termination_type == ceres::FAILURE)
    return Fail("the bundle adjustment failed: " + summary.message);
  return Status::Ok();
}

void Solver::EvaluatePoints() {
  for (size_t k = 0; k < points_.size(); ++k) {
    if (!point_blocks_[k]) continue;
    double r[2] = {0, 0}, c = 0;
    if (problem_->EvaluateResidualBlock(point_blocks_[k], false, &c, r, nullptr))
      points_[k].residual = std::hypot(r[0], r[1]);
    else
      points_[k].residual = 1e9;  // does not project any more
  }
}

void Solver::RejectOutliers() {
  EvaluatePoints();
  // Robust scale per kind (corners, tips): the median of |r| of a 2D normal is 1.1774 sigma.
  double thresh[2];
  for (int kind = 0; kind < 2; ++kind) {
    std::vector<double> v;
    for (size_t k = 0; k < points_.size(); ++k)
      if (point_blocks_[k] && (points_[k].point == 4) == (kind == 1))
        v.push_back(points_[k].residual);
    double scale = 1;
    if (!v.empty()) {
      std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
      scale = v[v.size() / 2] / 1.1774;
    }
    // Never tighter than the stated sigma: the detector's corners are often better than
    // 0.1 px on large markers, and a threshold at 5 times that would cut into the honest
    // residuals of small, oblique ones.
    thresh[kind] = options_.outlier_sigmas * std::max(scale, 1.0);
  }
  std::map<int, int> bad_per_detection;
  for (size_t k = 0; k < points_.size(); ++k) {
    PointObs& p = points_[k];
    if (point_blocks_[k] && p.residual > thresh[p.point == 4]) {
      p.rejected = true;
      ++bad_per_detection[p.detection];
    }
  }
  for (PointObs& p : points_)
    if (!p.rejected && point_blocks_[&p - points_.data()] &&
        bad_per_detection[p.detection] >= options_.outlier_points_per_detection)
      p.rejected = true;
  for (size_t k = 0; k < points_.size(); ++k)
    if (points_[k].rejected && point_blocks_[k])
      S_.rejected.push_back(RejectedPoint{images_[points_[k].image].name, points_[k].detected_id,
                                          kPointNames[points_[k].point],
                                          points_[k].residual * points_[k].sigma});
  // Images and markers left without points.
  std::vector<int> points_in_image(images_.size(), 0);
  std::map<int, int> points_of_marker;
  for (const PointObs& p : points_)
    if (!p.rejected && image_used_[p.image]) {
      ++points_in_image[p.image];
      if (p.point != 4) ++points_of_marker[p.marker_id];
    }
  for (size_t i = 0; i < images_.size(); ++i)
    if (points_in_image[i] == 0) image_used_[i] = false;
  for (int id : std::set<int>(surveyed_))
    if (!points_of_marker[id] && id != root_) {
      surveyed_.erase(id);
      S_.left_out.emplace_back(id, "every observation was rejected as an outlier");
      for (PointObs& p : points_)
        if (p.marker_id == id) p.rejected = true;
    }
  // The rejections may have cut the view graph: keep the root's component.
  std::vector<ImageSightings> left(images_.size());
  std::set<std::pair<int, int>> kept;  // (image, marker) with a corner left
  for (const PointObs& p : points_)
    if (!p.rejected && p.point != 4 && image_used_[p.image]) kept.insert({p.image, p.marker_id});
  for (const auto& [image, id] : kept) left[image].push_back(MarkerSighting{id, Pose(), 0, false});
  for (const std::vector<int>& comp : ConnectedComponents(left)) {
    if (std::count(comp.begin(), comp.end(), root_)) continue;
    for (int id : comp) {
      if (!surveyed_.erase(id)) continue;
      S_.left_out.emplace_back(
          id, "after outlier rejection, no longer seen together with the reference's group");
      for (PointObs& p : points_)
        if (p.marker_id == id) p.rejected = true;
    }
  }
  std::fill(points_in_image.begin(), points_in_image.end(), 0);
  for (const PointObs& p : points_)
    if (!p.rejected && image_used_[p.image]) ++points_in_image[p.image];
  for (size_t i = 0; i < images_.size(); ++i)
    if (points_in_image[i] == 0) image_used_[i] = false;
}

Status Solver::ComputeCovariance() {
  // SuiteSparseQR's numerical rank does not always see a gauge freedom (parameters in metres
  // and radians, poorly scaled), so the reduced normal matrix is checked first; with the
  // Schur-complement algorithm its inverse is the covariance.
  ReducedSystem reduced;
  if (const std::string undetermined = RankDeficiency(&reduced); !undetermined.empty())
    return Fail("the problem is rank deficient: " + undetermined);
  using Algorithm = SurveyOptions::CovarianceAlgorithm;
  std::unique_ptr<ceres::Covariance> covariance;
  if (options_.covariance_algorithm != Algorithm::kSchurComplement) {
    ceres::Covariance::Options co;
    co.algorithm_type =
        options_.covariance_algorithm == Algorithm::kDenseSvd ? ceres::DENSE_SVD : ceres::SPARSE_QR;
    if (co.algorithm_type == ceres::SPARSE_QR &&
        ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::SUITE_SPARSE))
      co.sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
    co.num_threads = options_.num_threads;
    covariance = std::make_unique<ceres::Covariance>(co);
    std::vector<std::pair<const double*, const double*>> blocks;
    for (const ReducedParam& p : reduced.params)
      if (p.block != intrinsics_.data()) blocks.emplace_back(p.block, p.block);
    if (!covariance->Compute(blocks, problem_.get()))
      return Fail(
          "the problem is rank deficient: ceres::Covariance::Compute failed (its numerical rank "
          "is below the number of parameters; no single undetermined direction was found at a "
          "relative tolerance of 1e-9: check the gauge and the geometry)");
  }
  // The covariance block (size x size, row-major) of a non-constant parameter block.
  auto get = [&](const double* block, int size, double* out) {
    if (covariance) {
      covariance->GetCovarianceBlock(block, block, out);
      return;
    }
    const int o = reduced.offset.at(block);
    for (int r = 0; r < size; ++r)
      for (int c = 0; c < size; ++c) out[r * size + c] = reduced.covariance(o + r, o + c);
  };
  const double factor = options_.scale_covariance ? S_.variance_factor : 1.0;
  S_.covariance_scaled = options_.scale_covariance;
  for (LayoutEntry& e : R_.layout.markers) {
    const Block6& b = object_from_marker_.at(e.marker.id);
    PoseCovariance c = PoseCovariance::Zero();
    if (!problem_->IsParameterBlockConstant(b.data())) {
      double raw[36];
      get(b.data(), 6, raw);
      const Eigen::Matrix<double, 6, 6, Eigen::RowMajor> cov_params(raw);
      Eigen::Matrix<double, 6, 6> J = Eigen::Matrix<double, 6, 6>::Identity();
      J.topLeftCorner<3, 3>() = LeftJacobian(Eigen::Vector3d(b[0], b[1], b[2]));
      c = factor * J * cov_params * J.transpose();
      for (const Eigen::MatrixXd* share : {&reduced.calibration, &reduced.repeat}) {
        if (share->size() == 0) continue;
        const Eigen::MatrixXd SL = J * share->middleRows(reduced.offset.at(b.data()), 6);
        c += SL * SL.transpose();
      }
      c = 0.5 * (c + c.transpose()).eval();
    }
    e.covariance = c;
    const int owner = markers_.at(e.marker.id).post_owner;
    if (owner >= 0 && post_height_.count(owner)) {
      double var = 0;
      double unscaled_var = 0;
      if (!problem_->IsParameterBlockConstant(&post_height_.at(owner))) {
        get(&post_height_.at(owner), 1, &var);
        for (const Eigen::MatrixXd* share : {&reduced.calibration, &reduced.repeat})
          if (share->size() > 0)
            unscaled_var += share->row(reduced.offset.at(&post_height_.at(owner))).squaredNorm();
      }
      e.post_height_sigma = std::sqrt(std::max(0.0, factor * var) + unscaled_var);
    }
  }
  if (config_.refine_intrinsics) {
    // The refined intrinsics' covariance, scaled as the layout's; positive definite after the
    // rank check, so its Cholesky factor exists.
    const int n = static_cast<int>(intrinsics_.size());
    const Eigen::MatrixXd block =
        factor * reduced.covariance.block(reduced.offset.at(intrinsics_.data()),
                                          reduced.offset.at(intrinsics_.data()), n, n);
    const Eigen::LLT<Eigen::MatrixXd> llt(0.5 * (block + block.transpose()));
    if (llt.info() != Eigen::Success || !R_.camera.set_intrinsics_covariance_factor(llt.matrixL()))
      return Fail("the refined intrinsics' covariance is not positive definite");
  }
  S_.covariance_ok = true;
  S_.calibration_in_covariance = reduced.calibration.size() > 0;
  S_.corner_repeat_in_covariance = reduced.repeat.size() > 0;
  return Status::Ok();
}

// Which parameters the observations leave undetermined: the Gauss-Newton matrix J^T J with
// the camera poses eliminated (Schur complement onto markers, posts and intrinsics),
// normalised by its diagonal; its near-null eigenvectors name the parameters they move.
// Empty when every parameter is determined; then reduced->covariance is the inverse of the
// reduced matrix, which is the markers', posts' and intrinsics' block of (J^T J)^-1.
std::string Solver::RankDeficiency(ReducedSystem* reduced) {
  std::vector<ReducedParam> cams;
  ReducedParams(&cams, reduced);
  const std::vector<ReducedParam>& rest = reduced->params;
  ReducedJacobian jac;
  if (!EvaluateReducedJacobian(cams, rest, &jac))
    return "(the Jacobian could not be evaluated at the solution: a point does not project)";
  ReducedNormal h;
  AccumulateReducedNormal(jac, static_cast<int>(cams.size()), &h);
  std::vector<std::string> found;
  EliminateCameras(cams, &h, &found);
  Eigen::VectorXd d;
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es;
  NullDirections(rest, &h, &d, &es, &found);
  if (found.empty()) {
    // S^-1 = D^-1 Sn^-1 D^-1, Sn^-1 from its eigen-decomposition (all eigenvalues > 1e-9 top).
    const Eigen::MatrixXd& V = es.eigenvectors();
    const Eigen::MatrixXd Sn_inv = V * es.eigenvalues().cwiseInverse().asDiagonal() * V.transpose();
    const Eigen::VectorXd dinv = d.cwiseInverse();
    reduced->covariance = dinv.asDiagonal() * Sn_inv * dinv.asDiagonal();
    // d params / d intrinsics = -S^-1 H_rt (the reduced normal equations at the optimum).
    if (jac.calibration)
      reduced->calibration = reduced->covariance * h.Hrt.leftCols(jac.nt) *
                             work_camera_.intrinsics_covariance_factor();
    // d params / d shifts likewise (the shifts have unit variance).
    if (jac.nb > 0) reduced->repeat = reduced->covariance * h.Hrt.rightCols(jac.nb);
    return "";
  }
  std::string s = "not determined: ";
  for (size_t i = 0; i < found.size(); ++i) s += (i ? "; " : "") + found[i];
  return s + " (fix the gauge or add observations that constrain them)";
}

// The camera poses in the problem (*cams), and the other free parameters in the order of the
// reduced system (reduced->params, ->offset: markers, post heights, refined intrinsics); the
// rest of *reduced is cleared.
void Solver::ReducedParams(std::vector<ReducedParam>* cams, ReducedSystem* reduced) {
  std::vector<ReducedParam> rest;
  for (size_t i = 0; i < cam_from_object_.size(); ++i)
    if (problem_->HasParameterBlock(cam_from_object_[i].data()))
      cams->push_back({cam_from_object_[i].data(), 6, "image " + images_[i].name});
  for (auto& [id, b] : object_from_marker_)
    if (problem_->HasParameterBlock(b.data()) && !problem_->IsParameterBlockConstant(b.data()))
      rest.push_back({b.data(), 6, "marker " + std::to_string(id)});
  for (auto& [id, h] : post_height_)
    if (problem_->HasParameterBlock(&h) && !problem_->IsParameterBlockConstant(&h))
      rest.push_back({&h, 1, "post height of marker " + std::to_string(id)});
  if (config_.refine_intrinsics)
    rest.push_back({intrinsics_.data(), static_cast<int>(intrinsics_.size()), "intrinsics"});
  reduced->params = rest;
  reduced->offset.clear();
  reduced->covariance.resize(0, 0);
  reduced->calibration.resize(0, 0);
  reduced->repeat.resize(0, 0);
  int o = 0;
  for (const ReducedParam& p : rest) {
    reduced->offset[p.block] = o;
    o += p.size;
  }
}

// The Jacobian at the solution over the columns [cams, rest, then with the calibration term
// the (constant) intrinsics, evaluated as variables], the points' residuals first, in points_
// order (so that each row's point is known: jac->row_of), then the others. With the repeated
// corner error (SurveyOptions::corner_repeat_px_grey) one more column per marker with a corner
// in the problem that has a repeat_px (jac->repeat_col), filled in by AccumulateReducedNormal.
// False if it cannot be evaluated.
bool Solver::EvaluateReducedJacobian(const std::vector<ReducedParam>& cams,
                                     const std::vector<ReducedParam>& rest, ReducedJacobian* jac) {
  ceres::Problem::EvaluateOptions eo;
  for (const ReducedParam& p : cams) eo.parameter_blocks.push_back(const_cast<double*>(p.block));
  for (const ReducedParam& p : rest) eo.parameter_blocks.push_back(const_cast<double*>(p.block));
  // The calibration term: the (constant) intrinsics' columns last, evaluated as variables.
  jac->calibration = calibration_term_ && problem_->HasParameterBlock(intrinsics_.data());
  jac->nt = jac->calibration ? static_cast<int>(intrinsics_.size()) : 0;
  if (jac->calibration) {
    eo.parameter_blocks.push_back(intrinsics_.data());
    problem_->SetParameterBlockVariable(intrinsics_.data());
  }
  std::vector<ceres::ResidualBlockId> all;
  problem_->GetResidualBlocks(&all);
  std::set<ceres::ResidualBlockId> point_rows;
  for (size_t k = 0; k < points_.size(); ++k) {
    const ceres::ResidualBlockId id = point_blocks_[k];
    if (!id) continue;
    point_rows.insert(id);
    eo.residual_blocks.push_back(id);
    const int m = problem_->GetCostFunctionForResidualBlock(id)->num_residuals();
    for (int a = 0; a < m; ++a) jac->row_of.emplace_back(static_cast<int>(k), a);
    const PointObs& p = points_[k];
    if (p.point < 4 && p.repeat_px > 0 && !jac->repeat_col.count(p.marker_id)) {
      const int next = static_cast<int>(jac->repeat_col.size());
      jac->repeat_col[p.marker_id] = next;
    }
  }
  for (ceres::ResidualBlockId id : all)
    if (!point_rows.count(id)) eo.residual_blocks.push_back(id);
  jac->nb = static_cast<int>(jac->repeat_col.size());
  const bool evaluated = problem_->Evaluate(eo, nullptr, nullptr, nullptr, &jac->crs);
  if (jac->calibration) problem_->SetParameterBlockConstant(intrinsics_.data());
  return evaluated;
}

// J^T J reduced onto the non-camera parameters, accumulated row by row from the Jacobian
// (every residual touches at most one camera): H_cc per camera, the coupling H_rc of each
// camera to the reduced rows it touches, and H_rr (dense, small) as S. Forming the whole J^T J
// as a sparse product instead takes most of the 2000 x 40 covariance step. With the
// calibration term and the repeated corner error also H(reduced rows, intrinsics and shifts)
// and H(camera block, intrinsics and shifts). A corner's residual is (projection - observed) /
// sigma, so its column for its marker's shift (of unit variance, moving each corner by
// repeat_px along outward) is -outward repeat_px / sigma.
void Solver::AccumulateReducedNormal(const ReducedJacobian& jac, int ncams,
                                     ReducedNormal* h) const {
  const ceres::CRSMatrix& crs = jac.crs;
  const int nt = jac.nt, nb = jac.nb;
  const int nc = 6 * ncams;
  const int nr = crs.num_cols - nc - nt;
  h->nr = nr;
  h->Hcc.assign(ncams, Eigen::Matrix<double, 6, 6>::Zero());
  h->Hrc.assign(ncams, {});
  h->S = Eigen::MatrixXd::Zero(nr, nr);
  const int nx = nt + nb;
  h->Hrt = Eigen::MatrixXd::Zero(nr, nx);
  h->Hct.assign(nx > 0 ? ncams : 0, Eigen::MatrixXd::Zero(6, nx));
  std::vector<std::pair<int, double>> cam_entries, rest_entries, extra_entries;
  for (int r = 0; r < crs.num_rows; ++r) {
    cam_entries.clear();
    rest_entries.clear();
    extra_entries.clear();
    int cam = -1;
    for (int k = crs.rows[r]; k < crs.rows[r + 1]; ++k) {
      const int col = crs.cols[k];
      if (col < nc) {
        cam = col / 6;
        cam_entries.emplace_back(col % 6, crs.values[k]);
      } else if (col < nc + nr) {
        rest_entries.emplace_back(col - nc, crs.values[k]);
      } else {
        extra_entries.emplace_back(col - nc - nr, crs.values[k]);
      }
    }
    if (nb > 0 && r < static_cast<int>(jac.row_of.size())) {
      const PointObs& p = points_[jac.row_of[r].first];
      const auto it = jac.repeat_col.find(p.marker_id);
      if (p.point < 4 && p.repeat_px > 0 && it != jac.repeat_col.end())
        extra_entries.emplace_back(nt + it->second,
                                   -p.outward(jac.row_of[r].second) * p.repeat_px / p.sigma);
    }
    for (const auto& [a, va] : rest_entries) {
      for (const auto& [b, vb] : rest_entries) h->S(a, b) += va * vb;
      for (const auto& [t, vt] : extra_entries) h->Hrt(a, t) += va * vt;
    }
    if (cam < 0) continue;
    for (const auto& [a, va] : cam_entries) {
      for (const auto& [b, vb] : cam_entries) h->Hcc[cam](a, b) += va * vb;
      for (const auto& [t, vt] : extra_entries) h->Hct[cam](a, t) += va * vt;
    }
    for (const auto& [a, va] : rest_entries) {
      ReducedNormal::Row6& row =
          h->Hrc[cam].try_emplace(a, ReducedNormal::Row6::Zero()).first->second;
      for (const auto& [b, vb] : cam_entries) row(b) += va * vb;
    }
  }
}

// Eliminates the cameras from the reduced normal equations (Schur complement: S -= H_rc
// H_cc^-1 H_cr, and H_rt likewise), over the reduced rows each camera touches only. A camera
// whose own block is singular is listed in *found instead.
void Solver::EliminateCameras(const std::vector<ReducedParam>& cams, ReducedNormal* h,
                              std::vector<std::string>* found) {
  const int nx = static_cast<int>(h->Hrt.cols());
  for (size_t c = 0; c < cams.size(); ++c) {
    const Vector6d values = SymmetricEigenvalues(h->Hcc[c]);
    if (values(0) <= 1e-12 * std::max(1.0, values(5))) {
      found->push_back(cams[c].name + " (camera pose)");
      continue;
    }
    std::vector<int> rows;
    Eigen::MatrixXd B(h->Hrc[c].size(), 6);
    for (const auto& [row, v] : h->Hrc[c]) {
      B.row(static_cast<Eigen::Index>(rows.size())) = v;
      rows.push_back(row);
    }
    const Eigen::Matrix<double, 6, 6> Hcc_inv = h->Hcc[c].inverse();
    const Eigen::MatrixXd update = B * Hcc_inv * B.transpose();
    for (size_t a = 0; a < rows.size(); ++a)
      for (size_t b = 0; b < rows.size(); ++b) h->S(rows[a], rows[b]) -= update(a, b);
    if (nx > 0) {
      const Eigen::MatrixXd coupling = B * Hcc_inv * h->Hct[c];
      for (size_t a = 0; a < rows.size(); ++a) h->Hrt.row(rows[a]) -= coupling.row(a);
    }
  }
}

// What the reduced system S (after EliminateCameras) leaves undetermined, into *found: each
// parameter no observation constrains (its row and column of S then set to the identity's),
// and each direction of S's null space (scaled to unit diagonal, *d: sqrt of that diagonal;
// eigenvalues within 1e-9 of the largest), named by the blocks it moves. *es: the
// eigen-decomposition of the scaled S.
void Solver::NullDirections(const std::vector<ReducedParam>& rest, ReducedNormal* h,
                            Eigen::VectorXd* d_out,
                            Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>* es_out,
                            std::vector<std::string>* found) {
  Eigen::MatrixXd& S = h->S;
  const int nr = h->nr;
  Eigen::VectorXd& d = *d_out;
  d = S.diagonal().cwiseMax(0).cwiseSqrt();
  // Parameter k is component `what[k]` of block `block_of[k]`.
  std::vector<std::string> block_of, what;
  static const char* kAxes[6] = {"rx", "ry", "rz", "tx", "ty", "tz"};
  for (const ReducedParam& p : rest)
    for (int k = 0; k < p.size; ++k) {
      block_of.push_back(p.name);
      what.push_back(p.size == 6 ? kAxes[k] : p.size == 1 ? "" : "[" + std::to_string(k) + "]");
    }
  for (int k = 0; k < nr; ++k)
    if (d(k) <= 1e-12 * std::max(1.0, d.maxCoeff())) {
      found->push_back(block_of[k] + (what[k].empty() ? "" : " " + what[k]) +
                       " (no observation constrains it)");
      d(k) = 1;
      S.row(k).setZero();
      S.col(k).setZero();
      S(k, k) = 1;  // listed; keep it out of the directions below
    }
  const Eigen::MatrixXd Sn = d.asDiagonal().inverse() * S * d.asDiagonal().inverse();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>& es = *es_out;
  es.compute(Sn);
  const double top = std::max(1e-300, es.eigenvalues().maxCoeff());
  int null_dims = 0;
  for (int e = 0; e < nr; ++e) {
    if (es.eigenvalues()(e) > 1e-9 * top) break;
    ++null_dims;
    const Eigen::VectorXd v = es.eigenvectors().col(e);
    // "marker 100 (rx tz), marker 101 (tx ty), post height of marker 104"
    std::vector<std::pair<std::string, std::string>> moved;
    for (int k = 0; k < nr; ++k) {
      if (std::abs(v(k)) <= 0.2 * v.cwiseAbs().maxCoeff()) continue;
      if (moved.empty() || moved.back().first != block_of[k])
        moved.emplace_back(block_of[k], what[k]);
      else
        moved.back().second += " " + what[k];
    }
    std::string dir;
    for (size_t i = 0; i < moved.size() && i < 10; ++i)
      dir += (i ? ", " : "") + moved[i].first +
             (moved[i].second.empty() ? "" : " (" + moved[i].second + ")");
    if (moved.size() > 10) dir += ", ... (" + std::to_string(moved.size()) + " blocks in all)";
    found->push_back("direction " + std::to_string(null_dims) + " moves " + dir);
  }
}

void Solver::FillResult() {
  Layout& L = R_.layout;
  L.name = "survey";
  L.markers.clear();
  auto entry = [&](int id) {
    const MarkerInfo& info = markers_.at(id);
    LayoutEntry e;
    e.marker = info.model;
    if (info.post_owner >= 0 && post_height_.count(info.post_owner))
      e.marker.post->height = post_height_.at(info.post_owner);
    e.object_from_marker = FromBlock(object_from_marker_.at(id));
    L.markers.push_back(e);
  };
  for (const MarkerModel& m : models_) {
    if (surveyed_.count(m.id)) entry(m.id);
    if (m.inner && surveyed_.count(m.inner->id)) entry(m.inner->id);
  }
  R_.image_names.clear();
  for (const SurveyImage& im : images_) R_.image_names.push_back(im.name);
  R_.image_used = image_used_;
  R_.cam_from_object.clear();
  for (const Block6& b : cam_from_object_) R_.cam_from_object.push_back(FromBlock(b));
  R_.camera = work_camera_;
  S_.intrinsics_refined = config_.refine_intrinsics;
  if (config_.refine_intrinsics) {
    CameraModel c;
    if (CameraModel::Create(work_camera_.lensmodel(), intrinsics_, work_camera_.width(),
                            work_camera_.height(), &c))
      R_.camera = c;
  }
  S_.markers_surveyed = static_cast<int>(surveyed_.size());
  S_.images_used = static_cast<int>(std::count(image_used_.begin(), image_used_.end(), true));

  // Residual statistics (pixels) of the final solve.
  EvaluatePoints();
  std::map<int, ResidualStats> per_marker;
  std::vector<ResidualStats> per_image(images_.size());
  double sum = 0;
  int count = 0;
  for (size_t k = 0; k < points_.size(); ++k) {
    const PointObs& p = points_[k];
    if (!image_used_[p.image] && !p.rejected) continue;
    ResidualStats& a = per_image[p.image];
    ResidualStats& b = per_marker[p.detected_id];
    if (p.rejected) {
      ++a.outliers;
      ++b.outliers;
      continue;
    }
    if (!point_blocks_[k]) continue;
    const double r = p.residual * p.sigma;
    for (ResidualStats* s : {&a, &b}) {
      ++s->points;
      s->rms_px += r * r;
      s->max_px = std::max(s->max_px, r);
    }
    sum += r * r;
    ++count;
  }
  S_.rms_px = count ? std::sqrt(sum / count) : 0;
  S_.per_image.clear();
  S_.per_marker.clear();
  for (size_t i = 0; i < images_.size(); ++i) {
    ResidualStats s = per_image[i];
    if (!s.points && !s.outliers) continue;
    s.name = images_[i].name;
    s.rms_px = s.points ? std::sqrt(s.rms_px / s.points) : 0;
    S_.per_image.push_back(s);
  }
  for (auto& [id, s0] : per_marker) {
    ResidualStats s = s0;
    s.name = "marker " + std::to_string(id);
    s.rms_px = s.points ? std::sqrt(s.rms_px / s.points) : 0;
    S_.per_marker.push_back(s);
  }
}

Status Solver::Run(const std::vector<MarkerModel>& models) {
  if (Status s = SetUpMarkers(models); !s) return s;
  const auto t0 = Clock::now();
  if (Status s = CollectObservations(); !s) return s;
  if (Status s = Initialise(); !s) return s;
  const auto t1 = Clock::now();
  S_.seconds_init = Seconds(t0, t1);

  const bool robust = options_.loss != "trivial";
  if (Status s = Solve(robust, &S_.first_cost, &S_.iterations_first, &S_.ceres_report_first); !s) {
    FillResult();
    return s;
  }
  const auto t2 = Clock::now();
  S_.seconds_first = Seconds(t1, t2);
  if (options_.reject_outliers) RejectOutliers();
  UpdateTipOffsets();
  if (Status s = Solve(false, &S_.final_cost, &S_.iterations_second, &S_.ceres_report_second); !s) {
    FillResult();
    return s;
  }
  UpdateTipOffsets();  // for the next user of the offsets; the change is far below the noise
  const auto t3 = Clock::now();
  S_.seconds_second = Seconds(t2, t3);

  // Residual and parameter counts of the final problem.
  S_.residuals = problem_->NumResiduals();
  int n = 0;
  std::vector<double*> blocks;
  problem_->GetParameterBlocks(&blocks);
  for (double* b : blocks)
    if (!problem_->IsParameterBlockConstant(b)) n += problem_->ParameterBlockSize(b);
  S_.parameters = n;
  FillResult();
  if (S_.residuals <= n)
    return Fail("too few observations: " + std::to_string(S_.residuals) + " residuals for " +
                std::to_string(n) + " parameters");
  S_.variance_factor = 2 * S_.final_cost / (S_.residuals - n);
  if (options_.compute_covariance) {
    const auto t4 = Clock::now();
    Status s = ComputeCovariance();
    S_.seconds_covariance = Seconds(t4, Clock::now());
    if (!s) return s;
  }
  S_.success = true;
  return Status::Ok();
}

}  // namespace

bool NamedPointInMarker(const NamedPoint& point, const MarkerModel& model, Eigen::Vector3d* out) {
  switch (point.kind) {
    case NamedPoint::Kind::kCentre:
      *out = Eigen::Vector3d::Zero();
      return true;
    case NamedPoint::Kind::kCorner:
      *out = model.Corners()[point.corner];
      return true;
    case NamedPoint::Kind::kTip:
      if (!model.post) return false;
      *out = Eigen::Vector3d(0, 0, model.post->height);
      return true;
  }
  return false;
}

Status RunSurvey(const std::vector<SurveyImage>& images, const std::vector<MarkerModel>& models,
                 const CameraModel& camera, const SurveyOptions& options,
                 const SurveyConfig& config, SurveyResult* result) {
  *result = SurveyResult();
  SurveySummary& S = result->summary;
  if (Status s = options.Check(); !s) {
    S.message = s.message();
    return s;
  }
  if (Status s = config.Check(); !s) {
    S.message = s.message();
    return s;
  }
  if (camera.empty()) {
    S.message = "camera: an empty camera model; expected the calibrated camera of the images";
    return Status::Error(S.message);
  }
  Solver solver(images, camera, options, config, result);
  return solver.Run(models);
}

}  // namespace svms
