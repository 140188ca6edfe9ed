// The camera's response curve, estimated from the images themselves.
//
// Across a straight black/white edge, the image of the light (the edge spread function: a step
// through the lens's blur and the pixels' area) is point-symmetric about the edge in linear
// light, whatever the blur, as long as the blur is symmetric. A response curve bends it: in
// gamma-encoded values the bright half is stretched and the dark half squeezed. So the gamma G
// that makes many edge profiles symmetric (their line spread functions unskewed) when the
// stored values are raised to it is the camera's (linear = stored^G; sRGB is close to G = 2.2). The
// sides of the markers a detector finds are such edges: a black square in a white stripe. `svms
// calibrate --response estimate` measures it on every board image; `svms detect` checks a declared
// response against it.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "svms/detect/detector.h"

namespace svms {

// One profile across an edge, from its dark side to its bright side, at kProfileSamples
// offsets kProfileStep px apart, centred on the edge as found. Each sample is the mean of
// kProfileLines parallel lines across the edge, spanning up to 4 px along it: on each, the four
// pixels around the point (their stored codes) with their bilinear weights, each line's
// summing to 1 / kProfileLines. The pixels are kept rather than their interpolation because
// the candidate response must be applied to each pixel before interpolating: interpolated
// encoded values read through a curve are not the interpolated light (for gamma > 1 they are
// darker between the pixels, which skews a sharp edge's profile as much as the curve itself).
// The lines are averaged because a skewness is a ratio of noisy moments: its bias grows with
// the variance of the profile's noise and, under shot noise (the bright side noisier than the
// dark), has a sign (response_estimate_test.cc, ShotNoiseDoesNotBiasTheEstimate).
constexpr int kProfileSamples = 25;
constexpr double kProfileStep = 0.25;
constexpr int kProfileLines = 5;
constexpr int kProfilePixels = 4 * kProfileLines;
struct EdgeProfile {
  // The stored values (8- or 16-bit codes) and their weights.
  std::array<std::array<uint16_t, kProfilePixels>, kProfileSamples> code{};
  std::array<std::array<float, kProfilePixels>, kProfileSamples> weight{};
  // A code's value on the 0..1 scale the response is applied on: (code - black) / range.
  float black = 0, range = 1;
};

// Profiles across the sides of `detections` (corners TL, TR, BR, BL as printed, pixels) in
// `stored` (one channel, 8 or 16 bits, values as stored: not linearised), normalised by
// `black_level` and `white_level` (0: the depth's largest value). Only sides of markers whose
// white stripe is at least 4 px wide (the profile's +-3 px must see both plateaus) give
// profiles: 5 per side, from its middle half, their lines min(1, length / 20) px apart.
// Appended to *out (at most `max_profiles` in all: further ones are dropped).

void CollectEdgeProfiles(const cv::Mat& stored, const std::vector<Detection>& detections,
                         double black_level, double white_level, std::vector<EdgeProfile>* out,
                         size_t max_profiles = 25000);

struct ResponseEstimate {
  double gamma = 1;  // linear = stored^gamma
  double sigma = 0;  // its standard error (from the spread of estimates over groups of edges)
  int profiles = 0;  // profiles it rests on (0: none usable; gamma 1)
  // Asymmetry of the profiles (the absolute pooled skewness of their line spread functions) at
  // `gamma`, and read as linear (gamma 1) and as sRGB: compared with `sigma`'s scale it says
  // whether a declared response is contradicted by the pixels.
  double asymmetry = 0, asymmetry_linear = 0, asymmetry_srgb = 0;
};

// The gamma in [0.5, 3.5] that makes `profiles` point-symmetric: where the pooled skewness of
// their line spread functions crosses zero, with its standard error from 8 groups of the
// profiles. Needs at least 20 profiles with a crossing (else profiles = 0 and gamma 1: binary
// edges, as on printed artwork, read the same through any curve and say nothing).
ResponseEstimate EstimateGammaFromEdges(const std::vector<EdgeProfile>& profiles);

}  // namespace svms
