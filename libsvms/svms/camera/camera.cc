#include "svms/camera/camera.h"

#include <cassert>
#include <cctype>
#include <cerrno>
#include <climits>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <utility>

#include "svms/base/file_io.h"
#include "svms/base/format.h"
#include "svms/camera/opencv_camera.h"

// mrcal 2.2's header has no extern "C" guard of its own.
extern "C" {
#include <mrcal/mrcal.h>
}

namespace svms {
namespace {

namespace fs = std::filesystem;

constexpr const char* kExpectedFile =
    "expected an mrcal .cameramodel: a Python-literal dict with 'lensmodel', 'intrinsics', "
    "'extrinsics' and 'imagersize'";

std::string SupportedLensModels() {
  std::string list;
  for (const char* const* name = mrcal_supported_lensmodel_names(); *name != nullptr; ++name) {
    list += (list.empty() ? "" : ", ") + std::string(*name);
  }
  return list;
}

// Parses `name` into *out. Returns "" or an error message starting with "lensmodel".
// mrcal_lensmodel_from_name alone is not enough: it accepts spline configurations that abort
// the process later inside mrcal_project (order 4, Nx = 2, ...), wraps "Nx=-1" to 65535, and
// reads "fov_x_deg=0" (NaN projections) and "linearity=inf".
std::string CheckLensModel(const std::string& name, mrcal_lensmodel_t* out) {
  mrcal_lensmodel_t m{};
  if (name.find('\0') != std::string::npos || !mrcal_lensmodel_from_name(&m, name.c_str())) {
    mrcal_lensmodel_t type_only{};
    type_only.type = mrcal_lensmodel_type_from_name(name.c_str());
    if (name.find('\0') == std::string::npos && mrcal_lensmodel_type_is_valid(type_only.type)) {
      return "lensmodel: '" + name + "' has a missing or unreadable configuration; expected " +
             mrcal_lensmodel_name_unconfigured(&type_only) + " with every ... filled in";
    }
    return "lensmodel: unknown lens model '" + name + "'; expected one of " + SupportedLensModels();
  }
  // A spline's configuration is read into 16-bit unsigned fields ("Nx=-1" becomes 65535), so its
  // name must be the one mrcal writes back. (CAHVORE's linearity is a double: "linearity=1" and
  // "linearity=1.00" are the same model, and mrcal writes "%.2f", so it is checked for
  // finiteness instead.)
  char canonical[1024];
  if (!mrcal_lensmodel_name(canonical, sizeof(canonical), &m)) {
    return "lensmodel: '" + name + "': mrcal cannot name this lens model; expected a shorter name";
  }
  if (m.type != MRCAL_LENSMODEL_CAHVORE && name != canonical) {
    return "lensmodel: '" + name + "' is not in mrcal's canonical form (mrcal reads it as '" +
           canonical + "'); expected '" + canonical + "'";
  }
  if (m.type == MRCAL_LENSMODEL_SPLINED_STEREOGRAPHIC) {
    const mrcal_LENSMODEL_SPLINED_STEREOGRAPHIC__config_t& c =
        m.LENSMODEL_SPLINED_STEREOGRAPHIC__config;
    if (c.order != 2 && c.order != 3) {
      return "lensmodel: '" + name + "': expected a spline order of 2 or 3, got " +
             std::to_string(c.order);
    }
    if (c.Nx < c.order + 1 || c.Ny < c.order + 1) {
      return "lensmodel: '" + name +
             "': expected Nx and Ny >= order + 1 = " + std::to_string(c.order + 1) +
             ", got Nx=" + std::to_string(c.Nx) + " Ny=" + std::to_string(c.Ny);
    }
    if (2LL * c.Nx * c.Ny + 4 > INT_MAX) {
      return "lensmodel: '" + name +
             "': expected fewer control points, got Nx=" + std::to_string(c.Nx) +
             " Ny=" + std::to_string(c.Ny);
    }
    if (c.fov_x_deg == 0 || c.fov_x_deg >= 360) {
      return "lensmodel: '" + name + "': expected 0 < fov_x_deg < 360, got " +
             std::to_string(c.fov_x_deg);
    }
  }
  if (m.type == MRCAL_LENSMODEL_CAHVORE && !std::isfinite(m.LENSMODEL_CAHVORE__config.linearity)) {
    return "lensmodel: '" + name + "': expected a finite linearity";
  }
  *out = m;
  return "";
}

// Error text for a value that is not a finite number, or "".
std::string CheckFinite(const std::string& field, int index, double v) {
  if (std::isfinite(v)) return "";
  return field + "[" + std::to_string(index) + "]: expected a finite number, got " + RoundTrip(v);
}

// ---------------------------------------------------------------------------------------------
// Explaining a file mrcal rejected. mrcal_read_cameramodel_* returns only NULL (its reasons go
// to stderr), so we re-read the file with a small parser of the Python-literal subset that
// .cameramodel files use and look for the first thing wrong. mrcal's parser still decides
// what is read; this one only words the error.

struct Literal {
  enum class Kind { kString, kAtom, kList };
  Kind kind = Kind::kAtom;
  std::string text;            // a string's contents, or an atom's characters ("1e-3", "nan")
  std::vector<Literal> items;  // a list's or tuple's elements
};

class LiteralParser {
 public:
  explicit LiteralParser(const std::string& s) : s_(s) {}

  // { 'key': value, ... } followed by nothing but blanks and comments.
  bool ParseDict(std::vector<std::pair<std::string, Literal>>* entries) {
    SkipBlanks();
    if (!Eat('{')) return false;
    while (true) {
      SkipBlanks();
      if (Eat('}')) break;
      Literal key, value;
      if (!ParseValue(&key, 0) || key.kind != Literal::Kind::kString) return false;
      SkipBlanks();
      if (!Eat(':') || !ParseValue(&value, 0)) return false;
      entries->emplace_back(key.text, std::move(value));
      SkipBlanks();
      if (Eat(',')) continue;
      if (Eat('}')) break;
      return false;
    }
    SkipBlanks();
    return i_ == s_.size();
  }

 private:
  void SkipBlanks() {
    while (i_ < s_.size()) {
      if (std::isspace(static_cast<unsigned char>(s_[i_]))) {
        ++i_;
      } else if (s_[i_] == '#') {
        while (i_ < s_.size() && s_[i_] != '\n') ++i_;
      } else {
        break;
      }
    }
  }
  bool Eat(char c) {
    if (i_ < s_.size() && s_[i_] == c) {
      ++i_;
      return true;
    }
    return false;
  }
  static bool IsSpecial(char c) {
    return c == '\0' || std::isspace(static_cast<unsigned char>(c)) ||
           std::strchr(",:[](){}#'\"", c) != nullptr;
  }
  bool ParseValue(Literal* out, int depth) {
    SkipBlanks();
    if (i_ >= s_.size() || depth > 16) return false;
    const char c = s_[i_];
    if (c == '[' || c == '(') {
      const char close = c == '[' ? ']' : ')';
      ++i_;
      out->kind = Literal::Kind::kList;
      while (true) {
        SkipBlanks();
        if (Eat(close)) return true;
        Literal item;
        if (!ParseValue(&item, depth + 1)) return false;
        out->items.push_back(std::move(item));
        SkipBlanks();
        if (Eat(',')) continue;
        return Eat(close);
      }
    }
    std::size_t j = i_;  // a string may have a prefix such as b'...'
    while (j < s_.size() && j - i_ < 2 && std::strchr("bBrRuU", s_[j]) != nullptr && s_[j]) ++j;
    if (j < s_.size() && (s_[j] == '\'' || s_[j] == '"')) {
      const char quote = s_[j];
      std::size_t k = j + 1;
      while (k < s_.size() && s_[k] != quote) k += s_[k] == '\\' ? 2 : 1;
      if (k >= s_.size()) return false;
      out->kind = Literal::Kind::kString;
      out->text = s_.substr(j + 1, k - j - 1);
      i_ = k + 1;
      return true;
    }
    std::size_t k = i_;
    while (k < s_.size() && !IsSpecial(s_[k])) ++k;
    if (k == i_) return false;
    out->kind = Literal::Kind::kAtom;
    out->text = s_.substr(i_, k - i_);
    i_ = k;
    return true;
  }

  const std::string& s_;
  std::size_t i_ = 0;
};

std::string ListText(const Literal& list) {
  std::string s = "[";
  for (std::size_t i = 0; i < list.items.size(); ++i) {
    const Literal& item = list.items[i];
    s += (i ? ", " : "") + (item.kind == Literal::Kind::kList     ? std::string("[...]")
                            : item.kind == Literal::Kind::kString ? "'" + item.text + "'"
                                                                  : item.text);
  }
  return s + "]";
}

// Checks a list of `expected` finite numbers (any count if expected < 0). "" if fine.
std::string CheckNumberList(const std::string& field, const Literal& v, int expected,
                            const std::string& what) {
  if (v.kind != Literal::Kind::kList) {
    return field + ": expected a list of " + what + ", got " +
           (v.kind == Literal::Kind::kString ? "a string" : "'" + v.text + "'");
  }
  if (expected >= 0 && static_cast<int>(v.items.size()) != expected) {
    return field + ": expected " + what + ", got " + std::to_string(v.items.size());
  }
  for (std::size_t i = 0; i < v.items.size(); ++i) {
    const Literal& item = v.items[i];
    const std::string where = field + "[" + std::to_string(i) + "]";
    if (item.kind != Literal::Kind::kAtom) return where + ": expected a finite number";
    char* end = nullptr;
    const double x = std::strtod(item.text.c_str(), &end);
    if (end != item.text.c_str() + item.text.size() || !std::isfinite(x)) {
      return where + ": expected a finite number, got '" + item.text + "'";
    }
  }
  return "";
}

bool IsPositiveInt(const Literal& v) {
  if (v.kind != Literal::Kind::kAtom || v.text.empty() || v.text.size() > 10) return false;
  for (const char c : v.text) {
    if (c < '0' || c > '9') return false;
  }
  const long long x = std::stoll(v.text);
  return x > 0 && x <= INT_MAX;
}

// Why mrcal rejected `text` (without the path prefix).
std::string Diagnose(const std::string& text) {
  if (text.find_first_not_of(" \t\r\n") == std::string::npos) {
    return std::string("the file is empty; ") + kExpectedFile;
  }
  std::vector<std::pair<std::string, Literal>> entries;
  if (!LiteralParser(text).ParseDict(&entries)) {
    return std::string("mrcal cannot parse the file; ") + kExpectedFile;
  }
  std::map<std::string, std::size_t> index;
  for (std::size_t i = 0; i < entries.size(); ++i) {
    if (!index.emplace(entries[i].first, i).second) {
      return "'" + entries[i].first + "' appears more than once; expected each key once";
    }
  }
  for (const char* key : {"lensmodel", "intrinsics", "extrinsics", "imagersize"}) {
    if (!index.count(key)) return "missing '" + std::string(key) + "'; " + kExpectedFile;
  }
  const Literal& lens = entries[index["lensmodel"]].second;
  if (lens.kind != Literal::Kind::kString) {
    return "lensmodel: expected a string such as 'LENSMODEL_OPENCV8'";
  }
  mrcal_lensmodel_t m;
  if (std::string e = CheckLensModel(lens.text, &m); !e.empty()) return e;
  const int n = mrcal_lensmodel_num_params(&m);
  if (std::string e = CheckNumberList("intrinsics", entries[index["intrinsics"]].second, n,
                                      std::to_string(n) + " values for " + lens.text);
      !e.empty()) {
    return e;
  }
  if (std::string e = CheckNumberList("extrinsics", entries[index["extrinsics"]].second, 6,
                                      "6 values (rt_cam_ref: a rotation vector, then a "
                                      "translation in metres)");
      !e.empty()) {
    return e;
  }
  const Literal& size = entries[index["imagersize"]].second;
  if (size.kind != Literal::Kind::kList || size.items.size() != 2 ||
      !IsPositiveInt(size.items[0]) || !IsPositiveInt(size.items[1])) {
    return "imagersize: expected a positive width and height (2 integers, pixels), got " +
           (size.kind == Literal::Kind::kList ? ListText(size) : "'" + size.text + "'");
  }
  if (index["intrinsics"] < index["lensmodel"]) {
    return "'intrinsics' comes before 'lensmodel'; mrcal 2.2 expects 'lensmodel' first";
  }
  return std::string("mrcal cannot parse the file (its reason is on stderr); ") + kExpectedFile;
}

// mrcal 2.2's scanner reads past the end of its buffer (and crashes, or reads whatever memory
// follows) when the text ends inside a quoted string or inside a comment (fuzz/fuzz_camera.cc
// covers it; docs/reliability.md). Returns why `text` ends inside a string, or "".
// Strings are delimited exactly as mrcal's scanner delimits them (cameramodel-parser.re:
// ["'] [^"'\x00]* ["']): either quote opens one, the next quote of either kind closes it, and
// a backslash escapes nothing. (Honouring escapes or matching the quote kinds would pass
// 'lensmodel": 'LENS... , on which mrcal reads past the end.) A comment at the end is made safe by
// appending a newline.
std::string UnclosedString(const std::string& text) {
  std::size_t line = 1;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '\n') {
      ++line;
    } else if (c == '#') {
      while (i + 1 < text.size() && text[i + 1] != '\n') ++i;
    } else if (c == '\'' || c == '"') {
      const std::size_t start_line = line;
      std::size_t k = i + 1;
      while (k < text.size() && text[k] != '\'' && text[k] != '"') {
        if (text[k] == '\n') ++line;
        ++k;
      }
      if (k >= text.size()) {
        return "the string opened on line " + std::to_string(start_line) +
               " is not closed before the end of the file (truncated?)";
      }
      i = k;
    }
  }
  return "";
}

// Whether the first thing in `text` after blanks and '#' comments is '{', as in every
// .cameramodel (and in no OpenCV YAML or XML file).
bool StartsLikeADict(const std::string& text) {
  std::size_t i = 0;
  while (i < text.size()) {
    if (std::isspace(static_cast<unsigned char>(text[i]))) {
      ++i;
    } else if (text[i] == '#') {
      while (i < text.size() && text[i] != '\n') ++i;
    } else {
      return text[i] == '{';
    }
  }
  return false;
}

// ---------------------------------------------------------------------------------------------

struct MrcalCameraModelDeleter {
  void operator()(mrcal_cameramodel_t* m) const { mrcal_free_cameramodel(&m); }
};

// mrcal's parsed lens model, out of CameraModel's opaque storage (see Create).
mrcal_lensmodel_t LoadLensModel(const unsigned char* bytes) {
  mrcal_lensmodel_t m;
  std::memcpy(&m, bytes, sizeof(m));
  return m;
}

// "[ 1, 2, 3,]" as mrcal's Python writes it; 8 values a line for long lists.
std::string FormatList(const double* v, std::size_t n) {
  std::string s = "[";
  for (std::size_t i = 0; i < n; ++i) {
    s += (i > 0 && i % 8 == 0) ? "\n                  " : " ";
    s += RoundTrip(v[i]) + ",";
  }
  return s + "]";
}

}  // namespace

Status CameraModel::Create(const std::string& lensmodel, const std::vector<double>& intrinsics,
                           int width, int height, CameraModel* out) {
  static_assert(
      sizeof(mrcal_lensmodel_t) <= kMrcalLensModelBytes && alignof(mrcal_lensmodel_t) <= 8,
      "CameraModel::mrcal_lensmodel_ is too small for mrcal_lensmodel_t");
  mrcal_lensmodel_t m;
  if (std::string e = CheckLensModel(lensmodel, &m); !e.empty()) return Status::Error(e);
  const int n = mrcal_lensmodel_num_params(&m);
  if (static_cast<int>(intrinsics.size()) != n) {
    return Status::Error("intrinsics: expected " + std::to_string(n) + " values for " + lensmodel +
                         ", got " + std::to_string(intrinsics.size()));
  }
  for (int i = 0; i < n; ++i) {
    if (std::string e = CheckFinite("intrinsics", i, intrinsics[i]); !e.empty()) {
      return Status::Error(e);
    }
  }
  // A lens model with a core (fx, fy, cx, cy first) needs positive focal lengths: zero divides
  // by zero when unprojecting, a negative one mirrors the image.
  if (mrcal_lensmodel_metadata(&m).has_core) {
    for (int i = 0; i < 2; ++i) {
      if (!(intrinsics[i] > 0)) {
        return Status::Error("intrinsics[" + std::to_string(i) + "]: expected a positive focal " +
                             "length " + (i == 0 ? "fx" : "fy") + " (pixels), got " +
                             RoundTrip(intrinsics[i]));
      }
    }
  }
  if (width <= 0 || height <= 0) {
    return Status::Error("imagersize: expected a positive width and height (pixels), got " +
                         std::to_string(width) + "x" + std::to_string(height));
  }
  CameraModel c;
  c.lensmodel_ = lensmodel;
  c.intrinsics_ = intrinsics;
  c.width_ = width;
  c.height_ = height;
  std::memcpy(c.mrcal_lensmodel_.data(), &m, sizeof(m));
  *out = std::move(c);
  return Status::Ok();
}

CameraModel CameraModel::Pinhole(double f, int width, int height) {
  CameraModel c;
  const Status s =
      Create("LENSMODEL_PINHOLE", {f, f, 0.5 * (width - 1), 0.5 * (height - 1)}, width, height, &c);
  if (!s.ok() || !(f > 0)) {
    assert(false && "CameraModel::Pinhole: f must be > 0 and the image size positive");
    return CameraModel();
  }
  return c;
}

Status CameraModel::Read(const std::string& path, CameraModel* out) {
  std::error_code ec;
  if (!fs::exists(fs::status(path, ec))) {
    return Status::Error(path + ": no such file; expected an mrcal .cameramodel file");
  }
  std::string text;
  if (Status s = ReadTextFile(path, &text); !s) return s;
  if (text.find('\0') != std::string::npos) {
    return Status::Error(path + ": contains a NUL byte; " + kExpectedFile);
  }
  // An OpenCV camera file (cv::FileStorage YAML or XML) is a common mistake: say how to
  // convert it rather than pass it to mrcal's parser, whose complaint would not say.
  if (LooksLikeOpenCvCameraFile(path, text) && !StartsLikeADict(text)) {
    return Status::Error(path +
                         ": an OpenCV camera file, not an mrcal .cameramodel; convert it with "
                         "`svms camera import " +
                         path + " --out CAM.cameramodel`");
  }
  if (std::string e = UnclosedString(text); !e.empty()) {
    return Status::Error(path + ": " + e + "; " + kExpectedFile);
  }
  if (!text.empty() && text.back() != '\n') text += '\n';  // see UnclosedString

  // We hand mrcal the bytes we read (rather than the path) so that a failure is explained from
  // exactly what mrcal saw. len = 0: the text ends at its terminating NUL.
  const std::unique_ptr<mrcal_cameramodel_t, MrcalCameraModelDeleter> m(
      text.empty() ? nullptr : mrcal_read_cameramodel_string(text.c_str(), 0));
  if (!m) return Status::Error(path + ": " + Diagnose(text));

  char name[1024];
  if (!mrcal_lensmodel_name(name, sizeof(name), &m->lensmodel)) {
    return Status::Error(path + ": lensmodel: mrcal cannot name this lens model");
  }
  const int n = mrcal_lensmodel_num_params(&m->lensmodel);
  if (m->imagersize[0] > INT_MAX || m->imagersize[1] > INT_MAX) {
    return Status::Error(path + ": imagersize: expected a width and height below 2^31, got " +
                         std::to_string(m->imagersize[0]) + "x" + std::to_string(m->imagersize[1]));
  }
  CameraModel c;
  const Status s =
      Create(name, std::vector<double>(m->intrinsics, m->intrinsics + n),
             static_cast<int>(m->imagersize[0]), static_cast<int>(m->imagersize[1]), &c);
  if (!s.ok()) return Status::Error(path + ": " + s.message());
  for (int i = 0; i < 6; ++i) {
    if (std::string e = CheckFinite("extrinsics", i, m->rt_cam_ref[i]); !e.empty()) {
      return Status::Error(path + ": " + e);
    }
  }
  c.cam_from_ref_.rvec = Eigen::Vector3d(m->rt_cam_ref[0], m->rt_cam_ref[1], m->rt_cam_ref[2]);
  c.cam_from_ref_.tvec = Eigen::Vector3d(m->rt_cam_ref[3], m->rt_cam_ref[4], m->rt_cam_ref[5]);
  *out = std::move(c);
  return Status::Ok();
}

Status CameraModel::CheckLensModelName(const std::string& lensmodel, int* num_intrinsics,
                                       bool* has_gradients) {
  mrcal_lensmodel_t m{};
  if (std::string e = CheckLensModel(lensmodel, &m); !e.empty()) return Status::Error(e);
  if (num_intrinsics) *num_intrinsics = mrcal_lensmodel_num_params(&m);
  if (has_gradients) *has_gradients = m.type != MRCAL_LENSMODEL_CAHVORE;
  return Status::Ok();
}

Status CameraModel::ToText(const std::string& path, std::string* out) const {
  // Not mrcal_write_cameramodel_file: mrcal 2.2's C writer prints every number with "%f"
  // (6 decimals), which loses precision (and turns small distortion terms into 0).
  if (empty()) {
    return Status::Error(path +
                         ": cannot write an empty CameraModel; expected one made by "
                         "Create, Read or Pinhole");
  }
  const double rt[6] = {cam_from_ref_.rvec.x(), cam_from_ref_.rvec.y(), cam_from_ref_.rvec.z(),
                        cam_from_ref_.tvec.x(), cam_from_ref_.tvec.y(), cam_from_ref_.tvec.z()};
  for (int i = 0; i < 6; ++i) {
    if (std::string e = CheckFinite("extrinsics", i, rt[i]); !e.empty()) {
      return Status::Error(path + ": " + e + " (cam_from_ref)");
    }
  }
  std::string text = "# mrcal camera model written by SVMS\n{\n";
  text += "    'lensmodel':  '" + lensmodel_ + "',\n\n";
  text += "    # intrinsics are fx,fy,cx,cy,distortion0,distortion1,....\n";
  text += "    'intrinsics': " + FormatList(intrinsics_.data(), intrinsics_.size()) + ",\n\n";
  text += "    # extrinsics are rt_fromref\n";
  text += "    'extrinsics': " + FormatList(rt, 6) + ",\n\n";
  text +=
      "    'imagersize': [ " + std::to_string(width_) + ", " + std::to_string(height_) + ",],\n}\n";
  *out = std::move(text);
  return Status::Ok();
}

Status CameraModel::Write(const std::string& path) const {
  std::string text;
  if (Status s = ToText(path, &text); !s) return s;
  return WriteFileAtomically(path, text);
}

std::string CameraModel::UnusableReason() const {
  if (empty()) return "an empty camera model";
  const mrcal_lensmodel_t lm = LoadLensModel(mrcal_lensmodel_.data());
  if (lm.type == MRCAL_LENSMODEL_CAHVORE)
    return lensmodel_ +
           ": mrcal 2.2 can neither unproject this model nor give its gradients, which corner "
           "fits and poses need; expected another lens model (e.g. LENSMODEL_OPENCV8)";
  if (mrcal_lensmodel_metadata(&lm).has_core) {
    for (int i = 0; i < 2; ++i) {
      const double f = intrinsics_[i];
      if (!(f >= kMinFocalPx && f <= kMaxFocalPx)) {
        char range[64];
        std::snprintf(range, sizeof range, "expected %g to %g", kMinFocalPx, kMaxFocalPx);
        return "intrinsics[" + std::to_string(i) + "]: " + (i == 0 ? "fx " : "fy ") + RoundTrip(f) +
               " pixels is not a focal length a lens has; " + range;
      }
    }
  }
  const Eigen::Vector2d centre(0.5 * (width_ - 1), 0.5 * (height_ - 1));
  Eigen::Vector3d d;
  Eigen::Vector2d back;
  Eigen::Matrix<double, 2, 3> J;
  if (!Unproject(centre, &d) || !Project(d, &back, &J) || !J.allFinite() ||
      (back - centre).norm() > 1e-3) {
    char buf[200];
    std::snprintf(buf, sizeof buf,
                  "the image centre (%.1f, %.1f) does not unproject and project back to itself; "
                  "expected a model that maps its image",
                  centre.x(), centre.y());
    return buf;
  }
  return "";
}

bool CameraModel::Project(const Eigen::Vector3d& p_cam, Eigen::Vector2d* px,
                          Eigen::Matrix<double, 2, 3>* dpx_dp,
                          Eigen::Matrix<double, 2, Eigen::Dynamic>* dpx_dintrinsics) const {
  assert(px != nullptr);
  if (empty() || !p_cam.allFinite()) return false;
  const mrcal_lensmodel_t lm = LoadLensModel(mrcal_lensmodel_.data());
  if (lm.type == MRCAL_LENSMODEL_PINHOLE) {
    // mrcal's pinhole formula, inline: the detector and the fits project thousands of points
    // per frame, and the call into mrcal (metadata, dispatch) costs more than the arithmetic.
    if (!(p_cam.z() > 0)) return false;
    const double fx = intrinsics_[0], fy = intrinsics_[1], cx = intrinsics_[2], cy = intrinsics_[3];
    const double iz = 1 / p_cam.z(), x = p_cam.x() * iz, y = p_cam.y() * iz;
    const Eigen::Vector2d q(fx * x + cx, fy * y + cy);
    if (!q.allFinite()) return false;
    if (dpx_dp != nullptr) {
      *dpx_dp << fx * iz, 0, -fx * x * iz, 0, fy * iz, -fy * y * iz;
      if (!dpx_dp->allFinite()) return false;
    }
    if (dpx_dintrinsics != nullptr) {
      dpx_dintrinsics->resize(2, 4);
      *dpx_dintrinsics << x, 0, 1, 0, 0, y, 0, 1;
    }
    *px = q;
    return true;
  }
  const mrcal_lensmodel_metadata_t meta = mrcal_lensmodel_metadata(&lm);
  if (!meta.can_project_behind_camera && !(p_cam.z() > 0)) return false;
  // CAHVORE: mrcal_project fails (and complains on stderr) if asked for gradients.
  if ((dpx_dp != nullptr || dpx_dintrinsics != nullptr) && !meta.has_gradients) return false;

  const mrcal_point3_t p = {{p_cam.x(), p_cam.y(), p_cam.z()}};
  mrcal_point2_t q;
  mrcal_point3_t dq_dp[2];  // row-major 2x3: dq_dp[row].xyz[col]
  // mrcal_project writes dq/dintrinsics as a dense row-major (N points, 2, Nintrinsics) array
  // for every model that has gradients. For splined models mrcal 2.2 computes the gradient
  // sparsely inside (only the core and the control points near the point are non-zero) and
  // densifies it before returning; camera_test checks it against finite differences.
  const int n = static_cast<int>(intrinsics_.size());
  // Per thread and kept: a warmed-up caller (the fusion's calibration term) allocates nothing.
  thread_local Eigen::Matrix<double, 2, Eigen::Dynamic, Eigen::RowMajor> dq_di;
  if (dpx_dintrinsics != nullptr) dq_di.resize(2, n);
  if (!mrcal_project(&q, dpx_dp != nullptr ? dq_dp : nullptr,
                     dpx_dintrinsics != nullptr ? dq_di.data() : nullptr, &p, 1, &lm,
                     intrinsics_.data())) {
    return false;
  }
  if (!std::isfinite(q.x) || !std::isfinite(q.y)) return false;
  Eigen::Matrix<double, 2, 3> j_p;
  if (dpx_dp != nullptr) {
    for (int r = 0; r < 2; ++r) {
      for (int c = 0; c < 3; ++c) j_p(r, c) = dq_dp[r].xyz[c];
    }
    if (!j_p.allFinite()) return false;
  }
  if (dpx_dintrinsics != nullptr && !dq_di.allFinite()) return false;

  *px = Eigen::Vector2d(q.x, q.y);
  if (dpx_dp != nullptr) *dpx_dp = j_p;
  if (dpx_dintrinsics != nullptr) *dpx_dintrinsics = dq_di;
  return true;
}

namespace {

// Unprojects one pixel by Newton's method on mrcal_project, in the stereographic
// parametrisation of directions (unit focal length: u = 2 tan(theta / 2) (x, y) / |(x, y)|),
// which covers every direction but straight back, so that wide lenses converge as well as
// narrow ones. It starts from the stereographic unprojection through the model's core (fx,
// fy, cx, cy), or from the optical axis for models without one.
//
// Why not mrcal_unproject: mrcal 2.2 runs a dogleg solver per point that allocates on the
// heap five times per pixel, and the detector unprojects about a thousand edge points per
// frame through non-pinhole models; the C API promises no allocation per frame. This solve
// needs only mrcal_project's own gradient and stack memory. Returns false when it does not
// reach max_residual_px (pixels) in 40 iterations; callers then ask mrcal_unproject.
bool NewtonUnproject(const mrcal_lensmodel_t& lm, bool has_core, const double* intrinsics,
                     const Eigen::Vector2d& px, double max_residual_px, Eigen::Vector3d* v_out) {
  static const double kUnitCore[4] = {1, 1, 0, 0};
  mrcal_point2_t u{{0, 0}};
  if (has_core) {
    const mrcal_point2_t q{{px.x(), px.y()}};
    mrcal_point3_t v0;
    mrcal_unproject_stereographic(&v0, nullptr, &q, 1, intrinsics);
    mrcal_project_stereographic(&u, nullptr, &v0, 1, kUnitCore);
  }
  // Pixel residual and its Jacobian d q / d u (2x2) at u.
  auto evaluate = [&](const mrcal_point2_t& at, mrcal_point3_t* v, Eigen::Vector2d* r,
                      Eigen::Matrix2d* J) {
    mrcal_point2_t dv_du[3];
    mrcal_unproject_stereographic(v, J ? dv_du : nullptr, &at, 1, kUnitCore);
    mrcal_point2_t q;
    mrcal_point3_t dq_dv[2];
    if (!mrcal_project(&q, J ? dq_dv : nullptr, nullptr, v, 1, &lm, intrinsics)) return false;
    *r = Eigen::Vector2d(q.x - px.x(), q.y - px.y());
    if (J) {
      for (int i = 0; i < 2; ++i)
        for (int j = 0; j < 2; ++j)
          (*J)(i, j) = dq_dv[i].xyz[0] * dv_du[0].xy[j] + dq_dv[i].xyz[1] * dv_du[1].xy[j] +
                       dq_dv[i].xyz[2] * dv_du[2].xy[j];
    }
    return r->allFinite() && (!J || J->allFinite());
  };
  mrcal_point3_t v;
  Eigen::Vector2d r;
  Eigen::Matrix2d J;
  if (!evaluate(u, &v, &r, &J)) return false;
  for (int iter = 0; iter < 40 && r.norm() > 1e-3 * max_residual_px; ++iter) {
    const double det = J.determinant();
    if (!(std::abs(det) > 0)) return false;
    const Eigen::Vector2d step = -J.inverse() * r;
    // Backtracking: halve the step until the residual shrinks.
    double scale = 1;
    bool improved = false;
    for (int k = 0; k < 20 && !improved; ++k, scale *= 0.5) {
      const mrcal_point2_t trial{{u.x + scale * step.x(), u.y + scale * step.y()}};
      mrcal_point3_t v_trial;
      Eigen::Vector2d r_trial;
      if (evaluate(trial, &v_trial, &r_trial, nullptr) && r_trial.norm() < r.norm()) {
        u = trial;
        improved = true;
      }
    }
    if (!improved || !evaluate(u, &v, &r, &J)) break;
  }
  if (!(r.norm() <= max_residual_px)) return false;
  *v_out = Eigen::Vector3d(v.x, v.y, v.z);
  return true;
}

}  // namespace

bool CameraModel::UnprojectMany(const std::vector<Eigen::Vector2d>& px,
                                std::vector<Eigen::Vector3d>* directions) const {
  assert(directions != nullptr);
  const std::size_t count = px.size();
  const Eigen::Vector3d kFailed = Eigen::Vector3d::Constant(std::nan(""));
  directions->assign(count, kFailed);
  if (count == 0) return !empty();
  if (empty() || count > static_cast<std::size_t>(INT_MAX)) return false;
  bool all_ok = true;
  for (std::size_t i = 0; i < count; ++i) {
    if (!Unproject(px[i], &(*directions)[i])) all_ok = false;
  }
  return all_ok;
}

bool CameraModel::Unproject(const Eigen::Vector2d& px, Eigen::Vector3d* direction) const {
  assert(direction != nullptr);
  if (empty() || !px.allFinite()) return false;
  const mrcal_lensmodel_t lm = LoadLensModel(mrcal_lensmodel_.data());
  // mrcal 2.2 cannot unproject CAHVORE (and says so on stderr at every call).
  if (lm.type == MRCAL_LENSMODEL_CAHVORE) return false;
  const mrcal_lensmodel_metadata_t meta = mrcal_lensmodel_metadata(&lm);
  Eigen::Vector3d d;
  // Newton first (no heap), mrcal's dogleg for what it leaves.
  if (!NewtonUnproject(lm, meta.has_core, intrinsics_.data(), px, 1e-6, &d)) {
    const mrcal_point2_t q{{px.x(), px.y()}};
    mrcal_point3_t v;
    // mrcal 2.2 signals a solve that did not converge with NaN in v (and still returns true).
    if (!mrcal_unproject(&v, &q, 1, &lm, intrinsics_.data())) return false;
    d = Eigen::Vector3d(v.x, v.y, v.z);
  }
  const double norm = d.norm();
  if (!std::isfinite(norm) || norm == 0 || (!meta.can_project_behind_camera && !(d.z() > 0)))
    return false;
  const Eigen::Vector3d unit = d / norm;
  // A finite answer is accepted only if it projects back onto the pixel.
  const mrcal_point3_t p{{unit.x(), unit.y(), unit.z()}};
  mrcal_point2_t back;
  if (!mrcal_project(&back, nullptr, nullptr, &p, 1, &lm, intrinsics_.data())) return false;
  if (!(std::hypot(back.x - px.x(), back.y - px.y()) <= kUnprojectTolerancePx)) return false;
  *direction = unit;
  return true;
}

Status CameraModel::set_intrinsics_covariance_factor(const Eigen::MatrixXd& factor) {
  const Eigen::Index n = static_cast<Eigen::Index>(intrinsics_.size());
  if (factor.size() == 0) {
    intrinsics_cov_factor_.resize(0, 0);
    return Status::Ok();
  }
  if (factor.rows() != n || factor.cols() != n) {
    return Status::Error("intrinsics covariance: expected a " + std::to_string(n) + "x" +
                         std::to_string(n) + " factor for " + lensmodel_ + ", got " +
                         std::to_string(factor.rows()) + "x" + std::to_string(factor.cols()));
  }
  if (!factor.allFinite()) {
    return Status::Error("intrinsics covariance: expected finite numbers, got a NaN or infinity");
  }
  intrinsics_cov_factor_ = factor;
  return Status::Ok();
}

std::string CameraModel::Summary() const {
  if (empty()) return "(empty camera model)";
  std::string s = lensmodel_ + " " + std::to_string(width_) + "x" + std::to_string(height_);
  const mrcal_lensmodel_t lm = LoadLensModel(mrcal_lensmodel_.data());
  if (mrcal_lensmodel_metadata(&lm).has_core) {
    char buf[96];
    std::snprintf(buf, sizeof(buf), ", fx %.1f fy %.1f", intrinsics_[0], intrinsics_[1]);
    s += buf;
  }
  return s;
}

}  // namespace svms
