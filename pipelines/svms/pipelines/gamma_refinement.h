// The camera's response curve refined by a calibration's edge bias (calib/calibrate.h): the
// decision `svms calibrate --response estimate` makes once it has measured how far the marker
// sides move per unit of gamma on its own images.
#pragma once

#include <string>

namespace svms {

struct GammaRefinement {
  double gamma = 0, sigma = 0;  // the refined curve and its standard deviation; 0: not refined
  std::string note;             // why not refined ("" when refined)
};

// `gamma` +- `gamma_sigma`: the edges' own estimate (response_estimate.h); `bias_px` +-
// `bias_sigma_px`: the edge bias the calibration fitted with that curve; `px_per_gamma`: how
// far the sides move out of their squares per unit of gamma, measured on the same images. The
// curve that leaves no bias is gamma - bias / px_per_gamma, with sigma bias_sigma / |px_per_gamma|.
// Refused (note set) when the sides do not move with the curve (|px_per_gamma| <= 1e-4), when
// the bias was not fitted (bias_sigma_px <= 0), or when the refined curve lies more than 3 of
// the edges' sigmas from their estimate: then the bias is not (only) the curve's error, e.g. a
// print's dot gain, which moves the sides too. The sigma assumes the bias is the curve's alone:
// a dot gain within the 3 sigmas is taken for the curve's error and moves the refined curve by
// up to 3 of the edges' sigmas, which the refined sigma does not include.
GammaRefinement RefineGammaByEdgeBias(double gamma, double gamma_sigma, double bias_px,
                                      double bias_sigma_px, double px_per_gamma);

}  // namespace svms
