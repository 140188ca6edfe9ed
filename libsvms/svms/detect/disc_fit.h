// Sub-pixel position of a small bright disc (the post's white top on the black square) from
// the pixel values around it, by fitting the disc's exact coverage of each pixel.
//
// Why not a centroid: once the disc is about a pixel across or less, the centroid of the
// pixel values is pulled toward the centre of the pixel the disc falls in ("pixel locking").
// On the simulator's 8 px markers (top radius 0.4 px) the 3 x 3 centroid is off by 0.44 x
// the disc's offset from the nearest pixel centre, 0.17 px RMS per axis: at 14 m, where the
// post is 2 px long, enough to choose the wrong one of the two planar poses. The pixel
// coverage below is exact, so the fit has no such bias on an ideal sensor; a symmetric blur
// (defocus) is not modelled and leaves the centre unbiased to first order.
#pragma once

#include <Eigen/Core>
#include <optional>

namespace svms {

// Area of the disc of radius r centred at the origin inside the rectangle [x0, x1] x [y0, y1]
// (any units; exact, closed form). 0 if r <= 0 or the rectangle is empty.
double DiscRectangleArea(double r, double x0, double x1, double y0, double y1);

struct DiscFit {
  Eigen::Vector2d centre;  // pixels, pixel centres at integer coordinates
  double amplitude = 0;    // grey levels of a pixel fully covered, above the background
  double background = 0;   // grey levels
  double rms = 0;          // residual RMS over the window, grey levels
  // Standard deviation of the centre, each axis (the larger of the two), pixels: the spread
  // of the place's likelihood, with the pixel noise taken from the residuals.
  double sigma_px = 0;
};

// Fits value(x, y) = background + amplitude * area(disc(centre, radius) n pixel(x, y)) to
// the `size` x `size` window `values` (row-major, grey levels; its top-left
// pixel is (origin_x, origin_y); at most 16 x 16). Pixel (x, y) covers
// [x - 1/2, x + 1/2] x [y - 1/2, y + 1/2]. Each coordinate is the mean of its likelihood
// (from the column or row sums, with amplitude and background solved at each place),
// so a disc wholly inside one pixel comes out at the middle of where it may be, with that
// spread as its sigma. The centre is looked for within `search_px` of the window's middle,
// each axis (0: anywhere in the window); for a disc of a pixel or more in radius, whose place
// the values pin down to hundredths of a pixel, a search of a pixel about a first guess costs
// a fraction of a whole window's; nullopt if the best place is at the edge of that search.
// nullopt if no disc of positive amplitude fits, for a window of fewer than 3 or more than 16
// pixels across, a radius that is not positive, or a search_px that is negative or NaN.
std::optional<DiscFit> FitDisc(const double* values, int size, int origin_x, int origin_y,
                               double radius, double search_px = 0);

}  // namespace svms
