// The approach's view 6 seen by a two-camera rig, for the tests of the rig's fused pose (the
// RigPoseEstimator and the C API's): the renders of each camera, the rig and the truth.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <vector>

#include "svms/camera/camera_rig.h"
#include "svms/datasets/datasets.h"
#include "svms/fusion/object_pose.h"
#include "svms/marker/model_io.h"
#include "svms/sim/render.h"
#include "svms/sim/truth.h"

namespace svms_testing {
using namespace svms;

// The approach's view 6 (the module at 4.5 m) seen by a two-camera rig whose frame is that
// view's camera frame: a narrow camera (20 degrees across) 0.25 m to the left and a wide one
// (60 degrees) 0.25 m to the right, 640 x 480 pinholes, each turned toward the module. Each
// camera's image is the simulator's render of the approach scene through that camera, with the
// true pose; rig_from_module is the truth.
struct TwoCameraApproach {
  using Vec3 = Eigen::Vector3d;
  Layout layout;
  CameraRig rig;
  std::vector<cv::Mat> images;
  Pose rig_from_module;
  TwoCameraApproach() {
    Dataset dataset;
    EXPECT_TRUE(MakeDataset("approach", DatasetOptions{1, true}, &dataset).ok());
    for (const auto& [name, text] : dataset.files)
      if (name == "true_layout.json") {
        ModelFile f;
        EXPECT_TRUE(ParseModelJson(text, name, &f).ok());
        layout = f.layout;
      }
    const Scene& approach = dataset.scenes[0].second;
    const View& view = approach.views.at(6);
    const Pose rig_from_world = view.cam_from_world;
    // The module's origin in the rig frame, from the scene itself.
    for (const SceneObject& o : approach.objects)
      if (o.name == "module") rig_from_module = rig_from_world * o.world_from_object;
    const double fov_deg[2] = {20, 60};
    const char* names[2] = {"narrow", "wide"};
    for (int c = 0; c < 2; ++c) {
      RigCamera camera;
      camera.name = names[c];
      camera.camera = CameraModel::Pinhole(320 / std::tan(fov_deg[c] / 2 * M_PI / 180), 640, 480);
      const Vec3 eye(c == 0 ? -0.25 : 0.25, 0, 0);
      camera.rig_from_cam = LookAt(eye, rig_from_module.tvec, Vec3(0, -1, 0)).Inverse();
      Scene scene = approach;
      scene.camera = camera.camera;
      View v = view;
      v.cam_from_world = camera.rig_from_cam.Inverse() * rig_from_world;
      scene.views = {v};
      std::unique_ptr<Renderer> renderer;
      EXPECT_TRUE(Renderer::Create(scene, &renderer).ok());
      images.push_back(renderer->Expose(renderer->RenderRadiance(0), 0));
      // The truth the renderer reports agrees with the rig's.
      for (const auto& [name, pose] : ComputeTruth(*renderer, 0).cam_from_object) {
        if (name == "module") {
          EXPECT_LT(PoseError(rig_from_module, camera.rig_from_cam * pose).norm(), 1e-9);
        }
      }
      rig.cameras.push_back(camera);
    }
  }
};

}  // namespace svms_testing
