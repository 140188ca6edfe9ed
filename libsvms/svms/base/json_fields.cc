#include "svms/base/json_fields.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <vector>

namespace svms::json_fields {

std::string TypeName(const json& j) {
  if (j.is_null()) return "null";
  if (j.is_boolean()) return "a boolean";
  // nlohmann reads a literal beyond the range of a double (1e400) as infinity (and dumps it as
  // null); JSON itself has no NaN or infinity.
  if (j.is_number_float() && !std::isfinite(j.get<double>()))
    return "a number beyond the range of a double";
  if (j.is_number()) return "the number " + j.dump();
  if (j.is_string()) return "the string " + j.dump();
  if (j.is_array()) return "an array of " + std::to_string(j.size());
  return "an object";
}

void Fail(const std::string& path, const std::string& expected, const json& got) {
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
  if (!std::isfinite(v.get<double>())) Fail(Join(path, key), "a finite number", v);
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

double NumberIn(const json& obj, const std::string& path, const std::string& key, double lo,
                double hi) {
  const double v = Number(obj, path, key);
  if (!(v >= lo && v <= hi)) {
    Fail(Join(path, key), "a number in [" + json(lo).dump() + ", " + json(hi).dump() + "]",
         obj.at(key));
  }
  return v;
}

bool Boolean(const json& obj, const std::string& path, const std::string& key) {
  const json& v = Required(obj, path, key);
  if (!v.is_boolean()) Fail(Join(path, key), "true or false", v);
  return v.get<bool>();
}

Pose ParsePose(const json& obj, const std::string& path, const std::string& key) {
  const std::string pp = Join(path, key);
  const json& pose = Required(obj, path, key);
  CheckKeys(pose, pp, {"rvec", "tvec"});
  Pose p;
  p.rvec = Vector<3>(pose, pp, "rvec");
  p.tvec = Vector<3>(pose, pp, "tvec");
  if (!p.rvec.allFinite() || !p.tvec.allFinite())
    throw FieldError{pp + ": expected finite numbers"};
  return p;
}

json PoseJson(const Pose& p) {
  return {{"rvec", {p.rvec(0), p.rvec(1), p.rvec(2)}}, {"tvec", {p.tvec(0), p.tvec(1), p.tvec(2)}}};
}

namespace {

// Thrown from the parser's callback to stop at a duplicate key or at the depth limit.
struct StructureError {
  std::string message;
};

// Follows the parser's events to know the path of the value being read, and checks that no
// object repeats a key and that nesting stays within kMaxJsonDepth.
class StructureChecker {
 public:
  bool operator()(int depth, json::parse_event_t event, json& parsed) {
    switch (event) {
      case json::parse_event_t::object_start:
      case json::parse_event_t::array_start:
        if (depth >= kMaxJsonDepth)
          throw StructureError{Path().substr(0, 48) + "...: nested deeper than " +
                               std::to_string(kMaxJsonDepth) +
                               " levels; expected an SVMS file (a few levels deep)"};
        frames_.push_back(Frame{event == json::parse_event_t::object_start, {}, "", 0});
        break;
      case json::parse_event_t::key: {
        Frame& f = frames_.back();
        f.key = parsed.get<std::string>();
        if (!f.keys.insert(f.key).second)
          throw StructureError{Path() +
                               ": the field appears twice in one object; expected "
                               "each field once (JSON does not say which would count)"};
        break;
      }
      case json::parse_event_t::object_end:
      case json::parse_event_t::array_end:
        frames_.pop_back();
        Advance();
        break;
      case json::parse_event_t::value:
        Advance();
        break;
    }
    return true;
  }

 private:
  struct Frame {
    bool object;
    std::set<std::string> keys;
    std::string key;  // objects: the current key
    size_t index;     // arrays: the current element
  };
  void Advance() {
    if (!frames_.empty() && !frames_.back().object) ++frames_.back().index;
  }
  std::string Path() const {
    std::string p;
    for (const Frame& f : frames_) {
      if (f.object)
        p += (p.empty() ? "" : ".") + f.key;
      else
        p += "[" + std::to_string(f.index) + "]";
    }
    return p.empty() ? "(top level)" : p;
  }
  std::vector<Frame> frames_;
};

}  // namespace

bool ParseText(const std::string& text, const std::string& source, json* out, std::string* error) {
  try {
    StructureChecker checker;
    *out = json::parse(text, std::ref(checker));
    return true;
  } catch (const StructureError& e) {
    *error = source + ": " + e.message;
    return false;
  } catch (const json::parse_error& e) {
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
    *error = source + ": line " + std::to_string(line) + ", column " + std::to_string(col) +
             ": not valid JSON: " + what;
    return false;
  } catch (const json::out_of_range& e) {
    // nlohmann 3.11 refuses a number literal beyond a double's range ("1e400") with
    // out_of_range 406, which carries the literal but not its place: find it in the text.
    std::string what = e.what();
    const size_t open = what.find('\''), close = what.rfind('\'');
    std::string where;
    if (open != std::string::npos && close > open + 1) {
      const std::string literal = what.substr(open + 1, close - open - 1);
      const size_t at = text.find(literal);
      if (at != std::string::npos) {
        const size_t line = 1 + std::count(text.begin(), text.begin() + at, '\n');
        const size_t bol = text.rfind('\n', at);
        const size_t col = at - (bol == std::string::npos ? 0 : bol + 1) + 1;
        where = ": line " + std::to_string(line) + ", column " + std::to_string(col);
        // The nearest key before it ("tvec" for "tvec": [0, 1e400, 0]).
        const size_t colon = text.rfind("\":", at);
        const size_t quote = colon == std::string::npos || colon == 0 ? std::string::npos
                                                                      : text.rfind('"', colon - 1);
        if (quote != std::string::npos && colon - quote - 1 < 64)
          where += ": " + text.substr(quote + 1, colon - quote - 1);
      }
      *error = source + where + ": the number " + literal +
               " is beyond the range of a double; expected a finite number";
    } else {
      *error = source + ": not valid JSON: " + what;
    }
    return false;
  } catch (const json::exception& e) {
    *error = source + ": not valid JSON: " + e.what();
    return false;
  }
}

}  // namespace svms::json_fields
