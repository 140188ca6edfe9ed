// libFuzzer target: Detector::Detect on arbitrary pixels. Input: width (1 byte, 1..256), height
// (1 byte, 1..256), type (1 byte: 8-bit grey, 16-bit grey, 8-bit colour, and the odd ones a
// caller could pass: 2 channels, float, 16-bit colour with alpha, double), then pixel bytes
// (repeated to fill the image, zeros if none). Two detectors: without a camera, and with a
// pinhole camera of the image's size and marker models (poses, post tips, nesting).
#include <cstdint>
#include <cstring>
#include <vector>

#include "svms/detect/detector.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 3) return 0;
  const int w = data[0] + 1, h = data[1] + 1;
  const int types[7] = {CV_8UC1, CV_16UC1, CV_8UC3, CV_8UC2, CV_32FC1, CV_16UC4, CV_64FC3};
  const int type = types[data[2] % 7];
  const uint8_t* px = data + 3;
  const size_t n = size - 3;
  cv::Mat img(h, w, type);
  const size_t bytes = img.total() * img.elemSize();
  for (size_t i = 0; i < bytes; ++i) img.data[i] = n ? px[i % n] : 0;

  static const std::vector<svms::MarkerModel> models = [] {
    svms::MarkerModel dual = svms::MarkerModel::Standard(1, 0.2, 0.02);
    dual.AddInner(2, 0.05);
    return std::vector<svms::MarkerModel>{dual, svms::MarkerModel::Standard(17, 0.1, -0.01)};
  }();
  static const svms::Detector bare(svms::DetectorOptions{}, svms::CameraModel(), {});
  bare.Detect(img);
  const svms::Detector posed(svms::DetectorOptions{}, svms::CameraModel::Pinhole(0.8 * w, w, h),
                             models);
  svms::DetectionStats stats;
  posed.Detect(img, &stats);
  return 0;
}
