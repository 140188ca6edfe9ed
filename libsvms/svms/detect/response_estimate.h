// The camera's response curve, estimated from the images themselves.
//
// Across a straight black/white edge, the image of the light (the edge spread function: a step
// through the lens's blur and the pixels' area) is point-symmetric about the edge in linear
// light, whatever the blur, as long as the blur is symmetric. A response curve bends it: in
// gamma-encoded values the bright half is stretched and the dark half squeezed. So the gamma G
// that makes many edges symmetric (their line spread functions unskewed) when the stored values
// are raised to it is the camera's (linear = stored^G; sRGB reads as G = 2.5 or so across a
// black/white edge, response_check.cc). The sides of the markers a detector finds are such
// edges: a black square in a white stripe. `svms calibrate --response estimate` measures it on
// every board image; `svms detect` checks a declared response against it.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "svms/detect/detector.h"

namespace svms {

// A patch of pixels across an edge: every pixel whose centre lies within kPatchHalfAcross px of
// the edge as found and within kPatchHalfAlong px along it of the patch's centre (less on sides
// under 32 px, so as to stop 3 px short of the corners), with its stored
// code, its signed distance across the edge (px; positive on the bright side) and its weight
// along the edge (a Gaussian of kPatchAlongSigma px about the patch's centre).
//
// Why pixels and not a profile interpolated across the edge: the moments of an edge's line
// spread function are then sums over the pixel lattice of smooth weights times the pixels'
// values (the derivative moved onto the weights by parts, EstimateGammaFromEdges), and such
// sums equal their integrals to within the blurred image's content at the lattice frequency,
// whatever the edge's angle and sub-pixel phase. A profile interpolated between pixels has an
// error that depends on that phase: on the simulator's board, noise-free, it scattered each
// profile's reading of gamma by +-1.9, where the pixel sums scatter by +-0.003 (docs/detector.md).
// The candidate curve is applied to each pixel's code, before anything is summed.
constexpr double kPatchHalfAcross = 4;
constexpr double kPatchHalfAlong = 5;
constexpr double kPatchAlongSigma = 2;
struct EdgePatch {
  std::vector<uint16_t> code;
  std::vector<float> across;  // px from the edge as found, positive towards the bright side
  std::vector<float> along_weight;
  std::vector<uint8_t> half;  // 0 before the patch's centre along the edge, 1 from it on
  // A code's value on the 0..1 scale the response is applied on: (code - black) / range.
  float black = 0, range = 1;
  // Room on the bright side before the next edge (the white stripe's width, px): the patch is
  // left out where its blur reaches beyond that.
  float room = 0;
  uint32_t side = 0;  // the marker side it lies on (patches of one side share their noise)
};

// Patches across the sides of `detections` (corners TL, TR, BR, BL as printed, pixels; pixel
// centres at integer coordinates) in `stored` (one channel, 8 or 16 bits, values as stored: not
// linearised), normalised by `black_level` and `white_level` (0: the depth's largest value).
// Only sides of markers whose white stripe is at least 4 px wide give patches: 5 per side,
// centred at 1/4, 3/8, 1/2, 5/8 and 3/4 of it. Appended to *out (at most `max_patches` in all:
// further ones are dropped).
void CollectEdgePatches(const cv::Mat& stored, const std::vector<Detection>& detections,
                        double black_level, double white_level, std::vector<EdgePatch>* out,
                        size_t max_patches = 25000);

// Keeps `keep` of *patches, evenly spaced in their order (an image's patches come marker by
// marker, side by side: so the markers keep about equal shares, as long as `keep` is not below
// their number); all of them when there are no more than `keep`.
void KeepEvenly(size_t keep, std::vector<EdgePatch>* patches);

struct ResponseEstimate {
  double gamma = 1;  // linear = stored^gamma
  double sigma = 0;  // its standard error (from the spread of estimates over groups of markers)
  int patches = 0;   // patches it rests on (0: none usable; gamma 1)
  // Asymmetry of the edges (the absolute pooled skewness of their line spread functions) at
  // `gamma`, and read as linear (gamma 1) and as sRGB: compared with `sigma`'s scale it says
  // whether a declared response is contradicted by the pixels.
  double asymmetry = 0, asymmetry_linear = 0, asymmetry_srgb = 0;
};

// The gamma in [0.5, 3.5] that makes the patches' edges point-symmetric: where the pooled
// skewness of their line spread functions crosses zero, with its standard error from 8 groups
// of the markers. Needs at least 20 usable patches with a crossing (else patches = 0 and
// gamma 1: binary edges, as on printed artwork, read the same through any curve and say
// nothing).
ResponseEstimate EstimateGammaFromEdges(const std::vector<EdgePatch>& patches);

}  // namespace svms
