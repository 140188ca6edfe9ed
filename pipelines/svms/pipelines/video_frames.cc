#include "svms/pipelines/video_frames.h"

extern "C" {
#include <libavutil/log.h>
}

#include <cstdarg>
#include <cstdio>
#include <filesystem>
#include <mutex>
#include <opencv2/videoio.hpp>

#include "svms/base/format.h"

namespace svms {

namespace fs = std::filesystem;

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

VideoFrames::VideoFrames() : capture_(std::make_unique<cv::VideoCapture>()) {}

VideoFrames::~VideoFrames() = default;

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
    capture_->open(path, cv::CAP_FFMPEG);
  } catch (const cv::Exception& e) {
    return Status::Error(path + ": cannot open the video with OpenCV's FFmpeg backend: " + e.err);
  }
  if (!capture_->isOpened()) {
    std::lock_guard<std::mutex> lock(ffmpeg_mutex);
    return Status::Error(path + ": cannot open the video with OpenCV's FFmpeg backend: " +
                         (ffmpeg_last_error.empty() ? std::string("not a video it can read")
                                                    : "FFmpeg says \"" + ffmpeg_last_error + "\"") +
                         "; expected a video file (.mp4, .mkv, .avi, ...)");
  }
  backend_ = capture_->getBackendName();
  path_ = path;
  declared_frames_ = capture_->get(cv::CAP_PROP_FRAME_COUNT);
  index_ = 0;
  return Status::Ok();
}

std::string VideoFrames::Incomplete(int frames_read) const {
  // Containers round their frame count from the duration; a frame or two short is not a
  // failure.
  if (!(declared_frames_ > 0) || frames_read + 2 >= declared_frames_) return "";
  std::lock_guard<std::mutex> lock(ffmpeg_mutex);
  return path_ + ": " + std::to_string(frames_read) + " of the " + Fixed(declared_frames_, 0) +
         " frames the container declares were read" +
         (ffmpeg_last_error.empty() ? std::string() : " (FFmpeg: " + ffmpeg_last_error + ")") +
         "; expected a complete video";
}

bool VideoFrames::Next(cv::Mat* frame, double* timestamp_s, int* index) {
  if (!capture_->isOpened() || !capture_->read(*frame) || frame->empty()) return false;
  // The position after the read is the frame's own presentation time in OpenCV 4.6.
  *timestamp_s = capture_->get(cv::CAP_PROP_POS_MSEC) / 1000.0;
  *index = index_++;
  return true;
}

}  // namespace svms
