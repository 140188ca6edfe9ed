#include "svms/datasets/datasets.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <set>

#include "svms/base/random_draws.h"
#include "svms/codec/svms44.h"
#include "svms/marker/model_io.h"

namespace svms {
namespace {

using Vec3 = Eigen::Vector3d;

constexpr double kDeg = M_PI / 180;

Sensor StandardSensor() {
  Sensor s;
  s.bits = 8;
  s.exposure = 15000;  // white in full sun: about 180 of 255
  s.full_well = 18000;
  s.read_noise = 4;
  s.shot_noise = true;
  s.rays_per_pixel = 16;
  // 16 jittered rays give an edge pixel's coverage to 5 % of the edge's contrast, several
  // times the shot noise of a sunlit white; 256 on edges bring it under 1 %, as in the compare
  // scenes, so calibration, test and comparison see one simulator (docs/simulator.md).
  s.edge_rays_per_pixel = 256;
  return s;
}

Lighting Sunlight(double elevation_deg, double azimuth_deg) {
  Lighting l;
  l.sun = Sun{Vec3(std::cos(elevation_deg * kDeg) * std::cos(azimuth_deg * kDeg),
                   std::cos(elevation_deg * kDeg) * std::sin(azimuth_deg * kDeg),
                   std::sin(elevation_deg * kDeg)),
              1.0, 0.53};
  l.ambient = 0.04;
  return l;
}

// A dual marker whose post (height inner / 4, radius inner / 20) suits its inner marker.
MarkerModel Dual(int id, double size, int inner_id, double inner_size) {
  MarkerModel m = MarkerModel::Standard(id, size, 0.25 * inner_size);
  m.AddInner(inner_id, inner_size);
  m.post->radius = m.post->tip_radius = inner_size / 20;
  return m;
}

// A scene with the standard sensor.
Scene NewScene(uint64_t seed, const CameraModel& camera, const Lighting& light) {
  Scene s;
  s.seed = seed;
  s.camera = camera;
  s.sensor = StandardSensor();
  s.light = light;
  return s;
}

SceneMarker Printed(const MarkerModel& m, const Pose& object_from_marker) {
  SceneMarker sm;
  sm.model = m;
  sm.object_from_marker = object_from_marker;
  return sm;
}

// A dark plate (spacecraft skin) of side `side`, 2 cm thick, front face at z = 0.
SceneObject Plate(double side, double reflectance = 0.15) {
  SceneObject o;
  o.name = "plate";
  o.shape = SceneObject::Shape::kBox;
  o.size = Vec3(side, side, 0.02);
  o.world_from_object.tvec = Vec3(0, 0, -0.01);
  o.material.reflectance = reflectance;
  return o;
}

// A marker centred on the plate's front face (world z = 0), turned by `spin`.
Pose OnPlate(double x, double y, double spin) {
  Pose p;
  p.rvec = Vec3(0, 0, spin);
  p.tvec = Vec3(x, y, 0.01);  // object frame: the box is centred 1 cm behind the face
  return p;
}

std::string Name(const char* prefix, int index) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%s%04d", prefix, index);
  return buf;
}

Dataset Range(const DatasetOptions& o) {
  Dataset d;
  d.name = "range";
  Scene s = NewScene(o.seed, RangeCamera(), Sunlight(50, 30));
  SceneObject plate = Plate(1.2);
  const MarkerModel dual = Dual(1, 0.432, 2, 0.108);
  plate.markers.push_back(Printed(dual, OnPlate(0, 0, 0)));
  s.objects.push_back(plate);
  // The dual marker's place on the plate (the object "plate"): what `svms bench pose --object
  // plate --reference 1` reads as the truth's layout.
  Layout truth_layout;
  truth_layout.name = "range plate (true)";
  truth_layout.markers.push_back({dual, OnPlate(0, 0, 0), std::nullopt, std::nullopt});
  std::mt19937_64 rng(o.seed);
  std::uniform_real_distribution<double> u(-1, 1);
  const int distances = o.quick ? 6 : 24, per = o.quick ? 1 : 4;
  int k = 0;
  for (int i = 0; i < distances; ++i) {
    const double D = 0.8 * std::pow(16.0 / 0.8, static_cast<double>(i) / (distances - 1));
    for (int j = 0; j < per; ++j) {
      // Nearly head-on (tilt up to 5 degrees), the marker near the image centre.
      const double tilt = 5 * kDeg * std::abs(u(rng)), az = M_PI * u(rng);
      const Vec3 eye =
          D * Vec3(std::sin(tilt) * std::cos(az), std::sin(tilt) * std::sin(az), std::cos(tilt));
      // Vectors of draws through DrawVector*: a fixed order whatever the compiler.
      const Eigen::Vector2d t = DrawVector2(u, rng);
      const Vec3 target = Vec3(t.x(), t.y(), 0) * 0.05 * std::min(D, 4.0);
      const Eigen::Vector2d w = DrawVector2(u, rng);
      const Vec3 up(std::sin(0.3 * w.x()), std::cos(0.3 * w.y()), 0);
      s.views.push_back(View{Name("range_", k++), LookAt(eye, target, up)});
    }
  }
  d.scenes.emplace_back("", s);
  d.files.emplace_back("true_layout.json", LayoutToJson(truth_layout));
  return d;
}

Dataset Angle(const DatasetOptions& o) {
  Dataset d;
  d.name = "angle";
  Scene s = NewScene(o.seed, RangeCamera(), Sunlight(60, 200));
  s.light.ambient = 0.15;
  SceneObject plate = Plate(1.5);
  plate.markers.push_back(Printed(MarkerModel::Standard(3, 0.2, 0.05), OnPlate(0, 0, 0.2)));
  s.objects.push_back(plate);
  const std::vector<double> angles =
      o.quick ? std::vector<double>{0, 45, 70}
              : std::vector<double>{0, 10, 20, 30, 40, 50, 60, 65, 70, 75};
  const std::vector<double> dists =
      o.quick ? std::vector<double>{1.5} : std::vector<double>{1.5, 4, 8};
  const std::vector<double> azimuths =
      o.quick ? std::vector<double>{0} : std::vector<double>{0, 135};
  int k = 0;
  for (double D : dists)
    for (double az : azimuths)
      for (double a : angles) {
        const Vec3 eye = D * Vec3(std::sin(a * kDeg) * std::cos(az * kDeg),
                                  std::sin(a * kDeg) * std::sin(az * kDeg), std::cos(a * kDeg));
        s.views.push_back(View{Name("angle_", k++), LookAt(eye, Vec3::Zero(), Vec3(0, 1, 0.3))});
      }
  d.scenes.emplace_back("", s);
  return d;
}

// Many small markers: a 5 x 5 grid of 0.04 m markers (posts 1 cm) on a dark plate, seen from
// 1.7 to 6.2 m, head-on and tilted 30-45 degrees, so that their squares span about 7 to 26 px
// (f = 1111 px). The range set has about a dozen markers per size bucket below 20 px; this one
// has hundreds, enough to compare detection rates and corner RMS between sensor profiles.
Dataset Small(const DatasetOptions& o) {
  Dataset d;
  d.name = "small";
  Scene s = NewScene(o.seed, RangeCamera(), Sunlight(55, 40));
  s.light.ambient = 0.1;
  SceneObject plate = Plate(0.8);
  const double size = 0.04, pitch = 0.12;
  for (int r = 0, id = 10; r < 5; ++r)
    for (int c = 0; c < 5; ++c, ++id) {
      // Turned by a different angle each, so that the sides meet the pixel rows at many angles.
      const double spin = std::fmod(17.0 * id, 90.0) * kDeg;
      plate.markers.push_back(Printed(MarkerModel::Standard(id, size, 0.25 * size),
                                      OnPlate(pitch * (c - 2), pitch * (2 - r), spin)));
    }
  s.objects.push_back(plate);
  std::mt19937_64 rng(o.seed * 31 + 7);
  std::uniform_real_distribution<double> u(-1, 1), u01(0, 1);
  const int distances = o.quick ? 3 : 12;
  int k = 0;
  for (int i = 0; i < distances; ++i) {
    const double D = 1.7 * std::pow(6.2 / 1.7, static_cast<double>(i) / (distances - 1));
    for (bool tilted : {false, true}) {
      if (o.quick && tilted != (i % 2 == 1)) continue;
      const double tilt = (tilted ? 30 + 15 * u01(rng) : 5 * u01(rng)) * kDeg;
      const double az = M_PI * u(rng);
      const Vec3 eye =
          D * Vec3(std::sin(tilt) * std::cos(az), std::sin(tilt) * std::sin(az), std::cos(tilt));
      const Eigen::Vector2d w = DrawVector2(u, rng);
      const Vec3 up(std::sin(0.3 * w.x()), std::cos(0.3 * w.y()), 0);
      s.views.push_back(View{Name("small_", k++), LookAt(eye, Vec3::Zero(), up)});
    }
  }
  d.scenes.emplace_back("", s);
  return d;
}

Dataset SunSweep(const DatasetOptions& o) {
  Dataset d;
  d.name = "sun";
  Scene s = NewScene(o.seed, RangeCamera(), Sunlight(45, 45));
  SceneObject plate = Plate(1.5);
  plate.markers.push_back(Printed(MarkerModel::Standard(4, 0.2, 0.05), OnPlate(0, 0, 0)));
  s.objects.push_back(plate);
  const Pose cam = LookAt(Vec3(0.25, -0.2, 2.0), Vec3::Zero(), Vec3(0, 1, 0));
  int k = 0;
  auto add = [&](double elev, double az, std::optional<std::vector<Occluder>> occ) {
    View v{Name("sun_", k++), cam};
    v.sun = Sunlight(elev, az).sun;
    v.occluders = std::move(occ);
    s.views.push_back(v);
  };
  for (int e = 5; e <= 90; e += o.quick ? 40 : 5) add(e, 45, std::vector<Occluder>{});
  for (int a = 0; a < 360; a += o.quick ? 180 : 30) add(30, a, std::vector<Occluder>{});
  // A shadow edge across the marker: a long bar 0.6 m above the plate, between sun and marker.
  const Lighting sl = Sunlight(40, 200);
  const Vec3 sdir = sl.sun->to_sun_world;
  for (int i = 0; i < (o.quick ? 1 : 8); ++i) {
    const double x = -0.18 + 0.36 * i / 7.0;  // where the shadow edge crosses the marker
    Occluder bar;
    bar.size = Vec3(0.3, 3.0, 0.02);
    bar.reflectance = 0.3;
    // The bar's edge at x casts its shadow edge onto the plate at x (bar centred 0.15 beyond).
    const Vec3 on_plate(x - 0.15, 0, 0);
    bar.world_from_occluder.tvec = on_plate + (0.6 / sdir.z()) * sdir;
    View v{Name("sun_", k++), cam};
    v.sun = sl.sun;
    v.occluders = std::vector<Occluder>{bar};
    s.views.push_back(v);
  }
  d.scenes.emplace_back("", s);
  return d;
}

Dataset Occlusion(const DatasetOptions& o) {
  Dataset d;
  d.name = "occlusion";
  Scene s = NewScene(o.seed, RangeCamera(), Sunlight(55, 120));
  s.light.ambient = 0.1;
  const MarkerModel m = MarkerModel::Standard(5, 0.2, 0.05);
  SceneObject plate = Plate(1.0);
  plate.markers.push_back(Printed(m, OnPlate(0, 0, 0)));
  s.objects.push_back(plate);
  const uint64_t word = Svms44::Codeword(m.id);
  std::mt19937_64 rng(o.seed * 7919 + 3);
  int k = 0;
  const std::vector<int> counts =
      o.quick ? std::vector<int>{0, 3, 5, 10} : std::vector<int>{0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10};
  for (int covered : counts) {
    for (int trial = 0; trial < (o.quick ? 1 : 10); ++trial) {
      // `covered` cells, each under a patch of the opposite colour 3 mm above it: every one a
      // flipped bit.
      std::vector<int> cells(44);
      for (int i = 0; i < 44; ++i) cells[i] = i;
      std::shuffle(cells.begin(), cells.end(), rng);
      std::vector<Occluder> patches;
      for (int c = 0; c < covered; ++c) {
        const Eigen::Vector2d cc = m.BitCellCentre(cells[c]);
        Occluder p;
        p.size = Vec3(1.04 * m.cell_size, 1.04 * m.cell_size, 0.001);
        p.world_from_occluder.tvec = Vec3(cc.x(), cc.y(), 0.003);
        p.reflectance = ((word >> cells[c]) & 1) ? 0.04 : 0.85;
        patches.push_back(p);
      }
      std::uniform_real_distribution<double> u(-1, 1);
      const Vec3 e = DrawVector3(u, rng);
      const Vec3 eye(0.3 * e.x(), 0.3 * e.y(), 1.6 + 0.4 * e.z());
      View v{Name("occl_", k++), LookAt(eye, Vec3::Zero(), Vec3(u(rng), 1, 0))};
      v.occluders = patches;
      s.views.push_back(v);
    }
  }
  d.scenes.emplace_back("", s);
  return d;
}

// The mockup module: a 1 x 1 x 2 m box (front, docking face at z = +1) with 8 markers of three
// sizes, a dual and a concave one, in the mockup's scene (distorted camera, sun, Earth below).
// Used by the survey set (mockup) and the approach path (approach); *truth_layout gets the
// true marker poses in the box's frame.
Scene MockupModuleScene(uint64_t seed, Layout* truth_layout) {
  Scene s = NewScene(seed, DistortedCamera(), Sunlight(40, 20));
  s.light.earthshine = Sun{Vec3(0, 0, -1), 0.08, 0};
  s.background.kind = Background::Kind::kEarth;
  s.background.brightness = 0.7;
  SceneObject box;
  box.name = "module";
  box.shape = SceneObject::Shape::kBox;
  box.size = Vec3(1, 1, 2);  // the front (docking) face is z = +1
  box.material.reflectance = 0.35;
  box.material.specular = 0.3;
  box.material.shininess = 80;
  const Vec3 half = 0.5 * box.size;
  const MarkerModel dual = Dual(10, 0.432, 11, 0.108);
  struct Place {
    MarkerModel m;
    int axis, sign;
    double u, v, spin;
  };
  const std::vector<Place> places = {
      {dual, 2, +1, 0, 0, 0},
      {MarkerModel::Standard(12, 0.2, 0.05), 0, +1, 0.0, 0.55, 0},
      {MarkerModel::Standard(13, 0.1, 0.025), 0, +1, 0.25, 0.0, 0.3},
      {MarkerModel::Standard(14, 0.2, -0.04), 0, +1, -0.1, -0.45, 0},  // concave
      {MarkerModel::Standard(15, 0.2, 0.05), 1, +1, 0.0, 0.55, 0.1},
      {MarkerModel::Standard(16, 0.1, 0.025), 1, +1, -0.25, 0.05, 0},
      {MarkerModel::Standard(17, 0.2, 0.05), 0, -1, 0.0, 0.5, 0},
      {MarkerModel::Standard(18, 0.1, 0.025), 1, -1, 0.2, 0.5, 0},
  };
  truth_layout->name = "mockup (true)";
  truth_layout->markers.clear();
  for (const Place& p : places) {
    const Pose pose = OnBoxFace(half, p.axis, p.sign, p.u, p.v, p.spin);
    box.markers.push_back(Printed(p.m, pose));
    truth_layout->markers.push_back(LayoutEntry{p.m, pose, std::nullopt, std::nullopt});
  }
  s.objects.push_back(box);
  return s;
}

Dataset Mockup(const DatasetOptions& o) {
  Dataset d;
  d.name = "mockup";
  Layout truth_layout;
  Scene s = MockupModuleScene(o.seed, &truth_layout);
  // A survey: views all around the module at 1.8 to 3.2 m, in eight sectors of azimuth about
  // its long axis, from 15 to 55 degrees above its equator toward the front face, so that every
  // marker is seen at 30 px or more from several directions and neighbouring faces are seen
  // together (a connected view graph). The approach path for fused poses is another dataset.
  std::mt19937_64 rng(o.seed * 31 + 1);
  std::uniform_real_distribution<double> u(-1, 1), u01(0, 1);
  const int n = o.quick ? 8 : 200;
  for (int i = 0; i < n; ++i) {
    const double az = (i % 8) * M_PI / 4 + 0.25 * u(rng);
    const double el = (15 + 40 * u01(rng)) * kDeg;
    const double D = 1.8 + 1.4 * u01(rng);
    const Vec3 centre(0, 0, 0.3);
    const Vec3 eye =
        centre + D * Vec3(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
    const Vec3 target = centre + 0.15 * DrawVector3(u, rng);
    const Eigen::Vector2d w = DrawVector2(u, rng);
    View v{Name("mockup_", i), LookAt(eye, target, Vec3(0.3 * w.x(), 0.3 * w.y(), 1))};
    const Eigen::Vector2d sun = DrawVector2(u01, rng);  // elevation, azimuth
    v.sun = Sunlight(25 + 30 * sun.x(), 360 * sun.y()).sun;
    s.views.push_back(v);
  }
  d.scenes.emplace_back("", s);
  d.files.emplace_back("true.cameramodel", "");  // written by the caller from the scene camera
  d.files.emplace_back("true_layout.json", LayoutToJson(truth_layout));
  return d;
}

// The approach: a chaser closing on the module's docking face from 12 m to 1.3 m along a line
// 35 degrees off the face normal (so that the front face and two side faces are in view), with
// a slow spiral of the line of sight and a roll that drifts, one frame every 0.1 s. The camera
// looks at the dual marker with an aim error of a few centimetres. The module is the mockup's,
// the same markers at the same places, so a survey of the mockup set is the layout to use.
Dataset Approach(const DatasetOptions& o) {
  Dataset d;
  d.name = "approach";
  Layout truth_layout;
  Scene s = MockupModuleScene(o.seed, &truth_layout);
  std::mt19937_64 rng(o.seed * 57 + 3);
  std::normal_distribution<double> g(0, 1);
  const int n = o.quick ? 12 : 500;
  const Vec3 face_centre(0, 0, 1);
  const Vec3 dir = Vec3(0.45, 0.35, 1).normalized();  // about 35 degrees off the z axis
  Vec3 aim_error = Vec3::Zero();
  for (int i = 0; i < n; ++i) {
    const double f = n == 1 ? 0 : static_cast<double>(i) / (n - 1);
    const double D = 12.0 * std::pow(1.3 / 12.0, f);  // geometric: equal steps in log range
    const double spiral = 6 * M_PI * f;
    const Vec3 side1 = dir.cross(Vec3::UnitY()).normalized(), side2 = dir.cross(side1);
    const Vec3 wobble = 0.08 * D * (std::cos(spiral) * side1 + std::sin(spiral) * side2);
    const Vec3 eye = face_centre + D * dir + wobble;
    aim_error = 0.9 * aim_error + 0.01 * DrawVector3(g, rng);
    const double roll = 0.4 * std::sin(2 * M_PI * f) + 0.02 * g(rng);
    View v;
    v.name = Name("approach_", i);
    v.cam_from_world =
        LookAt(eye, face_centre + aim_error, Vec3(std::sin(roll), std::cos(roll), 0));
    s.views.push_back(v);
  }
  d.scenes.emplace_back("", s);
  d.files.emplace_back("true.cameramodel", "");
  d.files.emplace_back("true_layout.json", LayoutToJson(truth_layout));
  return d;
}

Dataset Calibration(const DatasetOptions& o) {
  Dataset d;
  d.name = "calibration";
  const CameraModel cam = DistortedCamera();
  // The marker board: 6 x 5 flat markers of 0.06 m on white, pitch 0.135 m.
  const int cols = 6, rows = 5;
  const double size = 0.06, pitch = 2 * size + 0.015;
  SceneObject board;
  board.name = "board";
  board.shape = SceneObject::Shape::kPlane;
  board.size = Vec3(cols * pitch + 0.06, rows * pitch + 0.06, 0);
  board.material.reflectance = 0.85;
  Layout layout;
  layout.name = "calibration board 6x5, 0.06 m";
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) {
      Pose p;
      p.tvec = Vec3((c - 0.5 * (cols - 1)) * pitch, (0.5 * (rows - 1) - r) * pitch, 0);
      const MarkerModel m = MarkerModel::Standard(100 + r * cols + c, size, 0);
      board.markers.push_back(Printed(m, p));
      layout.markers.push_back(LayoutEntry{m, p, std::nullopt, std::nullopt});
    }
  // The chessboard of the comparison: 10 x 8 squares of 0.075 m with a white border.
  SceneObject chess;
  chess.name = "chessboard";
  chess.shape = SceneObject::Shape::kPlane;
  chess.size = Vec3(10 * 0.075 + 0.1, 8 * 0.075 + 0.1, 0);
  chess.material.pattern.kind = Pattern::Kind::kChecker;
  chess.material.pattern.period = 0.075;
  chess.material.pattern.cols = 10;
  chess.material.pattern.rows = 8;
  chess.material.pattern.low = 0.04;
  chess.material.pattern.high = 0.85;

  Scene base;
  base.seed = o.seed;
  base.camera = cam;
  base.sensor = StandardSensor();
  base.light.ambient = 0.9;  // an evenly lit lab
  std::mt19937_64 rng(o.seed * 101 + 7);
  std::uniform_real_distribution<double> u(-1, 1);
  const int n = o.quick ? 4 : 40;
  for (int i = 0; i < n; ++i) {
    // Cover the image: aim the board's centre at points spread over the field of view, tilted
    // up to 45 degrees, 1.3 to 2.4 m away.
    const double D = 1.3 + 1.1 * (0.5 + 0.5 * u(rng));
    const double tilt = 45 * kDeg * std::sqrt(0.5 + 0.5 * u(rng)), az = M_PI * u(rng);
    const Vec3 eye =
        D * Vec3(std::sin(tilt) * std::cos(az), std::sin(tilt) * std::sin(az), std::cos(tilt));
    const Pose look = LookAt(eye, Vec3::Zero(), Vec3(u(rng), 1, 0));
    // Then turn the camera so the board lands off-centre (toward the image corners).
    const Eigen::Vector2d t = DrawVector2(u, rng);
    const Pose turn{Vec3(0.16 * t.x(), 0.16 * t.y(), 0), Vec3::Zero()};
    base.views.push_back(View{Name("calib_", i), turn * look});
  }
  // Then eight views that put the board into the image corners (the views above never reach
  // them, so a lens model fitted to them only extrapolates there): 2.2 and 2.7 m away,
  // 20 degrees off the board's normal, the camera turned by 0.27 / 0.30 rad about its x and y
  // axes toward each corner. The whole board and the whole chessboard stay in view, their
  // outermost marker corners and squares 40-70 px from the image corner (checked with
  // mrcal.project through this camera).
  if (!o.quick) {
    int k = n;
    for (const double D : {2.2, 2.7})
      for (const int su : {-1, 1})
        for (const int sv : {-1, 1}) {
          const double tilt = 20 * kDeg, az = std::atan2(-sv, -su), th = D < 2.5 ? 0.27 : 0.30;
          const Vec3 eye = D * Vec3(std::sin(tilt) * std::cos(az), std::sin(tilt) * std::sin(az),
                                    std::cos(tilt));
          const Pose look = LookAt(eye, Vec3::Zero(), Vec3(0, 1, 0));
          const Pose turn{Vec3(-sv * th, su * th, 0), Vec3::Zero()};
          base.views.push_back(View{Name("calib_", k++), turn * look});
        }
  }
  Scene with_board = base, with_chess = base;
  with_board.objects = {board};
  with_chess.objects = {chess};
  d.scenes.emplace_back("board", with_board);
  d.scenes.emplace_back("chessboard", with_chess);
  d.files.emplace_back("true.cameramodel", "");
  d.files.emplace_back("board_layout.json", LayoutToJson(layout));
  return d;
}

Dataset Clutter(const DatasetOptions& o) {
  Dataset d;
  d.name = "clutter";
  Scene s = NewScene(o.seed, DistortedCamera(), Sunlight(50, 70));
  s.light.ambient = 0.1;
  s.background.kind = Background::Kind::kEarth;
  std::mt19937_64 rng(o.seed * 977 + 5);
  std::uniform_real_distribution<double> u(-1, 1), u01(0, 1);
  const Pattern::Kind kinds[] = {Pattern::Kind::kUniform, Pattern::Kind::kChecker,
                                 Pattern::Kind::kStripes, Pattern::Kind::kGrid,
                                 Pattern::Kind::kText,    Pattern::Kind::kNoise};
  for (int i = 0; i < 60; ++i) {
    SceneObject ob;
    ob.name = Name("clutter_", i);
    ob.shape = u01(rng) < 0.5 ? SceneObject::Shape::kBox : SceneObject::Shape::kPlane;
    const Vec3 size = DrawVector3(u01, rng), t = DrawVector3(u, rng), r = DrawVector3(u, rng);
    ob.size = Vec3(0.1 + 0.7 * size.x(), 0.1 + 0.7 * size.y(), 0.05 + 0.5 * size.z());
    ob.world_from_object.tvec = Vec3(2.5 * t.x(), 2.5 * t.y(), 0.8 * t.z());
    ob.world_from_object.rvec = Vec3(0.6 * r.x(), 0.6 * r.y(), M_PI * r.z());
    ob.material.reflectance = 0.05 + 0.8 * u01(rng);
    Pattern& p = ob.material.pattern;
    p.kind = kinds[i % 6];
    p.period = 0.01 + 0.08 * u01(rng);
    p.low = 0.03 + 0.1 * u01(rng);
    p.high = 0.6 + 0.3 * u01(rng);
    p.line = 0.2 * p.period;
    p.seed = rng();
    ob.material.specular = u01(rng) < 0.3 ? 0.5 : 0;
    s.objects.push_back(ob);
  }
  const int n = o.quick ? 5 : 50;
  for (int i = 0; i < n; ++i) {
    const Vec3 t = DrawVector3(u, rng);
    const Vec3 target(2 * t.x(), 2 * t.y(), 0.3 * t.z());
    const double D = 1.5 + 3 * u01(rng);
    const Eigen::Vector2d e = DrawVector2(u, rng);
    const Vec3 eye = target + D * Vec3(0.5 * e.x(), 0.5 * e.y(), 1).normalized();
    s.views.push_back(View{Name("clutter_", i), LookAt(eye, target, Vec3(u(rng), 1, 0))});
  }
  d.scenes.emplace_back("", s);
  return d;
}

// The pictures of docs/simulator.md: one marker in sun, in shadow, with a shadow edge and
// under a low sun; under the ring light with retro-reflective white; and the dual marker at
// 0.8, 7 and 16 m through a 256 x 256 window of the range camera (same focal length).
Dataset Gallery(const DatasetOptions& o) {
  Dataset d;
  d.name = "gallery";
  Scene s = NewScene(o.seed, CameraModel::Pinhole(900, 512, 512), Sunlight(50, 210));
  s.background.kind = Background::Kind::kEarth;
  SceneObject plate = Plate(1.0);
  plate.markers.push_back(Printed(MarkerModel::Standard(21, 0.2, 0.06), OnPlate(0, 0, 0)));
  s.objects.push_back(plate);
  const Pose cam = LookAt(Vec3(0.15, -0.25, 1.0), Vec3::Zero(), Vec3(0, 1, 0));
  const Vec3 to_sun = s.light.sun->to_sun_world;
  View sun{"sun", cam};
  View shadow{"shadow", cam};
  Occluder roof;  // a panel high up between sun and marker, out of the camera's view
  roof.size = Vec3(1.2, 1.2, 0.02);
  roof.world_from_occluder.tvec = (1.5 / to_sun.z()) * to_sun;
  shadow.occluders = std::vector<Occluder>{roof};
  View edge{"shadow_edge", cam};
  Occluder bar;
  bar.size = Vec3(0.6, 3.0, 0.02);
  bar.world_from_occluder.tvec = Vec3(-0.27, 0, 0) + (0.8 / to_sun.z()) * to_sun;
  edge.occluders = std::vector<Occluder>{bar};
  View low{"low_sun", cam};
  low.sun = Sunlight(12, 150).sun;
  s.views = {sun, shadow, edge, low};
  d.scenes.emplace_back("lighting", s);

  Scene ring = s;
  ring.objects[0].markers[0].retro = true;
  ring.light.ring_light = 0.02;  // retro white: 0.85 * 50 * 0.02 / 1.1 m^2 = 0.7
  ring.light.narrow_band_filter = true;
  ring.views = {View{"ring_light", cam}};
  d.scenes.emplace_back("ring", ring);

  Scene dual =
      NewScene(o.seed, CameraModel::Pinhole(30.0 * 16.0 / 0.432, 256, 256), Sunlight(50, 30));
  SceneObject p2 = Plate(1.2);
  const MarkerModel m = Dual(1, 0.432, 2, 0.108);
  p2.markers.push_back(Printed(m, OnPlate(0, 0, 0)));
  dual.objects.push_back(p2);
  for (double D : {0.8, 7.0, 16.0}) {
    char name[32];
    std::snprintf(name, sizeof name, "dual_%04.1fm", D);
    dual.views.push_back(
        View{name, LookAt(Vec3(0.02 * D, 0.03 * D, D), Vec3::Zero(), Vec3(0.1, 1, 0))});
  }
  d.scenes.emplace_back("dual", dual);
  return d;
}

}  // namespace

Scene LoneMarkerScene(const CameraModel& camera, const MarkerModel& marker,
                      const Pose& cam_from_world) {
  Scene s;
  s.seed = 3;
  s.camera = camera;
  s.light.sun = Sun{Vec3(0.3, -0.2, 1).normalized(), 1.0, 0.53};
  s.light.ambient = 0.08;
  s.background.kind = Background::Kind::kEarth;
  SceneObject plate;
  plate.name = "plate";
  plate.shape = SceneObject::Shape::kBox;
  plate.size = Vec3(2, 2, 0.02);
  plate.world_from_object.tvec = Vec3(0, 0, -0.01);
  plate.material.reflectance = 0.15;
  SceneMarker m;
  m.model = marker;
  m.object_from_marker = LoneMarkerLayout(marker).markers[0].object_from_marker;
  plate.markers.push_back(m);
  s.objects.push_back(plate);
  s.views.push_back(View{"v", cam_from_world});
  return s;
}

Layout LoneMarkerLayout(const MarkerModel& marker) {
  Layout layout;
  layout.markers.push_back(
      {marker, Pose{Vec3::Zero(), Vec3(0, 0, 0.01)}, std::nullopt, std::nullopt});
  return layout;
}

Pose LookAt(const Vec3& eye, const Vec3& target, const Vec3& up) {
  const Vec3 z = (target - eye).normalized();
  Vec3 y = -(up - up.dot(z) * z);
  if (y.norm() < 1e-9) y = z.unitOrthogonal();
  y.normalize();
  const Vec3 x = y.cross(z);
  Eigen::Matrix3d R_world_from_cam;
  R_world_from_cam << x, y, z;
  return Pose::FromRotation(R_world_from_cam.transpose(), -(R_world_from_cam.transpose() * eye));
}

Pose OnBoxFace(const Vec3& half, int axis, int sign, double u, double v, double spin) {
  const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
  const int lo = std::min(a1, a2), hi = std::max(a1, a2);
  Vec3 n = Vec3::Zero(), e1 = Vec3::Zero(), e2 = Vec3::Zero();
  n[axis] = sign;
  e1[lo] = 1;
  e2[hi] = 1;
  const Vec3 x0 = e1, y0 = n.cross(e1);
  const Vec3 x = std::cos(spin) * x0 + std::sin(spin) * y0, y = n.cross(x);
  Eigen::Matrix3d R;
  R << x, y, n;
  return Pose::FromRotation(R, half[axis] * n + u * e1 + v * e2);
}

CameraModel RangeCamera() { return CameraModel::Pinhole(30.0 * 16.0 / 0.432, 1024, 1024); }

CameraModel DistortedCamera() {
  CameraModel cam;
  const Status s = CameraModel::Create(
      "LENSMODEL_OPENCV8",
      {1111.0, 1109.0, 515.3, 508.7, -0.32, 0.12, 0.0006, -0.0004, -0.02, 0.01, 0.005, 0.001}, 1024,
      1024, &cam);
  if (!s) __builtin_trap();  // fixed, valid parameters
  return cam;
}

std::vector<std::string> DatasetNames() {
  return {"range",  "angle",    "small",       "sun",     "occlusion",
          "mockup", "approach", "calibration", "clutter", "gallery"};
}

std::string DatasetDescription(const std::string& name) {
  if (name == "range")
    return "dual marker 0.432/0.108 m, 0.8 to 16 m, 1024x1024 pinhole (0.432 m = 30 px at 16 m)";
  if (name == "angle") return "0.2 m marker, 0 to 75 degrees off-axis at 1.5, 4 and 8 m";
  if (name == "small")
    return "25 markers of 0.04 m on a plate, 1.7 to 6.2 m, head-on and tilted 30-45 degrees "
           "(about 7 to 26 px)";
  if (name == "sun")
    return "sun elevation and azimuth sweeps, post shadow, a bar's shadow edge across the marker";
  if (name == "occlusion")
    return "0 to 10 data bits covered by patches of the opposite colour (each a flipped bit)";
  if (name == "mockup")
    return "1 x 1 x 2 m module, 8 markers (3 sizes, a dual, a concave), 200 survey views all "
           "around it at 1.8-3.2 m, true layout";
  if (name == "approach")
    return "the mockup module approached from 12 m to 1.3 m, 35 degrees off its docking face's "
           "normal, 500 frames at 10 Hz, true layout";
  if (name == "calibration")
    return "a 6x5 marker board and a 10x8 chessboard, same 48 views (8 with the board in the image "
           "corners), OPENCV8 camera";
  if (name == "clutter")
    return "60 patterned boxes and planes (checker, stripes, grid, text, noise), no markers";
  if (name == "gallery")
    return "the pictures of docs/simulator.md: sun, shadow, shadow edge, ring light, dual at "
           "0.8/7/16 m";
  return "";
}

Status ApplySensorProfile(const std::string& profile, Dataset* dataset) {
  Sensor probe;
  if (Status s = ApplySensorProfile(profile, &probe); !s) return s;
  for (auto& [sub, scene] : dataset->scenes) ApplySensorProfile(profile, &scene.sensor);
  return Status::Ok();
}

Status MakeDataset(const std::string& name, const DatasetOptions& o, Dataset* out) {
  Dataset d;
  if (name == "range")
    d = Range(o);
  else if (name == "angle")
    d = Angle(o);
  else if (name == "small")
    d = Small(o);
  else if (name == "sun")
    d = SunSweep(o);
  else if (name == "occlusion")
    d = Occlusion(o);
  else if (name == "mockup")
    d = Mockup(o);
  else if (name == "approach")
    d = Approach(o);
  else if (name == "calibration")
    d = Calibration(o);
  else if (name == "clutter")
    d = Clutter(o);
  else if (name == "gallery")
    d = Gallery(o);
  else {
    std::string list;
    for (const auto& n : DatasetNames()) list += (list.empty() ? "" : ", ") + n;
    return Status::Error("dataset \"" + name + "\": expected one of " + list);
  }
  d.description = DatasetDescription(name);
  // Every set comes with its true camera (the first scene's), for the detector and the tests.
  bool has_camera = false;
  for (const auto& f : d.files) has_camera = has_camera || f.first == "true.cameramodel";
  if (!has_camera) d.files.emplace_back("true.cameramodel", "");
  // ... and the models of every marker in it (for --markers).
  std::vector<MarkerModel> models;
  std::set<int> seen;
  for (const auto& [sub, scene] : d.scenes)
    for (const SceneObject& o : scene.objects)
      for (const SceneMarker& m : o.markers)
        if (seen.insert(m.model.id).second) models.push_back(m.model);
  if (!models.empty()) d.files.emplace_back("markers.json", MarkerSetToJson(models));
  *out = std::move(d);
  return Status::Ok();
}

}  // namespace svms
