#include "image_inputs.h"

#include <glob.h>

extern "C" {
#include <libavutil/log.h>
}

#include <algorithm>
#include <cctype>
#include <cstdarg>
#include <cstdio>
#include <filesystem>
#include <mutex>
#include <opencv2/imgproc.hpp>

namespace svms::cli {

namespace fs = std::filesystem;

namespace {

std::string LowerExtension(const std::string& path) {
  std::string e = fs::path(path).extension().string();
  for (auto& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return e;
}

}  // namespace

bool IsImageFile(const std::string& path) {
  const std::string e = LowerExtension(path);
  return e == ".png" || e == ".jpg" || e == ".jpeg" || e == ".tif" || e == ".tiff" || e == ".bmp" ||
         e == ".pgm" || e == ".ppm";
}

bool IsVideoFile(const std::string& path) {
  const std::string e = LowerExtension(path);
  return e == ".mp4" || e == ".m4v" || e == ".mov" || e == ".avi" || e == ".mkv" || e == ".webm" ||
         e == ".mpg" || e == ".mpeg";
}

std::vector<std::string> ExpandImageInputs(const std::vector<std::string>& inputs) {
  std::vector<std::string> out;
  for (const std::string& in : inputs) {
    std::error_code ec;
    if (fs::is_directory(in, ec)) {
      std::vector<std::string> files;
      for (const auto& e : fs::directory_iterator(in, ec))
        if (e.is_regular_file() && IsImageFile(e.path().string()))
          files.push_back(e.path().string());
      std::sort(files.begin(), files.end());
      out.insert(out.end(), files.begin(), files.end());
    } else if (in.find_first_of("*?[") != std::string::npos) {
      glob_t g;
      if (glob(in.c_str(), 0, nullptr, &g) == 0)
        for (size_t i = 0; i < g.gl_pathc; ++i) out.push_back(g.gl_pathv[i]);
      else
        out.push_back(in);
      globfree(&g);
    } else {
      out.push_back(in);
    }
  }
  return out;
}

void AddPhotometryOptions(CLI::App* cmd, PhotometryOptions* o) {
  cmd->add_option("--response", o->response,
                  "The images' response curve: linear, srgb, gamma:G or table:FILE (default: the "
                  "camera's photometric file, else what the file declares, else srgb for 8-bit "
                  "and linear for 16-bit images; docs/conventions.md)");
  cmd->add_option("--black-level", o->black_level, "Pixel value of no light (raw sensors)");
  cmd->add_option("--white-level", o->white_level,
                  "Pixel value of saturation (e.g. 4095 for 12 bits in a 16-bit file)");
  cmd->add_option("--bayer", o->bayer,
                  "The images are raw Bayer mosaics: RGGB, BGGR, GRBG or GBRG (demosaiced by "
                  "OpenCV in linear light)");
}

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
  return m;
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
  if (m.bayer != BayerPattern::kNone) j["bayer"] = BayerPatternName(m.bayer);
  return j;
}

}  // namespace

Status Photometry::LinearizeFrame(const cv::Mat& frame, const std::string& declared,
                                  cv::Mat* linear, nlohmann::json* json) const {
  const double depth_max = frame.depth() == CV_16U ? 65535 : 255;
  PhotometrySource source;
  const PhotometricModel m = Resolve(depth_max, declared, &source);
  if (json) *json = PhotometryJson(m, depth_max, source);
  return LinearizeImage(frame, m, linear);
}

Status Photometry::Load(const std::string& path, int64_t max_pixels, cv::Mat* linear,
                        nlohmann::json* json, cv::Mat* stored_grey) const {
  cv::Mat stored;
  ImageHeader header;
  if (Status s = LoadStoredImage(path, max_pixels, &stored, &header); !s) return s;
  if (stored_grey) {
    if (stored.channels() == 3)
      cv::cvtColor(stored, *stored_grey, cv::COLOR_BGR2GRAY);
    else
      *stored_grey = stored;
  }
  if (Status s = LinearizeFrame(stored, header.declared_response, linear, json); !s)
    return Status::Error(path + ": " + s.message());
  return Status::Ok();
}

namespace {

// FFmpeg's own messages (OpenCV's backend calls FFmpeg in this process): the last error is
// kept for our one-line message instead of going to stderr on its own line.
std::mutex ffmpeg_mutex;
std::string ffmpeg_last_error;

void KeepFfmpegErrors(void* avcl, int level, const char* fmt, va_list args) {
  (void)avcl;
  if (level > AV_LOG_ERROR) return;
  char buf[512];
  std::vsnprintf(buf, sizeof buf, fmt, args);
  std::string m = buf;
  while (!m.empty() && (m.back() == '\n' || m.back() == ' ')) m.pop_back();
  std::lock_guard<std::mutex> lock(ffmpeg_mutex);
  ffmpeg_last_error = m;
}

}  // namespace

Status VideoFrames::Open(const std::string& path) {
  static std::once_flag once;
  std::call_once(once, [] { av_log_set_callback(KeepFfmpegErrors); });
  std::error_code ec;
  if (!fs::is_regular_file(path, ec))
    return Status::Error(path + ": no such file; expected a video file");
  {
    std::lock_guard<std::mutex> lock(ffmpeg_mutex);
    ffmpeg_last_error.clear();
  }
  try {
    capture_.open(path, cv::CAP_FFMPEG);
  } catch (const cv::Exception& e) {
    return Status::Error(path + ": cannot open the video with OpenCV's FFmpeg backend: " + e.err);
  }
  if (!capture_.isOpened()) {
    std::lock_guard<std::mutex> lock(ffmpeg_mutex);
    return Status::Error(path + ": cannot open the video with OpenCV's FFmpeg backend: " +
                         (ffmpeg_last_error.empty() ? std::string("not a video it can read")
                                                    : "FFmpeg says \"" + ffmpeg_last_error + "\"") +
                         "; expected a video file (.mp4, .mkv, .avi, ...)");
  }
  backend_ = capture_.getBackendName();
  path_ = path;
  declared_frames_ = capture_.get(cv::CAP_PROP_FRAME_COUNT);
  index_ = 0;
  return Status::Ok();
}

std::string VideoFrames::Incomplete(int frames_read) const {
  // Containers round their frame count from the duration; a frame or two short is not a
  // failure.
  if (!(declared_frames_ > 0) || frames_read + 2 >= declared_frames_) return "";
  std::lock_guard<std::mutex> lock(ffmpeg_mutex);
  char buf[128];
  std::snprintf(buf, sizeof buf, ": %d of the %.0f frames the container declares were read",
                frames_read, declared_frames_);
  return path_ + buf +
         (ffmpeg_last_error.empty() ? std::string() : " (FFmpeg: " + ffmpeg_last_error + ")") +
         "; expected a complete video";
}

bool VideoFrames::Next(cv::Mat* frame, double* timestamp_s, int* index) {
  if (!capture_.isOpened() || !capture_.read(*frame) || frame->empty()) return false;
  // The position after the read is the frame's own presentation time in OpenCV 4.6.
  *timestamp_s = capture_.get(cv::CAP_PROP_POS_MSEC) / 1000.0;
  *index = index_++;
  return true;
}

}  // namespace svms::cli
