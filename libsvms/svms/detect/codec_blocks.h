// Detector step 8's model of the error a side's edge points share within 8 x 8 pixel blocks.
//
// A JPEG codes each 8 x 8 block of luma on its own (the grid laid from the image's origin, as
// an uncropped JPEG's is; pixel centres at whole numbers, so block g spans [8g - 0.5,
// 8g + 7.5)), so the codec's error of a block moves the edge points in it together, and a
// side's line fitted to them is less certain than their scatter about it says. The model: a
// side's points err with covariance a I + c J, J joining two points of one block (1 on its
// diagonal too), so c / (a + c) is the share of a point's variance its block has in common.
// The residuals r = (I - H) e of an ordinary line fit (H its hat matrix, 1/n + s_i s_j / S
// from the points' places s along the side, centred) say how large a and c are:
//   E[r'r]  = a tr(I - H)     + c tr(J (I - H)),
//   E[r'Jr] = a tr(J (I - H)) + c tr(J (I - H) J (I - H)),
// two equations linear in (a, c), summed over a marker's four sides and solved there
// (BlockVariances). The traces need only each block's count n_g and sum of places t_g
// (SideBlockSums). Method of moments, not a constant: on frames without blocks c comes out
// about 0, and is taken as 0 unless it stands 2 sigmas out of its noise. RefineCorners fits
// weighted total least squares lines; these sums take them as ordinary ones.
//
// What the model cannot see: an error that neighbouring blocks share (the codec errs alike
// where alike pieces of one straight edge fall in them), or one common to a whole side. No
// residual about the line shows those.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

namespace svms {

constexpr double kCodecBlockPx = 8;

// One side's sums for the model (SideBlockSums).
struct SideBlocks {
  double q1 = 0, q2 = 0;                  // r'r and r'Jr of the side's inliers, px^2
  double a1 = 0, c1 = 0, a2 = 0, c2 = 0;  // E[q1] = a1 a + c1 c, E[q2] = a2 a + c2 c
  // For the side's line at its ends: inliers n, S = sum s^2, N2 = sum n_g^2, T2 = sum t_g^2,
  // NT = sum n_g t_g, and the ends' places s0, s1 (px along the side from the inliers' mean).
  double n = 0, S = 0, N2 = 0, T2 = 0, NT = 0, s0 = 0, s1 = 0;
};

// One block's running sums: its key, points, sum of their places and of their residuals.
struct CodecBlock {
  int64_t key;
  double n, t, r;
};

// `px`: a side's edge points in pixels, `r` their signed residuals about its fitted line
// (px), `use` the fit's inliers (all three of one length); the side runs from pixel a to b.
// Non-finite points are left out. *scratch: reused between calls (no allocation once grown).
// All zero where fewer than 3 inliers or no spread along the side.
SideBlocks SideBlockSums(const std::vector<Eigen::Vector2d>& px, const std::vector<double>& r,
                         const std::vector<char>& use, const Eigen::Vector2d& a,
                         const Eigen::Vector2d& b, std::vector<CodecBlock>* scratch);

// (a, c), px^2, from the sides' sums pooled: c = 0 and a = sum q1 / sum a1 unless r'Jr stands
// 2 sigmas above what c = 0 predicts (its variance under c = 0 and Gaussian errors, a
// estimated from r'r: 2 a^2 (sum c2 - (sum c1)^2 / sum a1)) and the solution has a > 0 and
// c > 0.
Eigen::Vector2d BlockVariances(const std::array<SideBlocks, 4>& sides);

// A side's fitted line, its place across itself at its two ends for per-point covariance
// a I + c J: variances v0, v1 and their covariance (px^2), and what its scatter about the line
// estimates a point's variance to be, E[r'r] / (n - 2) = a + c c1 / a1.
struct SideLineEnds {
  double v0 = 0, v1 = 0, covariance = 0, scatter = 0;
  bool ok = false;  // false where the sums are empty or the variances not positive
  // The mean over the two ends of the variance over what independent points of the scatter's
  // variance would give (scatter (1/n + s^2/S)): 1 where c = 0.
  double factor = 1;
  double Correlation() const;
};
SideLineEnds SideLineVariance(const SideBlocks& side, const Eigen::Vector2d& ac);

}  // namespace svms
