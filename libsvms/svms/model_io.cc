#include "svms/model_io.h"

#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

namespace svms {
namespace {

using nlohmann::json;

// Thrown inside this file only; turned into a Status at the boundary.
struct FieldError {
  std::string message;
};

std::string TypeName(const json& j) {
  if (j.is_null()) return "null";
  if (j.is_boolean()) return "a boolean";
  if (j.is_number()) return "the number " + j.dump();
  if (j.is_string()) return "the string " + j.dump();
  if (j.is_array()) return "an array of " + std::to_string(j.size());
  return "an object";
}

[[noreturn]] void Fail(const std::string& path, const std::string& expected, const json& got) {
  throw FieldError{path + ": expected " + expected + ", got " + TypeName(got)};
}

void CheckKeys(const json& obj, const std::string& path, const std::set<std::string>& allowed) {
  if (!obj.is_object()) Fail(path.empty() ? "(top level)" : path, "an object", obj);
  for (auto it = obj.begin(); it != obj.end(); ++it) {
    if (!allowed.count(it.key())) {
      std::string list;
      for (const auto& k : allowed) list += (list.empty() ? "" : ", ") + k;
      throw FieldError{(path.empty() ? "" : path + ".") + it.key() +
                       ": unknown field; expected one of " + list};
    }
  }
}

std::string Join(const std::string& path, const std::string& key) {
  return path.empty() ? key : path + "." + key;
}

const json& Required(const json& obj, const std::string& path, const std::string& key) {
  auto it = obj.find(key);
  if (it == obj.end()) throw FieldError{Join(path, key) + ": missing; this field is required"};
  return *it;
}

double Number(const json& obj, const std::string& path, const std::string& key) {
  const json& v = Required(obj, path, key);
  if (!v.is_number()) Fail(Join(path, key), "a number", v);
  return v.get<double>();
}

int Integer(const json& obj, const std::string& path, const std::string& key) {
  const json& v = Required(obj, path, key);
  if (!v.is_number_integer()) Fail(Join(path, key), "an integer", v);
  const auto i = v.get<int64_t>();
  if (i < INT32_MIN || i > INT32_MAX) Fail(Join(path, key), "an integer in range", v);
  return static_cast<int>(i);
}

std::string String(const json& obj, const std::string& path, const std::string& key) {
  const json& v = Required(obj, path, key);
  if (!v.is_string()) Fail(Join(path, key), "a string", v);
  return v.get<std::string>();
}

template <int N>
Eigen::Matrix<double, N, 1> Vector(const json& obj, const std::string& path,
                                   const std::string& key) {
  const json& v = Required(obj, path, key);
  if (!v.is_array() || v.size() != N) Fail(Join(path, key), "an array of " + std::to_string(N) + " numbers", v);
  Eigen::Matrix<double, N, 1> out;
  for (int i = 0; i < N; ++i) {
    if (!v[i].is_number())
      Fail(Join(path, key) + "[" + std::to_string(i) + "]", "a number", v[i]);
    out(i) = v[i].get<double>();
  }
  return out;
}

MarkerModel ParseMarker(const json& j, const std::string& path, bool top_level) {
  std::set<std::string> keys{"family", "id", "size", "stripe_width", "cell_size", "post", "inner"};
  if (top_level) keys.insert("type");
  CheckKeys(j, path, keys);
  MarkerModel m;
  m.family = String(j, path, "family");
  m.id = Integer(j, path, "id");
  m.size = Number(j, path, "size");
  m.stripe_width = Number(j, path, "stripe_width");
  m.cell_size = Number(j, path, "cell_size");
  auto parse_post = [](const json& p, const std::string& pp) {
    CheckKeys(p, pp, {"height", "radius", "tip_radius"});
    return PostModel{Number(p, pp, "height"), Number(p, pp, "radius"), Number(p, pp, "tip_radius")};
  };
  if (j.contains("post")) m.post = parse_post(j["post"], Join(path, "post"));
  if (j.contains("inner")) {
    const std::string ip = Join(path, "inner");
    const json& in = j["inner"];
    CheckKeys(in, ip, {"id", "size", "stripe_width", "cell_size", "post"});
    NestedMarker n;
    n.id = Integer(in, ip, "id");
    n.size = Number(in, ip, "size");
    n.stripe_width = Number(in, ip, "stripe_width");
    n.cell_size = Number(in, ip, "cell_size");
    m.inner = n;
    // The dual marker has one post at the common centre; it may be written in either place.
    if (in.contains("post")) {
      const PostModel p = parse_post(in["post"], Join(ip, "post"));
      if (m.post && (m.post->height != p.height || m.post->radius != p.radius ||
                     m.post->tip_radius != p.tip_radius)) {
        throw FieldError{Join(ip, "post") + ": a dual marker has one post at the common centre; " +
                         "expected it in one place (or the same in both), got two different posts"};
      }
      m.post = p;
    }
  }
  if (Status s = m.Validate(path.empty() ? "" : path + "."); !s) throw FieldError{s.message()};
  return m;
}

json MarkerJson(const MarkerModel& m) {
  json j;
  j["family"] = m.family;
  j["id"] = m.id;
  j["size"] = m.size;
  j["stripe_width"] = m.stripe_width;
  j["cell_size"] = m.cell_size;
  if (m.post)
    j["post"] = {{"height", m.post->height}, {"radius", m.post->radius}, {"tip_radius", m.post->tip_radius}};
  if (m.inner) {
    j["inner"] = {{"id", m.inner->id},
                  {"size", m.inner->size},
                  {"stripe_width", m.inner->stripe_width},
                  {"cell_size", m.inner->cell_size}};
  }
  return j;
}

void ParseRoot(const json& root, ModelFile* out) {
  if (!root.is_object()) Fail("(top level)", "an object with a \"type\" field", root);
  const std::string type = String(root, "", "type");
  if (type == "svms.marker") {
    out->kind = ModelFile::Kind::kMarker;
    out->markers = {ParseMarker(root, "", true)};
  } else if (type == "svms.markers") {
    CheckKeys(root, "", {"type", "markers"});
    const json& arr = Required(root, "", "markers");
    if (!arr.is_array() || arr.empty()) Fail("markers", "a non-empty array of marker models", arr);
    out->kind = ModelFile::Kind::kMarkerSet;
    std::set<int> ids;
    for (size_t i = 0; i < arr.size(); ++i) {
      const std::string p = "markers[" + std::to_string(i) + "]";
      out->markers.push_back(ParseMarker(arr[i], p, false));
      for (int id : {out->markers.back().id,
                     out->markers.back().inner ? out->markers.back().inner->id : -1}) {
        if (id >= 0 && !ids.insert(id).second)
          throw FieldError{p + ".id: ID " + std::to_string(id) + " appears twice; expected unique IDs"};
      }
    }
  } else if (type == "svms.layout") {
    CheckKeys(root, "", {"type", "name", "markers"});
    out->kind = ModelFile::Kind::kLayout;
    out->layout.name = String(root, "", "name");
    const json& arr = Required(root, "", "markers");
    if (!arr.is_array() || arr.empty()) Fail("markers", "a non-empty array of layout entries", arr);
    for (size_t i = 0; i < arr.size(); ++i) {
      const std::string p = "markers[" + std::to_string(i) + "]";
      const json& e = arr[i];
      CheckKeys(e, p, {"marker", "object_from_marker", "covariance", "post_height_sigma"});
      LayoutEntry entry;
      entry.marker = ParseMarker(Required(e, p, "marker"), p + ".marker", false);
      const std::string pp = p + ".object_from_marker";
      const json& pose = Required(e, p, "object_from_marker");
      CheckKeys(pose, pp, {"rvec", "tvec"});
      entry.object_from_marker.rvec = Vector<3>(pose, pp, "rvec");
      entry.object_from_marker.tvec = Vector<3>(pose, pp, "tvec");
      if (e.contains("covariance")) {
        const Eigen::Matrix<double, 36, 1> c = Vector<36>(e, p, "covariance");
        entry.covariance = Eigen::Map<const PoseCovariance>(c.data());
      }
      if (e.contains("post_height_sigma")) entry.post_height_sigma = Number(e, p, "post_height_sigma");
      out->layout.markers.push_back(entry);
      out->markers.push_back(entry.marker);
    }
    if (Status s = out->layout.Validate(); !s) throw FieldError{s.message()};
  } else {
    throw FieldError{"type: expected \"svms.marker\", \"svms.markers\" or \"svms.layout\", got \"" +
                     type + "\""};
  }
}

std::string Dump(const json& j) { return j.dump(2) + "\n"; }

}  // namespace

std::string ModelFile::Summary() const {
  switch (kind) {
    case Kind::kMarker: return markers.front().Summary();
    case Kind::kLayout: return layout.Summary();
    case Kind::kMarkerSet: {
      std::string s = "marker set: " + std::to_string(markers.size()) + " markers:";
      for (const MarkerModel& m : markers) s += " [" + m.Summary() + "]";
      return s;
    }
  }
  return "";
}

Status ParseModelJson(const std::string& text, const std::string& source, ModelFile* out) {
  json root;
  try {
    root = json::parse(text);
  } catch (const json::parse_error& e) {
    // Byte offset to line and column.
    size_t line = 1, col = 1;
    for (size_t i = 0; i + 1 < e.byte && i < text.size(); ++i) {
      if (text[i] == '\n') {
        ++line;
        col = 1;
      } else {
        ++col;
      }
    }
    std::string what = e.what();
    const size_t colon = what.rfind(": ");
    if (colon != std::string::npos) what = what.substr(colon + 2);
    return Status::Error(source + ": line " + std::to_string(line) + ", column " +
                         std::to_string(col) + ": not valid JSON: " + what);
  }
  ModelFile parsed;
  try {
    ParseRoot(root, &parsed);
  } catch (const FieldError& e) {
    return Status::Error(source + ": " + e.message);
  }
  *out = std::move(parsed);
  return Status::Ok();
}

Status ReadModelFile(const std::string& path, ModelFile* out) {
  std::string text;
  if (Status s = ReadTextFile(path, &text); !s) return s;
  return ParseModelJson(text, path, out);
}

std::string MarkerModelToJson(const MarkerModel& model) {
  json j = MarkerJson(model);
  j["type"] = "svms.marker";
  return Dump(j);
}

std::string MarkerSetToJson(const std::vector<MarkerModel>& models) {
  json arr = json::array();
  for (const MarkerModel& m : models) arr.push_back(MarkerJson(m));
  return Dump(json{{"type", "svms.markers"}, {"markers", arr}});
}

std::string LayoutToJson(const Layout& layout) {
  json arr = json::array();
  for (const LayoutEntry& e : layout.markers) {
    json je;
    je["marker"] = MarkerJson(e.marker);
    const auto& p = e.object_from_marker;
    je["object_from_marker"] = {{"rvec", {p.rvec(0), p.rvec(1), p.rvec(2)}},
                                {"tvec", {p.tvec(0), p.tvec(1), p.tvec(2)}}};
    if (e.covariance) {
      json c = json::array();
      for (int i = 0; i < 36; ++i) c.push_back(e.covariance->data()[i]);
      je["covariance"] = c;
    }
    if (e.post_height_sigma) je["post_height_sigma"] = *e.post_height_sigma;
    arr.push_back(je);
  }
  return Dump(json{{"type", "svms.layout"}, {"name", layout.name}, {"markers", arr}});
}

Status ReadTextFile(const std::string& path, std::string* text) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return Status::Error(path + ": cannot open for reading");
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) return Status::Error(path + ": read error");
  *text = ss.str();
  return Status::Ok();
}

Status WriteTextFile(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  if (!out) return Status::Error(path + ": cannot open for writing");
  out << text;
  out.close();
  if (!out) return Status::Error(path + ": write error");
  return Status::Ok();
}

}  // namespace svms
