#include "svms/sim/scene.h"

#include <cmath>
#include <filesystem>
#include <set>

#include "svms/base/json_fields.h"
#include "svms/camera/camera_json.h"
#include "svms/camera/photometric.h"
#include "svms/imageio/image_io.h"
#include "svms/marker/marker_json.h"
#include "svms/marker/model_io.h"

namespace svms {
namespace {

using namespace json_fields;  // NOLINT: the field readers

PrintedTag ParsePrint(const json& j, const std::string& path);
json PrintJson(const PrintedTag& t);

Eigen::Vector3d UnitDirection(const json& j, const std::string& path, const std::string& key) {
  const Eigen::Vector3d d = Vector<3>(j, path, key);
  if (!d.allFinite() || d.norm() < 1e-12)
    throw FieldError{Join(path, key) + ": expected a nonzero direction"};
  return d.normalized();
}

Sun ParseSun(const json& j, const std::string& path) {
  CheckKeys(j, path, {"to_sun", "irradiance", "angular_diameter_deg"});
  Sun s;
  s.to_sun_world = UnitDirection(j, path, "to_sun");
  s.irradiance = NumberIn(j, path, "irradiance", 0, 1e6);
  if (j.contains("angular_diameter_deg"))
    s.angular_diameter_deg = NumberIn(j, path, "angular_diameter_deg", 0, 20);
  return s;
}

json SunJson(const Sun& s) {
  return {{"to_sun", {s.to_sun_world(0), s.to_sun_world(1), s.to_sun_world(2)}},
          {"irradiance", s.irradiance},
          {"angular_diameter_deg", s.angular_diameter_deg}};
}

Pattern ParsePattern(const json& j, const std::string& path) {
  CheckKeys(j, path, {"kind", "period", "low", "high", "line", "squares", "seed"});
  Pattern p;
  const std::string kind = String(j, path, "kind");
  static const std::pair<const char*, Pattern::Kind> kKinds[] = {
      {"uniform", Pattern::Kind::kUniform}, {"checker", Pattern::Kind::kChecker},
      {"stripes", Pattern::Kind::kStripes}, {"grid", Pattern::Kind::kGrid},
      {"text", Pattern::Kind::kText},       {"noise", Pattern::Kind::kNoise}};
  bool found = false;
  for (const auto& [name, k] : kKinds) {
    if (kind == name) {
      p.kind = k;
      found = true;
    }
  }
  if (!found)
    throw FieldError{Join(path, "kind") +
                     ": expected uniform, checker, stripes, grid, text or noise, got \"" + kind +
                     "\""};
  if (j.contains("period")) p.period = NumberIn(j, path, "period", 1e-6, 1e6);
  if (j.contains("low")) p.low = NumberIn(j, path, "low", 0, 1);
  if (j.contains("high")) p.high = NumberIn(j, path, "high", 0, 1);
  if (j.contains("line")) p.line = NumberIn(j, path, "line", 0, 1e6);
  if (j.contains("squares")) {
    const Eigen::Vector2d sq = Vector<2>(j, path, "squares");
    if (sq.minCoeff() < 2 || sq.maxCoeff() > 1000 || sq != sq.array().round().matrix())
      throw FieldError{Join(path, "squares") + ": expected two whole numbers from 2 to 1000"};
    p.cols = static_cast<int>(sq.x());
    p.rows = static_cast<int>(sq.y());
  }
  if (j.contains("seed")) {
    if (!j["seed"].is_number_unsigned())
      Fail(Join(path, "seed"), "a non-negative integer", j["seed"]);
    p.seed = j["seed"].get<uint64_t>();
  }
  return p;
}

json PatternJson(const Pattern& p) {
  static const char* kNames[] = {"uniform", "checker", "stripes", "grid", "text", "noise"};
  json j = {{"kind", kNames[static_cast<int>(p.kind)]},
            {"period", p.period},
            {"low", p.low},
            {"high", p.high},
            {"line", p.line},
            {"seed", p.seed}};
  if (p.cols > 0) j["squares"] = {p.cols, p.rows};
  return j;
}

Occluder ParseOccluder(const json& j, const std::string& path) {
  CheckKeys(j, path, {"shape", "world_from_occluder", "size", "reflectance"});
  Occluder o;
  const std::string shape = String(j, path, "shape");
  if (shape == "bar") {
    o.shape = Occluder::Shape::kBar;
  } else if (shape == "blob") {
    o.shape = Occluder::Shape::kBlob;
  } else {
    throw FieldError{Join(path, "shape") + ": expected \"bar\" or \"blob\", got \"" + shape + "\""};
  }
  o.world_from_occluder = ParsePose(j, path, "world_from_occluder");
  o.size = Vector<3>(j, path, "size");
  if (!(o.size.minCoeff() > 0) || !o.size.allFinite())
    throw FieldError{Join(path, "size") + ": expected three positive numbers of metres"};
  o.reflectance = NumberIn(j, path, "reflectance", 0, 1);
  return o;
}

json OccluderJson(const Occluder& o) {
  return {{"shape", o.shape == Occluder::Shape::kBar ? "bar" : "blob"},
          {"world_from_occluder", PoseJson(o.world_from_occluder)},
          {"size", {o.size(0), o.size(1), o.size(2)}},
          {"reflectance", o.reflectance}};
}

std::vector<Occluder> ParseOccluders(const json& j, const std::string& path) {
  if (!j.is_array()) Fail(path, "an array of occluders", j);
  std::vector<Occluder> out;
  for (size_t i = 0; i < j.size(); ++i)
    out.push_back(ParseOccluder(j[i], path + "[" + std::to_string(i) + "]"));
  return out;
}

std::string Resolve(const std::string& base_dir, const std::string& file) {
  const std::filesystem::path p(file);
  if (p.is_absolute() || base_dir.empty()) return file;
  return (std::filesystem::path(base_dir) / p).string();
}

CameraModel ParseCamera(const json& j, const std::string& path, const std::string& base_dir) {
  CameraModel cam;
  if (j.is_string()) {
    const std::string file = Resolve(base_dir, j.get<std::string>());
    if (Status s = CameraModel::Read(file, &cam); !s) throw FieldError{path + ": " + s.message()};
    return cam;
  }
  CheckKeys(j, path, {"lensmodel", "intrinsics", "width", "height"});
  const json& in = Required(j, path, "intrinsics");
  if (!in.is_array()) Fail(Join(path, "intrinsics"), "an array of numbers", in);
  std::vector<double> intrinsics;
  for (size_t i = 0; i < in.size(); ++i) {
    if (!in[i].is_number())
      Fail(Join(path, "intrinsics") + "[" + std::to_string(i) + "]", "a number", in[i]);
    intrinsics.push_back(in[i].get<double>());
  }
  const Status s = CameraModel::Create(String(j, path, "lensmodel"), intrinsics,
                                       Integer(j, path, "width"), Integer(j, path, "height"), &cam);
  if (!s) throw FieldError{path + ": " + s.message()};
  return cam;
}

Sensor ParseSensor(const json& j) {
  const std::string p = "sensor";
  CheckKeys(j, p,
            {"bits", "exposure", "full_well", "read_noise", "shot_noise", "defocus_sigma_px",
             "vignetting", "rays_per_pixel", "edge_rays_per_pixel", "motion_blur", "response",
             "signal_bits", "black_level", "bayer", "channel_gain", "format", "jpeg_quality"});
  Sensor s;
  if (j.contains("bits")) {
    s.bits = Integer(j, p, "bits");
    if (s.bits != 8 && s.bits != 16) Fail(Join(p, "bits"), "8 or 16", j["bits"]);
  }
  if (j.contains("exposure")) s.exposure = NumberIn(j, p, "exposure", 0, 1e12);
  if (j.contains("full_well")) s.full_well = NumberIn(j, p, "full_well", 1, 1e12);
  if (j.contains("read_noise")) s.read_noise = NumberIn(j, p, "read_noise", 0, 1e6);
  if (j.contains("shot_noise")) s.shot_noise = Boolean(j, p, "shot_noise");
  if (j.contains("defocus_sigma_px"))
    s.defocus_sigma_px = NumberIn(j, p, "defocus_sigma_px", 0, 100);
  if (j.contains("vignetting")) s.vignetting = NumberIn(j, p, "vignetting", 0, 1);
  if (j.contains("motion_blur")) s.motion_blur = NumberIn(j, p, "motion_blur", 0, 1);
  if (j.contains("rays_per_pixel")) {
    s.rays_per_pixel = Integer(j, p, "rays_per_pixel");
    const int r = static_cast<int>(std::lround(std::sqrt(std::max(0, s.rays_per_pixel))));
    if (s.rays_per_pixel < 1 || s.rays_per_pixel > 1024 || r * r != s.rays_per_pixel)
      Fail(Join(p, "rays_per_pixel"), "a square number from 1 to 1024", j["rays_per_pixel"]);
  }
  if (j.contains("edge_rays_per_pixel")) {
    s.edge_rays_per_pixel = Integer(j, p, "edge_rays_per_pixel");
    if (!ValidEdgeRays(s))
      Fail(Join(p, "edge_rays_per_pixel"), "0 (off), or a square number of at most 4096",
           j["edge_rays_per_pixel"]);
  }
  // The camera pipeline: types here, values and their combinations in CheckSensor (which
  // scenes built in code meet too). A field that would have no effect is refused, not ignored.
  if (j.contains("response")) s.response = String(j, p, "response");
  if (j.contains("signal_bits")) s.signal_bits = Integer(j, p, "signal_bits");
  if (j.contains("black_level")) s.black_level = NumberIn(j, p, "black_level", 0, 65535);
  if (j.contains("bayer")) s.bayer = String(j, p, "bayer");
  if (j.contains("format")) s.format = String(j, p, "format");
  if (j.contains("channel_gain")) {
    if (s.bayer.empty())
      throw FieldError{
          "sensor.channel_gain: expected only with a Bayer mosaic (sensor.bayer), got it with a "
          "grey sensor"};
    const Eigen::Vector3d g = Vector<3>(j, p, "channel_gain");
    s.channel_gain = {g(0), g(1), g(2)};
  }
  if (j.contains("jpeg_quality")) {
    if (s.format != "jpeg")
      throw FieldError{
          "sensor.jpeg_quality: expected only with sensor.format \"jpeg\", got it with " +
          json(s.format).dump()};
    s.jpeg_quality = Integer(j, p, "jpeg_quality");
  }
  if (Status st = CheckSensor(s); !st) throw FieldError{st.message()};
  // One spelling of sRGB (Response::Parse also reads "sRGB"); a gamma keeps its digits.
  if (s.response == "sRGB") s.response = "srgb";
  return s;
}

// The scene's "light" object into *l.
void ParseLighting(const json& j, Lighting* l_out) {
  Lighting& l = *l_out;
  const std::string p = "light";
  CheckKeys(
      j, p,
      {"sun", "ambient", "earthshine", "ring_light", "narrow_band_filter", "filter_transmission"});
  if (j.contains("sun")) l.sun = ParseSun(j["sun"], "light.sun");
  if (j.contains("earthshine")) l.earthshine = ParseSun(j["earthshine"], "light.earthshine");
  if (j.contains("ambient")) l.ambient = NumberIn(j, p, "ambient", 0, 1e6);
  if (j.contains("ring_light")) l.ring_light = NumberIn(j, p, "ring_light", 0, 1e9);
  if (j.contains("narrow_band_filter")) l.narrow_band_filter = Boolean(j, p, "narrow_band_filter");
  if (j.contains("filter_transmission"))
    l.filter_transmission = NumberIn(j, p, "filter_transmission", 0, 1);
}

// The scene's "background" object into *b (an image's path resolved against base_dir).
void ParseBackground(const json& j, const std::string& base_dir, Background* b_out) {
  Background& b = *b_out;
  const std::string p = "background";
  CheckKeys(j, p, {"kind", "brightness", "image"});
  const std::string kind = String(j, p, "kind");
  if (kind == "black") {
    b.kind = Background::Kind::kBlack;
  } else if (kind == "earth") {
    b.kind = Background::Kind::kEarth;
  } else if (kind == "image") {
    b.kind = Background::Kind::kImage;
    b.image_path = Resolve(base_dir, String(j, p, "image"));
    if (!std::filesystem::is_regular_file(b.image_path))
      throw FieldError{"background.image: " + b.image_path + ": no such file"};
  } else {
    throw FieldError{"background.kind: expected \"black\", \"earth\" or \"image\", got \"" + kind +
                     "\""};
  }
  if (j.contains("brightness")) b.brightness = NumberIn(j, p, "brightness", 0, 1e6);
}

// One marker on an object (JSON path `mp`); its IDs (and its inner marker's) must not be in
// *ids already, and are added.
SceneMarker ParseSceneMarker(const json& mj, const std::string& mp, std::set<int>* ids) {
  CheckKeys(mj, mp,
            {"marker", "object_from_marker", "black", "white", "retro", "retro_gain", "print"});
  SceneMarker m;
  m.model = ParseMarker(Required(mj, mp, "marker"), mp + ".marker", false);
  m.object_from_marker = ParsePose(mj, mp, "object_from_marker");
  if (mj.contains("black")) m.black = NumberIn(mj, mp, "black", 0, 1);
  if (mj.contains("white")) m.white = NumberIn(mj, mp, "white", 0, 1);
  if (m.white <= m.black)
    throw FieldError{mp + ".white: expected a reflectance above black (" + json(m.black).dump() +
                     ")"};
  if (mj.contains("retro")) m.retro = Boolean(mj, mp, "retro");
  if (mj.contains("retro_gain")) m.retro_gain = NumberIn(mj, mp, "retro_gain", 0, 1e6);
  if (mj.contains("print")) {
    m.print = ParsePrint(mj["print"], mp + ".print");
    if (m.print.peer() && m.model.inner)
      throw FieldError{mp + ".print.family: expected \"svms44\" for a dual marker, got \"" +
                       m.print.family + "\""};
  }
  for (int id : {m.model.id, m.model.inner ? m.model.inner->id : -1}) {
    if (id >= 0 && !ids->insert(id).second)
      throw FieldError{mp + ".marker.id: ID " + std::to_string(id) +
                       " appears twice in the scene; expected unique IDs"};
  }
  return m;
}

// One object of the scene (JSON path p), with its markers (their IDs added to *ids).
SceneObject ParseObject(const json& j, const std::string& p, std::set<int>* ids) {
  CheckKeys(j, p,
            {"name", "shape", "size", "world_from_object", "reflectance", "specular", "shininess",
             "pattern", "markers"});
  SceneObject o;
  o.name = String(j, p, "name");
  const std::string shape = String(j, p, "shape");
  if (shape == "plane") {
    o.shape = SceneObject::Shape::kPlane;
  } else if (shape == "box") {
    o.shape = SceneObject::Shape::kBox;
  } else {
    throw FieldError{Join(p, "shape") + ": expected \"plane\" or \"box\", got \"" + shape + "\""};
  }
  o.size = Vector<3>(j, p, "size");
  const bool size_ok =
      o.shape == SceneObject::Shape::kBox ? o.size.minCoeff() > 0 : o.size.head<2>().minCoeff() > 0;
  if (!size_ok || !o.size.allFinite())
    throw FieldError{Join(p, "size") + ": expected positive extents in metres"};
  o.world_from_object = ParsePose(j, p, "world_from_object");
  o.material.reflectance = NumberIn(j, p, "reflectance", 0, 1);
  if (j.contains("specular")) o.material.specular = NumberIn(j, p, "specular", 0, 100);
  if (j.contains("shininess")) o.material.shininess = NumberIn(j, p, "shininess", 1, 10000);
  if (j.contains("pattern")) o.material.pattern = ParsePattern(j["pattern"], Join(p, "pattern"));
  if (j.contains("markers")) {
    const json& ms = j["markers"];
    if (!ms.is_array()) Fail(Join(p, "markers"), "an array of markers", ms);
    for (size_t k = 0; k < ms.size(); ++k)
      o.markers.push_back(ParseSceneMarker(ms[k], p + ".markers[" + std::to_string(k) + "]", ids));
  }
  return o;
}

// The scene's views (a non-empty array, unique names that are file names), appended to *out.
void ParseViews(const json& views, std::vector<View>* out) {
  if (!views.is_array() || views.empty()) Fail("views", "a non-empty array of views", views);
  std::set<std::string> names;
  for (size_t i = 0; i < views.size(); ++i) {
    const std::string p = "views[" + std::to_string(i) + "]";
    const json& j = views[i];
    CheckKeys(j, p, {"name", "cam_from_world", "sun", "occluders"});
    View v;
    v.name = String(j, p, "name");
    if (v.name.empty() || v.name.find_first_of("/\\") != std::string::npos)
      throw FieldError{Join(p, "name") + ": expected a non-empty file name without slashes"};
    if (!names.insert(v.name).second)
      throw FieldError{Join(p, "name") + ": \"" + v.name +
                       "\" appears twice; expected unique names"};
    v.cam_from_world = ParsePose(j, p, "cam_from_world");
    if (j.contains("sun")) v.sun = ParseSun(j["sun"], Join(p, "sun"));
    if (j.contains("occluders")) v.occluders = ParseOccluders(j["occluders"], Join(p, "occluders"));
    out->push_back(v);
  }
}

void ParseRoot(const json& root, const std::string& base_dir, Scene* scene) {
  CheckKeys(
      root, "",
      {"type", "seed", "camera", "sensor", "light", "background", "objects", "occluders", "views"});
  const std::string type = String(root, "", "type");
  if (type != "svms.scene") throw FieldError{"type: expected \"svms.scene\", got \"" + type + "\""};
  const json& seed = Required(root, "", "seed");
  if (!seed.is_number_unsigned()) Fail("seed", "a non-negative integer", seed);
  scene->seed = seed.get<uint64_t>();
  scene->camera = ParseCamera(Required(root, "", "camera"), "camera", base_dir);
  if (int64_t{scene->camera.width()} * scene->camera.height() > kDefaultMaxImagePixels) {
    throw FieldError{"camera: " + std::to_string(scene->camera.width()) + "x" +
                     std::to_string(scene->camera.height()) + " pixels; expected at most " +
                     std::to_string(kDefaultMaxImagePixels / 1000000) + " megapixels"};
  }
  if (root.contains("sensor")) scene->sensor = ParseSensor(root["sensor"]);
  if (root.contains("light")) ParseLighting(root["light"], &scene->light);
  if (root.contains("background"))
    ParseBackground(root["background"], base_dir, &scene->background);
  const json& objects = Required(root, "", "objects");
  if (!objects.is_array()) Fail("objects", "an array of objects", objects);
  std::set<int> ids;
  for (size_t i = 0; i < objects.size(); ++i)
    scene->objects.push_back(ParseObject(objects[i], "objects[" + std::to_string(i) + "]", &ids));
  if (root.contains("occluders")) scene->occluders = ParseOccluders(root["occluders"], "occluders");
  ParseViews(Required(root, "", "views"), &scene->views);
}

PrintedTag ParsePrint(const json& j, const std::string& path) {
  CheckKeys(j, path, {"family", "cells"});
  PrintedTag t;
  t.family = String(j, path, "family");
  if (!t.peer()) {
    if (j.contains("cells"))
      throw FieldError{Join(path, "cells") + ": expected no cells for the svms44 family"};
    return t;
  }
  const json& cells = Required(j, path, "cells");
  if (!cells.is_array() || cells.size() < 3)
    Fail(Join(path, "cells"), "an array of at least 3 rows of '0' (black) and '1' (white)", cells);
  t.n = static_cast<int>(cells.size());
  for (size_t r = 0; r < cells.size(); ++r) {
    const std::string rp = Join(path, "cells") + "[" + std::to_string(r) + "]";
    if (!cells[r].is_string()) Fail(rp, "a string of '0' and '1'", cells[r]);
    const std::string row = cells[r].get<std::string>();
    if (static_cast<int>(row.size()) != t.n || row.find_first_not_of("01") != std::string::npos)
      throw FieldError{rp + ": expected " + std::to_string(t.n) + " characters '0' or '1', got \"" +
                       row + "\""};
    for (char c : row) t.white.push_back(c == '1');
  }
  return t;
}

json PrintJson(const PrintedTag& t) {
  json j = {{"family", t.family}};
  if (t.peer()) {
    json rows = json::array();
    for (int r = 0; r < t.n; ++r) {
      std::string row;
      for (int c = 0; c < t.n; ++c) row += t.white[static_cast<size_t>(r) * t.n + c] ? '1' : '0';
      rows.push_back(row);
    }
    j["cells"] = rows;
  }
  return j;
}

}  // namespace

std::vector<Eigen::Vector2d> PrintedTag::DataCellCentres(double size) const {
  std::vector<Eigen::Vector2d> out;
  if (!peer() || n < 3) return out;
  const double cell = size / n;
  for (int r = 1; r < n - 1; ++r)
    for (int c = 1; c < n - 1; ++c)
      out.emplace_back(-0.5 * size + (c + 0.5) * cell, 0.5 * size - (r + 0.5) * cell);
  return out;
}

Status PrintedTag::Validate(const std::string& path) const {
  if (!peer()) {
    if (n != 0 || !white.empty())
      return Status::Error(path + "cells: expected no cells for the svms44 family");
    return Status::Ok();
  }
  if (n < 3 || white.size() != static_cast<size_t>(n) * n)
    return Status::Error(path + "cells: expected an n x n grid (n >= 3) for family \"" + family +
                         "\"");
  return Status::Ok();
}

Status Scene::Validate() const {
  if (views.empty()) return Status::Error("views: expected at least one view");
  if (camera.width() <= 0) return Status::Error("camera: expected a camera model");
  if (Status s = CheckSensor(sensor); !s) return s;
  for (size_t i = 0; i < objects.size(); ++i)
    for (size_t k = 0; k < objects[i].markers.size(); ++k) {
      const SceneMarker& m = objects[i].markers[k];
      const std::string path =
          "objects[" + std::to_string(i) + "].markers[" + std::to_string(k) + "].print.";
      if (Status s = m.print.Validate(path); !s) return s;
      if (m.print.peer() && m.model.inner)
        return Status::Error(path + "family: expected \"svms44\" for a dual marker");
    }
  return Status::Ok();
}

Status ParseSceneJson(const std::string& text, const std::string& source,
                      const std::string& base_dir, Scene* out) {
  json root;
  std::string error;
  if (!ParseText(text, source, &root, &error)) return Status::Error(error);
  Scene scene;
  try {
    ParseRoot(root, base_dir, &scene);
  } catch (const FieldError& e) {
    return Status::Error(source + ": " + e.message);
  }
  if (Status s = scene.Validate(); !s) return Status::Error(source + ": " + s.message());
  *out = std::move(scene);
  return Status::Ok();
}

Status ReadSceneFile(const std::string& path, Scene* out) {
  std::string text;
  if (Status s = ReadTextFile(path, &text); !s) return s;
  return ParseSceneJson(text, path, std::filesystem::path(path).parent_path().string(), out);
}

bool ValidEdgeRays(const Sensor& s) {
  if (s.edge_rays_per_pixel == 0) return true;
  const int r = static_cast<int>(std::lround(std::sqrt(std::max(0, s.edge_rays_per_pixel))));
  return s.edge_rays_per_pixel > 0 && s.edge_rays_per_pixel <= 4096 &&
         r * r == s.edge_rays_per_pixel;
}

Status CheckSensor(const Sensor& s) {
  auto bad = [](const std::string& field, const std::string& expected, const json& got) {
    return Status::Error("sensor." + field + ": expected " + expected + ", got " +
                         json_fields::TypeName(got));
  };
  if (s.bits != 8 && s.bits != 16) return bad("bits", "8 or 16", s.bits);
  // Checked before parsing: Response::Parse would read a table's file.
  Response response;
  if (s.response.rfind("table:", 0) == 0 || !Response::Parse(s.response, &response))
    return bad("response",
               "\"linear\", \"srgb\" or \"gamma:G\" with G in [0.1, 10] (no response tables "
               "in a scene)",
               s.response);
  if (s.signal_bits != 0 && (s.signal_bits < 6 || s.signal_bits > s.bits))
    return bad("signal_bits",
               "0 (all of sensor.bits) or 6 to " + std::to_string(s.bits) + " (sensor.bits)",
               s.signal_bits);
  const int white = s.white_level();
  if (!(s.black_level >= 0 && s.black_level < white))
    return bad("black_level",
               "at least 0 and below the white level " + std::to_string(white) +
                   " (2^signal_bits - 1), leaving room for the signal",
               s.black_level);
  static const std::set<std::string> kBayer = {"", "RGGB", "BGGR", "GRBG", "GBRG"};
  if (!kBayer.count(s.bayer))
    return bad("bayer", "\"\" (grey), \"RGGB\", \"BGGR\", \"GRBG\" or \"GBRG\"", s.bayer);
  for (int c = 0; c < 3; ++c) {
    if (!(s.channel_gain[c] > 0 && s.channel_gain[c] <= 10))
      return bad("channel_gain[" + std::to_string(c) + "]", "a number in (0, 10]",
                 s.channel_gain[c]);
  }
  if (s.format != "png" && s.format != "jpeg")
    return bad("format", "\"png\" or \"jpeg\"", s.format);
  if (s.format == "jpeg" && s.bits != 8)
    return bad("format", "\"png\" with " + std::to_string(s.bits) + " bits (a JPEG holds 8)",
               s.format);
  if (s.format == "jpeg" && !s.bayer.empty())
    return bad("format", "\"png\" for a Bayer mosaic (JPEG's lossy blocks would mix its colours)",
               s.format);
  if (s.jpeg_quality < 1 || s.jpeg_quality > 100)
    return bad("jpeg_quality", "1 to 100", s.jpeg_quality);
  return Status::Ok();
}

const std::vector<std::string>& SensorProfileNames() {
  static const std::vector<std::string> kNames = {"linear", "srgb8", "jpeg_srgb", "raw12",
                                                  "raw12_bayer"};
  return kNames;
}

Status ApplySensorProfile(const std::string& name, Sensor* sensor) {
  const Sensor defaults;
  Sensor p = *sensor;
  p.bits = defaults.bits;
  p.response = defaults.response;
  p.signal_bits = defaults.signal_bits;
  p.black_level = defaults.black_level;
  p.bayer = defaults.bayer;
  p.channel_gain = defaults.channel_gain;
  p.format = defaults.format;
  p.jpeg_quality = defaults.jpeg_quality;
  if (name == "linear") {
    // The defaults: the sensor of a scene that names no profile (an 8-bit linear PNG).
  } else if (name == "srgb8" || name == "jpeg_srgb") {
    // An ordinary camera: sRGB-encoded 8 bits behind optics that blur about a pixel, where
    // the response's bend moves a blurred edge toward its dark side.
    p.response = "srgb";
    p.defocus_sigma_px = 0.7;
    if (name == "jpeg_srgb") {
      p.format = "jpeg";
      p.jpeg_quality = 85;
    }
  } else if (name == "raw12" || name == "raw12_bayer") {
    // A machine-vision raw frame: 12 bits of linear signal above an offset, in 16-bit words.
    p.bits = 16;
    p.signal_bits = 12;
    p.black_level = 256;
    if (name == "raw12_bayer") p.bayer = "RGGB";
  } else {
    std::string list;
    const auto& names = SensorProfileNames();
    for (size_t i = 0; i < names.size(); ++i)
      list += (i == 0 ? "" : i + 1 == names.size() ? " or " : ", ") + names[i];
    return Status::Error("sensor profile \"" + name + "\": unknown; expected " + list);
  }
  *sensor = p;
  return Status::Ok();
}

std::string SceneToJson(const Scene& s) {
  json root;
  root["type"] = "svms.scene";
  root["seed"] = s.seed;
  root["camera"] = json_fields::CameraJson(s.camera);
  const Sensor& se = s.sensor;
  root["sensor"] = {{"bits", se.bits},
                    {"exposure", se.exposure},
                    {"full_well", se.full_well},
                    {"read_noise", se.read_noise},
                    {"shot_noise", se.shot_noise},
                    {"defocus_sigma_px", se.defocus_sigma_px},
                    {"vignetting", se.vignetting},
                    {"rays_per_pixel", se.rays_per_pixel},
                    {"motion_blur", se.motion_blur}};
  root["sensor"]["edge_rays_per_pixel"] = se.edge_rays_per_pixel;
  root["sensor"]["response"] = se.response;
  root["sensor"]["signal_bits"] = se.signal_bits;
  root["sensor"]["black_level"] = se.black_level;
  root["sensor"]["bayer"] = se.bayer;
  if (!se.bayer.empty()) root["sensor"]["channel_gain"] = se.channel_gain;
  root["sensor"]["format"] = se.format;
  if (se.format == "jpeg") root["sensor"]["jpeg_quality"] = se.jpeg_quality;
  json light = {{"ambient", s.light.ambient},
                {"ring_light", s.light.ring_light},
                {"narrow_band_filter", s.light.narrow_band_filter},
                {"filter_transmission", s.light.filter_transmission}};
  if (s.light.sun) light["sun"] = SunJson(*s.light.sun);
  if (s.light.earthshine) light["earthshine"] = SunJson(*s.light.earthshine);
  root["light"] = light;
  const char* kinds[] = {"black", "earth", "image"};
  json bg = {{"kind", kinds[static_cast<int>(s.background.kind)]},
             {"brightness", s.background.brightness}};
  if (s.background.kind == Background::Kind::kImage) bg["image"] = s.background.image_path;
  root["background"] = bg;
  json objects = json::array();
  for (const SceneObject& o : s.objects) {
    json jo = {{"name", o.name},
               {"shape", o.shape == SceneObject::Shape::kBox ? "box" : "plane"},
               {"size", {o.size(0), o.size(1), o.size(2)}},
               {"world_from_object", PoseJson(o.world_from_object)},
               {"reflectance", o.material.reflectance},
               {"specular", o.material.specular},
               {"shininess", o.material.shininess}};
    if (o.material.pattern.kind != Pattern::Kind::kUniform)
      jo["pattern"] = PatternJson(o.material.pattern);
    json ms = json::array();
    for (const SceneMarker& m : o.markers) {
      ms.push_back({{"marker", MarkerJson(m.model)},
                    {"object_from_marker", PoseJson(m.object_from_marker)},
                    {"black", m.black},
                    {"white", m.white},
                    {"retro", m.retro},
                    {"retro_gain", m.retro_gain}});
      if (m.print.peer()) ms.back()["print"] = PrintJson(m.print);
    }
    jo["markers"] = ms;
    objects.push_back(jo);
  }
  root["objects"] = objects;
  json occ = json::array();
  for (const Occluder& o : s.occluders) occ.push_back(OccluderJson(o));
  root["occluders"] = occ;
  json views = json::array();
  for (const View& v : s.views) {
    json jv = {{"name", v.name}, {"cam_from_world", PoseJson(v.cam_from_world)}};
    if (v.sun) jv["sun"] = SunJson(*v.sun);
    if (v.occluders) {
      json vo = json::array();
      for (const Occluder& o : *v.occluders) vo.push_back(OccluderJson(o));
      jv["occluders"] = vo;
    }
    views.push_back(jv);
  }
  root["views"] = views;
  return root.dump(1) + "\n";
}

}  // namespace svms
