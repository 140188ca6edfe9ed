#include "svms/fusion/object_pose.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>

#include "svms/base/statistics.h"
#include "svms/detect/marker_pose.h"
#include "svms/detect/pose_gauss_newton.h"
#include "svms/geometry/pose_matrix.h"
#include "svms/geometry/so3.h"

namespace svms {
namespace {

using Vec6 = Eigen::Matrix<double, 6, 1>;
using Mat6 = Eigen::Matrix<double, 6, 6>;
// A marker has at most 5 points (4 corners and a tip), 10 residuals, and up to 6 rows of its
// edges' quadratic: every per-marker matrix has that bound at compile time and lives on the
// stack (no heap allocation per frame).
constexpr int kMaxPoints = 5, kMaxEdgeRows = 6, kMaxRows = 2 * kMaxPoints + kMaxEdgeRows;
using VecR = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxRows, 1>;
using MatR6 = Eigen::Matrix<double, Eigen::Dynamic, 6, 0, kMaxRows, 6>;
using MatR7 = Eigen::Matrix<double, Eigen::Dynamic, 7, 0, kMaxRows, 7>;
using MatRR = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxRows, kMaxRows>;

// When the fused pose's Gauss-Newton stops (PoseGaussNewtonStep): steps below 1e-10 (radians;
// translation relative to the range). Every rotation step is applied.
constexpr PoseStepTolerances kObjectPoseTolerances{1e-10, 0, 0};

// The symmetric square root of a covariance, V sqrt(max(0, Lambda)) V^T (round-off's negative
// eigenvalues taken as zero): an error with that covariance is Sigma^(1/2) z with z of unit
// variance, the z that ObjectPose::bias_factor's columns for a rig_from_cam covariance answer.
Mat6 SymmetricSquareRoot(const Mat6& covariance) {
  const Eigen::SelfAdjointEigenSolver<Mat6> es(covariance);
  return es.eigenvectors() * es.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal() *
         es.eigenvectors().transpose();
}

// The angle between two poses' rotations, radians (AngleBetweenRad, svms/geometry/pose.h).
double AngleBetween(const Pose& a, const Pose& b) { return AngleBetweenRad(a, b); }

// One point of a marker: its position in the marker frame, its pixel and pixel sigma, and how
// it moves with the post height (d point / d height, marker frame; zero for corners).
struct Point {
  Eigen::Vector3d in_marker;
  Eigen::Vector2d px;
  double sigma;
  Eigen::Vector3d d_dheight = Eigen::Vector3d::Zero();
  int index = 0;  // 0-3 the corners, 4 the tip
};

// The points of one marker (at most kMaxPoints), in a fixed array.
struct Points {
  std::array<Point, kMaxPoints> p;
  int n = 0;
  size_t size() const { return static_cast<size_t>(n); }
  void clear() { n = 0; }
  void push_back(const Point& q) { p[n++] = q; }
  const Point& operator[](size_t i) const { return p[i]; }
};

// One camera as the solver sees it: its lens model and where it sits in the rig. The unknown is
// rig_from_object; a camera's points map into it by cam_from_rig. `identity` (the one-camera
// solve only: every rig camera has it false, even one at the rig's origin) skips the extra
// transform, so that the one-camera solve is exactly what it was without rigs.
struct View {
  const CameraModel* camera = nullptr;
  int index = 0;  // in the rig
  bool identity = true;
  Eigen::Matrix3d R_cr = Eigen::Matrix3d::Identity();  // cam_from_rig
  Eigen::Vector3d t_cr = Eigen::Vector3d::Zero();
  Eigen::Matrix3d R_rc = Eigen::Matrix3d::Identity();  // rig_from_cam
  Eigen::Vector3d t_rc = Eigen::Vector3d::Zero();
  Pose rig_from_cam;
  const PoseCovariance* extrinsics_covariance = nullptr;  // rig_from_cam, rig axes
};

// A pose of the view's camera (cam_from_x) as rig_from_x.
Pose ToRig(const View& v, const Pose& cam_from_x) {
  return v.identity ? cam_from_x : v.rig_from_cam * cam_from_x;
}

// cam_from_object of a view from rig_from_object (R, t).
void ToCamera(const View& v, const Eigen::Matrix3d& R, const Eigen::Vector3d& t,
              Eigen::Matrix3d* R_c, Eigen::Vector3d* t_c) {
  if (v.identity) {
    *R_c = R;
    *t_c = t;
  } else {
    *R_c = v.R_cr * R;
    *t_c = v.R_cr * t + v.t_cr;
  }
}

struct Block {
  const MarkerObservation* obs = nullptr;
  const View* view = nullptr;
  Points points;
  Eigen::Matrix3d R_om = Eigen::Matrix3d::Identity();  // object_from_marker rotation
  Eigen::Vector3d t_om = Eigen::Vector3d::Zero();
  MatRR L_inv;  // inverse Cholesky factor of the marker's residual covariance
  std::array<double, kMaxPoints> total_sigma{};  // per point: pixel and layout noise, RMS per axis
  // A rig camera with an extrinsics covariance: the rejection tests' factor and sigmas, which
  // also count how far the camera's rig_from_cam error moves the marker's pixels (the fit's
  // whitening cannot: that error is shared by all of the camera's markers).
  bool reject_with_extrinsics = false;
  MatRR L_inv_reject;
  std::array<double, kMaxPoints> reject_sigma{};
  double weight = 1;  // robust weight of the iteration
  bool active = true;
  // The marker's edges (ObjectPoseOptions::use_edges): edge_rows rows U (d - mu), d the change
  // of cam_from_marker from the detector's (R_det, t_det), U^T U the edges' information.
  int edge_rows = 0;
  Eigen::Matrix<double, kMaxEdgeRows, 6> edge_U = Eigen::Matrix<double, kMaxEdgeRows, 6>::Zero();
  Vec6 edge_mu = Vec6::Zero();
  Eigen::Matrix3d R_det = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t_det = Eigen::Vector3d::Zero();
  std::array<bool, 5> dropped{};  // points left out as outliers (corners 0-3, tip 4)
};

// Whether the marker's corners are whitened with their joint covariance from the line fits.
bool CorrelatedCorners(const ObjectPoseOptions& o, const MarkerObservation& m) {
  return o.corner_sigma_from_fit && o.corner_covariance_from_fit &&
         m.corner_covariance.diagonal().minCoeff() > 0;
}

// The marker's edge rows (Block::edge_rows) from its detector's edge quadratic: U = Lambda^1/2
// V^T over the information's eigenvalues above 1e-9 of the largest (H = V Lambda V^T).
void SetUpEdges(const ObjectPoseOptions& o, Block* b) {
  const MarkerObservation& m = *b->obs;
  b->edge_rows = 0;
  if (!o.use_edges || m.edge_points <= 0 || !m.cam_from_marker || m.pose_ambiguous ||
      !m.edge_information.allFinite() || !m.edge_offset.allFinite())
    return;
  Mat6 vectors;
  const Vec6 values =
      SymmetricEigenvalues(0.5 * (m.edge_information + m.edge_information.transpose()), &vectors);
  const double largest = values.maxCoeff();
  if (!(largest > 0)) return;
  for (int k = 0; k < 6; ++k) {
    if (!(values(k) > 1e-9 * largest)) continue;
    b->edge_U.row(b->edge_rows++) = std::sqrt(values(k)) * vectors.col(k).transpose();
  }
  b->edge_mu = m.edge_offset;
  b->R_det = m.cam_from_marker->Rotation();
  b->t_det = m.cam_from_marker->tvec;
}

// The marker's points at the current pose (the concave well's visible bottom depends on it).
void UpdatePoints(Block* b, const Eigen::Matrix3d& R, const Eigen::Vector3d& t,
                  const ObjectPoseOptions& o) {
  const MarkerObservation& m = *b->obs;
  b->points.clear();
  const auto corners = m.model.Corners();
  for (int k = 0; k < 4; ++k) {
    if (b->dropped[k]) continue;
    b->points.push_back(
        {corners[k], m.corners[k], CornerPixelSigma(o, m, k), Eigen::Vector3d::Zero(), k});
  }
  if (o.use_tips && m.tip && m.model.post && !b->dropped[4]) {
    // Camera centre in the marker frame: marker_from_cam = (cam_from_object object_from_marker)^-1.
    Eigen::Matrix3d R_co;
    Eigen::Vector3d t_co;
    ToCamera(*b->view, R, t, &R_co, &t_co);
    const Eigen::Matrix3d R_cm = R_co * b->R_om;
    const Eigen::Vector3d t_cm = R_co * b->t_om + t_co;
    const Eigen::Vector3d cam_in_marker = -R_cm.transpose() * t_cm;
    double fraction = 0;
    const Eigen::Vector3d tip = VisibleTipPoint(m.model, cam_in_marker, &fraction);
    if (fraction > 0 || !m.model.post->concave()) {
      Point p{tip, m.tip->pixel, TipPixelSigma(o, m)};
      p.d_dheight = Eigen::Vector3d::UnitZ();
      p.index = 4;
      b->points.push_back(p);
    }
  }
}

// Residuals (pixels) and Jacobians d residual / d [rotation, translation] of the object pose
// rig_from_object (R, t) (left perturbation, rig axes; the camera's axes in the one-camera
// solve) for one marker; also d pixel / d layout (the marker's object_from_marker, left
// perturbation in object axes, then the post height: 7 columns) and, when J_extrinsics is
// given, d pixel / d rig_from_cam (left perturbation, rig axes, [rotation, translation]).
bool Evaluate(const Block& b, const Eigen::Matrix3d& R, const Eigen::Vector3d& t, VecR* r, MatR6* J,
              MatR7* J_layout, MatR6* J_extrinsics = nullptr) {
  const View& v = *b.view;
  const CameraModel& camera = *v.camera;
  const int n = static_cast<int>(b.points.size());
  const int rows = 2 * n + b.edge_rows;
  r->resize(rows);
  J->resize(rows, 6);
  if (J_layout) J_layout->resize(rows, 7);
  if (J_extrinsics) J_extrinsics->resize(rows, 6);
  for (int i = 0; i < n; ++i) {
    const Point& p = b.points[i];
    const Eigen::Vector3d in_object_rotated = b.R_om * p.in_marker;
    const Eigen::Vector3d p_obj = in_object_rotated + b.t_om;
    const Eigen::Vector3d p_rig = R * p_obj + t;
    Eigen::Vector2d q;
    Eigen::Matrix<double, 2, 3> dq_dp;  // d pixel / d point in the rig frame
    if (v.identity) {
      if (!camera.Project(p_rig, &q, &dq_dp)) return false;
      if (J_extrinsics) J_extrinsics->middleRows<2>(2 * i).setZero();
    } else {
      Eigen::Matrix<double, 2, 3> dq_dcam;
      if (!camera.Project(v.R_cr * p_rig + v.t_cr, &q, &dq_dcam)) return false;
      dq_dp = dq_dcam * v.R_cr;
      if (J_extrinsics) {
        // p_cam = R_rc^T exp(-[e_rot]) (p_rig - t_rc - e_trans) to first order in the error e of
        // rig_from_cam: d p_cam / d e = R_rc^T [ [p_rig - t_rc]x, -I ].
        J_extrinsics->block<2, 3>(2 * i, 0) = dq_dp * Skew(p_rig - v.t_rc);
        J_extrinsics->block<2, 3>(2 * i, 3) = -dq_dp;
      }
    }
    r->segment<2>(2 * i) = q - p.px;
    J->block<2, 3>(2 * i, 0) = -dq_dp * Skew(R * p_obj);
    J->block<2, 3>(2 * i, 3) = dq_dp;
    if (J_layout) {
      J_layout->block<2, 3>(2 * i, 0) = -dq_dp * R * Skew(in_object_rotated);
      J_layout->block<2, 3>(2 * i, 3) = dq_dp * R;
      J_layout->block<2, 1>(2 * i, 6) = dq_dp * R * b.R_om * p.d_dheight;
    }
  }
  if (b.edge_rows > 0) {
    // The edges' rows: cam_from_marker = cam_from_rig (R R_om, R t_om + t), d its change from
    // the detector's pose [log(R_cm R_det^T), t_cm - t_det] (camera axes). A left perturbation
    // (w, u) of rig_from_object (rig axes) moves it by R_cr [w, u - [R t_om]x w]; one (e, f) of
    // object_from_marker (object axes) by [R_c e, R_c f]; one (a, c) of rig_from_cam (rig
    // axes) by R_cr [-a, [p - t_rc]x a - c], p = R t_om + t the marker's origin in the rig.
    const int k = b.edge_rows, e0 = 2 * n;
    Eigen::Matrix3d R_c;
    Eigen::Vector3d t_c;
    ToCamera(v, R, t, &R_c, &t_c);
    const Eigen::Matrix3d R_cr = v.identity ? Eigen::Matrix3d::Identity() : v.R_cr;
    Vec6 d;
    d.head<3>() = Log(R_c * b.R_om * b.R_det.transpose());
    d.tail<3>() = R_c * b.t_om + t_c - b.t_det;
    r->segment(e0, k) = b.edge_U.topRows(k) * (d - b.edge_mu);
    Mat6 dd_dpose = Mat6::Zero();
    dd_dpose.topLeftCorner<3, 3>() = R_cr;
    dd_dpose.bottomLeftCorner<3, 3>() = -R_cr * Skew(R * b.t_om);
    dd_dpose.bottomRightCorner<3, 3>() = R_cr;
    J->middleRows(e0, k) = b.edge_U.topRows(k) * dd_dpose;
    if (J_layout) {
      Mat6 dd_dlayout = Mat6::Zero();
      dd_dlayout.topLeftCorner<3, 3>() = R_c;
      dd_dlayout.bottomRightCorner<3, 3>() = R_c;
      J_layout->block(e0, 0, k, 6) = b.edge_U.topRows(k) * dd_dlayout;
      J_layout->block(e0, 6, k, 1).setZero();
    }
    if (J_extrinsics) {
      if (v.identity) {
        J_extrinsics->middleRows(e0, k).setZero();
      } else {
        Mat6 dd_dextrinsics = Mat6::Zero();
        dd_dextrinsics.topLeftCorner<3, 3>() = -R_cr;
        dd_dextrinsics.bottomLeftCorner<3, 3>() = R_cr * Skew(R * b.t_om + t - v.t_rc);
        dd_dextrinsics.bottomRightCorner<3, 3>() = -R_cr;
        J_extrinsics->middleRows(e0, k) = b.edge_U.topRows(k) * dd_dextrinsics;
      }
    }
  }
  return true;
}

// d pixel / d intrinsics of one marker's points at the current pose, mrcal's analytic
// gradients: the first 2n rows of *J (resized to kMaxRows x N, so that its allocation is kept
// from one marker and frame to the next), in point order.
bool IntrinsicsJacobian(const Block& b, const Eigen::Matrix3d& R_rig, const Eigen::Vector3d& t_rig,
                        Eigen::MatrixXd* J) {
  thread_local Eigen::Matrix<double, 2, Eigen::Dynamic> dq_dintrinsics;
  const CameraModel& camera = *b.view->camera;
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
  ToCamera(*b.view, R_rig, t_rig, &R, &t);
  const int n = static_cast<int>(b.points.size());
  const Eigen::Index N = static_cast<Eigen::Index>(camera.intrinsics().size());
  J->resize(kMaxRows, N);
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d p_cam = R * (b.R_om * b.points[i].in_marker + b.t_om) + t;
    Eigen::Vector2d q;
    if (!camera.Project(p_cam, &q, nullptr, &dq_dintrinsics)) return false;
    J->middleRows<2>(2 * i) = dq_dintrinsics;
  }
  // The edges' rows: their quadratic does not say how it moves with the intrinsics.
  J->middleRows(2 * n, b.edge_rows).setZero();
  return true;
}

// The whitening factor of one marker at the current pose: R_m = diag(sigma^2) + J_L S J_L^T.
bool Whitening(Block* b, const Eigen::Matrix3d& R, const Eigen::Vector3d& t,
               const ObjectPoseOptions& o) {
  VecR r;
  MatR6 J;
  MatR7 JL;
  if (!Evaluate(*b, R, t, &r, &J, &JL)) return false;
  const int n = static_cast<int>(b->points.size());
  const int rows = 2 * n + b->edge_rows;
  MatRR C = MatRR::Zero(rows, rows);
  for (int i = 0; i < n; ++i)
    C.block<2, 2>(2 * i, 2 * i).diagonal().setConstant(b->points[i].sigma * b->points[i].sigma);
  // The edges' rows are whitened already (unit covariance) before the layout's share.
  for (int k = 0; k < b->edge_rows; ++k) C(2 * n + k, 2 * n + k) = 1;
  const MarkerObservation& m = *b->obs;
  if (CorrelatedCorners(o, m)) {
    // The line fits' joint covariance, scaled; each corner's own block shifted so that its
    // mean variance stays the point's sigma^2 (systematic term and floor on top of the fit).
    const double scale = CornerFitScale(o, true), s2 = scale * scale;
    for (int i = 0; i < n; ++i) {
      const int a = b->points[i].index;
      if (a > 3) continue;
      for (int j = 0; j < n; ++j) {
        const int c = b->points[j].index;
        if (c > 3) continue;
        C.block<2, 2>(2 * i, 2 * j) = s2 * m.corner_covariance.block<2, 2>(2 * a, 2 * c);
      }
      const double own = 0.5 * C.block<2, 2>(2 * i, 2 * i).trace();
      C.block<2, 2>(2 * i, 2 * i).diagonal().array() +=
          std::max(0.0, b->points[i].sigma * b->points[i].sigma - own);
    }
  }
  if (o.use_layout_covariance) {
    Eigen::Matrix<double, 7, 7> S = Eigen::Matrix<double, 7, 7>::Zero();
    if (b->obs->layout_covariance) S.topLeftCorner<6, 6>() = *b->obs->layout_covariance;
    if (b->obs->post_height_sigma)
      S(6, 6) = *b->obs->post_height_sigma * *b->obs->post_height_sigma;
    C += JL * S * JL.transpose();
  }
  for (int i = 0; i < n; ++i)
    b->total_sigma[i] = std::sqrt(0.5 * C.block<2, 2>(2 * i, 2 * i).trace());
  Eigen::LLT<MatRR> llt(C);
  if (llt.info() != Eigen::Success) return false;
  b->L_inv = llt.matrixL().solve(MatRR::Identity(rows, rows));
  b->reject_with_extrinsics = o.use_extrinsics_covariance && b->view->extrinsics_covariance;
  if (b->reject_with_extrinsics) {
    MatR6 JE;
    if (!Evaluate(*b, R, t, &r, &J, nullptr, &JE)) return false;
    C += JE * *b->view->extrinsics_covariance * JE.transpose();
    for (int i = 0; i < n; ++i)
      b->reject_sigma[i] = std::sqrt(0.5 * C.block<2, 2>(2 * i, 2 * i).trace());
    Eigen::LLT<MatRR> llt_reject(C);
    if (llt_reject.info() != Eigen::Success) return false;
    b->L_inv_reject = llt_reject.matrixL().solve(MatRR::Identity(rows, rows));
  }
  return true;
}

}  // namespace

void ResetObjectPose(ObjectPose* out) {
  std::vector<int> ids_used = std::move(out->ids_used), ids_rejected = std::move(out->ids_rejected);
  std::vector<int> cameras_used = std::move(out->cameras_used),
                   cameras_rejected = std::move(out->cameras_rejected);
  std::string message = std::move(out->message);
  std::vector<double> bias_factor_values = std::move(out->bias_factor_values);
  *out = ObjectPose{};
  ObjectPose& result = *out;
  result.bias_factor_values = std::move(bias_factor_values);
  result.bias_factor_values.clear();
  result.cameras_used = std::move(cameras_used);
  result.cameras_used.clear();
  result.cameras_rejected = std::move(cameras_rejected);
  result.cameras_rejected.clear();
  result.ids_used = std::move(ids_used);
  result.ids_used.clear();
  result.ids_rejected = std::move(ids_rejected);
  result.ids_rejected.clear();
  result.message = std::move(message);
  result.message.clear();
}

namespace {

// 1. Start: the per-marker candidate with the least robust cost over all markers, into (*R,
// *t). With several markers, one flagged ambiguous offers both its planar poses (its kept one
// may be the wrong one, and the others tell). A lone marker starts from the detector's pose
// alone: the detector chose it on more than these points (the stripe's edges, each point's
// own sigma), and on a flat marker the robust cost below may prefer the wrong one. False if no
// marker has a single-marker pose.
bool StartPose(const ObjectPoseOptions& o, std::vector<Block>* blocks, Eigen::Matrix3d* R,
               Eigen::Vector3d* t) {
  double best = std::numeric_limits<double>::infinity();
  for (size_t k = 0; k < blocks->size(); ++k) {
    const MarkerObservation& m = *(*blocks)[k].obs;
    const View& view = *(*blocks)[k].view;
    for (const std::optional<Pose>* cam_from_marker :
         {&m.cam_from_marker, &m.alternative_cam_from_marker}) {
      if (!*cam_from_marker || (blocks->size() == 1 && cam_from_marker != &m.cam_from_marker))
        continue;
      const Pose candidate = ToRig(view, **cam_from_marker * m.object_from_marker.Inverse());
      const Eigen::Matrix3d Rc = candidate.Rotation();
      double cost = 0;
      for (Block& b : *blocks) {
        UpdatePoints(&b, Rc, candidate.tvec, o);
        VecR r;
        MatR6 J;
        if (!Evaluate(b, Rc, candidate.tvec, &r, &J, nullptr)) {
          cost += 1e6;
          continue;
        }
        for (int i = 0; i < 2 * static_cast<int>(b.points.size()); i += 2) {
          const double e =
              r.segment<2>(i).norm() / o.corner_sigma_px;  // Cauchy: robust to outliers
          cost += std::log1p(e * e / 9);
        }
      }
      if (cost < best) {
        best = cost;
        *R = Rc;
        *t = candidate.tvec;
      }
    }
  }
  return std::isfinite(best);
}

// 2. Gauss-Newton from (*R, *t) over the active blocks, each marker's residuals whitened by
// its covariance (refreshed every third iteration: the well's visible bottom and R_m follow
// the pose) and weighted by Cauchy's robust weight; a block that cannot be evaluated is left
// out for good. Stops when PoseGaussNewtonStep says converged, after o.max_iterations, or
// when no block is left.
void FitPose(const ObjectPoseOptions& o, std::vector<Block>* blocks, Eigen::Matrix3d* R_io,
             Eigen::Vector3d* t_io) {
  Eigen::Matrix3d& R = *R_io;
  Eigen::Vector3d& t = *t_io;
  for (Block& b : *blocks) {
    if (!b.active) continue;
    UpdatePoints(&b, R, t, o);
    if (!Whitening(&b, R, t, o)) b.active = false;
  }
  bool converged = false;
  for (int iter = 0; iter < o.max_iterations && !converged; ++iter) {
    Mat6 H = Mat6::Zero();
    Vec6 g = Vec6::Zero();
    int active = 0;
    for (Block& b : *blocks) {
      if (!b.active) continue;
      if (iter > 0 && iter % 3 == 0) {  // the well's visible bottom and R_m follow the pose
        UpdatePoints(&b, R, t, o);
        if (!Whitening(&b, R, t, o)) {
          b.active = false;
          continue;
        }
      }
      VecR r;
      MatR6 J;
      if (!Evaluate(b, R, t, &r, &J, nullptr)) {
        b.active = false;
        continue;
      }
      const VecR wr = b.L_inv * r;
      const MatR6 wJ = b.L_inv * J;
      // The robust weight's norm, for a rig camera with an extrinsics covariance with that
      // error's spread counted (it is not the marker's fault).
      const double norm =
          std::sqrt((b.reject_with_extrinsics ? (b.L_inv_reject * r).eval() : wr).squaredNorm() /
                    static_cast<double>(r.size()));
      b.weight = 1.0 / (1.0 + (norm / o.robust_k) * (norm / o.robust_k));  // Cauchy
      H += b.weight * wJ.transpose() * wJ;
      g += b.weight * wJ.transpose() * wr;
      ++active;
    }
    if (active == 0) break;
    const PoseStep step = PoseGaussNewtonStep(H, g, kObjectPoseTolerances, &R, &t);
    if (step == PoseStep::kFailed) break;
    converged = step == PoseStep::kConverged;
  }
}

// Chi-square of a block at (R, t) over its quantile (> 1: inconsistent), and its worst point
// (*worst_point: 0-3 a corner, 4 the tip, -1 none) in sigmas of pixel and layout noise (and, for
// a rig camera with an extrinsics covariance, of the pixel shift that error gives).
double Excess(const ObjectPoseOptions& o, const Block& b, const Eigen::Matrix3d& R,
              const Eigen::Vector3d& t, int* worst_point, double* worst_norm) {
  VecR r;
  MatR6 J;
  *worst_point = -1;
  *worst_norm = 0;
  if (!Evaluate(b, R, t, &r, &J, nullptr)) return std::numeric_limits<double>::infinity();
  for (size_t k = 0; k < b.points.size(); ++k) {
    const double n = r.segment<2>(2 * k).norm() /
                     (b.reject_with_extrinsics ? b.reject_sigma[k] : b.total_sigma[k]);
    if (n > *worst_norm) {
      *worst_norm = n;
      *worst_point = b.points[k].index;
    }
  }
  return ((b.reject_with_extrinsics ? b.L_inv_reject : b.L_inv) * r).squaredNorm() /
         ChiSquareQuantile(o.reject_quantile, static_cast<int>(r.size()));
}

// 3. Rejection, one thing at a time, each followed by a new fit (FitPose from (*R, *t)). The
// most inconsistent marker (chi-square beyond the reject_quantile) is refitted without its
// worst point: if that makes it consistent, only the point goes (a corner hidden by the post,
// a glint taken for the tip); if not, the whole marker goes (a misread quad, a marker at a
// grazing angle), before it pulls the fit and makes good points elsewhere look bad. Then
// single points beyond point_reject_sigma (pixel and layout noise) go, as long as their marker
// keeps 3. Counts what went in *result; `trial` is a work buffer.
void RejectOutliers(const ObjectPoseOptions& o, std::vector<Block>* blocks_io,
                    std::vector<Block>* trial_io, Eigen::Matrix3d* R, Eigen::Vector3d* t,
                    ObjectPose* result) {
  std::vector<Block>& blocks = *blocks_io;
  std::vector<Block>& trial = *trial_io;
  for (;;) {
    FitPose(o, &blocks, R, t);
    int worst_marker = -1, worst_block = -1, worst_point = -1, active = 0;
    double worst_excess = 1, worst_norm = o.point_reject_sigma;
    for (size_t i = 0; i < blocks.size(); ++i) {
      if (!blocks[i].active) continue;
      ++active;
      int point;
      double norm;
      const double e = Excess(o, blocks[i], *R, *t, &point, &norm);
      if (e > worst_excess) {
        worst_excess = e;
        worst_marker = static_cast<int>(i);
      }
      if (blocks[i].points.size() > 3 && norm > worst_norm) {
        worst_norm = norm;
        worst_block = static_cast<int>(i);
        worst_point = point;
      }
    }
    if (worst_marker >= 0) {
      Block& b = blocks[worst_marker];
      int point;
      double norm;
      Excess(o, b, *R, *t, &point, &norm);
      if (b.points.size() > 3 && point >= 0) {
        trial = blocks;
        trial[worst_marker].dropped[point] = true;
        Eigen::Matrix3d R2 = *R;
        Eigen::Vector3d t2 = *t;
        FitPose(o, &trial, &R2, &t2);
        int p2;
        double n2;
        if (trial[worst_marker].active && Excess(o, trial[worst_marker], R2, t2, &p2, &n2) <= 1) {
          b.dropped[point] = true;
          ++result->points_rejected;
          continue;
        }
      }
      if (active > 1) {
        b.active = false;
        result->ids_rejected.push_back(b.obs->id);
        result->cameras_rejected.push_back(b.view->index);
        continue;
      }
    }
    if (worst_block >= 0) {
      blocks[worst_block].dropped[worst_point] = true;
      ++result->points_rejected;
      continue;
    }
    break;
  }
}

// What the markers kept say at the final pose (step 4).
struct FitInformation {
  Mat6 H = Mat6::Zero();  // their unweighted information, sum of (whitened J)^T (whitened J)
  // The same over their corners and tips alone: the calibration's share is S = -H_points^-1 G
  // (the edges' quadratic does not say how it moves with the intrinsics; the edges lie along
  // the square's sides and move with them, so the pose moves as the corners-and-tips fit
  // does, the detector's own rule for its single-marker covariance).
  Mat6 H_points = Mat6::Zero();
  bool with_calibration = false;  // some G below is filled
  bool with_extrinsics = false;   // some G_extrinsics below is filled
  double ss = 0, chi2 = 0;        // sums of squared residuals, pixels and whitened
  int points = 0;
  int edge_rows = 0;                        // of the edges' quadratics
  bool ambiguous_single = false;            // the last marker's pose was ambiguous
  const MarkerObservation* last = nullptr;  // the last marker used
  const View* last_view = nullptr;          // and its camera
};

// Step 4's sums over the active blocks at (R, t) into *info (and result->ids_used), with the
// calibration's coupling per camera c, G[c] = sum over c's markers of (whitened d r / d pose)^T
// (whitened d r / d intrinsics of c), 6 x N_c, when the covariance is to include it, and the
// extrinsics' coupling G_extrinsics[c] likewise with d r / d rig_from_cam of c (6 x 6; zero
// for a camera without extrinsics covariance). False (result->message says why) if a camera
// gives no intrinsics gradients.
bool AccumulateInformation(const std::vector<View>& views, const ObjectPoseOptions& o,
                           std::vector<Block>* blocks, const Eigen::Matrix3d& R,
                           const Eigen::Vector3d& t, FitInformation* info,
                           std::vector<Eigen::MatrixXd>* G, std::vector<Mat6>* G_extrinsics,
                           ObjectPose* result) {
  if (G->size() < views.size()) G->resize(views.size());
  G_extrinsics->assign(views.size(), Mat6::Zero());
  for (size_t c = 0; c < views.size(); ++c) {
    const Eigen::MatrixXd& intrinsics_factor = views[c].camera->intrinsics_covariance_factor();
    if (o.use_calibration_covariance && intrinsics_factor.size() > 0) {
      info->with_calibration = true;
      (*G)[c].setZero(6, intrinsics_factor.rows());
    } else {
      (*G)[c].resize(0, 0);
    }
    if (o.use_extrinsics_covariance && views[c].extrinsics_covariance) info->with_extrinsics = true;
  }
  thread_local Eigen::MatrixXd J_intrinsics;
  for (Block& b : *blocks) {
    if (!b.active) continue;
    const size_t c = static_cast<size_t>(b.view - views.data());
    UpdatePoints(&b, R, t, o);
    if (!Whitening(&b, R, t, o)) continue;
    VecR r;
    MatR6 J, J_extrinsics;
    const bool extrinsics = o.use_extrinsics_covariance && b.view->extrinsics_covariance;
    if (!Evaluate(b, R, t, &r, &J, nullptr, extrinsics ? &J_extrinsics : nullptr)) continue;
    const MatR6 wJ = b.L_inv * J;
    if ((*G)[c].size() > 0 || extrinsics) {
      const Eigen::Matrix<double, 6, Eigen::Dynamic, 0, 6, kMaxRows> wJt_W =
          wJ.transpose() * b.L_inv;
      if ((*G)[c].size() > 0) {
        // The corners and tips alone (their own whitening without the edge rows).
        Block points = b;
        points.edge_rows = 0;
        VecR r_points;
        MatR6 J_points;
        if (!Whitening(&points, R, t, o) ||
            !Evaluate(points, R, t, &r_points, &J_points, nullptr) ||
            !IntrinsicsJacobian(points, R, t, &J_intrinsics)) {
          result->message = "the camera gives no intrinsics gradients (CAHVORE)";
          return false;
        }
        const MatR6 wJ_points = points.L_inv * J_points;
        info->H_points += wJ_points.transpose() * wJ_points;
        (*G)[c].noalias() +=
            wJ_points.transpose() * points.L_inv * J_intrinsics.topRows(J_points.rows());
      }
      if (extrinsics) (*G_extrinsics)[c].noalias() += wJt_W * J_extrinsics;
    }
    info->H += wJ.transpose() * wJ;
    info->ss += r.head(2 * b.points.size()).squaredNorm();
    info->chi2 += (b.L_inv * r).squaredNorm();
    info->points += static_cast<int>(b.points.size());
    info->edge_rows += b.edge_rows;
    result->ids_used.push_back(b.obs->id);
    result->cameras_used.push_back(b.view->index);
    info->ambiguous_single = b.obs->pose_ambiguous;
    info->last = b.obs;
    info->last_view = b.view;
  }
  return true;
}

// Where camera c's rig_from_cam block of ObjectPose::bias_factor's columns starts. Every
// camera's calibration block comes first, in camera order (its intrinsics_covariance_factor's
// columns, when G[c] is filled), then every camera's rig_from_cam block (6 columns, when the fit
// includes its covariance); c = views.size() gives the number of columns.
int ExtrinsicsBiasColumn(const std::vector<View>& views, const FitInformation& info,
                         const std::vector<Eigen::MatrixXd>& G, size_t c) {
  int column = 0;
  for (size_t k = 0; k < views.size(); ++k)
    if (info.with_calibration && G[k].size() > 0)
      column += static_cast<int>(views[k].camera->intrinsics_covariance_factor().cols());
  for (size_t k = 0; k < std::min(c, views.size()); ++k)
    if (info.with_extrinsics && views[k].extrinsics_covariance) column += 6;
  return column;
}

// The covariance of the fused pose ([rotation, translation], camera axes) from step 4's sums:
// the inverse information, scaled by the variance factor, plus the calibration's share and,
// for a single marker, the detector's widening for its mirror solution. False (with
// result->message) when no marker is left or the pose is not determined.
bool FusedCovariance(const std::vector<View>& views, const ObjectPoseOptions& o,
                     const FitInformation& info, const std::vector<Eigen::MatrixXd>& G,
                     const std::vector<Mat6>& G_extrinsics, const Eigen::Matrix3d& R,
                     const Eigen::Vector3d& t, ObjectPose* out) {
  ObjectPose& result = *out;
  const int points = info.points;
  result.markers_used = static_cast<int>(result.ids_used.size());
  result.points_used = points;
  if (result.markers_used == 0 || points < 3) {
    result.message = "no marker left after rejection";
    return false;
  }
  if (const int rank = InvertFullPivLu(info.H, &result.covariance); rank < 6) {
    result.message = "the pose is not determined (rank " + std::to_string(rank) + " of 6)";
    return false;
  }
  result.covariance = 0.5 * (result.covariance + result.covariance.transpose()).eval();
  const Mat6 H_inv = result.covariance;
  // The frame's own evidence on the noise level: the variance factor's posterior mean under a
  // prior worth variance_prior_dof degrees of freedom at 1 (the nominal noise model).
  const int dof = 2 * points + info.edge_rows - 6;
  result.variance_factor = o.variance_prior_dof > 0 ? (o.variance_prior_dof + info.chi2) /
                                                          (o.variance_prior_dof + std::max(0, dof))
                                                    : 1.0;
  result.covariance *= result.variance_factor;
  // The errors common to every frame, one block of ObjectPose::bias_factor's columns each.
  const int bias_columns = ExtrinsicsBiasColumn(views, info, G, views.size());
  result.bias_factor_values.assign(6 * static_cast<size_t>(bias_columns), 0.0);
  Eigen::Map<Eigen::Matrix<double, 6, Eigen::Dynamic>> B(result.bias_factor_values.data(), 6,
                                                         bias_columns);
  int column = 0;
  if (info.with_calibration) {
    // The calibration's error d intrinsics = L z moves the optimum by d pose = S L z, S =
    // -H_points^-1 G (the implicit function theorem at J^T W r = 0, over the corners and tips:
    // FitInformation); its covariance S L L^T S^T is added after the variance factor (not the
    // frame's noise). The same error is in every frame, so it is a bias along a sequence, not
    // noise that averages away. Each camera's calibration is its own, independent error.
    // The columns are H_points^-1 G L = -S L: a model whose intrinsics are the true ones plus
    // L z puts the object at -S L z from the truth, so PoseError's truth minus estimate is
    // +H_points^-1 G L z (CalibrationBiasFactorIsTheErrorOfTheDraw holds the sign).
    thread_local Eigen::MatrixXd HG;
    Mat6 H_points_inv = H_inv;
    InvertFullPivLu(info.H_points, &H_points_inv);
    for (size_t c = 0; c < views.size(); ++c) {
      if (G[c].size() == 0) continue;
      const Eigen::MatrixXd& L = views[c].camera->intrinsics_covariance_factor();
      HG.noalias() = H_points_inv * G[c];
      auto SL = B.middleCols(column, L.cols());
      SL.noalias() = HG * L;
      result.covariance.noalias() += SL * SL.transpose();
      column += static_cast<int>(L.cols());
    }
    result.calibration_in_covariance = true;
  }
  if (info.with_extrinsics) {
    // The same for each camera's rig_from_cam: its error e (covariance Sigma_c, rig axes) moves
    // the optimum by d pose = -H^-1 G_extrinsics[c] e; (H^-1 G_c) Sigma_c (H^-1 G_c)^T is added.
    // Fixed in every frame like the calibration's: a bias along a sequence.
    for (size_t c = 0; c < views.size(); ++c) {
      if (!views[c].extrinsics_covariance) continue;
      const Mat6 S = H_inv * G_extrinsics[c];
      result.covariance.noalias() += S * *views[c].extrinsics_covariance * S.transpose();
      // A camera truly at exp([e_rot]) R_rc, t_rc + e_trans leaves the object truly moved by
      // -S e from where the fit puts it (PoseError's truth minus estimate).
      B.middleCols<6>(column) = -S * SymmetricSquareRoot(*views[c].extrinsics_covariance);
      column += 6;
    }
    result.extrinsics_in_covariance = true;
  }
  const MarkerObservation* last = info.last;
  if (result.markers_used == 1 && !last->ambiguity_covariance.isZero()) {
    // One marker: its mirror solution is as possible here as it was to the detector. Its
    // widening, about the marker's origin, moved to the object's: with a left perturbation
    // in camera axes, d t_object = d t_marker - [a]x d theta, a = object origin - marker
    // origin (camera axes).
    // In a rig, the widening (camera axes) is first turned into rig axes.
    const Eigen::Vector3d a = t - (R * last->object_from_marker.tvec + t);
    Mat6 J = Mat6::Identity();
    J.bottomLeftCorner<3, 3>() << 0, a.z(), -a.y(), -a.z(), 0, a.x(), a.y(), -a.x(), 0;
    if (!info.last_view->identity) {
      Mat6 rotate = Mat6::Zero();
      rotate.topLeftCorner<3, 3>() = info.last_view->R_rc;
      rotate.bottomRightCorner<3, 3>() = info.last_view->R_rc;
      J = (J * rotate).eval();
    }
    result.covariance += J * last->ambiguity_covariance * J.transpose();
  }
  return true;
}

// Where the fit rests on one marker whose detector pose used the stripe's and decal's edges
// (ObjectPoseOptions::use_marker_pose_with_edges), that pose moved to the object replaces (*R,
// *t) and the covariance: when none of the marker's points was rejected here (the detector's
// pose holds them all), and when the detector's covariance carries the camera calibration's
// share exactly when this fit's would. In a rig it is composed with the camera's
// rig_from_cam (rig axes), whose covariance, if any, is added to first order: an error (a, c)
// of it moves rig_from_object by [a, c - [R_rc t_co]x a].
// The extrinsics' columns of ObjectPose::bias_factor are then those of this rule; the
// calibration's stay the fit's (the detector does not give its sensitivity).
void UseMarkerPoseWithEdges(const std::vector<View>& views, const ObjectPoseOptions& o,
                            const FitInformation& info, const std::vector<Eigen::MatrixXd>& G,
                            Eigen::Matrix3d* R, Eigen::Vector3d* t, ObjectPose* out) {
  ObjectPose& result = *out;
  const MarkerObservation* m = info.last;
  // Not for a marker flagged ambiguous: its edges are left out of the fit too (SetUpEdges),
  // and the fit's own ambiguity result describes the pose it returns.
  if (!o.use_marker_pose_with_edges || result.markers_used != 1 || !m || !info.last_view ||
      result.points_rejected > 0 || m->edge_points <= 0 || !m->cam_from_marker ||
      m->pose_ambiguous || m->calibration_in_marker_covariance != info.with_calibration)
    return;
  Pose cam_from_object;
  PoseCovariance covariance;
  if (!ObjectPoseFromMarker(*m, o.use_layout_covariance, &cam_from_object, &covariance)) return;
  const View& v = *info.last_view;
  std::optional<Mat6> extrinsics_columns;
  if (!v.identity) {
    Mat6 A = Mat6::Zero();
    A.topLeftCorner<3, 3>() = v.R_rc;
    A.bottomRightCorner<3, 3>() = v.R_rc;
    covariance = (A * covariance * A.transpose()).eval();
    if (o.use_extrinsics_covariance && v.extrinsics_covariance) {
      Mat6 JE = Mat6::Identity();
      JE.bottomLeftCorner<3, 3>() = -Skew(v.R_rc * cam_from_object.tvec);
      covariance += JE * *v.extrinsics_covariance * JE.transpose();
      extrinsics_columns = JE * SymmetricSquareRoot(*v.extrinsics_covariance);
    }
    cam_from_object = v.rig_from_cam * cam_from_object;
  }
  if (!covariance.allFinite()) return;
  *R = cam_from_object.Rotation();
  *t = cam_from_object.tvec;
  result.covariance = covariance;
  result.from_marker_pose = true;
  if (extrinsics_columns) {
    const size_t c = static_cast<size_t>(&v - views.data());
    const int column = ExtrinsicsBiasColumn(views, info, G, c);
    Eigen::Map<Eigen::Matrix<double, 6, Eigen::Dynamic>> B(result.bias_factor_values.data(), 6,
                                                           result.bias_columns());
    B.middleCols<6>(column) = *extrinsics_columns;
  }
}

// The rest of the result at the fused pose (R, t): residual statistics, the single marker's
// ambiguity and alternative, the conditioning flag and validity.
void DescribeResult(const ObjectPoseOptions& o, const FitInformation& info,
                    const Eigen::Matrix3d& R, const Eigen::Vector3d& t, ObjectPose* out) {
  ObjectPose& result = *out;
  const int points = info.points;
  const MarkerObservation* last = info.last;
  result.cam_from_object = Pose::FromRotation(R, t);
  result.rms_px = std::sqrt(info.ss / (2.0 * points));
  result.chi2 = info.chi2;
  result.dof = 2 * points + info.edge_rows - 6;
  result.edge_rows = info.edge_rows;
  result.ambiguous = result.markers_used == 1 && info.ambiguous_single;
  if (result.ambiguous && last->alternative_cam_from_marker && last->cam_from_marker) {
    // Should the fit have ended nearer the detector's other pose than its kept one, the kept
    // one is the alternative instead.
    const Pose marker_from_object = last->object_from_marker.Inverse();
    const Pose cam_from_marker = result.cam_from_object * last->object_from_marker;
    const Pose kept = ToRig(*info.last_view, *last->cam_from_marker);
    const Pose other = ToRig(*info.last_view, *last->alternative_cam_from_marker);
    const bool swapped = AngleBetween(cam_from_marker, other) < AngleBetween(cam_from_marker, kept);
    result.alternative_cam_from_object = (swapped ? kept : other) * marker_from_object;
    result.alternative_weight = swapped ? 1 - last->alternative_weight : last->alternative_weight;
  }
  const double rot_sigma_deg =
      std::sqrt(result.covariance.topLeftCorner<3, 3>().diagonal().maxCoeff()) * 180 / M_PI;
  const double trans_sigma = std::sqrt(result.covariance.bottomRightCorner<3, 3>().trace());
  result.poorly_conditioned = rot_sigma_deg > o.max_rotation_sigma_deg ||
                              trans_sigma > o.max_translation_sigma_fraction * t.norm();
  result.valid = result.covariance.allFinite() && result.cam_from_object.tvec.allFinite();
  if (!result.valid) result.message = "the solve gave non-finite numbers";
}

}  // namespace

double CornerFitScale(const ObjectPoseOptions& o, bool correlated) {
  if (o.corner_fit_scale > 0) return o.corner_fit_scale;
  return correlated ? kCornerCovarianceScale : kCornerFitScale;
}

double CornerSigma(const ObjectPoseOptions& o, double side_px) {
  const double side = std::max(1.0, side_px);
  return std::max(o.min_corner_sigma_px,
                  o.corner_sigma_px * std::pow(30.0 / side, o.corner_sigma_exponent));
}

double CornerPixelSigma(const ObjectPoseOptions& o, const MarkerObservation& m, int k) {
  if (!o.corner_sigma_from_fit || !(m.corner_sigma[k] > 0)) return CornerSigma(o, m.side_px);
  const double fit_scale = CornerFitScale(o, CorrelatedCorners(o, m));
  return std::max(o.min_corner_sigma_px,
                  std::hypot(fit_scale * m.corner_sigma[k], o.corner_sigma_systematic_px));
}

double TipPixelSigma(const ObjectPoseOptions& o, const MarkerObservation& m) {
  return std::max(o.min_tip_sigma_px, m.tip ? m.tip->sigma_px : 0.0);
}

std::vector<MarkerObservation> ObservationsFromDetections(const std::vector<Detection>& detections,
                                                          const Layout& layout) {
  std::vector<MarkerObservation> out;
  ObservationsFromDetections(detections, layout, &out);
  return out;
}

void ObservationsFromDetections(const std::vector<Detection>& detections, const Layout& layout,
                                std::vector<MarkerObservation>* observations) {
  std::vector<MarkerObservation>& out = *observations;
  out.clear();
  // Outer markers first, so that a shared post's tip is the outer marker's (a bigger marker
  // predicts it better).
  thread_local std::vector<const Detection*> order;
  order.clear();
  // (Two passes rather than std::stable_sort, which allocates a buffer on every call.)
  for (const Detection& d : detections)
    if (d.nested_in < 0) order.push_back(&d);
  for (const Detection& d : detections)
    if (d.nested_in >= 0) order.push_back(&d);
  for (const Detection* d : order) {
    for (size_t e = 0; e < layout.markers.size(); ++e) {
      const LayoutEntry& entry = layout.markers[e];
      MarkerObservation o;
      if (entry.marker.id == d->id) {
        o.model = entry.marker;
      } else if (entry.marker.inner && entry.marker.inner->id == d->id) {
        std::optional<MarkerModel> inner = entry.marker.InnerModel();
        if (!inner) continue;
        o.model = *inner;
      } else {
        continue;
      }
      o.id = d->id;
      o.object_from_marker = entry.object_from_marker;
      o.layout_covariance = entry.covariance;
      o.post_height_sigma = entry.post_height_sigma;
      o.corners = d->corners;
      o.corner_sigma = d->corner_sigma;
      o.corner_covariance = d->corner_covariance;
      // The shortest side: a marker seen obliquely has fewer edge pixels along it, and its
      // corners are worse than its mean size says.
      o.side_px = std::numeric_limits<double>::infinity();
      for (int k = 0; k < 4; ++k)
        o.side_px = std::min(o.side_px, (d->corners[(k + 1) % 4] - d->corners[k]).norm());
      o.cam_from_marker = d->cam_from_marker;
      o.pose_ambiguous = d->pose_ambiguous;
      o.ambiguity_covariance = d->ambiguity_covariance;
      o.alternative_cam_from_marker = d->alternative_pose;
      o.alternative_weight = d->alternative_weight;
      o.marker_covariance = d->covariance;
      o.calibration_in_marker_covariance = d->calibration_in_covariance;
      o.edge_points = d->edge_points;
      o.edge_information = d->edge_information;
      o.edge_offset = d->edge_offset;
      // One tip per physical post: the inner marker of a dual shares the outer's post, whether
      // the layout has them as one entry or (as the survey writes) as two.
      if (d->tip && o.model.post) {
        o.tip = d->tip;
        const Eigen::Vector3d tip_in_object = o.object_from_marker * *o.model.PostTip();
        for (const MarkerObservation& prev : out)
          if (prev.tip &&
              (prev.object_from_marker * *prev.model.PostTip() - tip_in_object).norm() < 1e-4)
            o.tip.reset();
      }
      out.push_back(o);
      break;
    }
  }
}

bool ObjectPoseFromMarker(const MarkerObservation& m, bool with_layout, Pose* cam_from_object,
                          PoseCovariance* covariance) {
  if (!m.cam_from_marker) return false;
  *cam_from_object = *m.cam_from_marker * m.object_from_marker.Inverse();
  const Eigen::Matrix3d R = cam_from_object->Rotation();
  // The marker's covariance about its origin, moved to the object's: with a left perturbation
  // in camera axes, d t_object = d t_marker - [a]x d theta, a = object origin - marker origin
  // (camera axes).
  const Eigen::Vector3d a = cam_from_object->tvec - m.cam_from_marker->tvec;
  Mat6 J = Mat6::Identity();
  J.bottomLeftCorner<3, 3>() = -Skew(a);
  *covariance = J * m.marker_covariance * J.transpose();
  // The layout's error of object_from_marker (left perturbation, object axes). Its post
  // height's sigma is not counted: the detector fitted the tip at the model's height, and the
  // tip's share of a pose that also has the edges is small.
  if (with_layout && m.layout_covariance) {
    Mat6 JL = Mat6::Zero();
    JL.topLeftCorner<3, 3>() = -R;
    JL.bottomLeftCorner<3, 3>() = -Skew(R * m.object_from_marker.tvec) * R;
    JL.bottomRightCorner<3, 3>() = -R;
    *covariance += JL * *m.layout_covariance * JL.transpose();
  }
  *covariance = 0.5 * (*covariance + covariance->transpose()).eval();
  return true;
}

ObjectPose SolveObjectPose(const CameraModel& camera, const std::vector<MarkerObservation>& obs,
                           const ObjectPoseOptions& o) {
  ObjectPose result;
  SolveObjectPose(camera, obs, o, &result);
  return result;
}

namespace {
// The one solve behind SolveObjectPose and SolveRigObjectPose: observation i is seen by
// views[camera_of(i)].
template <typename CameraOf>
void Solve(const std::vector<View>& views, const std::vector<MarkerObservation>& obs,
           CameraOf camera_of, const ObjectPoseOptions& o, ObjectPose* out) {
  ResetObjectPose(out);
  ObjectPose& result = *out;
  result.markers_seen = static_cast<int>(obs.size());
  if (obs.empty()) {
    result.message = "no marker of the layout detected";
    return;
  }
  thread_local std::vector<Block> blocks, trial;
  blocks.resize(obs.size());
  for (Block& b : blocks) b = Block{};
  for (size_t i = 0; i < obs.size(); ++i) {
    blocks[i].obs = &obs[i];
    blocks[i].view = &views[camera_of(i)];
    blocks[i].R_om = obs[i].object_from_marker.Rotation();
    blocks[i].t_om = obs[i].object_from_marker.tvec;
    SetUpEdges(o, &blocks[i]);
  }

  // 1. Start: the best single-marker candidate.
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
  if (!StartPose(o, &blocks, &R, &t)) {
    result.message = "no detected marker has a single-marker pose to start from";
    return;
  }
  // 2-3. Gauss-Newton, and rejection of outlying markers and points, each followed by a new
  // fit.
  RejectOutliers(o, &blocks, &trial, &R, &t, &result);
  // 4. The result: covariance from the unweighted information of the markers kept.
  thread_local std::vector<Eigen::MatrixXd> G;
  thread_local std::vector<Mat6> G_extrinsics;
  FitInformation info;
  if (!AccumulateInformation(views, o, &blocks, R, t, &info, &G, &G_extrinsics, &result)) return;
  if (!FusedCovariance(views, o, info, G, G_extrinsics, R, t, &result)) return;
  UseMarkerPoseWithEdges(views, o, info, G, &R, &t, &result);
  DescribeResult(o, info, R, t, &result);
}
}  // namespace

void SolveObjectPose(const CameraModel& camera, const std::vector<MarkerObservation>& obs,
                     const ObjectPoseOptions& o, ObjectPose* out) {
  thread_local std::vector<View> views(1);
  views[0] = View{};
  views[0].camera = &camera;
  Solve(
      views, obs, [](size_t) { return 0; }, o, out);
}

ObjectPose SolveRigObjectPose(const std::vector<RigCameraView>& cameras,
                              const std::vector<MarkerObservation>& obs,
                              const ObjectPoseOptions& options) {
  ObjectPose result;
  SolveRigObjectPose(cameras, obs, options, &result);
  return result;
}

void SolveRigObjectPose(const std::vector<RigCameraView>& cameras,
                        const std::vector<MarkerObservation>& obs, const ObjectPoseOptions& o,
                        ObjectPose* out) {
  thread_local std::vector<View> views;
  views.resize(cameras.size());
  for (size_t c = 0; c < cameras.size(); ++c) {
    View& v = views[c];
    v = View{};
    v.camera = cameras[c].camera;
    v.index = static_cast<int>(c);
    v.identity = false;
    v.rig_from_cam = cameras[c].rig_from_cam;
    v.R_rc = v.rig_from_cam.Rotation();
    v.t_rc = v.rig_from_cam.tvec;
    v.R_cr = v.R_rc.transpose();
    v.t_cr = -(v.R_cr * v.t_rc);
    v.extrinsics_covariance =
        cameras[c].rig_from_cam_covariance ? &*cameras[c].rig_from_cam_covariance : nullptr;
  }
  for (size_t i = 0; i < obs.size(); ++i) {
    if (obs[i].camera < 0 || obs[i].camera >= static_cast<int>(cameras.size()) ||
        !cameras[obs[i].camera].camera) {
      ResetObjectPose(out);
      out->markers_seen = static_cast<int>(obs.size());
      out->message = "observation " + std::to_string(i) + " names camera " +
                     std::to_string(obs[i].camera) + "; expected one of the rig's " +
                     std::to_string(cameras.size()) + " cameras";
      return;
    }
  }
  Solve(
      views, obs, [&](size_t i) { return static_cast<size_t>(obs[i].camera); }, o, out);
}

Eigen::Matrix<double, 6, 1> PoseError(const Pose& truth, const Pose& estimate) {
  Eigen::Matrix<double, 6, 1> e;
  e.head<3>() = Log(truth.Rotation() * estimate.Rotation().transpose());
  e.tail<3>() = truth.tvec - estimate.tvec;
  return e;
}

double Nees(const Pose& truth, const Pose& estimate, const PoseCovariance& covariance) {
  const Eigen::Matrix<double, 6, 1> e = PoseError(truth, estimate);
  Eigen::Matrix<double, 6, 1> information_e;  // covariance^-1 e
  if (!SolveLdlt(covariance, e, &information_e)) return std::nan("");
  return e.dot(information_e);
}

}  // namespace svms
