// Internal: strict reading of JSON fields with paths in the messages, shared by the parsers
// of model, layout, camera and scene files (camera/camera_json.h and
// marker/marker_json.h add the camera and marker objects). Not installed. Errors are thrown as
// FieldError inside the parsers and turned into a Status at their boundary.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <set>
#include <string>

#include "svms/geometry/pose.h"

namespace svms::json_fields {

using nlohmann::json;

struct FieldError {
  std::string message;
};

std::string TypeName(const json& j);
[[noreturn]] void Fail(const std::string& path, const std::string& expected, const json& got);
void CheckKeys(const json& obj, const std::string& path, const std::set<std::string>& allowed);
std::string Join(const std::string& path, const std::string& key);
const json& Required(const json& obj, const std::string& path, const std::string& key);
// A finite number (a literal beyond the range of a double, read as infinity, is an error).
double Number(const json& obj, const std::string& path, const std::string& key);
// A number in [lo, hi], named in the message.
double NumberIn(const json& obj, const std::string& path, const std::string& key, double lo,
                double hi);
int Integer(const json& obj, const std::string& path, const std::string& key);
bool Boolean(const json& obj, const std::string& path, const std::string& key);
std::string String(const json& obj, const std::string& path, const std::string& key);

// An array of exactly N finite numbers.
template <int N>
Eigen::Matrix<double, N, 1> Vector(const json& obj, const std::string& path,
                                   const std::string& key) {
  const json& v = Required(obj, path, key);
  if (!v.is_array() || v.size() != N)
    Fail(Join(path, key), "an array of " + std::to_string(N) + " numbers", v);
  Eigen::Matrix<double, N, 1> out;
  for (int i = 0; i < N; ++i) {
    if (!v[i].is_number() || !std::isfinite(v[i].get<double>()))
      Fail(Join(path, key) + "[" + std::to_string(i) + "]", "a finite number", v[i]);
    out(i) = v[i].get<double>();
  }
  return out;
}

// {"rvec": [3], "tvec": [3]}
Pose ParsePose(const json& obj, const std::string& path, const std::string& key);
json PoseJson(const Pose& p);

// Parses `text`; a syntax error becomes "<source>: line L, column C: not valid JSON: ...".
// Also refused, with the field's path: a key that appears twice in one object (JSON leaves it
// undefined; nlohmann would keep the last, so a second "id" or pose would silently win), and
// nesting deeper than kMaxJsonDepth (no SVMS file nests beyond 6; 66 MB of "[" would take
// gigabytes as a DOM).
constexpr int kMaxJsonDepth = 64;
bool ParseText(const std::string& text, const std::string& source, json* out, std::string* error);

}  // namespace svms::json_fields
