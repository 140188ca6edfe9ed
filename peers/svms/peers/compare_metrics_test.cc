// Scoring of one image against its truth: hits, wrong IDs, false positives, nested markers,
// errors; and the small statistics.
#include "svms/peers/compare_metrics.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

#include "svms/geometry/pose.h"

namespace svms {
namespace {

MarkerTruth Square(int id, double cx, double cy, double half, int nested_in = -1) {
  MarkerTruth t;
  t.id = id;
  t.nested_in = nested_in;
  t.facing = true;
  t.cam_from_marker.tvec = Eigen::Vector3d(0, 0, 2);
  t.cam_from_marker.rvec = Eigen::Vector3d(M_PI, 0, 0);  // facing the camera
  const double d[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
  for (int k = 0; k < 4; ++k) {
    t.corners[k].pixel = Eigen::Vector2d(cx + half * d[k][0], cy + half * d[k][1]);
    t.corners[k].projects = t.corners[k].in_image = true;
  }
  t.side_px = t.min_side_px = 2 * half;
  return t;
}

FoundMarker Found(const MarkerTruth& t, int id, double shift) {
  FoundMarker f;
  f.id = id;
  for (int k = 0; k < 4; ++k) f.corners[k] = t.corners[k].pixel + Eigen::Vector2d(shift, 0);
  return f;
}

TEST(CompareMetrics, HitsWrongIdsAndFalsePositives) {
  ViewTruth v;
  v.markers = {Square(5, 100, 100, 20), Square(6, 300, 100, 20), Square(7, 500, 100, 20)};
  v.markers[2].bits_occluded = 11;
  FoundMarker posed = Found(v.markers[0], 5, 0.3);
  Pose p = v.markers[0].cam_from_marker;
  p.tvec.z() += 0.01;
  p.rvec = Eigen::Vector3d(M_PI, 0, 0.2);  // 0.2 rad off about z... of the rotated frame
  posed.cam_from_marker = p;
  const ImageOutcome o = EvaluateImage(v, {posed, Found(v.markers[1], 99, 0),
                                           Found(v.markers[0], 5, 0), Found(v.markers[0], 5, 900)});
  ASSERT_EQ(o.markers.size(), 3u);
  EXPECT_TRUE(o.markers[0].detected);
  EXPECT_NEAR(o.markers[0].corner_rms_px, 0.3, 1e-12);  // the first of two duplicates counts
  EXPECT_NEAR(o.markers[0].range_err_m, 0.01, 1e-12);
  EXPECT_GT(o.markers[0].orientation_err_deg, 1);
  EXPECT_FALSE(o.markers[1].detected);
  EXPECT_TRUE(o.markers[1].wrong_id);
  EXPECT_FALSE(o.markers[2].detected);
  EXPECT_NEAR(o.markers[2].occluded_fraction, 0.25, 1e-12);
  EXPECT_NEAR(o.markers[0].view_angle_deg, 0, 1e-9);
  EXPECT_EQ(o.wrong_ids, 1);
  EXPECT_EQ(o.false_positives, 1);
}

// NEES, known answer: an error of 2 sigmas in one rotation axis and 1 sigma in one translation
// axis is 4 + 1; without a covariance (the peers) there is none.
TEST(CompareMetrics, PoseNeesIsTheErrorInUnitsOfTheCovariance) {
  ViewTruth v;
  v.markers = {Square(5, 100, 100, 20)};
  const Pose& truth = v.markers[0].cam_from_marker;
  PoseCovariance cov = PoseCovariance::Zero();
  cov.diagonal() << 1e-6, 4e-6, 9e-6, 1e-4, 4e-4, 9e-4;
  FoundMarker f = Found(v.markers[0], 5, 0);
  // The covariance's error is [log(R_truth R_est^T), t_truth - t_est] (object_pose.h): the
  // estimate turned by 2 sigmas about the camera's y axis and 3 cm (1 sigma) nearer on z.
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(-2 * 2e-3, Eigen::Vector3d::UnitY()).toRotationMatrix() * truth.Rotation();
  f.cam_from_marker = Pose::FromRotation(R, truth.tvec - Eigen::Vector3d(0, 0, 0.03));
  f.covariance = cov;
  const ImageOutcome o = EvaluateImage(v, {f});
  ASSERT_TRUE(o.markers[0].detected);
  EXPECT_NEAR(o.markers[0].pose_nees, 4 + 1, 1e-6);
  f.covariance.reset();
  EXPECT_TRUE(std::isnan(EvaluateImage(v, {f}).markers[0].pose_nees));
}

// The alternative pose beside a flagged one is scored like the pose: its orientation error.
TEST(CompareMetrics, TheAlternativePoseIsScoredToo) {
  ViewTruth v;
  v.markers = {Square(5, 100, 100, 20)};
  const Pose& truth = v.markers[0].cam_from_marker;
  FoundMarker f = Found(v.markers[0], 5, 0);
  const Eigen::Matrix3d off =
      Eigen::AngleAxisd(12 * M_PI / 180, Eigen::Vector3d::UnitX()).toRotationMatrix();
  f.cam_from_marker = Pose::FromRotation(off * truth.Rotation(), truth.tvec);
  f.pose_ambiguous = true;
  EXPECT_TRUE(std::isnan(EvaluateImage(v, {f}).markers[0].alternative_err_deg));
  f.alternative_pose = Pose::FromRotation(
      Eigen::AngleAxisd(3 * M_PI / 180, Eigen::Vector3d::UnitY()).toRotationMatrix() *
          truth.Rotation(),
      truth.tvec);
  const ImageOutcome o = EvaluateImage(v, {f});
  EXPECT_NEAR(o.markers[0].orientation_err_deg, 12, 1e-9);
  EXPECT_NEAR(o.markers[0].alternative_err_deg, 3, 1e-9);
  EXPECT_EQ(o.markers[0].alternative_weight, 0);
  f.alternative_weight = 0.3;
  const ImageOutcome w = EvaluateImage(v, {f});
  EXPECT_EQ(w.markers[0].alternative_weight, 0.3);
  const double sep = AngleBetweenDeg(*f.alternative_pose, *f.cam_from_marker);
  EXPECT_NEAR(w.markers[0].alternative_sep_deg, sep, 1e-9);
  EXPECT_GT(w.markers[0].alternative_sep_deg, 12);  // 12 about x, 3 about y: about 12.4
  EXPECT_LT(w.markers[0].alternative_sep_deg, 13);
}

TEST(CompareMetrics, NestedMarkerGoesToTheInnerSquare) {
  ViewTruth v;
  v.markers = {Square(1, 200, 200, 100), Square(2, 200, 200, 25, 1)};
  const ImageOutcome o = EvaluateImage(v, {Found(v.markers[1], 2, 0), Found(v.markers[0], 1, 0)});
  EXPECT_TRUE(o.markers[0].detected);
  EXPECT_TRUE(o.markers[1].detected);
  EXPECT_EQ(o.wrong_ids + o.false_positives, 0);
  // A wrong ID inside the inner square is charged to the inner marker.
  const ImageOutcome w = EvaluateImage(v, {Found(v.markers[1], 3, 0)});
  EXPECT_TRUE(w.markers[1].wrong_id);
  EXPECT_FALSE(w.markers[0].wrong_id);
}

TEST(CompareMetrics, OnlyAPoseNearATwinFarFromTheTruthIsAPlanarFlip) {
  MarkerOutcome m;
  m.view_angle_deg = 12;
  m.orientation_err_deg = 23;
  m.twin_err_deg = 2;
  EXPECT_TRUE(m.planar_flip());
  m.twin_err_deg = 30;  // far from both: noise
  EXPECT_FALSE(m.planar_flip());
  m.twin_err_deg = 2;
  m.orientation_err_deg = 8;  // not a flip at all
  EXPECT_FALSE(m.planar_flip());
  m.orientation_err_deg = 18;
  m.view_angle_deg = 0.2;  // head on: the twin is the pose itself
  m.twin_err_deg = 17.9;
  EXPECT_FALSE(m.planar_flip());
}

}  // namespace
}  // namespace svms
