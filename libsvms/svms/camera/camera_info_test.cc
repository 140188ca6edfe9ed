#include "svms/camera/camera_info.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "svms/camera/camera_covariance.h"
#include "svms_testing/scratch_dir.h"

namespace svms {
namespace {

const svms_testing::ScratchDir& Dir() {
  static const svms_testing::ScratchDir dir("svms_camera_info_test");
  return dir;
}

// Known answer: a pinhole camera's field of view is 2 atan(W / 2f), its distortion zero.
TEST(CameraInfo, PinholeFieldOfView) {
  const std::string path = Dir().File("pin.cameramodel");
  ASSERT_TRUE(CameraModel::Pinhole(800, 1000, 600).Write(path).ok());
  CameraInfo info;
  ASSERT_TRUE(ReadCameraInfo(path, &info).ok());
  EXPECT_NEAR(info.fov_x_deg, 2 * std::atan(500.0 / 800) * 180 / M_PI, 1e-9);
  EXPECT_NEAR(info.fov_y_deg, 2 * std::atan(300.0 / 800) * 180 / M_PI, 1e-9);
  EXPECT_EQ(info.max_distortion_px, 0);
  EXPECT_TRUE(info.distortion.empty());
  EXPECT_EQ(info.distortion_count, 0);
  EXPECT_TRUE(info.sidecar_path.empty());
  EXPECT_FALSE(info.has_optimization_inputs);
}

// Barrel distortion (k1 < 0) moves the corners inwards by a known amount: for k1 alone, a
// corner at normalised radius r is imaged at r (1 + k1 r^2), so the pixel at the corner has a
// ray whose pinhole image lies further out.
TEST(CameraInfo, DistortionNamesAndSize) {
  CameraModel cam;
  ASSERT_TRUE(CameraModel::Create("LENSMODEL_OPENCV4", {1000, 1000, 499.5, 399.5, -0.1, 0, 0, 0},
                                  1000, 800, &cam)
                  .ok());
  const std::string path = Dir().File("k1.cameramodel");
  ASSERT_TRUE(cam.Write(path).ok());
  CameraInfo info;
  ASSERT_TRUE(ReadCameraInfo(path, &info).ok());
  ASSERT_EQ(info.distortion.size(), 4u);
  EXPECT_EQ(info.distortion[0].first, "k1");
  EXPECT_EQ(info.distortion[0].second, -0.1);
  EXPECT_EQ(info.distortion[3].first, "p2");
  // The corner pixel (0, 0) is at distorted radius rd = hypot(499.5, 399.5) / 1000; its ray's
  // undistorted radius r solves r (1 - 0.1 r^2) = rd.
  const double rd = std::hypot(499.5, 399.5) / 1000;
  double r = rd;
  for (int i = 0; i < 50; ++i) r = rd / (1 - 0.1 * r * r);
  EXPECT_NEAR(info.max_distortion_px, (r - rd) * 1000, 1e-6);
  EXPECT_GT(info.fov_x_deg, 2 * std::atan(500.0 / 1000) * 180 / M_PI);
}

TEST(CameraInfo, ReportsSidecarAndItsMismatch) {
  CameraModel cam = CameraModel::Pinhole(800, 640, 480);
  ASSERT_TRUE(cam.set_intrinsics_covariance_factor(Eigen::MatrixXd::Identity(4, 4) * 0.1).ok());
  const std::string path = Dir().File("cov.cameramodel");
  ASSERT_TRUE(WriteCameraWithSidecar(path, cam, 0.3, 12).ok());
  CameraInfo info;
  ASSERT_TRUE(ReadCameraInfo(path, &info).ok());
  EXPECT_EQ(info.sidecar_path, path + ".covariance.json");
  EXPECT_EQ(info.sidecar_error, "");
  // Re-calibrated (another focal length) without its sidecar: the stale one is reported.
  ASSERT_TRUE(CameraModel::Pinhole(801, 640, 480).Write(path).ok());
  ASSERT_TRUE(ReadCameraInfo(path, &info).ok());
  EXPECT_EQ(info.sidecar_path, path + ".covariance.json");
  EXPECT_NE(info.sidecar_error, "");
}

TEST(CameraInfo, FindsOptimizationInputsKeyOnly) {
  EXPECT_TRUE(HasOptimizationInputs("{\n 'lensmodel': 'X',\n 'optimization_inputs': b'abc',\n}"));
  EXPECT_TRUE(HasOptimizationInputs("{ \"optimization_inputs\"  : 1 }"));
  EXPECT_FALSE(HasOptimizationInputs("# 'optimization_inputs': here in a comment\n{ 'a': 1 }"));
  EXPECT_FALSE(HasOptimizationInputs("{ 'note': 'optimization_inputs', 'b': 2 }"));
  EXPECT_FALSE(HasOptimizationInputs("{ 'optimization_inputs_x': 1 }"));
}

}  // namespace
}  // namespace svms
