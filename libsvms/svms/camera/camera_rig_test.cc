#include "svms/camera/camera_rig.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "svms_testing/scratch_dir.h"

namespace svms {
namespace {
namespace fs = std::filesystem;

// A folder with two pinhole camera models, narrow.cameramodel and wide.cameramodel.
const fs::path& Folder() {
  static const svms_testing::ScratchDir scratch("svms_camera_rig_test");
  static const fs::path dir = [] {
    const fs::path d = scratch.path();
    CameraModel narrow, wide;
    EXPECT_TRUE(
        CameraModel::Create("LENSMODEL_PINHOLE", {2900, 2900, 511.5, 511.5}, 1024, 1024, &narrow)
            .ok());
    EXPECT_TRUE(
        CameraModel::Create("LENSMODEL_PINHOLE", {890, 890, 511.5, 511.5}, 1024, 1024, &wide).ok());
    EXPECT_TRUE(narrow.Write((d / "narrow.cameramodel").string()).ok());
    EXPECT_TRUE(wide.Write((d / "wide.cameramodel").string()).ok());
    return d;
  }();
  return dir;
}

std::string WriteRig(const std::string& name, const std::string& text) {
  const std::string path = (Folder() / name).string();
  std::ofstream(path) << text;
  return path;
}

const char* kCovariance =
    "[[1e-6,0,0,0,0,0],[0,1e-6,0,0,0,0],[0,0,1e-6,0,0,0],"
    "[0,0,0,1e-6,0,0],[0,0,0,0,1e-6,0],[0,0,0,0,0,1e-6]]";

std::string RigText(const std::string& second_camera_extra = "",
                    const std::string& covariance = kCovariance) {
  return std::string(R"({"type": "svms.rig", "name": "port", "cameras": [
    {"name": "narrow", "cameramodel": "narrow.cameramodel",
     "rig_from_cam": {"rvec": [0, 0, 0], "tvec": [-0.25, 0, 0]}, "covariance": )") +
         covariance + R"(},
    {"name": "wide", "cameramodel": "wide.cameramodel",
     "rig_from_cam": {"rvec": [0, 0.1, 0], "tvec": [0.25, 0, 0]})" +
         second_camera_extra + "}]}";
}

TEST(CameraRig, ReadsCamerasPosesAndCovariances) {
  CameraRig rig;
  const std::string path = WriteRig("good.rig", RigText());
  const Status s = ReadRigFile(path, &rig);
  ASSERT_TRUE(s.ok()) << s.message();
  EXPECT_EQ(rig.name, "port");
  ASSERT_EQ(rig.cameras.size(), 2u);
  EXPECT_EQ(rig.cameras[0].name, "narrow");
  EXPECT_EQ(rig.cameras[0].camera.intrinsics()[0], 2900);
  EXPECT_EQ(rig.cameras[1].camera.intrinsics()[0], 890);
  EXPECT_EQ(rig.cameras[1].rig_from_cam.tvec.x(), 0.25);
  EXPECT_EQ(rig.cameras[1].rig_from_cam.rvec.y(), 0.1);
  ASSERT_TRUE(rig.cameras[0].rig_from_cam_covariance);
  EXPECT_EQ((*rig.cameras[0].rig_from_cam_covariance)(5, 5), 1e-6);
  EXPECT_FALSE(rig.cameras[1].rig_from_cam_covariance);
}

TEST(CameraRig, ACameraIsFoundByNameAndAnUnknownNameListsTheRigsCameras) {
  CameraRig rig;
  ASSERT_TRUE(ReadRigFile(WriteRig("names.rig", RigText()), &rig).ok());
  int index = -1;
  ASSERT_TRUE(FindRigCamera(rig, "wide", "port.rig", &index).ok());
  EXPECT_EQ(index, 1);
  ASSERT_TRUE(FindRigCamera(rig, "narrow", "port.rig", &index).ok());
  EXPECT_EQ(index, 0);
  index = 7;
  const Status s = FindRigCamera(rig, "tele", "port.rig", &index);
  EXPECT_FALSE(s.ok());
  EXPECT_EQ(index, 7);  // untouched
  EXPECT_EQ(s.message(), "no camera named 'tele' in port.rig (it has narrow, wide)");
}

// Every bad rig file gives one line naming the file and the field.
TEST(CameraRig, BadRigFilesGiveOneLineErrorsNamingFileAndField) {
  const struct {
    std::string text, expected;
  } cases[] = {
      {"{", "not valid JSON"},
      {R"({"type": "svms.layout", "cameras": []})", "type: expected \"svms.rig\""},
      {R"({"type": "svms.rig", "cameras": []})", "cameras: expected a non-empty array"},
      {R"({"type": "svms.rig", "cameras": [{"name": "a", "cameramodel": "missing.cameramodel",
          "rig_from_cam": {"rvec": [0, 0, 0], "tvec": [0, 0, 0]}}]})",
       "cameras[0].cameramodel: "},
      {RigText(R"(, "focal": 3)"), "cameras[1].focal: unknown field"},
      {R"({"type": "svms.rig", "cameras": [{"name": "a", "cameramodel": "wide.cameramodel",
          "rig_from_cam": {"rvec": [0, 0], "tvec": [0, 0, 0]}}]})",
       "cameras[0].rig_from_cam.rvec: expected an array of 3 numbers"},
      {R"({"type": "svms.rig", "cameras": [{"name": "a", "cameramodel": "wide.cameramodel"}]})",
       "cameras[0].rig_from_cam: "},
      {RigText("",
               "[[1e-6,1e-7,0,0,0,0],[0,1e-6,0,0,0,0],[0,0,1e-6,0,0,0],"
               "[0,0,0,1e-6,0,0],[0,0,0,0,1e-6,0],[0,0,0,0,0,1e-6]]"),
       "cameras[0].covariance: expected a symmetric 6x6 matrix"},
      {RigText("",
               "[[-1e-6,0,0,0,0,0],[0,1e-6,0,0,0,0],[0,0,1e-6,0,0,0],"
               "[0,0,0,1e-6,0,0],[0,0,0,0,1e-6,0],[0,0,0,0,0,1e-6]]"),
       "cameras[0].covariance: expected a positive definite matrix"},
      {RigText("", "[[1e-6,0,0,0,0,0]]"), "cameras[0].covariance: expected 6 rows"},
      {R"({"type": "svms.rig", "cameras": [
          {"name": "a", "cameramodel": "wide.cameramodel", "rig_from_cam": {"rvec": [0, 0, 0], "tvec": [0, 0, 0]}},
          {"name": "a", "cameramodel": "wide.cameramodel", "rig_from_cam": {"rvec": [0, 0, 0], "tvec": [0, 0, 0]}}]})",
       "cameras[1].name: 'a' appears twice"},
  };
  int k = 0;
  for (const auto& c : cases) {
    const std::string path = WriteRig("bad" + std::to_string(k++) + ".rig", c.text);
    CameraRig rig;
    const Status s = ReadRigFile(path, &rig);
    ASSERT_FALSE(s.ok()) << c.text;
    EXPECT_EQ(s.message().find('\n'), std::string::npos) << s.message();
    EXPECT_EQ(s.message().rfind(path, 0), 0u) << s.message();
    EXPECT_NE(s.message().find(c.expected), std::string::npos)
        << s.message() << "\nexpected: " << c.expected;
  }
  CameraRig rig;
  const Status missing = ReadRigFile((Folder() / "none.rig").string(), &rig);
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.message().find("none.rig"), std::string::npos);
}

std::string Quoted(const std::string& s) { return "\"" + s + "\""; }

TEST(CameraRig, WrittenRigFilesReadBackToTheLastBit) {
  CameraRig rig;
  ASSERT_TRUE(ReadRigFile(WriteRig("in.rig", RigText()), &rig).ok());
  rig.cameras[1].rig_from_cam =
      Pose{Eigen::Vector3d(0.1 / 3, -0.2, 1e-17), Eigen::Vector3d(1 / 3.0, 0, -2e-3)};
  PoseCovariance c = PoseCovariance::Identity() * 1e-7;
  c(0, 3) = c(3, 0) = 2.0 / 3 * 1e-8;
  rig.cameras[1].rig_from_cam_covariance = c;
  // Written into a sub-folder: the camera models' paths are rewritten relative to it.
  fs::create_directories(Folder() / "out");
  const std::string out = (Folder() / "out" / "surveyed.rig").string();
  ASSERT_TRUE(WriteRigFile(out, rig).ok());
  CameraRig back;
  const Status s = ReadRigFile(out, &back);
  ASSERT_TRUE(s.ok()) << s.message();
  ASSERT_EQ(back.cameras.size(), 2u);
  EXPECT_EQ(back.name, "port");
  for (size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(back.cameras[i].name, rig.cameras[i].name);
    EXPECT_EQ(back.cameras[i].rig_from_cam.rvec, rig.cameras[i].rig_from_cam.rvec);
    EXPECT_EQ(back.cameras[i].rig_from_cam.tvec, rig.cameras[i].rig_from_cam.tvec);
    ASSERT_TRUE(back.cameras[i].rig_from_cam_covariance);
    EXPECT_EQ(*back.cameras[i].rig_from_cam_covariance, *rig.cameras[i].rig_from_cam_covariance);
    EXPECT_EQ(back.cameras[i].camera.intrinsics(), rig.cameras[i].camera.intrinsics());
  }
  EXPECT_NE(RigToJson(rig, (Folder() / "out").string()).find("\"../narrow.cameramodel\""),
            std::string::npos);
  // A path the rig file gave as absolute stays so.
  rig.cameras[0].cameramodel_absolute = true;
  EXPECT_NE(RigToJson(rig, "x").find(Quoted(rig.cameras[0].cameramodel_path)), std::string::npos);
}

}  // namespace
}  // namespace svms
