#include "svms/peers/compare_scenes.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include "svms/base/random_draws.h"
#include "svms/datasets/datasets.h"
#include "svms/peers/peer_tags.h"

namespace svms {
namespace {

using Vec3 = Eigen::Vector3d;
constexpr double kDeg = M_PI / 180;

Sun SunAt(double elevation_deg, double azimuth_deg) {
  const double e = elevation_deg * kDeg, a = azimuth_deg * kDeg;
  return Sun{Vec3(std::cos(e) * std::cos(a), std::cos(e) * std::sin(a), std::sin(e)), 1.0, 0.53};
}

// The standard sensor (with o.edge_rays_per_pixel) and camera of the datasets (taken from the
// range set, so they stay the same as everything else measured on it), sun from elevation 50, a
// little ambient; one marker of side `size` on a dark plate 4 sides wide (its front at world z = 0,
// marker frame = world).
Scene Base(const CompareOptions& o, uint64_t salt) {
  Dataset range;
  MakeDataset("range", DatasetOptions{o.seed, true}, &range);
  Scene s = range.scenes.front().second;
  s.seed = o.seed * 1000 + salt;
  s.sensor.edge_rays_per_pixel = o.edge_rays_per_pixel;
  s.objects.clear();
  s.views.clear();
  s.occluders.clear();
  s.light = Lighting{};
  s.light.sun = SunAt(50, 30);
  s.light.ambient = 0.06;
  SceneObject plate;
  plate.name = "plate";
  plate.shape = SceneObject::Shape::kBox;
  plate.size = Vec3(4 * o.marker_size, 4 * o.marker_size, 0.02);
  plate.world_from_object.tvec = Vec3(0, 0, -0.01);
  plate.material.reflectance = 0.15;
  SceneMarker m;
  m.model = MarkerModel::Standard(1, o.marker_size, o.post_height_fraction * o.marker_size);
  m.object_from_marker.tvec = Vec3(0, 0, 0.01);  // on the plate's front face
  plate.markers.push_back(m);
  s.objects.push_back(plate);
  return s;
}

std::string Name(const char* fmt, double a, int b) {
  char buf[64];
  std::snprintf(buf, sizeof buf, fmt, a, b);
  return buf;
}

// A camera `D` from the marker centre, `tilt` off its normal toward azimuth `az`, rolled by
// `roll`, aimed so the marker lands `offset_px` (x, y) from the image centre.
Pose Viewpoint(double D, double tilt, double az, double roll, const Eigen::Vector2d& offset_px,
               double f) {
  const Vec3 eye =
      D * Vec3(std::sin(tilt) * std::cos(az), std::sin(tilt) * std::sin(az), std::cos(tilt));
  const Pose look = LookAt(eye, Vec3::Zero(), Vec3(std::sin(roll), std::cos(roll), 0));
  // Turn the camera so the marker appears off-centre: a small rotation about its own axes.
  const Pose turn{Vec3(offset_px.y() / f, -offset_px.x() / f, 0), Vec3::Zero()};
  return turn * look;
}

}  // namespace

std::vector<CompareSweep> MakeCompareSweeps(const CompareOptions& o) {
  std::vector<CompareSweep> out;
  const double s = o.marker_size;
  const double f = 30.0 * 16.0 / 0.432;  // the range camera's focal length, px
  std::mt19937_64 rng(o.seed * 6151 + 11);
  std::uniform_real_distribution<double> u(-1, 1), u01(0, 1);

  {  // Size: the black square (peer: outer black edge) from 8 to 120 px, tilt up to 20 deg.
    CompareSweep w{"size", "", Base(o, 1)};
    const std::vector<int> px =
        o.quick ? std::vector<int>{10, 16, 30, 60}
                : std::vector<int>{8, 10, 12, 14, 16, 18, 20, 23, 26, 30, 35, 40, 50, 60, 80, 120};
    const int per = o.quick ? 1 : std::max(1, o.size_views);
    for (int p : px)
      for (int k = 0; k < per; ++k) {
        // Draws in a fixed order whatever the compiler (random_draws.h): offset, roll, azimuth,
        // tilt.
        const Eigen::Vector2d offset = 300 * DrawVector2(u, rng);
        const Eigen::Vector2d az_roll = M_PI * DrawVector2(u, rng);
        const double tilt = 20 * kDeg * u01(rng);
        const Pose cam = Viewpoint(f * s / p, tilt, az_roll.x(), az_roll.y(), offset, f);
        w.scene.views.push_back(View{Name("size_%03.0fpx_%02d", p, k), cam});
      }
    w.description = "black square (peer: outer black edge) " + std::to_string(px.front()) + " to " +
                    std::to_string(px.back()) + " px, tilt 0-20 deg, " + std::to_string(per) +
                    " views per size";
    out.push_back(std::move(w));
  }
  {  // Viewing angle: 50 px head-on, 0 to 80 degrees off the normal.
    CompareSweep w{"angle", "", Base(o, 2)};
    const std::vector<int> angles =
        o.quick ? std::vector<int>{0, 45, 70}
                : std::vector<int>{0, 10, 20, 30, 40, 50, 55, 60, 65, 70, 75, 80};
    const int per = o.quick ? 1 : 6;
    for (int a : angles)
      for (int k = 0; k < per; ++k) {
        const Eigen::Vector2d offset = 200 * DrawVector2(u, rng);  // fixed order, as above
        const Eigen::Vector2d az_roll = M_PI * DrawVector2(u, rng);
        const Pose cam = Viewpoint(f * s / 50, a * kDeg, az_roll.x(), az_roll.y(), offset, f);
        w.scene.views.push_back(View{Name("angle_%02.0fdeg_%02d", a, k), cam});
      }
    w.description = "50 px head-on, 0 to " + std::to_string(angles.back()) +
                    " deg off the marker normal, " + std::to_string(per) + " views per angle";
    out.push_back(std::move(w));
  }
  {  // Occlusion: a grey ball 2-3 mm above the marker, radius 0.1-0.5 side, 60 px.
    CompareSweep w{"occlusion", "", Base(o, 3)};
    const int n = o.quick ? 4 : 80;
    for (int k = 0; k < n; ++k) {
      const Eigen::Vector2d offset = 150 * DrawVector2(u, rng);  // fixed order, as above
      const Eigen::Vector2d az_roll = M_PI * DrawVector2(u, rng);
      const double tilt = 15 * kDeg * u01(rng);
      const Pose cam = Viewpoint(f * s / 60, tilt, az_roll.x(), az_roll.y(), offset, f);
      View v{Name("occl_%.0f_%04d", 60, k), cam};
      std::vector<Occluder> occ;
      if (k % 5 != 0) {  // every fifth view unoccluded
        Occluder ball;
        ball.shape = Occluder::Shape::kBlob;
        const double r = s * (0.1 + 0.4 * u01(rng));
        ball.size = Vec3(r, r, r);
        const Eigen::Vector2d c = s * DrawVector2(u, rng);
        ball.world_from_occluder.tvec = Vec3(c.x(), c.y(), r + 0.0025);
        ball.reflectance = 0.3;
        occ.push_back(ball);
      }
      v.occluders = occ;
      w.scene.views.push_back(v);
    }
    w.description =
        "60 px, a grey ball (radius 0.1-0.5 side) just above the marker at a random "
        "place within one side of its centre, " +
        std::to_string(n) + " views";
    out.push_back(std::move(w));
  }
  {  // Sun and shadow: 75 px, a fixed camera; the sun moves, a bar's shadow edge crosses.
    CompareSweep w{"sun", "", Base(o, 4)};
    const Pose cam = Viewpoint(f * s / 75, 20 * kDeg, 0.7, 0.1, Eigen::Vector2d(40, -30), f);
    const std::vector<int> elev =
        o.quick ? std::vector<int>{10, 45} : std::vector<int>{5, 10, 15, 20, 30, 45, 60, 75, 90};
    for (int e : elev)
      for (int a : (o.quick ? std::vector<int>{45} : std::vector<int>{45, 135, 225, 315})) {
        View v{Name(e <= 15 ? "lowsun_e%02.0f_a%03d" : "sun_e%02.0f_a%03d", e, a), cam};
        v.sun = SunAt(e, a);
        v.occluders = std::vector<Occluder>{};
        w.scene.views.push_back(v);
      }
    const Sun edge_sun = SunAt(40, 200);
    const int edges = o.quick ? 1 : 11;
    for (int i = 0; i < edges; ++i) {
      // A bar 0.3 m above the plate whose shadow edge crosses the marker at x.
      const double x = edges == 1 ? 0.1 * s : s * (-0.55 + 1.1 * i / (edges - 1));
      Occluder bar;
      bar.size = Vec3(0.4, 3.0, 0.02);
      bar.reflectance = 0.3;
      bar.world_from_occluder.tvec =
          Vec3(x - 0.2, 0, 0) + (0.3 / edge_sun.to_sun_world.z()) * edge_sun.to_sun_world;
      View v{Name("edge_%.0fdeg_%02d", 40, i), cam};
      v.sun = edge_sun;
      v.occluders = std::vector<Occluder>{bar};
      w.scene.views.push_back(v);
    }
    for (int i = 0; i < (o.quick ? 1 : 4); ++i) {
      // The whole marker in the shadow of a panel: lit by the ambient alone.
      Occluder roof;
      roof.size = Vec3(1.5, 1.5, 0.02);
      const Sun sun = SunAt(30 + 15 * i, 60 + 70 * i);
      roof.world_from_occluder.tvec = (0.8 / sun.to_sun_world.z()) * sun.to_sun_world;
      View v{Name("shadow_e%.0f_%02d", 30 + 15 * i, i), cam};
      v.sun = sun;
      v.occluders = std::vector<Occluder>{roof};
      w.scene.views.push_back(v);
    }
    w.description =
        "75 px, fixed camera 20 deg off-axis: sun elevation 5-90 deg (low sun: <= 15), "
        "a shadow edge across the marker, the whole marker in shadow";
    out.push_back(std::move(w));
  }
  return out;
}

Status PeerScene(const Scene& scene, const std::string& family, Scene* out) {
  Scene s = scene;
  if (family != "svms44") {
    const int count = PeerIdCount(family);
    if (count == 0) return Status::Error("unknown peer family \"" + family + "\"");
    int k = 0;
    for (SceneObject& o : s.objects)
      for (SceneMarker& m : o.markers) {
        SceneMarker peer;
        if (Status st = AsPeerMarker(m, family, (7 + 37 * k++) % count, &peer); !st) return st;
        m = peer;
      }
  }
  *out = std::move(s);
  return Status::Ok();
}

}  // namespace svms
