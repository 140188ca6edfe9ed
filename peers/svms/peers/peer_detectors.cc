#include "svms/peers/peer_detectors.h"

#include <nlohmann/json.hpp>
#include <opencv2/aruco.hpp>
#include <opencv2/imgproc.hpp>

extern "C" {
#include <apriltag/apriltag.h>
#include <apriltag/tag36h11.h>
}

#include "svms/peers/peer_tags.h"

namespace svms {

std::string PeerDetectorConfig::family() const {
  return kind == Kind::kAprilTag ? kTag36h11 : kAruco6x6;
}

std::string PeerDetectorConfig::DescribeJson() const {
  nlohmann::json j;
  j["name"] = name;
  j["family"] = family();
  if (kind == Kind::kAprilTag) {
    j["library"] = "libapriltag 3.3 (Debian 12)";
    j["quad_decimate"] = quad_decimate;
    j["quad_sigma"] = quad_sigma;
    j["refine_edges"] = refine_edges;
    j["decode_sharpening"] = decode_sharpening;
    j["max_hamming"] = max_hamming;
    j["nthreads"] = 1;
    j["corner_offset_px"] = -0.5;
  } else {
    j["library"] = "OpenCV " CV_VERSION " aruco (contrib), DICT_6X6_1000";
    j["cornerRefinementMethod"] = corner_refinement == 0   ? "CORNER_REFINE_NONE"
                                  : corner_refinement == 1 ? "CORNER_REFINE_SUBPIX"
                                                           : "CORNER_REFINE_CONTOUR";
    j["useAruco3Detection"] = aruco3;
    j["other_parameters"] = "DetectorParameters::create() defaults";
    j["threads"] = 1;
  }
  return j.dump();
}

std::vector<PeerDetectorConfig> StandardPeerConfigs() {
  std::vector<PeerDetectorConfig> out;
  PeerDetectorConfig a;
  a.kind = PeerDetectorConfig::Kind::kAprilTag;
  a.name = "apriltag_d2";
  a.quad_decimate = 2;
  out.push_back(a);
  a.name = "apriltag_d1";
  a.quad_decimate = 1;
  out.push_back(a);
  PeerDetectorConfig r;
  r.kind = PeerDetectorConfig::Kind::kAruco;
  r.name = "aruco_subpix";
  r.corner_refinement = 1;
  out.push_back(r);
  r.name = "aruco3";
  r.aruco3 = true;
  out.push_back(r);
  return out;
}

struct PeerDetector::Impl {
  PeerDetectorConfig config;
  apriltag_family_t* tf = nullptr;
  apriltag_detector_t* td = nullptr;
  cv::Ptr<cv::aruco::Dictionary> dict;
  cv::Ptr<cv::aruco::DetectorParameters> params;
};

PeerDetector::PeerDetector(const PeerDetectorConfig& config) : impl_(std::make_unique<Impl>()) {
  Impl& I = *impl_;
  I.config = config;
  if (config.kind == PeerDetectorConfig::Kind::kAprilTag) {
    I.tf = tag36h11_create();
    I.td = apriltag_detector_create();
    apriltag_detector_add_family_bits(I.td, I.tf, config.max_hamming);
    I.td->quad_decimate = static_cast<float>(config.quad_decimate);
    I.td->quad_sigma = static_cast<float>(config.quad_sigma);
    I.td->refine_edges = config.refine_edges;
    I.td->decode_sharpening = config.decode_sharpening;
    I.td->nthreads = 1;
  } else {
    I.dict = cv::aruco::getPredefinedDictionary(cv::aruco::DICT_6X6_1000);
    I.params = cv::aruco::DetectorParameters::create();
    I.params->cornerRefinementMethod = config.corner_refinement;
    I.params->useAruco3Detection = config.aruco3;
  }
}

PeerDetector::~PeerDetector() {
  if (impl_->td) apriltag_detector_destroy(impl_->td);
  if (impl_->tf) tag36h11_destroy(impl_->tf);
}

const PeerDetectorConfig& PeerDetector::config() const { return impl_->config; }

std::vector<PeerDetection> PeerDetector::Detect(const cv::Mat& image) const {
  const Impl& I = *impl_;
  cv::Mat grey = image;
  if (grey.channels() == 3) cv::cvtColor(grey, grey, cv::COLOR_BGR2GRAY);
  if (grey.depth() == CV_16U) grey.convertTo(grey, CV_8U, 1.0 / 257);
  if (!grey.isContinuous()) grey = grey.clone();
  std::vector<PeerDetection> out;
  if (I.td) {
    image_u8_t im{grey.cols, grey.rows, static_cast<int32_t>(grey.step[0]), grey.data};
    zarray_t* dets = apriltag_detector_detect(I.td, &im);
    for (int i = 0; i < zarray_size(dets); ++i) {
      apriltag_detection_t* det;
      zarray_get(dets, i, &det);
      PeerDetection d;
      d.id = det->id;
      d.hamming = det->hamming;
      // AprilTag's p[0..3] wrap counter-clockwise (in the image) from the printed bottom-left:
      // BL, BR, TR, TL (measured on rendered tags, peers_test.cc).
      static constexpr int kFromApril[4] = {3, 2, 1, 0};
      for (int c = 0; c < 4; ++c)
        d.corners[c] =
            Eigen::Vector2d(det->p[kFromApril[c]][0] - 0.5, det->p[kFromApril[c]][1] - 0.5);
      out.push_back(d);
    }
    apriltag_detections_destroy(dets);
  } else {
    std::vector<std::vector<cv::Point2f>> corners, rejected;
    std::vector<int> ids;
    cv::aruco::detectMarkers(grey, I.dict, corners, ids, I.params, rejected);
    for (size_t i = 0; i < ids.size(); ++i) {
      PeerDetection d;
      d.id = ids[i];
      // ArUco: clockwise from the printed top-left, as ours.
      for (int c = 0; c < 4; ++c) d.corners[c] = Eigen::Vector2d(corners[i][c].x, corners[i][c].y);
      out.push_back(d);
    }
  }
  return out;
}

}  // namespace svms
