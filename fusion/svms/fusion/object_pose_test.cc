#include "svms/fusion/object_pose.h"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cstdio>
#include <limits>
#include <random>

#include "svms/base/random_draws.h"
#include "svms/datasets/datasets.h"
#include "svms/detect/ippe.h"
#include "svms/geometry/pose.h"
#include "svms/geometry/so3.h"

namespace svms {
namespace {

using Vec3 = Eigen::Vector3d;

// Three markers on three faces of a 1 m box (0.2 m, 0.2 m concave-free, 0.1 m), seen from
// 3 m at an oblique angle through the distorted camera of the datasets.
struct Rig {
  CameraModel camera = DistortedCamera();
  Layout layout;
  Pose cam_from_object;
  Rig() {
    const Vec3 half(0.5, 0.5, 1.0);
    layout.markers.push_back({MarkerModel::Standard(1, 0.2, 0.05), OnBoxFace(half, 2, 1, 0, 0, 0),
                              std::nullopt, std::nullopt});
    layout.markers.push_back({MarkerModel::Standard(2, 0.2, 0.05),
                              OnBoxFace(half, 0, 1, 0.1, 0.5, 0.2), std::nullopt, std::nullopt});
    layout.markers.push_back({MarkerModel::Standard(3, 0.1, 0.025),
                              OnBoxFace(half, 1, 1, -0.2, 0.4, 0), std::nullopt, std::nullopt});
    cam_from_object = LookAt(Vec3(1.6, 1.3, 3.0), Vec3(0, 0, 0.8), Vec3(0, 0, 1));
  }
  // Exact pixels of one marker's corners and tip under `object_from_marker_seen` (the truth
  // may differ from the layout's belief).
  MarkerObservation Observe(int k, const Pose& object_from_marker_seen) const {
    const LayoutEntry& e = layout.markers[k];
    MarkerObservation o;
    o.id = e.marker.id;
    o.model = e.marker;
    o.object_from_marker = e.object_from_marker;
    o.layout_covariance = e.covariance;
    o.post_height_sigma = e.post_height_sigma;
    const Pose cam_from_marker = cam_from_object * object_from_marker_seen;
    const auto corners = e.marker.Corners();
    for (int c = 0; c < 4; ++c)
      EXPECT_TRUE(camera.Project(cam_from_marker * corners[c], &o.corners[c]));
    TipObservation tip;
    EXPECT_TRUE(camera.Project(cam_from_marker * *e.marker.PostTip(), &tip.pixel));
    tip.sigma_px = 0.3;
    o.tip = tip;
    o.cam_from_marker = cam_from_marker;
    return o;
  }
  std::vector<MarkerObservation> ObserveAll() const {
    std::vector<MarkerObservation> obs;
    for (size_t k = 0; k < layout.markers.size(); ++k)
      obs.push_back(Observe(static_cast<int>(k), layout.markers[k].object_from_marker));
    return obs;
  }
};

void AddNoise(std::mt19937_64* rng, double sigma, double tip_sigma, MarkerObservation* o) {
  std::normal_distribution<double> g(0, 1);
  for (auto& c : o->corners) c += sigma * DrawVector2(g, *rng);  // fixed order (random_draws.h)
  if (o->tip) o->tip->pixel += tip_sigma * DrawVector2(g, *rng);
}

TEST(ObjectPose, ExactObservationsGiveTheTruth) {
  const Rig rig;
  std::vector<MarkerObservation> obs = rig.ObserveAll();
  // Start from a poor single-marker pose: the fit must still converge to the truth.
  for (auto& o : obs) o.cam_from_marker->rvec += Vec3(0.05, -0.03, 0.02);
  const ObjectPose p = SolveObjectPose(rig.camera, obs, ObjectPoseOptions{});
  ASSERT_TRUE(p.valid) << p.message;
  EXPECT_EQ(p.markers_used, 3);
  EXPECT_EQ(p.points_used, 15);
  EXPECT_EQ(p.dof, 24);
  EXPECT_LT(PoseError(rig.cam_from_object, p.cam_from_object).norm(), 1e-9);
  EXPECT_LT(p.rms_px, 1e-7);
  EXPECT_FALSE(p.poorly_conditioned);
  EXPECT_TRUE(p.ids_rejected.empty());
}

TEST(ObjectPose, NothingToFitIsInvalidWithAReason) {
  const Rig rig;
  const ObjectPose p = SolveObjectPose(rig.camera, {}, ObjectPoseOptions{});
  EXPECT_FALSE(p.valid);
  EXPECT_NE(p.message.find("no marker"), std::string::npos);
  std::vector<MarkerObservation> obs = rig.ObserveAll();
  for (auto& o : obs) o.cam_from_marker.reset();
  EXPECT_FALSE(SolveObjectPose(rig.camera, obs, ObjectPoseOptions{}).valid);
}

// The covariance is honest when the noise is what the options say: NEES ~ chi-square(6).
TEST(ObjectPose, MonteCarloNeesMatchesChiSquareSix) {
  const Rig rig;
  std::mt19937_64 rng(7);
  ObjectPoseOptions o;
  o.corner_sigma_px = 0.15;
  o.min_tip_sigma_px = 0.3;
  const int trials = 1000;
  double sum = 0;
  for (int i = 0; i < trials; ++i) {
    std::vector<MarkerObservation> obs = rig.ObserveAll();
    for (auto& m : obs) AddNoise(&rng, 0.15, 0.3, &m);
    const ObjectPose p = SolveObjectPose(rig.camera, obs, o);
    ASSERT_TRUE(p.valid);
    sum += Nees(rig.cam_from_object, p.cam_from_object, p.covariance);
  }
  // Mean of 1000 chi-square(6) draws: 6 +- 0.077 (1 sigma); allow 4 sigma.
  EXPECT_NEAR(sum / trials, 6.0, 0.31);
}

// Corners that err together as the line fits say (two on a side in opposite directions across
// it): drawn from each marker's 8 x 8 corner covariance, the fused pose's NEES is chi-square(6)
// when the fusion whitens with that covariance, and not when it takes the corners as
// independent with the same per-corner sigmas. With a diagonal covariance both models agree.
TEST(ObjectPose, CorrelatedCornerNoiseIsWhitenedByTheCornersJointCovariance) {
  const Rig rig;
  std::mt19937_64 rng(11);
  std::normal_distribution<double> g(0, 1);
  const double sigma = 0.15, rho = -0.68;  // across a side, between its two ends
  // One marker's corner covariance: each side's line moves across itself at its two ends with
  // variance v and correlation rho; a corner moves as the two lines through it (sides at right
  // angles in this approximation, each corner's variance sigma^2 per axis).
  auto covariance_of = [&](const MarkerObservation& m) {
    Eigen::Matrix<double, 8, 8> moves = Eigen::Matrix<double, 8, 8>::Zero(), A = moves;
    std::array<Eigen::Vector2d, 4> n;
    for (int k = 0; k < 4; ++k) {
      const Eigen::Vector2d u = (m.corners[(k + 1) % 4] - m.corners[k]).normalized();
      n[k] = Eigen::Vector2d(u.y(), -u.x());
      moves.block<2, 2>(2 * k, 2 * k) << 1, rho, rho, 1;
    }
    for (int k = 0; k < 4; ++k) {
      const int j = (k + 3) % 4;
      Eigen::Matrix2d N;
      N << n[j].transpose(), n[k].transpose();
      const Eigen::Matrix2d N_inv = N.inverse();
      A.block<2, 1>(2 * k, 2 * j + 1) = N_inv.col(0);
      A.block<2, 1>(2 * k, 2 * k) = N_inv.col(1);
    }
    Eigen::Matrix<double, 8, 8> C = A * moves * A.transpose();
    for (int k = 0; k < 4; ++k) {  // each corner's mean variance sigma^2
      const double s = sigma / std::sqrt(0.5 * C.block<2, 2>(2 * k, 2 * k).trace());
      C.middleRows<2>(2 * k) *= s;
      C.middleCols<2>(2 * k) *= s;
    }
    return Eigen::Matrix<double, 8, 8>(0.5 * (C + C.transpose()));
  };
  ObjectPoseOptions joint;
  joint.corner_covariance_from_fit = true;
  joint.corner_fit_scale = 1;
  joint.use_tips = false;
  ObjectPoseOptions independent = joint;
  independent.corner_covariance_from_fit = false;
  const int trials = 1000;
  double nees_joint = 0, nees_independent = 0;
  for (int i = 0; i < trials; ++i) {
    std::vector<MarkerObservation> obs = rig.ObserveAll();
    for (auto& m : obs) {
      m.corner_covariance = covariance_of(m);
      m.corner_sigma.fill(sigma);
      Eigen::Matrix<double, 8, 1> z;
      for (int r = 0; r < 8; ++r) z[r] = g(rng);
      const Eigen::Matrix<double, 8, 1> e = m.corner_covariance.llt().matrixL() * z;
      for (int k = 0; k < 4; ++k) m.corners[k] += e.segment<2>(2 * k);
    }
    const ObjectPose pj = SolveObjectPose(rig.camera, obs, joint);
    const ObjectPose pi = SolveObjectPose(rig.camera, obs, independent);
    ASSERT_TRUE(pj.valid && pi.valid);
    nees_joint += Nees(rig.cam_from_object, pj.cam_from_object, pj.covariance);
    nees_independent += Nees(rig.cam_from_object, pi.cam_from_object, pi.covariance);
  }
  // Mean of 1000 chi-square(6) draws: 6 +- 0.077 (1 sigma); allow 4 sigma.
  EXPECT_NEAR(nees_joint / trials, 6.0, 0.31);
  EXPECT_GT(std::abs(nees_independent / trials - 6.0), 1.0) << nees_independent / trials;

  // A diagonal joint covariance is the independent model: the same pose and covariance.
  std::vector<MarkerObservation> obs = rig.ObserveAll();
  for (auto& m : obs) {
    AddNoise(&rng, sigma, 0, &m);
    m.corner_sigma.fill(sigma);
    m.corner_covariance = Eigen::Matrix<double, 8, 8>::Identity() * sigma * sigma;
  }
  const ObjectPose a = SolveObjectPose(rig.camera, obs, joint);
  const ObjectPose b = SolveObjectPose(rig.camera, obs, independent);
  ASSERT_TRUE(a.valid && b.valid);
  EXPECT_LT(PoseError(a.cam_from_object, b.cam_from_object).norm(), 1e-12);
  EXPECT_LT((a.covariance - b.covariance).norm(), 1e-12 * a.covariance.norm());
}

// A layout that is itself uncertain: the markers really sit off their surveyed poses by draws
// from the layout covariance. Including it keeps NEES at 6; leaving it out is optimistic.
TEST(ObjectPose, LayoutUncertaintyIsPropagated) {
  Rig rig;
  PoseCovariance S = PoseCovariance::Zero();
  S.diagonal() << std::pow(0.002, 2), std::pow(0.002, 2), std::pow(0.002, 2), std::pow(0.001, 2),
      std::pow(0.001, 2), std::pow(0.001, 2);
  for (auto& e : rig.layout.markers) e.covariance = S;
  const Eigen::LLT<PoseCovariance> llt(S);
  std::mt19937_64 rng(11);
  std::normal_distribution<double> g(0, 1);
  ObjectPoseOptions with, without;
  with.corner_sigma_px = without.corner_sigma_px = 0.1;
  without.use_layout_covariance = false;
  const int trials = 1000;
  double nees_with = 0, nees_without = 0;
  for (int i = 0; i < trials; ++i) {
    std::vector<MarkerObservation> obs;
    for (int k = 0; k < 3; ++k) {
      Eigen::Matrix<double, 6, 1> d;
      for (int j = 0; j < 6; ++j) d[j] = g(rng);
      d = llt.matrixL() * d;
      const Pose& belief = rig.layout.markers[k].object_from_marker;
      // Left perturbation in object axes, as layout.h documents.
      const Eigen::Matrix3d R =
          Eigen::AngleAxisd(d.head<3>().norm(), d.head<3>().normalized()).toRotationMatrix() *
          belief.Rotation();
      MarkerObservation o = rig.Observe(k, Pose::FromRotation(R, belief.tvec + d.tail<3>()));
      AddNoise(&rng, 0.1, 0.3, &o);
      obs.push_back(o);
    }
    const ObjectPose a = SolveObjectPose(rig.camera, obs, with);
    const ObjectPose b = SolveObjectPose(rig.camera, obs, without);
    ASSERT_TRUE(a.valid && b.valid);
    nees_with += Nees(rig.cam_from_object, a.cam_from_object, a.covariance);
    nees_without += Nees(rig.cam_from_object, b.cam_from_object, b.covariance);
  }
  EXPECT_NEAR(nees_with / trials, 6.0, 0.35);
  EXPECT_GT(nees_without / trials, 12.0);  // the layout's error dominates here
}

// A calibration's covariance factor L (n x n) for n intrinsics: the focal lengths and principal
// point by about 1 px, the distortion by 2e-3, neighbours correlated by 0.4.
Eigen::MatrixXd CalibrationFactor(int n) {
  Eigen::VectorXd sigma = Eigen::VectorXd::Constant(n, 2e-3);
  sigma.head<4>() << 1.0, 1.2, 0.8, 0.9;
  Eigen::MatrixXd correlation = Eigen::MatrixXd::Identity(n, n);
  for (int i = 0; i + 1 < n; ++i) correlation(i, i + 1) = correlation(i + 1, i) = 0.4;
  return sigma.asDiagonal() * Eigen::MatrixXd(correlation.llt().matrixL());
}

// `truth` with its intrinsics moved by `off` and the calibration covariance factor L.
CameraModel Calibrated(const CameraModel& truth, const Eigen::VectorXd& off,
                       const Eigen::MatrixXd& L) {
  std::vector<double> intrinsics = truth.intrinsics();
  for (size_t k = 0; k < intrinsics.size(); ++k) intrinsics[k] += off[static_cast<Eigen::Index>(k)];
  CameraModel calibrated;
  EXPECT_TRUE(
      CameraModel::Create(truth.lensmodel(), intrinsics, truth.width(), truth.height(), &calibrated)
          .ok());
  EXPECT_TRUE(calibrated.set_intrinsics_covariance_factor(L).ok());
  return calibrated;
}

Eigen::VectorXd StandardNormal(std::mt19937_64* rng, int n) {
  std::normal_distribution<double> g(0, 1);
  Eigen::VectorXd z(n);
  for (int k = 0; k < n; ++k) z[k] = g(*rng);
  return z;
}

// A camera whose intrinsics are off by draws from its calibration's covariance
// (CalibrationFactor): with that covariance on the camera, NEES stays at 6; without it, the
// pose is overconfident.
TEST(ObjectPose, CalibrationUncertaintyIsPropagated) {
  const Rig rig;
  const CameraModel& truth = rig.camera;
  const int n = static_cast<int>(truth.intrinsics().size());
  const Eigen::MatrixXd L = CalibrationFactor(n);
  std::mt19937_64 rng(13);
  std::normal_distribution<double> g(0, 1);
  ObjectPoseOptions with, without;
  with.corner_sigma_px = without.corner_sigma_px = 0.1;
  without.use_calibration_covariance = false;
  const int trials = 1000;
  double nees_with = 0, nees_without = 0;
  for (int i = 0; i < trials; ++i) {
    Eigen::VectorXd z(n);
    for (int k = 0; k < n; ++k) z[k] = g(rng);
    const CameraModel calibrated = Calibrated(truth, L * z, L);
    std::vector<MarkerObservation> obs = rig.ObserveAll();  // through the true camera
    for (auto& m : obs) AddNoise(&rng, 0.1, 0.3, &m);
    const ObjectPose a = SolveObjectPose(calibrated, obs, with);
    const ObjectPose b = SolveObjectPose(calibrated, obs, without);
    ASSERT_TRUE(a.valid && b.valid);
    EXPECT_TRUE(a.calibration_in_covariance);
    EXPECT_FALSE(b.calibration_in_covariance);
    nees_with += Nees(rig.cam_from_object, a.cam_from_object, a.covariance);
    nees_without += Nees(rig.cam_from_object, b.cam_from_object, b.covariance);
  }
  EXPECT_NEAR(nees_with / trials, 6.0, 0.35);
  EXPECT_GT(nees_without / trials, 12.0);  // the calibration's error dominates here
}

// ObjectPose::bias_factor B holds the calibration's share of the covariance (B B^T is what the
// share adds) and is the pose's response to the calibration's error: with a camera model whose
// intrinsics are the true ones plus L z and exact pixels through the true camera, the error
// PoseError(truth, estimate) is B z to first order, for every draw z.
TEST(ObjectPose, CalibrationBiasFactorIsTheErrorOfTheDraw) {
  const Rig rig;
  const int n = static_cast<int>(rig.camera.intrinsics().size());
  const Eigen::MatrixXd L = CalibrationFactor(n);
  std::mt19937_64 rng(5);
  ObjectPoseOptions without;
  without.use_calibration_covariance = false;
  const std::vector<MarkerObservation> obs = rig.ObserveAll();
  for (int trial = 0; trial < 20; ++trial) {
    const Eigen::VectorXd z = StandardNormal(&rng, n);
    const CameraModel calibrated = Calibrated(rig.camera, L * z, L);
    const ObjectPose a = SolveObjectPose(calibrated, obs, ObjectPoseOptions{});
    const ObjectPose b = SolveObjectPose(calibrated, obs, without);
    ASSERT_TRUE(a.valid && b.valid) << a.message << b.message;
    ASSERT_EQ(a.bias_columns(), L.cols());
    EXPECT_EQ(b.bias_columns(), 0);
    const PoseCovariance share = a.bias_factor() * a.bias_factor().transpose();
    EXPECT_LT((share - (a.covariance - b.covariance)).norm(), 1e-9 * share.norm());
    const Eigen::Matrix<double, 6, 1> predicted = a.bias_factor() * z;
    const Eigen::Matrix<double, 6, 1> error = PoseError(rig.cam_from_object, a.cam_from_object);
    // About 1 px of intrinsics error: first order to a few per cent.
    EXPECT_LT((error - predicted).norm(), 0.05 * predicted.norm())
        << "error " << error.transpose() << "\npredicted " << predicted.transpose();
  }
}

// More markers, more information: the fused covariance is below every single marker's.
TEST(ObjectPose, FusedCovarianceIsBelowEachSingleMarkers) {
  const Rig rig;
  const std::vector<MarkerObservation> all = rig.ObserveAll();
  const ObjectPose fused = SolveObjectPose(rig.camera, all, ObjectPoseOptions{});
  ASSERT_TRUE(fused.valid);
  for (const MarkerObservation& one : all) {
    const ObjectPose single = SolveObjectPose(rig.camera, {one}, ObjectPoseOptions{});
    ASSERT_TRUE(single.valid);
    EXPECT_EQ(single.markers_used, 1);
    // Loewner order: single - fused is positive semi-definite.
    const Eigen::SelfAdjointEigenSolver<PoseCovariance> es(single.covariance - fused.covariance);
    EXPECT_GT(es.eigenvalues().minCoeff(), -1e-12 * single.covariance.norm());
    EXPECT_LT(fused.covariance.trace(), 0.8 * single.covariance.trace());
  }
}

// One marker's observations are wrong (a wrong layout entry, a misdetection): it is rejected
// and the others give the truth.
TEST(ObjectPose, AnInconsistentMarkerIsRejected) {
  const Rig rig;
  std::vector<MarkerObservation> obs = rig.ObserveAll();
  for (auto& c : obs[1].corners) c += Eigen::Vector2d(4, -3);
  obs[1].tip->pixel += Eigen::Vector2d(4, -3);
  const ObjectPose p = SolveObjectPose(rig.camera, obs, ObjectPoseOptions{});
  ASSERT_TRUE(p.valid);
  ASSERT_EQ(p.ids_rejected.size(), 1u);
  EXPECT_EQ(p.ids_rejected[0], 2);
  EXPECT_EQ(p.markers_used, 2);
  EXPECT_EQ(p.points_rejected, 0);  // the bad marker went first: no good point was dropped
  EXPECT_LT(PoseError(rig.cam_from_object, p.cam_from_object).norm(), 1e-8);
}

// One corner is off (hidden by the post, pulled by a neighbouring edge): that corner goes,
// the marker stays.
TEST(ObjectPose, ASingleBadCornerIsDroppedAndItsMarkerKept) {
  const Rig rig;
  std::vector<MarkerObservation> obs = rig.ObserveAll();
  obs[0].corners[2] += Eigen::Vector2d(1.5, 0.5);
  const ObjectPose p = SolveObjectPose(rig.camera, obs, ObjectPoseOptions{});
  ASSERT_TRUE(p.valid);
  EXPECT_TRUE(p.ids_rejected.empty());
  EXPECT_EQ(p.points_rejected, 1);
  EXPECT_EQ(p.points_used, 14);
  EXPECT_LT(PoseError(rig.cam_from_object, p.cam_from_object).norm(), 1e-8);
}

TEST(ObjectPose, CornerSigmaFollowsTheMarkerSize) {
  ObjectPoseOptions o;
  o.corner_sigma_px = 0.05;
  EXPECT_DOUBLE_EQ(CornerSigma(o, 30), 0.05);
  EXPECT_NEAR(CornerSigma(o, 120), 0.025, 1e-12);
  EXPECT_DOUBLE_EQ(CornerSigma(o, 1e9), o.min_corner_sigma_px);
  EXPECT_TRUE(std::isfinite(CornerSigma(o, 0)));
}

TEST(ObjectPose, ObservationsFromDetectionsMatchTheLayoutAndShareADualsPost) {
  Layout layout;
  MarkerModel dual = MarkerModel::Standard(10, 0.432, 0.027);
  dual.AddInner(11, 0.108);
  layout.markers.push_back({dual, Pose{}, std::nullopt, std::nullopt});
  layout.markers.push_back({MarkerModel::Standard(12, 0.2, 0.05),
                            Pose{Vec3(0, 0, 0), Vec3(1, 0, 0)}, std::nullopt, 0.001});
  std::vector<Detection> dets(4);
  dets[0].id = 11;  // the inner marker, listed first
  dets[0].nested_in = 10;
  dets[0].tip = TipObservation{Eigen::Vector2d(1, 2), 0.4};
  dets[1].id = 10;
  dets[1].tip = TipObservation{Eigen::Vector2d(1.1, 2), 0.3};
  dets[2].id = 12;
  dets[3].id = 99;  // not in the layout
  const std::vector<MarkerObservation> obs = ObservationsFromDetections(dets, layout);
  ASSERT_EQ(obs.size(), 3u);  // 99 is not in the layout
  // Outer markers first: the shared tip is the outer marker's.
  EXPECT_EQ(obs[0].id, 10);
  ASSERT_TRUE(obs[0].tip.has_value());
  EXPECT_EQ(obs[0].tip->pixel.x(), 1.1);
  EXPECT_EQ(obs[1].id, 12);
  EXPECT_EQ(obs[1].object_from_marker.tvec.x(), 1);
  EXPECT_EQ(*obs[1].post_height_sigma, 0.001);
  EXPECT_EQ(obs[2].id, 11);
  EXPECT_FALSE(obs[2].tip.has_value());
  EXPECT_NEAR(obs[2].model.size, 0.108, 1e-12);
}

// One marker whose detector could not rule out its mirror pose: that widening reaches the
// fused covariance, moved from the marker's origin to the object's; with two markers it does
// not (the geometry settles it).
TEST(ObjectPose, ASingleMarkersMirrorPoseWidensTheFusedCovariance) {
  const Rig rig;
  std::vector<MarkerObservation> one = {rig.Observe(0, rig.layout.markers[0].object_from_marker)};
  const ObjectPose base = SolveObjectPose(rig.camera, one, ObjectPoseOptions{});
  ASSERT_TRUE(base.valid) << base.message;
  PoseCovariance A = PoseCovariance::Zero();
  A.topLeftCorner<3, 3>() = Eigen::Vector3d(4e-4, 1e-4, 0).asDiagonal();
  A(3, 3) = 1e-6;
  one[0].ambiguity_covariance = A;
  one[0].pose_ambiguous = true;
  const ObjectPose widened = SolveObjectPose(rig.camera, one, ObjectPoseOptions{});
  ASSERT_TRUE(widened.valid) << widened.message;
  EXPECT_TRUE(widened.ambiguous);
  // The expected move, written out: a rotation d about the marker's origin moves the object's
  // origin by d x a, a from the marker's origin to the object's (camera axes).
  const Pose cam_from_marker = widened.cam_from_object * rig.layout.markers[0].object_from_marker;
  const Vec3 a = widened.cam_from_object.tvec - cam_from_marker.tvec;
  Eigen::Matrix<double, 6, 6> J = Eigen::Matrix<double, 6, 6>::Identity();
  for (int k = 0; k < 3; ++k) J.block<3, 1>(3, k) = Vec3::Unit(k).cross(a);
  const PoseCovariance expected = base.covariance + J * A * J.transpose();
  EXPECT_LT((widened.covariance - expected).cwiseAbs().maxCoeff(), 1e-9 * expected.norm());
  // Two markers: no widening.
  std::vector<MarkerObservation> two = {one[0],
                                        rig.Observe(1, rig.layout.markers[1].object_from_marker)};
  two[1].ambiguity_covariance = A;
  std::vector<MarkerObservation> two_plain = two;
  for (auto& o : two_plain) o.ambiguity_covariance.setZero();
  const ObjectPose p2 = SolveObjectPose(rig.camera, two, ObjectPoseOptions{});
  const ObjectPose p2_plain = SolveObjectPose(rig.camera, two_plain, ObjectPoseOptions{});
  ASSERT_TRUE(p2.valid && p2_plain.valid);
  EXPECT_FALSE(p2.ambiguous);
  EXPECT_LT((p2.covariance - p2_plain.covariance).cwiseAbs().maxCoeff(), 1e-15);
}

// A single ambiguous marker's other planar pose becomes the object's alternative, moved by the
// same marker_from_object; where the fit leaves the detector's pose for the other one (the tip
// settles it), the two swap and so do their weights. With two markers there is none.
TEST(ObjectPose, ASingleMarkersAlternativePoseIsTheObjectsAlternative) {
  const Rig rig;
  const Pose& object_from_marker = rig.layout.markers[0].object_from_marker;
  const Pose truth = rig.cam_from_object * object_from_marker;
  const Pose twin = PlanarTwin(truth);
  ASSERT_GT(AngleBetweenDeg(truth, twin), 10);
  MarkerObservation o = rig.Observe(0, object_from_marker);
  o.pose_ambiguous = true;
  o.ambiguity_covariance = 1e-6 * PoseCovariance::Identity();
  o.alternative_cam_from_marker = twin;
  o.alternative_weight = 0.2;
  const ObjectPose right = SolveObjectPose(rig.camera, {o}, ObjectPoseOptions{});
  ASSERT_TRUE(right.valid && right.ambiguous) << right.message;
  ASSERT_TRUE(right.alternative_cam_from_object.has_value());
  EXPECT_LT(AngleBetweenDeg(right.cam_from_object, rig.cam_from_object), 1e-6);
  const Pose expected = twin * object_from_marker.Inverse();
  EXPECT_LT(AngleBetweenDeg(*right.alternative_cam_from_object, expected), 1e-9);
  EXPECT_LT((right.alternative_cam_from_object->tvec - expected.tvec).norm(), 1e-12);
  EXPECT_DOUBLE_EQ(right.alternative_weight, 0.2);

  // Where the fit ends nearer the detector's other pose than its kept one, the two swap, and
  // so do their weights.
  MarkerObservation near = o;
  near.cam_from_marker = Pose::FromRotation(
      Eigen::AngleAxisd(3 * M_PI / 180, Vec3::UnitX()).toRotationMatrix() * truth.Rotation(),
      truth.tvec);
  near.alternative_cam_from_marker = truth;
  near.alternative_weight = 0.3;
  const ObjectPose swapped = SolveObjectPose(rig.camera, {near}, ObjectPoseOptions{});
  ASSERT_TRUE(swapped.valid && swapped.ambiguous) << swapped.message;
  EXPECT_LT(AngleBetweenDeg(swapped.cam_from_object, rig.cam_from_object), 1e-6);
  ASSERT_TRUE(swapped.alternative_cam_from_object.has_value());
  EXPECT_LT(AngleBetweenDeg(*swapped.alternative_cam_from_object,
                            *near.cam_from_marker * object_from_marker.Inverse()),
            1e-9);
  EXPECT_DOUBLE_EQ(swapped.alternative_weight, 0.7);

  // Not flagged, or not alone: no alternative.
  MarkerObservation plain = o;
  plain.pose_ambiguous = false;
  EXPECT_FALSE(
      SolveObjectPose(rig.camera, {plain}, ObjectPoseOptions{}).alternative_cam_from_object);
  const ObjectPose two =
      SolveObjectPose(rig.camera, {o, rig.Observe(1, rig.layout.markers[1].object_from_marker)},
                      ObjectPoseOptions{});
  ASSERT_TRUE(two.valid);
  EXPECT_FALSE(two.ambiguous);
  EXPECT_FALSE(two.alternative_cam_from_object);
  EXPECT_EQ(two.alternative_weight, 0);
}

// Two markers, and the only single-marker pose to start from is the wrong planar one of the
// first (the second's detection gave none): its alternative is a start too, and the fit
// over both ends at the truth with both markers kept.
TEST(ObjectPose, AnAmbiguousMarkersAlternativeIsAStart) {
  const Rig rig;
  std::vector<MarkerObservation> obs = {rig.Observe(0, rig.layout.markers[0].object_from_marker),
                                        rig.Observe(1, rig.layout.markers[1].object_from_marker)};
  const Pose truth = *obs[0].cam_from_marker;
  obs[0].cam_from_marker = PlanarTwin(truth);
  obs[0].pose_ambiguous = true;
  obs[0].alternative_cam_from_marker = truth;
  obs[0].alternative_weight = 0.4;
  obs[1].cam_from_marker.reset();
  const ObjectPose p = SolveObjectPose(rig.camera, obs, ObjectPoseOptions{});
  ASSERT_TRUE(p.valid) << p.message;
  EXPECT_LT(AngleBetweenDeg(p.cam_from_object, rig.cam_from_object), 1e-6);
  EXPECT_EQ(p.markers_used, 2);
  EXPECT_FALSE(p.ambiguous);
  EXPECT_FALSE(p.alternative_cam_from_object);
}

// The object pose from one marker's own pose: the composition, and the covariance's two
// first-order terms checked against finite differences of the composition itself (a small
// error of cam_from_marker, then of the layout's object_from_marker, each a left perturbation:
// camera axes for the first, object axes for the second).
TEST(ObjectPose, ObjectPoseFromMarkerMovesTheCovarianceAndAddsTheLayouts) {
  const Rig rig;
  MarkerObservation m = rig.Observe(1, rig.layout.markers[1].object_from_marker);
  Pose cam_from_object;
  PoseCovariance C;
  EXPECT_FALSE(ObjectPoseFromMarker(MarkerObservation{}, true, &cam_from_object, &C));
  ASSERT_TRUE(ObjectPoseFromMarker(m, true, &cam_from_object, &C));
  EXPECT_LT(PoseError(rig.cam_from_object, cam_from_object).norm(), 1e-12);
  EXPECT_LT(C.cwiseAbs().maxCoeff(), 1e-300);  // no covariance given, none made up
  auto perturbed = [](const Pose& p, const Eigen::Matrix<double, 6, 1>& d) {
    return Pose::FromRotation(Exp(Vec3(d.head<3>())) * p.Rotation(), p.tvec + d.tail<3>());
  };
  const double h = 1e-7;
  Eigen::Matrix<double, 6, 6> J_marker, J_layout;
  for (int k = 0; k < 6; ++k) {
    const Eigen::Matrix<double, 6, 1> d = h * Eigen::Matrix<double, 6, 1>::Unit(k);
    MarkerObservation a = m;
    a.cam_from_marker = perturbed(*m.cam_from_marker, d);
    Pose p;
    ASSERT_TRUE(ObjectPoseFromMarker(a, false, &p, &C));
    J_marker.col(k) = -PoseError(cam_from_object, p) / h;  // PoseError: truth - estimate
    MarkerObservation b = m;
    b.object_from_marker = perturbed(m.object_from_marker, d);
    ASSERT_TRUE(ObjectPoseFromMarker(b, false, &p, &C));
    J_layout.col(k) = -PoseError(cam_from_object, p) / h;
  }
  // Covariances with every entry in play (rotation-translation cross terms too).
  Eigen::Matrix<double, 6, 6> A;
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < 6; ++j) A(i, j) = std::sin(1.0 + i + 3.0 * j);
  const PoseCovariance S_marker = 1e-6 * (A * A.transpose() + PoseCovariance::Identity());
  const PoseCovariance S_layout = 1e-6 * (A.transpose() * A + PoseCovariance::Identity());
  m.marker_covariance = S_marker;
  m.layout_covariance = S_layout;
  ASSERT_TRUE(ObjectPoseFromMarker(m, false, &cam_from_object, &C));
  const PoseCovariance expect_marker = J_marker * S_marker * J_marker.transpose();
  EXPECT_LT((C - expect_marker).cwiseAbs().maxCoeff(), 1e-5 * expect_marker.norm());
  ASSERT_TRUE(ObjectPoseFromMarker(m, true, &cam_from_object, &C));
  const PoseCovariance expect = expect_marker + J_layout * S_layout * J_layout.transpose();
  EXPECT_LT((C - expect).cwiseAbs().maxCoeff(), 1e-5 * expect.norm());
  // The layout's share is not negligible here (the test would not see a wrong term).
  EXPECT_GT((expect - expect_marker).norm(), 0.1 * expect_marker.norm());
}

// A lone marker whose detector pose fitted its stripe and decal edges: the fused pose is that
// pose moved to the object, with the detector's covariance moved likewise (and the layout's
// added); without edges, with the option off, or with one of its points rejected here, the
// fusion refits from the corners and tip.
TEST(ObjectPose, ALoneMarkerWithEdgesGivesItsOwnPose) {
  const Rig rig;
  MarkerObservation m = rig.Observe(0, rig.layout.markers[0].object_from_marker);
  // The detector's pose: off the corners' own solution by a small rotation (what the edges
  // moved it by), with a covariance.
  m.cam_from_marker = Pose::FromRotation(Exp(Vec3(2e-3, -1e-3, 0)) * m.cam_from_marker->Rotation(),
                                         m.cam_from_marker->tvec + Vec3(1e-4, 0, 0));
  m.marker_covariance = PoseCovariance::Identity() * 1e-6;
  m.layout_covariance = PoseCovariance::Identity() * 1e-8;
  m.edge_points = 90;
  Pose expected_pose;
  PoseCovariance expected_covariance;
  ASSERT_TRUE(ObjectPoseFromMarker(m, true, &expected_pose, &expected_covariance));
  const ObjectPose p = SolveObjectPose(rig.camera, {m}, ObjectPoseOptions{});
  ASSERT_TRUE(p.valid) << p.message;
  EXPECT_TRUE(p.from_marker_pose);
  EXPECT_LT(PoseError(expected_pose, p.cam_from_object).norm(), 1e-12);
  EXPECT_LT((p.covariance - expected_covariance).cwiseAbs().maxCoeff(), 1e-18);
  EXPECT_EQ(p.markers_used, 1);
  // The refit over the corners and tip goes back to their exact solution (the truth).
  auto refits = [&](const MarkerObservation& o, const ObjectPoseOptions& options) {
    const ObjectPose q = SolveObjectPose(rig.camera, {o}, options);
    EXPECT_TRUE(q.valid) << q.message;
    EXPECT_FALSE(q.from_marker_pose);
    EXPECT_LT(PoseError(rig.cam_from_object, q.cam_from_object).norm(), 1e-8);
  };
  MarkerObservation no_edges = m;
  no_edges.edge_points = 0;
  refits(no_edges, ObjectPoseOptions{});
  ObjectPoseOptions off;
  off.use_marker_pose_with_edges = false;
  refits(m, off);
  MarkerObservation glint = m;
  glint.tip->pixel += Eigen::Vector2d(4, 3);  // a glint taken for the tip: rejected here
  const ObjectPose q = SolveObjectPose(rig.camera, {glint}, ObjectPoseOptions{});
  ASSERT_TRUE(q.valid) << q.message;
  EXPECT_EQ(q.points_rejected, 1);
  EXPECT_FALSE(q.from_marker_pose);
  // Two markers: the joint fit, as before.
  const ObjectPose two =
      SolveObjectPose(rig.camera, {m, rig.Observe(1, rig.layout.markers[1].object_from_marker)},
                      ObjectPoseOptions{});
  ASSERT_TRUE(two.valid) << two.message;
  EXPECT_FALSE(two.from_marker_pose);
}

// A marker's edge quadratic in the fit: its information reaches the fused pose moved from the
// marker's origin to the object's (J^T H J, J = [[I, 0], [-[R t_om]x, I]]), its offset moves
// the pose by the same amount the marker's own information says, and a layout covariance adds
// exactly the layout's share of one rigid marker (the edge rows carry the layout's error like
// the corners do). The lone marker's own-pose shortcut is off here so that the fit is seen.
TEST(ObjectPose, AMarkersEdgeQuadraticJoinsTheFit) {
  const Rig rig;
  ObjectPoseOptions o;
  o.use_marker_pose_with_edges = false;
  const MarkerObservation plain = rig.Observe(0, rig.layout.markers[0].object_from_marker);
  const ObjectPose without = SolveObjectPose(rig.camera, {plain}, o);
  ASSERT_TRUE(without.valid) << without.message;
  EXPECT_EQ(without.edge_rows, 0);
  Eigen::Matrix<double, 6, 6> A;
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < 6; ++j) A(i, j) = std::cos(0.7 + 2.0 * i + j);
  const Eigen::Matrix<double, 6, 6> H =
      1e6 * (A * A.transpose() + 0.1 * Eigen::Matrix<double, 6, 6>::Identity());
  MarkerObservation m = plain;
  m.edge_points = 60;
  m.edge_information = H;
  const ObjectPose with = SolveObjectPose(rig.camera, {m}, o);
  ASSERT_TRUE(with.valid) << with.message;
  EXPECT_EQ(with.edge_rows, 6);
  EXPECT_EQ(with.dof, without.dof + 6);
  EXPECT_LT(PoseError(rig.cam_from_object, with.cam_from_object).norm(), 1e-9);  // mu = 0
  const Pose cam_from_marker = with.cam_from_object * plain.object_from_marker;
  Eigen::Matrix<double, 6, 6> J = Eigen::Matrix<double, 6, 6>::Identity();
  J.bottomLeftCorner<3, 3>() = -Skew(cam_from_marker.tvec - with.cam_from_object.tvec);
  const Eigen::Matrix<double, 6, 6> info_expected =
      without.covariance.inverse() + J.transpose() * H * J;
  const Eigen::Matrix<double, 6, 6> info = with.covariance.inverse();
  EXPECT_LT((info - info_expected).norm(), 1e-6 * info_expected.norm());
  // An offset: the edges alone want the marker moved by mu; the fit goes a share of the way
  // that the two informations set: d = (I_pts + H)^-1 H mu in the marker's coordinates.
  Eigen::Matrix<double, 6, 1> mu;
  mu << 1e-4, -2e-4, 5e-5, 1e-5, 2e-5, -1e-5;
  m.edge_offset = mu;
  const ObjectPose moved = SolveObjectPose(rig.camera, {m}, o);
  ASSERT_TRUE(moved.valid) << moved.message;
  const Eigen::Matrix<double, 6, 6> I_pts =
      J.transpose().inverse() * without.covariance.inverse() * J.inverse();
  const Eigen::Matrix<double, 6, 1> d_expected = (I_pts + H).ldlt().solve(H * mu);
  // PoseError(a, b) = [log(R_a R_b^T), t_a - t_b]: the change from b to a.
  const Eigen::Matrix<double, 6, 1> d =
      PoseError(moved.cam_from_object * plain.object_from_marker, cam_from_marker);
  EXPECT_LT((d - d_expected).norm(), 0.02 * d_expected.norm()) << d.transpose() << "\n"
                                                               << d_expected.transpose();
  // A layout covariance: one rigid marker, so its share is exactly the layout's
  // (ObjectPoseFromMarker's first-order term).
  m.edge_offset.setZero();
  const PoseCovariance S = 1e-7 * (A.transpose() * A + PoseCovariance::Identity());
  MarkerObservation with_layout = m;
  with_layout.layout_covariance = S;
  const ObjectPose p = SolveObjectPose(rig.camera, {with_layout}, o);
  ASSERT_TRUE(p.valid) << p.message;
  MarkerObservation layout_only = with_layout;
  layout_only.marker_covariance.setZero();
  layout_only.cam_from_marker = cam_from_marker;
  Pose unused;
  PoseCovariance layout_share;
  ASSERT_TRUE(ObjectPoseFromMarker(layout_only, true, &unused, &layout_share));
  const PoseCovariance expected = with.covariance + layout_share;
  EXPECT_LT((p.covariance - expected).norm(), 1e-6 * expected.norm());
  EXPECT_GT(layout_share.norm(), 0.1 * with.covariance.norm());  // not negligible
  // An ambiguous marker's quadratic is left out.
  MarkerObservation ambiguous = m;
  ambiguous.pose_ambiguous = true;
  EXPECT_EQ(SolveObjectPose(rig.camera, {ambiguous}, o).edge_rows, 0);
  o.use_edges = false;
  EXPECT_EQ(SolveObjectPose(rig.camera, {m}, o).edge_rows, 0);
}

TEST(ObjectPose, NeesOfAKnownErrorIsItsMahalanobisNorm) {
  Pose truth{Vec3(0.1, 0.2, 0.3), Vec3(1, 2, 3)};
  Pose est = truth;
  est.tvec += Vec3(0.01, 0, 0);
  PoseCovariance C = PoseCovariance::Identity() * 1e-4;
  EXPECT_NEAR(Nees(truth, est, C), 1.0, 1e-9);
  EXPECT_NEAR(PoseError(truth, est)[3], -0.01, 1e-15);
}

// Two cameras 0.5 m apart on a rig, both looking at the box of `Rig`: camera 0 where Rig's
// camera is, camera 1 beside it. The rig frame is neither camera's.
struct TwoCameras {
  Rig scene;  // its camera and cam_from_object are camera 0's
  Pose rig_from_object;
  std::array<Pose, 2> rig_from_cam;
  TwoCameras() {
    rig_from_cam[0] = Pose{Vec3(0.02, -0.01, 0.03), Vec3(-0.1, 0.05, 0.02)};
    rig_from_object = rig_from_cam[0] * scene.cam_from_object;
    const Vec3 eye1 = Vec3(1.6, 1.3, 3.0) + 0.5 * Vec3(-1.3, 1.6, 0).normalized();
    const Pose cam1_from_object = LookAt(eye1, Vec3(0, 0, 0.8), Vec3(0, 0, 1));
    rig_from_cam[1] = rig_from_object * cam1_from_object.Inverse();
  }
  // Exact observations of every marker by both cameras, the cameras truly at rig_from_cam_true.
  std::vector<MarkerObservation> ObserveAll(const std::array<Pose, 2>& rig_from_cam_true) const {
    std::vector<MarkerObservation> obs;
    for (int c = 0; c < 2; ++c) {
      Rig seen = scene;
      seen.cam_from_object = rig_from_cam_true[c].Inverse() * rig_from_object;
      for (MarkerObservation& m : seen.ObserveAll()) {
        m.camera = c;
        obs.push_back(m);
      }
    }
    return obs;
  }
  std::vector<RigCameraView> Views(const std::optional<PoseCovariance>& extrinsics) const {
    std::vector<RigCameraView> views(2);
    for (int c = 0; c < 2; ++c) views[c] = {&scene.camera, rig_from_cam[c], extrinsics};
    return views;
  }
};

TEST(RigObjectPose, ExactObservationsOfTwoCamerasGiveTheTruth) {
  const TwoCameras rig;
  std::vector<MarkerObservation> obs = rig.ObserveAll(rig.rig_from_cam);
  for (auto& o : obs) o.cam_from_marker->rvec += Vec3(0.05, -0.03, 0.02);  // a poor start
  const ObjectPose p = SolveRigObjectPose(rig.Views(std::nullopt), obs, ObjectPoseOptions{});
  ASSERT_TRUE(p.valid) << p.message;
  EXPECT_EQ(p.markers_used, 6);
  EXPECT_EQ(p.points_used, 30);
  EXPECT_LT(PoseError(rig.rig_from_object, p.cam_from_object).norm(), 1e-9);
  EXPECT_LT(p.rms_px, 1e-7);
  EXPECT_EQ(std::count(p.cameras_used.begin(), p.cameras_used.end(), 1), 3);
  EXPECT_FALSE(p.extrinsics_in_covariance);
  // Camera 1's observations alone give the same pose; and the rig's covariance is below each
  // camera's alone (more information).
  std::vector<MarkerObservation> only1(obs.begin() + 3, obs.end());
  const ObjectPose p1 = SolveRigObjectPose(rig.Views(std::nullopt), only1, ObjectPoseOptions{});
  ASSERT_TRUE(p1.valid) << p1.message;
  EXPECT_LT(PoseError(rig.rig_from_object, p1.cam_from_object).norm(), 1e-9);
  const Eigen::SelfAdjointEigenSolver<PoseCovariance> gap(p1.covariance - p.covariance);
  EXPECT_GT(gap.eigenvalues().minCoeff(), 0);
  // An observation naming a camera the rig has not.
  obs[0].camera = 2;
  const ObjectPose bad = SolveRigObjectPose(rig.Views(std::nullopt), obs, ObjectPoseOptions{});
  EXPECT_FALSE(bad.valid);
  EXPECT_NE(bad.message.find("camera 2"), std::string::npos) << bad.message;
}

// A one-camera rig whose camera sits at the rig's origin is the one-camera solve.
TEST(RigObjectPose, AOneCameraRigAtTheOriginIsTheOneCameraSolve) {
  const Rig scene;
  std::mt19937_64 rng(3);
  std::vector<MarkerObservation> obs = scene.ObserveAll();
  for (auto& m : obs) AddNoise(&rng, 0.1, 0.3, &m);
  const ObjectPose a = SolveObjectPose(scene.camera, obs, ObjectPoseOptions{});
  const ObjectPose b =
      SolveRigObjectPose({{&scene.camera, Pose{}, std::nullopt}}, obs, ObjectPoseOptions{});
  ASSERT_TRUE(a.valid && b.valid);
  EXPECT_LT(PoseError(a.cam_from_object, b.cam_from_object).norm(), 1e-12);
  EXPECT_LT((a.covariance - b.covariance).norm(), 1e-12 * a.covariance.norm());
}

// The extrinsics' share of the covariance is (d pose / d rig_from_cam) Sigma (...)^T: against
// central finite differences of the solve itself (exact observations, the nominal extrinsics
// of one camera moved by +-h along each of its six error coordinates). Also with every marker's
// edge quadratic in the fit (its rows move with the extrinsics like the corners).
TEST(RigObjectPose, ExtrinsicsCovarianceMatchesFiniteDifferences) {
  for (bool edges : {false, true}) {
    SCOPED_TRACE(edges ? "with edges" : "corners and tips");
    const TwoCameras rig;
    std::vector<MarkerObservation> obs = rig.ObserveAll(rig.rig_from_cam);
    if (edges) {
      Eigen::Matrix<double, 6, 6> A;
      for (int i = 0; i < 6; ++i)
        for (int j = 0; j < 6; ++j) A(i, j) = std::cos(0.7 + 2.0 * i + j);
      for (MarkerObservation& m : obs) {
        m.edge_points = 60;
        m.edge_information =
            1e6 * (A * A.transpose() + 0.1 * Eigen::Matrix<double, 6, 6>::Identity());
      }
    }
    PoseCovariance sigma = PoseCovariance::Zero();
    sigma.diagonal() << 4e-6, 1e-6, 2e-6, 1e-6, 4e-6, 9e-6;
    sigma(0, 4) = sigma(4, 0) = 1e-6;
    ObjectPoseOptions o;
    std::vector<RigCameraView> views = rig.Views(std::nullopt);
    const ObjectPose without = SolveRigObjectPose(views, obs, o);
    views[1].rig_from_cam_covariance = sigma;
    const ObjectPose with = SolveRigObjectPose(views, obs, o);
    ASSERT_TRUE(without.valid && with.valid);
    EXPECT_TRUE(with.extrinsics_in_covariance);
    EXPECT_EQ(with.edge_rows, edges ? 6 * static_cast<int>(obs.size()) : 0);
    Eigen::Matrix<double, 6, 6> S;
    const double h = 1e-6;
    for (int k = 0; k < 6; ++k) {
      std::array<Eigen::Matrix<double, 6, 1>, 2> moved;
      for (int sign : {0, 1}) {
        Eigen::Matrix<double, 6, 1> e = Eigen::Matrix<double, 6, 1>::Zero();
        e[k] = sign ? h : -h;
        std::vector<RigCameraView> v = rig.Views(std::nullopt);
        v[1].rig_from_cam = Pose::FromRotation(Exp(e.head<3>()) * rig.rig_from_cam[1].Rotation(),
                                               rig.rig_from_cam[1].tvec + e.tail<3>());
        const ObjectPose p = SolveRigObjectPose(v, obs, o);
        ASSERT_TRUE(p.valid);
        moved[sign] = PoseError(p.cam_from_object, rig.rig_from_object);
      }
      S.col(k) = (moved[1] - moved[0]) / (2 * h);
    }
    const PoseCovariance expected = S * sigma * S.transpose();
    const PoseCovariance added = with.covariance - without.covariance;
    EXPECT_GT(expected.norm(), 1e-3 * without.covariance.norm());  // the share matters here
    EXPECT_LT((added - expected).norm(), 1e-4 * expected.norm()) << "added\n"
                                                                 << added << "\nexpected\n"
                                                                 << expected;
  }
}

// The same in a rig, where the columns are each camera's calibration, then each camera's
// rig_from_cam: a draw of all four errors moves the rig's pose by B z, and a camera that sees
// nothing keeps its (zero) columns, so that column j means the same error in every frame. Where
// the pose is a lone marker's own (with its edges), its extrinsics columns are those of the
// marker's rigid move with its camera, as the fit's own are.
TEST(RigObjectPose, BiasFactorColumnsAreEachCamerasCalibrationThenExtrinsics) {
  const TwoCameras rig;
  const int n = static_cast<int>(rig.scene.camera.intrinsics().size());
  const Eigen::MatrixXd L = CalibrationFactor(n);
  PoseCovariance sigma = PoseCovariance::Zero();
  sigma.diagonal() << 4e-8, 1e-8, 2e-8, 1e-8, 4e-8, 9e-8;
  sigma(0, 4) = sigma(4, 0) = 1e-8;
  const Eigen::SelfAdjointEigenSolver<PoseCovariance> es(sigma);
  const PoseCovariance root =
      es.eigenvectors() * es.eigenvalues().cwiseSqrt().asDiagonal() * es.eigenvectors().transpose();
  std::mt19937_64 rng(8);
  // The least-squares fit itself, every marker kept: the robust weights and the rejection tests
  // count the extrinsics' pixel spread, which would make the two fits below weigh the cameras
  // apart, and the draws move pixels by about a pixel.
  ObjectPoseOptions all;
  all.robust_k = all.point_reject_sigma = std::numeric_limits<double>::infinity();
  all.reject_quantile = 1;
  all.corner_sigma_px = all.min_tip_sigma_px = 2;
  ObjectPoseOptions none = all;
  none.use_calibration_covariance = false;
  none.use_extrinsics_covariance = false;
  for (int trial = 0; trial < 10; ++trial) {
    const Eigen::VectorXd z = StandardNormal(&rng, 2 * n + 12);
    std::array<CameraModel, 2> models;
    std::array<Pose, 2> truth;
    std::vector<RigCameraView> views(2);
    for (int c = 0; c < 2; ++c) {
      models[c] = Calibrated(rig.scene.camera, L * z.segment(c * n, n), L);
      const Eigen::Matrix<double, 6, 1> e = root * z.segment<6>(2 * n + 6 * c);
      truth[c] = Pose::FromRotation(Exp(e.head<3>()) * rig.rig_from_cam[c].Rotation(),
                                    rig.rig_from_cam[c].tvec + e.tail<3>());
      views[c] = {&models[c], rig.rig_from_cam[c], sigma};
    }
    const std::vector<MarkerObservation> obs = rig.ObserveAll(truth);
    const ObjectPose a = SolveRigObjectPose(views, obs, all);
    const ObjectPose b = SolveRigObjectPose(views, obs, none);
    ASSERT_TRUE(a.valid && b.valid) << a.message << b.message;
    ASSERT_EQ(a.bias_columns(), 2 * n + 12);
    EXPECT_EQ(a.markers_used, 6);
    EXPECT_EQ(b.markers_used, 6);
    const PoseCovariance share = a.bias_factor() * a.bias_factor().transpose();
    EXPECT_LT((share - (a.covariance - b.covariance)).norm(), 1e-9 * share.norm());
    const Eigen::Matrix<double, 6, 1> predicted = a.bias_factor() * z;
    const Eigen::Matrix<double, 6, 1> error = PoseError(rig.rig_from_object, a.cam_from_object);
    EXPECT_LT((error - predicted).norm(), 0.05 * predicted.norm())
        << "error " << error.transpose() << "\npredicted " << predicted.transpose();
    // Camera 0 sees nothing: its columns stay, as zeros.
    const std::vector<MarkerObservation> only1(obs.begin() + 3, obs.end());
    const ObjectPose c1 = SolveRigObjectPose(views, only1, ObjectPoseOptions{});
    ASSERT_TRUE(c1.valid) << c1.message;
    ASSERT_EQ(c1.bias_columns(), 2 * n + 12);
    EXPECT_EQ(c1.bias_factor().leftCols(n).norm(), 0);
    EXPECT_EQ(c1.bias_factor().middleCols<6>(2 * n).norm(), 0);
    EXPECT_GT(c1.bias_factor().middleCols(n, n).norm(), 0);
    EXPECT_GT(c1.bias_factor().rightCols<6>().norm(), 0);
  }
  // A lone marker of camera 1 with edges: its own pose, and the extrinsics columns of the
  // marker's rigid move, which the fit over its corners and tip gives too.
  std::vector<RigCameraView> views = rig.Views(sigma);
  MarkerObservation m = rig.ObserveAll(rig.rig_from_cam)[3];
  m.marker_covariance = PoseCovariance::Identity() * 1e-6;
  m.edge_points = 90;
  const ObjectPose own = SolveRigObjectPose(views, {m}, ObjectPoseOptions{});
  ObjectPoseOptions fit;
  fit.use_marker_pose_with_edges = false;
  const ObjectPose refit = SolveRigObjectPose(views, {m}, fit);
  ASSERT_TRUE(own.valid && refit.valid) << own.message << refit.message;
  EXPECT_TRUE(own.from_marker_pose);
  EXPECT_FALSE(refit.from_marker_pose);
  ASSERT_EQ(own.bias_columns(), 12);
  ASSERT_EQ(refit.bias_columns(), 12);
  // The lone marker's own covariance gains exactly its camera's extrinsics block of B B^T.
  const ObjectPose own_plain =
      SolveRigObjectPose(rig.Views(std::nullopt), {m}, ObjectPoseOptions{});
  ASSERT_TRUE(own_plain.valid && own_plain.from_marker_pose) << own_plain.message;
  const auto B1 = own.bias_factor().rightCols<6>();
  const PoseCovariance added = own.covariance - own_plain.covariance;
  EXPECT_LT((added - B1 * B1.transpose()).norm(), 1e-9 * added.norm());
  EXPECT_EQ(own.bias_factor().leftCols<6>().norm(), 0);  // camera 0 sees nothing
  EXPECT_LT((own.bias_factor() - refit.bias_factor()).norm(), 1e-6 * refit.bias_factor().norm())
      << "own\n"
      << own.bias_factor() << "\nrefit\n"
      << refit.bias_factor();
}

// NEES of the two-camera solve ~ chi-square(6): with pixel noise only, and with the cameras
// truly off their nominal rig_from_cam by draws from the extrinsics covariance (which the
// covariance then includes; without it, it is overconfident). Both with the default robust
// weights and rejection, which count the extrinsics' pixel spread (else a camera that is off
// loses good points and weight: NEES 6.45), and with rejection off.
TEST(RigObjectPose, MonteCarloNeesMatchesChiSquareSixWithPixelAndExtrinsicsNoise) {
  const TwoCameras rig;
  PoseCovariance sigma = PoseCovariance::Zero();
  sigma.diagonal() << 4e-8, 4e-8, 4e-8, 1e-8, 1e-8, 1e-8;  // 0.2 mrad, 0.1 mm
  const Eigen::Matrix<double, 6, 6> L = sigma.llt().matrixL();
  std::mt19937_64 rng(21);
  std::normal_distribution<double> g(0, 1);
  ObjectPoseOptions o;
  o.corner_sigma_px = 0.15;
  ObjectPoseOptions no_rejection = o;
  no_rejection.point_reject_sigma = std::numeric_limits<double>::infinity();
  no_rejection.reject_quantile = 1;
  ObjectPoseOptions without = no_rejection;
  without.use_extrinsics_covariance = false;
  const int trials = 500;
  double nees_pixels = 0, nees_with = 0, nees_without = 0, nees_default = 0;
  for (int i = 0; i < trials; ++i) {
    {
      std::vector<MarkerObservation> obs = rig.ObserveAll(rig.rig_from_cam);
      for (auto& m : obs) AddNoise(&rng, 0.15, 0.3, &m);
      const ObjectPose p = SolveRigObjectPose(rig.Views(std::nullopt), obs, o);
      ASSERT_TRUE(p.valid) << p.message;
      nees_pixels += Nees(rig.rig_from_object, p.cam_from_object, p.covariance);
    }
    std::array<Pose, 2> truth;
    for (int c = 0; c < 2; ++c) {
      Eigen::Matrix<double, 6, 1> z;
      for (int k = 0; k < 6; ++k) z[k] = g(rng);
      const Eigen::Matrix<double, 6, 1> e = L * z;
      truth[c] = Pose::FromRotation(Exp(e.head<3>()) * rig.rig_from_cam[c].Rotation(),
                                    rig.rig_from_cam[c].tvec + e.tail<3>());
    }
    std::vector<MarkerObservation> obs = rig.ObserveAll(truth);
    for (auto& m : obs) AddNoise(&rng, 0.15, 0.3, &m);
    const ObjectPose a = SolveRigObjectPose(rig.Views(sigma), obs, no_rejection);
    const ObjectPose b = SolveRigObjectPose(rig.Views(sigma), obs, without);
    const ObjectPose d = SolveRigObjectPose(rig.Views(sigma), obs, o);
    ASSERT_TRUE(a.valid && b.valid && d.valid);
    EXPECT_TRUE(a.extrinsics_in_covariance);
    nees_with += Nees(rig.rig_from_object, a.cam_from_object, a.covariance);
    nees_without += Nees(rig.rig_from_object, b.cam_from_object, b.covariance);
    nees_default += Nees(rig.rig_from_object, d.cam_from_object, d.covariance);
  }
  std::printf(
      "mean NEES over %d trials: pixels %.3f; pixels and extrinsics %.3f (without their "
      "covariance %.3f; default rejection %.3f)\n",
      trials, nees_pixels / trials, nees_with / trials, nees_without / trials,
      nees_default / trials);
  // Mean of 500 chi-square(6) draws: 6 +- 0.11 (1 sigma); 95 %: [5.70, 6.31]; allow 4 sigma.
  EXPECT_NEAR(nees_pixels / trials, 6.0, 0.44);
  EXPECT_NEAR(nees_with / trials, 6.0, 0.44);
  EXPECT_GT(nees_without / trials, 30.0);
  EXPECT_NEAR(nees_default / trials, 6.0, 0.44);  // 6.05 over 4000 trials
}

}  // namespace
}  // namespace svms
