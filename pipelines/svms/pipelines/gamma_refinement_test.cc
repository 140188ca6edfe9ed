#include "svms/pipelines/gamma_refinement.h"

#include <gtest/gtest.h>

namespace svms {
namespace {

TEST(RefineGammaByEdgeBias, TheCurveThatLeavesNoBias) {
  // svms bench calibrate's gamma-2.2 boards: the edges read 2.194 +- 0.006, the calibration
  // finds the sides 0.0015 px inside their squares, and they move 0.24 px out per unit of gamma.
  const GammaRefinement r = RefineGammaByEdgeBias(2.194, 0.006, -0.0015, 0.00012, 0.24);
  EXPECT_TRUE(r.note.empty()) << r.note;
  EXPECT_NEAR(r.gamma, 2.194 + 0.0015 / 0.24, 1e-12);
  EXPECT_NEAR(r.sigma, 0.00012 / 0.24, 1e-12);
  // Either sign of the sides' response to the curve.
  const GammaRefinement n = RefineGammaByEdgeBias(2.194, 0.006, 0.0015, 0.00012, -0.24);
  EXPECT_NEAR(n.gamma, r.gamma, 1e-12);
  EXPECT_NEAR(n.sigma, r.sigma, 1e-12);
}

TEST(RefineGammaByEdgeBias, RefusedWhereTheBiasIsNotTheCurves) {
  // 0.05 px of dot gain would ask for gamma 0.2 off an estimate good to 0.006.
  GammaRefinement r = RefineGammaByEdgeBias(2.194, 0.006, 0.05, 0.0001, 0.24);
  EXPECT_EQ(r.gamma, 0);
  EXPECT_NE(r.note.find("more than 3 sigmas"), std::string::npos) << r.note;
  // At 3 sigmas exactly it is still taken.
  r = RefineGammaByEdgeBias(2.0, 0.01, -0.03 * 0.24 + 1e-12, 0.0001, 0.24);
  EXPECT_NEAR(r.gamma, 2.03, 1e-9) << r.note;
  r = RefineGammaByEdgeBias(2.2, 0.006, -0.001, 0.0001, 0.0);
  EXPECT_EQ(r.gamma, 0);
  EXPECT_NE(r.note.find("do not move"), std::string::npos) << r.note;
  r = RefineGammaByEdgeBias(2.2, 0.006, 0.0, 0.0, 0.24);
  EXPECT_EQ(r.gamma, 0);
  EXPECT_NE(r.note.find("no edge bias"), std::string::npos) << r.note;
}

}  // namespace
}  // namespace svms
