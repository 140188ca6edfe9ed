// What a lens's blur costs an edge's measured place, at best: the Fisher information of a
// straight edge's offset across it, per unit length, for box pixels behind a Gaussian blur.
//
// A straight step edge of unit contrast at offset d along its normal n gives pixel i the mean
// mu_i(d) = integral over the pixel of Phi((n.x - d) / s), s the blur's sigma (pixels). With
// white noise of unit sigma the information on d is sum_i (d mu_i / d d)^2; the pixel centres
// fill the plane one per unit area, so per unit length of edge it is the integral of k(u)^2 du,
// where k = p * phi_s and p is the density of n.x over one pixel (the convolution of two boxes
// of widths |cos theta| and |sin theta|: a trapezoid). Its inverse square root is the
// Cramer-Rao bound on the offset's sigma of any unbiased estimator from those pixels; so the
// ratio of two blurs' bounds is what one blur costs against the other at the same noise for
// estimators equally efficient behind both (a bound on RMS errors, not on a given detector's
// medians). The noise is taken white and the same on every pixel: with shot noise, larger on
// the white side, the factor at 0.7 px is about 5 % larger. `svms bench profiles` states it
// beside the measured ratios of its sensor profiles (docs/benchmarks.md).
#pragma once

namespace svms {

// The information per unit length of a unit-contrast edge at unit noise, pixels^-1 (1 for an
// unblurred edge along the pixel columns). `blur_sigma_px` >= 0; theta in radians.
double EdgeOffsetInformation(double blur_sigma_px, double theta_rad);

// How much larger the Cramer-Rao bound on an edge's offset is behind a blur of
// `blur_sigma_px` than behind one of `reference_sigma_px` (0: none), at the same noise:
// sqrt(I(reference) / I(blur)), averaged over edge directions 0-45 degrees to the pixel axes.
double EdgeBlurBoundFactor(double blur_sigma_px, double reference_sigma_px = 0);

}  // namespace svms
