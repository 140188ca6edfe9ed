// The SVMS detector: every marker in one image, on its own (no state between frames).
//
// Steps, each a free function over plain structs, each timed (DetectionStats):
//   1-3  edges -> chains -> straight segments          (segments.h)
//   4    quadrilaterals and their corners              (quads.h)
//   4b   small three-sided squares completed, their corners fitted first (quads.h)
//   5    homography from the corners
//   6    data bits, thresholds from the marker's own square and stripe   (bit_sampler.h)
//   7    svms44 decoding with graded acceptance        (svms44.h)
//   8    sub-pixel corners                             (corner_refine.h)
//   9-10 post tip and pose                             (marker_pose.h)
//   10b  sides refitted clear of the post's silhouette, pose again (grazing views)
//   11   nesting of dual markers, duplicates removed
// Safe to use one Detector per thread; Detect() is const. Its working buffers are kept per
// thread (thread_local, grown to the largest image the thread has seen), so that the Detect
// overload with an output vector allocates nothing on the heap once a thread has warmed up on
// images of its size (docs/flight-interface.md; capi_alloc_test counts). With
// DetectorOptions::threads > 1 the Detector owns that many threads less one (worker_pool.h),
// which share each frame with the calling thread; their buffers too are kept between frames.
#pragma once

#include <Eigen/Core>
#include <array>
#include <chrono>
#include <map>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "svms/camera/camera.h"
#include "svms/detect/corner_refine.h"
#include "svms/detect/marker_pose.h"
#include "svms/detect/noise_model.h"
#include "svms/detect/quads.h"
#include "svms/detect/ring_deconvolution.h"
#include "svms/detect/ring_equalizer.h"
#include "svms/detect/segments.h"
#include "svms/geometry/pose.h"
#include "svms/marker/marker_model.h"

namespace svms {

// One marker found in an image.
struct Detection {
  int id = -1;
  int rotation = 0;    // which marker corner the quad's first corner was (svms44.h)
  int bit_errors = 0;  // corrected bits
  std::array<Eigen::Vector2d, 4> corners;  // TL, TR, BR, BL as printed; pixels
  std::array<double, 4> corner_sigma{};  // each corner's sigma from its line fits (px); 0: unknown
  // The corners' joint covariance from the same fits (RefinedCorners::corner_covariance:
  // pixels^2, x0, y0, ..., x3, y3; corners on one side correlate across it). Zero: unknown.
  Eigen::Matrix<double, 8, 8> corner_covariance = Eigen::Matrix<double, 8, 8>::Zero();
  // Sides (k: from corner k to corner k + 1) whose edge was taken from under a shadow's
  // penumbra (RefinedCorners::penumbra_sides).
  std::array<bool, 4> penumbra_sides{};
  std::optional<TipObservation> tip;                   // the post tip, when found
  std::optional<Pose> cam_from_marker;                 // with a camera and the marker's model
  PoseCovariance covariance = PoseCovariance::Zero();  // [rotation, translation], camera axes
  bool pose_ambiguous = false;  // the two planar poses are not told apart (MarkerPose)
  // The other planar solution's share of `covariance` (MarkerPose::ambiguity_covariance).
  PoseCovariance ambiguity_covariance = PoseCovariance::Zero();
  // Where pose_ambiguous: the other planar pose and its share of the likelihood
  // (MarkerPose::alternative).
  std::optional<Pose> alternative_pose;
  double alternative_weight = 0;
  bool calibration_in_covariance = false;  // `covariance` includes the camera calibration's
  double pose_rms_px = 0;
  // Stripe and decal edge points in the pose's fit (MarkerPose::edge_points); 0: corners and tip.
  // Their own quadratic about cam_from_marker (MarkerPose::edge_information, edge_offset).
  int edge_points = 0;
  Eigen::Matrix<double, 6, 6> edge_information = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 1> edge_offset = Eigen::Matrix<double, 6, 1>::Zero();
  // With a camera and the marker's model but no pose: why (MarkerPose::failure).
  std::string pose_error;
  int nested_in = -1;           // the outer marker's ID for the inner marker of a dual
  double black = 0, white = 0;  // grey levels of the square and the stripe
  double side_px() const;
};

struct DetectorOptions {
  SegmentOptions segments;
  QuadOptions quads;
  CornerRefineOptions refine;
  MarkerPoseOptions pose;
  int max_corrections = 5;              // never more than this many corrected bits
  int max_unsupported_corrections = 2;  // beyond this, a decode needs independent evidence
  int id_count = 32768;                 // decode among IDs [0, id_count)
  bool known_ids_only = true;           // with marker models: report only their IDs
  double min_contrast = 5;  // white - black, grey levels (a marker in deep shadow: about 10)
  bool refine_corners = true;
  // A quad whose shortest side is below small_quad_refine_px (pixels), whose stripe and square
  // differ by small_quad_min_contrast grey levels at least, with at least
  // small_quad_min_separated_refs of its 44 cells' own stripe and square references apart by
  // half that contrast (BitReading::separated_refs), and whose bits do not decode, or decode
  // only with more than max_unsupported_corrections, gets its corners refined (step 8's fit)
  // and is read again (step 7b; a decode is replaced only by the same ID and rotation). The two
  // bars keep the retry off most of a busy background's small quads: on the detector benchmark's
  // 640 x 480 frame 4 of its 6 such texture quads score 28-38, while all 13 markers of 8-12 px
  // retried in the comparison's size sweep score 44. The segments' corners are only whole-pixel
  // accurate (their edge points are pixels): 0.6-1.0 px off on a 16 px marker behind 0.7 px of blur
  // (sRGB renders), a third of a bit cell (a sixth of the side); 32 px keeps that under a
  // fifth. Where the image is decimated by N (decimate, when the image is large enough) the bar
  // is N times this: the corners are then whole coarse pixels accurate.
  double small_quad_refine_px = 32;
  double small_quad_min_contrast = 20;
  int small_quad_min_separated_refs = 40;
  // Step 7c: step 7b's reading that does not decode, or decodes only with more than
  // max_unsupported_corrections, is read again with its ring's inter-symbol interference
  // modelled from its own cells (ring_equalizer.h), and replaces it where it decodes with fewer
  // corrections. On the small set's 8-12 px markers behind 0.7 px of blur and JPEG, most of the
  // bits a plain reading flips are white cells between black ones. Only on 7b's reading: the
  // segments' corners of such markers are too far off for any reading of their bits, and each
  // equalisation costs some tens of microseconds.
  bool equalize_rings = true;
  // ... only where at least equalize_min_near_cells of the 44 cells read within
  // equalize_near_margin of the threshold (BitReading::margin) and at least
  // equalize_min_clear_cells do not. These bounds were read off jpeg_srgb renders (a scratch
  // probe at the truth's corners) and checked on every sensor profile by `svms bench profiles`:
  // with them no marker any profile found before is lost. Of the small set's 8-12 px JPEG markers
  // whose plain reading at their true corners is 3 or more flips off (77), every one has 2 or more
  // such cells, and 30 or more clear ones; a quad across a marker's stripe, a sharp ring that does
  // not decode, has none, and a flat patch no clear one.
  double equalize_near_margin = 0.1;
  int equalize_min_near_cells = 2;
  int equalize_min_clear_cells = 11;
  RingEqualizerOptions ring_equalizer;
  // Step 7d: where step 7c still leaves the reading weak (under the same bounds on its cells),
  // the ring is read by deconvolution (ring_deconvolution.h): its regions' brightness fitted
  // to its pixels through a blurred pixel footprint, the blur chosen by the fit. It replaces
  // the reading as 7c's does. On the small set's 8-12 px JPEG markers (a scratch probe, views
  // 13, 15, 17, 19, 20 of `svms dataset small --profile jpeg_srgb`) it reads 90 of 94 quads within
  // two flips from step 8's corners, where SampleBits or 7c reads 68. 1-3 ms per quad, so last,
  // only where the quicker readings left the quad weak, and not begun past the frame's deadline.
  bool deconvolve_rings = true;
  RingDeconvolutionOptions ring_deconvolution;
  // Step 10b: when the post's silhouette (grown by this margin, pixels) reaches a side, that
  // side is refitted without the edge points under it and the pose solved again. <= 0: off.
  double post_silhouette_margin_px = 2.5;
  // If set, DetectionStats::debug_pictures receives a picture of each step (the detector
  // writes no files: where pictures go is the caller's business).
  bool debug_pictures = false;
  // Threads per frame (>= 1). Above 1, one frame is shared by that many threads: the edge map
  // in bands of rows and the edge chains in parts (segments.h), the quad search by first side
  // (quads.h), steps 5-8 and 9-10 of each candidate quad as two parts, each part into a slot of
  // its own merged in the serial order. The detections are the same, to the last bit, as with
  // one thread (unless a deadline passes). Images under 128 rows stay on the calling thread;
  // the edge linking (which the chains' fits overlap), the collinear merge and step 11 run on
  // one thread.
  // At most kMaxDetectorThreads (more are taken as that many).
  int threads = 1;
  // Steps 1-4 (edges, segments, quads) on the image averaged over decimate x decimate pixel
  // blocks, as AprilTag's quad_decimate: about decimate^2 times fewer pixels and, on texture,
  // fewer and longer edges. The segments (at least 4 coarse pixels long) are mapped to the full
  // image (pixel centres at integers: coarse pixel q is full pixels decimate q .. decimate q +
  // decimate - 1, the last cols % decimate columns and rows % decimate rows left out of the
  // search), and every later step (reading, corners, tip, pose) works on the full image as with
  // decimate 1 (step 7b's size bar aside: small_quad_refine_px): the corners and poses of a
  // marker found either way come from the same full-resolution fit. What it costs is the small
  // markers: a side must give a segment of 4 coarse pixels after its corners' blunting, so
  // squares under about 8 decimate pixels are mostly lost (at 2, on bench speed's photographs:
  // 26 of 64 found under 16 px, 64 of 66 at 16-24 px, and 1 of 129 lost at 24-70 px), and step 4b
  // (complete_below_px, full pixels) sees no sides under 4 decimate pixels (at 3 and more, none
  // under its 12). The edge thresholds are those of full resolution: averaging lowers the noise and
  // steepens a marker's edge per pixel, so fewer noise edges pass them and a marker's edges pass
  // more easily. The block average is block_average.h's (OpenCV's area resize, which allocates on
  // every call, rounded the same way). 1 (default): off. Values are taken in [1, kMaxDecimate]; an
  // image under 16 x 16 coarse pixels is not decimated.
  int decimate = 1;
};
constexpr int kMaxDetectorThreads = 64;
constexpr int kMaxDecimate = 4;

struct DetectionStats {
  static constexpr int kSteps = 6;
  static constexpr const char* kStepNames[kSteps] = {"segments", "quads", "decode",
                                                     "refine",   "pose",  "nesting"};
  // Wall time per step. With DetectorOptions::threads > 1 steps 5-10 run together per quad:
  // their time is under "decode", and "refine" and "pose" are 0.
  std::array<double, kSteps> ms{};
  int segments = 0, quads = 0, decoded = 0, rejected_for_evidence = 0;
  // The deadline passed before the frame was done: what was finished is returned (nothing when
  // it passed in steps 1-4, the edges or the quads).
  bool budget_exceeded = false;
  // With DetectorOptions::debug_pictures: {"1_segments", BGR picture}, {"2_quads", ...}, each
  // the frame's size.
  std::vector<std::pair<std::string, cv::Mat>> debug_pictures;
  // A 16-bit image's noise as estimated from it (its units); not estimated for 8-bit images.
  NoiseModel noise;
};

class WorkerPool;

class Detector {
 public:
  // `camera` (may be empty) enables undistorted corner fits and poses; `models` (may be
  // empty) give each ID's geometry, its post and its nesting. options.threads < 1 counts as 1,
  // above kMaxDetectorThreads as that.
  Detector(const DetectorOptions& options, const CameraModel& camera,
           const std::vector<MarkerModel>& models);
  // A copy has threads of its own (with options.threads > 1).
  Detector(const Detector& other);
  Detector& operator=(const Detector& other);
  Detector(Detector&& other) noexcept;
  Detector& operator=(Detector&& other) noexcept;
  ~Detector();

  // All markers in `image`, whose values must be linear in light (an image as a camera stores
  // it goes through LinearizeImage, photometric.h, first): CV_8UC1 or CV_16UC1 (any size >=
  // 1x1); a 16-bit image is measured at its full depth (corners, tip, pose), only the search
  // for candidates (steps 1-7) runs on an 8-bit copy scaled to its brightest pixel. Colour
  // images and other depths are converted to grey with OpenCV's weights (other depths through
  // float, saturated to 8 bits); 1, 3 or 4 channels, none for other counts.
  std::vector<Detection> Detect(const cv::Mat& image, DetectionStats* stats = nullptr) const;
  // The same under a deadline: every step checks it (a 16-bit image's noise estimate every 64
  // rows, the edge map, made by bands under a deadline, within every 32 rows and 4,096 pixels of
  // hysteresis, edge linking every 32 rows, the chains every 64, the collinear merge every 256
  // pieces, the quad search every 256 segments, the decoding every 8 quads, corners, tip and pose
  // every marker); once it has passed, stats->budget_exceeded is set and only the markers that
  // went through every step before it are returned: none when it passed in steps 1-4 (edges,
  // segments, quads). Not interrupted, so they bound how far past the deadline a frame runs:
  // step 0 (grey conversion; a 16-bit image's scaling to 8 bits) and one marker's corners, tip
  // and pose (docs/benchmarks.md: 0.35 ms past it at most on a cluttered 1024 x 1024 frame).
  std::vector<Detection> Detect(const cv::Mat& image, DetectionStats* stats,
                                std::chrono::steady_clock::time_point deadline) const;
  // The same into *detections (replaced), whose capacity is reused: with one vector kept by
  // the caller, an 8-bit single-channel image and a camera that is pinhole or one of mrcal's
  // models with gradients, a warmed-up call makes no heap allocation (other depths and colour
  // images are converted into a new buffer).
  // `noise`, when given and valid: the frame's noise in `image`'s units, used instead of the
  // estimate from `image` (a 16-bit image's): EstimateStoredNoise (noise_model.h) measures a raw
  // frame's noise on its stored values, below the black level included, which the linear image
  // has lost.
  void Detect(const cv::Mat& image, DetectionStats* stats,
              std::chrono::steady_clock::time_point deadline, std::vector<Detection>* detections,
              const NoiseModel* noise = nullptr) const;

  const DetectorOptions& options() const { return options_; }

 private:
  DetectorOptions options_;
  CameraModel camera_;
  std::map<int, MarkerModel> models_;  // by ID, inner markers included
  std::map<int, int> outer_of_;        // inner ID -> outer ID
  // The other threads of a frame (options_.threads > 1). A Detect call from a second thread
  // while one runs does its frame on its own thread (WorkerPool::Run): the same results.
  std::unique_ptr<WorkerPool> pool_;
};

}  // namespace svms
