#include "svms/detect/detector.h"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/QR>
#include <chrono>
#include <functional>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <set>
#include <string>
#include <tuple>

#include "svms/base/random_draws.h"
#include "svms/camera/photometric.h"
#include "svms/detect/canny.h"
#include "svms/detect/ippe.h"
#include "svms/detect/noise_model.h"
#include "svms/detect/segments.h"
#include "svms/geometry/pose.h"
#include "svms/sim/render.h"
#include "svms/sim/truth.h"
#include "svms_testing/flat_marker_views.h"
#include "svms_testing/scratch_dir.h"

namespace svms {
namespace {

Pose Look(const Eigen::Vector3d& eye, const Eigen::Vector3d& target) {
  const Eigen::Vector3d z = (target - eye).normalized();
  Eigen::Vector3d y = -(Eigen::Vector3d(0, 1, 0.2) - Eigen::Vector3d(0, 1, 0.2).dot(z) * z);
  y.normalize();
  const Eigen::Vector3d x = y.cross(z);
  Eigen::Matrix3d R;
  R << x, y, z;
  return Pose::FromRotation(R.transpose(), -(R.transpose() * eye));
}

struct Rendered {
  Scene scene;
  cv::Mat image;
  ViewTruth truth;
};

Rendered Render(Scene s) {
  std::unique_ptr<Renderer> r;
  EXPECT_TRUE(Renderer::Create(s, &r).ok());
  Rendered out;
  out.image = r->Expose(r->RenderRadiance(0), 0);
  if (const char* dir = std::getenv("SVMS_TEST_IMAGES")) {
    static int n = 0;
    cv::imwrite(std::string(dir) + "/" +
                    ::testing::UnitTest::GetInstance()->current_test_info()->name() +
                    std::to_string(n++) + ".png",
                out.image);
  }
  out.truth = ComputeTruth(*r, 0);
  out.scene = s;
  return out;
}

// The image an ordinary camera writes of `s`'s view (sRGB at 8 bits behind 0.7 px of lens blur:
// the srgb8 sensor profile, blurred before the pixels integrate the light; or jpeg_srgb, the
// same through OpenCV's JPEG codec at quality 85), read back into linear light as svms detect
// reads it.
Rendered RenderThroughAnOrdinaryCamera(Scene s, const std::string& profile = "srgb8") {
  EXPECT_TRUE(ApplySensorProfile(profile, &s.sensor).ok());
  std::unique_ptr<Renderer> r;
  EXPECT_TRUE(Renderer::Create(s, &r).ok());
  cv::Mat stored;
  EXPECT_TRUE(
      ThroughCodec(s.sensor, r->Expose(r->RenderRadianceFor(0, s.sensor), 0, s.sensor), &stored)
          .ok());
  PhotometricModel m;
  EXPECT_TRUE(Response::Parse("srgb", &m.response).ok());
  m.white_level = 255;
  Rendered out;
  EXPECT_TRUE(Linearizer(m).Apply(stored, &out.image).ok());
  out.truth = ComputeTruth(*r, 0);
  out.scene = s;
  return out;
}

Scene Base(const CameraModel& cam, const std::vector<std::pair<MarkerModel, Pose>>& markers,
           const Pose& view) {
  Scene s;
  s.seed = 3;
  s.camera = cam;
  s.light.sun = Sun{Eigen::Vector3d(0.3, -0.2, 1).normalized(), 1.0, 0.53};
  s.light.ambient = 0.08;
  s.background.kind = Background::Kind::kEarth;
  SceneObject plate;
  plate.name = "plate";
  plate.shape = SceneObject::Shape::kBox;
  plate.size = Eigen::Vector3d(2, 2, 0.02);
  plate.world_from_object.tvec = Eigen::Vector3d(0, 0, -0.01);
  plate.material.reflectance = 0.15;
  for (const auto& [m, p] : markers) {
    SceneMarker sm;
    sm.model = m;
    sm.object_from_marker = p;
    sm.object_from_marker.tvec.z() += 0.01;
    plate.markers.push_back(sm);
  }
  s.objects.push_back(plate);
  s.views.push_back(View{"v", view, std::nullopt, std::nullopt});
  return s;
}

CameraModel Distorted() {
  CameraModel cam;
  EXPECT_TRUE(CameraModel::Create(
                  "LENSMODEL_OPENCV8",
                  {800, 800, 321, 238, -0.3, 0.1, 0.0005, -0.0003, -0.01, 0.01, 0.004, 0.001}, 640,
                  480, &cam)
                  .ok());
  return cam;
}

// Two markers, a post (ID 17) and a concave well (ID 4242), about 100 px at 0.75 m through an
// OPENCV8 lens, on a plate under the sun.
struct TwoMarkers {
  MarkerModel a = MarkerModel::Standard(17, 0.1, 0.025);
  MarkerModel b = MarkerModel::Standard(4242, 0.12, -0.02);  // concave
  Rendered r;
};

TwoMarkers RenderTwoMarkers() {
  TwoMarkers t;
  Pose pa, pb;
  pa.tvec = Eigen::Vector3d(-0.13, 0.02, 0);
  pa.rvec = Eigen::Vector3d(0, 0, 0.4);
  pb.tvec = Eigen::Vector3d(0.12, -0.03, 0);
  pb.rvec = Eigen::Vector3d(0, 0, -2.0);
  t.r = Render(Base(Distorted(), {{t.a, pa}, {t.b, pb}}, Look({0.1, -0.25, 0.75}, {0, 0, 0})));
  return t;
}

TEST(Detector, FindsEveryMarkerWithAccurateCornersAndPose) {
  const TwoMarkers two = RenderTwoMarkers();
  const MarkerModel &a = two.a, &b = two.b;
  const Rendered& r = two.r;
  DetectorOptions dopt;
  dopt.debug_pictures = true;
  const Detector det(dopt, r.scene.camera, {a, b});
  DetectionStats stats;
  const std::vector<Detection> found = det.Detect(r.image, &stats);
  ASSERT_EQ(found.size(), 2u) << "segments " << stats.segments << " quads " << stats.quads;
  // A picture of each step, of the frame's size.
  ASSERT_EQ(stats.debug_pictures.size(), 2u);
  EXPECT_EQ(stats.debug_pictures[0].first, "1_segments");
  EXPECT_EQ(stats.debug_pictures[1].first, "2_quads");
  for (const auto& [step, picture] : stats.debug_pictures) {
    EXPECT_EQ(picture.size(), r.image.size()) << step;
    EXPECT_EQ(picture.type(), CV_8UC3) << step;
  }
  for (const Detection& d : found) {
    const MarkerTruth* t = nullptr;
    for (const auto& mt : r.truth.markers)
      if (mt.id == d.id) t = &mt;
    ASSERT_NE(t, nullptr) << d.id;
    double worst = 0;
    for (int k = 0; k < 4; ++k)
      worst = std::max(worst, (d.corners[k] - t->corners[k].pixel).norm());
    // Limits 1.5 times what the detector reaches here (measured, worst of the two markers:
    // corners 0.038 px, position 0.083 mm, orientation 0.043 deg; the post's top 0.035 px),
    // so a 2x loss of accuracy fails.
    EXPECT_LT(worst, 0.057) << "ID " << d.id << ": corner error in pixels";
    ASSERT_TRUE(d.cam_from_marker.has_value());
    EXPECT_LT((d.cam_from_marker->tvec - t->cam_from_marker.tvec).norm(), 0.125e-3) << d.id;
    EXPECT_LT(AngleBetweenDeg(*d.cam_from_marker, t->cam_from_marker), 0.065) << d.id;
    EXPECT_TRUE(d.tip.has_value()) << d.id;
    // A post's white top is seen whole; a well's bottom only partly (and partly shadowed).
    if (d.tip && d.id == 17) {
      EXPECT_LT((d.tip->pixel - t->tip.pixel).norm(), 0.052) << d.id;
    }
    EXPECT_FALSE(d.pose_ambiguous);
    EXPECT_EQ(d.nested_in, -1);
    // The covariance is a covariance.
    EXPECT_TRUE((d.covariance - d.covariance.transpose()).cwiseAbs().maxCoeff() < 1e-12);
    EXPECT_GT(d.covariance.diagonal().minCoeff(), 0);
    EXPECT_FALSE(d.calibration_in_covariance);
  }
  // The same camera carrying its calibration's uncertainty: the same poses, wider covariances.
  CameraModel calibrated = r.scene.camera;
  Eigen::VectorXd s = Eigen::VectorXd::Constant(calibrated.intrinsics().size(), 1e-4);
  s.head<4>().setConstant(0.5);
  ASSERT_TRUE(calibrated.set_intrinsics_covariance_factor(s.asDiagonal().toDenseMatrix()).ok());
  const std::vector<Detection> again =
      Detector(DetectorOptions{}, calibrated, {a, b}).Detect(r.image);
  ASSERT_EQ(again.size(), found.size());
  for (size_t i = 0; i < found.size(); ++i) {
    EXPECT_TRUE(again[i].calibration_in_covariance);
    ASSERT_TRUE(again[i].cam_from_marker.has_value());
    EXPECT_EQ(again[i].cam_from_marker->tvec, found[i].cam_from_marker->tvec);
    for (int k = 0; k < 6; ++k)
      EXPECT_GT(again[i].covariance(k, k), found[i].covariance(k, k)) << again[i].id << " " << k;
  }
}

// DetectorOptions::decimate: steps 1-4 on a block-averaged image find the same markers (here
// about 100 px), whose corners and poses come from the same full-image fit as without it; the
// coarse segments are mapped back to full-image pixels without a shift (a missed half-pixel
// offset between block and pixel centres would move every unrefined corner the same way).
TEST(Detector, ADecimatedEdgeSearchFindsTheSameMarkersAndCorners) {
  const TwoMarkers two = RenderTwoMarkers();
  const MarkerModel &a = two.a, &b = two.b;
  const Rendered& r = two.r;
  DetectionStats full_stats;
  const std::vector<Detection> full =
      Detector(DetectorOptions{}, r.scene.camera, {a, b}).Detect(r.image, &full_stats);
  ASSERT_EQ(full.size(), 2u);
  auto with_id = [](const std::vector<Detection>& v, int id) -> const Detection* {
    for (const Detection& d : v)
      if (d.id == id) return &d;
    return nullptr;
  };
  for (const int f : {2, 3}) {
    SCOPED_TRACE("decimate " + std::to_string(f));
    DetectorOptions o;
    o.decimate = f;
    DetectionStats stats;
    const std::vector<Detection> found =
        Detector(o, r.scene.camera, {a, b}).Detect(r.image, &stats);
    ASSERT_EQ(found.size(), full.size());
    // The coarse image has fewer edges: the search did run on it.
    EXPECT_LT(stats.segments, full_stats.segments);
    for (const Detection& d : found) {
      const Detection* same = with_id(full, d.id);
      ASSERT_NE(same, nullptr) << d.id;
      for (int k = 0; k < 4; ++k) EXPECT_LT((d.corners[k] - same->corners[k]).norm(), 0.01) << d.id;
      ASSERT_TRUE(d.cam_from_marker.has_value());
      EXPECT_LT(AngleBetweenDeg(*d.cam_from_marker, *same->cam_from_marker), 0.01);
    }
    // Unrefined: the segments' own corners, within a pixel of the truth and not shifted, on the
    // image and on a crop whose sides f does not divide (637 x 479: the last columns and rows
    // are left out of the search, and the blocks stay f pixels wide).
    o.refine_corners = false;
    for (const cv::Mat& image : {r.image, r.image(cv::Rect(0, 0, 637, 479))}) {
      SCOPED_TRACE(std::to_string(image.cols) + " x " + std::to_string(image.rows));
      const std::vector<Detection> rough = Detector(o, CameraModel{}, {a, b}).Detect(image);
      ASSERT_EQ(rough.size(), full.size());
      Eigen::Vector2d mean_offset = Eigen::Vector2d::Zero();
      for (const Detection& d : rough) {
        const MarkerTruth* t = nullptr;
        for (const auto& mt : r.truth.markers)
          if (mt.id == d.id) t = &mt;
        ASSERT_NE(t, nullptr);
        for (int k = 0; k < 4; ++k) {
          EXPECT_LT((d.corners[k] - t->corners[k].pixel).norm(), 0.6 * f) << d.id << " " << k;
          mean_offset += (d.corners[k] - t->corners[k].pixel) / 8;
        }
      }
      // A missed (f - 1) / 2 would shift the mean by 0.5 (f = 2) or 1 px (f = 3) in x and y
      // alike, blocks of the wrong width by up to a pixel across the image.
      EXPECT_LT(mean_offset.cwiseAbs().maxCoeff(), 0.25) << mean_offset.transpose();
    }
  }
}

TEST(Detector, ADeadlinePassedBeforeTheEdgesEndsTheFrameFlaggedAndEmpty) {
  const MarkerModel a = MarkerModel::Standard(17, 0.1, 0.025);
  Pose pa;
  pa.rvec = Eigen::Vector3d(0, 0, 0.4);
  const Rendered r = Render(Base(Distorted(), {{a, pa}}, Look({0.05, -0.2, 0.7}, {0, 0, 0})));
  // Decimated too: that path ends flagged and empty as well.
  for (const int decimate : {1, 2}) {
    SCOPED_TRACE("decimate " + std::to_string(decimate));
    DetectorOptions o;
    o.decimate = decimate;
    const Detector det(o, r.scene.camera, {a});
    DetectionStats stats;
    ASSERT_FALSE(det.Detect(r.image, &stats).empty());
    EXPECT_FALSE(stats.budget_exceeded);
    const auto past = std::chrono::steady_clock::now() - std::chrono::seconds(1);
    EXPECT_TRUE(det.Detect(r.image, &stats, past).empty());
    EXPECT_TRUE(stats.budget_exceeded);
    EXPECT_EQ(stats.quads, 0);  // the quad search never ran
    const auto later = std::chrono::steady_clock::now() + std::chrono::hours(1);
    EXPECT_EQ(det.Detect(r.image, &stats, later).size(), det.Detect(r.image).size());
    EXPECT_FALSE(stats.budget_exceeded);
  }
}

// The time of the edge map's steps that a deadline must interrupt, alone (fastest of two
// runs): for 8 bits the read noise, the grey-level table, the derivatives and Canny; for 16
// bits the noise estimate and the rescaling to 8 bits.
double EdgeMapMs(const cv::Mat& image) {
  double best = 1e9;
  for (int run = 0; run < 2; ++run) {
    const auto t0 = std::chrono::steady_clock::now();
    if (image.depth() == CV_16U) {
      cv::Mat out8;
      StabiliseVariance(image, EstimateNoise(image), &out8);
    } else {
      EstimateReadNoise(image);
      cv::Mat table(1, 256, CV_8U), stabilised, gx, gy, edges;
      for (int v = 0; v < 256; ++v)
        table.at<uint8_t>(v) = cv::saturate_cast<uint8_t>(16 * std::sqrt(v));
      cv::LUT(image, table, stabilised);
      cv::spatialGradient(stabilised, gx, gy, 3);
      CannyScratch scratch;
      CannyFromDerivatives(gx, gy, 24, 64, true, &scratch, &edges);
    }
    best = std::min(
        best,
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
  return best;
}

TEST(Detector, ADeadlinePassedBeforeTheEdgeMapEndsTheFrameBeforeTheEdgeMapIsMade) {
  // A 1024 x 1024 textured frame (8 and 16 bits, one and two threads): under a deadline already
  // passed the frame ends flagged and empty within the first rows of the edge map (and of a
  // 16-bit image's noise estimate), in a fraction of the time the edge map alone takes.
  cv::Mat blocks(128, 128, CV_8U), texture;
  cv::RNG rng(9);
  rng.fill(blocks, cv::RNG::UNIFORM, 30, 220);
  cv::resize(blocks, texture, cv::Size(1024, 1024), 0, 0, cv::INTER_NEAREST);
  cv::GaussianBlur(texture, texture, cv::Size(0, 0), 1);
  cv::Mat texture16;
  texture.convertTo(texture16, CV_16U, 200);
  for (const int threads : {1, 2}) {
    DetectorOptions o;
    o.threads = threads;
    const Detector det(o, CameraModel(), {});
    for (const cv::Mat& image : {texture, texture16}) {
      const std::string what =
          std::to_string(threads) + " threads, " + (image.depth() == CV_8U ? "8 bits" : "16 bits");
      DetectionStats stats;
      det.Detect(image, &stats);
      ASSERT_FALSE(stats.budget_exceeded) << what;
      ASSERT_GT(stats.segments, 1000) << what;
      double stopped = 1e9;  // the fastest of a few runs: the machine may be busy
      for (int run = 0; run < 3; ++run) {
        const auto past = std::chrono::steady_clock::now() - std::chrono::seconds(1);
        EXPECT_TRUE(det.Detect(image, &stats, past).empty()) << what;
        EXPECT_TRUE(stats.budget_exceeded) << what;
        EXPECT_EQ(stats.segments, 0) << what;
        EXPECT_EQ(stats.quads, 0) << what;
        stopped = std::min(stopped, stats.ms[0]);
      }
      // Measured: 0.05-0.15 ms against 20 ms (8 bits: dense edges) and 1.6 ms (16 bits).
      const double edge_map = EdgeMapMs(image);
      EXPECT_LT(stopped, 0.4 * edge_map) << what << ": " << stopped << " ms against " << edge_map;
    }
  }
}

// Every field of two detections, to the bit.
void ExpectSameBitForBit(const Detection& a, const Detection& b, const std::string& what) {
  EXPECT_EQ(a.id, b.id) << what;
  EXPECT_EQ(a.rotation, b.rotation) << what;
  EXPECT_EQ(a.bit_errors, b.bit_errors) << what;
  for (int k = 0; k < 4; ++k) {
    EXPECT_TRUE(a.corners[k] == b.corners[k]) << what << " corner " << k;
    EXPECT_EQ(a.corner_sigma[k], b.corner_sigma[k]) << what;
    EXPECT_EQ(a.penumbra_sides[k], b.penumbra_sides[k]) << what;
  }
  EXPECT_TRUE(a.corner_covariance == b.corner_covariance) << what;
  ASSERT_EQ(a.tip.has_value(), b.tip.has_value()) << what;
  if (a.tip) {
    EXPECT_TRUE(a.tip->pixel == b.tip->pixel) << what;
    EXPECT_EQ(a.tip->sigma_px, b.tip->sigma_px) << what;
  }
  ASSERT_EQ(a.cam_from_marker.has_value(), b.cam_from_marker.has_value()) << what;
  if (a.cam_from_marker) {
    EXPECT_TRUE(a.cam_from_marker->rvec == b.cam_from_marker->rvec) << what;
    EXPECT_TRUE(a.cam_from_marker->tvec == b.cam_from_marker->tvec) << what;
  }
  EXPECT_TRUE(a.covariance == b.covariance) << what;
  EXPECT_EQ(a.pose_ambiguous, b.pose_ambiguous) << what;
  EXPECT_TRUE(a.ambiguity_covariance == b.ambiguity_covariance) << what;
  ASSERT_EQ(a.alternative_pose.has_value(), b.alternative_pose.has_value()) << what;
  if (a.alternative_pose) {
    EXPECT_TRUE(a.alternative_pose->rvec == b.alternative_pose->rvec) << what;
    EXPECT_TRUE(a.alternative_pose->tvec == b.alternative_pose->tvec) << what;
  }
  EXPECT_EQ(a.alternative_weight, b.alternative_weight) << what;
  EXPECT_EQ(a.calibration_in_covariance, b.calibration_in_covariance) << what;
  EXPECT_EQ(a.pose_rms_px, b.pose_rms_px) << what;
  EXPECT_EQ(a.pose_error, b.pose_error) << what;
  EXPECT_EQ(a.nested_in, b.nested_in) << what;
  EXPECT_EQ(a.black, b.black) << what;
  EXPECT_EQ(a.white, b.white) << what;
}

TEST(Detector, SeveralThreadsGiveTheSameDetectionsToTheBit) {
  // Sixteen markers of 25-90 px (one a dual marker) on a noise-textured plate seen at an
  // angle through a distorted lens: hundreds of edge chains across every band of rows, dozens
  // of candidate quads.
  CameraModel cam;
  ASSERT_TRUE(CameraModel::Create("LENSMODEL_OPENCV4", {700, 700, 479.5, 359.5, -0.2, 0.05, 0, 0},
                                  960, 720, &cam)
                  .ok());
  std::vector<std::pair<MarkerModel, Pose>> markers;
  for (int i = 0; i < 16; ++i) {
    const double size = i == 5 ? 0.12 : 0.04 + 0.01 * (i % 5);
    MarkerModel m = MarkerModel::Standard(40 + i, size, i % 3 == 0 ? -size / 5 : size / 4);
    if (i == 5) {
      m.post = MarkerModel::Standard(40 + i, size, 0.02).post;
      m.AddInner(140, 0.03);
      m.post->radius = m.post->tip_radius = 0.003;
    }
    Pose p;
    p.tvec = Eigen::Vector3d(-0.36 + 0.24 * (i % 4), -0.27 + 0.18 * (i / 4), 0);
    p.rvec = Eigen::Vector3d(0, 0, 0.4 * i);
    markers.emplace_back(m, p);
  }
  Scene scene = Base(cam, markers, Look({0.15, -0.3, 1.1}, {0, 0, 0}));
  scene.objects[0].material.pattern.kind = Pattern::Kind::kNoise;
  scene.objects[0].material.pattern.period = 0.01;
  scene.objects[0].material.pattern.low = 0.05;
  scene.objects[0].material.pattern.high = 0.4;
  scene.sensor.rays_per_pixel = 4;  // a quarter of the default: this test needs no fine edges
  const Rendered r = Render(scene);
  std::vector<MarkerModel> models;
  for (const auto& [m, p] : markers) models.push_back(m);
  DetectorOptions one;
  const Detector serial(one, cam, models);
  DetectionStats stats1;
  const std::vector<Detection> want = serial.Detect(r.image, &stats1);
  ASSERT_GE(want.size(), 15u) << "segments " << stats1.segments << " quads " << stats1.quads;
  EXPECT_GE(stats1.quads, 30);
  for (const int threads : {2, 3}) {
    DetectorOptions several;
    several.threads = threads;
    const Detector parallel(several, cam, models);
    for (int frame = 0; frame < 2; ++frame) {  // the second frame on warmed-up threads
      DetectionStats stats;
      const std::vector<Detection> got = parallel.Detect(r.image, &stats);
      EXPECT_EQ(stats.segments, stats1.segments);
      EXPECT_EQ(stats.quads, stats1.quads);
      EXPECT_EQ(stats.rejected_for_evidence, stats1.rejected_for_evidence);
      EXPECT_FALSE(stats.budget_exceeded);
      ASSERT_EQ(got.size(), want.size()) << threads << " threads";
      for (size_t i = 0; i < want.size(); ++i)
        ExpectSameBitForBit(got[i], want[i],
                            std::to_string(threads) + " threads, detection " + std::to_string(i));
    }
  }
  // A copy has its own threads and gives the same.
  DetectorOptions two;
  two.threads = 2;
  const Detector original(two, cam, models);
  const Detector copy = original;
  const std::vector<Detection> again = copy.Detect(r.image);
  ASSERT_EQ(again.size(), want.size());
  for (size_t i = 0; i < want.size(); ++i) ExpectSameBitForBit(again[i], want[i], "copy");
}

TEST(Detector, DualMarkerReportsBothWithTheirNesting) {
  MarkerModel dual = MarkerModel::Standard(1, 0.3, 0.02);
  dual.AddInner(2, 0.075);
  dual.post->radius = dual.post->tip_radius = 0.004;
  const Rendered r =
      Render(Base(Distorted(), {{dual, Pose{}}}, Look({0.05, -0.15, 1.6}, {0, 0, 0})));
  const Detector det(DetectorOptions{}, r.scene.camera, {dual});
  const std::vector<Detection> found = det.Detect(r.image);
  ASSERT_EQ(found.size(), 2u);
  for (const Detection& d : found) {
    if (d.id == 2) {
      EXPECT_EQ(d.nested_in, 1);
    } else {
      EXPECT_EQ(d.nested_in, -1);
    }
  }
}

// Flips bit cells `cells` of the marker with pixel corners `c` (TL, TR, BR, BL) by painting
// each cell's square (90 % of it) with the level of the opposite colour.
void PaintFlippedCells(const std::array<Eigen::Vector2d, 4>& c, const std::vector<int>& cells,
                       cv::Mat* image) {
  const MarkerModel unit = MarkerModel::Standard(0, 1.0, 0);
  cv::Mat src = (cv::Mat_<float>(4, 2) << -0.5, 0.5, 0.5, 0.5, 0.5, -0.5, -0.5, -0.5),
          dst(4, 2, CV_32F);
  for (int k = 0; k < 4; ++k) dst.at<float>(k, 0) = c[k].x(), dst.at<float>(k, 1) = c[k].y();
  const cv::Mat H = cv::getPerspectiveTransform(src, dst);
  double lo, hi;
  cv::minMaxLoc(*image, &lo, &hi);
  for (int i : cells) {
    const Eigen::Vector2d m = unit.BitCellCentre(i);
    const double h = 0.45 * unit.cell_size;
    std::vector<cv::Point2f> in = {{float(m.x() - h), float(m.y() + h)},
                                   {float(m.x() + h), float(m.y() + h)},
                                   {float(m.x() + h), float(m.y() - h)},
                                   {float(m.x() - h), float(m.y() - h)}},
                             out;
    cv::perspectiveTransform(in, out, H);
    std::vector<cv::Point2f> centre;
    cv::perspectiveTransform(std::vector<cv::Point2f>{{float(m.x()), float(m.y())}}, centre, H);
    cv::perspectiveTransform(in, out, H);
    const bool white =
        image->at<uint8_t>(cvRound(centre[0].y), cvRound(centre[0].x)) > 0.5 * (lo + hi);
    std::vector<cv::Point> poly;
    for (const cv::Point2f& p : out) poly.emplace_back(cvRound(p.x * 16), cvRound(p.y * 16));
    cv::fillConvexPoly(*image, poly, cv::Scalar(white ? lo : hi), cv::LINE_AA, 4);
  }
}

// A decode with 4 corrected bits has no evidence of its own without a tip (more than
// max_unsupported_corrections, more than the 3 a known ID may have): the inner marker of a
// dual is still accepted inside its outer marker's square, while the same reading of the
// same ID standing alone is not.
TEST(Detector, AnInnerMarkersLargeCorrectionIsAcceptedInsideItsOuterMarker) {
  MarkerModel dual = MarkerModel::Standard(1, 0.3, 0.02);
  dual.AddInner(2, 0.075);
  dual.post->radius = dual.post->tip_radius = 0.004;
  const MarkerModel alone = MarkerModel::Standard(2, 0.075, 0);
  Pose there;
  there.tvec = Eigen::Vector3d(0.45, 0, 0);
  Rendered r = Render(
      Base(Distorted(), {{dual, Pose{}}, {alone, there}}, Look({0.15, -0.15, 1.5}, {0.15, 0, 0})));
  std::vector<Eigen::Vector2d> inner_centres;
  for (const MarkerTruth& m : r.truth.markers) {
    if (m.id != 2) continue;
    std::array<Eigen::Vector2d, 4> c;
    for (int k = 0; k < 4; ++k) c[k] = m.corners[k].pixel;
    EXPECT_GT((c[1] - c[0]).norm(), 18);  // large enough for the painted cells to be read
    PaintFlippedCells(c, {3, 14, 25, 36}, &r.image);
    if (m.nested_in == 1) inner_centres.push_back(0.25 * (c[0] + c[1] + c[2] + c[3]));
  }
  ASSERT_EQ(inner_centres.size(), 1u);
  // No camera: no pose, so no tip; the models give the IDs and the nesting.
  const Detector det(DetectorOptions{}, CameraModel(), {dual});
  DetectionStats stats;
  const std::vector<Detection> found = det.Detect(r.image, &stats);
  int twos = 0;
  for (const Detection& d : found) {
    if (d.id != 2) continue;
    ++twos;
    EXPECT_EQ(d.bit_errors, 4);
    EXPECT_EQ(d.nested_in, 1);
    const Eigen::Vector2d c = 0.25 * (d.corners[0] + d.corners[1] + d.corners[2] + d.corners[3]);
    EXPECT_LT((c - inner_centres[0]).norm(), 1.0);
  }
  EXPECT_EQ(twos, 1);
  EXPECT_GE(stats.rejected_for_evidence, 1);  // the one standing alone
  // Two threads: the inner marker waits for its outer one there too, and all is the same.
  DetectorOptions two;
  two.threads = 2;
  DetectionStats stats2;
  const std::vector<Detection> again =
      Detector(two, CameraModel(), {dual}).Detect(r.image, &stats2);
  EXPECT_EQ(stats2.rejected_for_evidence, stats.rejected_for_evidence);
  ASSERT_EQ(again.size(), found.size());
  for (size_t i = 0; i < found.size(); ++i) ExpectSameBitForBit(again[i], found[i], "2 threads");
}

// At 65 degrees the standard post (a quarter of the side high) leans across a side of the
// square: its dark body bulges into the white stripe and its top sits on the edge. Fitted
// through, that side is off by tenths of a pixel at its corners.
TEST(Detector, APostAcrossASideDoesNotMoveTheCorners) {
  CameraModel cam;
  ASSERT_TRUE(
      CameraModel::Create("LENSMODEL_PINHOLE", {1111.1, 1111.1, 511.5, 511.5}, 1024, 1024, &cam)
          .ok());
  const MarkerModel m = MarkerModel::Standard(3, 0.2, 0.05);
  Pose object_from_marker;
  object_from_marker.rvec = Eigen::Vector3d(0, 0, 0.2);
  Pose view;  // the angle dataset's view 17: 65 degrees, 1.5 m
  view.rvec = Eigen::Vector3d(-2.1773614854504215, 0.8536895362626495, -1.3654178663675791);
  view.tvec = Eigen::Vector3d(0, 0, 1.5);
  Scene s = Base(cam, {{m, object_from_marker}}, view);
  s.sensor.read_noise = 0;
  s.sensor.shot_noise = false;
  s.sensor.rays_per_pixel = 64;
  const Rendered r = Render(s);
  ASSERT_EQ(r.truth.markers.size(), 1u);
  const MarkerTruth& t = r.truth.markers[0];
  auto corner_rms = [&](const DetectorOptions& o, Detection* out) {
    const std::vector<Detection> found = Detector(o, cam, {m}).Detect(r.image);
    if (found.size() != 1) return -1.0;
    double ss = 0;
    for (int k = 0; k < 4; ++k) ss += (found[0].corners[k] - t.corners[k].pixel).squaredNorm();
    *out = found[0];
    return std::sqrt(ss / 4);
  };
  Detection plain, fixed;
  DetectorOptions o;
  o.refine.trim_passes = 0;
  o.post_silhouette_margin_px = 0;
  const double before = corner_rms(o, &plain);
  const double after = corner_rms(DetectorOptions{}, &fixed);
  EXPECT_GT(before, 0.06) << "the post no longer crosses a side: the test lost its point";
  EXPECT_LT(after, 0.03) << "corner RMS error, pixels (" << before << " without step 10b)";
  EXPECT_LT(after, 0.5 * before);
  ASSERT_TRUE(fixed.cam_from_marker.has_value());
  EXPECT_LT(AngleBetweenDeg(*fixed.cam_from_marker, t.cam_from_marker), 0.1);
  EXPECT_LT((fixed.cam_from_marker->tvec - t.cam_from_marker.tvec).norm(), 5e-4);
}

TEST(Detector, TheTipPicksTheRightPoseWhereThePlanarPoseIsAmbiguous) {
  // A small marker (about 55 x 30 px) seen 55 degrees off-axis: the two planar solutions are
  // close in corner error; the post tip tells them apart.
  MarkerModel m = MarkerModel::Standard(99, 0.08, 0.02);
  const CameraModel cam = CameraModel::Pinhole(700, 320, 240);
  const double a = 55 * M_PI / 180;
  const Rendered r =
      Render(Base(cam, {{m, Pose{}}}, Look({std::sin(a), 0.1, std::cos(a)}, {0, 0, 0})));
  const Detector det(DetectorOptions{}, cam, {m});
  const std::vector<Detection> found = det.Detect(r.image);
  ASSERT_EQ(found.size(), 1u);
  ASSERT_TRUE(found[0].cam_from_marker && found[0].tip);
  EXPECT_LT(AngleBetweenDeg(*found[0].cam_from_marker, r.truth.markers[0].cam_from_marker), 3.0);
  EXPECT_FALSE(found[0].pose_ambiguous);
  // Without the post, the same corners (and the stripe's edges) leave the choice to the fit:
  // either it gets it right or it says it could not tell.
  MarkerModel flat = m;
  flat.post.reset();
  const Detector det_flat(DetectorOptions{}, cam, {flat});
  const std::vector<Detection> f2 = det_flat.Detect(r.image);
  ASSERT_EQ(f2.size(), 1u);
  ASSERT_TRUE(f2[0].cam_from_marker);
  const double flat_error =
      AngleBetweenDeg(*f2[0].cam_from_marker, r.truth.markers[0].cam_from_marker);
  RecordProperty("flat_orientation_error_deg", std::to_string(flat_error));
  EXPECT_TRUE(f2[0].pose_ambiguous || flat_error < 3.0) << flat_error;
}

// Rotation error of `estimate` against `truth` (camera axes, radians) in units of the
// covariance's rotation block: its squared Mahalanobis length (3 degrees of freedom).
double RotationNees(const Pose& truth, const Pose& estimate, const PoseCovariance& covariance) {
  const Eigen::Vector3d w = Log(estimate.Rotation() * truth.Rotation().transpose());
  return w.dot(covariance.topLeftCorner<3, 3>().ldlt().solve(w));
}

// Flat markers (no post) of about 20 px, 5-27 degrees off-axis: the corners hardly tell the
// two planar poses apart. Where the wrong one is kept, the pose is flagged and its covariance
// spans the right one too, so the error stays within it.
TEST(Detector, AnAmbiguousPoseCoversBothPlanarSolutions) {
  const CameraModel cam = CameraModel::Pinhole(1111.1, 320, 240);
  int ambiguous = 0, wrong = 0;
  for (int v = 0; v < svms_testing::kFlatMarkerViews; ++v) {
    const MarkerModel m = svms_testing::FlatMarker(v);
    const Rendered r =
        Render(Base(cam, {{m, Pose{}}}, Look(svms_testing::FlatMarkerEye(v), {0, 0, 0})));
    const std::vector<Detection> d = Detector(DetectorOptions{}, cam, {m}).Detect(r.image);
    ASSERT_EQ(d.size(), 1u) << v;
    ASSERT_TRUE(d[0].cam_from_marker);
    const Pose& truth = r.truth.markers[0].cam_from_marker;
    const double error = AngleBetweenDeg(*d[0].cam_from_marker, truth);
    const double nees = RotationNees(truth, *d[0].cam_from_marker, d[0].covariance);
    ambiguous += d[0].pose_ambiguous;
    wrong += error > 5;
    SCOPED_TRACE("view " + std::to_string(v) + ": error " + std::to_string(error) + " deg");
    if (error > 5) {
      EXPECT_TRUE(d[0].pose_ambiguous);
    }
    // A flagged pose comes with the other planar pose; where the kept one is wrong, that one
    // is right.
    ASSERT_EQ(d[0].alternative_pose.has_value(), d[0].pose_ambiguous);
    if (d[0].alternative_pose) {
      EXPECT_GT(d[0].alternative_weight, 0.01);
      EXPECT_LE(d[0].alternative_weight, 0.5);
      if (error > 5) {
        EXPECT_LT(AngleBetweenDeg(*d[0].alternative_pose, truth), 5);
      }
    }
    EXPECT_LT(nees, 16.3);  // chi-square, 3 dof, 99.9 %
  }
  RecordProperty("ambiguous", ambiguous);
  RecordProperty("wrong_solution_kept", wrong);
  EXPECT_GT(ambiguous, 0);
}

// EstimateMarkerPose with MarkerPoseOptions::corner_covariance_from_fit, on the detected
// corners of rendered markers: the flat ones of the ambiguity test (no post: the other planar
// solution widens the covariance) and ones with a post of about 45 and 10 px (the tip picks
// the candidate), through a camera with a calibration covariance. Given a diagonal joint
// covariance (each corner's own sigma^2, scaled as the independent fit scales it), the paths
// that whiten the corners (the candidates' refinement and chi2, the stripe and decal edges, the
// other solution's weight, the calibration's share) must give the independent fit to rounding:
// a whitener with the wrong scale, on the wrong rows or left out of the fit would not. Given
// the detector's own joint covariance, the other solution's weight must be the one the
// corners' chi2 under that covariance gives (a transposed whitener fails here), and the pose
// stays within its covariance of the truth. Not reached by these views: the planar twin's
// weight (WidenForPlanarTwin), taken only where both candidates refine to one pose.
TEST(EstimateMarkerPose, JointCornersWithADiagonalCovarianceAreTheIndependentFit) {
  CameraModel cam = CameraModel::Pinhole(1111.1, 320, 240);
  ASSERT_TRUE(cam.set_intrinsics_covariance_factor(
                     Eigen::Vector4d(2.0, 2.0, 1.5, 1.5).asDiagonal().toDenseMatrix())
                  .ok());
  std::vector<std::pair<MarkerModel, Eigen::Vector3d>> views;
  for (int v = 0; v < svms_testing::kFlatMarkerViews; ++v)
    views.emplace_back(svms_testing::FlatMarker(v), svms_testing::FlatMarkerEye(v));
  for (int v = 0; v < 16; ++v) {  // 4 of about 45 px, then 12 of 10 px
    const double a = (v < 4 ? 10 + 12 * v : 8 + 4 * (v - 4)) * M_PI / 180, range = v < 4 ? 5 : 22;
    views.emplace_back(MarkerModel::Standard(100 + v, 0.2, 0.05),
                       Eigen::Vector3d(range * std::sin(a), 0.3, range * std::cos(a)));
  }
  // A scale other than 1 on both, so that a whitener that leaves it out or squares it again
  // shows.
  MarkerPoseOptions independent;
  independent.corner_fit_scale = 1.3;
  MarkerPoseOptions joint = independent;
  joint.corner_covariance_from_fit = true;
  joint.corner_covariance_scale = independent.corner_fit_scale;
  int widened = 0, alternatives_weighed = 0, missed = 0, tips = 0, with_edges = 0;
  double nees_joint = 0;
  for (size_t v = 0; v < views.size(); ++v) {
    SCOPED_TRACE("view " + std::to_string(v));
    const MarkerModel& m = views[v].first;
    const Rendered r = Render(Base(cam, {{m, Pose{}}}, Look(views[v].second, {0, 0, 0})));
    ASSERT_EQ(r.image.depth(), CV_8U);  // so the detection's grey levels are the image's
    const std::vector<Detection> d = Detector(DetectorOptions{}, cam, {m}).Detect(r.image);
    if (d.size() != 1 && v >= views.size() - 12) {
      ++missed;
      continue;
    }
    ASSERT_EQ(d.size(), 1u);
    ASSERT_GT(d[0].corner_covariance.diagonal().minCoeff(), 0);
    Eigen::Matrix<double, 8, 8> diagonal = Eigen::Matrix<double, 8, 8>::Zero();
    for (int k = 0; k < 4; ++k)
      diagonal(2 * k, 2 * k) = diagonal(2 * k + 1, 2 * k + 1) =
          d[0].corner_sigma[k] * d[0].corner_sigma[k];
    MarkerPose a, b, c;
    ASSERT_TRUE(EstimateMarkerPose(r.image, d[0].corners, m, cam, d[0].black, d[0].white,
                                   independent, &a, d[0].corner_sigma));
    ASSERT_TRUE(EstimateMarkerPose(r.image, d[0].corners, m, cam, d[0].black, d[0].white, joint, &b,
                                   d[0].corner_sigma, &diagonal));
    ASSERT_TRUE(EstimateMarkerPose(r.image, d[0].corners, m, cam, d[0].black, d[0].white, joint, &c,
                                   d[0].corner_sigma, &d[0].corner_covariance));
    EXPECT_FALSE(a.joint_corners);
    EXPECT_TRUE(b.joint_corners);
    EXPECT_TRUE(c.joint_corners);
    // The diagonal whitener is the independent fit.
    EXPECT_LT(AngleBetweenDeg(a.cam_from_marker, b.cam_from_marker), 1e-7);
    EXPECT_LT((a.cam_from_marker.tvec - b.cam_from_marker.tvec).norm(),
              1e-8 * a.cam_from_marker.tvec.norm());
    EXPECT_LT((a.covariance - b.covariance).norm(), 1e-6 * a.covariance.norm());
    EXPECT_LT((a.ambiguity_covariance - b.ambiguity_covariance).norm(), 1e-6 * a.covariance.norm());
    EXPECT_EQ(a.ambiguous, b.ambiguous);
    EXPECT_NEAR(a.alternative_weight, b.alternative_weight, 1e-9);
    EXPECT_EQ(a.edge_points, b.edge_points);
    EXPECT_EQ(a.tip.has_value(), b.tip.has_value());
    EXPECT_TRUE(a.calibration_in_covariance);
    EXPECT_TRUE(b.calibration_in_covariance);
    // The detector's joint covariance is used.
    EXPECT_GT((c.covariance - a.covariance).norm(), 1e-3 * a.covariance.norm());
    const double nees =
        RotationNees(r.truth.markers[0].cam_from_marker, c.cam_from_marker, c.covariance);
    EXPECT_LT(nees, 16.3);  // chi-square, 3 dof, 99.9 %
    nees_joint += nees;
    // The other planar solution's weight 1 / (1 + exp(dchi2 / 2)) where the corners are the
    // only points (no post; edges off, so the kept pose is the one weighed) and that solution,
    // not the kept pose's planar twin, widened the covariance (the twin's leaves the
    // translation alone): chi2 of each solution d8^T C^-1 d8 under the joint covariance C (a
    // transposed whitener would give other values).
    MarkerPoseOptions corners_only = joint;
    corners_only.use_stripe_edge = false;
    MarkerPose e;
    ASSERT_TRUE(EstimateMarkerPose(r.image, d[0].corners, m, cam, d[0].black, d[0].white,
                                   corners_only, &e, d[0].corner_sigma, &d[0].corner_covariance));
    if (!e.tip && e.alternative && e.ambiguity_covariance.bottomRightCorner<3, 3>().norm() > 0) {
      const Eigen::Matrix<double, 8, 8> C =
          joint.corner_covariance_scale * joint.corner_covariance_scale * d[0].corner_covariance;
      auto chi2 = [&](const Pose& pose) {
        Eigen::Matrix<double, 8, 1> r8;
        for (int k = 0; k < 4; ++k) {
          Eigen::Vector2d q;
          EXPECT_TRUE(cam.Project(pose * m.Corners()[k], &q));
          r8.segment<2>(2 * k) = q - d[0].corners[k];
        }
        return r8.dot(C.ldlt().solve(r8));
      };
      const double dchi2 = std::max(0.0, chi2(*e.alternative) - chi2(e.cam_from_marker));
      EXPECT_NEAR(e.alternative_weight, 1 / (1 + std::exp(0.5 * dchi2)),
                  1e-6 * e.alternative_weight);
      ++alternatives_weighed;
    }
    widened += a.ambiguity_covariance.norm() > 0;
    tips += a.tip.has_value();
    with_edges += a.edge_points > 0;
  }
  RecordProperty("views_widened_by_the_other_solution", widened);
  RecordProperty("alternatives_weighed_jointly", alternatives_weighed);
  RecordProperty("mean_rotation_nees_joint", std::to_string(nees_joint / (views.size() - missed)));
  // The paths above were taken.
  EXPECT_GT(widened, 0);
  EXPECT_GT(alternatives_weighed, 0);
  EXPECT_LE(missed, 2);  // of the 10 px markers
  EXPECT_GT(tips, 0);
  EXPECT_GT(with_edges, 0);
}

// A 30 px marker nearly head-on (the paper's Fig. 9 at its far end): the white stripe's outer
// edge, fitted where black cells border it, brings the orientation closer to the truth and the
// covariance says so.
TEST(Detector, TheStripeAndDecalEdgesSharpenTheOrientationOfASmallMarker) {
  const CameraModel cam = CameraModel::Pinhole(1111.1, 320, 240);
  double err_on = 0, err_off = 0, err_stripe = 0, sigma_on = 0, sigma_off = 0, sigma_stripe = 0;
  int n = 0;
  for (int v = 0; v < 6; ++v) {
    const MarkerModel m = MarkerModel::Standard(100 + v, 0.2, 0.05);
    const double a = (5 + 4 * v) * M_PI / 180;
    const Rendered r = Render(
        Base(cam, {{m, Pose{}}}, Look({7.4 * std::sin(a), 0.3, 7.4 * std::cos(a)}, {0, 0, 0})));
    DetectorOptions off, stripe_only;
    off.pose.use_stripe_edge = false;
    stripe_only.pose.use_decal_edge = false;
    const std::vector<Detection> d_on = Detector(DetectorOptions{}, cam, {m}).Detect(r.image);
    const std::vector<Detection> d_off = Detector(off, cam, {m}).Detect(r.image);
    const std::vector<Detection> d_stripe = Detector(stripe_only, cam, {m}).Detect(r.image);
    ASSERT_EQ(d_on.size(), 1u);
    ASSERT_EQ(d_off.size(), 1u);
    ASSERT_EQ(d_stripe.size(), 1u);
    ASSERT_TRUE(d_on[0].cam_from_marker && d_off[0].cam_from_marker && d_stripe[0].cam_from_marker);
    const Pose& truth = r.truth.markers[0].cam_from_marker;
    err_on += std::pow(AngleBetweenDeg(*d_on[0].cam_from_marker, truth), 2);
    err_off += std::pow(AngleBetweenDeg(*d_off[0].cam_from_marker, truth), 2);
    err_stripe += std::pow(AngleBetweenDeg(*d_stripe[0].cam_from_marker, truth), 2);
    sigma_on += d_on[0].covariance.topLeftCorner<3, 3>().trace();
    sigma_off += d_off[0].covariance.topLeftCorner<3, 3>().trace();
    sigma_stripe += d_stripe[0].covariance.topLeftCorner<3, 3>().trace();
    ++n;
  }
  err_on = std::sqrt(err_on / n);
  err_off = std::sqrt(err_off / n);
  err_stripe = std::sqrt(err_stripe / n);
  RecordProperty("orientation_rms_deg_with_edges", std::to_string(err_on));
  RecordProperty("orientation_rms_deg_stripe_edge_only", std::to_string(err_stripe));
  RecordProperty("orientation_rms_deg_without", std::to_string(err_off));
  RecordProperty("orientation_variance_ratio_both_to_stripe",
                 std::to_string(sigma_on / sigma_stripe));
  EXPECT_LT(err_on, err_off);
  EXPECT_LT(sigma_on, 0.7 * sigma_off);     // the edge points carry real information
  EXPECT_LT(sigma_on, 0.9 * sigma_stripe);  // and the decal's edge adds to the stripe's
}

// `count` 0.1 m markers (IDs first_id, first_id + 1, ...; posts `post_m` tall, 0 for flat ones)
// lying on the plate, marker i turned in its plane by i * turn_rad and centred at at(i) (metres):
// the rows of small markers the tests below render.
struct MarkerRow {
  std::vector<std::pair<MarkerModel, Pose>> markers;
  std::vector<MarkerModel> models;
};
MarkerRow MakeMarkerRow(int first_id, int count, double post_m, double turn_rad,
                        const std::function<Eigen::Vector3d(int)>& at) {
  MarkerRow row;
  for (int i = 0; i < count; ++i) {
    Pose p;
    p.rvec = Eigen::Vector3d(0, 0, turn_rad * i);
    p.tvec = at(i);
    row.markers.push_back({MarkerModel::Standard(first_id + i, 0.1, post_m), p});
    row.models.push_back(row.markers.back().first);
  }
  return row;
}

// The markers of `row` that the detector finds in `image` (through `cam`), each counted once;
// any other ID, or an ID reported twice, fails the test.
int FoundInRow(const DetectorOptions& o, const CameraModel& cam, const MarkerRow& row,
               const cv::Mat& image) {
  std::set<int> ours, seen;
  for (const MarkerModel& m : row.models) ours.insert(m.id);
  int wrong = 0, twice = 0;
  for (const Detection& d : Detector(o, cam, row.models).Detect(image)) {
    if (!ours.count(d.id)) ++wrong;
    if (!seen.insert(d.id).second) ++twice;
  }
  EXPECT_EQ(wrong, 0);
  EXPECT_EQ(twice, 0);
  return static_cast<int>(seen.size()) - wrong;
}

// Markers whose black square is 8-11 px: the corners of such a small quad are off by tenths
// of a pixel, and the bits are read right only after the corner fit (step 7b).
TEST(Detector, TenPixelMarkersAreReadAfterTheirCornersAreRefined) {
  const MarkerRow row = MakeMarkerRow(40, 6, 0.025, 0.25, [](int i) {
    return Eigen::Vector3d(-0.6 + 0.25 * i, 0.12 * (i % 2), 0);
  });
  const CameraModel cam = CameraModel::Pinhole(600, 400, 200);
  const Rendered r = Render(Base(cam, row.markers, Look({0.05, -0.3, 5.6}, {0, 0, 0})));
  for (const MarkerTruth& t : r.truth.markers) ASSERT_LT(t.side_px, 11.5);
  auto found_ids = [&](const DetectorOptions& o) { return FoundInRow(o, cam, row, r.image); };
  DetectorOptions without;
  without.small_quad_refine_px = 0;
  const int with_7b = found_ids(DetectorOptions{}), without_7b = found_ids(without);
  RecordProperty("found_with_7b", with_7b);
  RecordProperty("found_without_7b", without_7b);
  EXPECT_GE(with_7b, 5);
  EXPECT_GT(with_7b, without_7b);
}

// At decimate 2 the segments' corners are whole coarse pixels accurate: a 17-22 px marker's as far
// off, relative to its side, as a 9-11 px marker's at full resolution, and its bits are read
// right only after step 7b's fit, which takes quads up to decimate times small_quad_refine_px.
// With that bar at 12 px (24 at decimate 2) every marker is found as with the default; without
// the retry (0) most are not.
TEST(Detector, TwentyPixelMarkersAtDecimateTwoAreReadAfterTheirCornersAreRefined) {
  const MarkerRow row = MakeMarkerRow(40, 12, 0.025, 0.25, [](int i) {
    return Eigen::Vector3d(-0.75 + 0.27 * (i % 6), -0.2 + 0.4 * (i / 6), 0);
  });
  const CameraModel cam = CameraModel::Pinhole(600, 640, 360);
  const Rendered r = Render(Base(cam, row.markers, Look({0.05, -0.3, 2.9}, {0, 0, 0})));
  for (const MarkerTruth& t : r.truth.markers) {
    ASSERT_GT(t.side_px, 16);
    ASSERT_LT(t.side_px, 23);
  }
  auto found_ids = [&](double refine_px) {
    DetectorOptions o;
    o.decimate = 2;
    o.small_quad_refine_px = refine_px;
    return FoundInRow(o, cam, row, r.image);
  };
  const int by_default = found_ids(DetectorOptions{}.small_quad_refine_px);
  const int below_24 = found_ids(12), without = found_ids(0);
  RecordProperty("found", by_default);
  RecordProperty("found_without_7b", without);
  EXPECT_EQ(by_default, 12);
  EXPECT_EQ(below_24, by_default);
  EXPECT_LT(without, by_default - 3);
}

// Markers of 28-31 px at decimate 2, through an ordinary camera (0.7 px of blur, sRGB at 8 bits),
// turned 0-1.5 rad: on the coarse image their squares are 14-15 px with corners blunted by about a
// coarse pixel; all 16 are found at decimate 1 and 2. (The quad search's join
// floor in coarse pixels, detector.cc step 4, was set on a bench speed photograph whose 30 px
// marker's side ended 10 px short of its corner; these renders pass with the plain floor too.)
TEST(Detector, DecimatedSearchFindsThirtyPixelMarkersAtEveryTurn) {
  // Two rows of eight, turned in steps of 0.1 rad (0 to 1.5), through an ordinary camera. A
  // 0.1 m marker's artwork is 0.2 m across (0.28 m along a row when turned 45 degrees): 0.27 m
  // apart, with neighbours turned 0.1 rad apart, no ring lies under a neighbour's stripe, which
  // at 0.2 m apart would cover some (a covered ring is not read at any decimation).
  const MarkerRow row = MakeMarkerRow(60, 16, 0.025, 0.1, [](int i) {
    return Eigen::Vector3d(-0.945 + 0.27 * (i % 8), i < 8 ? -0.2 : 0.2, 0);
  });
  const CameraModel cam = CameraModel::Pinhole(600, 800, 400);
  const Rendered r =
      RenderThroughAnOrdinaryCamera(Base(cam, row.markers, Look({0.05, -0.3, 2.0}, {0, 0, 0})));
  for (const MarkerTruth& t : r.truth.markers) {
    ASSERT_GT(t.side_px, 24);
    ASSERT_LT(t.side_px, 34);
  }
  auto found = [&](int decimate) {
    DetectorOptions o;
    o.decimate = decimate;
    return FoundInRow(o, cam, row, r.image);
  };
  EXPECT_EQ(found(1), 16);
  EXPECT_EQ(found(2), 16);
}

// A background edge in line with a marker's side, beginning just past its ring (a circuit
// board's trace, a panel's edge) with the same polarity (dark above, bright below): the
// collinear merge joins the side to it across the stripe and the ring, and keeps both pieces
// (segments.h, merge_gap_px): without the side alone no segment ends at the square's corner and
// the marker is lost (in 3 of these 8 views at full resolution, 4 at decimate 2, when the pieces
// are not kept; so was a 50 px marker on bench speed's circuit-board photograph at decimate 2).
// The segments are checked too: at full resolution the join across the gap is made in at
// least 3 of the 8 views (or they test nothing), and where it is the side alone is kept.
TEST(Detector, ASideInLineWithABackgroundEdgeStillClosesItsSquare) {
  const MarkerModel a = MarkerModel::Standard(23, 0.1, 0.025);
  const CameraModel cam = CameraModel::Pinhole(500, 320, 240);
  int joined_views = 0;
  for (const double roll : {0.0, 0.08}) {
    Pose pa;
    pa.rvec = Eigen::Vector3d(0, 0, roll);
    const Rendered r = Render(Base(cam, {{a, pa}}, Look({0, -0.0001, 1.0}, {0, 0, 0})));
    ASSERT_EQ(r.truth.markers.size(), 1u);
    const MarkerTruth& t = r.truth.markers[0];
    // The square's lower side, p0 its left end; the edge is drawn leftwards from half a side
    // beyond p0 (the ring's outer edge), `offset` px below the side's line, turned by `turn`.
    int k = 0;
    for (int j = 1; j < 4; ++j)
      if (t.corners[j].pixel.y() + t.corners[(j + 1) % 4].pixel.y() >
          t.corners[k].pixel.y() + t.corners[(k + 1) % 4].pixel.y())
        k = j;
    Eigen::Vector2d p0 = t.corners[k].pixel, p1 = t.corners[(k + 1) % 4].pixel;
    if (p0.x() > p1.x()) std::swap(p0, p1);
    const double side_px = (p1 - p0).norm();
    ASSERT_NEAR(side_px, 50, 2);
    for (const double offset : {1.2, 2.0})
      for (const double turn_deg : {0.0, 2.0}) {
        SCOPED_TRACE("roll " + std::to_string(roll) + " offset " + std::to_string(offset) +
                     " turn " + std::to_string(turn_deg));
        const Eigen::Vector2d d =
            Eigen::Rotation2Dd(turn_deg * M_PI / 180) * (p1 - p0).normalized();
        Eigen::Vector2d n(-d.y(), d.x());
        if (n.y() < 0) n = -n;  // downwards
        cv::Mat image = r.image.clone();
        ASSERT_EQ(image.type(), CV_8UC1);
        for (int y = 0; y < image.rows; ++y)
          for (int x = 0; x < image.cols; ++x) {
            const Eigen::Vector2d v = Eigen::Vector2d(x, y) - (p0 + offset * n);
            const double along = -v.dot(d), across = v.dot(n);
            if (along > 0.5 * side_px && along < 1.9 * side_px && std::abs(across) < 12)
              image.at<uint8_t>(y, x) = across < 0 ? 15 : 200;
          }
        // At full resolution: is there a segment from the side's right corner past the edge's
        // start, and then one from there to the left corner (the side alone)? Ends within 3 px
        // (the corners' blunting).
        std::vector<Segment> segments;
        cv::Mat gx, gy;
        FindSegments(image, SegmentOptions{}, &gx, &gy, &segments);
        bool joined = false, side = false;
        for (const Segment& s : segments)
          for (const auto& [e, f] : {std::pair(s.a, s.b), std::pair(s.b, s.a)})
            if ((e - p1).norm() < 3) {
              joined = joined || (p0 - f).dot(d) > 0.6 * side_px;
              side = side || (f - p0).norm() < 3;
            }
        joined_views += joined;
        if (joined) {
          EXPECT_TRUE(side);
        }
        for (const int decimate : {1, 2}) {
          DetectorOptions o;
          o.decimate = decimate;
          const std::vector<Detection> found = Detector(o, cam, {a}).Detect(image);
          EXPECT_EQ(found.size(), 1u) << "decimate " << decimate;
          if (found.size() != 1) continue;
          EXPECT_EQ(found[0].id, 23);
          for (int c = 0; c < 4; ++c)
            EXPECT_LT((found[0].corners[c] - t.corners[c].pixel).norm(), 0.1) << c;
        }
      }
  }
  EXPECT_GE(joined_views, 3);
}

// Twelve flat 0.1 m markers of 8-10 px through an ordinary camera (sRGB, 0.7 px of blur): each
// bit cell is 1.3-1.7 px, and a plain threshold reads white cells between black ones as black
// (and the other way round). Without a post there is no tip to stand as evidence for a decode
// with more than two or three corrections. Step 7c reads the ring with that interference
// modelled from its own cells: every marker it finds within two corrections.
TEST(Detector, EightPixelRingsBehindABlurAreReadWithTheirInterferenceModelled) {
  const MarkerRow row = MakeMarkerRow(70, 12, 0, 0.11, [](int i) {
    return Eigen::Vector3d(-0.75 + 0.3 * (i % 6), -0.2 + 0.4 * (i / 6), 0);
  });
  const std::vector<std::pair<MarkerModel, Pose>>& markers = row.markers;
  const std::vector<MarkerModel>& models = row.models;
  const CameraModel cam = CameraModel::Pinhole(600, 400, 200);
  const Rendered r =
      RenderThroughAnOrdinaryCamera(Base(cam, markers, Look({0.05, -0.3, 6.6}, {0, 0, 0})));
  for (const MarkerTruth& t : r.truth.markers) {
    ASSERT_GT(t.side_px, 8);
    ASSERT_LT(t.side_px, 10);
  }
  struct Tally {
    int right = 0, wrong = 0, unsupported = 0;  // unsupported: within max_unsupported_corrections
  };
  // Every detection, any of the 32,768 IDs allowed, matched to the marker under it by ID and
  // corners (within a pixel): a marker read as another ID, or a duplicate, is wrong.
  auto count = [&](DetectorOptions o) {
    o.known_ids_only = false;
    Tally t;
    std::vector<bool> seen(r.truth.markers.size(), false);
    for (const Detection& d : Detector(o, cam, models).Detect(r.image)) {
      bool matched = false;
      for (size_t k = 0; k < r.truth.markers.size() && !matched; ++k) {
        const MarkerTruth& m = r.truth.markers[k];
        double worst = 0;
        for (int c = 0; c < 4; ++c)
          worst = std::max(worst, (d.corners[c] - m.corners[c].pixel).norm());
        if (m.id == d.id && worst < 1 && !seen[k]) matched = seen[k] = true;
      }
      if (!matched) {
        ++t.wrong;
        continue;
      }
      ++t.right;
      t.unsupported += d.bit_errors <= o.max_unsupported_corrections;
    }
    return t;
  };
  // 7c against neither 7c nor 7d (7d, after it, would read many of the same rings).
  DetectorOptions off, equalised;
  off.equalize_rings = equalised.deconvolve_rings = off.deconvolve_rings = false;
  const Tally on = count(equalised), plain = count(off);
  RecordProperty("found_equalised", on.right);
  RecordProperty("found_plain", plain.right);
  RecordProperty("within_two_corrections_equalised", on.unsupported);
  RecordProperty("within_two_corrections_plain", plain.unsupported);
  EXPECT_EQ(on.wrong, 0);
  EXPECT_EQ(plain.wrong, 0);
  EXPECT_GE(on.right, plain.right);
  EXPECT_GE(on.right, 9);
  EXPECT_EQ(on.unsupported, on.right);
  EXPECT_GE(on.unsupported, plain.unsupported + 3);
}

// The same kind of row, 8-9 px, through the jpeg_srgb profile (0.7 px of blur, then JPEG at
// quality 85): step 8's corners of such markers are tenths of a pixel off and a cell's centre
// no longer reads its cell, equalised or not (and some give no quad at all). Step 7d reads the
// ring by deconvolution: more markers found, more within two corrections, none wrong (all
// 32,768 IDs allowed), over four exposures of the row.
TEST(Detector, EightPixelRingsThroughJpegAreReadByDeconvolution) {
  const MarkerRow row = MakeMarkerRow(90, 12, 0, 0.13, [](int i) {
    return Eigen::Vector3d(-0.75 + 0.3 * (i % 6), -0.2 + 0.4 * (i / 6), 0);
  });
  const CameraModel cam = CameraModel::Pinhole(600, 400, 200);
  // Several exposures of the row (each its own noise and codec blocks), summed: at 8 px a
  // marker read or not turns on a few grey levels, so one frame's 12 say little.
  std::vector<Rendered> frames;
  for (uint64_t seed : {3, 4, 5, 6}) {
    Scene s = Base(cam, row.markers, Look({0.05, -0.3, 7.2}, {0, 0, 0}));
    s.seed = seed;
    frames.push_back(RenderThroughAnOrdinaryCamera(s, "jpeg_srgb"));
    for (const MarkerTruth& t : frames.back().truth.markers) {
      ASSERT_GT(t.side_px, 7.5);
      ASSERT_LT(t.side_px, 9.2);
    }
  }
  auto count = [&](DetectorOptions o, int* wrong, int* unsupported) {
    o.known_ids_only = false;
    int right = 0;
    *wrong = *unsupported = 0;
    for (const Rendered& r : frames) {
      int found = 0;
      for (const Detection& d : Detector(o, cam, row.models).Detect(r.image)) {
        const bool ok = d.id >= 90 && d.id < 102 &&
                        (d.corners[0] - r.truth.markers[d.id - 90].corners[0].pixel).norm() < 1;
        (ok ? found : *wrong)++;
        *unsupported += ok && d.bit_errors <= o.max_unsupported_corrections;
      }
      right += found;
    }
    return right;
  };
  DetectorOptions off;
  off.deconvolve_rings = false;
  int wrong_on, wrong_off, unsupported_on, unsupported_off;
  const int on = count(DetectorOptions{}, &wrong_on, &unsupported_on);
  const int plain = count(off, &wrong_off, &unsupported_off);
  std::printf(
      "%d exposures of 12 markers: %d found (%d within the unsupported corrections) "
      "deconvolved, %d (%d) without\n",
      static_cast<int>(frames.size()), on, unsupported_on, plain, unsupported_off);
  RecordProperty("found_deconvolved", on);
  RecordProperty("found_without", plain);
  EXPECT_EQ(wrong_on, 0);
  EXPECT_EQ(wrong_off, 0);
  // Measured: 32 (31) of 48 against 10 (7); on the renders of before the fine grid was cast
  // at edges only (render.cc), 34 (31) against 15 (11).
  EXPECT_GE(on, plain + 8);
  EXPECT_GE(unsupported_on, unsupported_off + 8);
}

// Step 4b on the pixels of an ordinary camera: 24 markers of 8.5-8.6 px (srgb8: 0.7 px of blur) and
// of 7.9 px (jpeg_srgb: the same blur and a JPEG codec), turned in steps of 7.5 degrees. Their
// corners round off; where a side's chain bends into the next or splits, three sides are left,
// and the completed quads give markers back (srgb8 20 -> 22, jpeg_srgb 12 -> 13 of 24) with no
// false detection (every ID allowed) and none lost.
TEST(Detector, ThreeSidedSmallSquaresBehindABlurAreCompleted) {
  const MarkerRow row = MakeMarkerRow(200, 24, 0, 7.5 * M_PI / 180, [](int i) {
    return Eigen::Vector3d(-0.9 + 0.36 * (i % 6), -0.45 + 0.3 * (i / 6), 0);
  });
  const CameraModel cam = CameraModel::Pinhole(600, 400, 200);
  for (const auto& [profile, distance, gain] :
       {std::tuple("srgb8", 7.0, 2), std::tuple("jpeg_srgb", 7.6, 1)}) {
    SCOPED_TRACE(profile);
    const Rendered r = RenderThroughAnOrdinaryCamera(
        Base(cam, row.markers, Look({0.05, -0.3, distance}, {0, 0, 0})), profile);
    for (const MarkerTruth& t : r.truth.markers) {
      ASSERT_GT(t.side_px, 7.8);
      ASSERT_LT(t.side_px, 8.7);
    }
    auto found = [&](DetectorOptions o, int* wrong) {
      o.known_ids_only = false;
      std::set<int> right;
      int right_detections = 0;
      *wrong = 0;
      for (const Detection& d : Detector(o, cam, row.models).Detect(r.image)) {
        const bool ok = d.id >= 200 && d.id < 224 &&
                        (d.corners[0] - r.truth.markers[d.id - 200].corners[0].pixel).norm() < 1;
        if (ok) {
          right.insert(d.id);
          ++right_detections;
        } else {
          ++*wrong;
        }
      }
      EXPECT_EQ(right_detections, static_cast<int>(right.size())) << "a marker found twice";
      return right;
    };
    DetectorOptions off;
    off.quads.complete_below_px = 0;
    int wrong_on, wrong_off;
    const std::set<int> on = found(DetectorOptions{}, &wrong_on);
    const std::set<int> plain = found(off, &wrong_off);
    RecordProperty(std::string("found_completed_") + profile, static_cast<int>(on.size()));
    RecordProperty(std::string("found_without_") + profile, static_cast<int>(plain.size()));
    EXPECT_EQ(wrong_on, 0);
    EXPECT_EQ(wrong_off, 0);
    EXPECT_GE(on.size(), plain.size() + gain);
    for (const int id : plain) EXPECT_TRUE(on.count(id)) << id << " is lost with step 4b";
  }
}

// Six 0.1 m markers (post 25 mm, IDs first_id..first_id + 5) tilted by `tilt` about their
// x axis after a roll of roll0 + k roll_step, in a row lifted off the plate (so that the tilted
// decal is not buried in it), seen head-on by a 600 px pinhole from `distance` metres: the
// scene of the small-marker tip tests.
struct TiltedRow {
  CameraModel cam = CameraModel::Pinhole(600, 400, 200);
  std::vector<MarkerModel> models;
  Rendered r;
};
TiltedRow RenderTiltedRow(int first_id, double roll0, double roll_step, double tilt, double x0,
                          double dx, double dy, double distance, bool ordinary_camera = false) {
  TiltedRow row;
  std::vector<std::pair<MarkerModel, Pose>> markers;
  for (int i = 0; i < 6; ++i) {
    const Eigen::Matrix3d R = (Eigen::AngleAxisd(roll0 + roll_step * i, Eigen::Vector3d::UnitZ()) *
                               Eigen::AngleAxisd(tilt, Eigen::Vector3d::UnitX()))
                                  .toRotationMatrix();
    markers.push_back({MarkerModel::Standard(first_id + i, 0.1, 0.025),
                       Pose::FromRotation(R, Eigen::Vector3d(x0 + dx * i, dy * (i % 2), 0.05))});
    row.models.push_back(markers.back().first);
  }
  const Scene scene = Base(row.cam, markers, Look({0.05, -0.3, distance}, {0, 0, 0}));
  row.r = ordinary_camera ? RenderThroughAnOrdinaryCamera(scene) : Render(scene);
  return row;
}

// What the detector made of a TiltedRow: poses, tips, errors above 10 degrees (with which
// markers), ambiguous flags; and the largest true side in pixels.
struct TipTally {
  int posed = 0, with_tip = 0, flipped = 0, ambiguous = 0;
  double max_side_px = 0;
  std::string flips;
};
TipTally DetectTiltedRow(const TiltedRow& row, int first_id, const DetectorOptions& options) {
  TipTally t;
  for (const Detection& d : Detector(options, row.cam, row.models).Detect(row.r.image)) {
    EXPECT_TRUE(d.cam_from_marker.has_value()) << d.id << ": " << d.pose_error;
    if (!d.cam_from_marker) continue;
    const MarkerTruth& truth = row.r.truth.markers[d.id - first_id];
    t.max_side_px = std::max(t.max_side_px, truth.side_px);
    ++t.posed;
    t.with_tip += d.tip.has_value();
    t.ambiguous += d.pose_ambiguous;
    const double err = AngleBetweenDeg(*d.cam_from_marker, truth.cam_from_marker);
    if (err > 10) {
      ++t.flipped;
      t.flips += " marker " + std::to_string(d.id) + (d.tip ? " (tip) " : " (no tip) ") +
                 std::to_string(err) + " deg;";
    }
  }
  return t;
}

// 8 px markers 18 degrees off-axis: the top (0.4 px in radius, 0.6 px from the square's
// centre) sits within 3 px of a corner of the white stripe, which must not make it be taken
// for part of the print; without it the mirror pose (36 degrees off) is as likely.
TEST(Detector, AnEightPixelMarkersTopIsFoundNextToTheStripesCorner) {
  const TiltedRow row = RenderTiltedRow(60, 0.4, 0.9, 0.32, -0.9, 0.36, 0.2, 7.5);
  const TipTally t = DetectTiltedRow(row, 60, DetectorOptions{});
  EXPECT_LT(t.max_side_px, 9);
  EXPECT_GE(t.posed, 4);
  EXPECT_EQ(t.with_tip, t.posed);
  EXPECT_EQ(t.flipped, 0) << t.flips;
}

// The post's white top on a 10 px marker is a third of a pixel across: it still shows in the
// black and picks the planar solution; without it most of these tilted markers come out
// mirrored (20 degrees of tilt: the two solutions are about 40 degrees apart).
TEST(Detector, ASubPixelTipPicksThePoseOfATenPixelMarker) {
  const TiltedRow row = RenderTiltedRow(40, 0, 0.7, 0.35, -0.6, 0.25, 0.12, 6.0);
  const TipTally t = DetectTiltedRow(row, 40, DetectorOptions{});
  EXPECT_LT(t.max_side_px, 10.5);
  EXPECT_GE(t.posed, 5);
  EXPECT_EQ(t.with_tip, t.posed);
  EXPECT_EQ(t.flipped, 0) << t.flips;
  // The same markers with the tip left to tops of half a pixel or more: no tip, ambiguous.
  DetectorOptions no_small_tips;
  no_small_tips.pose.tip_min_radius_px = 0.5;
  const TipTally without = DetectTiltedRow(row, 40, no_small_tips);
  EXPECT_EQ(without.with_tip, 0);
  EXPECT_GE(without.ambiguous, 5);
  EXPECT_GE(without.flipped, 2) << "the scene no longer shows what the tip is for";
  RecordProperty("flipped_without_small_tips", without.flipped);  // 5 of 6 when written
}

// The same 10 px markers through an ordinary camera (sRGB, 0.7 px of blur): the blur lowers the
// top's peak below the sharp top's test and the bits' black is raised, but its light is
// there (FindTip's sum over its 3 x 3), and it still picks the planar solution.
TEST(Detector, ABlurredSubPixelTipPicksThePoseOfATenPixelMarker) {
  const TiltedRow row = RenderTiltedRow(40, 0, 0.7, 0.35, -0.6, 0.25, 0.12, 6.0, true);
  const TipTally t = DetectTiltedRow(row, 40, DetectorOptions{});
  EXPECT_LT(t.max_side_px, 10.5);
  EXPECT_GE(t.posed, 5);
  EXPECT_GE(t.with_tip, t.posed - 1);
  EXPECT_EQ(t.flipped, 0) << t.flips;
  RecordProperty("posed", t.posed);
  RecordProperty("with_tip", t.with_tip);
}

// Six markers of 13-20 px seen 30 degrees off-axis through an ordinary camera: behind the blur
// the segments' square is smaller than the marker, outer bit cells are read toward the stripe
// and flip (4 on one of these), and a decode with that many corrections needs evidence the
// pose cannot always give. Step 7b reads such a square again on refined corners: every marker
// is found, with at most the corrections a decode may have on its own.
TEST(Detector, BlurredSmallMarkersWithManyCorrectionsAreReadAgainOnRefinedCorners) {
  const MarkerRow row = MakeMarkerRow(50, 6, 0.025, 0.13, [](int i) {
    return Eigen::Vector3d(-0.75 + 0.3 * i, 0.15 * (i % 2), 0);
  });
  const std::vector<std::pair<MarkerModel, Pose>>& markers = row.markers;
  const std::vector<MarkerModel>& models = row.models;
  const CameraModel cam = CameraModel::Pinhole(600, 400, 200);
  const Rendered r =
      RenderThroughAnOrdinaryCamera(Base(cam, markers, Look({1.6, -0.4, 2.9}, {0, 0, 0})));
  for (const MarkerTruth& t : r.truth.markers) ASSERT_LT(t.side_px, 21);
  int found = 0, wrong = 0, most_corrections = 0;
  for (const Detection& d : Detector(DetectorOptions{}, cam, models).Detect(r.image)) {
    (d.id >= 50 && d.id < 56 ? found : wrong)++;
    most_corrections = std::max(most_corrections, d.bit_errors);
  }
  EXPECT_EQ(wrong, 0);
  EXPECT_EQ(found, 6);
  EXPECT_LE(most_corrections, DetectorOptions{}.max_unsupported_corrections);
}

TEST(Detector, WithoutCameraOrModelsGivesIdsAndCornersOnly) {
  MarkerModel a = MarkerModel::Standard(321, 0.1, 0.025);
  const Rendered r = Render(
      Base(CameraModel::Pinhole(600, 320, 240), {{a, Pose{}}}, Look({0, -0.1, 0.6}, {0, 0, 0})));
  const Detector det(DetectorOptions{}, CameraModel{}, {});
  const std::vector<Detection> found = det.Detect(r.image);
  ASSERT_EQ(found.size(), 1u);
  EXPECT_EQ(found[0].id, 321);
  EXPECT_FALSE(found[0].cam_from_marker.has_value());
  for (int k = 0; k < 4; ++k)
    EXPECT_LT((found[0].corners[k] - r.truth.markers[0].corners[k].pixel).norm(), 0.15)
        << k << " found " << found[0].corners[k].transpose() << " truth "
        << r.truth.markers[0].corners[k].pixel.transpose();
}

TEST(Detector, OddImagesGiveNoDetectionsAndNoCrash) {
  const Detector det(DetectorOptions{}, CameraModel{}, {});
  EXPECT_TRUE(det.Detect(cv::Mat()).empty());
  EXPECT_TRUE(det.Detect(cv::Mat(1, 1, CV_8U, cv::Scalar(7))).empty());
  EXPECT_TRUE(det.Detect(cv::Mat(3, 1000, CV_8U, cv::Scalar(7))).empty());
  EXPECT_TRUE(det.Detect(cv::Mat(100, 100, CV_16U, cv::Scalar(0))).empty());
  cv::Mat noise(240, 320, CV_8UC3);
  cv::randu(noise, 0, 255);
  EXPECT_TRUE(det.Detect(noise).empty());
}

// One marker (ID 55, 0.1 m) 0.6 m away, rendered as a 16-bit 320 x 240 frame.
Rendered SixteenBitFrame() {
  MarkerModel a = MarkerModel::Standard(55, 0.1, 0.025);
  Scene s =
      Base(CameraModel::Pinhole(600, 320, 240), {{a, Pose{}}}, Look({0, -0.1, 0.6}, {0, 0, 0}));
  s.sensor.bits = 16;
  return Render(s);
}

TEST(Detector, SixteenBitAndColourImagesWork) {
  const Rendered r = SixteenBitFrame();
  const Detector det(DetectorOptions{}, CameraModel{}, {});
  ASSERT_EQ(det.Detect(r.image).size(), 1u);
  cv::Mat colour;
  cv::Mat eight;
  r.image.convertTo(eight, CV_8U, 1.0 / 256);
  cv::cvtColor(eight, colour, cv::COLOR_GRAY2BGR);
  ASSERT_EQ(det.Detect(colour).size(), 1u);
}

// A 16-bit frame is decimated after its variance-stabilising rescale to 8 bits: the coarse
// search finds the marker with the same corners. An image under 16 coarse pixels on a side is
// searched whole: at decimate 4 a 64 x 60 crop (16 x 15 coarse) gives the same segments and
// corners as decimate 1, where its 24 px square, 6 coarse pixels, would not be found coarse.
TEST(Detector, SixteenBitFramesAreDecimatedAndTooSmallImagesAreNot) {
  const Rendered r = SixteenBitFrame();
  ASSERT_EQ(r.image.depth(), CV_16U);
  auto detect = [](const cv::Mat& image, int decimate, DetectionStats* stats) {
    DetectorOptions o;
    o.decimate = decimate;
    return Detector(o, CameraModel{}, {}).Detect(image, stats);
  };
  auto same_corners = [](const std::vector<Detection>& x, const std::vector<Detection>& y) {
    ASSERT_EQ(x.size(), 1u);
    ASSERT_EQ(y.size(), 1u);
    EXPECT_EQ(x[0].id, y[0].id);
    for (int k = 0; k < 4; ++k) EXPECT_LT((x[0].corners[k] - y[0].corners[k]).norm(), 0.01);
  };
  DetectionStats full, coarse;
  const std::vector<Detection> at1 = detect(r.image, 1, &full), at2 = detect(r.image, 2, &coarse);
  same_corners(at1, at2);
  EXPECT_LT(coarse.segments, full.segments);

  const MarkerModel a = MarkerModel::Standard(56, 0.1, 0.025);
  Pose p;
  p.rvec = Eigen::Vector3d(0, 0, 0.3);
  const Rendered small =
      Render(Base(CameraModel::Pinhole(600, 64, 60), {{a, p}}, Look({0, -0.1, 2.5}, {0, 0, 0})));
  ASSERT_EQ(small.truth.markers.size(), 1u);
  ASSERT_GT(small.truth.markers[0].side_px, 20);
  ASSERT_LT(small.truth.markers[0].side_px, 28);
  DetectionStats whole, at4_stats;
  const std::vector<Detection> small1 = detect(small.image, 1, &whole),
                               small4 = detect(small.image, 4, &at4_stats);
  same_corners(small1, small4);
  EXPECT_EQ(at4_stats.segments, whole.segments);
}

const NoiseModel kNoNoise;  // invalid (bins 0)

// A noise model given with a 16-bit frame (a raw frame's, from its stored values) is the one the
// frame's edges are searched with, in place of the estimate from the image; an invalid one is
// ignored.
TEST(Detector, AGivenNoiseModelReplacesTheEstimate) {
  const Rendered r = SixteenBitFrame();
  const Detector det(DetectorOptions{}, CameraModel{}, {});
  const auto forever = std::chrono::steady_clock::time_point::max();
  std::vector<Detection> found;
  DetectionStats estimated, given;
  det.Detect(r.image, &estimated, forever, &found);
  ASSERT_EQ(found.size(), 1u);
  ASSERT_TRUE(estimated.noise.valid());
  NoiseModel noise;
  noise.read_sigma = 2 * estimated.noise.read_sigma + 10;
  noise.shot_gain = 1.5 * estimated.noise.shot_gain;
  noise.bins = 3;
  det.Detect(r.image, &given, forever, &found, &noise);
  EXPECT_EQ(given.noise.read_sigma, noise.read_sigma);
  EXPECT_EQ(given.noise.shot_gain, noise.shot_gain);
  EXPECT_EQ(found.size(), 1u);
  DetectionStats ignored;
  det.Detect(r.image, &ignored, forever, &found, &kNoNoise);
  EXPECT_EQ(ignored.noise.read_sigma, estimated.noise.read_sigma);
}

// Central differences of `residuals(R, t)` (N values, already whitened) with respect to a
// left rotation of `at` (camera axes, radians) and its translation: the Jacobian RefinePose's
// covariance (J^T J)^-1 must agree with.
template <int N, typename F>
Eigen::Matrix<double, N, 6> NumericPoseJacobian(const Pose& at, F residuals) {
  Eigen::Matrix<double, N, 6> J;
  const double h = 1e-7;
  for (int k = 0; k < 6; ++k) {
    Eigen::Matrix<double, 6, 1> dlt = Eigen::Matrix<double, 6, 1>::Zero();
    dlt(k) = h;
    auto perturbed = [&](double sgn) {
      const Eigen::Vector3d w = sgn * dlt.head<3>();
      const Eigen::Matrix3d R =
          (w.norm() > 0 ? Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix()
                        : Eigen::Matrix3d::Identity()) *
          at.Rotation();
      return Eigen::Matrix<double, N, 1>(
          residuals(R, Eigen::Vector3d(at.tvec + sgn * dlt.tail<3>())));
    };
    J.col(k) = (perturbed(1) - perturbed(-1)) / (2 * h);
  }
  return J;
}

// The projections of X[0, n) at (R, t), divided by sigma, into r[0, 2n): the point part of a
// whitened residual (the observed pixels are constant and cancel in differences).
void ScaledProjections(const CameraModel& cam, const Eigen::Matrix3d& R, const Eigen::Vector3d& t,
                       const std::vector<Eigen::Vector3d>& X, int n, double sigma,
                       Eigen::Ref<Eigen::VectorXd> r) {
  for (int i = 0; i < n; ++i) {
    Eigen::Vector2d q;
    cam.Project(R * X[i] + t, &q);
    r.segment<2>(2 * i) = q / sigma;
  }
}

// The RefinePose tests' marker pose: 0.8 m away, turned about 35 degrees.
Pose RefinePoseTruth() {
  Pose truth;
  truth.rvec = Eigen::Vector3d(0.3, -0.5, 0.2);
  truth.tvec = Eigen::Vector3d(0.05, -0.02, 0.8);
  return truth;
}

// The four corners and the post tip of a 0.1 m marker with a 30 mm post (marker frame, m).
std::vector<Eigen::Vector3d> RefinePoseMarkerPoints() {
  const MarkerModel m = MarkerModel::Standard(1, 0.1, 0.03);
  const auto corners = m.Corners();
  std::vector<Eigen::Vector3d> X(corners.begin(), corners.end());
  X.push_back(*m.PostTip());
  return X;
}

TEST(RefinePose, JacobianMatchesFiniteDifferencesAndRecoversThePose) {
  const CameraModel cam = Distorted();
  const Pose truth = RefinePoseTruth();
  const std::vector<Eigen::Vector3d> X = RefinePoseMarkerPoints();
  std::vector<Eigen::Vector2d> px;
  for (const auto& x : X) {
    Eigen::Vector2d q;
    ASSERT_TRUE(cam.Project(truth * x, &q));
    px.push_back(q);
  }
  Pose start = truth;
  start.rvec += Eigen::Vector3d(0.05, -0.03, 0.02);
  start.tvec += Eigen::Vector3d(0.01, 0.01, -0.05);
  PoseCovariance cov;
  double rms;
  ASSERT_TRUE(RefinePose(cam, X, px, std::vector<double>(5, 0.1), &start, &cov, &rms));
  EXPECT_LT((start.tvec - truth.tvec).norm(), 1e-9);
  EXPECT_LT(AngleBetweenDeg(start, truth), 1e-7);
  EXPECT_LT(rms, 1e-6);
  // The covariance is (J^T W J)^-1: compare with a finite-difference Jacobian.
  const Eigen::Matrix<double, 10, 6> J =
      NumericPoseJacobian<10>(truth, [&](const Eigen::Matrix3d& R, const Eigen::Vector3d& t) {
        Eigen::VectorXd r(10);
        ScaledProjections(cam, R, t, X, 5, 0.1, r);
        return r;
      });
  const PoseCovariance numeric = (J.transpose() * J).inverse();
  EXPECT_LT((numeric - cov).norm() / cov.norm(), 1e-4);
}

// A camera whose intrinsics are off by draws from its calibration's covariance: a single
// marker's fit (corners and tip) with CalibrationCovariance added has NEES near 6; without
// it the fit is overconfident.
TEST(RefinePose, CalibrationCovarianceMatchesMonteCarlo) {
  const CameraModel truth_camera = Distorted();
  const Pose truth = RefinePoseTruth();
  const std::vector<Eigen::Vector3d> X = RefinePoseMarkerPoints();
  const std::vector<double> sigma(5, 0.1);
  const int n = static_cast<int>(truth_camera.intrinsics().size());
  Eigen::VectorXd s = Eigen::VectorXd::Constant(n, 1e-3);
  s.head<4>() << 2.0, 2.0, 1.5, 1.5;
  const Eigen::MatrixXd L = s.asDiagonal().toDenseMatrix();
  std::mt19937_64 rng(5);
  std::normal_distribution<double> g(0, 1);
  const int trials = 1000;
  double nees_with = 0, nees_without = 0;
  for (int i = 0; i < trials; ++i) {
    std::vector<double> intrinsics = truth_camera.intrinsics();
    for (int k = 0; k < n; ++k) intrinsics[k] += s[k] * g(rng);
    CameraModel cam;
    ASSERT_TRUE(CameraModel::Create(truth_camera.lensmodel(), intrinsics, truth_camera.width(),
                                    truth_camera.height(), &cam)
                    .ok());
    ASSERT_TRUE(cam.set_intrinsics_covariance_factor(L).ok());
    std::vector<Eigen::Vector2d> px;
    for (const auto& x : X) {
      Eigen::Vector2d q;
      ASSERT_TRUE(truth_camera.Project(truth * x, &q));
      px.push_back(q + 0.1 * DrawVector2(g, rng));
    }
    Pose pose = truth;
    PoseCovariance cov, calibration;
    double rms;
    ASSERT_TRUE(RefinePose(cam, X, px, sigma, &pose, &cov, &rms));
    ASSERT_TRUE(CalibrationCovariance(cam, pose, X, sigma, &calibration));
    if (i == 0) {
      // The corners whitened together by a diagonal whitener: the same.
      const Eigen::Matrix<double, 8, 8> W = Eigen::Matrix<double, 8, 8>::Identity() / 0.1;
      PoseCovariance joint;
      ASSERT_TRUE(CalibrationCovariance(cam, pose, X, sigma, &joint, &W));
      EXPECT_LT((joint - calibration).norm(), 1e-9 * calibration.norm());
      // By two whiteners of one correlated C (L^-1 and Q L^-1, Q orthogonal): the same, and
      // not what L^-T gives.
      Eigen::Matrix<double, 8, 8> M, N;
      for (int k = 0; k < 64; ++k) M(k) = g(rng), N(k) = g(rng);
      const Eigen::Matrix<double, 8, 8> C =
          0.01 * (M * M.transpose() / 8 + Eigen::Matrix<double, 8, 8>::Identity());
      const Eigen::Matrix<double, 8, 8> L_inv =
          Eigen::Matrix<double, 8, 8>(C.llt().matrixL()).inverse();
      const Eigen::Matrix<double, 8, 8> Q_L_inv =
          Eigen::HouseholderQR<Eigen::Matrix<double, 8, 8>>(N).householderQ() * L_inv;
      const Eigen::Matrix<double, 8, 8> L_inv_t = L_inv.transpose();
      PoseCovariance by_l, by_ql, by_lt;
      ASSERT_TRUE(CalibrationCovariance(cam, pose, X, sigma, &by_l, &L_inv));
      ASSERT_TRUE(CalibrationCovariance(cam, pose, X, sigma, &by_ql, &Q_L_inv));
      ASSERT_TRUE(CalibrationCovariance(cam, pose, X, sigma, &by_lt, &L_inv_t));
      EXPECT_LT((by_l - by_ql).norm(), 1e-9 * by_l.norm());
      EXPECT_GT((by_l - by_lt).norm(), 1e-3 * by_l.norm());
    }
    Eigen::Matrix<double, 6, 1> e;
    e << Log(truth.Rotation() * pose.Rotation().transpose()), truth.tvec - pose.tvec;
    nees_with += e.dot((cov + calibration).ldlt().solve(e));
    nees_without += e.dot(cov.ldlt().solve(e));
  }
  EXPECT_NEAR(nees_with / trials, 6.0, 0.4);
  EXPECT_GT(nees_without / trials, 12.0);
  PoseCovariance unused;
  EXPECT_FALSE(CalibrationCovariance(truth_camera, truth, X, sigma, &unused));  // no factor
}

// With edge points (step 10c) the residual is the distance across each edge's image: the fit
// must land on the truth from a start half a degree off, and its covariance must be
// (J^T W J)^-1 of that residual (finite differences at the truth).
TEST(RefinePose, EdgePointsJacobianMatchesFiniteDifferences) {
  const CameraModel cam = Distorted();
  const Pose truth = RefinePoseTruth();
  const MarkerModel m = MarkerModel::Standard(1, 0.1, 0.03);
  const auto corners = m.Corners();
  const std::vector<Eigen::Vector3d> X(corners.begin(), corners.end());
  std::vector<Eigen::Vector2d> px;
  for (const auto& x : X) {
    Eigen::Vector2d q;
    ASSERT_TRUE(cam.Project(truth * x, &q));
    px.push_back(q);
  }
  const double h = 5 * m.cell_size;  // the stripe's outer half-side
  std::vector<EdgeObservation> edges;
  for (int side = 0; side < 4; ++side)
    for (double f : {-0.8, -0.4, 0.0, 0.4, 0.8}) {
      EdgeObservation e;
      const bool horizontal = side % 2 == 0;
      const double sign = side < 2 ? 1 : -1;
      e.point =
          horizontal ? Eigen::Vector3d(f * h, sign * h, 0) : Eigen::Vector3d(sign * h, f * h, 0);
      e.direction = horizontal ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
      ASSERT_TRUE(cam.Project(truth * e.point, &e.pixel));
      e.sigma_px = 0.05;
      edges.push_back(e);
    }
  Pose start = truth;
  start.rvec += Eigen::Vector3d(0.01, -0.01, 0.005);
  start.tvec += Eigen::Vector3d(0.003, -0.002, 0.005);
  Pose fit = start;
  PoseCovariance cov;
  double rms;
  const std::vector<double> sigmas(4, 0.1);
  ASSERT_TRUE(RefinePose(cam, X, px, sigmas, &fit, &cov, &rms, &edges));
  EXPECT_LT((fit.tvec - truth.tvec).norm(), 1e-9);
  EXPECT_LT(AngleBetweenDeg(fit, truth), 1e-7);
  // Residuals at the truth perturbed: corners / sigma, then edges along their normals.
  auto normal_at = [&](const EdgeObservation& e) {
    Eigen::Vector2d a, b;
    cam.Project(truth * e.point, &a);
    cam.Project(truth * (e.point + 1e-4 * e.direction), &b);
    const Eigen::Vector2d u = (b - a).normalized();
    return Eigen::Vector2d(-u.y(), u.x());
  };
  const Eigen::Matrix<double, 28, 6> J =
      NumericPoseJacobian<28>(truth, [&](const Eigen::Matrix3d& R, const Eigen::Vector3d& t) {
        Eigen::VectorXd r(28);
        ScaledProjections(cam, R, t, X, 4, 0.1, r);
        for (int i = 0; i < 20; ++i) {
          Eigen::Vector2d q;
          cam.Project(R * edges[i].point + t, &q);
          r(8 + i) = normal_at(edges[i]).dot(q - edges[i].pixel) / edges[i].sigma_px;
        }
        return r;
      });
  const PoseCovariance numeric = (J.transpose() * J).inverse();
  EXPECT_LT((numeric - cov).norm() / cov.norm(), 1e-4);
  // And the edges carry information: the covariance is smaller than from the corners alone.
  Pose corners_only = start;
  PoseCovariance cov_corners;
  ASSERT_TRUE(RefinePose(cam, X, px, sigmas, &corners_only, &cov_corners, &rms));
  EXPECT_LT(cov.trace(), 0.5 * cov_corners.trace());
}

}  // namespace
}  // namespace svms
