// The survey end to end on rendered images (a survey of a small rendered scene recovers the
// truth within its reported sigmas): the simulator renders a few views of a box carrying five
// markers (one a concave well), the detector measures them, RunSurvey surveys them, and every
// marker comes out within a few of its own sigmas of the truth.
// Unlike survey_test.cc, the corners and tips here carry the renderer's and the detector's real
// errors, not Gaussian noise drawn to match the assumed sigmas.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <map>
#include <memory>

#include "svms/bundle/survey.h"
#include "svms/datasets/datasets.h"
#include "svms/detect/detector.h"
#include "svms/sim/render.h"

namespace svms {
namespace {

using Vec3 = Eigen::Vector3d;

struct RenderedSurvey {
  Layout truth;  // object_from_marker, object frame = the box's (= world)
  std::vector<MarkerModel> models;
  CameraModel camera = DistortedCamera();
  std::vector<SurveyImage> images;
};

// Five markers on three faces of a 0.8 m box (front z+, right x+, top y+), twelve views from
// 1.6 to 2.1 m spread over the octant in front of the three faces, so that each marker is
// seen head-on and obliquely and the faces are seen together (a connected view graph).
// Rendered with the datasets' distorted camera (1024 x 1024, OPENCV8), sun and shot noise,
// 9 rays per pixel; then detected with the default DetectorOptions.
RenderedSurvey RenderAndDetect() {
  RenderedSurvey out;
  const Vec3 half(0.4, 0.4, 0.4);
  struct Place {
    MarkerModel m;
    int axis, sign;
    double u, v, spin;
  };
  const std::vector<Place> places = {
      {MarkerModel::Standard(20, 0.15, 0.03), 2, +1, -0.17, 0.15, 0},
      {MarkerModel::Standard(21, 0.12, 0.025), 2, +1, 0.17, 0.15, 0.4},
      {MarkerModel::Standard(22, 0.15, -0.03), 2, +1, 0.0, -0.17, 0},  // concave well
      {MarkerModel::Standard(23, 0.15, 0.03), 0, +1, 0.05, 0.1, 0.3},
      {MarkerModel::Standard(24, 0.12, 0.025), 1, +1, 0.1, 0.0, -0.2},
  };
  Scene s;
  s.seed = 5;
  s.camera = out.camera;
  s.sensor.exposure = 15000;
  s.sensor.full_well = 18000;
  s.sensor.rays_per_pixel = 9;
  s.light.sun = Sun{Vec3(0.5, 0.6, 1).normalized(), 1.0, 0.53};
  s.light.ambient = 0.1;
  s.background.kind = Background::Kind::kEarth;
  s.background.brightness = 0.5;
  SceneObject box;
  box.name = "box";
  box.shape = SceneObject::Shape::kBox;
  box.size = 2 * half;
  box.material.reflectance = 0.3;
  for (const Place& p : places) {
    SceneMarker sm;
    sm.model = p.m;
    sm.object_from_marker = OnBoxFace(half, p.axis, p.sign, p.u, p.v, p.spin);
    box.markers.push_back(sm);
    out.truth.markers.push_back(
        LayoutEntry{p.m, sm.object_from_marker, std::nullopt, std::nullopt});
    out.models.push_back(p.m);
  }
  s.objects.push_back(box);
  const std::vector<Vec3> directions = {
      {0.2, 0.2, 1}, {0.7, 0.2, 1},  {0.2, 0.7, 1},  {0.8, 0.8, 1}, {1, 0.3, 0.7}, {0.3, 1, 0.7},
      {1, 0.9, 0.8}, {-0.2, 0.3, 1}, {0.3, -0.2, 1}, {1, 0.5, 1.1}, {0.5, 1, 1.1}, {0.6, 0.6, 1}};
  for (size_t i = 0; i < directions.size(); ++i) {
    const double D = 1.6 + 0.5 * static_cast<double>(i % 4) / 3;
    const Vec3 eye = D * directions[i].normalized();
    const Vec3 target(0.03 * (i % 3) - 0.03, 0.02 * (i % 2), 0.1);
    s.views.push_back(View{"view" + std::to_string(i), LookAt(eye, target, Vec3(0, 1, 0))});
  }
  std::unique_ptr<Renderer> r;
  const Status st = Renderer::Create(s, &r);
  EXPECT_TRUE(st) << st.message();
  if (!st) return out;
  const Detector detector(DetectorOptions{}, out.camera, out.models);
  for (size_t i = 0; i < s.views.size(); ++i) {
    const cv::Mat img = r->Expose(r->RenderRadiance(static_cast<int>(i)), static_cast<int>(i));
    out.images.push_back(SurveyImage{s.views[i].name, detector.Detect(img)});
  }
  return out;
}

// The sigma of a zero-mean vector with covariance C along the direction of `e` (e != 0).
double SigmaAlong(const Eigen::Matrix3d& C, const Vec3& e) {
  const Vec3 u = e.normalized();
  return std::sqrt(std::max(0.0, u.dot(C * u)));
}

TEST(SurveyRendered, SmallRenderedSceneRecoversTheTruthWithinItsSigmas) {
  const auto t0 = std::chrono::steady_clock::now();
  const RenderedSurvey rs = RenderAndDetect();
  ASSERT_EQ(rs.images.size(), 12u);
  std::map<int, int> seen;
  for (const SurveyImage& im : rs.images)
    for (const Detection& d : im.detections) {
      ++seen[d.id];
      EXPECT_GE(d.id, 20) << im.name << ": a false positive";
      EXPECT_LE(d.id, 24) << im.name << ": a false positive";
    }
  for (const LayoutEntry& e : rs.truth.markers)
    EXPECT_GE(seen[e.marker.id], 3) << "marker " << e.marker.id << " seen too rarely";

  const int ref = 20;
  SurveyConfig config;
  config.reference_id = ref;
  SurveyResult r;
  const Status s = RunSurvey(rs.images, rs.models, rs.camera, SurveyOptions{}, config, &r);
  ASSERT_TRUE(s) << s.message();
  EXPECT_TRUE(r.summary.covariance_ok);
  EXPECT_EQ(r.summary.markers_surveyed, 5);
  EXPECT_LT(r.summary.rms_px, 0.3) << "rendered corners are good to a small fraction of a pixel";
  std::printf(
      "survey: %d images, %d detections, RMS %.3f px, variance factor %.3f, %zu points "
      "rejected\n",
      r.summary.images_used, r.summary.detections_used, r.summary.rms_px, r.summary.variance_factor,
      r.summary.rejected.size());

  // The gauge as the survey fixes it: the reference marker's frame. The truth in that frame:
  const Pose ref_from_object = rs.truth.Find(ref)->object_from_marker.Inverse();
  constexpr double kPositionFloor = 5e-5;                   // metres
  constexpr double kOrientationFloor = 0.005 * M_PI / 180;  // radians
  constexpr double kPostFloor = 5e-5;                       // metres
  int checked = 0;
  for (const LayoutEntry& e : r.layout.markers) {
    if (e.marker.id == ref) continue;
    const LayoutEntry* t = rs.truth.Find(e.marker.id);
    ASSERT_NE(t, nullptr);
    ASSERT_TRUE(e.covariance.has_value()) << e.marker.id;
    const Pose truth = ref_from_object * t->object_from_marker;
    const Eigen::AngleAxisd aa(e.object_from_marker.Rotation() * truth.Rotation().transpose());
    const Vec3 rot_err = aa.axis() * aa.angle();  // left, object axes, as the covariance
    const Vec3 pos_err = e.object_from_marker.tvec - truth.tvec;
    const Eigen::Matrix3d C_rot = e.covariance->topLeftCorner<3, 3>();
    const Eigen::Matrix3d C_pos = e.covariance->bottomRightCorner<3, 3>();
    // The sigmas are what this survey gives, within 30 % either way: a covariance 2x off (in
    // variance, 1.41x in sigma) fails. Measured (mm, deg): 21: 0.0548, 0.0158; 22: 0.0580,
    // 0.0145; 23: 0.1134, 0.0171; 24: 0.1310, 0.0251.
    const std::map<int, std::pair<double, double>> measured = {{21, {0.0548, 0.0158}},
                                                               {22, {0.0580, 0.0145}},
                                                               {23, {0.1134, 0.0171}},
                                                               {24, {0.1310, 0.0251}}};
    ASSERT_TRUE(measured.count(e.marker.id)) << e.marker.id;
    const auto [sigma_mm, sigma_deg] = measured.at(e.marker.id);
    EXPECT_GT(1e3 * std::sqrt(C_pos.trace()), sigma_mm / 1.3) << "marker " << e.marker.id;
    EXPECT_LT(1e3 * std::sqrt(C_pos.trace()), sigma_mm * 1.3) << "marker " << e.marker.id;
    EXPECT_GT(std::sqrt(C_rot.trace()) * 180 / M_PI, sigma_deg / 1.3) << "marker " << e.marker.id;
    EXPECT_LT(std::sqrt(C_rot.trace()) * 180 / M_PI, sigma_deg * 1.3) << "marker " << e.marker.id;
    EXPECT_LT(pos_err.norm(), 4 * SigmaAlong(C_pos, pos_err) + kPositionFloor)
        << "marker " << e.marker.id << ": position error " << 1000 * pos_err.transpose()
        << " mm, sigma along it " << 1000 * SigmaAlong(C_pos, pos_err) << " mm";
    EXPECT_LT(rot_err.norm(), 4 * SigmaAlong(C_rot, rot_err) + kOrientationFloor)
        << "marker " << e.marker.id << ": orientation error " << aa.angle() * 180 / M_PI
        << " deg, sigma along it " << SigmaAlong(C_rot, rot_err) * 180 / M_PI << " deg";
    std::printf(
        "marker %d: %d detections, position error %.4f mm (sigma along it %.4f mm), "
        "orientation error %.4f deg (sigma along it %.4f deg)\n",
        e.marker.id, seen[e.marker.id], 1000 * pos_err.norm(), 1000 * SigmaAlong(C_pos, pos_err),
        aa.angle() * 180 / M_PI, SigmaAlong(C_rot, rot_err) * 180 / M_PI);
    if (e.marker.post && !e.marker.post->concave() && e.post_height_sigma) {
      const double h_err = e.marker.post->height - t->marker.post->height;
      EXPECT_LT(std::abs(h_err), 4 * *e.post_height_sigma + kPostFloor)
          << "marker " << e.marker.id << ": post height error " << 1000 * h_err << " mm, sigma "
          << 1000 * *e.post_height_sigma << " mm";
    }
    ++checked;
  }
  EXPECT_EQ(checked, 4);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  RecordProperty("seconds", std::to_string(seconds));
}

}  // namespace
}  // namespace svms
