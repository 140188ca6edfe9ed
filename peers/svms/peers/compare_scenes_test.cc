// The comparison's own scenes: where the size sweep's smallest markers are posed wrong, the
// detector says so.
#include "svms/peers/compare_scenes.h"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <opencv2/imgcodecs.hpp>

#include "svms/detect/detector.h"
#include "svms/detect/ippe.h"
#include "svms/fusion/object_pose.h"
#include "svms/geometry/pose.h"
#include "svms/sim/render.h"
#include "svms/sim/truth.h"

namespace svms {
namespace {

// The 3-dof NEES of `estimate`'s orientation (`covariance`'s rotation block, camera axes).
double RotationNees(const Pose& truth, const Pose& estimate, const PoseCovariance& covariance) {
  const Eigen::Vector3d w = Log(estimate.Rotation() * truth.Rotation().transpose());
  return w.dot(covariance.topLeftCorner<3, 3>().ldlt().solve(w));
}

// Each view of the size sweep at `px` ("008"): the orientation error (degrees, NaN where not
// posed), the ambiguity flag, the rotation NEES, and the error's part along the way to the
// pose's planar twin in units of the covariance's sigma that way.
struct Posed {
  std::string view;
  double error_deg = NAN, nees = NAN, twin_way_sigmas = NAN;
  double alternative_error_deg = NAN;  // of the alternative pose, where flagged
  bool ambiguous = false;
};
std::vector<Posed> PoseSizeViews(const std::string& px) {
  std::vector<Posed> out;
  for (const CompareSweep& sw : MakeCompareSweeps(CompareOptions{})) {
    if (sw.name != "size") continue;
    std::unique_ptr<Renderer> r;
    EXPECT_TRUE(Renderer::Create(sw.scene, &r));
    if (!r) return out;
    std::vector<MarkerModel> models;
    for (const SceneObject& ob : sw.scene.objects)
      for (const SceneMarker& m : ob.markers) models.push_back(m.model);
    const Detector det(DetectorOptions{}, sw.scene.camera, models);
    for (size_t v = 0; v < sw.scene.views.size(); ++v) {
      if (sw.scene.views[v].name.rfind("size_" + px + "px_", 0) != 0) continue;
      const cv::Mat img = r->Expose(r->RenderRadiance(static_cast<int>(v)), static_cast<int>(v));
      const ViewTruth truth = ComputeTruth(*r, static_cast<int>(v));
      Posed p{sw.scene.views[v].name};
      for (const Detection& d : det.Detect(img)) {
        if (d.id != truth.markers[0].id || !d.cam_from_marker) continue;
        const Pose& t = truth.markers[0].cam_from_marker;
        p.error_deg = AngleBetweenDeg(*d.cam_from_marker, t);
        p.nees = RotationNees(t, *d.cam_from_marker, d.covariance);
        const Eigen::AngleAxisd e(d.cam_from_marker->Rotation() * t.Rotation().transpose());
        const Eigen::AngleAxisd tw(PlanarTwin(*d.cam_from_marker).Rotation() *
                                   d.cam_from_marker->Rotation().transpose());
        const Eigen::Vector3d way = tw.axis();
        p.twin_way_sigmas = std::abs((e.angle() * e.axis()).dot(way)) /
                            std::sqrt(way.dot(d.covariance.topLeftCorner<3, 3>() * way));
        p.ambiguous = d.pose_ambiguous;
        if (d.alternative_pose) p.alternative_error_deg = AngleBetweenDeg(*d.alternative_pose, t);
      }
      out.push_back(p);
    }
  }
  return out;
}

// The post's height follows CompareOptions in every sweep's SVMS marker (svms bench compare
// --post-height).
TEST(CompareScenes, ThePostIsAsTallAsAsked) {
  CompareOptions o;
  o.quick = true;
  o.post_height_fraction = 0.4;
  int markers = 0;
  for (const CompareSweep& sw : MakeCompareSweeps(o))
    for (const SceneObject& ob : sw.scene.objects)
      for (const SceneMarker& m : ob.markers) {
        ASSERT_TRUE(m.model.post.has_value()) << sw.name;
        EXPECT_DOUBLE_EQ(m.model.post->height, 0.4 * o.marker_size) << sw.name;
        ++markers;
      }
  EXPECT_GE(markers, 4);
}

// Edge pixels get CompareOptions' rays in every sweep (svms bench compare --edge-rays), 256 by
// default, over the datasets' 16 everywhere else.
TEST(CompareScenes, EdgePixelsGetTheRaysAsked) {
  CompareOptions o;
  o.quick = true;
  for (const CompareSweep& sw : MakeCompareSweeps(o)) {
    EXPECT_EQ(sw.scene.sensor.edge_rays_per_pixel, 256) << sw.name;
    EXPECT_EQ(sw.scene.sensor.rays_per_pixel, 16) << sw.name;
  }
  o.edge_rays_per_pixel = 0;
  for (const CompareSweep& sw : MakeCompareSweeps(o))
    EXPECT_EQ(sw.scene.sensor.edge_rays_per_pixel, 0) << sw.name;
}

// 8 px markers at 14 m, 0-18 degrees off-axis: the post's top is 0.4 px in radius, found to
// about 0.15 px, and a corner 3 sigmas off can outweigh it. In view size_008px_05 (6 degrees
// off-axis) both planar solutions refine to the twin, 12 degrees off; no second solution is
// left to weigh, and the flag comes from how far apart the pose and its twin put the points.
// Its covariance then spans the twin (the error along the way to it within 3 sigmas); its NEES
// stays high (27, 35 without the twin) because the same corner turned the roll 0.9 degrees,
// 3 of its sigmas.
TEST(CompareScenes, EightPixelMarkersArePosedRightOrFlagged) {
  const std::vector<Posed> views = PoseSizeViews("008");
  ASSERT_EQ(views.size(), 8u);
  int posed = 0;
  for (const Posed& p : views) {
    if (!std::isfinite(p.error_deg)) continue;
    ++posed;
    SCOPED_TRACE(p.view + ": error " + std::to_string(p.error_deg) + " deg");
    if (p.error_deg > 10) {
      EXPECT_TRUE(p.ambiguous);
      EXPECT_LT(p.twin_way_sigmas, 3);
      EXPECT_LT(p.alternative_error_deg, 5);  // the other planar pose is the right one
    } else {
      EXPECT_LT(p.nees, 16.3);  // chi-square, 3 dof, 99.9 %
    }
  }
  EXPECT_GE(posed, 6);
}

// At 30 px the top is found to a few hundredths of a pixel: every pose right, none flagged.
TEST(CompareScenes, ThirtyPixelMarkersAreNotFlagged) {
  const std::vector<Posed> views = PoseSizeViews("030");
  ASSERT_EQ(views.size(), 8u);
  for (const Posed& p : views) {
    SCOPED_TRACE(p.view);
    ASSERT_TRUE(std::isfinite(p.error_deg));
    EXPECT_LT(p.error_deg, 2);
    EXPECT_FALSE(p.ambiguous);
  }
}

// The sun sweep's shadow-edge views (75 px, 20 degrees off-axis, a bar's shadow edge across the
// marker): where the penumbra runs along a side, just outside it on the white stripe, the
// strongest rise across that side is the penumbra's, not the black square's (view 09: the side
// came out 2.9 px outside, the pose 5.4 degrees off with NEES 744). Every marker is found,
// every corner within 0.15 px of the truth, every pose within 0.5 degrees, and no NEES above
// chi-square's 99.9 % point.
TEST(CompareScenes, AShadowEdgeAlongASideDoesNotMoveIt) {
  for (const CompareSweep& sw : MakeCompareSweeps(CompareOptions{})) {
    if (sw.name != "sun") continue;
    std::unique_ptr<Renderer> r;
    ASSERT_TRUE(Renderer::Create(sw.scene, &r));
    std::vector<MarkerModel> models;
    for (const SceneObject& ob : sw.scene.objects)
      for (const SceneMarker& m : ob.markers) models.push_back(m.model);
    const Detector det(DetectorOptions{}, sw.scene.camera, models);
    int views = 0;
    for (size_t v = 0; v < sw.scene.views.size(); ++v) {
      const std::string& name = sw.scene.views[v].name;
      if (name.rfind("edge_", 0) != 0) continue;
      ++views;
      SCOPED_TRACE(name);
      const cv::Mat img = r->Expose(r->RenderRadiance(static_cast<int>(v)), static_cast<int>(v));
      if (const char* dir = std::getenv("SVMS_TEST_IMAGES"))
        cv::imwrite(std::string(dir) + "/" + name + ".png", img);
      const ViewTruth truth = ComputeTruth(*r, static_cast<int>(v));
      const MarkerTruth& t = truth.markers[0];
      const Detection* found = nullptr;
      const std::vector<Detection> dets = det.Detect(img);
      for (const Detection& d : dets)
        if (d.id == t.id && d.cam_from_marker) found = &d;
      ASSERT_NE(found, nullptr);
      double worst_px = 0, worst_sigmas = 0;
      for (int k = 0; k < 4; ++k) {
        const double e = (found->corners[k] - t.corners[k].pixel).norm();
        worst_px = std::max(worst_px, e);
        worst_sigmas = std::max(worst_sigmas, e / found->corner_sigma[k]);
      }
      const double error_deg = AngleBetweenDeg(*found->cam_from_marker, t.cam_from_marker);
      std::printf("%s: worst corner %.3f px (%.1f sigma), orientation %.3f deg, NEES %.1f\n",
                  name.c_str(), worst_px, worst_sigmas, error_deg,
                  Nees(t.cam_from_marker, *found->cam_from_marker, found->covariance));
      // Only view 09 has the penumbra along a side (its right side, 1 to 2, as printed).
      EXPECT_EQ(found->penumbra_sides,
                (std::array<bool, 4>{false, name == "edge_40deg_09", false, false}));
      EXPECT_LT(worst_px, 0.15);
      EXPECT_LT(error_deg, 0.5);
      EXPECT_LT(Nees(t.cam_from_marker, *found->cam_from_marker, found->covariance), 22.46);
    }
    EXPECT_EQ(views, 11);
  }
}

}  // namespace
}  // namespace svms
