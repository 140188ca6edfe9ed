#include "svms/sim/truth.h"

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "svms/base/json_fields.h"
#include "svms/camera/camera_json.h"
#include "svms/camera/photometric.h"

namespace svms {
namespace {

using nlohmann::json;

PointTruth Point(const Renderer& r, int view, const Pose& cam_from_world,
                 const Eigen::Vector3d& p_world) {
  const Scene& s = r.scene();
  PointTruth t;
  t.pixel.setConstant(NAN);
  const Eigen::Vector3d p_cam = cam_from_world * p_world;
  Eigen::Vector2d px;
  t.projects = p_cam.z() > 0 && s.camera.Project(p_cam, &px) && px.allFinite();
  if (t.projects) {
    t.pixel = px;
    t.in_image = px.x() >= -0.5 && px.y() >= -0.5 && px.x() <= s.camera.width() - 0.5 &&
                 px.y() <= s.camera.height() - 0.5;
  }
  const Eigen::Vector3d centre = cam_from_world.Inverse().tvec;
  const Eigen::Vector3d to = p_world - centre;
  const double dist = to.norm();
  if (auto hit = r.Cast(view, centre, to)) t.occluded = hit->t < dist * (1 - 1e-9) - 1e-7;
  t.in_shadow = r.InSunShadow(view, p_world);
  return t;
}

json PoseJ(const Pose& p) { return json_fields::PoseJson(p); }

json PointJ(const PointTruth& t) {
  json px = t.projects ? json{t.pixel.x(), t.pixel.y()} : json();
  return {{"pixel", px},
          {"in_image", t.in_image},
          {"occluded", t.occluded},
          {"in_shadow", t.in_shadow}};
}

}  // namespace

bool MarkerTruth::fully_visible() const {
  if (!facing || bits_outside > 0 || bits_occluded > 0) return false;
  for (const PointTruth& c : corners)
    if (!c.in_image || c.occluded) return false;
  return true;
}

ViewTruth ComputeTruth(const Renderer& r, int view) {
  const Scene& s = r.scene();
  ViewTruth vt;
  vt.name = s.views[view].name;
  vt.cam_from_world = s.views[view].cam_from_world;
  for (const SceneObject& o : s.objects) {
    const Pose cam_from_object = vt.cam_from_world * o.world_from_object;
    vt.cam_from_object.emplace_back(o.name, cam_from_object);
    for (const SceneMarker& sm : o.markers) {
      const Pose world_from_marker = o.world_from_object * sm.object_from_marker;
      std::vector<MarkerModel> models{sm.model};
      if (auto inner = sm.model.InnerModel()) models.push_back(*inner);
      for (size_t k = 0; k < models.size(); ++k) {
        const MarkerModel& m = models[k];
        MarkerTruth mt;
        mt.id = m.id;
        mt.nested_in = k == 0 ? -1 : sm.model.id;
        mt.object = o.name;
        mt.cam_from_marker = vt.cam_from_world * world_from_marker;
        const auto corners = m.Corners();
        for (int c = 0; c < 4; ++c)
          mt.corners[c] = Point(r, view, vt.cam_from_world, world_from_marker * corners[c]);
        if (auto tip = m.PostTip()) {
          mt.has_tip = true;
          mt.tip = Point(r, view, vt.cam_from_world, world_from_marker * *tip);
        }
        mt.family = sm.print.family;
        std::vector<Eigen::Vector2d> cells = sm.print.DataCellCentres(m.size);
        if (!sm.print.peer())
          for (int b = 0; b < 44; ++b) cells.push_back(m.BitCellCentre(b));
        for (const Eigen::Vector2d& c : cells) {
          const PointTruth pt = Point(r, view, vt.cam_from_world,
                                      world_from_marker * Eigen::Vector3d(c.x(), c.y(), 0));
          mt.bits_occluded += pt.occluded;
          mt.bits_in_shadow += pt.in_shadow;
          mt.bits_outside += !pt.in_image;
        }
        double side = 0, shortest = 1e300;
        for (int c = 0; c < 4; ++c) {
          const double l = (mt.corners[c].pixel - mt.corners[(c + 1) % 4].pixel).norm();
          side += l;
          shortest = std::min(shortest, l);
        }
        mt.side_px = std::isfinite(side) ? side / 4 : 0;
        mt.min_side_px = std::isfinite(shortest) ? shortest : 0;
        // Facing: the camera centre is on the front (+z) side of the marker plane.
        const Eigen::Vector3d cam_in_marker = mt.cam_from_marker.Inverse().tvec;
        mt.facing = cam_in_marker.z() > 0;
        vt.markers.push_back(mt);
      }
    }
  }
  return vt;
}

std::string TruthToJson(const Scene& s, const std::vector<ViewTruth>& views) {
  const std::string extension = ViewFileExtension(s.sensor);
  json root;
  root["type"] = "svms.truth";
  root["camera"] = json_fields::CameraJson(s.camera);
  root["seed"] = s.seed;
  root["rays_per_pixel"] = s.sensor.rays_per_pixel;
  root["edge_rays_per_pixel"] = s.sensor.edge_rays_per_pixel;
  root["bits"] = s.sensor.bits;
  // How the images store light (docs/simulator.md, "Camera pipeline and sensor profiles"): a
  // reader turns a value v into linear light as response^-1((v - black) / (white - black)).
  const Sensor& se = s.sensor;
  Response response;  // the one spelling of the response ("sRGB" -> "srgb")
  const bool parsed =
      se.response.rfind("table:", 0) != 0 && Response::Parse(se.response, &response);
  json photometry = {{"response", parsed ? response.Name() : se.response},
                     {"bits", se.bits},
                     {"signal_bits", se.signal_bits > 0 ? se.signal_bits : se.bits},
                     {"black_level", se.black_level},
                     {"white_level", se.white_level()},
                     {"bayer", se.bayer},
                     {"format", se.format}};
  if (!se.bayer.empty()) photometry["channel_gain"] = se.channel_gain;
  if (se.format == "jpeg") photometry["jpeg_quality"] = se.jpeg_quality;
  root["photometry"] = photometry;
  json jv = json::array();
  for (const ViewTruth& v : views) {
    json objects = json::object();
    for (const auto& [name, pose] : v.cam_from_object) objects[name] = PoseJ(pose);
    json markers = json::array();
    for (const MarkerTruth& m : v.markers) {
      json corners = json::array();
      for (const PointTruth& c : m.corners) corners.push_back(PointJ(c));
      json jm = {{"id", m.id},
                 {"object", m.object},
                 {"cam_from_marker", PoseJ(m.cam_from_marker)},
                 {"corners", corners},
                 {"tip", m.has_tip ? PointJ(m.tip) : json()},
                 {"bits_occluded", m.bits_occluded},
                 {"bits_in_shadow", m.bits_in_shadow},
                 {"bits_outside", m.bits_outside},
                 {"side_px", m.side_px},
                 {"min_side_px", m.min_side_px},
                 {"facing", m.facing},
                 {"fully_visible", m.fully_visible()}};
      if (m.nested_in >= 0) jm["nested_in"] = m.nested_in;
      if (m.family != "svms44") jm["family"] = m.family;
      markers.push_back(jm);
    }
    jv.push_back({{"name", v.name},
                  {"image", v.name + extension},
                  {"cam_from_world", PoseJ(v.cam_from_world)},
                  {"cam_from_object", objects},
                  {"markers", markers}});
  }
  root["views"] = jv;
  return root.dump(1) + "\n";
}

}  // namespace svms
