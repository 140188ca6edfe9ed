// Scene-simulator benchmarks. Target: one 1024x1024 image at 16 rays per pixel in at most 1 s
// on one core (Renderer::RenderRadiance alone; Create unprojects the pixel grid once and is
// measured separately). Run:
//   build/bin/svms_bench_render --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
//
// The scene: a 1 x 1 x 2 m box 2.85 m away, covering 43 % of the frame (40 % with the OPENCV8
// lens), seen from above one of its vertical edges so two side faces and the top are visible;
// 8 markers of three sizes on those faces (posts, one dual, one concave well), a sun at 40
// degrees elevation with its 0.53 degree disc (posts cast shadows on the faces), ambient 0.05
// and the procedural earth behind the box. Pinhole f = 1100 px, and the same with an OPENCV8
// lens.
#include <benchmark/benchmark.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdlib>
#include <memory>
#include <string>

#include "svms/sim/render.h"
#include "svms/sim/scene.h"

namespace {

using Eigen::Vector3d;

constexpr int kSize = 1024;
constexpr double kFocal = 1100;

svms::CameraModel Camera(bool distorted) {
  if (!distorted) return svms::CameraModel::Pinhole(kFocal, kSize, kSize);
  svms::CameraModel cam;
  const svms::Status s =
      svms::CameraModel::Create("LENSMODEL_OPENCV8",
                                {kFocal, kFocal + 4, (kSize - 1) / 2.0 + 3, (kSize - 1) / 2.0 - 2,
                                 -0.28, 0.09, 0.001, -0.0007, -0.01, 0.02, 0.003, 0.001},
                                kSize, kSize, &cam);
  if (!s.ok()) std::abort();
  return cam;
}

// object_from_marker for a marker centred at (a, b) on the face of a box (half extents `half`)
// whose outward normal is +axis `axis` (0, 1, 2): marker z = the face normal, the marker's y
// along the face's "up" (object +z on the side faces, +y on the top).
svms::Pose OnFace(const Vector3d& half, int axis, double a, double b) {
  Eigen::Matrix3d R;  // columns: marker x, y, z in the object frame
  Vector3d t;
  switch (axis) {
    case 0:  // +x face: marker x = object y, y = object z
      R.col(0) = Vector3d::UnitY();
      R.col(1) = Vector3d::UnitZ();
      t = Vector3d(half.x(), a, b);
      break;
    case 1:  // +y face: marker x = object -x, y = object z
      R.col(0) = -Vector3d::UnitX();
      R.col(1) = Vector3d::UnitZ();
      t = Vector3d(-a, half.y(), b);
      break;
    default:  // +z face (top): marker x = object x, y = object y
      R.col(0) = Vector3d::UnitX();
      R.col(1) = Vector3d::UnitY();
      t = Vector3d(a, b, half.z());
      break;
  }
  R.col(2) = R.col(0).cross(R.col(1));
  return svms::Pose::FromRotation(R, t);
}

svms::SceneMarker Marker(const svms::MarkerModel& m, const svms::Pose& object_from_marker) {
  svms::SceneMarker sm;
  sm.model = m;
  sm.object_from_marker = object_from_marker;
  return sm;
}

// A camera at `eye` looking at `target` with world +z up in the image.
svms::Pose LookAt(const Vector3d& eye, const Vector3d& target) {
  const Vector3d f = (target - eye).normalized();
  const Vector3d right = f.cross(Vector3d::UnitZ()).normalized();
  const Vector3d down = f.cross(right);
  Eigen::Matrix3d world_from_cam;
  world_from_cam << right, down, f;
  const Eigen::Matrix3d R = world_from_cam.transpose();
  return svms::Pose::FromRotation(R, -R * eye);
}

svms::Scene BenchScene(bool distorted) {
  svms::Scene s;
  s.seed = 7;
  s.camera = Camera(distorted);
  s.sensor.rays_per_pixel = 16;
  s.sensor.read_noise = 4;
  s.sensor.shot_noise = true;
  const double elev = 40 * M_PI / 180, az = 25 * M_PI / 180;
  s.light.sun = svms::Sun{
      Vector3d(std::cos(elev) * std::cos(az), std::cos(elev) * std::sin(az), std::sin(elev)), 1.0,
      0.53};
  s.light.ambient = 0.05;
  s.background.kind = svms::Background::Kind::kEarth;

  svms::SceneObject box;
  box.name = "box";
  box.shape = svms::SceneObject::Shape::kBox;
  box.size = Vector3d(1, 1, 2);
  box.world_from_object.rvec = Vector3d(0, 0, 0.1);  // turned a little about the vertical
  box.material.reflectance = 0.35;
  const Vector3d half = 0.5 * box.size;
  // +x face (1 m wide, 2 m tall): the dual marker high up, three small ones below.
  svms::MarkerModel dual = svms::MarkerModel::Standard(101, 0.432, 0.432 / 4);
  dual.AddInner(102, 0.108);
  box.markers.push_back(Marker(dual, OnFace(half, 0, 0, 0.5)));
  box.markers.push_back(
      Marker(svms::MarkerModel::Standard(103, 0.2, 0.05), OnFace(half, 0, -0.2, -0.5)));
  box.markers.push_back(
      Marker(svms::MarkerModel::Standard(104, 0.1, 0.025), OnFace(half, 0, 0.25, -0.4)));
  box.markers.push_back(
      Marker(svms::MarkerModel::Standard(105, 0.1, 0.025), OnFace(half, 0, 0.25, -0.75)));
  // +y face: a concave 0.2 m marker, a 0.432 m one, a 0.1 m one.
  box.markers.push_back(
      Marker(svms::MarkerModel::Standard(106, 0.2, -0.05), OnFace(half, 1, -0.2, 0.6)));
  box.markers.push_back(
      Marker(svms::MarkerModel::Standard(107, 0.432, 0.108), OnFace(half, 1, 0, -0.45)));
  box.markers.push_back(
      Marker(svms::MarkerModel::Standard(108, 0.1, 0.025), OnFace(half, 1, 0.3, 0.65)));
  // Top face.
  box.markers.push_back(Marker(svms::MarkerModel::Standard(109, 0.2, 0.05), OnFace(half, 2, 0, 0)));
  s.objects.push_back(box);

  // 2.85 m from the box centre, 45 degrees round from its +x face, 25 degrees above it.
  const double ce = 25 * M_PI / 180, ca = 50 * M_PI / 180, dist = 2.85;
  const Vector3d eye =
      dist * Vector3d(std::cos(ce) * std::cos(ca), std::cos(ce) * std::sin(ca), std::sin(ce));
  svms::View view;
  view.name = "v0";
  view.cam_from_world = LookAt(eye, Vector3d(0, 0, 0));
  s.views.push_back(view);
  return s;
}

std::unique_ptr<svms::Renderer> MakeRenderer(const svms::Scene& s) {
  std::unique_ptr<svms::Renderer> r;
  if (!svms::Renderer::Create(s, &r).ok()) std::abort();
  return r;
}

// Renderer::Create: unprojects the (W+1) x (H+1) pixel-corner grid and builds the earth.
void BM_RendererCreate(benchmark::State& state) {
  const svms::Scene s = BenchScene(state.range(0) != 0);
  for (auto _ : state) benchmark::DoNotOptimize(MakeRenderer(s));
}
BENCHMARK(BM_RendererCreate)->ArgName("opencv8")->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

// One 1024x1024 radiance image at 16 rays per pixel (the target: at most 1000 ms).
void BM_RenderRadiance(benchmark::State& state) {
  const svms::Scene s = BenchScene(state.range(0) != 0);
  const auto r = MakeRenderer(s);
  for (auto _ : state) benchmark::DoNotOptimize(r->RenderRadiance(0));
  state.SetLabel(std::to_string(s.sensor.rays_per_pixel) + " rays/px");
}
BENCHMARK(BM_RenderRadiance)->ArgName("opencv8")->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

// The sensor model on that image: shot and read noise, 8-bit quantisation.
void BM_Expose(benchmark::State& state) {
  const svms::Scene s = BenchScene(false);
  const auto r = MakeRenderer(s);
  const cv::Mat radiance = r->RenderRadiance(0);
  for (auto _ : state) benchmark::DoNotOptimize(r->Expose(radiance, 0));
}
BENCHMARK(BM_Expose)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
