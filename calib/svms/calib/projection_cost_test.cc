#include "svms/calib/projection_cost.h"

#include <ceres/gradient_checker.h>
#include <gtest/gtest.h>

#include <random>

#include "svms/base/random_draws.h"

namespace svms {
namespace {

void CheckGradients(const std::string& lensmodel, std::vector<double> intrinsics, bool warp,
                    double tolerance = 1e-5) {
  auto lens = LensModel::Parse(lensmodel);
  ASSERT_NE(lens, nullptr) << lensmodel;
  ASSERT_EQ(lens->num_params(), static_cast<int>(intrinsics.size()));
  const BoardExtent extent{-0.4, 0.4, -0.3, 0.3};
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int trial = 0; trial < 5; ++trial) {
    const Eigen::Vector2d xy = DrawVector2(u, rng);  // fixed order (random_draws.h)
    const Eigen::Vector3d point(0.3 * xy.x(), 0.25 * xy.y(), trial == 4 ? 0.02 : 0.0);
    ProjectionCost cost(lens, point, Eigen::Vector2d(500, 400), 1.7, warp, extent);
    double rt[6] = {0.3 * u(rng), 0.3 * u(rng), 0.2 * u(rng),
                    0.1 * u(rng), 0.1 * u(rng), 1.5 + 0.2 * u(rng)};
    double w[2] = {0.002, -0.001};
    std::vector<const double*> params = {intrinsics.data(), rt};
    if (warp) params.push_back(w);
    ceres::NumericDiffOptions nd;
    nd.relative_step_size = 1e-7;
    const std::vector<const ceres::Manifold*>* none = nullptr;
    ceres::GradientChecker checker(&cost, none, nd);
    ceres::GradientChecker::ProbeResults results;
    EXPECT_TRUE(checker.Probe(params.data(), tolerance, &results))
        << lensmodel << ": " << results.error_log;
  }
}

TEST(ProjectionCost, GradientsPinhole) {
  CheckGradients("LENSMODEL_PINHOLE", {1000, 1010, 512, 500}, false);
}

TEST(ProjectionCost, GradientsOpenCV8WithWarp) {
  CheckGradients(
      "LENSMODEL_OPENCV8",
      {1111, 1109, 515.3, 508.7, -0.32, 0.12, 0.0006, -0.0004, -0.02, 0.01, 0.005, 0.001}, true);
}

TEST(ProjectionCost, GradientsOpenCV12) {
  std::vector<double> in = {900,  905, 500, 490, -0.2,  0.05,   0.001, -0.001,
                            0.01, 0.0, 0.0, 0.0, 0.001, -0.002, 0.001, 0.0005};
  CheckGradients("LENSMODEL_OPENCV12", in, false);
}

TEST(ProjectionCost, GradientsSplined) {
  const std::string name = "LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=8_Ny=6_fov_x_deg=80";
  auto lens = LensModel::Parse(name);
  ASSERT_NE(lens, nullptr);
  std::vector<double> in(lens->num_params(), 0.0);
  in[0] = in[1] = 800, in[2] = 512, in[3] = 384;
  std::mt19937 rng(5);
  std::normal_distribution<double> g(0, 0.01);
  for (size_t k = 4; k < in.size(); ++k) in[k] = g(rng);
  // The spline is only C2 across knots: central differences are a little less exact there.
  CheckGradients(name, in, true, 1e-4);
}

TEST(EdgeBiasedProjectionCost, GradientsAndResidual) {
  auto lens = LensModel::Parse("LENSMODEL_OPENCV8");
  std::vector<double> in = {1111,   1109,    515.3, 508.7, -0.32, 0.12,
                            0.0006, -0.0004, -0.02, 0.01,  0.005, 0.001};
  const BoardExtent extent{-0.4, 0.4, -0.3, 0.3};
  const Eigen::Vector3d point(0.1, -0.05, 0);
  const Eigen::Vector2d observed(480, 420), shift(0.9, -1.2);
  const double weight = 1.7;
  double rt[6] = {0.1, -0.2, 0.05, 0.02, -0.03, 1.4};
  double w[2] = {0.002, -0.001};
  double bias = 0.03;
  ProjectionCost plain(lens, point, observed, weight, true, extent);
  EdgeBiasedProjectionCost cost(new ProjectionCost(lens, point, observed, weight, true, extent),
                                shift, weight);
  ASSERT_EQ(cost.parameter_block_sizes(), (std::vector<int32_t>{12, 6, 2, 1}));
  const double* params[4] = {in.data(), rt, w, &bias};
  double r0[2], r1[2];
  ASSERT_TRUE(plain.Evaluate(params, r0, nullptr));
  ASSERT_TRUE(cost.Evaluate(params, r1, nullptr));
  // The prediction moves by bias * shift: the residual by weight times that.
  EXPECT_NEAR(r1[0] - r0[0], weight * bias * shift.x(), 1e-9);
  EXPECT_NEAR(r1[1] - r0[1], weight * bias * shift.y(), 1e-9);
  ceres::NumericDiffOptions nd;
  nd.relative_step_size = 1e-7;
  const std::vector<const ceres::Manifold*>* none = nullptr;
  ceres::GradientChecker checker(&cost, none, nd);
  ceres::GradientChecker::ProbeResults results;
  EXPECT_TRUE(checker.Probe(params, 1e-5, &results)) << results.error_log;

  // Without the warp the bias is the third block; only the bias's Jacobian asked for.
  EdgeBiasedProjectionCost no_warp(new ProjectionCost(lens, point, observed, weight, false, extent),
                                   shift, weight);
  ASSERT_EQ(no_warp.parameter_block_sizes(), (std::vector<int32_t>{12, 6, 1}));
  const double* params3[3] = {in.data(), rt, &bias};
  double r2[2], jb[2] = {0, 0};
  double* jac[3] = {nullptr, nullptr, jb};
  ASSERT_TRUE(no_warp.Evaluate(params3, r2, jac));
  EXPECT_EQ(jb[0], weight * shift.x());
  EXPECT_EQ(jb[1], weight * shift.y());
  ceres::GradientChecker checker3(&no_warp, none, nd);
  EXPECT_TRUE(checker3.Probe(params3, 1e-5, &results)) << results.error_log;
}

TEST(ProjectionCost, FailsBehindThePinholeCamera) {
  auto lens = LensModel::Parse("LENSMODEL_PINHOLE");
  std::vector<double> in = {1000, 1000, 512, 512};
  ProjectionCost cost(lens, Eigen::Vector3d(0, 0, 0), Eigen::Vector2d(0, 0), 1, false, {});
  double rt[6] = {0, 0, 0, 0, 0, -1};
  const double* params[2] = {in.data(), rt};
  double r[2];
  EXPECT_FALSE(cost.Evaluate(params, r, nullptr));
}

TEST(IntrinsicsPrior, Gradients) {
  IntrinsicsPrior prior(6, {2, 4, 5}, {1.0, 0.0, 0.5}, {0.1, 2.0, 3.0});
  std::vector<double> in = {1, 2, 3, 4, 5, 6};
  const double* params[1] = {in.data()};
  const std::vector<const ceres::Manifold*>* none = nullptr;
  ceres::GradientChecker checker(&prior, none, ceres::NumericDiffOptions());
  ceres::GradientChecker::ProbeResults results;
  EXPECT_TRUE(checker.Probe(params, 1e-7, &results)) << results.error_log;
  EXPECT_NEAR(results.residuals[1], 2.0 * 5, 1e-12);
}

}  // namespace
}  // namespace svms
