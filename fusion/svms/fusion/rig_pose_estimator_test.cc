#include "svms/fusion/rig_pose_estimator.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

#include "svms/base/statistics.h"
#include "svms/datasets/datasets.h"
#include "svms/marker/model_io.h"
#include "svms/sim/render.h"
#include "svms/sim/truth.h"
#include "svms_testing/two_camera_rig.h"

namespace svms {
namespace {

using Vec3 = Eigen::Vector3d;

using svms_testing::TwoCameraApproach;

// The covariance of a camera's cam_from_object turned into rig axes (rig_from_object =
// rig_from_cam cam_from_object: both the rotation and the translation rotate by R_rig_cam).
PoseCovariance InRigAxes(const Pose& rig_from_cam, const PoseCovariance& c) {
  Eigen::Matrix<double, 6, 6> R = Eigen::Matrix<double, 6, 6>::Zero();
  R.topLeftCorner<3, 3>() = R.bottomRightCorner<3, 3>() = rig_from_cam.Rotation();
  return R * c * R.transpose();
}

TEST(RigPoseEstimator, RenderedTwoCameraRigIsAtLeastAsGoodAsItsBetterCamera) {
  const auto start = std::chrono::steady_clock::now();
  const TwoCameraApproach a;
  std::unique_ptr<RigPoseEstimator> est;
  ASSERT_TRUE(RigPoseEstimator::Create(a.rig, {a.layout}, {}, &est).ok());
  RigFrameResult r;
  est->Estimate(a.images, 1.5, &r);
  ASSERT_TRUE(r.pose.valid) << r.pose.message;
  EXPECT_EQ(r.timestamp, 1.5);
  ASSERT_EQ(r.cameras.size(), 2u);
  const double chi2_999 = ChiSquareQuantile(0.999, 6);
  const double nees = Nees(a.rig_from_module, r.pose.cam_from_object, r.pose.covariance);
  const Eigen::Matrix<double, 6, 1> e = PoseError(a.rig_from_module, r.pose.cam_from_object);
  std::printf(
      "rig: %d markers (%d narrow), error %.3f mrad %.3f mm, sigma %.3f mrad %.3f mm, "
      "NEES %.2f\n",
      r.pose.markers_used,
      static_cast<int>(std::count(r.pose.cameras_used.begin(), r.pose.cameras_used.end(), 0)),
      e.head<3>().norm() * 1e3, e.tail<3>().norm() * 1e3,
      std::sqrt(r.pose.covariance.topLeftCorner<3, 3>().trace()) * 1e3,
      std::sqrt(r.pose.covariance.bottomRightCorner<3, 3>().trace()) * 1e3, nees);
  EXPECT_LT(nees, chi2_999);
  // Both cameras contributed markers.
  for (int c = 0; c < 2; ++c)
    EXPECT_GT(std::count(r.pose.cameras_used.begin(), r.pose.cameras_used.end(), c), 0) << c;
  // Each camera alone, in rig axes: consistent with the truth too, and no better than the rig
  // (its covariance, and on this deterministic render its actual error).
  double better_rotation = 1e9, better_translation = 1e9;
  for (int c = 0; c < 2; ++c) {
    const ObjectPose& alone = r.cameras[c].pose;
    ASSERT_TRUE(alone.valid) << alone.message;
    const Pose rig_from_object = a.rig.cameras[c].rig_from_cam * alone.cam_from_object;
    const PoseCovariance cov = InRigAxes(a.rig.cameras[c].rig_from_cam, alone.covariance);
    const Eigen::Matrix<double, 6, 1> ec = PoseError(a.rig_from_module, rig_from_object);
    std::printf(
        "%s alone: %d markers, error %.3f mrad %.3f mm, sigma %.3f mrad %.3f mm, "
        "NEES %.2f\n",
        a.rig.cameras[c].name.c_str(), alone.markers_used, ec.head<3>().norm() * 1e3,
        ec.tail<3>().norm() * 1e3, std::sqrt(cov.topLeftCorner<3, 3>().trace()) * 1e3,
        std::sqrt(cov.bottomRightCorner<3, 3>().trace()) * 1e3,
        Nees(a.rig_from_module, rig_from_object, cov));
    EXPECT_LE((r.pose.covariance.topLeftCorner<3, 3>().trace()),
              (cov.topLeftCorner<3, 3>().trace() * 1.0001));
    EXPECT_LE((r.pose.covariance.bottomRightCorner<3, 3>().trace()),
              (cov.bottomRightCorner<3, 3>().trace() * 1.0001));
    EXPECT_LT(Nees(a.rig_from_module, rig_from_object, cov), chi2_999);
    better_rotation = std::min(better_rotation, ec.head<3>().norm());
    better_translation = std::min(better_translation, ec.tail<3>().norm());
  }
  EXPECT_LE(e.head<3>().norm(), better_rotation);
  EXPECT_LE(e.tail<3>().norm(), better_translation);
  // A wrong number of frames is refused with a reason, not a crash.
  est->Estimate({a.images[0]}, 2, &r);
  EXPECT_FALSE(r.pose.valid);
  EXPECT_NE(r.pose.message.find("one per camera"), std::string::npos) << r.pose.message;
  // One camera without a frame: the other still gives the pose, and the missing camera's
  // result (which held the last frame's) is empty.
  est->Estimate(a.images, 2.5, &r);
  ASSERT_TRUE(r.cameras[0].pose.valid);
  ASSERT_FALSE(r.cameras[0].detections.empty());
  const ObjectPose both = r.pose;
  est->Estimate({cv::Mat(), a.images[1]}, 3, &r);
  EXPECT_TRUE(r.pose.valid) << r.pose.message;
  const FrameResult& none = r.cameras[0];
  EXPECT_EQ(none.timestamp, 3);
  EXPECT_FALSE(none.pose.valid);
  EXPECT_EQ(none.pose.message, "no frame");
  EXPECT_TRUE(none.pose.ids_used.empty());
  EXPECT_EQ(none.pose.markers_used, 0);
  EXPECT_TRUE(none.detections.empty());
  EXPECT_TRUE(none.unassigned_ids.empty());
  EXPECT_EQ(none.detection_passes, 0);
  EXPECT_EQ(none.latency_ms, 0);
  EXPECT_FALSE(none.budget_exceeded);
  // Both again: the pose of both frames, to the bit.
  est->Estimate(a.images, 2.5, &r);
  ASSERT_TRUE(r.pose.valid);
  EXPECT_EQ(r.pose.cam_from_object.rvec, both.cam_from_object.rvec);
  EXPECT_EQ(r.pose.cam_from_object.tvec, both.cam_from_object.tvec);
  EXPECT_EQ(r.pose.covariance, both.covariance);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_LT(seconds, 20);
}

}  // namespace
}  // namespace svms
