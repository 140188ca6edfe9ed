// The frames of a video file, read through OpenCV's VideoCapture (its FFmpeg backend).
#pragma once

#include <memory>
#include <opencv2/core.hpp>
#include <string>

#include "svms/base/status.h"

namespace cv {
class VideoCapture;
}

namespace svms {

// The frames of a video file in order, each with its time stamp from the container
// (CAP_PROP_POS_MSEC, seconds). FFmpeg's own error messages are kept for ours instead of going
// to stderr on their own lines.
class VideoFrames {
 public:
  VideoFrames();
  ~VideoFrames();
  VideoFrames(const VideoFrames&) = delete;
  VideoFrames& operator=(const VideoFrames&) = delete;

  // Errors name the file and the backend's reason ("cannot open ... with OpenCV's FFmpeg
  // backend").
  Status Open(const std::string& path);
  // The next frame (as decoded: 8-bit BGR or grey); false at the end.
  bool Next(cv::Mat* frame, double* timestamp_s, int* index);
  // After the last frame: "" when `frames_read` is what the container says it holds (or it
  // does not say), else why the video ended early (FFmpeg's last error).
  std::string Incomplete(int frames_read) const;
  std::string backend() const { return backend_; }

 private:
  std::unique_ptr<cv::VideoCapture> capture_;
  std::string backend_, path_;
  double declared_frames_ = 0;
  int index_ = 0;
};

}  // namespace svms
