// The photometric model of a camera: how a pixel value relates to the light that fell on it.
//
// The detector locates edges by the area under their profile and models noise as shot plus
// read noise: both hold only in linear light. Most 8-bit files (every JPEG, most PNGs from
// ordinary cameras) are gamma-encoded: on them a blurred black/white edge moves toward its
// dark side by a good part of the blur width. So every image is turned into linear light
// before it is measured, through this model:
//
//   linear = ToLinear((value - black_level) / (white_level - black_level))   in [0, 1]
//
// where `value` is the stored pixel value (8 or 16 bits), `black_level` the value of no light
// (a raw sensor's offset), `white_level` the value of saturation (255, 65535, or 4095 for
// 12 bits of signal in a 16-bit container), and ToLinear the inverse of the camera's response
// curve: linear, sRGB (IEC 61966-2-1), a pure gamma, or a lookup table.
//
// Where the model comes from, first match wins (docs/conventions.md, "Photometry"):
//   1. `--response` on the command line (and `--black-level`, `--white-level`);
//   2. the camera's photometric file, CAMERA.cameramodel.photometric.json, when it exists;
//   3. the image file's own declaration: a PNG's sRGB or gAMA chunk (svms render writes
//      gAMA 1.0, linear, on its PNGs); a JPEG is sRGB;
//   4. the default: 8-bit images are sRGB, 16-bit images linear.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "svms/base/status.h"

namespace svms {

// A camera's response curve: linear light in [0, 1] -> encoded value in [0, 1], and back.
class Response {
 public:
  enum class Kind { kLinear, kSrgb, kGamma, kTable };

  Response() = default;  // linear
  static Response Linear() { return Response(); }
  static Response Srgb();
  // encoded = linear^(1 / gamma): gamma 2.2 is the classic video curve. gamma > 0.
  static Response Gamma(double gamma);
  // `encoded_to_linear`: the linear light of encoded values 0, 1/(n-1), ..., 1 (n >= 2 entries,
  // non-decreasing, from 0 to 1), interpolated linearly between them.
  static Status Table(const std::vector<double>& encoded_to_linear, Response* out);

  // "linear", "srgb", "gamma:G" (e.g. "gamma:2.2"), or "table:FILE" (FILE: one number per line
  // or whitespace-separated, the linear light of evenly spaced encoded values). Errors name the
  // text and list the choices.
  static Status Parse(const std::string& text, Response* out);
  // The inverse of Parse for the first three kinds; "table(N entries)" for a table.
  std::string Name() const;

  Kind kind() const { return kind_; }
  double gamma() const { return gamma_; }  // kGamma only
  const std::vector<double>& table() const { return table_; }

  // encoded in [0, 1] -> linear light in [0, 1] (clamped outside).
  double ToLinear(double encoded) const;
  // linear light in [0, 1] -> encoded in [0, 1] (clamped outside).
  double FromLinear(double linear) const;
  // d linear / d encoded at `encoded` (how the curve stretches noise).
  double Slope(double encoded) const;

 private:
  Kind kind_ = Kind::kLinear;
  double gamma_ = 1;
  std::vector<double> table_;
};

// The colour filter array of a raw sensor: the colours of the top-left 2 x 2 pixels, row by
// row ("RGGB": red at (0, 0), green at (0, 1) and (1, 0), blue at (1, 1)).
enum class BayerPattern { kNone, kRggb, kBggr, kGrbg, kGbrg };
// "RGGB", "BGGR", "GRBG", "GBRG" (any case), or "" / "none" for none. Errors name the text.
Status ParseBayerPattern(const std::string& text, BayerPattern* out);
std::string BayerPatternName(BayerPattern pattern);  // "RGGB", ... or "none"

// How a mosaic becomes the one channel the detector measures on. kLuminance (the default): the
// white-balanced mosaic filtered by a frequency-selection kernel (bayer_luminance.h), which
// cannot move an edge. kOpenCv: OpenCV's edge-aware demosaic (COLOR_Bayer..._EA) to BGR, then
// the Rec. 709 luminance; it moves sharp edges by a few hundredths of a pixel (docs/detector.md)
// and is kept for comparison and for colour scenes where its sharper result matters more.
enum class BayerMethod { kLuminance, kOpenCv };
// "luminance" or "opencv"; errors name the text.
Status ParseBayerMethod(const std::string& text, BayerMethod* out);
std::string BayerMethodName(BayerMethod method);

struct PhotometricModel {
  Response response;
  // Pixel values of no light and of saturation, in the units of the stored image (0..255 or
  // 0..65535). white_level 0: the largest value of the image's depth (255 or 65535).
  double black_level = 0;
  double white_level = 0;
  // A raw sensor's mosaic, demosaiced before the luminance is taken (kNone: grey or colour).
  BayerPattern bayer = BayerPattern::kNone;
  BayerMethod demosaic = BayerMethod::kLuminance;

  // True when stored values are linear light already and need no conversion (linear
  // response, black level 0, white level the full scale of `depth_max`, no mosaic).
  bool IsIdentity(double depth_max) const;

  // Checks the levels: finite, 0 <= black < white (when white is set).
  Status Check() const;
  // "srgb, black 0, white 255" (the white level of an image of `depth_max` if not set).
  std::string Summary(double depth_max) const;
};

// An image as stored (1 channel: grey or, with model.bayer, a mosaic; 3 channels: BGR; 8 or 16
// bits) in linear light, as the detector measures it: one channel, CV_16UC1, 0 at the black
// level and 65535 at the white level (values beyond clipped), the luminance of colour images
// taken in linear light (Rec. 709 weights, the sRGB primaries), a mosaic turned into luminance
// in linear light as model.demosaic says. Where the model is the identity for
// an 8-bit grey image the image itself is returned (no copy, no change).
Status LinearizeImage(const cv::Mat& stored, const PhotometricModel& model, cv::Mat* linear);

// LinearizeImage for many images of one camera: the model's tables are built once (for 8-
// and for 16-bit images), and `linear` is reused when it has the right size, so that a frame
// of the same size and depth as the last allocates nothing (for a demosaic, OpenCV's own).
class Linearizer {
 public:
  Linearizer() = default;  // the identity for 8-bit grey; linear for 16-bit
  // `depth` CV_8U or CV_16U builds the table of that depth only; -1 both.
  explicit Linearizer(const PhotometricModel& model, int depth = -1);
  // `linear` may be `stored` itself.
  Status Apply(const cv::Mat& stored, cv::Mat* linear) const;
  const PhotometricModel& model() const { return model_; }

 private:
  PhotometricModel model_;
  std::vector<uint16_t> lut8_, lut16_;
};

// Where a PhotometricModel came from, for messages and the JSON output.
enum class PhotometrySource { kOption, kCameraFile, kImageFile, kDefault };
const char* PhotometrySourceName(PhotometrySource source);

// CAMERA.cameramodel -> CAMERA.cameramodel.photometric.json
std::string PhotometricPath(const std::string& cameramodel_path);

// {"type": "svms.photometric", "response": "srgb" | "linear" | "gamma:2.2", or
// "response_table": [numbers], "black_level": B, "white_level": W, optional "bayer": "RGGB"
// and "demosaic": "luminance" | "opencv"}.
// Errors name the field.
Status ParsePhotometricJson(const std::string& text, const std::string& source,
                            PhotometricModel* out);
Status ReadPhotometricFile(const std::string& path, PhotometricModel* out);
std::string PhotometricToJson(const PhotometricModel& model);

}  // namespace svms
