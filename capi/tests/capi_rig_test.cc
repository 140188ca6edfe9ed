// The C API's camera rig (svms_create_rig, svms_process_rig_frame, svms_destroy_rig) on the
// renders of svms_testing/two_camera_rig.h: bit for bit the RigPoseEstimator's pose (8-bit
// frames, and 16-bit through svms_process_rig_frame_u16), the
// frames' count and sizes checked, a camera without a frame allowed, bad rig files refused
// with the file and field, a destroyed handle detected.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <vector>

#include "svms/fusion/rig_pose_estimator.h"
#include "svms/svms.h"
#include "svms_testing/scratch_dir.h"
#include "svms_testing/two_camera_rig.h"

namespace {

// The rig's files in `dir`: narrow.cameramodel, wide.cameramodel, port.rig (the narrow camera
// with an extrinsics covariance), layout.json.
void WriteRigFiles(const svms_testing::TwoCameraApproach& a, const std::string& dir) {
  std::ofstream rig(dir + "/port.rig");
  rig.precision(17);
  rig << R"({"type": "svms.rig", "name": "test", "cameras": [)";
  for (size_t c = 0; c < a.rig.cameras.size(); ++c) {
    const svms::RigCamera& cam = a.rig.cameras[c];
    ASSERT_TRUE(cam.camera.Write(dir + "/" + cam.name + ".cameramodel").ok());
    const svms::Pose& p = cam.rig_from_cam;
    rig << (c ? "," : "") << R"({"name": ")" << cam.name << R"(", "cameramodel": ")" << cam.name
        << R"(.cameramodel", "rig_from_cam": {"rvec": [)" << p.rvec.x() << "," << p.rvec.y() << ","
        << p.rvec.z() << R"(], "tvec": [)" << p.tvec.x() << "," << p.tvec.y() << "," << p.tvec.z()
        << "]}";
    if (c == 0)
      rig << R"(, "covariance": [[1e-8,0,0,0,0,0],[0,1e-8,0,0,0,0],[0,0,1e-8,0,0,0],)"
          << R"([0,0,0,1e-8,0,0],[0,0,0,0,1e-8,0],[0,0,0,0,0,1e-8]])";
    rig << "}";
  }
  rig << "]}";
  rig.close();
  std::ofstream(dir + "/layout.json") << svms::LayoutToJson(a.layout);
}

TEST(CapiRig, ProcessRigFrameIsTheRigPoseEstimators) {
  const svms_testing::TwoCameraApproach a;
  const svms_testing::ScratchDir scratch("svms_capi_rig_test");
  const std::string dir = scratch.path().string();
  WriteRigFiles(a, dir);
  svms_rig_estimator* est = nullptr;
  ASSERT_EQ(
      svms_create_rig((dir + "/port.rig").c_str(), (dir + "/layout.json").c_str(), nullptr, &est),
      SVMS_OK)
      << svms_last_error();
  int n = 0;
  ASSERT_EQ(svms_rig_camera_count(est, &n), SVMS_OK);
  ASSERT_EQ(n, 2);
  svms_rig_frame frames[2];
  for (int c = 0; c < 2; ++c) {
    ASSERT_EQ(a.images[c].type(), CV_8UC1);
    frames[c] = {a.images[c].data, a.images[c].cols, a.images[c].rows,
                 static_cast<ptrdiff_t>(a.images[c].step)};
  }
  svms_pose pose;
  ASSERT_EQ(svms_process_rig_frame(est, frames, 2, 4.5, &pose), SVMS_OK) << svms_last_error();
  ASSERT_EQ(pose.valid, 1);
  EXPECT_EQ(pose.timestamp, 4.5);
  EXPECT_TRUE(pose.flags & SVMS_FLAG_EXTRINSICS_IN_COVARIANCE);

  std::unique_ptr<svms::RigPoseEstimator> cpp;
  ASSERT_TRUE(
      svms::RigPoseEstimator::CreateFromFiles(dir + "/port.rig", {dir + "/layout.json"}, {}, &cpp)
          .ok());
  // The C API's pose is the RigPoseEstimator's, bit for bit, and within its covariance of the
  // truth (chi-square 6 at 99.9 %).
  auto expect_same_pose = [&](const svms_pose& c_pose, const svms::ObjectPose& cpp_pose) {
    for (int i = 0; i < 3; ++i) {
      EXPECT_EQ(c_pose.rvec[i], cpp_pose.cam_from_object.rvec[i]);
      EXPECT_EQ(c_pose.tvec[i], cpp_pose.cam_from_object.tvec[i]);
    }
    for (int i = 0; i < 36; ++i) EXPECT_EQ(c_pose.covariance[i], cpp_pose.covariance(i / 6, i % 6));
    EXPECT_EQ(c_pose.markers_used, cpp_pose.markers_used);
    EXPECT_LT(svms::Nees(a.rig_from_module, cpp_pose.cam_from_object, cpp_pose.covariance), 22.46);
  };
  svms::RigFrameResult r;
  cpp->Estimate(a.images, 4.5, &r);
  ASSERT_TRUE(r.pose.valid);
  expect_same_pose(pose, r.pose);
  // The extrinsics' share, common to every frame, and its factor: the RigPoseEstimator's.
  ASSERT_GT(r.pose.bias_columns(), 0);
  const Eigen::Matrix<double, 6, 6> common =
      r.pose.bias_factor() * r.pose.bias_factor().transpose();
  for (int i = 0; i < 36; ++i) EXPECT_EQ(pose.covariance_common[i], common(i / 6, i % 6));
  std::vector<double> factor(6 * 64, -1);
  int columns = -1;
  ASSERT_EQ(svms_last_rig_bias_factor(est, 0, factor.data(), 64, &columns), SVMS_OK)
      << svms_last_error();
  ASSERT_EQ(columns, r.pose.bias_columns());
  for (int i = 0; i < 6 * columns; ++i) EXPECT_EQ(factor[i], r.pose.bias_factor_values[i]);
  EXPECT_EQ(svms_last_rig_bias_factor(est, 1, factor.data(), 64, &columns),
            SVMS_ERR_INVALID_ARGUMENT);
  EXPECT_NE(std::string(svms_last_error()).find("object is 1, expected 0 to 0"), std::string::npos)
      << svms_last_error();

  // 16-bit frames (the renders scaled to 12 bits, as a machine-vision camera stores its raw
  // frames): svms_process_rig_frame_u16 gives the RigPoseEstimator's pose of the same frames.
  std::vector<cv::Mat> images16(2);
  svms_rig_frame_u16 frames16[2];
  for (int c = 0; c < 2; ++c) {
    a.images[c].convertTo(images16[c], CV_16U, 16);
    frames16[c] = {images16[c].ptr<uint16_t>(), images16[c].cols, images16[c].rows,
                   static_cast<ptrdiff_t>(images16[c].step)};
  }
  svms_pose pose16;
  ASSERT_EQ(svms_process_rig_frame_u16(est, frames16, 2, 6, &pose16), SVMS_OK) << svms_last_error();
  ASSERT_EQ(pose16.valid, 1);
  EXPECT_EQ(pose16.timestamp, 6);
  EXPECT_TRUE(pose16.flags & SVMS_FLAG_EXTRINSICS_IN_COVARIANCE);
  svms::RigFrameResult r16;
  cpp->Estimate(images16, 6, &r16);
  ASSERT_TRUE(r16.pose.valid);
  expect_same_pose(pose16, r16.pose);
  // A 16-bit frame's stride: at least two bytes per pixel, and even.
  svms_rig_frame_u16 bad16[2] = {frames16[0], frames16[1]};
  bad16[1].stride = bad16[1].width;
  EXPECT_EQ(svms_process_rig_frame_u16(est, bad16, 2, 6, &pose16), SVMS_ERR_INVALID_ARGUMENT);
  EXPECT_NE(std::string(svms_last_error()).find("frames[1].stride is"), std::string::npos)
      << svms_last_error();
  bad16[1].stride = frames16[1].stride + 1;
  EXPECT_EQ(svms_process_rig_frame_u16(est, bad16, 2, 6, &pose16), SVMS_ERR_INVALID_ARGUMENT);
  EXPECT_NE(std::string(svms_last_error()).find("a multiple of 2"), std::string::npos)
      << svms_last_error();
  EXPECT_EQ(svms_process_rig_frame_u16(est, nullptr, 2, 6, &pose16), SVMS_ERR_NULL_ARGUMENT);
  EXPECT_NE(std::string(svms_last_error()).find("svms_process_rig_frame_u16: frames is NULL"),
            std::string::npos)
      << svms_last_error();

  // The wide camera alone (no narrow frame).
  svms_rig_frame wide_only[2] = {{nullptr, 0, 0, 0}, frames[1]};
  ASSERT_EQ(svms_process_rig_frame(est, wide_only, 2, 5, &pose), SVMS_OK);
  EXPECT_EQ(pose.valid, 1);
  // Both again, after the narrow camera's result was emptied: the first frame's pose, to the bit.
  ASSERT_EQ(svms_process_rig_frame(est, frames, 2, 4.5, &pose), SVMS_OK) << svms_last_error();
  expect_same_pose(pose, r.pose);
  // Wrong count and size.
  EXPECT_EQ(svms_process_rig_frame(est, frames, 1, 5, &pose), SVMS_ERR_INVALID_ARGUMENT);
  EXPECT_NE(std::string(svms_last_error()).find("n_frames is 1"), std::string::npos);
  svms_rig_frame small[2] = {frames[0], frames[1]};
  small[1].width = 320;
  EXPECT_EQ(svms_process_rig_frame(est, small, 2, 5, &pose), SVMS_ERR_INVALID_ARGUMENT);
  EXPECT_NE(std::string(svms_last_error()).find("frames[1]"), std::string::npos);
  EXPECT_EQ(svms_process_rig_frame(est, nullptr, 2, 5, &pose), SVMS_ERR_NULL_ARGUMENT);

  // Two threads per frame on every camera: the same pose to the bit; a value out of range is
  // refused by name.
  ASSERT_EQ(svms_set_rig_detection(est, 1, 2), SVMS_OK) << svms_last_error();
  ASSERT_EQ(svms_process_rig_frame(est, frames, 2, 4.5, &pose), SVMS_OK) << svms_last_error();
  expect_same_pose(pose, r.pose);
  EXPECT_EQ(svms_set_rig_detection(est, 0, 2), SVMS_ERR_INVALID_ARGUMENT);
  EXPECT_NE(std::string(svms_last_error()).find("svms_set_rig_detection: decimate: expected 1"),
            std::string::npos)
      << svms_last_error();
  EXPECT_EQ(svms_set_rig_detection(nullptr, 1, 1), SVMS_ERR_NULL_ARGUMENT);

  ASSERT_EQ(svms_destroy_rig(est), SVMS_OK);
  EXPECT_EQ(svms_set_rig_detection(est, 1, 1), SVMS_ERR_BAD_HANDLE);
  EXPECT_EQ(svms_process_rig_frame(est, frames, 2, 5, &pose), SVMS_ERR_BAD_HANDLE);
  EXPECT_EQ(svms_process_rig_frame_u16(est, frames16, 2, 5, &pose), SVMS_ERR_BAD_HANDLE);
  EXPECT_NE(std::string(svms_last_error())
                .find("svms_process_rig_frame_u16: the estimator is not "
                      "one from svms_create_rig"),
            std::string::npos)
      << svms_last_error();
  EXPECT_EQ(svms_destroy_rig(est), SVMS_ERR_BAD_HANDLE);

  // A bad rig file: SVMS_ERR_FILE naming the file and the field.
  std::ofstream(dir + "/bad.rig") << R"({"type": "svms.rig", "cameras": [{"name": "a",
      "cameramodel": "nowhere.cameramodel", "rig_from_cam": {"rvec": [0,0,0], "tvec": [0,0,0]}}]})";
  svms_rig_estimator* bad = nullptr;
  EXPECT_EQ(
      svms_create_rig((dir + "/bad.rig").c_str(), (dir + "/layout.json").c_str(), nullptr, &bad),
      SVMS_ERR_FILE);
  EXPECT_EQ(bad, nullptr);
  const std::string error = svms_last_error();
  EXPECT_NE(error.find("bad.rig: cameras[0] 'a'"), std::string::npos) << error;
  EXPECT_EQ(error.find('\n'), std::string::npos) << error;
}

}  // namespace
