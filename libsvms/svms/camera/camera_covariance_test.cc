#include "svms/camera/camera_covariance.h"

#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "svms/marker/model_io.h"
#include "svms_testing/scratch_dir.h"

namespace svms {
namespace {

CameraModel Camera() {
  CameraModel c;
  EXPECT_TRUE(CameraModel::Create("LENSMODEL_OPENCV4",
                                  {1000.5, 1001.25, 511.5, 383.5, -0.1, 0.02, 1e-4, -2e-4}, 1024,
                                  768, &c)
                  .ok());
  return c;
}

Eigen::MatrixXd Factor(int n) {
  Eigen::MatrixXd L = Eigen::MatrixXd::Zero(n, n);
  for (int i = 0; i < n; ++i)
    for (int k = 0; k <= i; ++k) L(i, k) = (i == k ? 0.5 : 0.1) / (1 + i + k);
  return L;
}

class Sidecar : public ::testing::Test {
 protected:
  void SetUp() override {
    path_ = CovarianceSidecarPath(dir_.File("cam.cameramodel"));
    camera_ = Camera();
    ASSERT_TRUE(camera_.set_intrinsics_covariance_factor(Factor(8)).ok());
    ASSERT_TRUE(WriteCovarianceSidecar(path_, camera_, 0.05, 30).ok());
    std::string text;
    ASSERT_TRUE(ReadTextFile(path_, &text).ok());
    json_ = nlohmann::json::parse(text);
  }
  // Writes json_ after `edit` and reads it into a fresh camera: the error message ("" if ok).
  template <typename Edit>
  std::string ReadEdited(Edit edit) {
    nlohmann::json j = json_;
    edit(j);
    EXPECT_TRUE(WriteTextFile(path_, j.dump()).ok());
    CameraModel c = Camera();
    const Status s = ReadCovarianceSidecar(path_, &c);
    if (!s) {
      EXPECT_EQ(c.intrinsics_covariance_factor().size(), 0) << "changed on error";
    }
    return s.ok() ? "" : s.message();
  }
  svms_testing::ScratchDir dir_{"svms_sidecar"};
  std::string path_;
  CameraModel camera_;
  nlohmann::json json_;
};

TEST_F(Sidecar, PathIsNextToTheModel) {
  EXPECT_EQ(CovarianceSidecarPath("a/b.cameramodel"), "a/b.cameramodel.covariance.json");
}

TEST_F(Sidecar, WriteThenReadIsExact) {
  CameraModel c = Camera();
  ASSERT_TRUE(ReadCovarianceSidecar(path_, &c).ok());
  EXPECT_EQ(c.intrinsics_covariance_factor(), camera_.intrinsics_covariance_factor());
  EXPECT_EQ(json_["type"], "svms.intrinsics_covariance");
  // The sigmas for people are the square roots of the covariance's diagonal.
  const Eigen::MatrixXd C = Factor(8) * Factor(8).transpose();
  for (int i = 0; i < 8; ++i)
    EXPECT_NEAR(json_["sigma"][i].get<double>(), std::sqrt(C(i, i)), 1e-15);
}

TEST_F(Sidecar, ACameraWithoutACovarianceIsNotWritten) {
  const Status s = WriteCovarianceSidecar(path_, Camera(), 0.05, 30);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("no intrinsics covariance"), std::string::npos) << s.message();
}

TEST_F(Sidecar, AnotherCalibrationsSidecarIsRefused) {
  EXPECT_NE(
      ReadEdited([](auto& j) {
        j["lensmodel"] = "LENSMODEL_OPENCV5";
      }).find("lensmodel: written for LENSMODEL_OPENCV5, but the camera is LENSMODEL_OPENCV4"),
      std::string::npos);
  EXPECT_NE(ReadEdited([](auto& j) {
              j["imagersize"] = {640, 480};
            }).find("imagersize: written for 640x480"),
            std::string::npos);
  EXPECT_NE(ReadEdited([](auto& j) {
              j["intrinsics"][2] = 511.6;
            }).find("intrinsics[2]: written for 511.6"),
            std::string::npos);
  // Round-off far below the model's own precision is the same model.
  EXPECT_EQ(ReadEdited([](auto& j) { j["intrinsics"][0] = 1000.5 * (1 + 1e-13); }), "");
}

TEST_F(Sidecar, MalformedFieldsAreNamed) {
  const std::string p = path_ + ": ";
  EXPECT_EQ(ReadEdited([](auto& j) { j.erase("covariance_factor"); }),
            p + "covariance_factor: missing; this field is required");
  EXPECT_NE(ReadEdited([](auto& j) {
              j["covariance_factor"].erase(7);
            }).find(p + "covariance_factor: expected 8 rows of 8 numbers"),
            std::string::npos);
  EXPECT_NE(ReadEdited([](auto& j) {
              j["covariance_factor"][3].push_back(0);
            }).find(p + "covariance_factor[3]: expected an array of 8 numbers"),
            std::string::npos);
  EXPECT_NE(ReadEdited([](auto& j) {
              j["covariance_factor"][2][1] = "x";
            }).find(p + "covariance_factor[2][1]: expected a finite number"),
            std::string::npos);
  EXPECT_NE(ReadEdited([](auto& j) {
              j["type"] = "svms.layout";
            }).find(p + "type: expected \"svms.intrinsics_covariance\""),
            std::string::npos);
  EXPECT_NE(ReadEdited([](auto& j) { j["extra"] = 1; }).find("extra"), std::string::npos);
  EXPECT_NE(
      ReadEdited([](auto& j) { j["views"] = 0; }).find(p + "views: expected a positive integer"),
      std::string::npos);
  EXPECT_NE(ReadEdited([](auto& j) { j = nlohmann::json::array(); }).find(p + "(top level)"),
            std::string::npos);
  ASSERT_TRUE(WriteTextFile(path_, "{\"type\": ").ok());
  CameraModel c = Camera();
  const Status s = ReadCovarianceSidecar(path_, &c);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.message().rfind(path_, 0), 0u) << s.message();
  EXPECT_NE(s.message().find("not valid JSON"), std::string::npos) << s.message();
}

TEST_F(Sidecar, ALensModelWithoutGradientsIsRefused) {
  // CAHVORE has no intrinsics gradients in mrcal 2.2: nothing could propagate the covariance.
  CameraModel cahvore;
  const std::vector<double> intrinsics = {1000, 1000, 511.5, 383.5, 0, 0, 0, 0, 0, 0, 0, 0};
  ASSERT_TRUE(
      CameraModel::Create("LENSMODEL_CAHVORE_linearity=1.00", intrinsics, 1024, 768, &cahvore)
          .ok());
  nlohmann::json j = json_;
  j["lensmodel"] = cahvore.lensmodel();
  j["imagersize"] = {1024, 768};
  j["intrinsics"] = intrinsics;
  j["covariance_factor"] = nlohmann::json::array();
  for (int i = 0; i < 12; ++i) {
    std::vector<double> row(12, 0.0);
    row[i] = 0.1;
    j["covariance_factor"].push_back(row);
  }
  ASSERT_TRUE(WriteTextFile(path_, j.dump()).ok());
  const Status s = ReadCovarianceSidecar(path_, &cahvore);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find(path_ + ": LENSMODEL_CAHVORE_linearity=1.00 gives no intrinsics "
                                     "gradients"),
            std::string::npos)
      << s.message();
  EXPECT_EQ(cahvore.intrinsics_covariance_factor().size(), 0);
}

TEST_F(Sidecar, MeanFramesFactorRoundTripsAndIsChecked) {
  Eigen::MatrixXd none;
  ASSERT_TRUE(ReadMeanFramesFactor(path_, camera_, &none).ok());
  EXPECT_EQ(none.size(), 0) << "svms calibrate's sidecar has none";
  const Eigen::MatrixXd M = Factor(14);
  ASSERT_TRUE(WriteCovarianceSidecar(path_, camera_, 0.05, 30, M).ok());
  CameraModel c = Camera();
  ASSERT_TRUE(ReadCovarianceSidecar(path_, &c).ok());
  Eigen::MatrixXd back;
  ASSERT_TRUE(ReadMeanFramesFactor(path_, camera_, &back).ok());
  EXPECT_EQ(back, M);
  EXPECT_FALSE(WriteCovarianceSidecar(path_, camera_, 0.05, 30, Factor(13)).ok());
  std::string text;
  ASSERT_TRUE(ReadTextFile(path_, &text).ok());
  nlohmann::json j = nlohmann::json::parse(text);
  j["mean_frames_factor"].erase(13);
  ASSERT_TRUE(WriteTextFile(path_, j.dump()).ok());
  EXPECT_NE(ReadMeanFramesFactor(path_, camera_, &back).message().find("mean_frames_factor"),
            std::string::npos);
  EXPECT_FALSE(ReadCovarianceSidecar(path_, &c).ok());
}

// Cov(q) = G M M^T G^T with G = [dq/dintrinsics, dq/dp (-[p]x), dq/dp], checked against the
// pieces: the intrinsics alone, a rotation alone (also at infinity) and a translation alone
// (left out at infinity).
TEST(CameraCovariance, MeanFramesProjectionCovariance) {
  const CameraModel c = Camera();
  const Eigen::Vector3d p(0.2, -0.1, 1.5);
  Eigen::Vector2d q;
  Eigen::Matrix<double, 2, 3> dq_dp;
  Eigen::Matrix<double, 2, Eigen::Dynamic> dq_di;
  ASSERT_TRUE(c.Project(p, &q, &dq_dp, &dq_di));
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(14, 14);
  Eigen::Matrix2d cov;
  M(0, 0) = 2;  // fx only
  ASSERT_TRUE(MeanFramesProjectionCovariance(c, M, p, false, &cov));
  EXPECT_TRUE(cov.isApprox(4 * dq_di.col(0) * dq_di.col(0).transpose(), 1e-12));
  M.setZero();
  M(10, 10) = 1e-3;  // psi_z: p moves by psi_z (-p.y, p.x, 0)
  ASSERT_TRUE(MeanFramesProjectionCovariance(c, M, p, false, &cov));
  const Eigen::Vector2d dq = dq_dp * Eigen::Vector3d(-p.y(), p.x(), 0) * 1e-3;
  EXPECT_TRUE(cov.isApprox(dq * dq.transpose(), 1e-9));
  ASSERT_TRUE(MeanFramesProjectionCovariance(c, M, 7 * p, true, &cov));
  EXPECT_TRUE(cov.isApprox(dq * dq.transpose(), 1e-9)) << "at infinity the direction counts";
  M.setZero();
  M(11, 11) = 1e-3;  // kappa_x
  ASSERT_TRUE(MeanFramesProjectionCovariance(c, M, p, false, &cov));
  EXPECT_TRUE(cov.isApprox(1e-6 * dq_dp.col(0) * dq_dp.col(0).transpose(), 1e-9));
  ASSERT_TRUE(MeanFramesProjectionCovariance(c, M, p, true, &cov));
  EXPECT_EQ(cov.norm(), 0);
  EXPECT_FALSE(MeanFramesProjectionCovariance(c, Factor(8), p, false, &cov));
}

TEST(CameraCovariance, FactorShapeAndValuesAreChecked) {
  CameraModel c = Camera();
  EXPECT_FALSE(c.set_intrinsics_covariance_factor(Eigen::MatrixXd::Identity(4, 4)).ok());
  Eigen::MatrixXd bad = Eigen::MatrixXd::Identity(8, 8);
  bad(3, 2) = std::nan("");
  EXPECT_FALSE(c.set_intrinsics_covariance_factor(bad).ok());
  EXPECT_EQ(c.intrinsics_covariance_factor().size(), 0);
  ASSERT_TRUE(c.set_intrinsics_covariance_factor(Eigen::MatrixXd::Identity(8, 8)).ok());
  ASSERT_TRUE(c.set_intrinsics_covariance_factor(Eigen::MatrixXd()).ok());  // clears
  EXPECT_EQ(c.intrinsics_covariance_factor().size(), 0);
}

TEST(CameraCovariance, CompactFactorKeepsTheCovariance) {
  // Rows of a wide factor (5 x 40) -> a 5 x 5 lower-triangular factor of the same covariance.
  Eigen::MatrixXd F(5, 40);
  for (int i = 0; i < 5; ++i)
    for (int k = 0; k < 40; ++k) F(i, k) = std::sin(1.0 + 3 * i + 0.7 * k * (i + 1));
  const Eigen::MatrixXd L = CompactFactor(F);
  ASSERT_EQ(L.rows(), 5);
  ASSERT_EQ(L.cols(), 5);
  EXPECT_LT((L * L.transpose() - F * F.transpose()).norm(), 1e-12 * (F * F.transpose()).norm());
  EXPECT_LT(L.triangularView<Eigen::StrictlyUpper>().toDenseMatrix().norm(), 1e-300);
  // Fewer columns than rows (a rank-deficient covariance): still exact.
  const Eigen::MatrixXd F2 = F.leftCols(3);
  const Eigen::MatrixXd L2 = CompactFactor(F2);
  EXPECT_LT((L2 * L2.transpose() - F2 * F2.transpose()).norm(),
            1e-12 * (F2 * F2.transpose()).norm());
}

}  // namespace
}  // namespace svms
