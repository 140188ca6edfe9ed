#include "svms/camera/opencv_camera.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <opencv2/core.hpp>

#include "svms/base/file_io.h"
#include "svms/base/format.h"

namespace svms {
namespace {

std::string Lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

bool EndsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() &&
         s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

constexpr const char* kExpectedFile =
    "expected an OpenCV camera file (cv::FileStorage YAML, XML or JSON) with a camera matrix, "
    "distortion coefficients and the image size";

// What OpenCV says about a file it cannot parse, in one line. OpenCV 4.6 passes a parse
// error's text, "FILENAME(LINE): what", as the exception's function name and the function's
// name as its text (FileStorage::Impl::parseError), so the text is taken from where it is; the
// line number is corrected for the `added_lines` WithOpenCvYamlDirective put in front.
std::string ParseErrorText(const cv::Exception& e, int added_lines) {
  std::string why = e.code == cv::Error::StsParseError && !e.func.empty() ? e.func : e.err;
  if (!why.empty() && why[0] == '(') {  // "(LINE): what" for text read from memory
    const size_t close = why.find("): ");
    int line = 0;
    if (close != std::string::npos && std::sscanf(why.c_str(), "(%d)", &line) == 1) {
      why = "line " + std::to_string(line - added_lines) + ": " + why.substr(close + 3);
    }
  }
  std::replace(why.begin(), why.end(), '\n', ' ');
  return why;
}

// A matrix read from a file node: its values row by row, and its shape.
struct Numbers {
  std::vector<double> v;
  int rows = 0, cols = 0;
};

// Reads one number. False for anything else.
bool ReadNumber(const cv::FileNode& n, double* x) {
  if (!n.isInt() && !n.isReal()) return false;
  *x = n.real();
  return true;
}

// Reads a node as numbers: a number (1x1), a sequence of numbers (1xN) or of equal sequences
// of numbers (rows), an OpenCV matrix (!!opencv-matrix), or a ROS-style map {rows, cols, data}.
// Returns "" or what is wrong (without the field name).
std::string ReadNumbers(const cv::FileNode& n, Numbers* out) {
  Numbers r;
  double x;
  if (ReadNumber(n, &x)) {
    r.v = {x};
    r.rows = r.cols = 1;
  } else if (n.isSeq()) {
    for (size_t i = 0; i < n.size(); ++i) {
      const cv::FileNode item = n[static_cast<int>(i)];
      const bool nested = item.isSeq();
      if (i > 0 && nested != (n[0].isSeq())) return "expected numbers, or rows of numbers";
      if (ReadNumber(item, &x)) {
        r.v.push_back(x);
        r.rows = 1;
        ++r.cols;
      } else if (nested) {
        if (i > 0 && static_cast<int>(item.size()) != r.cols) {
          return "expected rows of equal length (a matrix)";
        }
        r.cols = static_cast<int>(item.size());
        for (size_t j = 0; j < item.size(); ++j) {
          if (!ReadNumber(item[static_cast<int>(j)], &x)) return "expected numbers";
          r.v.push_back(x);
        }
        r.rows = static_cast<int>(i) + 1;
      } else {
        return "expected numbers";
      }
    }
  } else if (n.isMap() && !n["dt"].empty()) {
    cv::Mat m;
    try {
      n >> m;
    } catch (const cv::Exception& e) {
      return "OpenCV cannot read this matrix (" + ParseErrorText(e, 0) + ")";
    }
    if (m.empty()) return "expected a non-empty matrix";
    if (m.channels() != 1) return "expected a single-channel matrix";
    m.convertTo(m, CV_64F);
    r.rows = m.rows;
    r.cols = m.cols;
    for (int i = 0; i < m.rows; ++i) {
      for (int j = 0; j < m.cols; ++j) r.v.push_back(m.at<double>(i, j));
    }
  } else if (n.isMap() && n["data"].isSeq()) {
    // ROS's camera_calibration_parsers: {rows: R, cols: C, data: [...]}.
    const cv::FileNode data = n["data"];
    for (size_t i = 0; i < data.size(); ++i) {
      if (!ReadNumber(data[static_cast<int>(i)], &x)) return "data: expected numbers";
      r.v.push_back(x);
    }
    double rows = 1, cols = static_cast<double>(r.v.size());
    if (!n["rows"].empty() && !ReadNumber(n["rows"], &rows)) return "rows: expected a number";
    if (!n["cols"].empty() && !ReadNumber(n["cols"], &cols)) return "cols: expected a number";
    if (rows < 0 || cols < 0 || rows * cols != static_cast<double>(r.v.size())) {
      return "expected rows x cols = " + std::to_string(r.v.size()) + " data values, got " +
             RoundTrip(rows) + " x " + RoundTrip(cols);
    }
    r.rows = static_cast<int>(rows);
    r.cols = static_cast<int>(cols);
  } else {
    return "expected a matrix (!!opencv-matrix, a sequence of numbers, or {rows, cols, data})";
  }
  for (size_t i = 0; i < r.v.size(); ++i) {
    if (!std::isfinite(r.v[i])) return "value " + std::to_string(i) + " is not finite";
  }
  *out = std::move(r);
  return "";
}

// The first of `names` present in `fs` (its name in *found), or an empty node.
cv::FileNode FindField(const cv::FileStorage& fs, std::initializer_list<const char*> names,
                       std::string* found) {
  for (const char* name : names) {
    cv::FileNode n = fs[name];
    if (!n.empty()) {
      *found = name;
      return n;
    }
  }
  return cv::FileNode();
}

// An image dimension: a whole number of pixels, positive. Returns "" or what is wrong.
std::string ToPixels(double x, int* out) {
  if (!(x >= 1 && x <= 1e9) || x != std::floor(x)) {
    return "expected a positive whole number of pixels, got " + RoundTrip(x);
  }
  *out = static_cast<int>(x);
  return "";
}

// YAML text that cv::FileStorage reads: OpenCV's YAML parser needs its own "%YAML:1.0"
// directive first, which ROS's camera_calibration_parsers and hand-written files lack, and
// reads the standard "%YAML 1.x" spelling as an error.
std::string WithOpenCvYamlDirective(const std::string& text) {
  const size_t first = text.find_first_not_of(" \t\r\n");
  if (first == std::string::npos) return text;
  if (text[first] == '<' || text[first] == '{') return text;  // XML, JSON
  if (text.compare(first, 6, "%YAML:") == 0) return text;
  if (text.compare(first, 5, "%YAML") == 0) {
    const size_t eol = text.find('\n', first);
    return "%YAML:1.0" + (eol == std::string::npos ? std::string() : text.substr(eol));
  }
  return "%YAML:1.0\n" + text;
}

}  // namespace

bool LooksLikeOpenCvCameraFile(const std::string& path, const std::string& text) {
  const std::string p = Lower(path);
  if (EndsWith(p, ".yml") || EndsWith(p, ".yaml") || EndsWith(p, ".xml")) return true;
  const size_t first = text.find_first_not_of(" \t\r\n");
  return first != std::string::npos &&
         (text.compare(first, 5, "%YAML") == 0 || text.compare(first, 5, "<?xml") == 0);
}

Status ReadOpenCvCameraFile(const std::string& path, int width, int height, OpenCvCamera* out) {
  std::string text;
  if (Status s = ReadTextFile(path, &text); !s) return s;
  if (text.find('\0') != std::string::npos) {
    return Status::Error(path + ": contains a NUL byte; " + kExpectedFile);
  }
  if (text.find_first_not_of(" \t\r\n") == std::string::npos) {
    return Status::Error(path + ": the file is empty; " + kExpectedFile);
  }
  cv::FileStorage fs;
  const std::string yaml = WithOpenCvYamlDirective(text);
  try {
    fs.open(yaml, cv::FileStorage::READ | cv::FileStorage::MEMORY);
  } catch (const cv::Exception& e) {
    const int added_lines = static_cast<int>(std::count(yaml.begin(), yaml.end(), '\n') -
                                             std::count(text.begin(), text.end(), '\n'));
    return Status::Error(path + ": OpenCV cannot parse the file (" +
                         ParseErrorText(e, added_lines) + "); " + kExpectedFile);
  }
  if (!fs.isOpened() || !fs.root().isMap()) {
    return Status::Error(path + ": OpenCV cannot parse the file; " + kExpectedFile);
  }

  OpenCvCamera c;
  auto bad = [&](const std::string& field, const std::string& what) {
    return Status::Error(path + ": " + field + ": " + what);
  };
  try {
    // The camera matrix.
    std::string kname;
    const cv::FileNode kn = FindField(fs, {"camera_matrix", "cameraMatrix", "K"}, &kname);
    if (kn.empty()) {
      return Status::Error(path + ": no camera matrix (camera_matrix, cameraMatrix or K); " +
                           kExpectedFile);
    }
    Numbers k;
    if (std::string e = ReadNumbers(kn, &k); !e.empty()) return bad(kname, e);
    if (k.v.size() != 9 || !((k.rows == 3 && k.cols == 3) || k.rows == 1 || k.cols == 1)) {
      return bad(kname, "expected a 3x3 camera matrix, got " + std::to_string(k.rows) + "x" +
                            std::to_string(k.cols));
    }
    for (int i = 0; i < 9; ++i) c.K[i / 3][i % 3] = k.v[i];

    // The distortion model's name (ROS), then the coefficients.
    if (const cv::FileNode m = fs["distortion_model"]; !m.empty()) {
      if (!m.isString()) return bad("distortion_model", "expected a string");
      const std::string model = Lower(m.string());
      if (model == "equidistant" || model == "fisheye" || model == "kannala_brandt" ||
          model == "kb4") {
        c.fisheye = true;
      } else if (model != "plumb_bob" && model != "rational_polynomial" && model != "radtan") {
        return bad("distortion_model",
                   "unknown model '" + m.string() +
                       "'; expected plumb_bob, rational_polynomial, radtan (OpenCV's pinhole "
                       "distortion) or equidistant (cv::fisheye)");
      }
    }
    std::string dname;
    const cv::FileNode dn =
        FindField(fs, {"distortion_coefficients", "distCoeffs", "dist_coeffs", "D"}, &dname);
    if (!dn.empty()) {
      Numbers d;
      // Nothing (an empty sequence; in XML an empty element) is no distortion.
      const bool nothing =
          dn.isNone() || ((dn.isSeq() || dn.isMap()) && dn.size() == 0) ||
          (dn.isString() && dn.string().find_first_not_of(" \t\r\n") == std::string::npos);
      if (!nothing) {
        if (std::string e = ReadNumbers(dn, &d); !e.empty()) return bad(dname, e);
        if (d.rows != 1 && d.cols != 1) {
          return bad(dname, "expected a row or column of coefficients, got " +
                                std::to_string(d.rows) + "x" + std::to_string(d.cols));
        }
      }
      c.dist = d.v;
    }

    // The image size.
    std::string wname, hname, sname;
    const cv::FileNode wn = FindField(fs, {"image_width"}, &wname);
    const cv::FileNode hn = FindField(fs, {"image_height"}, &hname);
    const cv::FileNode sn = FindField(fs, {"imageSize", "image_size"}, &sname);
    if (!wn.empty() || !hn.empty()) {
      if (wn.empty() || hn.empty()) {
        return bad(wn.empty() ? "image_width" : "image_height",
                   "missing (the other is there); expected both, in pixels");
      }
      double w, h;
      if (!ReadNumber(wn, &w)) return bad("image_width", "expected a number of pixels");
      if (!ReadNumber(hn, &h)) return bad("image_height", "expected a number of pixels");
      if (std::string e = ToPixels(w, &c.width); !e.empty()) return bad("image_width", e);
      if (std::string e = ToPixels(h, &c.height); !e.empty()) return bad("image_height", e);
    } else if (!sn.empty()) {
      Numbers s;
      if (std::string e = ReadNumbers(sn, &s); !e.empty()) return bad(sname, e);
      if (s.v.size() != 2) {
        return bad(sname,
                   "expected [width, height], got " + std::to_string(s.v.size()) + " values");
      }
      if (std::string e = ToPixels(s.v[0], &c.width); !e.empty()) return bad(sname, "width: " + e);
      if (std::string e = ToPixels(s.v[1], &c.height); !e.empty()) {
        return bad(sname, "height: " + e);
      }
    }
  } catch (const cv::Exception& e) {
    return Status::Error(path + ": OpenCV cannot read the file (" + ParseErrorText(e, 0) + "); " +
                         kExpectedFile);
  }

  if (width > 0 && height > 0) {
    if (c.width > 0 && (c.width != width || c.height != height)) {
      return Status::Error(path + ": the file's image size " + std::to_string(c.width) + "x" +
                           std::to_string(c.height) + " differs from the one given, " +
                           std::to_string(width) + "x" + std::to_string(height) +
                           "; expected the same or no --image-size");
    }
    c.width = width;
    c.height = height;
  }
  *out = std::move(c);
  return Status::Ok();
}

Status CameraFromOpenCv(const OpenCvCamera& c, CameraModel* out) {
  const double(&K)[3][3] = c.K;
  for (int i = 0; i < 9; ++i) {
    if (!std::isfinite(K[i / 3][i % 3])) {
      return Status::Error("camera_matrix: value " + std::to_string(i) + " is not finite");
    }
  }
  if (K[1][0] != 0 || K[2][0] != 0 || K[2][1] != 0 || K[2][2] != 1) {
    return Status::Error(
        "camera_matrix: expected [fx 0 cx; 0 fy cy; 0 0 1], got a last row or lower triangle "
        "of [" +
        RoundTrip(K[2][0]) + " " + RoundTrip(K[2][1]) + " " + RoundTrip(K[2][2]) + "], K[1][0] " +
        RoundTrip(K[1][0]));
  }
  if (K[0][1] != 0) {
    return Status::Error("camera_matrix: skew K[0][1] = " + RoundTrip(K[0][1]) +
                         "; mrcal's lens models have no skew, expected 0");
  }
  if (!(K[0][0] > 0) || !(K[1][1] > 0)) {
    return Status::Error("camera_matrix: expected positive focal lengths fx, fy (pixels), got " +
                         RoundTrip(K[0][0]) + ", " + RoundTrip(K[1][1]));
  }
  if (c.fisheye) {
    return Status::Error(
        "distortion_model: cv::fisheye's Kannala-Brandt model has no lens model in mrcal 2.2; "
        "expected OpenCV's pinhole distortion (k1 k2 p1 p2 [k3 [k4 k5 k6 [s1..s4]]])");
  }
  for (size_t i = 0; i < c.dist.size(); ++i) {
    if (!std::isfinite(c.dist[i])) {
      return Status::Error("distortion_coefficients: value " + std::to_string(i) +
                           " is not finite");
    }
  }
  if (c.width <= 0 || c.height <= 0) {
    return Status::Error(
        "image size: missing (image_width and image_height, or imageSize); mrcal needs the "
        "imager size: expected it in the file, or give --image-size WxH");
  }
  std::vector<double> dist = c.dist;
  const size_t n = dist.size();
  if (n == 14) {
    if (dist[12] != 0 || dist[13] != 0) {
      return Status::Error("distortion_coefficients: a tilted sensor (tx = " + RoundTrip(dist[12]) +
                           ", ty = " + RoundTrip(dist[13]) +
                           ") has no lens model in mrcal 2.2; expected tx = ty = 0");
    }
    dist.resize(12);
  } else if (n != 0 && n != 4 && n != 5 && n != 8 && n != 12) {
    return Status::Error(
        "distortion_coefficients: expected 0, 4, 5, 8, 12 or 14 coefficients "
        "(k1 k2 p1 p2 [k3 [k4 k5 k6 [s1 s2 s3 s4 [tx ty]]]]), got " +
        std::to_string(n));
  }
  const bool zero = std::all_of(dist.begin(), dist.end(), [](double d) { return d == 0; });
  const std::string lensmodel =
      zero ? "LENSMODEL_PINHOLE" : "LENSMODEL_OPENCV" + std::to_string(dist.size());
  std::vector<double> intrinsics = {K[0][0], K[1][1], K[0][2], K[1][2]};
  if (!zero) intrinsics.insert(intrinsics.end(), dist.begin(), dist.end());
  return CameraModel::Create(lensmodel, intrinsics, c.width, c.height, out);
}

Status OpenCvFromCamera(const CameraModel& camera, OpenCvCamera* out) {
  const std::string& lm = camera.lensmodel();
  const std::vector<double>& in = camera.intrinsics();
  OpenCvCamera c;
  if (lm == "LENSMODEL_PINHOLE") {
    c.dist.assign(5, 0.0);
  } else if (lm == "LENSMODEL_OPENCV4" || lm == "LENSMODEL_OPENCV5" || lm == "LENSMODEL_OPENCV8" ||
             lm == "LENSMODEL_OPENCV12") {
    c.dist.assign(in.begin() + 4, in.end());
  } else {
    return Status::Error("lensmodel: " + (lm.empty() ? std::string("(empty camera model)") : lm) +
                         " has no OpenCV equivalent; expected LENSMODEL_PINHOLE or "
                         "LENSMODEL_OPENCV4/5/8/12");
  }
  c.K[0][0] = in[0];
  c.K[1][1] = in[1];
  c.K[0][2] = in[2];
  c.K[1][2] = in[3];
  c.width = camera.width();
  c.height = camera.height();
  *out = std::move(c);
  return Status::Ok();
}

Status ImportOpenCvCamera(const std::string& path, int width, int height, CameraModel* out) {
  OpenCvCamera c;
  if (Status s = ReadOpenCvCameraFile(path, width, height, &c); !s) return s;
  if (Status s = CameraFromOpenCv(c, out); !s) return Status::Error(path + ": " + s.message());
  return Status::Ok();
}

Status OpenCvCameraText(const std::string& path, const CameraModel& camera, std::string* text) {
  OpenCvCamera c;
  if (Status s = OpenCvFromCamera(camera, &c); !s) return Status::Error(path + ": " + s.message());
  const std::string p = Lower(path);
  const bool xml = EndsWith(p, ".xml"), json = EndsWith(p, ".json");
  const int format = xml    ? cv::FileStorage::FORMAT_XML
                     : json ? cv::FileStorage::FORMAT_JSON
                            : cv::FileStorage::FORMAT_YAML;
  try {
    cv::FileStorage fs(".", cv::FileStorage::WRITE | cv::FileStorage::MEMORY | format);
    if (!json) {
      fs.writeComment("Written by svms camera export from an mrcal " + camera.lensmodel() +
                      " model: OpenCV's pinhole camera");
      fs.writeComment("(cv::calibrateCamera's); pixel (0,0) is the centre of the top-left pixel.");
    }
    fs << "image_width" << c.width << "image_height" << c.height;
    fs << "camera_matrix" << cv::Mat(3, 3, CV_64F, &c.K[0][0]).clone();
    fs << "distortion_coefficients"
       << cv::Mat(1, static_cast<int>(c.dist.size()), CV_64F, c.dist.data()).clone();
    *text = fs.releaseAndGetString();
  } catch (const cv::Exception& e) {
    std::string why = e.err;
    std::replace(why.begin(), why.end(), '\n', ' ');
    return Status::Error(path + ": OpenCV cannot write the camera (" + why + ")");
  }
  return Status::Ok();
}

Status WriteOpenCvCameraFile(const std::string& path, const CameraModel& camera) {
  std::string text;
  if (Status s = OpenCvCameraText(path, camera, &text); !s) return s;
  return WriteFileAtomically(path, text);
}

}  // namespace svms
