// Detector steps 1-3: edge points from the image gradient, edge chains, and straight
// segments split and fitted from the chains.
//
// Edges come from Canny (hysteresis on the Sobel gradient of 16 sqrt(grey), non-maximum
// suppressed; canny.h, OpenCV's algorithm without its allocations); chains are the edge map's
// 8-connected curves; each chain is split where it stops being straight (Douglas-Peucker, then
// neighbouring pieces that still fit one line are joined again) and every piece gets a
// total-least-squares line. A segment knows its polarity: the side its dark region is on.
#pragma once

#include <Eigen/Core>
#include <chrono>
#include <opencv2/core.hpp>
#include <vector>

namespace svms {

class WorkerPool;

struct Segment {
  // End points in pixels, ordered so that the darker side is on the right as seen on screen
  // when walking from `a` to `b` (image x right, y down): the border of a dark square is then
  // walked clockwise on screen, each segment's `b` next to the following segment's `a`.
  Eigen::Vector2d a, b;
  Eigen::Vector3d line;  // normalised line (nx, ny, c): nx x + ny y + c = 0, (nx, ny) unit
  double contrast = 0;   // mean gradient magnitude along the segment, grey levels per pixel
  double length() const { return (b - a).norm(); }
};

struct SegmentOptions {
  // Hysteresis thresholds on the gradient, grey levels per pixel: low, because a marker in
  // shadow or seen at a grazing angle may show a step of only 10-20 grey levels.
  double canny_low = 3, canny_high = 8;
  // Find edges on 16 sqrt(grey) (noise about one level at every brightness; see segments.cc)
  // instead of on the grey levels; the thresholds above then apply on that scale.
  bool stabilise_variance = true;
  // Sensor read noise breaks that: 16 sqrt(grey) multiplies the noise in the dark by
  // 8 / sqrt(grey), and 4 grey levels of read noise become 12 levels inside a black square,
  // thousands of noise edges and a detector ten times slower. The read noise is estimated in
  // each image (EstimateReadNoise); above read_noise_gate grey levels the scale becomes
  // 16 sqrt(grey + 64 sigma^2), the stabilising transform for shot plus read noise.
  double read_noise_gate = 1.5;
  // The noise's sigma on the input's scale when the caller has stabilised the variance itself
  // (stabilise_variance false, noise_model.h StabiliseVariance): the hysteresis thresholds are
  // in units of it. 1 otherwise.
  double noise_sigma = 1;
  double min_length = 4;  // pixels
  // A chain is split where it leaves its chord by more than max(max_deviation,
  // relative_deviation * chord length): lens distortion bows a marker's side by about 1 % of
  // its length, a corner by far more.
  double max_deviation = 1.0;  // pixels
  double relative_deviation = 0.02;
  // Neighbouring pieces of a chain are joined again when their union stays within
  // max(rejoin_deviation, relative_deviation * length) of one line: the pixels of a digital
  // edge stray up to a pixel from it, one more at a corner pixel; the corners of a 30 px marker
  // seen at 70 degrees stray several pixels.
  double rejoin_deviation = 1.5;  // pixels
  // Pieces of one straight edge (split by a junction, a shadow or a small occlusion) are
  // joined when they point the same way within merge_angle_deg (a short piece: within the
  // angle that moves its far end by merge_offset_px), the shorter piece's ends lie within
  // merge_offset_px of the longer's line, and the gap is at most merge_gap_fraction of the
  // shorter piece (or merge_gap_px). A join across a gap wider than merge_gap_px keeps its two
  // pieces as well: a marker's side may line up with a background edge beyond its stripe and
  // ring, and the quad search needs the side alone.
  double merge_angle_deg = 4;
  double merge_offset_px = 1.5;
  double merge_gap_fraction = 0.5;
  double merge_gap_px = 3;
  // Step 3c: where one piece starts within bridge_gap_px of another's end and turns by less
  // than bridge_max_turn_deg (too much to merge them), a segment spanning both is added and
  // both are kept: a shadow or the post's shade across a small square's side bends its edge
  // by 5-15 degrees halfway, and the quad search needs one segment per side. 0: off.
  double bridge_max_turn_deg = 20;
  double bridge_gap_px = 1.5;
};

// The segment from s.a to t.b: its line through the length-weighted middle of both pieces,
// its contrast their length-weighted mean (how MergeCollinear and BridgeKinks join pieces).
Segment JoinSegments(const Segment& s, const Segment& t);

// Step 3b: joins collinear pieces (see SegmentOptions); the result replaces `segments`: the
// pieces left and joined, in their order, then the two pieces of each join across a gap wider
// than merge_gap_px as they were when joined (either may be an earlier join's result; the piece
// extended first, then the one joined to its end), in the order of the joins.
// `deadline` is read every 256 pieces of each sweep: once it has passed the result is false and
// *segments a part-merged list fit for nothing but discarding.
bool MergeCollinear(
    const SegmentOptions& options, std::vector<Segment>* segments,
    std::chrono::steady_clock::time_point deadline = std::chrono::steady_clock::time_point::max());
// Step 3c: appends a segment over each pair of pieces joined by a small bend (SegmentOptions).
void BridgeKinks(const SegmentOptions& options, std::vector<Segment>* segments);

// Finds straight edge segments in an 8-bit image. `gradient_x`, `gradient_y` (CV_16S Sobel,
// computed here) are returned for later steps.
// The read noise of an 8-bit image, grey levels RMS: from the darkest grey-level bin
// with enough pixels (every 4th pixel of every 4th row, binned by grey level in steps of 32), the
// robust spread of the 4-neighbour Laplacian there, less the shot noise the 16 sqrt(grey) scale
// assumes (grey / 64) and the quantisation's 1/12. Texture inflates it; the median keeps
// that small where most of the bin is flat. 0 for images smaller than 8 x 8.
double EstimateReadNoise(const cv::Mat& gray8);

std::vector<Segment> FindSegments(const cv::Mat& gray8, const SegmentOptions& options,
                                  cv::Mat* gradient_x, cv::Mat* gradient_y);
// The same into *segments (replaced). Its buffers, and this thread's scratch (kept between
// calls, per thread), are reused: with *segments, gradient_x and gradient_y kept by the caller,
// a call on an image no larger than earlier ones allocates nothing once they have grown.
// `deadline`: with one (and an image of 128 rows or more) the edge map is made by bands of rows
// on this thread (edge_bands.h, the same map), which read it before each band of the read-noise
// sums and every 32 rows of the map and every 4,096 pixels of its hysteresis; then every 32 rows
// of edge linking, every 64 edge chains and every 256 pieces of the merge; once it has passed
// the result is false, with the segments found so far (none when the edge map or linking was
// interrupted; part-merged where the merge had not finished). True when every chain was
// processed. Without a deadline the whole-image path runs (cv::spatialGradient, then Canny),
// about 10 % faster.
// With `pool` (2 threads or more) the edge map is computed in bands of rows (edge_bands.h), and
// the chains are fitted in chunks on its threads while one of them links them (the linking
// itself stays on one thread: which chain takes a pixel depends on the walks' order): the same
// segments in the same order, value for value.
bool FindSegments(
    const cv::Mat& gray8, const SegmentOptions& options, cv::Mat* gradient_x, cv::Mat* gradient_y,
    std::vector<Segment>* segments,
    std::chrono::steady_clock::time_point deadline = std::chrono::steady_clock::time_point::max(),
    WorkerPool* pool = nullptr);

}  // namespace svms
