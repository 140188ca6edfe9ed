// The noise of a linear-light image, estimated from the image itself.
//
// A camera's pixel noise is read noise plus shot noise: variance(L) = read^2 + gain L at level
// L (both in the image's units). The detector needs it to find edges on a scale where the
// noise is the same everywhere (segments.h) and to judge what it measures; it must not assume
// the simulator's sensor. Estimated here from the spread of the 4-neighbour Laplacian in
// bins of brightness (texture and edges inflate it; a low quantile of |Laplacian| keeps that
// small where most of a bin is flat), fitted by weighted least squares over the bins. Two
// things real frames do are handled:
//  - clipping: a black background clipped at 0 (or glints clipped at saturation) has less
//    spread than its noise; samples touching a clipped value are left out, and a bin is used
//    only when its level is at least 3 of its own sigmas above 0;
//  - encoding: estimated on linear values, so a tone curve that stretched the darks has been
//    undone first (photometric.h). The rounding to the stored codes is taken out code by code:
//    an 8-bit image's 1/12 level^2; a 16-bit image that takes only some values (an sRGB or
//    gamma-encoded 8-bit image in linear light, 20 units apart in the darks and 400 in the
//    brights; 12-bit raw data, 16 apart) is measured on the ranks of its values, where the
//    rounding is 1/12 of a code^2 everywhere, and brought back by the codes' step.
//    Bins where the noise is under about a code's step are left out (the codes hide it);
//    where they hold most samples (a JPEG, whose codec smooths the flat areas' noise away) no
//    noise is reported: read and gain 0 (the detector then searches the edges on the square-root
//    scale at its thresholds' floor, detector.cc).
// Where only one level is seen (a flat scene), the variance cannot be split into read and shot
// noise: it is all counted as read noise, which never amplifies the dark parts of the image.
#pragma once

#include <chrono>
#include <opencv2/core.hpp>

#include "svms/camera/photometric.h"

namespace svms {

struct NoiseModel {
  double read_sigma = 0;  // image units (grey levels of the image given), RMS
  double shot_gain = 0;   // variance per unit of level: variance(L) = read_sigma^2 + shot_gain L
  int bins = 0;  // brightness bins the fit rests on, or where the codes hid the noise (both
                 // 0 then); 0: nothing usable
  bool valid() const { return bins > 0; }
  double Sigma(double level) const;  // the noise at `level`, image units
  // The same model for the image scaled by `k` (values k L): read k sigma, gain k shot_gain.
  NoiseModel Scaled(double k) const;
};

// `linear`: CV_8UC1 or CV_16UC1, linear in light (photometric.h), 0 the black level and the
// depth's largest value saturation. Samples every 4th pixel of every 4th row (about 65,000
// samples at 1024 x 1024).
NoiseModel EstimateNoise(const cv::Mat& linear);
// The same under a deadline, read every 64 rows: false, with *noise invalid, once it has passed.
bool EstimateNoise(const cv::Mat& linear, std::chrono::steady_clock::time_point deadline,
                   NoiseModel* noise);

// The noise of a frame as the sensor stored it, measured on its own values, levels counted from
// the black level and values below it included, in the units of the linear image LinearizeImage
// makes of it (`model`'s): a dark background's values below the black level show the read noise
// that the linear image, clipped at black, hides. Applies to one-channel 8- or 16-bit frames of
// a linear response with a black level above 0, a white level within the depth and no Bayer
// mosaic (raw frames) that hold at least 16 sampled values below black and at least half as
// many as at black (a frame clipped at black holds no more than its linear image). A camera that
// clips its raw values a little below black is not told from one that does not. False where it
// does not apply (then estimate on the linear image) or once `deadline` (read every 64 rows)
// passed.
bool EstimateStoredNoise(const cv::Mat& stored, const PhotometricModel& model,
                         std::chrono::steady_clock::time_point deadline, NoiseModel* linear_noise);

// The 16-bit linear image on a scale where `noise` is the same at every brightness (the
// generalised Anscombe transform T(L) = 2 / g (sqrt(g L + r^2) - r) for read noise r and shot
// gain g; L / r for read noise alone), scaled to fill 8 bits: what the edge search runs on.
// Returns the noise's sigma on that 8-bit scale (its thresholds are in those units): the
// scale factor itself, since T has unit noise.
// `deadline` is read every 64 rows (not while the 65,536-entry table is rebuilt for a new model):
// once it has passed the result is 0 and *out8 incomplete.
double StabiliseVariance(
    const cv::Mat& linear16, const NoiseModel& noise, cv::Mat* out8,
    std::chrono::steady_clock::time_point deadline = std::chrono::steady_clock::time_point::max());

}  // namespace svms
