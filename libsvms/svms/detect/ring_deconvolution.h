// Reading a small marker's bit ring through a blur by deconvolution (detector step 7d).
//
// On a marker of 8-12 px a bit cell is 1.3-2 px wide, and the pixels' own area and any lens
// blur mix each cell with its neighbours, with the stripe inside it and with what lies beyond
// the quiet zone outside it. SampleBits' threshold at a cell's centre cannot undo that, and its
// reading depends on the corners to a tenth of a pixel: the corners step 8 fits on such a marker
// behind 0.7 px of blur and JPEG are 0.1-0.3 px off, because the stripe is too narrow for an
// unbiased edge profile and the cells beside it tilt the sides.
//
// This reader models the image instead of thresholding it. The marker is a set of regions of
// unknown brightness (albedo): the black square (less a centre patch where the post and its tip
// project, and where a dual marker's inner marker lies), the white stripe, the 44 bit cells, the
// quiet zone beyond the ring (read on its own: the simulator's and a print's quiet zone need not
// match the stripe), everything beyond it, and the centre patch. Each pixel sees those regions
// through its own area convolved with an isotropic Gaussian blur of sigma s (pixels): its value
// is sum_r w_pr a_r, w_pr the share of region r in pixel p's footprint, found by sampling the
// marker plane through the homography of the given corners on a 0.25 px grid. The albedos a
// follow by linear least squares over the pixels out to 1.3 half-extents of the ring; the
// cells' albedos against the midpoint of the square's and the stripe's are the bits. The blur
// is not a constant: the candidates of `blur_sigmas_px` are fitted from the middle one downhill
// to a local minimum of the squared residual (it falls toward the image's blur and rises past
// it; on 200 random renders of 8-13 px markers at 0-1.3 px of blur, a scratch check, the same
// choice as the least of all five), so the sigma comes from the marker's own pixels.
//
// The least squares spread each cell's light back over its neighbours, which undoes the
// interference ring_equalizer.h models along the ring; and since every pixel near the ring
// enters the fit, not one sample per cell, corners a few tenths of a pixel off shift the
// regions' footprints a little instead of moving a cell's sample off its cell. Measured with a
// scratch probe (not a command of the repository) on the small set's 8-12 px markers behind
// 0.7 px of blur and JPEG (`svms dataset small --profile jpeg_srgb`, seed 1, views 13, 15, 17,
// 19 and 20: 108 markers, 94 with a quad): from step 8's corners, 90 of the 94 read within two
// flips of their codeword (SampleBits, or its equalised reading, whichever is nearer: 68); at
// the true corners all 108.
//
// Like the equalised reading, this is a second reading of the quad, not a test that it is a
// marker; the detector takes it only on small quads whose stripe and square stand apart and
// whose earlier readings were weak (detector.h, step 7d).
#pragma once

#include <Eigen/Core>
#include <array>
#include <chrono>
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

namespace svms {

struct RingDeconvolutionOptions {
  // The blurs that may be tried (Gaussian sigma, pixels, on top of the pixel's own area; those
  // outside (0, 4] are ignored); the fit's residual picks one.
  std::vector<double> blur_sigmas_px = {0.25, 0.45, 0.65, 0.9, 1.2};
  // Markers whose ring (twice the square's side) has a side longer than this (pixels), or whose
  // fitted window is more than twice this across, are not read: the cost grows with the area
  // (about 3 ms per call at the limit, a 14 px square), and the markers this reading recovers
  // in `svms bench profiles` are 8-12 px.
  double max_extent_px = 28;
};

struct RingDeconvolution {
  uint64_t word = 0;  // bit i = 1 where cell i reads white, BitReading::word's order
  // Albedos (grey levels of the image read) of the square and the stripe, and of each cell.
  double black = 0, white = 0;
  std::array<double, 44> cell{};
  double blur_sigma_px = 0;  // the blur kept
  double residual_rms = 0;   // grey levels, per degree of freedom
  int pixels = 0;            // pixels in the fit (0 where the window was refused)
  // The fit had pixels enough, the square, the stripe and every cell had pixels, and the stripe
  // reads brighter than the square by more than three times the fit's residual: word is
  // meaningful.
  bool ok = false;
  // The deadline passed before the fit was done (ok is then false).
  bool out_of_time = false;
};

// The ring of the marker whose unit plane (black square of side 1 centred on the origin, y up;
// pixel_from_unit as SampleBits' pixel_from_plane for MarkerModel::Standard(id, 1.0, 0)) maps
// to pixels of `image` (CV_8UC1 or CV_16UC1; (0, 0) the centre of the top-left pixel), read
// as above. Standard proportions (marker_model.h): a cell a sixth of the square, the stripe two
// cells, a quiet zone of one cell. ok is false where the window (the bounding box of its
// corners) reaches past the image's border, the marker is too large (max_extent_px), or the fit
// fails. On this project's 2-core machine a call took about 1 ms on an 8 px square, 2 ms at
// 12 px and 3 ms at 14 px (thread CPU time, the machine busy; three or four blurs fitted).
// `deadline` is read before each blur's fit: past it, the reading stops there (out_of_time), so
// that it overruns a frame's budget by one fit at most.
RingDeconvolution ReadRingDeconvolved(
    const cv::Mat& image, const Eigen::Matrix3d& pixel_from_unit,
    const RingDeconvolutionOptions& options = {},
    std::chrono::steady_clock::time_point deadline = std::chrono::steady_clock::time_point::max());

}  // namespace svms
