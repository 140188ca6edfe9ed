#include "svms/fusion/pose_estimator.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <tuple>

#include "svms/datasets/datasets.h"
#include "svms/detect/detector.h"
#include "svms/marker/model_io.h"
#include "svms/sim/render.h"
#include "svms/sim/truth.h"
#include "svms_testing/flat_marker_views.h"
#include "svms_testing/scratch_dir.h"
#include "svms_testing/two_objects.h"

namespace svms {
namespace {

struct Approach {
  Dataset dataset;
  Layout layout;
  std::unique_ptr<Renderer> renderer;
  Approach() {
    EXPECT_TRUE(MakeDataset("approach", DatasetOptions{1, true}, &dataset).ok());
    for (const auto& [name, text] : dataset.files)
      if (name == "true_layout.json") {
        ModelFile f;
        EXPECT_TRUE(ParseModelJson(text, name, &f).ok());
        layout = f.layout;
      }
    EXPECT_TRUE(Renderer::Create(dataset.scenes[0].second, &renderer).ok());
  }
  const CameraModel& camera() const { return dataset.scenes[0].second.camera; }
  cv::Mat Image(int view) const { return renderer->Expose(renderer->RenderRadiance(view), view); }
  Pose Truth(int view) const {
    const ViewTruth t = ComputeTruth(*renderer, view);
    for (const auto& [name, pose] : t.cam_from_object)
      if (name == "module") return pose;
    ADD_FAILURE() << "no module in view " << view;
    return {};
  }
};

const Approach& Shared() {
  static const Approach* a = new Approach;
  return *a;
}

// End to end on rendered approach frames with the true layout: the fused pose is within a few
// of its own sigmas of the truth, and the close frames use several markers.
TEST(PoseEstimator, RenderedApproachFramesMatchTheTruthWithinTheirSigmas) {
  const Approach& a = Shared();
  ASSERT_EQ(a.layout.markers.size(), 8u);
  std::unique_ptr<PoseEstimator> est;
  PoseEstimatorOptions options;
  options.fusion.corner_sigma_px = 0.1;
  ASSERT_TRUE(PoseEstimator::Create(a.camera(), a.layout, options, &est).ok());
  int several = 0;
  for (int view : {0, 6, 11}) {
    FrameResult r;
    est->Estimate(a.Image(view), 0.1 * view, &r);
    EXPECT_EQ(r.timestamp, 0.1 * view);
    ASSERT_TRUE(r.pose.valid) << "view " << view << ": " << r.pose.message;
    const Pose truth = a.Truth(view);
    const Eigen::Matrix<double, 6, 1> e = PoseError(truth, r.pose.cam_from_object);
    for (int k = 0; k < 6; ++k)
      EXPECT_LT(std::abs(e[k]), 6 * std::sqrt(r.pose.covariance(k, k)) + 1e-5)
          << "view " << view << " component " << k;
    // Accuracy: 1.5 times what the method reaches on these frames (measured: view 0, 12.9 m:
    // 1.89 mm, 0.049 deg; view 6: 0.033 mm, 0.0013 deg; view 11, 2.25 m: 0.107 mm, 0.0054
    // deg), so a 2x loss of accuracy fails.
    const double max_mm = view == 0 ? 2.8 : view == 6 ? 0.05 : 0.16;
    const double max_deg = view == 0 ? 0.074 : view == 6 ? 0.002 : 0.008;
    EXPECT_LT(1e3 * e.tail<3>().norm(), max_mm) << "view " << view;
    EXPECT_LT(e.head<3>().norm() * 180 / M_PI, max_deg) << "view " << view;
    several += r.pose.markers_used >= 3;
    EXPECT_GE(r.latency_ms, r.detect_ms);
  }
  EXPECT_GE(several, 1);
}

// The single-marker covariance is honest on rendered frames, in both directions: a 0.2 m marker
// with its post, alone on a plate, from 48 views (1.5 to 6 m, 0 to 55 degrees off its normal,
// all around; 13 to 53 px through a 320 x 240 pinhole): the mean NEES (6 dof) of the
// detector's poses stays near 6. Measured: 5.22 over 47 poses (one view's pose is ambiguous).
// A covariance 2x too small (in variance) would give about 10.4, 2x too large about 2.6; the
// bounds [3.6, 8] sit 2 and 4.8 standard errors of the mean (sqrt(12 / 47) = 0.5) from those,
// and 3.2 and 5.6 from the measured value.
TEST(PoseEstimator, RenderedLoneMarkerNeesIsNearSix) {
  const CameraModel camera = CameraModel::Pinhole(400, 320, 240);
  const MarkerModel marker = MarkerModel::Standard(21, 0.2, 0.05);
  const Detector detector(DetectorOptions(), camera, {marker});
  double sum = 0;
  int n = 0, views = 0;
  for (int i = 0; i < 48; ++i) {
    const double range = 1.5 + 4.5 * (i % 4) / 3.0, off = (i / 4) * 5 * M_PI / 180;
    const double az = i * 2.4;  // radians: an irrational turn spreads the azimuths
    const Eigen::Vector3d eye =
        range *
        Eigen::Vector3d(std::sin(off) * std::cos(az), std::sin(off) * std::sin(az), std::cos(off));
    const Pose cam_from_world = LookAt(eye, Eigen::Vector3d::Zero(), Eigen::Vector3d(0, 1, 0.3));
    std::unique_ptr<Renderer> renderer;
    ASSERT_TRUE(Renderer::Create(LoneMarkerScene(camera, marker, cam_from_world), &renderer).ok());
    const cv::Mat image = renderer->Expose(renderer->RenderRadiance(0), 0);
    const ViewTruth t = ComputeTruth(*renderer, 0);
    ++views;
    for (const Detection& d : detector.Detect(image)) {
      if (d.id != marker.id || !d.cam_from_marker || d.pose_ambiguous) continue;
      const double nees = Nees(t.markers.at(0).cam_from_marker, *d.cam_from_marker, d.covariance);
      ASSERT_TRUE(std::isfinite(nees)) << "view " << i;
      sum += nees;
      ++n;
    }
  }
  ASSERT_GE(n, 44) << "of " << views << " views";
  std::printf("mean NEES %.2f over %d single-marker poses\n", sum / n, n);
  EXPECT_GT(sum / n, 3.6);
  EXPECT_LT(sum / n, 8);
}

// A lone marker whose black square is 30 px (0.2 m at 7.4 m through a 1111 px pinhole, 5-17
// degrees off its axis; the scale of the 0.432 m dual marker at 16 m): the fused pose is the
// detector's own, which also fits the stripe's and decal's edges, and its orientation is
// clearly better than the refit over the corners and tip alone; the fit with the edges'
// quadratic (the path of a frame with several markers) nearly as good. Measured over these 4
// views: RMS orientation 0.20 deg (detector's pose), 0.25 (fit with edges), 0.46 (corners and
// tip); mean NEES 3.7 and 3.4. The covariance stays honest: mean NEES below 12 (a covariance
// 2x too small in variance gives about 12 on average).
TEST(PoseEstimator, ALoneDistantMarkersFusedPoseHasItsStripeAndDecalEdges) {
  const CameraModel camera = CameraModel::Pinhole(1111.1, 320, 240);
  PoseEstimatorOptions own, fit, corners_tip;
  fit.fusion.use_marker_pose_with_edges = false;
  corners_tip.fusion.use_marker_pose_with_edges = false;
  corners_tip.fusion.use_edges = false;
  double ss_own = 0, ss_fit = 0, ss_corners = 0, nees = 0, nees_fit = 0, var_own = 0,
         var_corners = 0;
  int n = 0;
  for (int v = 0; v < 4; ++v) {
    const MarkerModel marker = MarkerModel::Standard(100 + v, 0.2, 0.05);
    const double a = (5 + 4 * v) * M_PI / 180;
    const Pose cam_from_world = LookAt(Eigen::Vector3d(7.4 * std::sin(a), 0.3, 7.4 * std::cos(a)),
                                       Eigen::Vector3d::Zero(), Eigen::Vector3d(0, 1, 0.2));
    std::unique_ptr<Renderer> renderer;
    ASSERT_TRUE(Renderer::Create(LoneMarkerScene(camera, marker, cam_from_world), &renderer).ok());
    const cv::Mat image = renderer->Expose(renderer->RenderRadiance(0), 0);
    const Pose truth = ComputeTruth(*renderer, 0).markers.at(0).cam_from_marker;
    const Layout layout = LoneMarkerLayout(marker);
    const Pose& object_from_marker = layout.markers[0].object_from_marker;
    FrameResult r_own, r_fit, r_corners;
    for (auto [options, result] : {std::make_pair(&own, &r_own), std::make_pair(&fit, &r_fit),
                                   std::make_pair(&corners_tip, &r_corners)}) {
      std::unique_ptr<PoseEstimator> est;
      ASSERT_TRUE(PoseEstimator::Create(camera, layout, *options, &est).ok());
      est->Estimate(image, 0, result);
      ASSERT_TRUE(result->pose.valid) << "view " << v << ": " << result->pose.message;
    }
    ASSERT_EQ(r_own.detections.size(), 1u);
    const Detection& d = r_own.detections[0];
    ASSERT_GT(d.edge_points, 0) << "view " << v;
    ASSERT_TRUE(r_own.pose.from_marker_pose);
    EXPECT_FALSE(r_fit.pose.from_marker_pose || r_corners.pose.from_marker_pose);
    EXPECT_GT(r_fit.pose.edge_rows, 0);
    EXPECT_EQ(r_corners.pose.edge_rows, 0);
    const Pose fused = r_own.pose.cam_from_object * object_from_marker;
    EXPECT_LT(PoseError(*d.cam_from_marker, fused).norm(), 1e-9) << "view " << v;
    ss_own += std::pow(AngleBetweenDeg(fused, truth), 2);
    ss_fit += std::pow(AngleBetweenDeg(r_fit.pose.cam_from_object * object_from_marker, truth), 2);
    ss_corners +=
        std::pow(AngleBetweenDeg(r_corners.pose.cam_from_object * object_from_marker, truth), 2);
    var_own += r_own.pose.covariance.topLeftCorner<3, 3>().trace();
    var_corners += r_corners.pose.covariance.topLeftCorner<3, 3>().trace();
    const Pose truth_object = truth * object_from_marker.Inverse();
    nees += Nees(truth_object, r_own.pose.cam_from_object, r_own.pose.covariance);
    nees_fit += Nees(truth_object, r_fit.pose.cam_from_object, r_fit.pose.covariance);
    ++n;
  }
  const double rms_own = std::sqrt(ss_own / n), rms_fit = std::sqrt(ss_fit / n),
               rms_corners = std::sqrt(ss_corners / n);
  std::printf(
      "orientation RMS %.3f deg (detector's pose), %.3f (fit with edges), %.3f (corners and "
      "tip); mean NEES %.2f, %.2f\n",
      rms_own, rms_fit, rms_corners, nees / n, nees_fit / n);
  EXPECT_LT(rms_own, 0.6 * rms_corners);
  EXPECT_LT(rms_fit, 0.7 * rms_corners);
  EXPECT_LT(var_own, 0.7 * var_corners);  // the edge points carry real information
  EXPECT_LT(nees / n, 12);
  EXPECT_LT(nees_fit / n, 12);
}

// The fused pose's covariance over every view of the approach (12 frames, 1 to 8 markers each):
// its mean NEES, deterministic for these renders, is 2.99 with the default model (corners
// independent, their line-fit sigmas unscaled): conservative, as over the 500-frame approach
// (3.93, docs/benchmarks.md), because independent corners overstate the pose's uncertainty.
// The bounds [2.2, 5] catch a covariance 2x too small (about 6 expected) or 2x too large
// (about 1.5); a model that brings the NEES near 6 moves them with it. The single
// markers of these frames seen beyond 60 degrees (markers 12, 14 and 15 on the module's other
// faces) are overconfident (docs/detector.md, limitations): they are not judged here.
TEST(PoseEstimator, RenderedApproachFusedNeesStaysWithinAFactorOfTwoOfItsMeasure) {
  const Approach& a = Shared();
  std::unique_ptr<PoseEstimator> est;
  ASSERT_TRUE(PoseEstimator::Create(a.camera(), a.layout, {}, &est).ok());
  double sum = 0;
  int fused = 0;
  // Printed, not judged: the single markers' NEES below and beyond 60 degrees off their normal
  // (the figures of docs/detector.md's limitations).
  double single[2] = {0, 0};
  int singles[2] = {0, 0};
  const int views = static_cast<int>(a.dataset.scenes[0].second.views.size());
  for (int view = 0; view < views; ++view) {
    FrameResult r;
    est->Estimate(a.Image(view), 0, &r);
    const ViewTruth t = ComputeTruth(*a.renderer, view);
    for (const Detection& d : r.detections) {
      if (!d.cam_from_marker || d.pose_ambiguous) continue;
      for (const MarkerTruth& m : t.markers)
        if (m.id == d.id && m.nested_in < 0) {
          const Eigen::Vector3d to_cam = -m.cam_from_marker.tvec.normalized();
          const double cos_angle =
              std::abs(m.cam_from_marker.Rotation().col(2).dot(to_cam));  // 60 deg: 0.5
          const int grazing = cos_angle < 0.5;
          single[grazing] += Nees(m.cam_from_marker, *d.cam_from_marker, d.covariance);
          ++singles[grazing];
        }
    }
    if (!r.pose.valid || r.pose.ambiguous) continue;
    sum += Nees(a.Truth(view), r.pose.cam_from_object, r.pose.covariance);
    ++fused;
  }
  ASSERT_GE(fused, 10);
  std::printf(
      "mean NEES %.2f over %d fused poses; single markers %.2f over %d poses within 60 "
      "degrees of their normal, %.2f over %d beyond\n",
      sum / fused, fused, single[0] / std::max(1, singles[0]), singles[0],
      single[1] / std::max(1, singles[1]), singles[1]);
  EXPECT_GT(sum / fused, 2.2);
  EXPECT_LT(sum / fused, 5.0);
}

// A lone flat marker (no post) of about 20 px, 5-27 degrees off-axis, the only marker of its
// layout: where the detector cannot tell its planar poses apart, the fused pose is flagged and
// carries the object's pose under the other one, and where the kept pose is the wrong one the
// alternative is right.
TEST(PoseEstimator, ALoneAmbiguousMarkerGivesTheOtherPlanarPoseToo) {
  const CameraModel cam = CameraModel::Pinhole(1111.1, 320, 240);
  int ambiguous = 0, wrong = 0;
  for (int v = 0; v < svms_testing::kFlatMarkerViews; ++v) {
    const MarkerModel m = svms_testing::FlatMarker(v);
    const Scene scene =
        LoneMarkerScene(cam, m,
                        LookAt(svms_testing::FlatMarkerEye(v), Eigen::Vector3d::Zero(),
                               Eigen::Vector3d(0, 1, 0.2)));
    std::unique_ptr<Renderer> renderer;
    ASSERT_TRUE(Renderer::Create(scene, &renderer).ok());
    std::unique_ptr<PoseEstimator> est;
    ASSERT_TRUE(PoseEstimator::Create(cam, LoneMarkerLayout(m), {}, &est).ok());
    FrameResult r;
    est->Estimate(renderer->Expose(renderer->RenderRadiance(0), 0), 0, &r);
    SCOPED_TRACE("view " + std::to_string(v));
    ASSERT_TRUE(r.pose.valid) << r.pose.message;
    ASSERT_EQ(r.detections.size(), 1u);
    Pose truth;
    for (const auto& [name, pose] : ComputeTruth(*renderer, 0).cam_from_object)
      if (name == "plate") truth = pose;
    const double error = PoseError(truth, r.pose.cam_from_object).head<3>().norm() * 180 / M_PI;
    EXPECT_EQ(r.pose.ambiguous, r.detections[0].pose_ambiguous);
    ASSERT_EQ(r.pose.alternative_cam_from_object.has_value(), r.pose.ambiguous);
    ambiguous += r.pose.ambiguous;
    wrong += error > 5;
    if (error > 5) {
      EXPECT_TRUE(r.pose.ambiguous) << error;
    }
    if (r.pose.alternative_cam_from_object) {
      EXPECT_GT(r.pose.alternative_weight, 0.01);
      EXPECT_LE(r.pose.alternative_weight, 0.5);
      const double alternative_error =
          PoseError(truth, *r.pose.alternative_cam_from_object).head<3>().norm() * 180 / M_PI;
      std::printf("view %d: error %.2f deg, alternative %.2f deg, weight %.3f\n", v, error,
                  alternative_error, r.pose.alternative_weight);
      if (error > 5) {
        EXPECT_LT(alternative_error, 5);
      }
      // The alternative is one of the detector's two poses moved to the object.
      const Pose marker_from_object = LoneMarkerLayout(m).markers[0].object_from_marker.Inverse();
      const Eigen::Vector3d t = r.pose.alternative_cam_from_object->tvec;
      EXPECT_LT(std::min((t - (*r.detections[0].alternative_pose * marker_from_object).tvec).norm(),
                         (t - (*r.detections[0].cam_from_marker * marker_from_object).tvec).norm()),
                1e-9);
    }
  }
  RecordProperty("ambiguous", ambiguous);
  RecordProperty("wrong_solution_kept", wrong);
  EXPECT_GT(ambiguous, 0);
}

TEST(PoseEstimator, ABudgetTooSmallIsFlaggedAndNeverCrashes) {
  const Approach& a = Shared();
  std::unique_ptr<PoseEstimator> est;
  PoseEstimatorOptions options;
  options.budget_ms = 1e-6;
  ASSERT_TRUE(PoseEstimator::Create(a.camera(), a.layout, options, &est).ok());
  FrameResult r;
  est->Estimate(a.Image(11), 1.1, &r);
  EXPECT_TRUE(r.budget_exceeded);
  EXPECT_FALSE(r.pose.valid);
  EXPECT_FALSE(r.pose.message.empty());
}

// A frame stored as a raw sensor's (16 bits, black level 4096): its latency starts at the call,
// before the conversion to linear light and the stored-noise estimate, so it is more than the
// detection and the fusion (it equalled their sum when the clock started at the detection).
TEST(PoseEstimator, TheLatencyOfARawFrameIncludesItsConversion) {
  const Approach& a = Shared();
  cv::Mat raw;
  a.Image(11).convertTo(raw, CV_16U, 200, 4096);  // 8-bit linear -> 4096 + 200 v
  PoseEstimatorOptions options;
  options.photometric.emplace();
  options.photometric->black_level = 4096;
  options.photometric->white_level = 4096 + 200 * 255;
  std::unique_ptr<PoseEstimator> est;
  ASSERT_TRUE(PoseEstimator::Create(a.camera(), a.layout, options, &est).ok());
  FrameResult r;
  est->Estimate(raw, 1.1, &r);
  ASSERT_TRUE(r.pose.valid) << r.pose.message;
  EXPECT_GT(r.latency_ms, r.detect_ms + r.fuse_ms);
}

// SetDetection between frames: more threads per frame give the same pose to the bit; a coarser
// search loses the far frame's small markers (view 0, 12 m) and keeps the close frame's pose; a
// value out of range is refused by name and leaves the settings as they were.
TEST(PoseEstimator, SetDetectionChangesTheSearchAndRefusesValuesOutOfRange) {
  const Approach& a = Shared();
  std::unique_ptr<PoseEstimator> est;
  ASSERT_TRUE(PoseEstimator::Create(a.camera(), a.layout, {}, &est).ok());
  const cv::Mat close = a.Image(11), far = a.Image(0);
  FrameResult one, far_full;
  est->Estimate(close, 1.1, &one);
  est->Estimate(far, 0.0, &far_full);
  ASSERT_TRUE(one.pose.valid && far_full.pose.valid) << one.pose.message;

  ASSERT_TRUE(est->SetDetection(1, 2).ok());
  EXPECT_EQ(est->options().detector.threads, 2);
  FrameResult two;
  est->Estimate(close, 1.1, &two);
  ASSERT_TRUE(two.pose.valid);
  EXPECT_EQ(two.pose.ids_used, one.pose.ids_used);
  EXPECT_EQ(two.pose.cam_from_object.tvec, one.pose.cam_from_object.tvec);
  EXPECT_EQ(two.pose.covariance, one.pose.covariance);

  ASSERT_TRUE(est->SetDetection(4, 1).ok());
  EXPECT_EQ(est->options().detector.decimate, 4);
  FrameResult coarse, far_coarse;
  est->Estimate(close, 1.1, &coarse);
  est->Estimate(far, 0.0, &far_coarse);
  ASSERT_TRUE(coarse.pose.valid) << coarse.pose.message;
  // Its corners are fitted on the full image as the full search's are, from other starting
  // points: the same position within a tenth of its own RMS standard deviation (about 50 um
  // here), and the full search's limit from the truth (capi_test.c).
  EXPECT_LT((coarse.pose.cam_from_object.tvec - a.Truth(11).tvec).norm(), 0.16e-3);
  EXPECT_LT((coarse.pose.cam_from_object.tvec - one.pose.cam_from_object.tvec).norm(),
            0.1 * std::sqrt(coarse.pose.covariance.bottomRightCorner<3, 3>().trace()));
  EXPECT_LT(far_coarse.detections.size(), far_full.detections.size());

  for (const auto& [decimate, threads, name] :
       {std::tuple{0, 1, "decimate"}, std::tuple{kMaxDecimate + 1, 1, "decimate"},
        std::tuple{1, 0, "frame_threads"},
        std::tuple{1, kMaxDetectorThreads + 1, "frame_threads"}}) {
    const Status s = est->SetDetection(decimate, threads);
    EXPECT_FALSE(s.ok());
    EXPECT_NE(s.message().find(name), std::string::npos) << s.message();
    EXPECT_EQ(est->options().detector.decimate, 4);
    EXPECT_EQ(est->options().detector.threads, 1);
  }
}

TEST(PoseEstimator, BadInputsAreRejectedWithTheirNames) {
  const Approach& a = Shared();
  std::unique_ptr<PoseEstimator> est;
  EXPECT_FALSE(PoseEstimator::Create(CameraModel(), a.layout, {}, &est).ok());
  EXPECT_FALSE(PoseEstimator::Create(a.camera(), Layout{}, {}, &est).ok());
  PoseEstimatorOptions bad;
  bad.fusion.corner_sigma_px = std::nan("");
  Status s = PoseEstimator::Create(a.camera(), a.layout, bad, &est);
  EXPECT_NE(s.message().find("corner_sigma_px"), std::string::npos) << s.message();
  bad = {};
  bad.budget_ms = -1;
  s = PoseEstimator::Create(a.camera(), a.layout, bad, &est);
  EXPECT_NE(s.message().find("budget_ms"), std::string::npos) << s.message();

  const std::string dir = ::testing::TempDir();
  s = PoseEstimator::CreateFromFiles(dir + "/nope.cameramodel", dir + "/nope.json", {}, &est);
  EXPECT_NE(s.message().find("nope.cameramodel"), std::string::npos) << s.message();
  ASSERT_TRUE(a.camera().Write(dir + "/cam.cameramodel").ok());
  {
    std::ofstream f(dir + "/markers.json");
    f << MarkerSetToJson({MarkerModel::Standard(3, 0.1, 0.02)});
  }
  s = PoseEstimator::CreateFromFiles(dir + "/cam.cameramodel", dir + "/markers.json", {}, &est);
  EXPECT_NE(s.message().find("expected a layout"), std::string::npos) << s.message();

  // A frame of nothing: no crash, invalid, says why.
  ASSERT_TRUE(PoseEstimator::Create(a.camera(), a.layout, {}, &est).ok());
  FrameResult r;
  est->Estimate(cv::Mat(), 0, &r);
  EXPECT_FALSE(r.pose.valid);
  est->Estimate(cv::Mat(1, 1, CV_8UC1, cv::Scalar(0)), 0, &r);
  EXPECT_FALSE(r.pose.valid);
  EXPECT_NE(r.pose.message.find("no marker"), std::string::npos);
}

// The approach's view 6 with the fixture beside the module (svms_testing/two_objects.h), and the
// two objects' true poses.
struct TwoObjects {
  Scene scene;
  cv::Mat image;
  Pose module_truth, fixture_truth;
  TwoObjects() {
    scene = svms_testing::WithFixture(Shared().dataset.scenes[0].second);
    std::unique_ptr<Renderer> r;
    EXPECT_TRUE(Renderer::Create(scene, &r).ok());
    const int v = svms_testing::kTwoObjectsView;
    image = r->Expose(r->RenderRadiance(v), v);
    for (const auto& [name, pose] : ComputeTruth(*r, v).cam_from_object)
      (name == "module" ? module_truth : fixture_truth) = pose;
  }
};
const TwoObjects& SharedTwoObjects() {
  static const TwoObjects* t = new TwoObjects;
  return *t;
}

void ExpectSamePose(const ObjectPose& a, const ObjectPose& b, const std::string& what) {
  ASSERT_EQ(a.valid, b.valid) << what;
  EXPECT_EQ(a.cam_from_object.rvec, b.cam_from_object.rvec) << what;
  EXPECT_EQ(a.cam_from_object.tvec, b.cam_from_object.tvec) << what;
  EXPECT_EQ(a.covariance, b.covariance) << what;
  EXPECT_EQ(a.ids_used, b.ids_used) << what;
  EXPECT_EQ(a.ids_rejected, b.ids_rejected) << what;
  EXPECT_EQ(a.chi2, b.chi2) << what;
  EXPECT_EQ(a.markers_seen, b.markers_seen) << what;
  EXPECT_EQ(a.message, b.message) << what;
}

// One frame with two objects, one layout each: one detection pass gives both poses, each near
// its own truth and bit for bit what a single-layout estimator of that object gives.
TEST(PoseEstimator, TwoLayoutsShareOneDetectionAndEachEqualsItsOwnEstimator) {
  const Approach& a = Shared();
  const TwoObjects& t = SharedTwoObjects();
  const Layout fixture = svms_testing::FixtureLayout();
  std::unique_ptr<PoseEstimator> both, module_only, fixture_only;
  ASSERT_TRUE(PoseEstimator::Create(a.camera(), {a.layout, fixture}, {}, &both).ok());
  ASSERT_TRUE(PoseEstimator::Create(a.camera(), a.layout, {}, &module_only).ok());
  ASSERT_TRUE(PoseEstimator::Create(a.camera(), fixture, {}, &fixture_only).ok());
  ASSERT_EQ(both->layouts().size(), 2u);
  FrameResult r, rm, rf;
  both->Estimate(t.image, 0.6, &r);
  module_only->Estimate(t.image, 0.6, &rm);
  fixture_only->Estimate(t.image, 0.6, &rf);
  ASSERT_EQ(r.num_objects(), 2u);
  EXPECT_EQ(r.detection_passes, 1);
  EXPECT_EQ(r.timestamp, 0.6);
  // Each object near its truth (within 6 of its sigmas, and a few millimetres at 3.6-4.5 m).
  const Pose truths[2] = {t.module_truth, t.fixture_truth};
  for (size_t i = 0; i < 2; ++i) {
    const ObjectPose& p = r.object(i);
    ASSERT_TRUE(p.valid) << "object " << i << ": " << p.message;
    EXPECT_GE(p.markers_used, 2) << "object " << i;
    const Eigen::Matrix<double, 6, 1> e = PoseError(truths[i], p.cam_from_object);
    for (int k = 0; k < 6; ++k)
      EXPECT_LT(std::abs(e[k]), 6 * std::sqrt(p.covariance(k, k)) + 1e-5)
          << "object " << i << " component " << k;
    EXPECT_LT(1e3 * e.tail<3>().norm(), 5) << "object " << i;
    std::printf("object %zu: %d markers, error %.3f mm %.4f deg\n", i, p.markers_used,
                1e3 * e.tail<3>().norm(), e.head<3>().norm() * 180 / M_PI);
  }
  // The fixture's markers are not the module's (and the other way round).
  for (int id : r.pose.ids_used) EXPECT_TRUE(a.layout.Find(id)) << id;
  for (int id : r.object(1).ids_used) EXPECT_TRUE(fixture.Find(id)) << id;
  // Bit for bit the single-layout estimators' poses.
  ExpectSamePose(r.object(0), rm.pose, "module");
  ExpectSamePose(r.object(1), rf.pose, "fixture");
  // The detector reports only the layouts' IDs by default, so nothing is unassigned; with
  // known_ids_only off, the module's estimator reports the fixture's three markers as
  // unassigned, and the two-layout estimator none.
  EXPECT_TRUE(r.unassigned_ids.empty());
  EXPECT_TRUE(rm.unassigned_ids.empty());
  std::vector<int> fixture_seen;
  for (const Detection& d : r.detections)
    if (fixture.Find(d.id)) fixture_seen.push_back(d.id);
  EXPECT_EQ(fixture_seen.size(), 3u);
  PoseEstimatorOptions all_ids;
  all_ids.detector.known_ids_only = false;
  ASSERT_TRUE(PoseEstimator::Create(a.camera(), a.layout, all_ids, &module_only).ok());
  ASSERT_TRUE(PoseEstimator::Create(a.camera(), {a.layout, fixture}, all_ids, &both).ok());
  FrameResult r_all;
  module_only->Estimate(t.image, 0.6, &rm);
  both->Estimate(t.image, 0.6, &r_all);
  EXPECT_EQ(rm.unassigned_ids, fixture_seen);
  EXPECT_TRUE(r_all.unassigned_ids.empty());
  ExpectSamePose(r_all.pose, rm.pose, "module, every ID");
  // Latency: one detection and two fusions.
  EXPECT_GE(r.latency_ms, r.detect_ms + r.fuse_ms - 1e-6);
  std::printf("two layouts: detect %.2f ms, fuse %.3f ms; module alone: detect %.2f, fuse %.3f\n",
              r.detect_ms, r.fuse_ms, rm.detect_ms, rm.fuse_ms);
}

TEST(PoseEstimator, AnIdInTwoLayoutsIsRefusedNamingBoth) {
  const Approach& a = Shared();
  Layout other = svms_testing::FixtureLayout();
  other.markers[1].marker = MarkerModel::Standard(13, 0.12, 0.02);  // the module's ID 13
  std::unique_ptr<PoseEstimator> est;
  Status s = PoseEstimator::Create(a.camera(), {a.layout, other}, {}, &est);
  ASSERT_FALSE(s.ok());
  EXPECT_FALSE(est);
  EXPECT_NE(s.message().find("layouts[1] 'fixture': marker ID 13 is also in layouts[0] '" +
                             a.layout.name + "'"),
            std::string::npos)
      << s.message();
  // An inner marker's ID counts too (11 is the inner marker of the module's dual 10).
  other = svms_testing::FixtureLayout();
  other.markers[0].marker = MarkerModel::Standard(11, 0.12, 0.02);
  s = PoseEstimator::Create(a.camera(), {a.layout, other}, {}, &est);
  EXPECT_NE(s.message().find("marker ID 11 is also in"), std::string::npos) << s.message();
  EXPECT_FALSE(PoseEstimator::Create(a.camera(), std::vector<Layout>{}, {}, &est).ok());
  EXPECT_FALSE(PoseEstimator::Create(a.camera(), {a.layout, Layout{}}, {}, &est).ok());

  // From files: the error names both files and the ID; a missing file is named.
  svms_testing::ScratchDir scratch("svms_pose_estimator_test");
  const std::string dir = scratch.path().string();
  const std::string cam = dir + "/cam.cameramodel", la = dir + "/module.json",
                    lb = dir + "/other.json";
  ASSERT_TRUE(a.camera().Write(cam).ok());
  ASSERT_TRUE(WriteTextFile(la, LayoutToJson(a.layout)).ok());
  other = svms_testing::FixtureLayout();
  other.markers[2].marker = MarkerModel::Standard(16, 0.12, 0.02);
  ASSERT_TRUE(WriteTextFile(lb, LayoutToJson(other)).ok());
  s = PoseEstimator::CreateFromFiles(cam, std::vector<std::string>{la, lb}, {}, &est);
  EXPECT_EQ(s.message(), lb + ": marker ID 16 is also in " + la +
                             "; expected each marker ID in one layout only (a detection must "
                             "belong to one object)");
  s = PoseEstimator::CreateFromFiles(cam, std::vector<std::string>{la, dir + "/nope.json"}, {},
                                     &est);
  EXPECT_NE(s.message().find(dir + "/nope.json"), std::string::npos) << s.message();
  ASSERT_TRUE(WriteTextFile(lb, LayoutToJson(svms_testing::FixtureLayout())).ok());
  ASSERT_TRUE(PoseEstimator::CreateFromFiles(cam, std::vector<std::string>{la, lb}, {}, &est).ok());
  EXPECT_EQ(est->layouts()[1].name, "fixture");
}

}  // namespace
}  // namespace svms
