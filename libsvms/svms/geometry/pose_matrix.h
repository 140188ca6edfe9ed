// Decompositions of the 6x6 matrices of pose estimation: information matrices (J^T W J) and
// covariances, ordered as PoseCovariance ([rotation(3), translation(3)]).
//
// Every module that fits or checks a pose inverts, factors or diagonalises such a matrix.
// These functions are compiled once (pose_matrix.cc) rather than instantiated from Eigen's
// headers in each file that needs them, which costs seconds of compile time per file and
// decomposition, and return bit for bit what the Eigen decomposition named in each comment
// returns; a file that needs more of a decomposition than they give uses Eigen directly.
#pragma once

#include <Eigen/Core>

namespace svms {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

// Eigen::FullPivLU of a with its default rank threshold: returns the rank of a, and when it is
// 6 sets *inverse to a's inverse (left untouched otherwise).
int InvertFullPivLu(const Matrix6d& a, Matrix6d* inverse);

// Eigen::SelfAdjointEigenSolver of a symmetric a (its lower triangle is read): the eigenvalues
// in increasing order, and in *vectors (when not null) the unit eigenvectors as columns, in the
// same order.
Vector6d SymmetricEigenvalues(const Matrix6d& a, Matrix6d* vectors = nullptr);

// Eigen::LDLT (Cholesky with pivoting) of a symmetric a (its lower triangle is read): *x =
// LDLT::solve(b), which is a^-1 b for a positive definite a. Returns true when the
// factorisation succeeded and a is positive semi-definite (LDLT::info() and isPositive());
// *d (when not null) receives the diagonal of D, in pivoted order.
bool SolveLdlt(const Matrix6d& a, const Vector6d& b, Vector6d* x, Vector6d* d = nullptr);
// The same for several right-hand sides: b is 6 x n, *x is resized to 6 x n.
bool SolveLdlt(const Matrix6d& a, const Eigen::Matrix<double, 6, Eigen::Dynamic>& b,
               Eigen::Matrix<double, 6, Eigen::Dynamic>* x, Vector6d* d = nullptr);

}  // namespace svms
