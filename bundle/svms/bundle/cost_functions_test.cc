#include "svms/bundle/cost_functions.h"

#include <ceres/gradient_checker.h>
#include <gtest/gtest.h>

#include "svms/bundle/survey.h"
#include "svms/datasets/datasets.h"

namespace svms {
namespace {

const std::vector<const ceres::Manifold*>* kNoManifolds = nullptr;

// Checks every Jacobian of `cost` at `params` against central differences.
void ExpectGradientsMatch(const ceres::CostFunction& cost, std::vector<double*> params,
                          double precision = 1e-6) {
  ceres::NumericDiffOptions nd;
  nd.relative_step_size = 1e-7;
  ceres::GradientChecker checker(&cost, kNoManifolds, nd);
  ceres::GradientChecker::ProbeResults results;
  EXPECT_TRUE(checker.Probe(params.data(), precision, &results)) << results.error_log;
  EXPECT_LT(results.maximum_relative_error, precision);
}

struct Fixture {
  CameraModel camera = DistortedCamera();
  // A camera 1.5 m in front of a marker tilted by 30 degrees, off-centre, so that the lens
  // distortion matters.
  double cam_from_object[6] = {3.0, 0.1, -0.2, 0.15, -0.1, 1.4};
  double object_from_marker[6] = {0.3, -0.5, 0.2, 0.05, 0.02, -0.1};
  double post_height[1] = {0.05};
  Eigen::Vector2d Project(const Eigen::Vector3d& p_marker) const {
    double o[3], c[3];
    TransformPoint(object_from_marker, p_marker.data(), o);
    TransformPoint(cam_from_object, o, c);
    Eigen::Vector2d px;
    EXPECT_TRUE(camera.Project(Eigen::Vector3d(c[0], c[1], c[2]), &px));
    return px;
  }
};

TEST(MarkerPointCost, CornerJacobiansMatchNumericDifferences) {
  Fixture f;
  const Eigen::Vector3d corner(-0.1, 0.1, 0);
  const Eigen::Vector2d obs = f.Project(corner) + Eigen::Vector2d(0.3, -0.2);
  std::unique_ptr<MarkerPointCost> cost(
      MarkerPointCost::CreateCorner(&f.camera, corner, obs, 0.1, false));
  ExpectGradientsMatch(*cost, {f.cam_from_object, f.object_from_marker});
  // The residual is the pixel error over sigma.
  double r[2];
  const double* p[] = {f.cam_from_object, f.object_from_marker};
  ASSERT_TRUE(cost->Evaluate(p, r, nullptr));
  EXPECT_NEAR(r[0], -3.0, 1e-9);
  EXPECT_NEAR(r[1], 2.0, 1e-9);
}

TEST(MarkerPointCost, TipJacobiansIncludeThePostHeight) {
  Fixture f;
  const Eigen::Vector2d tip_xy(0.002, -0.001);  // a concave well's visible offset
  const Eigen::Vector2d obs = f.Project(Eigen::Vector3d(tip_xy.x(), tip_xy.y(), f.post_height[0])) +
                              Eigen::Vector2d(0.1, 0.1);
  std::unique_ptr<MarkerPointCost> cost(
      MarkerPointCost::CreateTip(&f.camera, &tip_xy, obs, 0.5, false));
  ASSERT_EQ(cost->parameter_block_sizes().size(), 3u);
  ExpectGradientsMatch(*cost, {f.cam_from_object, f.object_from_marker, f.post_height});
  double r[2];
  const double* p[] = {f.cam_from_object, f.object_from_marker, f.post_height};
  ASSERT_TRUE(cost->Evaluate(p, r, nullptr));
  EXPECT_NEAR(r[0], -0.2, 1e-9);
}

TEST(RigMarkerPointCost, IsTheWrappedCostThroughTheRigWithMatchingJacobians) {
  Fixture f;
  // A camera half a metre from the rig's origin, turned by 0.4 rad: rig_from_object is
  // rig_from_cam * cam_from_object, so the wrapped cost sees the fixture's cam_from_object.
  double rig_from_cam[6] = {0.1, 0.4, -0.05, 0.5, 0.02, -0.03};
  double rig_from_object[6];
  {
    const Pose rc{Eigen::Vector3d(rig_from_cam[0], rig_from_cam[1], rig_from_cam[2]),
                  Eigen::Vector3d(rig_from_cam[3], rig_from_cam[4], rig_from_cam[5])};
    const Pose co{
        Eigen::Vector3d(f.cam_from_object[0], f.cam_from_object[1], f.cam_from_object[2]),
        Eigen::Vector3d(f.cam_from_object[3], f.cam_from_object[4], f.cam_from_object[5])};
    const Pose ro = rc * co;
    for (int i = 0; i < 3; ++i) {
      rig_from_object[i] = ro.rvec(i);
      rig_from_object[3 + i] = ro.tvec(i);
    }
  }
  const Eigen::Vector2d tip_xy(0.001, 0.002);
  const Eigen::Vector2d obs = f.Project(Eigen::Vector3d(tip_xy.x(), tip_xy.y(), f.post_height[0])) +
                              Eigen::Vector2d(0.2, -0.1);
  std::vector<double> intrinsics = f.camera.intrinsics();
  RigMarkerPointCost cost(MarkerPointCost::CreateTip(&f.camera, &tip_xy, obs, 0.5, true));
  ASSERT_EQ(cost.parameter_block_sizes().size(), 5u);
  ExpectGradientsMatch(cost, {rig_from_object, rig_from_cam, f.object_from_marker, f.post_height,
                              intrinsics.data()});
  double r[2];
  const double* p[] = {rig_from_object, rig_from_cam, f.object_from_marker, f.post_height,
                       intrinsics.data()};
  ASSERT_TRUE(cost.Evaluate(p, r, nullptr));
  EXPECT_NEAR(r[0], -0.4, 1e-8);
  EXPECT_NEAR(r[1], 0.2, 1e-8);
}

TEST(MarkerPointCost, IntrinsicsJacobiansComeFromMrcal) {
  Fixture f;
  std::vector<double> intrinsics = f.camera.intrinsics();
  const Eigen::Vector3d corner(0.1, -0.1, 0);
  const Eigen::Vector2d obs = f.Project(corner) + Eigen::Vector2d(-0.4, 0.25);
  std::unique_ptr<MarkerPointCost> cost(
      MarkerPointCost::CreateCorner(&f.camera, corner, obs, 0.1, true));
  ASSERT_EQ(cost->parameter_block_sizes().back(), static_cast<int>(intrinsics.size()));
  intrinsics[0] *= 1.01;  // away from the camera's own values: the cost must use the block
  ExpectGradientsMatch(*cost, {f.cam_from_object, f.object_from_marker, intrinsics.data()}, 1e-5);
  const Eigen::Vector2d tip_xy(0, 0);
  std::unique_ptr<MarkerPointCost> tip(
      MarkerPointCost::CreateTip(&f.camera, &tip_xy, obs, 0.5, true));
  ExpectGradientsMatch(
      *tip, {f.cam_from_object, f.object_from_marker, f.post_height, intrinsics.data()}, 1e-5);
}

TEST(MarkerPointCost, BehindTheCameraFailsTheEvaluation) {
  Fixture f;
  f.cam_from_object[5] = -3;  // the object behind the camera
  std::unique_ptr<MarkerPointCost> cost(MarkerPointCost::CreateCorner(
      &f.camera, Eigen::Vector3d::Zero(), Eigen::Vector2d(500, 500), 0.1, false));
  double r[2];
  const double* p[] = {f.cam_from_object, f.object_from_marker};
  EXPECT_FALSE(cost->Evaluate(p, r, nullptr));
}

TEST(ScaleBarCost, JacobiansAndValue) {
  NamedPoint a, b;
  ASSERT_TRUE(ParseNamedPoint("3.tl", &a));
  ASSERT_TRUE(ParseNamedPoint("5.tip", &b));
  ScaleBar bar{a, b, 1.0, 1e-4};
  double pose_a[6] = {0.1, 0.2, -0.3, 0.0, 0.1, 0.2};
  double pose_b[6] = {-0.4, 0.1, 0.2, 0.9, -0.2, 0.3};
  double h_b[1] = {0.04};
  const Eigen::Vector3d a_in(-0.05, 0.05, 0);
  std::unique_ptr<ceres::CostFunction> cost(ScaleBarCost::Create(bar, a_in, Eigen::Vector3d()));
  ASSERT_EQ(cost->parameter_block_sizes().size(), 3u);
  ExpectGradientsMatch(*cost, {pose_a, pose_b, h_b});
  double pa[3], pb[3], tip[3] = {0, 0, h_b[0]}, r;
  TransformPoint(pose_a, a_in.data(), pa);
  TransformPoint(pose_b, tip, pb);
  const double d =
      (Eigen::Vector3d(pa[0], pa[1], pa[2]) - Eigen::Vector3d(pb[0], pb[1], pb[2])).norm();
  const double* p[] = {pose_a, pose_b, h_b};
  ASSERT_TRUE(cost->Evaluate(p, &r, nullptr));
  EXPECT_NEAR(r, (d - 1.0) / 1e-4, 1e-6);
}

TEST(ControlPointCost, JacobiansAndValue) {
  NamedPoint n;
  ASSERT_TRUE(ParseNamedPoint("7.br", &n));
  ControlPoint cp{n, Eigen::Vector3d(0.5, 0.2, -0.1), 1e-3};
  double pose[6] = {0.5, -0.2, 0.1, 0.45, 0.25, -0.05};
  const Eigen::Vector3d in(0.05, -0.05, 0);
  std::unique_ptr<ceres::CostFunction> cost(ControlPointCost::Create(cp, in));
  ExpectGradientsMatch(*cost, {pose});
  double r[3], p_obj[3];
  TransformPoint(pose, in.data(), p_obj);
  const double* p[] = {pose};
  ASSERT_TRUE(cost->Evaluate(p, r, nullptr));
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(r[i], (p_obj[i] - cp.point_in_object[i]) / 1e-3, 1e-9);
}

TEST(PostHeightPriorCost, Jacobians) {
  std::unique_ptr<ceres::CostFunction> cost(PostHeightPriorCost::Create(0.05, 0.002));
  double h[1] = {0.053};
  ExpectGradientsMatch(*cost, {h});
  double r;
  const double* p[] = {h};
  ASSERT_TRUE(cost->Evaluate(p, &r, nullptr));
  EXPECT_NEAR(r, 1.5, 1e-12);
}

TEST(NamedPoint, ParsesAndRejects) {
  NamedPoint p;
  ASSERT_TRUE(ParseNamedPoint("12", &p));
  EXPECT_EQ(p.marker_id, 12);
  EXPECT_EQ(p.kind, NamedPoint::Kind::kCentre);
  ASSERT_TRUE(ParseNamedPoint("4.bl", &p));
  EXPECT_EQ(p.kind, NamedPoint::Kind::kCorner);
  EXPECT_EQ(p.corner, 3);
  const Status s = ParseNamedPoint("4.middle", &p);
  EXPECT_FALSE(s);
  EXPECT_NE(s.message().find("4.middle"), std::string::npos);
  EXPECT_FALSE(ParseNamedPoint("x1", &p));
  EXPECT_FALSE(ParseNamedPoint("", &p));
}

}  // namespace
}  // namespace svms
