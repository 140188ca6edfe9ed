#include "svms/fusion/sequence_nees.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <random>

#include "svms/base/statistics.h"

namespace svms {
namespace {

using Mat6 = Eigen::Matrix<double, 6, 6>;
using Mat6X = Eigen::Matrix<double, 6, Eigen::Dynamic>;

// C^-1 B for the covariance's Cholesky factor C. Eigen's triangular solve reads the first
// coefficient of its right-hand side even when it has no columns (undefined behaviour on the
// null data of an empty matrix), so an empty B gives an empty result without it.
Mat6X WhitenedBias(const Eigen::LLT<Mat6>& llt, const Mat6X& bias_factor) {
  if (bias_factor.cols() == 0) return Mat6X(6, 0);
  return llt.matrixL().solve(bias_factor);
}

bool CheckSizes(size_t covariances, size_t bias_factors, std::string* error) {
  if (covariances == 0 || bias_factors != covariances) {
    *error = "expected one bias factor per covariance and at least one frame (got " +
             std::to_string(covariances) + " covariances, " + std::to_string(bias_factors) +
             " bias factors)";
    return false;
  }
  return true;
}

// Checks frame f's covariance and bias factor (k columns, as the first frame's) and gives the
// Cholesky factor of its covariance, its own share N_f = Sigma_f - B_f B_f^T and the symmetric
// square root of that share (round-off's negative eigenvalues taken as zero).
bool SplitFrame(size_t f, const PoseCovariance& covariance, const Mat6X& bias_factor,
                Eigen::Index k, Eigen::LLT<Mat6>* llt, Mat6* noise, Mat6* noise_root,
                std::string* error, double* whitened_min = nullptr) {
  const std::string frame = "frame " + std::to_string(f);
  if (bias_factor.cols() != k) {
    *error = frame + ": its bias factor has " + std::to_string(bias_factor.cols()) +
             " columns; expected " + std::to_string(k) + " as the first frame's";
    return false;
  }
  llt->compute(covariance);
  if (!covariance.allFinite() || llt->info() != Eigen::Success) {
    *error = frame + ": its covariance is not positive definite";
    return false;
  }
  *noise = covariance - bias_factor * bias_factor.transpose();
  // In the covariance's whitened coordinates (free of the rad^2 / m^2 scales) the own share is
  // I - V V^T, V = C^-1 B: its eigenvalues must not go below round-off.
  const Mat6X V = WhitenedBias(*llt, bias_factor);
  const Eigen::SelfAdjointEigenSolver<Mat6> whitened(Mat6::Identity() - V * V.transpose());
  if (whitened.eigenvalues().minCoeff() < -1e-9) {
    *error =
        frame +
        ": its bias factor's share exceeds its covariance (whitened, the rest has eigenvalue " +
        std::to_string(whitened.eigenvalues().minCoeff()) + ")";
    return false;
  }
  if (whitened_min) *whitened_min = whitened.eigenvalues().minCoeff();
  const Eigen::SelfAdjointEigenSolver<Mat6> es(*noise);
  *noise_root = es.eigenvectors() * es.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal() *
                es.eigenvectors().transpose();
  return true;
}

}  // namespace

bool ComputeSequenceNeesBand(const std::vector<PoseCovariance>& covariance,
                             const std::vector<Mat6X>& bias_factor,
                             const SequenceNeesOptions& options, SequenceNeesBand* band,
                             std::string* error) {
  *band = SequenceNeesBand{};
  const size_t n = covariance.size();
  if (!CheckSizes(n, bias_factor.size(), error)) return false;
  if (options.trials < 2 || !(options.probability > 0 && options.probability < 1)) {
    *error = "expected at least 2 trials and a probability in (0, 1)";
    return false;
  }
  const Eigen::Index k = bias_factor[0].cols();
  // Each frame whitened by its covariance's Cholesky factor C (Sigma = C C^T): NEES = |C^-1 e|^2
  // with e = N^(1/2) w + B z, so the trials need W = C^-1 N^(1/2) and V = C^-1 B only.
  std::vector<Mat6> W(n);
  std::vector<Mat6X> V(n);
  double share = 0;
  for (size_t f = 0; f < n; ++f) {
    Eigen::LLT<Mat6> llt;
    Mat6 noise, noise_root;
    if (!SplitFrame(f, covariance[f], bias_factor[f], k, &llt, &noise, &noise_root, error))
      return false;
    W[f] = llt.matrixL().solve(noise_root);
    V[f] = WhitenedBias(llt, bias_factor[f]);
    share += V[f].squaredNorm() / 6;
  }
  std::mt19937_64 rng(options.seed);
  std::normal_distribution<double> g(0, 1);
  std::vector<double> means(static_cast<size_t>(options.trials));
  Eigen::VectorXd z(k);
  Eigen::Matrix<double, 6, 1> w, e;
  for (double& mean : means) {
    for (Eigen::Index j = 0; j < k; ++j) z[j] = g(rng);
    double sum = 0;
    for (size_t f = 0; f < n; ++f) {
      for (int j = 0; j < 6; ++j) w[j] = g(rng);
      e.noalias() = W[f] * w;
      if (k > 0) e.noalias() += V[f] * z;
      sum += e.squaredNorm();
    }
    mean = sum / static_cast<double>(n);
  }
  const double tail = 0.5 * (1 - options.probability);
  band->frames = static_cast<int>(n);
  band->common_columns = static_cast<int>(k);
  band->lo = Percentile(means, tail);
  band->hi = Percentile(means, 1 - tail);
  double total = 0;
  for (double m : means) total += m;
  band->mean = total / static_cast<double>(means.size());
  const double dof = 6.0 * static_cast<double>(n);
  band->independent_lo = ChiSquareQuantile(tail, dof) / static_cast<double>(n);
  band->independent_hi = ChiSquareQuantile(1 - tail, dof) / static_cast<double>(n);
  band->common_share = share / static_cast<double>(n);
  return true;
}

bool EstimateCommonDraw(const std::vector<Eigen::Matrix<double, 6, 1>>& errors,
                        const std::vector<PoseCovariance>& covariance,
                        const std::vector<Mat6X>& bias_factor, CommonDrawEstimate* estimate,
                        std::string* error) {
  *estimate = CommonDrawEstimate{};
  const size_t n = covariance.size();
  if (!CheckSizes(n, bias_factor.size(), error)) return false;
  if (errors.size() != n) {
    *error = "expected one error per covariance (got " + std::to_string(errors.size()) +
             " errors, " + std::to_string(n) + " covariances)";
    return false;
  }
  const Eigen::Index k = bias_factor[0].cols();
  std::vector<Mat6> noise_inv(n);
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(k, k);
  Eigen::VectorXd b = Eigen::VectorXd::Zero(k);
  for (size_t f = 0; f < n; ++f) {
    Eigen::LLT<Mat6> llt;
    Mat6 noise, noise_root;
    double whitened_min = 0;
    if (!SplitFrame(f, covariance[f], bias_factor[f], k, &llt, &noise, &noise_root, error,
                    &whitened_min))
      return false;
    // Singular where, whitened by the covariance, some direction is all common error.
    const Eigen::LLT<Mat6> own(noise);
    if (own.info() != Eigen::Success || whitened_min <= 1e-12) {
      *error = "frame " + std::to_string(f) +
               ": its own share of the covariance (less the common error's) is singular";
      return false;
    }
    noise_inv[f] = own.solve(Mat6::Identity());
    A.noalias() += bias_factor[f].transpose() * noise_inv[f] * bias_factor[f];
    b.noalias() += bias_factor[f].transpose() * noise_inv[f] * errors[f];
  }
  if (k == 0) {  // no common error: every frame's NEES is its own
    double own = 0;
    for (size_t f = 0; f < n; ++f) own += errors[f].dot(noise_inv[f] * errors[f]);
    estimate->own_nees_mean = own / static_cast<double>(n);
    return true;
  }
  // A's eigenvalues below 1e-9 of its largest are directions of z the sequence does not see.
  // In A's eigenbasis z_hat = diag(1 / lambda) U^T b on the seen directions, and under honest
  // covariances each of its components there is N(0, 1 + 1 / lambda).
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(A);
  const Eigen::VectorXd& lambda = es.eigenvalues();
  const double floor = 1e-9 * std::max(lambda.maxCoeff(), 0.0);
  const Eigen::VectorXd ub = es.eigenvectors().transpose() * b;
  Eigen::VectorXd zu = Eigen::VectorXd::Zero(k);
  for (Eigen::Index j = 0; j < k; ++j) {
    if (!(lambda[j] > floor)) continue;
    zu[j] = ub[j] / lambda[j];
    estimate->chi2 += zu[j] * zu[j] / (1 + 1 / lambda[j]);
    ++estimate->rank;
  }
  estimate->z = es.eigenvectors() * zu;
  double own = 0;
  for (size_t f = 0; f < n; ++f) {
    const Eigen::Matrix<double, 6, 1> r = errors[f] - bias_factor[f] * estimate->z;
    own += r.dot(noise_inv[f] * r);
  }
  estimate->own_nees_mean = own / static_cast<double>(n);
  return true;
}

}  // namespace svms
