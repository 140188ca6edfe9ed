// Encodes and decodes through an installed SVMS (find_package(svms COMPONENTS ...)) and runs
// its detector over a blank frame; exits 0 only if the code round trip is right and the blank
// frame holds no marker.
#include <cstdio>
#include <opencv2/imgproc.hpp>

#include "svms/codec/svms44.h"
#include "svms/detect/detector.h"
#include "svms/marker/marker_model.h"

int main() {
  const svms::CodeMatch m =
      svms::Svms44::Decode(svms::Svms44::Rotate(svms::Svms44::Codeword(4242), 3) ^ 0b101, 2);
  const svms::MarkerModel model = svms::MarkerModel::Standard(4242, 0.1, 0.02);
  const svms::Detector detector(svms::DetectorOptions(), svms::CameraModel(), {model});
  const size_t found = detector.Detect(cv::Mat(480, 640, CV_8UC1, cv::Scalar(128))).size();
  const bool ok = m.accepted() && m.id == 4242 && m.rotation == 3 && m.bit_errors == 2 &&
                  model.Validate().ok() && found == 0;
  std::printf("downstream: id %d rotation %d bit_errors %d, %zu markers in a blank frame -> %s\n",
              m.id, m.rotation, m.bit_errors, found, ok ? "ok" : "WRONG");
  return ok ? 0 : 1;
}
