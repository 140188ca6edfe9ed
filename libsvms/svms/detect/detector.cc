#include "svms/detect/detector.h"

#include <algorithm>
#include <atomic>
#include <cassert>
#include <chrono>
#include <memory>
#include <opencv2/imgproc.hpp>
#include <thread>

#include "svms/base/thread_scratch.h"
#include "svms/codec/svms44.h"
#include "svms/detect/bit_sampler.h"
#include "svms/detect/block_average.h"
#include "svms/detect/noise_model.h"
#include "svms/detect/ring_deconvolution.h"
#include "svms/detect/ring_equalizer.h"
#include "svms/detect/worker_pool.h"
#include "svms/geometry/quad_sides.h"

namespace svms {
namespace {

using Clock = std::chrono::steady_clock;

double Ms(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

// The homography from the marker plane of a unit marker (black square of side 1) to pixels,
// with h33 = 1: the 8x8 system cv::getPerspectiveTransform solves, solved here on the stack
// (OpenCV's allocates its matrices on the heap, 16 times a frame).
Eigen::Matrix3d UnitHomography(const std::array<Eigen::Vector2d, 4>& q) {
  static const double src[4][2] = {{-0.5, 0.5}, {0.5, 0.5}, {0.5, -0.5}, {-0.5, -0.5}};
  Eigen::Matrix<double, 8, 8> A = Eigen::Matrix<double, 8, 8>::Zero();
  Eigen::Matrix<double, 8, 1> b;
  for (int i = 0; i < 4; ++i) {
    const double x = src[i][0], y = src[i][1], u = q[i].x(), v = q[i].y();
    A.row(i) << x, y, 1, 0, 0, 0, -x * u, -y * u;
    A.row(i + 4) << 0, 0, 0, x, y, 1, -x * v, -y * v;
    b(i) = u;
    b(i + 4) = v;
  }
  const Eigen::Matrix<double, 8, 1> h = A.partialPivLu().solve(b);
  Eigen::Matrix3d H;
  H << h(0), h(1), h(2), h(3), h(4), h(5), h(6), h(7), 1;
  return H;
}

// Buffers of Detect, kept per thread between calls (no allocation once grown).
struct DetectScratch {
  cv::Mat gray, gray8, gx, gy, stabilised;
  cv::Mat decimated;  // DetectorOptions::decimate: steps 1-3's coarse image
  std::vector<Segment> segments;
  std::vector<Quad> quads;
  std::vector<Detection> decoded, accepted, pending;
  std::vector<ExcludedRegion> excluded;
  // With several threads: steps 5-10 of quad i in slots[i].
  struct QuadSlot {
    // kMeasured: decoded and its corners refined, waiting for its tip and pose (step 9-10).
    enum State { kDropped, kMeasured, kAccepted, kPending, kRejectedForEvidence, kUnfinished };
    State state = kDropped;
    bool known = false;  // its ID has a model
    Detection detection;
  };
  std::vector<QuadSlot> slots;
  // measured[i]: set (release) once steps 5-8 of quad i are done; its pose part waits for it.
  std::unique_ptr<std::atomic<bool>[]> measured;
  size_t measured_size = 0;
};

bool Inside(const Eigen::Vector2d& p, const std::array<Eigen::Vector2d, 4>& q) {
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector2d e = q[(k + 1) % 4] - q[k], d = p - q[k];
    if (e.x() * d.y() - e.y() * d.x() < 0) return false;  // clockwise on screen: inside is right
  }
  return true;
}

// The pose, its covariance, tip and flags of `mp` into `d` (steps 9-10 and 10b's refit).
void SetPose(const MarkerPose& mp, Detection* d) {
  d->cam_from_marker = mp.cam_from_marker;
  d->covariance = mp.covariance;
  d->tip = mp.tip;
  d->pose_ambiguous = mp.ambiguous;
  d->ambiguity_covariance = mp.ambiguity_covariance;
  d->alternative_pose = mp.alternative;
  d->alternative_weight = mp.alternative_weight;
  d->calibration_in_covariance = mp.calibration_in_covariance;
  d->pose_rms_px = mp.rms_px;
  d->edge_points = mp.edge_points;
  d->edge_information = mp.edge_information;
  d->edge_offset = mp.edge_offset;
}

// Step 0's images: what the other steps read.
struct StepImages {
  cv::Mat gray;      // 8-bit grey: steps 1-7 (edges, quads, bits)
  cv::Mat measure;   // the image at its full depth: steps 8-10 (corners, tip, pose)
  double level = 1;  // one grey level of `gray` in `measure`'s units
  // `measure`'s noise where it is 16-bit: step 1's estimate or the caller's (read and gain 0
  // where the codes hide it, a JPEG's); invalid for an 8-bit `measure`.
  NoiseModel noise;
};

// Step 8 for one decoded marker: its corners, their sigmas and joint covariance, and its
// penumbra sides from the sub-pixel fit on the full-depth image (left as decoded where the fit
// fails).
void RefineDetectionCorners(const StepImages& im, const CameraModel* cam, const DetectorOptions& o,
                            Detection* d) {
  const RefinedCorners r =
      RefineCorners(im.measure, d->corners, cam, o.refine, {}, d->black * im.level);
  if (!r.ok) return;
  d->corners = r.corners;
  d->corner_sigma = r.corner_sigma;
  d->corner_covariance = r.corner_covariance;
  d->penumbra_sides = r.penumbra_sides;
}

// 0. One 8-bit grey image (16-bit scaled to its used range, colour converted; other depths
// through 32-bit float, which cvtColor accepts, then saturated to 8 bits), and the image to
// measure on. An 8-bit grey image is used in place; conversions go to sc's buffers. False when
// there is nothing to look at: no image, a channel count that is not an image we know how to
// read (2, 5+), or smaller than 8 x 8.
bool PrepareImages(const cv::Mat& input, DetectScratch* sc, StepImages* im) {
  if (input.empty() || (input.channels() != 1 && input.channels() != 3 && input.channels() != 4))
    return false;
  cv::Mat gray = input, source = input;
  if (input.depth() != CV_8U && input.depth() != CV_16U && input.depth() != CV_32F)
    input.convertTo(source, CV_32F);
  if (source.channels() == 3) {
    cv::cvtColor(source, sc->gray, cv::COLOR_BGR2GRAY);
    gray = sc->gray;
  } else if (source.channels() == 4) {
    cv::cvtColor(source, sc->gray, cv::COLOR_BGRA2GRAY);
    gray = sc->gray;
  } else {
    gray = source;
  }
  // Steps 1-7 (edges, quads, bits) need only a coarse image: 8 bits. Steps 8-10 (corners, tip,
  // pose) measure on `measure`, the image at its full depth: a 16-bit image keeps its
  // precision there, with the grey levels read in steps 5-7 (Detection::black and white, in
  // the 8-bit image's units) times `level` in its units.
  cv::Mat measure;
  double level = 1;
  if (gray.depth() == CV_16U) {
    double mx;
    cv::minMaxLoc(gray, nullptr, &mx);
    const double k = mx > 0 ? 255.0 / mx : 1.0;
    measure = gray;
    level = 1 / k;
    gray.convertTo(sc->gray8, CV_8U, k);
    gray = sc->gray8;
  } else if (gray.depth() != CV_8U) {
    gray.convertTo(sc->gray8, CV_8U);
    gray = sc->gray8;
  }
  if (measure.empty()) measure = gray;
  im->gray = gray;
  im->measure = measure;
  im->level = level;
  return gray.cols >= 8 && gray.rows >= 8;
}

// 1-3. Edges, chains, segments into sc->segments. A 16-bit image's noise is `given_noise` when
// valid, else estimated from the image at its full depth (noise_model.h: black backgrounds
// clipped at 0 and saturated glints left out), and the edges are searched on a scale where it is
// the same everywhere. False when `deadline` passed before every edge chain was processed
// (sc->segments then holds a part, or nothing), the noise estimate and the edge map included.
// With `decimate` > 1 (DetectorOptions::decimate) the edges are those of the image averaged over
// decimate x decimate blocks (BlockAverage), and the segments are returned in full-image pixels;
// *decimated_by is the factor used (1 where the image is too small to decimate).
bool FindEdgeSegments(const StepImages& im, const SegmentOptions& options, DetectScratch* sc,
                      DetectionStats* stats, Clock::time_point deadline, WorkerPool* pool,
                      const NoiseModel* given_noise, int decimate, int* decimated_by) {
  const cv::Mat* edge_image = &im.gray;
  SegmentOptions segment_options = options;
  if (im.measure.depth() == CV_16U) {
    if (given_noise && given_noise->valid())
      stats->noise = *given_noise;
    else if (!EstimateNoise(im.measure, deadline, &stats->noise))
      return false;
    // An image whose codes hide its noise (a JPEG's flat areas: read and gain 0, valid) is
    // searched on the shot noise's square-root scale with the thresholds at their floor below:
    // its edges are as clean as its codes allow.
    NoiseModel edge_noise = stats->noise;
    if (edge_noise.valid() && edge_noise.read_sigma + edge_noise.shot_gain == 0)
      edge_noise.shot_gain = 1;
    if (edge_noise.valid() && edge_noise.read_sigma + edge_noise.shot_gain > 0) {
      const double unit = StabiliseVariance(im.measure, edge_noise, &sc->stabilised, deadline);
      if (unit == 0) return false;
      segment_options.stabilise_variance = false;
      // Very clean images would put the thresholds under the 8 bits' own steps.
      segment_options.noise_sigma = std::max(unit, 0.5);
      edge_image = &sc->stabilised;
    }
  }
  // DetectorOptions::decimate: the edges of the block-averaged image (of the grey levels, or of
  // a 16-bit image's stabilised copy), its segments mapped back to full-image pixels.
  const int f = std::clamp(decimate, 1, kMaxDecimate);
  const bool coarse = f > 1 && edge_image->type() == CV_8UC1 && edge_image->cols / f >= 16 &&
                      edge_image->rows / f >= 16;
  *decimated_by = coarse ? f : 1;
  if (coarse) {
    if (deadline != Clock::time_point::max() && Clock::now() >= deadline) return false;
    const bool averaged = BlockAverage(*edge_image, f, &sc->decimated);
    static_assert(kMaxDecimate <= 4, "BlockAverage averages blocks of up to 4 x 4");
    assert(averaged);  // an 8-bit image and f in [2, kMaxDecimate], as `coarse` requires
    (void)averaged;
    edge_image = &sc->decimated;
  }
  const bool complete =
      FindSegments(*edge_image, segment_options, &sc->gx, &sc->gy, &sc->segments, deadline, pool);
  if (coarse) {
    // Coarse pixel q's centre is full pixel f q + (f - 1) / 2: p = f q + h, so the line
    // n.q + c = 0 becomes n.p + f c - n.h = 0. Contrast: grey levels per full pixel.
    const double h = 0.5 * (f - 1);
    for (Segment& s : sc->segments) {
      s.a = f * s.a + Eigen::Vector2d(h, h);
      s.b = f * s.b + Eigen::Vector2d(h, h);
      s.line.z() = f * s.line.z() - h * (s.line.x() + s.line.y());
      s.contrast /= f;
    }
  }
  stats->segments = static_cast<int>(sc->segments.size());
  return complete;
}

// 7c-7d: the decoding of step 7b's reading of a small square (`bits`, through
// pixel_from_unit), and, where it does not decode or decodes only with more corrections than a
// decode may have without evidence, of the same reading with its ring equalised
// (DetectorOptions::equalize_rings), and where that is still weak, of the ring read by
// deconvolution (DetectorOptions::deconvolve_rings, and `deconvolve`). A later reading is taken
// where the earlier failed, or names the same ID and rotation with fewer corrections: two readings
// of one square that name two codewords cannot both be right, and the first keeps its need for
// evidence. 7d, the dearest reading (1-3 ms), is not begun after `deadline`, and stops between its
// blurs' fits once it has passed; *out_of_time then says so.
CodeMatch DecodeSmallRing(const cv::Mat& gray, const Eigen::Matrix3d& pixel_from_unit,
                          const BitReading& bits, const DetectorOptions& o, bool deconvolve,
                          Clock::time_point deadline, bool* out_of_time) {
  CodeMatch m = Svms44::Decode(bits.word, o.max_corrections, o.id_count);
  auto weak = [&] { return !m.accepted() || m.bit_errors > o.max_unsupported_corrections; };
  if (!weak() || (!o.equalize_rings && !o.deconvolve_rings)) return m;
  // Interference brings cells near the threshold, while the rest stay clear of it: a reading
  // with every cell far from it (a sharp ring that does not decode, such as a marker's stripe
  // read as a ring) or none (a flat patch) is not read again.
  int near = 0;
  for (float margin : bits.margin) near += std::abs(margin) < o.equalize_near_margin;
  if (near < o.equalize_min_near_cells || near > Svms44::kBits - o.equalize_min_clear_cells)
    return m;
  auto consider = [&](uint64_t word) {
    const CodeMatch m2 = Svms44::Decode(word, o.max_corrections, o.id_count);
    if (m2.accepted() && (!m.accepted() || (m2.id == m.id && m2.rotation == m.rotation &&
                                            m2.bit_errors < m.bit_errors)))
      m = m2;
  };
  if (o.equalize_rings) {
    const RingEqualization eq = EqualizeRing(bits, o.ring_equalizer);
    if (eq.ok && eq.word != bits.word) consider(eq.word);
  }
  if (o.deconvolve_rings && deconvolve && weak()) {
    if (deadline != Clock::time_point::max() && Clock::now() >= deadline) {
      *out_of_time = true;
      return m;
    }
    const RingDeconvolution dc =
        ReadRingDeconvolved(gray, pixel_from_unit, o.ring_deconvolution, deadline);
    if (dc.out_of_time) {
      *out_of_time = true;
      return m;
    }
    if (dc.ok && dc.word != bits.word) consider(dc.word);
  }
  return m;
}

// Step 4b's inferred side (3, from corner 3 to corner 0) against the middle known side (1):
// at each side's quarter points, the pixels 0.2 of the middle side's length inside (the black
// square, half a side deep) and outside (the white stripe, a third of a side wide) agree within
// 0.3 of the middle side's own step. A real square's missing side is the same black-to-stripe
// edge as the others, only lost to rounded corners; a texture's three-sided curve rarely closes
// like that. On the small sets (jpeg_srgb, srgb8, linear) the markers 4b gave back differ by at
// most 0.15 of their step. On four of bench speed's photographs (Autumn, aloeR, Path,
// BytheWater) 4b completed 34,500 quads before its skew bound; 4.6 % pass this test, 3.0 % both.
// It reads 12 samples where SampleBits reads hundreds, so it comes first.
bool InferredSideMatches(const cv::Mat& gray, const Quad& q) {
  const Eigen::Vector2d centre = QuadCentroid(q.corners);
  const double depth = 0.2 * (q.corners[2] - q.corners[1]).norm();
  auto levels = [&](const Eigen::Vector2d& p, const Eigen::Vector2d& r, double* in, double* out) {
    const Eigen::Vector2d n = OutwardNormal(p, r, centre);
    *in = *out = 0;
    for (const double t : {0.25, 0.5, 0.75}) {
      const Eigen::Vector2d m = p + t * (r - p);
      *out += SampleImage(gray, m.x() + depth * n.x(), m.y() + depth * n.y()) / 3;
      *in += SampleImage(gray, m.x() - depth * n.x(), m.y() - depth * n.y()) / 3;
    }
  };
  double in1, out1, in3, out3;
  levels(q.corners[1], q.corners[2], &in1, &out1);
  levels(q.corners[3], q.corners[0], &in3, &out3);
  const double step = out1 - in1;
  return step > 0 && std::max(std::abs(in3 - in1), std::abs(out3 - out1)) <= 0.3 * step;
}

// 5-7 for one quad: the homography from its corners, its bits, their decoding. A small square
// whose bits do not decode, or decode only with more corrections than a decode may have without
// evidence, gets its corners refined once and is read again (7b), that reading also with its
// ring equalised (7c) and deconvolved (7d). A quad step 4b completed (Quad::completed) is
// dropped unless its guessed side passes InferredSideMatches and corner fits are on
// (DetectorOptions::refine_corners); its corners are fitted before anything is read, and it is
// not deconvolved. The detection (ID, rotation, corners in the marker's order, grey levels), or
// nullopt; nullopt with *out_of_time set where 7d was due after `deadline` (the quad is then
// unfinished, not rejected). `decimated_by`: the factor the quad's segments were found at
// (FindEdgeSegments); their corners are whole coarse pixels accurate, so 7b retries quads up to
// decimated_by times small_quad_refine_px.
std::optional<Detection> DecodeQuad(const cv::Mat& gray, Quad q, const DetectorOptions& o,
                                    int decimated_by, const CameraModel* cam,
                                    Clock::time_point deadline, bool* out_of_time) {
  static const MarkerModel unit = MarkerModel::Standard(0, 1.0, 0);
  if (q.completed) {
    // 4b's quad: two corners are guesses 1-3 px off, at which the bits mean nothing (a scratch
    // probe on the jpeg_srgb small set: 26-44 of 44 references separated, no decode), nor
    // whether a sample falls outside the image; step 8's fit brings them to 0.1-0.3 px from
    // the truth, as from the segments' corners of a complete square, and the quad is read from
    // there (7b fits once more where that reading is weak). The fit costs more than a reading:
    // only where the stripe and square differ as 7b asks of any retry.
    if (!o.refine_corners || !InferredSideMatches(gray, q)) return std::nullopt;
    const BitReading rough = SampleBits(gray, UnitHomography(q.corners), unit);
    if (rough.white - rough.black < o.small_quad_min_contrast) return std::nullopt;
    const RefinedCorners r = RefineCorners(gray, q.corners, cam, o.refine);
    if (!r.ok) return std::nullopt;
    q.corners = r.corners;
  }
  BitReading bits = SampleBits(gray, UnitHomography(q.corners), unit);
  if (bits.samples_outside > 0 || bits.white - bits.black < o.min_contrast) return std::nullopt;
  CodeMatch m = Svms44::Decode(bits.word, o.max_corrections, o.id_count);
  // 7b. A small square's corners from the segments are off by tenths of a pixel, which at
  // its bit cells (a sixth of its side, out to twice its half-side) misplaces the samples:
  // refine the corners first and read again. Also where the bits decode only with more
  // corrections than a decode may have without independent evidence: behind a lens's blur the
  // segments' square is smaller than the marker's (1.4 px on an 18 px marker behind 0.7 px,
  // where the edges are searched on the noise's square-root scale), its outer bit cells are
  // read toward the stripe, and 3-5 of them flip; the marker would then be turned away for
  // want of a tip. The re-read replaces a decode that failed, or the same ID and rotation read
  // with fewer corrections. From a decimated search the corners are as far off, relative to the
  // side, as a square decimated_by times smaller's: without the retry a 34 px marker's at
  // decimate 2 can flip bits of its ring (three on bench speed's photographs).
  const bool weak = !m.accepted() || m.bit_errors > o.max_unsupported_corrections;
  if (weak && o.refine_corners && q.min_side() < o.small_quad_refine_px * decimated_by &&
      bits.white - bits.black >= o.small_quad_min_contrast &&
      bits.separated_refs >= o.small_quad_min_separated_refs) {
    // Step 8's own fit: the gates above keep texture's quads out of this retry, and on a
    // small blurred marker one iteration leaves corners tenths of a pixel off, which costs
    // bits (JPEG, 11 px: 4 or 5 flipped bits after one iteration, 2 or 3 after two).
    const RefinedCorners r = RefineCorners(gray, q.corners, cam, o.refine);
    if (r.ok) {
      const Eigen::Matrix3d pixel_from_unit = UnitHomography(r.corners);
      const BitReading again = SampleBits(gray, pixel_from_unit, unit);
      if (again.samples_outside == 0 && again.white - again.black >= o.min_contrast) {
        // Not 7d on 4b's quads: a small square in a chessboard (a calibration target, the
        // squares a monitor shows) closes as 4b asks, its ring reads as a weak word, and 7d's
        // 1-3 ms per quad then came to 5-9 ms per frame on bench speed's chessboard photographs
        // (opencv-doc left02, left09), for 2 of the 8 markers 4b with 7d gave back on the
        // jpeg_srgb small set (3 of 10 on srgb8); 7b and 7c cost microseconds.
        const CodeMatch m2 =
            DecodeSmallRing(gray, pixel_from_unit, again, o, !q.completed, deadline, out_of_time);
        if (*out_of_time) return std::nullopt;
        // A decode is replaced only by the same ID in the same rotation with fewer
        // corrections: two readings of one square that name two codewords (9 or more bits
        // apart) cannot both be right, and the weak one still needs its evidence.
        if (m2.accepted() && (!m.accepted() || (m2.id == m.id && m2.rotation == m.rotation &&
                                                m2.bit_errors < m.bit_errors))) {
          q.corners = r.corners;
          bits = again;
          m = m2;
        }
      }
    }
  }
  if (!m.accepted()) return std::nullopt;
  Detection d;
  d.id = m.id;
  d.rotation = m.rotation;
  d.bit_errors = m.bit_errors;
  for (int k = 0; k < 4; ++k) d.corners[k] = q.corners[(k - m.rotation + 4) % 4];
  d.black = bits.black;
  d.white = bits.white;
  return d;
}

// 9-10 for one detection of a marker whose model is known: the tip and the pose, and 10b.
// Without a pose, d->pose_error says why.
void PoseMarker(const StepImages& im, const CameraModel& camera, const MarkerModel& model,
                const DetectorOptions& o, std::vector<ExcludedRegion>* excluded, Detection* d) {
  MarkerPoseOptions pose_options = o.pose;
  if (im.noise.valid()) pose_options.black_noise_sigma = im.noise.Sigma(d->black * im.level);
  MarkerPose mp;
  const bool posed = EstimateMarkerPose(im.measure, d->corners, model, camera, d->black * im.level,
                                        d->white * im.level, pose_options, &mp, d->corner_sigma,
                                        &d->corner_covariance);
  if (!posed) {
    d->pose_error = mp.failure;
    return;
  }
  SetPose(mp, d);
  // 10b. At grazing views the post's silhouette crosses a side and moves the edge points
  // there by pixels: refit the sides without them and solve the pose again.
  std::optional<ExcludedRegion> post;
  if (o.refine_corners && o.post_silhouette_margin_px > 0)
    post = PostSilhouette(model, camera, mp.cam_from_marker, o.post_silhouette_margin_px);
  if (!post || !RegionTouchesSides(*post, d->corners)) return;
  excluded->assign(1, *post);
  const RefinedCorners r =
      RefineCorners(im.measure, d->corners, &camera, o.refine, *excluded, d->black * im.level);
  MarkerPose again;
  // Kept only if the sides fit better without those points: on a short side (a small
  // marker at a grazing angle) the post may hide most of it, and the few points left
  // say less than all of them did.
  auto sum2 = [](const std::array<double, 4>& s) {
    return s[0] * s[0] + s[1] * s[1] + s[2] * s[2] + s[3] * s[3];
  };
  if (r.ok && r.excluded_points > 0 && sum2(r.corner_sigma) < sum2(d->corner_sigma) &&
      EstimateMarkerPose(im.measure, r.corners, model, camera, d->black * im.level,
                         d->white * im.level, pose_options, &again, r.corner_sigma,
                         &r.corner_covariance)) {
    d->corners = r.corners;
    d->corner_sigma = r.corner_sigma;
    d->corner_covariance = r.corner_covariance;
    d->penumbra_sides = r.penumbra_sides;
    SetPose(again, d);
  }
}

// 5-10 on the pool's threads, for DetectorOptions::threads > 1: what the serial steps do to
// each quad (decoding, the ID filter, corners, tip and pose, the evidence for large
// corrections), each quad's outcome into its slot; the accepted detections are then appended
// to sc->accepted, and the inner markers of duals that wait for their outer marker
// (AcceptNestedInOuter) to sc->pending, in the quads' order, as the serial steps append them. A
// quad reached after the deadline is left unfinished (stats->budget_exceeded).
// Each quad is two parts of one job: steps 5-8 (part i) and 9-10 (part n + i, which waits for
// part i to end; parts are handed out in order, so part i is already running or done). A frame
// has a few markers among many quads, and a marker's two halves cost about the same: with two
// parts per quad a thread that has finished one marker's corners poses another's meanwhile,
// where with one part per quad three markers on two threads would take two markers' time.
void MeasureQuadsInParallel(const StepImages& im, const std::vector<Quad>& quads, int decimated_by,
                            const DetectorOptions& o, const CameraModel& camera,
                            const std::map<int, MarkerModel>& models,
                            const std::map<int, int>& outer_of, Clock::time_point deadline,
                            WorkerPool* pool, DetectScratch* sc, DetectionStats* stats) {
  using Slot = DetectScratch::QuadSlot;
  const bool has_deadline = deadline != Clock::time_point::max();
  auto past = [&] { return has_deadline && Clock::now() >= deadline; };
  const CameraModel* cam = camera.empty() ? nullptr : &camera;
  if (sc->slots.size() < quads.size()) sc->slots.resize(quads.size());
  if (sc->measured_size < quads.size()) {
    sc->measured_size = std::max(quads.size(), 2 * sc->measured_size);
    sc->measured = std::make_unique<std::atomic<bool>[]>(sc->measured_size);
  }
  const int n = static_cast<int>(quads.size());
  std::atomic<bool>* measured = sc->measured.get();
  for (int i = 0; i < n; ++i) measured[i].store(false, std::memory_order_relaxed);
  pool->Run(2 * n, [&](int part) {
    if (part < n) {
      // 5-8: decode, the ID filter, the corners. `measured` is set however this ends (an
      // exception included), so that the pose part never waits for ever.
      Slot& slot = sc->slots[part];
      struct Done {
        std::atomic<bool>* flag;
        ~Done() { flag->store(true, std::memory_order_release); }
      } done{&measured[part]};
      slot.state = Slot::kDropped;
      if (past()) {
        slot.state = Slot::kUnfinished;
        return;
      }
      bool out_of_time = false;
      std::optional<Detection> decoded =
          DecodeQuad(im.gray, quads[part], o, decimated_by, cam, deadline, &out_of_time);
      if (out_of_time) slot.state = Slot::kUnfinished;
      if (!decoded) return;
      Detection& d = slot.detection;
      d = std::move(*decoded);
      slot.known = models.count(d.id) > 0;
      if (!models.empty() && o.known_ids_only && !slot.known) return;
      if (o.refine_corners) {
        if (past()) {
          slot.state = Slot::kUnfinished;
          return;
        }
        RefineDetectionCorners(im, cam, o, &d);
      }
      slot.state = Slot::kMeasured;
      return;
    }
    // 9-10: tip and pose, and the evidence for large corrections.
    Slot& slot = sc->slots[part - n];
    // Part part - n is running on another thread (or done): wait for it, yielding now and then
    // so that a machine with more threads than cores lets it run.
    for (int k = 0; !measured[part - n].load(std::memory_order_acquire); ++k) {
      if (k % 64 == 63) std::this_thread::yield();
      CpuRelax();
    }
    if (slot.state != Slot::kMeasured) return;
    if (past()) {
      slot.state = Slot::kUnfinished;
      return;
    }
    Detection& d = slot.detection;
    thread_local std::vector<ExcludedRegion> excluded;
    if (cam && slot.known) PoseMarker(im, camera, models.at(d.id), o, &excluded, &d);
    const bool evidence = d.tip.has_value() || (d.bit_errors <= 3 && slot.known);
    if (d.bit_errors <= o.max_unsupported_corrections || evidence) {
      slot.state = Slot::kAccepted;
    } else if (outer_of.count(d.id) > 0) {
      slot.state = Slot::kPending;  // the inner marker of a known dual: AcceptNestedInOuter
    } else {
      slot.state = Slot::kRejectedForEvidence;
    }
  });
  for (size_t i = 0; i < quads.size(); ++i) {
    const Slot& slot = sc->slots[i];
    if (slot.state == Slot::kUnfinished) stats->budget_exceeded = true;
    if (slot.state == Slot::kRejectedForEvidence) ++stats->rejected_for_evidence;
    if (slot.state == Slot::kPending) sc->pending.push_back(slot.detection);
    if (slot.state == Slot::kAccepted) sc->accepted.push_back(slot.detection);
  }
}

// 11. `accepted` without duplicates (the same marker from two quads: the one with fewer
// corrected bits stays) into *result, and each inner marker of a dual marked as nested in its
// outer one (by the models' nesting; without models, any marker inside one 1.5 times its size).
void MergeAndNest(const std::vector<Detection>& accepted, const std::map<int, int>& outer_of,
                  std::vector<Detection>* out) {
  std::vector<Detection>& result = *out;
  for (const Detection& d : accepted) {
    bool dup = false;
    for (Detection& r : result) {
      if (r.id == d.id && (r.corners[0] - d.corners[0]).norm() < 0.2 * r.side_px()) {
        if (d.bit_errors < r.bit_errors) r = d;
        dup = true;
      }
    }
    if (!dup) result.push_back(d);
  }
  for (Detection& d : result) {
    auto it = outer_of.find(d.id);
    for (const Detection& r : result) {
      if (&r == &d) continue;
      const Eigen::Vector2d c = QuadCentroid(d.corners);
      const bool model_says = it != outer_of.end() && it->second == r.id;
      if ((model_says || outer_of.empty()) && r.side_px() > 1.5 * d.side_px() &&
          Inside(c, r.corners)) {
        d.nested_in = r.id;
      }
    }
  }
}

// Graded acceptance's last evidence: a decode with more corrections than it may have alone,
// of the inner marker of a known dual marker, is accepted when it lies inside the black
// square of that dual's outer marker, itself accepted. A random word lands within 5 flips of
// one given ID in any of 4 rotations with probability 4 x 1.24e6 / 2^44 = 3e-7, and a
// texture's quad does not lie inside a marker's black square: on a small blurred marker
// (JPEG, 8-11 px) the true corners themselves read 2-4 flipped bits, and no tip shows.
// The rest of *pending counts in *rejected; *pending is consumed.
void AcceptNestedInOuter(const std::map<int, int>& outer_of, std::vector<Detection>* pending,
                         std::vector<Detection>* accepted, int* rejected) {
  const size_t before = accepted->size();
  for (const Detection& d : *pending) {
    const int outer = outer_of.at(d.id);
    const Eigen::Vector2d c = QuadCentroid(d.corners);
    bool inside = false;
    for (size_t i = 0; i < before && !inside; ++i) {
      const Detection& r = (*accepted)[i];
      inside = r.id == outer && r.side_px() > 1.5 * d.side_px() && Inside(c, r.corners);
    }
    if (inside)
      accepted->push_back(d);
    else
      ++*rejected;
  }
  pending->clear();
}

// The pictures of DetectorOptions::debug_pictures: the segments, the quads.
void DrawDebugPictures(const cv::Mat& gray, const std::vector<Segment>& segs,
                       const std::vector<Quad>& quads, DetectionStats* stats) {
  cv::Mat dbg;
  cv::cvtColor(gray, dbg, cv::COLOR_GRAY2BGR);
  for (const Segment& s : segs)
    cv::line(dbg, cv::Point2d(s.a.x(), s.a.y()), cv::Point2d(s.b.x(), s.b.y()),
             cv::Scalar(0, 200, 255), 1);
  stats->debug_pictures.emplace_back("1_segments", dbg);
  cv::cvtColor(gray, dbg, cv::COLOR_GRAY2BGR);
  for (const Quad& q : quads)
    for (int k = 0; k < 4; ++k)
      cv::line(dbg, cv::Point2d(q.corners[k].x(), q.corners[k].y()),
               cv::Point2d(q.corners[(k + 1) % 4].x(), q.corners[(k + 1) % 4].y()),
               cv::Scalar(255, 100, 0), 1);
  stats->debug_pictures.emplace_back("2_quads", dbg);
}

}  // namespace

double Detection::side_px() const {
  double s = 0;
  for (int k = 0; k < 4; ++k) s += (corners[(k + 1) % 4] - corners[k]).norm();
  return s / 4;
}

Detector::Detector(const DetectorOptions& options, const CameraModel& camera,
                   const std::vector<MarkerModel>& models)
    : options_(options), camera_(camera) {
  options_.threads = std::clamp(options_.threads, 1, kMaxDetectorThreads);
  for (const MarkerModel& m : models) {
    models_[m.id] = m;
    if (auto inner = m.InnerModel()) {
      models_[inner->id] = *inner;
      outer_of_[inner->id] = m.id;
    }
  }
  if (options_.threads > 1) pool_ = std::make_unique<WorkerPool>(options_.threads);
}

Detector::Detector(const Detector& other)
    : options_(other.options_),
      camera_(other.camera_),
      models_(other.models_),
      outer_of_(other.outer_of_) {
  if (options_.threads > 1) pool_ = std::make_unique<WorkerPool>(options_.threads);
}

Detector& Detector::operator=(const Detector& other) {
  if (this == &other) return *this;
  options_ = other.options_;
  camera_ = other.camera_;
  models_ = other.models_;
  outer_of_ = other.outer_of_;
  pool_.reset();
  if (options_.threads > 1) pool_ = std::make_unique<WorkerPool>(options_.threads);
  return *this;
}

Detector::Detector(Detector&& other) noexcept = default;
Detector& Detector::operator=(Detector&& other) noexcept = default;
Detector::~Detector() = default;

std::vector<Detection> Detector::Detect(const cv::Mat& input, DetectionStats* stats_out) const {
  return Detect(input, stats_out, Clock::time_point::max());
}

std::vector<Detection> Detector::Detect(const cv::Mat& input, DetectionStats* stats_out,
                                        Clock::time_point deadline) const {
  std::vector<Detection> result;
  Detect(input, stats_out, deadline, &result);
  return result;
}

void Detector::Detect(const cv::Mat& input, DetectionStats* stats_out, Clock::time_point deadline,
                      std::vector<Detection>* detections, const NoiseModel* noise) const {
  DetectScratch& sc = ThreadScratch<DetectScratch>();
  DetectionStats stats;
  const DetectorOptions& o = options_;
  std::vector<Detection>& result = *detections;
  result.clear();
  std::vector<Detection>& out = sc.decoded;
  out.clear();
  if (stats_out) *stats_out = stats;
  const bool has_deadline = deadline != Clock::time_point::max();
  auto past_deadline = [&] {
    if (!has_deadline || Clock::now() < deadline) return false;
    stats.budget_exceeded = true;  // only fully processed markers are reported
    return true;
  };

  // The workers' wake-up behind steps 0-1 (worker_pool.h), where the frame will use them.
  if (pool_ && input.rows >= 128) pool_->Prewake();
  // 0. The images the steps read.
  StepImages im;
  if (!PrepareImages(input, &sc, &im)) return;

  // 1-3. Edges, chains, segments.
  auto t0 = Clock::now();
  // Past the deadline in steps 1-4 the frame ends there, flagged, with no detections: a part of
  // the edges or quads would find the markers of a part of the image, which a caller could not
  // tell from a frame without the others.
  int decimated_by = 1;
  const bool edges_complete = FindEdgeSegments(im, o.segments, &sc, &stats, deadline, pool_.get(),
                                               noise, o.decimate, &decimated_by);
  im.noise = stats.noise;
  auto t1 = Clock::now();
  stats.ms[0] = Ms(t0, t1);
  if (!edges_complete) {
    stats.budget_exceeded = true;
    if (stats_out) *stats_out = stats;
    return;
  }

  // 4. Quads. From a decimated image's segments a side's end may miss its corner by whole
  // coarse pixels: the block average and the 3 x 3 derivatives blunt a corner by about a coarse
  // pixel, and the piece of chain around it, under the segments' minimum length, is dropped. The
  // join distance's floor is that, in coarse pixels (5 at the defaults: a 30 px marker's corner
  // at decimate 2 was missed by 10 full pixels on a photograph of bench speed).
  QuadOptions quad_options = o.quads;
  if (decimated_by > 1)
    quad_options.join_min_px =
        decimated_by * std::max(o.quads.join_min_px, o.segments.min_length + 1);
  std::vector<Quad>& quads = sc.quads;
  const bool quads_complete = FindQuads(sc.segments, quad_options, im.gray.cols, im.gray.rows,
                                        &quads, deadline, pool_.get());
  stats.quads = static_cast<int>(quads.size());
  auto t2 = Clock::now();
  stats.ms[1] = Ms(t1, t2);
  if (!quads_complete) {
    stats.budget_exceeded = true;
    if (stats_out) *stats_out = stats;
    return;
  }

  if (pool_) {
    // 5-10 per quad on the pool's threads.
    sc.accepted.clear();
    sc.pending.clear();
    MeasureQuadsInParallel(im, quads, decimated_by, o, camera_, models_, outer_of_, deadline,
                           pool_.get(), &sc, &stats);
    AcceptNestedInOuter(outer_of_, &sc.pending, &sc.accepted, &stats.rejected_for_evidence);
    const auto t5 = Clock::now();
    stats.ms[2] = Ms(t2, t5);
    MergeAndNest(sc.accepted, outer_of_, &result);
    stats.decoded = static_cast<int>(result.size());
    stats.ms[5] = Ms(t5, Clock::now());
    if (o.debug_pictures) DrawDebugPictures(im.gray, sc.segments, quads, &stats);
    if (stats_out) *stats_out = stats;
    return;
  }

  // 5-7. Homography, bits, decoding (the clock is read every 8 quads).
  const CameraModel* cam = camera_.empty() ? nullptr : &camera_;
  for (size_t qi = 0; qi < quads.size(); ++qi) {
    if (qi % 8 == 0 && past_deadline()) break;
    bool out_of_time = false;
    std::optional<Detection> d =
        DecodeQuad(im.gray, quads[qi], o, decimated_by, cam, deadline, &out_of_time);
    if (out_of_time) {
      stats.budget_exceeded = true;
      break;
    }
    if (!d) continue;
    const bool known = models_.count(d->id) > 0;
    if (!models_.empty() && o.known_ids_only && !known) continue;
    out.push_back(*d);
  }
  auto t3 = Clock::now();
  stats.ms[2] = Ms(t2, t3);

  // 8. Sub-pixel corners (in the rotated order: clockwise on screen either way).
  if (o.refine_corners) {
    for (size_t i = 0; i < out.size(); ++i) {
      if (stats.budget_exceeded || past_deadline()) {
        stats.budget_exceeded = true;
        out.resize(i);
        break;
      }
      Detection& d = out[i];
      RefineDetectionCorners(im, cam, o, &d);
    }
  }
  auto t4 = Clock::now();
  stats.ms[3] = Ms(t3, t4);

  // 9-10. Tip and pose; graded acceptance of large corrections.
  std::vector<Detection>& accepted = sc.accepted;
  std::vector<Detection>& pending = sc.pending;
  accepted.clear();
  pending.clear();
  for (Detection& d : out) {
    if (past_deadline()) break;
    auto it = models_.find(d.id);
    if (cam && it != models_.end()) PoseMarker(im, camera_, it->second, o, &sc.excluded, &d);
    if (d.bit_errors > o.max_unsupported_corrections) {
      // Independent evidence: the post tip found where the pose puts it (and, for 3
      // corrections, membership of the known set is enough).
      const bool known = models_.count(d.id) > 0;
      const bool evidence = d.tip.has_value() || (d.bit_errors <= 3 && known);
      if (!evidence) {
        // The inner marker of a known dual may still have its outer marker around it.
        if (outer_of_.count(d.id) > 0)
          pending.push_back(d);
        else
          ++stats.rejected_for_evidence;
        continue;
      }
    }
    accepted.push_back(d);
  }
  AcceptNestedInOuter(outer_of_, &pending, &accepted, &stats.rejected_for_evidence);
  auto t5 = Clock::now();
  stats.ms[4] = Ms(t4, t5);

  // 11. Duplicates (the same marker from two quads) and nesting.
  MergeAndNest(accepted, outer_of_, &result);
  stats.decoded = static_cast<int>(result.size());
  stats.ms[5] = Ms(t5, Clock::now());

  if (o.debug_pictures) DrawDebugPictures(im.gray, sc.segments, quads, &stats);
  if (stats_out) *stats_out = stats;
}

}  // namespace svms
