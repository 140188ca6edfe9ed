#include "svms/camera/photometric.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "svms/base/file_io.h"
#include "svms/base/json_fields.h"
#include "svms/camera/bayer_luminance.h"

namespace svms {

Response Response::Srgb() {
  Response r;
  r.kind_ = Kind::kSrgb;
  return r;
}

Response Response::Gamma(double gamma) {
  Response r;
  r.kind_ = Kind::kGamma;
  r.gamma_ = gamma;
  return r;
}

Status Response::Table(const std::vector<double>& t, Response* out) {
  if (t.size() < 2 || t.size() > 65536)
    return Status::Error("response table: expected 2 to 65536 entries, got " +
                         std::to_string(t.size()));
  for (size_t i = 0; i < t.size(); ++i) {
    if (!std::isfinite(t[i]) || t[i] < 0 || t[i] > 1 || (i > 0 && t[i] < t[i - 1]))
      return Status::Error("response table[" + std::to_string(i) +
                           "]: expected non-decreasing numbers in [0, 1]");
  }
  if (t.front() != 0 || t.back() != 1)
    return Status::Error(
        "response table: expected the first entry 0 and the last 1 (linear "
        "light of the darkest and the brightest encoded value)");
  Response r;
  r.kind_ = Kind::kTable;
  r.table_ = t;
  *out = std::move(r);
  return Status::Ok();
}

Status Response::Parse(const std::string& text, Response* out) {
  const std::string choices = "; expected linear, srgb, gamma:G (e.g. gamma:2.2) or table:FILE";
  if (text == "linear") {
    *out = Linear();
    return Status::Ok();
  }
  if (text == "srgb" || text == "sRGB") {
    *out = Srgb();
    return Status::Ok();
  }
  if (text.rfind("gamma:", 0) == 0) {
    char* end = nullptr;
    const double g = std::strtod(text.c_str() + 6, &end);
    if (end == text.c_str() + 6 || *end != '\0' || !(g >= 0.1 && g <= 10))
      return Status::Error("--response \"" + text + "\": expected gamma:G with G in [0.1, 10]");
    *out = Gamma(g);
    return Status::Ok();
  }
  if (text.rfind("table:", 0) == 0) {
    const std::string path = text.substr(6);
    std::string body;
    if (Status s = ReadTextFile(path, &body); !s)
      return Status::Error("--response: " + s.message());
    std::istringstream in(body);
    std::vector<double> t;
    for (std::string w; in >> w;) {
      char* end = nullptr;
      const double v = std::strtod(w.c_str(), &end);
      if (*end != '\0') return Status::Error(path + ": \"" + w + "\" is not a number" + choices);
      t.push_back(v);
    }
    if (Status s = Table(t, out); !s) return Status::Error(path + ": " + s.message());
    return Status::Ok();
  }
  return Status::Error("--response \"" + text + "\": unknown response" + choices);
}

std::string Response::Name() const {
  switch (kind_) {
    case Kind::kLinear:
      return "linear";
    case Kind::kSrgb:
      return "srgb";
    case Kind::kGamma: {
      char buf[32];
      std::snprintf(buf, sizeof buf, "gamma:%g", gamma_);
      return buf;
    }
    case Kind::kTable:
      return "table(" + std::to_string(table_.size()) + " entries)";
  }
  return "";
}

double Response::ToLinear(double e) const {
  e = std::clamp(e, 0.0, 1.0);
  switch (kind_) {
    case Kind::kLinear:
      return e;
    case Kind::kSrgb:
      return e <= 0.04045 ? e / 12.92 : std::pow((e + 0.055) / 1.055, 2.4);
    case Kind::kGamma:
      return std::pow(e, gamma_);
    case Kind::kTable: {
      const double x = e * static_cast<double>(table_.size() - 1);
      const size_t i = std::min(static_cast<size_t>(x), table_.size() - 2);
      const double f = x - static_cast<double>(i);
      return (1 - f) * table_[i] + f * table_[i + 1];
    }
  }
  return e;
}

double Response::FromLinear(double l) const {
  l = std::clamp(l, 0.0, 1.0);
  switch (kind_) {
    case Kind::kLinear:
      return l;
    case Kind::kSrgb:
      return l <= 0.0031308 ? 12.92 * l : 1.055 * std::pow(l, 1 / 2.4) - 0.055;
    case Kind::kGamma:
      return std::pow(l, 1 / gamma_);
    case Kind::kTable: {
      // The table is non-decreasing: the first entry at or above l, interpolated.
      const auto it = std::lower_bound(table_.begin(), table_.end(), l);
      if (it == table_.begin()) return 0;
      if (it == table_.end()) return 1;
      const size_t i = static_cast<size_t>(it - table_.begin());
      const double a = table_[i - 1], b = table_[i];
      const double f = b > a ? (l - a) / (b - a) : 0;
      return (static_cast<double>(i - 1) + f) / static_cast<double>(table_.size() - 1);
    }
  }
  return l;
}

double Response::Slope(double e) const {
  const double h = 1e-4;
  const double a = std::max(0.0, e - h), b = std::min(1.0, e + h);
  return (ToLinear(b) - ToLinear(a)) / (b - a);
}

Status ParseBayerPattern(const std::string& text, BayerPattern* out) {
  std::string t;
  for (char c : text) t += static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  if (t.empty() || t == "NONE")
    *out = BayerPattern::kNone;
  else if (t == "RGGB")
    *out = BayerPattern::kRggb;
  else if (t == "BGGR")
    *out = BayerPattern::kBggr;
  else if (t == "GRBG")
    *out = BayerPattern::kGrbg;
  else if (t == "GBRG")
    *out = BayerPattern::kGbrg;
  else
    return Status::Error("--bayer \"" + text +
                         "\": unknown Bayer pattern; expected RGGB, BGGR, GRBG or GBRG");
  return Status::Ok();
}

Status ParseBayerMethod(const std::string& text, BayerMethod* out) {
  if (text == "luminance") {
    *out = BayerMethod::kLuminance;
  } else if (text == "opencv") {
    *out = BayerMethod::kOpenCv;
  } else {
    return Status::Error("--demosaic \"" + text + "\": unknown; expected luminance or opencv");
  }
  return Status::Ok();
}

std::string BayerMethodName(BayerMethod method) {
  return method == BayerMethod::kOpenCv ? "opencv" : "luminance";
}

std::string BayerPatternName(BayerPattern p) {
  switch (p) {
    case BayerPattern::kRggb:
      return "RGGB";
    case BayerPattern::kBggr:
      return "BGGR";
    case BayerPattern::kGrbg:
      return "GRBG";
    case BayerPattern::kGbrg:
      return "GBRG";
    case BayerPattern::kNone:
      break;
  }
  return "none";
}

bool PhotometricModel::IsIdentity(double depth_max) const {
  return response.kind() == Response::Kind::kLinear && black_level == 0 &&
         (white_level == 0 || white_level == depth_max) && bayer == BayerPattern::kNone;
}

namespace {

// Stored value -> linear light, 0 .. 65535, for the `n` values of a depth whose largest is
// n - 1.
std::vector<uint16_t> LinearTable(const PhotometricModel& m, int n) {
  const double white = m.white_level > 0 ? m.white_level : n - 1;
  std::vector<uint16_t> lut(static_cast<size_t>(n));
  for (int v = 0; v < n; ++v) {
    const double e = (v - m.black_level) / (white - m.black_level);
    lut[static_cast<size_t>(v)] =
        static_cast<uint16_t>(std::lround(65535 * m.response.ToLinear(std::clamp(e, 0.0, 1.0))));
  }
  return lut;
}

}  // namespace

Linearizer::Linearizer(const PhotometricModel& model, int depth) : model_(model) {
  if (!model_.Check().ok()) return;
  if (depth != CV_16U && model_.white_level <= 255) lut8_ = LinearTable(model_, 256);
  if (depth != CV_8U) lut16_ = LinearTable(model_, 65536);
}

Status Linearizer::Apply(const cv::Mat& stored_in, cv::Mat* linear) const {
  const cv::Mat stored = stored_in;  // a header of our own: `linear` may be `stored_in`
  const PhotometricModel& m = model_;
  if (stored.empty() || (stored.depth() != CV_8U && stored.depth() != CV_16U) ||
      (stored.channels() != 1 && stored.channels() != 3))
    return Status::Error("expected an 8- or 16-bit image of 1 or 3 channels");
  if (m.bayer != BayerPattern::kNone && stored.channels() != 1)
    return Status::Error("--bayer " + BayerPatternName(m.bayer) +
                         ": expected a one-channel mosaic, got a colour image");
  const bool eight = stored.depth() == CV_8U;
  const double depth_max = eight ? 255 : 65535;
  if (Status s = m.Check(); !s) return s;
  const double white = m.white_level > 0 ? m.white_level : depth_max;
  if (m.black_level >= white || white > depth_max)
    return Status::Error(
        "black level " + std::to_string(m.black_level) + ", white level " + std::to_string(white) +
        ": expected 0 <= black < white <= " + std::to_string(static_cast<int>(depth_max)) +
        " for a " + (eight ? "8" : "16") + "-bit image");
  if (stored.channels() == 1 && eight && m.IsIdentity(depth_max)) {
    *linear = stored;
    return Status::Ok();
  }
  const std::vector<uint16_t>& lut = eight ? lut8_ : lut16_;
  if (lut.empty()) return Status::Error("no table for this depth (white level)");
  cv::Mat& out = *linear;
  const bool direct = stored.channels() == 1 && m.bayer == BayerPattern::kNone;
  thread_local cv::Mat mosaic, bgr;
  cv::Mat& table_out = direct ? out : (m.bayer != BayerPattern::kNone ? mosaic : bgr);
  if (table_out.data == stored.data) table_out = cv::Mat();  // never write over the input
  table_out.create(stored.size(), CV_16UC(stored.channels()));
  const int width = stored.cols * stored.channels();
  for (int y = 0; y < stored.rows; ++y) {
    uint16_t* o = table_out.ptr<uint16_t>(y);
    if (eight) {
      const uint8_t* p = stored.ptr<uint8_t>(y);
      for (int x = 0; x < width; ++x) o[x] = lut[p[x]];
    } else {
      const uint16_t* p = stored.ptr<uint16_t>(y);
      for (int x = 0; x < width; ++x) o[x] = lut[p[x]];
    }
  }
  if (direct) return Status::Ok();
  if (m.bayer != BayerPattern::kNone && m.demosaic == BayerMethod::kLuminance) {
    if (out.data == stored.data) out = cv::Mat();
    BayerLuminance(mosaic, m.bayer, EstimateBayerGains(mosaic, m.bayer), &out);
    return Status::Ok();
  }
  if (m.bayer != BayerPattern::kNone) {
    static const int codes[] = {0, cv::COLOR_BayerRGGB2BGR_EA, cv::COLOR_BayerBGGR2BGR_EA,
                                cv::COLOR_BayerGRBG2BGR_EA, cv::COLOR_BayerGBRG2BGR_EA};
    cv::cvtColor(mosaic, bgr, codes[static_cast<int>(m.bayer)]);
  }
  // Luminance in linear light (Rec. 709 / sRGB primaries), B, G, R order.
  if (out.data == stored.data) out = cv::Mat();
  cv::transform(bgr, out, cv::Matx13f(0.0722f, 0.7152f, 0.2126f));
  return Status::Ok();
}

Status LinearizeImage(const cv::Mat& stored, const PhotometricModel& model, cv::Mat* linear) {
  return Linearizer(model, stored.depth()).Apply(stored, linear);
}

Status PhotometricModel::Check() const {
  if (!std::isfinite(black_level) || !std::isfinite(white_level) || black_level < 0 ||
      white_level < 0 || (white_level > 0 && !(black_level < white_level)))
    return Status::Error("black_level " + std::to_string(black_level) + ", white_level " +
                         std::to_string(white_level) +
                         ": expected 0 <= black level < white level (white 0: the largest "
                         "value of the image's depth)");
  return Status::Ok();
}

std::string PhotometricModel::Summary(double depth_max) const {
  char buf[128];
  std::snprintf(buf, sizeof buf, "%s, black %g, white %g", response.Name().c_str(), black_level,
                white_level > 0 ? white_level : depth_max);
  return buf;
}

const char* PhotometrySourceName(PhotometrySource source) {
  switch (source) {
    case PhotometrySource::kOption:
      return "option";
    case PhotometrySource::kCameraFile:
      return "camera";
    case PhotometrySource::kImageFile:
      return "image";
    case PhotometrySource::kDefault:
      return "default";
  }
  return "";
}

std::string PhotometricPath(const std::string& cameramodel_path) {
  return cameramodel_path + ".photometric.json";
}

Status ParsePhotometricJson(const std::string& text, const std::string& source,
                            PhotometricModel* out) {
  using namespace json_fields;  // NOLINT: the field readers
  json j;
  std::string error;
  if (!ParseText(text, source, &j, &error)) return Status::Error(error);
  PhotometricModel m;
  try {
    CheckKeys(
        j, "",
        {"type", "response", "response_table", "black_level", "white_level", "bayer", "demosaic"});
    if (String(j, "", "type") != "svms.photometric")
      Fail("type", "\"svms.photometric\"", j["type"]);
    if (j.contains("response") == j.contains("response_table"))
      throw FieldError{"response: expected either \"response\" or \"response_table\""};
    if (j.contains("response")) {
      if (Status s = Response::Parse(String(j, "", "response"), &m.response);
          !s || m.response.kind() == Response::Kind::kTable)
        throw FieldError{"response: expected \"linear\", \"srgb\" or \"gamma:G\", got " +
                         j["response"].dump()};
    } else {
      const json& t = j["response_table"];
      if (!t.is_array()) Fail("response_table", "an array of numbers", t);
      std::vector<double> v;
      for (size_t i = 0; i < t.size(); ++i) {
        if (!t[i].is_number()) Fail("response_table[" + std::to_string(i) + "]", "a number", t[i]);
        v.push_back(t[i].get<double>());
      }
      if (Status s = Response::Table(v, &m.response); !s) throw FieldError{s.message()};
    }
    m.black_level = NumberIn(j, "", "black_level", 0, 65535);
    m.white_level = NumberIn(j, "", "white_level", 0, 65535);
    if (j.contains("bayer"))
      if (Status s = ParseBayerPattern(String(j, "", "bayer"), &m.bayer); !s)
        throw FieldError{"bayer: expected RGGB, BGGR, GRBG or GBRG, got " + j["bayer"].dump()};
    if (j.contains("demosaic"))
      if (Status s = ParseBayerMethod(String(j, "", "demosaic"), &m.demosaic); !s)
        throw FieldError{"demosaic: expected luminance or opencv, got " + j["demosaic"].dump()};
    if (Status s = m.Check(); !s) throw FieldError{s.message()};
  } catch (const FieldError& e) {
    return Status::Error(source + ": " + e.message);
  }
  *out = std::move(m);
  return Status::Ok();
}

Status ReadPhotometricFile(const std::string& path, PhotometricModel* out) {
  std::string text;
  if (Status s = ReadTextFile(path, &text); !s) return s;
  return ParsePhotometricJson(text, path, out);
}

std::string PhotometricToJson(const PhotometricModel& m) {
  json_fields::json j = {
      {"type", "svms.photometric"}, {"black_level", m.black_level}, {"white_level", m.white_level}};
  if (m.bayer != BayerPattern::kNone) {
    j["bayer"] = BayerPatternName(m.bayer);
    j["demosaic"] = BayerMethodName(m.demosaic);
  }
  if (m.response.kind() == Response::Kind::kTable)
    j["response_table"] = m.response.table();
  else
    j["response"] = m.response.Name();
  return j.dump(2) + "\n";
}

}  // namespace svms
