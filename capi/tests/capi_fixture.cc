// Writes what the C API tests need into DIR: true.cameramodel and true_layout.json of the
// quick approach dataset, the same camera as cal.cameramodel with a covariance sidecar (the
// intrinsics' sigma 0.5 px for the core, 1e-4 for the distortion), and two rendered frames as raw
// 8-bit pixels (frame_N.raw, width x height bytes, row-major) with their true cam_from_object
// (frame_N.txt: rvec and tvec). For the tests of several objects per frame: the approach's view 6
// with a second object beside the module (svms_testing/two_objects.h), as raw pixels (pair.raw)
// and as a PGM (pair.pgm, linear values), the second object's layout (fixture_layout.json), a
// layout repeating the module's ID 13 (clash_layout.json), and both true poses (pair.txt: the
// module's rvec and tvec, then the fixture's).
#include <filesystem>
#include <fstream>
#include <iostream>

#include "svms/camera/camera_covariance.h"
#include "svms/datasets/datasets.h"
#include "svms/marker/model_io.h"
#include "svms/sim/render.h"
#include "svms/sim/truth.h"
#include "svms_testing/two_objects.h"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: svms_capi_fixture DIR\n";
    return 2;
  }
  const std::string dir = argv[1];
  std::filesystem::create_directories(dir);
  svms::Dataset d;
  if (!svms::MakeDataset("approach", svms::DatasetOptions{1, true}, &d).ok()) return 1;
  const svms::Scene& scene = d.scenes.at(0).second;
  if (svms::Status s = scene.camera.Write(dir + "/true.cameramodel"); !s) {
    std::cerr << s.message() << "\n";
    return 1;
  }
  svms::CameraModel calibrated = scene.camera;
  const int n = static_cast<int>(calibrated.intrinsics().size());
  Eigen::VectorXd sigma = Eigen::VectorXd::Constant(n, 1e-4);
  sigma.head<4>().setConstant(0.5);
  if (svms::Status s =
          calibrated.set_intrinsics_covariance_factor(sigma.asDiagonal().toDenseMatrix());
      !s)
    return 1;
  if (!calibrated.Write(dir + "/cal.cameramodel").ok() ||
      !svms::WriteCovarianceSidecar(svms::CovarianceSidecarPath(dir + "/cal.cameramodel"),
                                    calibrated, 0.05, 20)
           .ok())
    return 1;
  // A sidecar whose covariance overflows (a factor of 1e300: finite, but L L^T is not).
  sigma(0) = 1e300;
  if (!calibrated.set_intrinsics_covariance_factor(sigma.asDiagonal().toDenseMatrix()).ok() ||
      !calibrated.Write(dir + "/overflow.cameramodel").ok() ||
      !svms::WriteCovarianceSidecar(svms::CovarianceSidecarPath(dir + "/overflow.cameramodel"),
                                    calibrated, 0.05, 20)
           .ok())
    return 1;
  for (const auto& [name, text] : d.files) {
    if (name != "true_layout.json") continue;
    std::ofstream(dir + "/" + name) << text;
    // The same layout with a second "object_from_marker" in its first entry (last one would win).
    std::string dup = text;
    const size_t at = dup.find("\"object_from_marker\"");
    if (at == std::string::npos) return 1;
    dup.insert(at, "\"object_from_marker\": {\"rvec\": [0, 0, 0], \"tvec\": [14, 0, 0]}, ");
    std::ofstream(dir + "/dup_layout.json") << dup;
  }
  std::unique_ptr<svms::Renderer> r;
  if (!svms::Renderer::Create(scene, &r).ok()) return 1;
  for (int view : {0, 11}) {
    const cv::Mat img = r->Expose(r->RenderRadiance(view), view);
    if (img.type() != CV_8UC1 || !img.isContinuous()) return 1;
    const std::string base = dir + "/frame_" + std::to_string(view);
    std::ofstream(base + ".raw", std::ios::binary)
        .write(reinterpret_cast<const char*>(img.data), img.total());
    const svms::ViewTruth t = svms::ComputeTruth(*r, view);
    for (const auto& [object, pose] : t.cam_from_object)
      if (object == "module") {
        std::ofstream f(base + ".txt");
        f.precision(17);
        f << pose.rvec.transpose() << " " << pose.tvec.transpose() << "\n";
      }
  }
  // A lone flat 0.1 m marker (no post, ID 206) 17 degrees off-axis at 5.5 m, 20 px in a
  // 320 x 240 pinhole camera: its two planar poses cannot be told apart, and the detector keeps
  // the wrong one (lone.cameramodel, lone_layout.json, lone.raw, lone.txt: width, height, the
  // true cam_from_object's rvec and tvec; lone_scene.json for svms render).
  const svms::CameraModel lone_camera = svms::CameraModel::Pinhole(1111.1, 320, 240);
  svms::MarkerModel lone = svms::MarkerModel::Standard(206, 0.1, 0.02);
  lone.post.reset();
  const svms::Scene lone_scene =
      svms::LoneMarkerScene(lone_camera, lone,
                            svms::LookAt(Eigen::Vector3d(0, -1.608, 5.26), Eigen::Vector3d::Zero(),
                                         Eigen::Vector3d(0, 1, 0.2)));
  if (!lone_camera.Write(dir + "/lone.cameramodel").ok() ||
      !svms::WriteTextFile(dir + "/lone_layout.json",
                           svms::LayoutToJson(svms::LoneMarkerLayout(lone)))
           .ok() ||
      !svms::Renderer::Create(lone_scene, &r).ok())
    return 1;
  if (!svms::WriteTextFile(dir + "/lone_scene.json", svms::SceneToJson(lone_scene)).ok()) return 1;
  const cv::Mat lone_image = r->Expose(r->RenderRadiance(0), 0);
  std::ofstream(dir + "/lone.raw", std::ios::binary)
      .write(reinterpret_cast<const char*>(lone_image.data), lone_image.total());
  for (const auto& [object, pose] : svms::ComputeTruth(*r, 0).cam_from_object) {
    std::ofstream f(dir + "/lone.txt");
    f.precision(17);
    f << lone_image.cols << " " << lone_image.rows << " " << pose.rvec.transpose() << " "
      << pose.tvec.transpose() << "\n";
  }
  // Two objects in one frame.
  svms::Layout clash = svms_testing::FixtureLayout();
  clash.name = "clash";
  clash.markers[1].marker = svms::MarkerModel::Standard(13, 0.12, 0.02);
  if (!svms::WriteTextFile(dir + "/fixture_layout.json",
                           svms::LayoutToJson(svms_testing::FixtureLayout()))
           .ok() ||
      !svms::WriteTextFile(dir + "/clash_layout.json", svms::LayoutToJson(clash)).ok() ||
      !svms::Renderer::Create(svms_testing::WithFixture(scene), &r).ok())
    return 1;
  const int pv = svms_testing::kTwoObjectsView;
  const cv::Mat pair = r->Expose(r->RenderRadiance(pv), pv);
  if (pair.type() != CV_8UC1 || !pair.isContinuous()) return 1;
  std::ofstream(dir + "/pair.raw", std::ios::binary)
      .write(reinterpret_cast<const char*>(pair.data), pair.total());
  {
    std::ofstream pgm(dir + "/pair.pgm", std::ios::binary);
    pgm << "P5\n" << pair.cols << " " << pair.rows << "\n255\n";
    pgm.write(reinterpret_cast<const char*>(pair.data), pair.total());
  }
  {
    std::ofstream f(dir + "/pair.txt");
    f.precision(17);
    for (const char* object : {"module", "fixture"})
      for (const auto& [name, pose] : svms::ComputeTruth(*r, pv).cam_from_object)
        if (name == object) f << pose.rvec.transpose() << " " << pose.tvec.transpose() << "\n";
  }
  std::cout << "svms_capi_fixture: wrote " << dir << "\n";
  return 0;
}
