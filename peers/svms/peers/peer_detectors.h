// The peer detectors of the comparison benchmark, each behind one interface: a grey image in,
// IDs and four corners out, in the same corner order and pixel convention as svms::Detection
// (top-left, top-right, bottom-right, bottom-left as printed; pixel (0,0) = centre of the
// top-left pixel, docs/conventions.md).
//
// Configurations (StandardPeerConfigs), each with every setting written by Describe():
//   apriltag_d2   libapriltag 3.3, tag36h11, quad_decimate 2 (its demo's default), refine_edges
//   apriltag_d1   the same at full resolution (decimation 1): its best setting for small tags
//   aruco_subpix  OpenCV 4.6 ArUco, DICT_6X6_1000, CORNER_REFINE_SUBPIX (recommended for pose)
//   aruco3        the same with useAruco3Detection (the fast mode), CORNER_REFINE_SUBPIX
// All run on one thread (AprilTag nthreads = 1; the caller limits OpenCV with
// cv::setNumThreads(1)).
//
// Pixel conventions: AprilTag reports corners with pixel centres at half-integers (its quad fit
// works on pixel corners: (0.5, 0.5) is the centre of the top-left pixel); the wrapper
// subtracts 0.5 (measured: the mean corner offset vs truth on rendered tags is then < 0.05 px,
// peers_test.cc). OpenCV already uses pixel centres at integers.
#pragma once

#include <Eigen/Core>
#include <array>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace svms {

struct PeerDetection {
  int id = -1;
  std::array<Eigen::Vector2d, 4> corners;  // TL, TR, BR, BL as printed; pixels
  int hamming = 0;                         // corrected bits (AprilTag), 0 for ArUco
};

struct PeerDetectorConfig {
  enum class Kind { kAprilTag, kAruco };
  std::string name;  // e.g. "apriltag_d1"
  Kind kind = Kind::kAprilTag;
  // AprilTag (apriltag_detector_t fields)
  double quad_decimate = 2;
  double quad_sigma = 0;
  bool refine_edges = true;
  double decode_sharpening = 0.25;
  int max_hamming = 2;  // bits corrected (apriltag_detector_add_family_bits)
  // ArUco (cv::aruco::DetectorParameters fields; the rest at their defaults)
  int corner_refinement = 1;  // cv::aruco::CornerRefineMethod: 0 none, 1 subpix, 2 contour
  bool aruco3 = false;        // useAruco3Detection

  std::string family() const;  // "tag36h11" or "aruco6x6"
  // Every setting, as a JSON object (for the benchmark's output).
  std::string DescribeJson() const;
};

// apriltag_d2, apriltag_d1, aruco_subpix, aruco3 (see the file comment).
std::vector<PeerDetectorConfig> StandardPeerConfigs();

// One configured peer detector. Not thread-safe (AprilTag's detector keeps state while it
// runs): one per thread.
class PeerDetector {
 public:
  explicit PeerDetector(const PeerDetectorConfig& config);
  ~PeerDetector();
  PeerDetector(const PeerDetector&) = delete;
  PeerDetector& operator=(const PeerDetector&) = delete;

  // All tags in `image` (CV_8UC1; other types are converted to 8-bit grey).
  std::vector<PeerDetection> Detect(const cv::Mat& image) const;
  const PeerDetectorConfig& config() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace svms
