// The luminance of a raw Bayer mosaic at every pixel, made for measuring edges.
//
// What the detector measures on a mosaic is where a black/white edge lies, to hundredths of a
// pixel. An edge-aware demosaic (OpenCV's COLOR_Bayer..._EA, VNG) chooses per pixel along
// which direction to interpolate, from the pixels themselves: at a sharp grey edge that choice
// moves the interpolated edge by a few hundredths of a pixel, differently on each side of a
// marker, which no covariance from the edge's own scatter sees (docs/detector.md). A linear,
// shift-invariant, symmetric filter cannot move an edge at all. So the luminance is taken here
// by frequency selection (Alleysson, Suesstrunk and Herault, "Linear demosaicing inspired by
// the human visual system", IEEE Trans. Image Processing 14(4), 2005): a Bayer mosaic is the
// luminance at low spatial frequencies plus the chrominance modulated onto the carriers at
// (pi, pi), (pi, 0) and (0, pi); a 5 x 5 filter with zeros at those carriers keeps the
// luminance and removes the colour's checkerboard.
//
// Before the filter the mosaic is white-balanced: red and blue pixels are scaled to green's
// sensitivity by gains estimated from the image itself (the median red/green and blue/green
// ratios over flat, unclipped 2 x 2 cells). On a grey scene, as a printed marker is, the
// balanced mosaic has no chrominance at all and the filter is only a slight symmetric blur;
// without the balance the channels' different sensitivities would put a checkerboard of the
// edge's own contrast onto the carriers, part of which the filter leaves near a sharp edge.
#pragma once

#include <array>
#include <opencv2/core.hpp>

#include "svms/base/status.h"

namespace svms {

enum class BayerPattern;
struct PhotometricModel;

// Gains that scale each colour of the mosaic to green's sensitivity: {red, green, blue}, the
// green one 1. Estimated from `mosaic` (CV_16UC1, linear, 0 = black, `saturation` = white) as
// 1 / median(R / G) and 1 / median(B / G) over the 2 x 2 cells (at most about 16,000, evenly
// strided) whose green pixels are above 5 % of `saturation` and agree within 5 %, and whose
// pixels are all below 98 %; {1, 1, 1} where fewer than 64 cells qualify (a dark or saturated
// frame: nothing to balance by) or for BayerPattern::kNone.
std::array<double, 3> EstimateBayerGains(const cv::Mat& mosaic, BayerPattern pattern,
                                         double saturation = 65535);

// The luminance (R + 2 G + B) / 4 of the white-balanced channels at every pixel of `mosaic`
// (CV_16UC1, linear in light), as CV_16UC1 of the same size (rounded, clipped to 0..65535):
// the mosaic scaled by `gains` per colour, filtered by the frequency-selection kernel (its sum
// 1, its response 0 at the chrominance carriers), borders reflected without repeating the edge
// pixel (which keeps each pixel's colour). `out` may not be `mosaic`.
void BayerLuminance(const cv::Mat& mosaic, BayerPattern pattern, const std::array<double, 3>& gains,
                    cv::Mat* out);

// The 5 x 5 frequency-selection kernel, sum 1.
cv::Matx<float, 5, 5> BayerLuminanceKernel();

// The widest window (half-width across an edge, pixels) the corner fit should use along the
// pixel rows on images read through `model` (CornerRefineOptions::max_row_window_px): 3.5 for
// a mosaic turned into luminance here, whose filter blurs every edge about as much as a
// Gaussian of 0.7 px, so that the window's levels are read on the edge's plateaus; 2
// otherwise. Why not on every image, and the figures: docs/detector.md (Bayer mosaics, and the
// known limitations).
double CornerRowWindowPx(const PhotometricModel& model);

}  // namespace svms
