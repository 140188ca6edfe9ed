#include "svms/marker/model_io.h"

#include <set>
#include <sstream>

#include "svms/base/json_fields.h"
#include "svms/marker/marker_json.h"

namespace svms {
namespace {

using namespace json_fields;  // NOLINT: the field readers

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
          throw FieldError{p + ".id: ID " + std::to_string(id) +
                           " appears twice; expected unique IDs"};
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
      entry.object_from_marker = ParsePose(e, p, "object_from_marker");
      if (e.contains("covariance")) {
        const Eigen::Matrix<double, 36, 1> c = Vector<36>(e, p, "covariance");
        entry.covariance = Eigen::Map<const PoseCovariance>(c.data());
      }
      if (e.contains("post_height_sigma"))
        entry.post_height_sigma = Number(e, p, "post_height_sigma");
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
    case Kind::kMarker:
      return markers.front().Summary();
    case Kind::kLayout:
      return layout.Summary();
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
  std::string syntax_error;
  if (!ParseText(text, source, &root, &syntax_error)) return Status::Error(syntax_error);
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
    je["object_from_marker"] = PoseJson(e.object_from_marker);
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

}  // namespace svms
