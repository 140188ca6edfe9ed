#include "svms/pipelines/photometry.h"

#include <filesystem>
#include <opencv2/imgproc.hpp>

#include "svms/camera/bayer_luminance.h"
#include "svms/imageio/image_io.h"

namespace svms {

namespace fs = std::filesystem;

Status Photometry::Create(const PhotometryOptions& options, const std::string& camera_path,
                          Photometry* out, bool allow_estimate) {
  Photometry p;
  p.options_ = options;
  if (options.estimate() && allow_estimate) {
    p.estimating_ = true;
    p.options_.response.clear();
  } else if (!options.response.empty()) {
    if (Status s = Response::Parse(options.response, &p.option_response_); !s)
      return Status::Error(s.message() + (allow_estimate ? ", or estimate" : ""));
  }
  if (!options.bayer.empty())
    if (Status s = ParseBayerPattern(options.bayer, &p.option_bayer_); !s) return s;
  if (!options.demosaic.empty())
    if (Status s = ParseBayerMethod(options.demosaic, &p.option_demosaic_); !s) return s;
  PhotometricModel check;
  check.black_level = options.black_level.value_or(0);
  check.white_level = options.white_level.value_or(0);
  if (Status s = check.Check(); !s)
    return Status::Error("--black-level/--white-level: " + s.message());
  if (!camera_path.empty()) {
    const std::string file = PhotometricPath(camera_path);
    std::error_code ec;
    if (fs::exists(file, ec)) {
      PhotometricModel m;
      if (Status s = ReadPhotometricFile(file, &m); !s) return s;
      p.camera_ = m;
      p.camera_file_ = file;
    }
  }
  *out = std::move(p);
  return Status::Ok();
}

std::optional<PhotometricModel> Photometry::GivenModel() const {
  if (options_.response.empty()) return std::nullopt;
  PhotometricModel m;
  m.response = option_response_;
  m.black_level = black_level();
  m.white_level = white_level();
  m.bayer = option_bayer_;
  m.demosaic = option_demosaic_;
  return m;
}

double Photometry::CornerRowWindowPx() const {
  PhotometrySource source;
  return svms::CornerRowWindowPx(Resolve(65535, "", &source));
}

void Photometry::UseResponse(const Response& response) {
  option_response_ = response;
  options_.response = response.Name();
}

PhotometricModel Photometry::Resolve(double depth_max, const std::string& declared,
                                     PhotometrySource* source) const {
  PhotometricModel m;
  *source = PhotometrySource::kDefault;
  m.response = depth_max > 255 ? Response::Linear() : Response::Srgb();
  Response r;
  if (!declared.empty() && Response::Parse(declared, &r).ok()) {
    m.response = r;
    *source = PhotometrySource::kImageFile;
  }
  if (camera_) {
    m = *camera_;
    *source = PhotometrySource::kCameraFile;
  }
  if (options_.any()) *source = PhotometrySource::kOption;
  if (!options_.response.empty()) m.response = option_response_;
  if (!options_.bayer.empty()) m.bayer = option_bayer_;
  if (!options_.demosaic.empty()) m.demosaic = option_demosaic_;
  if (options_.black_level) m.black_level = *options_.black_level;
  if (options_.white_level) m.white_level = *options_.white_level;
  return m;
}

namespace {

nlohmann::json PhotometryJson(const PhotometricModel& m, double depth_max,
                              PhotometrySource source) {
  nlohmann::json j = {{"response", m.response.Name()},
                      {"black_level", m.black_level},
                      {"white_level", m.white_level > 0 ? m.white_level : depth_max},
                      {"source", PhotometrySourceName(source)}};
  if (m.bayer != BayerPattern::kNone) {
    j["bayer"] = BayerPatternName(m.bayer);
    j["demosaic"] = BayerMethodName(m.demosaic);
  }
  return j;
}

}  // namespace

Status Photometry::LinearizeFrame(const cv::Mat& frame, const std::string& declared,
                                  cv::Mat* linear, nlohmann::json* json,
                                  NoiseModel* stored_noise) const {
  const double depth_max = frame.depth() == CV_16U ? 65535 : 255;
  PhotometrySource source;
  const PhotometricModel m = Resolve(depth_max, declared, &source);
  if (json) *json = PhotometryJson(m, depth_max, source);
  if (stored_noise) {
    *stored_noise = NoiseModel();
    EstimateStoredNoise(frame, m, std::chrono::steady_clock::time_point::max(), stored_noise);
  }
  return LinearizeImage(frame, m, linear);
}

Status Photometry::Load(const std::string& path, int64_t max_pixels, cv::Mat* linear,
                        nlohmann::json* json, cv::Mat* stored_grey,
                        NoiseModel* stored_noise) const {
  cv::Mat stored;
  ImageHeader header;
  if (Status s = LoadStoredImage(path, max_pixels, &stored, &header); !s) return s;
  if (stored_grey) {
    if (stored.channels() == 3)
      cv::cvtColor(stored, *stored_grey, cv::COLOR_BGR2GRAY);
    else
      *stored_grey = stored;
  }
  if (Status s = LinearizeFrame(stored, header.declared_response, linear, json, stored_noise); !s)
    return Status::Error(path + ": " + s.message());
  return Status::Ok();
}

}  // namespace svms
