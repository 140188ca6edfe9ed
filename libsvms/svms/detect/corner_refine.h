// Detector step 8: sub-pixel corners. Along each side of a quad, the edge is located across
// the side (near the peak of the intensity derivative along the normal, then from the area
// under the normalised profile around it),
// a line is fitted to those edge points (robustly: points off the line are dropped) -- in the
// undistorted image plane when a lens model is given, so that the curved image of a straight side
// is handled exactly -- and the corners are the intersections of consecutive lines, projected back
// to pixels.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cmath>
#include <opencv2/core.hpp>
#include <optional>
#include <vector>

#include "svms/camera/camera.h"

namespace svms {

struct CornerRefineOptions {
  int iterations = 2;
  double search_px = 2.5;  // half-width of the search across each side, pixels
  // Fraction of each side left out next to the corners; where the edge points are taken along
  // the pixel rows, more on a short slanted side, so that no row window reaches past a corner.
  double end_margin = 0.12;
  // Take each edge point's area again along the pixel row through it (LocateEdge's along_rows;
  // quads of narrow_stripe_side_px or more). Exact whatever the edge's angle and pixel phase,
  // where the bilinear profile across the pixels is not: corners of 60 px markers without
  // sensor noise 0.0109 -> 0.0027 px RMS; with noise on renders with 256 rays on edge pixels
  // (compare size sweep, seed 2, 72-140 views) 60 px 0.0108 -> 0.0061, 30 px 0.0171 ->
  // 0.0088, 16 px 0.0213 -> 0.0144; on 16-ray renders 30 px 0.0326 -> 0.0300. On the datasets
  // (256 rays on edge pixels) `svms bench detect`'s range set at 16 m gives 0.245 degrees RMS
  // orientation with it against 0.301 without, and the other distances agree within their
  // 4-view noise.
  bool edges_along_rows = true;
  // The widest window (half-width across the edge, pixels) of the area along the rows where an
  // edge is blurred (corner_refine.cc: RowWindow; 2 px on sharp edges), and never wider than the
  // white stripe (a third of the quad's shortest side) less 2 px, so that the stripe's far
  // edge, blurred, stays out of it. 2: never widened, the default; the commands widen it to
  // 3.5 on Bayer mosaics read through the luminance filter (CornerRowWindowPx,
  // camera/bayer_luminance.h, says why not everywhere).
  double max_row_window_px = 2.0;
  // The same on quads narrower than narrow_stripe_side_px, whose edges are placed along the
  // normal (LocateEdge's narrow_band). Measured on the compare size sweep (seed 2, 256 rays on
  // edge pixels, 128-142 views per size; corner per-axis Z^2 against its sigma, and RMS): at
  // 0.12 the corners of 8 / 10 / 12 px markers had Z^2 1.57 / 1.44 / 1.18 (RMS 0.0323 / 0.0273
  // / 0.0241 px), at 0.15 1.11 / 1.02 / 0.94 (0.0339 / 0.0278 / 0.0229): the points next to
  // the corners err together, more than their scatter says. Wider quads, placed along the
  // pixel rows, are best at 0.12 (60 px: RMS 0.0061 at 0.12, 0.0069 at 0.15).
  double narrow_end_margin = 0.15;
  int max_points = 64;  // edge points per side
  // Each side's line is refitted without the edge points farther from it than
  // max(trim_sigmas x robust sigma, trim_floor_px), trim_passes times (0: plain fit).
  int trim_passes = 2;
  double trim_sigmas = 3.0;
  double trim_floor_px = 0.05;
  // A trim that would leave fewer than this many points, or fewer than half of the side's, is
  // not made: on a short side (a small marker at a grazing angle) a line through the few
  // points left extrapolates to corners pixels off.
  int trim_min_points = 6;
  // Each side's edge-point sigma is its own scatter shrunk toward the four sides' pooled
  // scatter, which counts as this many degrees of freedom: (ss_k + nu0 s_pooled^2) /
  // (dof_k + nu0). On a small marker a side has a handful of points (5 at 8 px, 3 degrees of
  // freedom), whose scatter alone is so uncertain that the corners' normalised errors have
  // heavy tails (t with 3 dof: RMS 1.7); all sides see the same noise and contrast. On sides
  // of 60 points it changes little.
  double pooled_prior_dof = 8;
  // A corner's variance is then a weighted sum of the four sides' own estimates, and rests on
  // nu degrees of freedom (Satterthwaite's rule for that sum): its error over the sigma it
  // gives is Student-t, whose mean square is nu / (nu - 2), not 1 (1.33 for two sides of 6
  // points each on their own). true: each corner's variance is multiplied by that factor, so
  // that its normalised squared error has mean 1, not only in the limit of many points.
  bool small_sample_variance = true;
  // Estimate from the sides' residuals how much of the edge points' error the points within
  // one 8 x 8 pixel block share (RefinedCorners::block_correlation) and widen the sides'
  // lines by it: a JPEG codes each block on its own (the model and what it cannot see:
  // codec_blocks.h). false: the points' errors are taken as shared only through their lag-1
  // correlation.
  bool codec_blocks = true;
  // A quad whose shortest side is below this (pixels) has a white stripe (a third of the side)
  // too narrow for the edge profile's +-2 px window plus the pixels' blur: its edges are placed
  // as LocateEdge's narrow_band says.
  double narrow_stripe_side_px = 13.5;
  // On such quads behind a blur, the stripe's brightest point falls short of its white and the
  // sides are placed inward (RefinedCorners::band_bias_px): carried in the corners' sigmas.
  bool blurred_band_sigma = true;
  // A shadow's penumbra on the white stripe along a side rises more steeply than the black
  // square's own edge into the shadowed stripe (a few grey levels), and the edge locator takes
  // it: the side came out 2.9 px outside the truth with a sigma of 0.14 px (compare view
  // edge_40deg_09). Its edge points then have their dark side well above the square's black:
  // where more than half of 8 evenly spread points of a side (sides of penumbra_min_side_px or
  // more, in the last iteration, and only when RefineCorners is given the square's black
  // level) are darker than
  // penumbra_dark_fraction of the way from black to their bright side, each point is moved
  // inward to where the profile falls half-way from the penumbra's foot to black. Measured on
  // every simulated set (sides of 12 px or more within 0.3 px of the truth): that fraction's
  // median 0.000, 99th percentile 0.020, largest 0.042; the penumbra side 0.16.
  // A smooth penumbra whose steepest rise lies beyond the search from a side already on the
  // square's edge gives no located edge: where most of a side's points see the rise run on past
  // the search's outward end and those ends pass the same check, the side is found under the
  // penumbra from there, in any iteration.
  double penumbra_dark_fraction = 0.08;
  double penumbra_min_side_px = 12;
};

// Part of the image whose edges are not the marker's sides: the post's silhouette, which
// crosses a side at grazing views. The points within `radius` of the segment a-b (pixels).
struct ExcludedRegion {
  Eigen::Vector2d a, b;
  double radius = 0;
  bool Contains(const Eigen::Vector2d& p) const;
};

struct RefinedCorners {
  std::array<Eigen::Vector2d, 4> corners;  // same order as the input
  std::array<double, 4> side_rms{};  // each side's edge-point sigma about its line, px (n - 2 dof)
  std::array<int, 4> side_points{};  // edge points used per side
  // Standard deviation of each corner (pixels, each axis) propagated from its two side lines'
  // fits: each line's offset and slope from its edge points' scatter (side_rms shrunk toward
  // the four sides' pooled scatter, see pooled_prior_dof; side_points; times the larger of
  // (1 + rho) / (1 - rho), for the points' correlation rho along the side, `correlation`, and
  // what errors shared within 8 x 8 blocks add, `block_correlation`), evaluated at the corner, then
  // the intersection at the lines' angle; times nu / (nu - 2) in variance for the degrees of
  // freedom it rests on, small_sample_variance).
  std::array<double, 4> corner_sigma{};
  // The four corners' joint covariance (pixels^2; rows and columns x0, y0, x1, y1, ..., in the
  // order of `corners`) from the same line fits. Two corners on one side share that side's
  // line: its offset moves both across the side together, its slope moves them in opposite
  // directions, and with the edge points spread over the middle fraction f of the side the
  // slope wins, so their components across the side correlate by (1 - 3 / f^2) / (1 + 3 / f^2)
  // (-0.65 at f = 0.8) for independent points spread evenly; from the points' own places and
  // the errors they share within blocks (block_correlation) where those are known. Each corner's 2
  // x 2 block has corner_sigma^2 as its mean diagonal. Zero where the corners were not refined.
  Eigen::Matrix<double, 8, 8> corner_covariance = Eigen::Matrix<double, 8, 8>::Zero();
  // The lag-1 correlation of the edge points' residuals along the sides (pooled over the four;
  // 0 where it does not stand out of its noise), by which corner_sigma was widened: see
  // RefineCorners.
  double correlation = 0;
  // The share of the edge points' variance that the points within one 8 x 8 pixel block (a
  // JPEG's coding unit, laid from the image's origin) have in common, estimated from the
  // sides' residuals by moments (0 where it does not stand 2 sigmas out of its noise). It
  // widens each side's line and sets the correlation of its two ends in corner_covariance.
  double block_correlation = 0;
  int excluded_points = 0;  // edge points left out because they fell in an ExcludedRegion
  // On a quad under narrow_stripe_side_px: an upper bound on how far inward its sides are
  // placed because the stripe's blurred peak falls short of its white (pixels, from the stripe
  // profiles' own steepness; near 0 for a sharp image), added to each corner_sigma in
  // quadrature; not to be subtracted from the corners.
  double band_bias_px = 0;
  // Sides whose edge was taken from under a shadow's penumbra (see penumbra_dark_fraction).
  std::array<bool, 4> penumbra_sides{};
  bool ok = false;
};

// `corners` go clockwise on screen around a dark quad on a brighter surround. `image` is
// CV_8UC1 or CV_16UC1. `camera` may be null (lines fitted in pixels). No edge point is taken
// inside `excluded` (may be empty). `black`: the square's grey level (BitReading::black), for
// the penumbra check; NaN leaves it out.
RefinedCorners RefineCorners(const cv::Mat& image, const std::array<Eigen::Vector2d, 4>& corners,
                             const CameraModel* camera, const CornerRefineOptions& options,
                             const std::vector<ExcludedRegion>& excluded = {}, double black = NAN);

// Bilinear sample at pixel-centre coordinates (clamped to the image).
double SampleImage(const cv::Mat& image, double u, double v);

// Step 8's edge locator on its own: the straight edge crossing `p` (pixels) across which the
// intensity rises along `dark_to_bright` (unit vector, pixels), searched within +-search_px
// (0.5 px steps) around p, then placed from the area under the normalised profile across it
// (+-2 px). `along_rows` (RefineCorners' choice): that area is taken again along the pixel row
// or column through the point found (the axis nearer dark_to_bright), from the pixels' own
// values, exact for a straight edge whatever its angle and pixel phase (the bilinear profile
// across pixels at an angle is not). Without it (the white stripe's outer edge, marker_pose.h,
// bordered by bit cells a sixth of the side long: along a row at an angle the window runs up
// to 2 px along the edge toward the next cell; with rows there the orientation median / p95
// on 30 px markers rendered with 256 rays on edges is 0.15 / 0.32 degrees, without 0.12 /
// 0.28) the profile stays along the normal. *edge: the edge point (pixels);
// *strength: the derivative's peak (grey levels per pixel). False where no rising edge stands
// out (at the search's ends, or too little contrast across it).
// `narrow_band`: the bright side may be a band narrower than about 4.5 px with something darker
// beyond it; where the profile falls again by more than 2 % of its contrast within 2 px, the
// area is taken up to its brightest point only. `max_row_window` (along_rows only): the
// half-width across the edge up to which the window along the row widens where the edge is
// blurred (2: never).
bool LocateEdge(const cv::Mat& image, const Eigen::Vector2d& p,
                const Eigen::Vector2d& dark_to_bright, double search_px, Eigen::Vector2d* edge,
                double* strength, bool narrow_band = false, bool along_rows = false,
                double max_row_window = 2.0);

}  // namespace svms
