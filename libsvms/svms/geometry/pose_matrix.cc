#include "svms/geometry/pose_matrix.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>

namespace svms {

int InvertFullPivLu(const Matrix6d& a, Matrix6d* inverse) {
  const Eigen::FullPivLU<Matrix6d> lu(a);
  const int rank = static_cast<int>(lu.rank());
  if (rank == 6) *inverse = lu.inverse();
  return rank;
}

Vector6d SymmetricEigenvalues(const Matrix6d& a, Matrix6d* vectors) {
  // Eigenvectors always, so that the eigenvalues are bit for bit those of Eigen's default
  // (ComputeEigenvectors) mode.
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(a);
  if (vectors) *vectors = eig.eigenvectors();
  return eig.eigenvalues();
}

namespace {
template <typename B, typename X>
bool Solve(const Matrix6d& a, const B& b, X* x, Vector6d* d) {
  const Eigen::LDLT<Matrix6d> ldlt(a);
  *x = ldlt.solve(b);
  if (d) *d = ldlt.vectorD();
  return ldlt.info() == Eigen::Success && ldlt.isPositive();
}
}  // namespace

bool SolveLdlt(const Matrix6d& a, const Vector6d& b, Vector6d* x, Vector6d* d) {
  return Solve(a, b, x, d);
}

bool SolveLdlt(const Matrix6d& a, const Eigen::Matrix<double, 6, Eigen::Dynamic>& b,
               Eigen::Matrix<double, 6, Eigen::Dynamic>* x, Vector6d* d) {
  return Solve(a, b, x, d);
}

}  // namespace svms
