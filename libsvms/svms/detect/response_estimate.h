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

#include <array>
#include <opencv2/core.hpp>
#include <vector>

#include "svms/detect/detector.h"

namespace svms {

// One profile across an edge, from its dark side to its bright side, at kProfileSamples
// offsets kProfileStep px apart, centred on the edge as found: at each, the four pixels around
// the point (stored values, 0..1 of the range between the black and white levels) and their
// bilinear weights. The pixels are kept rather than their interpolation because the candidate
// response must be applied to each pixel before interpolating: interpolated encoded values
// read through a curve are not the interpolated light (for gamma > 1 they are darker between
// the pixels, which skews a sharp edge's profile as much as the curve itself).
constexpr int kProfileSamples = 25;
constexpr double kProfileStep = 0.25;
struct EdgeProfile {
  std::array<std::array<float, 4>, kProfileSamples> value;
  std::array<std::array<float, 4>, kProfileSamples> weight;
  // The profile read through `to_linear` (stored 0..1 -> linear), interpolated.
  template <typename F>
  double At(int i, const F& to_linear) const {
    double v = 0;
    for (int k = 0; k < 4; ++k) v += weight[i][k] * to_linear(value[i][k]);
    return v;
  }
};

// Profiles across the sides of `detections` (corners TL, TR, BR, BL as printed, pixels) in
// `stored` (one channel, 8 or 16 bits, values as stored: not linearised), normalised by
// `black_level` and `white_level` (0: the depth's largest value). Only sides of markers whose
// white stripe is at least 4 px wide (the profile's +-3 px must see both plateaus) give
// profiles: 5 per side, from its middle 60 %. Appended to *out (at most `max_profiles` in
// all: further ones are dropped).

void CollectEdgeProfiles(const cv::Mat& stored, const std::vector<Detection>& detections,
                         double black_level, double white_level, std::vector<EdgeProfile>* out,
                         size_t max_profiles = 50000);

struct ResponseEstimate {
  double gamma = 1;  // linear = stored^gamma
  double sigma = 0;  // its standard error (from the spread of estimates over groups of edges)
  int profiles = 0;  // profiles it rests on (0: none usable; gamma 1)
  // Asymmetry of the profiles (the absolute mean skewness of their line spread functions) at
  // `gamma`, and read as linear (gamma 1) and as sRGB: compared with `sigma`'s scale it says
  // whether a declared response is contradicted by the pixels.
  double asymmetry = 0, asymmetry_linear = 0, asymmetry_srgb = 0;
};

// The gamma in [0.5, 3.5] that makes `profiles` point-symmetric: where the mean skewness of
// their line spread functions crosses zero, with its standard error from 8 groups of the
// profiles. Needs at least 20 profiles with a crossing (else profiles = 0 and gamma 1: binary
// edges, as on printed artwork, read the same through any curve and say nothing).
ResponseEstimate EstimateGammaFromEdges(const std::vector<EdgeProfile>& profiles);

}  // namespace svms
