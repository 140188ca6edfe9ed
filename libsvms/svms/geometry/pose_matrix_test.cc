#include "svms/geometry/pose_matrix.h"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <random>

namespace svms {
namespace {

// A symmetric positive definite 6x6 with eigenvalues spread over six decades, as a pose's
// information matrix has (radians against metres).
Matrix6d SpdMatrix(unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n;
  Matrix6d m;
  for (int i = 0; i < 36; ++i) m(i) = n(rng);
  const Eigen::HouseholderQR<Matrix6d> qr(m);
  const Matrix6d Q = qr.householderQ();
  Vector6d values;
  values << 1e-3, 1e-2, 0.5, 3, 1e2, 1e3;
  return Q * values.asDiagonal() * Q.transpose();
}

TEST(PoseMatrix, InvertFullPivLuIsTheInverseAndEigensOwn) {
  for (unsigned seed = 1; seed <= 20; ++seed) {
    const Matrix6d a = SpdMatrix(seed);
    Matrix6d inverse;
    ASSERT_EQ(InvertFullPivLu(a, &inverse), 6);
    EXPECT_LT((a * inverse - Matrix6d::Identity()).cwiseAbs().maxCoeff(), 1e-9);
    EXPECT_EQ(inverse, Matrix6d(Eigen::FullPivLU<Matrix6d>(a).inverse()));  // to the bit
  }
}

TEST(PoseMatrix, ARankDeficientMatrixKeepsTheOutputAndSaysItsRank) {
  // Two directions of no information: rank 4.
  Eigen::Matrix<double, 6, 4> basis = Eigen::Matrix<double, 6, 4>::Zero();
  basis.topRows<4>() = Eigen::Matrix4d::Identity();
  const Matrix6d a = basis * basis.transpose();
  Matrix6d inverse = Matrix6d::Constant(7);
  EXPECT_EQ(InvertFullPivLu(a, &inverse), 4);
  EXPECT_EQ(inverse, Matrix6d::Constant(7));
  EXPECT_EQ(InvertFullPivLu(Matrix6d::Zero(), &inverse), 0);
}

TEST(PoseMatrix, SymmetricEigenvaluesRebuildTheMatrixInIncreasingOrder) {
  for (unsigned seed = 1; seed <= 20; ++seed) {
    const Matrix6d a = SpdMatrix(seed);
    Matrix6d vectors;
    const Vector6d values = SymmetricEigenvalues(a, &vectors);
    Vector6d expected;
    expected << 1e-3, 1e-2, 0.5, 3, 1e2, 1e3;
    EXPECT_LT((values - expected).cwiseAbs().maxCoeff(), 1e-10) << values.transpose();
    for (int k = 1; k < 6; ++k) EXPECT_LT(values(k - 1), values(k));
    EXPECT_LT((vectors * values.asDiagonal() * vectors.transpose() - a).cwiseAbs().maxCoeff(),
              1e-10);
    EXPECT_LT((vectors.transpose() * vectors - Matrix6d::Identity()).cwiseAbs().maxCoeff(), 1e-12);
    const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(a);
    EXPECT_EQ(values, eig.eigenvalues());  // to the bit, with or without the vectors
    EXPECT_EQ(SymmetricEigenvalues(a), eig.eigenvalues());
    EXPECT_EQ(vectors, eig.eigenvectors());
  }
  // Only the lower triangle is read.
  Matrix6d a = SpdMatrix(5);
  const Vector6d lower = SymmetricEigenvalues(a);
  a.triangularView<Eigen::StrictlyUpper>().setConstant(1e9);
  EXPECT_EQ(SymmetricEigenvalues(a), lower);
}

TEST(PoseMatrix, SolveLdltSolvesAndTellsAnIndefiniteMatrix) {
  const Matrix6d a = SpdMatrix(7);
  Vector6d b;
  b << 1, -2, 3, 0.5, -0.25, 4;
  Vector6d x, d;
  EXPECT_TRUE(SolveLdlt(a, b, &x, &d));
  EXPECT_LT((a * x - b).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_EQ(x, Vector6d(a.ldlt().solve(b)));
  EXPECT_EQ(d, Vector6d(a.ldlt().vectorD()));
  EXPECT_GT(d.minCoeff(), 0);
  // Several right-hand sides at once: the same columns, and Eigen's own to the bit.
  Eigen::Matrix<double, 6, Eigen::Dynamic> B(6, 2), X;
  B << b, 2 * b;
  EXPECT_TRUE(SolveLdlt(a, B, &X));
  ASSERT_EQ(X.cols(), 2);
  EXPECT_EQ(X, (Eigen::Matrix<double, 6, Eigen::Dynamic>(a.ldlt().solve(B))));
  EXPECT_LT((X.col(0) - x).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((X.col(1) - 2 * x).cwiseAbs().maxCoeff(), 1e-11);
  // One negative eigenvalue: not positive semi-definite.
  Matrix6d indefinite = a;
  indefinite -= 2 * indefinite.col(0).norm() * Vector6d::Unit(0) * Vector6d::Unit(0).transpose();
  EXPECT_FALSE(SolveLdlt(indefinite, b, &x));
  EXPECT_FALSE(SolveLdlt(indefinite, B, &X));
}

}  // namespace
}  // namespace svms
