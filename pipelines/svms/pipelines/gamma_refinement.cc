#include "svms/pipelines/gamma_refinement.h"

#include <cmath>

#include "svms/base/format.h"

namespace svms {

GammaRefinement RefineGammaByEdgeBias(double gamma, double gamma_sigma, double bias_px,
                                      double bias_sigma_px, double px_per_gamma) {
  GammaRefinement r;
  if (!(bias_sigma_px > 0) || !std::isfinite(bias_px)) {
    r.note = "no edge bias was fitted; the edges' estimate is kept";
    return r;
  }
  if (!(std::abs(px_per_gamma) > 1e-4)) {
    r.note = "the sides do not move with the curve (" + Scientific(px_per_gamma, 2) +
             " px per unit of gamma); the edges' estimate is kept";
    return r;
  }
  const double refined = gamma - bias_px / px_per_gamma;
  if (!(std::abs(refined - gamma) <= 3 * gamma_sigma)) {
    r.note = "the edge bias (" + Fixed(bias_px, 4) + " px) asks for gamma " + Fixed(refined, 3) +
             ", more than 3 sigmas from the edges' estimate " + Fixed(gamma, 3) + " +- " +
             Fixed(gamma_sigma, 3) +
             ": it is not (only) the curve's error (the print's dot gain?); the edges' estimate "
             "is kept";
    return r;
  }
  r.gamma = refined;
  r.sigma = bias_sigma_px / std::abs(px_per_gamma);
  return r;
}

}  // namespace svms
