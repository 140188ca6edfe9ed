// What the mean NEES of a sequence of fused poses may be when their errors share one draw.
//
// A pose's covariance holds the frame's own noise and, when the camera carries its calibration's
// uncertainty (or a rig its extrinsics'), an error that is the same in every frame: one draw z
// of it, taken when the camera was calibrated, sits in every frame's error as B_f z
// (ObjectPose::bias_factor). The NEES of each frame is still chi-square(6) on average, but the
// mean over N frames is not the mean of N independent draws: the one z moves all of them
// together, so its spread does not shrink as N grows, and the chi-square(6 N) / N band (e.g.
// [5.70, 6.31] for 500 frames) is far too narrow to judge one calibration's sequence by.
//
// SequenceNeesBand draws what the mean NEES of the given frames would be if every covariance
// were honest: z ~ N(0, I) once per trial and each frame's noise n_f ~ N(0, Sigma_f - B_f
// B_f^T) independently, e_f = B_f z + n_f, NEES_f = e_f^T Sigma_f^-1 e_f, and gives the central
// interval of the trials' means. It uses nothing but the frames' own covariances and bias
// factors, so a benchmark's band follows from its own run: a sequence whose mean NEES falls
// outside it has covariances that are wrong in scale, whatever the calibration's draw was.
// The noise of different frames is taken as independent (true of the sensor's noise; the
// layout's error, which is also common to every frame, is not in bias_factor and is taken as
// noise here).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "svms/geometry/pose.h"

namespace svms {

struct SequenceNeesOptions {
  double probability = 0.95;  // of the central interval
  int trials = 4000;          // Monte-Carlo draws of the whole sequence
  uint64_t seed = 1;
};

struct SequenceNeesBand {
  int frames = 0;
  int common_columns = 0;  // of the bias factors (0: every frame's error its own)
  // The central `probability` interval of the sequence's mean NEES with the common draw, by
  // Monte-Carlo (trials), and the trials' mean (6 up to the Monte-Carlo's error).
  double lo = 0, hi = 0, mean = 0;
  // The same interval if every frame's error were independent: chi-square(6 N) / N
  // (ChiSquareQuantile).
  double independent_lo = 0, independent_hi = 0;
  // The common error's share of the NEES' expectation, mean over frames of
  // trace(Sigma_f^-1 B_f B_f^T) / 6, in [0, 1].
  double common_share = 0;
};

// The band for frames with covariances `covariance[f]` ([rotation, translation], any fixed
// axes) and bias factors `bias_factor[f]` (6 x k, the same k and column meaning for every frame:
// ObjectPose::bias_factor; k = 0 allowed). False with *error when the inputs do not fit (sizes,
// a covariance that is not positive definite, a bias factor whose share exceeds its
// covariance by more than round-off: the frame is named).
bool ComputeSequenceNeesBand(
    const std::vector<PoseCovariance>& covariance,
    const std::vector<Eigen::Matrix<double, 6, Eigen::Dynamic>>& bias_factor,
    const SequenceNeesOptions& options, SequenceNeesBand* band, std::string* error);

// The common draw z as a sequence's errors against the truth show it, and what is left of each
// frame's error once it is taken out. With e_f = B_f z + n_f, n_f ~ N(0, N_f), N_f = Sigma_f -
// B_f B_f^T, the generalised least-squares estimate is z_hat = A^+ sum_f B_f^T N_f^-1 e_f, A =
// sum_f B_f^T N_f^-1 B_f. Only the part of z in A's range is seen (a pose does not tell every
// intrinsic apart), and if the covariances are honest that part of z_hat is N(0, P + A^+)
// (P the projector onto the range): `chi2` on `rank` degrees of freedom tests the common
// error's covariance (the calibration's) against its draw, and `own_nees_mean`, the mean of
// (e_f - B_f z_hat)^T N_f^-1 (e_f - B_f z_hat), tests the frames' own share (6 - rank / N on
// average when honest). So one run tells which of the two is off.
struct CommonDrawEstimate {
  Eigen::VectorXd z;  // z_hat (k)
  int rank = 0;       // of A: the components of z the sequence sees
  double chi2 = 0;    // z_hat^T (P + A^+)^+ z_hat, chi-square(rank) when honest
  double own_nees_mean = 0;
};

// False with *error when the inputs do not fit (as ComputeSequenceNeesBand, and one 6-vector
// error per frame: PoseError(truth, estimate)).
bool EstimateCommonDraw(const std::vector<Eigen::Matrix<double, 6, 1>>& errors,
                        const std::vector<PoseCovariance>& covariance,
                        const std::vector<Eigen::Matrix<double, 6, Eigen::Dynamic>>& bias_factor,
                        CommonDrawEstimate* estimate, std::string* error);

}  // namespace svms
