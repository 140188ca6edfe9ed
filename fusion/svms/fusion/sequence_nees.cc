#include "svms/fusion/sequence_nees.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <random>

#include "svms/base/statistics.h"

namespace svms {

bool ComputeSequenceNeesBand(
    const std::vector<PoseCovariance>& covariance,
    const std::vector<Eigen::Matrix<double, 6, Eigen::Dynamic>>& bias_factor,
    const SequenceNeesOptions& options, SequenceNeesBand* band, std::string* error) {
  using Mat6 = Eigen::Matrix<double, 6, 6>;
  using Mat6X = Eigen::Matrix<double, 6, Eigen::Dynamic>;
  *band = SequenceNeesBand{};
  const size_t n = covariance.size();
  if (n == 0 || bias_factor.size() != n) {
    *error = "expected one bias factor per covariance and at least one frame (got " +
             std::to_string(n) + " covariances, " + std::to_string(bias_factor.size()) +
             " bias factors)";
    return false;
  }
  if (options.trials < 2 || !(options.probability > 0 && options.probability < 1)) {
    *error = "expected at least 2 trials and a probability in (0, 1)";
    return false;
  }
  const Eigen::Index k = bias_factor[0].cols();
  // Each frame whitened by its covariance's Cholesky factor C (Sigma = C C^T): NEES = |C^-1 e|^2
  // with e = Sigma_noise^(1/2) w + B z, so the trials need W = C^-1 Sigma_noise^(1/2) and
  // V = C^-1 B only.
  std::vector<Mat6> W(n);
  std::vector<Mat6X> V(n);
  double share = 0;
  for (size_t f = 0; f < n; ++f) {
    const std::string frame = "frame " + std::to_string(f);
    if (bias_factor[f].cols() != k) {
      *error = frame + ": its bias factor has " + std::to_string(bias_factor[f].cols()) +
               " columns; expected " + std::to_string(k) + " as the first frame's";
      return false;
    }
    const Eigen::LLT<Mat6> llt(covariance[f]);
    if (!covariance[f].allFinite() || llt.info() != Eigen::Success) {
      *error = frame + ": its covariance is not positive definite";
      return false;
    }
    const Mat6 noise = covariance[f] - bias_factor[f] * bias_factor[f].transpose();
    const Eigen::SelfAdjointEigenSolver<Mat6> es(noise);
    const double scale = covariance[f].diagonal().maxCoeff();
    if (es.eigenvalues().minCoeff() < -1e-9 * scale) {
      *error = frame +
               ": its bias factor's share exceeds its covariance (the rest has eigenvalue " +
               std::to_string(es.eigenvalues().minCoeff()) + ")";
      return false;
    }
    const Mat6 noise_root = es.eigenvectors() *
                            es.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal() *
                            es.eigenvectors().transpose();
    W[f] = llt.matrixL().solve(noise_root);
    V[f] = llt.matrixL().solve(bias_factor[f]);
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

}  // namespace svms
