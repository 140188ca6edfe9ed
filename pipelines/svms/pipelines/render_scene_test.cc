#include "svms/pipelines/render_scene.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "svms/camera/camera.h"
#include "svms/geometry/pose.h"
#include "svms/marker/marker_model.h"
#include "svms/pipelines/exit_codes.h"
#include "svms/sim/scene.h"
#include "svms_testing/scratch_dir.h"

namespace svms {
namespace {

namespace fs = std::filesystem;

// A camera at (x, y, distance) looking along the world's -z (camera y down = world -y).
Pose LookDown(double distance, double x, double y) {
  Pose p;
  p.rvec = Eigen::Vector3d(M_PI, 0, 0);
  p.tvec = -(p.Rotation() * Eigen::Vector3d(x, y, distance));
  return p;
}

// A 0.1 m marker on a grey plate, two views from 1.2 m (about 80 px through a 160 x 120
// pinhole of f = 1000 px), behind 0.7 px of defocus, with shot and read noise: every stage a twin
// render shares or not (the fine grid, the noise draw, the response, the codec).
Scene SmallScene() {
  Scene s;
  s.seed = 5;
  s.camera = CameraModel::Pinhole(1000, 160, 120);
  s.sensor.defocus_sigma_px = 0.7;
  s.sensor.rays_per_pixel = 4;
  s.sensor.edge_rays_per_pixel = 16;
  s.light.ambient = 1.0;
  SceneObject plate;
  plate.name = "plate";
  plate.shape = SceneObject::Shape::kPlane;
  plate.size = Eigen::Vector3d(1, 1, 0);
  plate.material.reflectance = 0.3;
  SceneMarker sm;
  sm.model = MarkerModel::Standard(7, 0.1, 0.02);
  plate.markers.push_back(sm);
  s.objects.push_back(plate);
  for (int v = 0; v < 2; ++v)
    s.views.push_back(View{"view_" + std::to_string(v), LookDown(1.2, 0.03 * v, 0.02)});
  return s;
}

std::string Bytes(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// Every file of `dir`, by name.
std::vector<std::string> Names(const fs::path& dir) {
  std::vector<std::string> out;
  for (const auto& e : fs::directory_iterator(dir)) out.push_back(e.path().filename().string());
  std::sort(out.begin(), out.end());
  return out;
}

TEST(RenderSceneThrough, WritesWhatSeparateRendersWriteByteForByte) {
  svms_testing::ScratchDir tmp("svms_render_scene_test");
  const Scene scene = SmallScene();
  std::vector<SensorOutput> outputs(3, SensorOutput{scene.sensor, ""});
  outputs[0].sensor.response = "gamma:2.2";
  outputs[0].out_dir = tmp.File("gamma");
  outputs[1].out_dir = tmp.File("linear");
  outputs[2].sensor.response = "srgb";
  outputs[2].sensor.format = "jpeg";
  outputs[2].sensor.defocus_sigma_px = 1.2;  // another blur of the same fine-grid light
  outputs[2].out_dir = tmp.File("jpeg");
  ASSERT_EQ(RenderSceneThrough(scene, outputs, "small", 2, true), kExitOk);
  for (const SensorOutput& o : outputs) {
    Scene alone = scene;
    alone.sensor = o.sensor;
    const std::string dir = o.out_dir + "_alone";
    ASSERT_EQ(RenderScene(alone, "small", dir, 1, false, true), kExitOk);
    const std::vector<std::string> names = Names(o.out_dir);
    ASSERT_EQ(names, Names(dir)) << o.out_dir;
    EXPECT_EQ(names.size(), 3u) << o.out_dir;  // two views and truth.json
    for (const std::string& n : names)
      EXPECT_TRUE(Bytes(fs::path(o.out_dir) / n) == Bytes(fs::path(dir) / n))
          << o.out_dir << "/" << n;
  }
  // The outputs differ from each other: each went through its own pipeline.
  EXPECT_NE(Bytes(fs::path(outputs[0].out_dir) / "view_0.png"),
            Bytes(fs::path(outputs[1].out_dir) / "view_0.png"));
}

TEST(RenderSceneThrough, ASensorCastingOtherRaysIsRefusedBeforeAnythingIsWritten) {
  svms_testing::ScratchDir tmp("svms_render_scene_test");
  const Scene scene = SmallScene();
  std::vector<SensorOutput> outputs(2, SensorOutput{scene.sensor, ""});
  outputs[0].out_dir = tmp.File("a");
  outputs[1].out_dir = tmp.File("b");
  for (auto change :
       {+[](Sensor* s) { s->rays_per_pixel = 9; }, +[](Sensor* s) { s->edge_rays_per_pixel = 0; },
        +[](Sensor* s) { s->motion_blur = 0.5; }, +[](Sensor* s) { s->defocus_sigma_px = 0; }}) {
    std::vector<SensorOutput> bad = outputs;
    change(&bad[1].sensor);
    testing::internal::CaptureStderr();
    EXPECT_EQ(RenderSceneThrough(scene, bad, "small", 1, true), kExitBadInput);
    const std::string err = testing::internal::GetCapturedStderr();
    EXPECT_NE(err.find("casts other rays than the scene's"), std::string::npos) << err;
    EXPECT_FALSE(fs::exists(outputs[0].out_dir));
  }
  // A sensor CheckSensor refuses, one directory named twice, and no output at all.
  std::vector<SensorOutput> bad = outputs;
  bad[1].sensor.bits = 12;
  EXPECT_EQ(RenderSceneThrough(scene, bad, "small", 1, true), kExitBadInput);
  bad = outputs;
  bad[1].out_dir = outputs[0].out_dir + "/.";
  testing::internal::CaptureStderr();
  EXPECT_EQ(RenderSceneThrough(scene, bad, "small", 1, true), kExitBadInput);
  const std::string err = testing::internal::GetCapturedStderr();
  EXPECT_NE(err.find("named twice"), std::string::npos) << err;
  EXPECT_EQ(RenderSceneThrough(scene, {}, "small", 1, true), kExitBadInput);
  EXPECT_FALSE(fs::exists(outputs[0].out_dir));
  EXPECT_FALSE(fs::exists(outputs[1].out_dir));
}

}  // namespace
}  // namespace svms
