#include "svms/calib/calibrate.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cstdio>
#include <cstdlib>
#include <random>

#include "svms/base/random_draws.h"
#include "svms/calib/board.h"
#include "svms/datasets/datasets.h"
#include "svms_testing/scratch_dir.h"

namespace svms {
namespace {

// The calibration dataset's board and its 40 view poses (the board sits at the world origin).
struct BoardViews {
  Layout layout = MakeBoardLayout(BoardSpec{5, 6, 0.06, 0.015, 100});
  std::vector<Pose> cam_from_board;
};

BoardViews DatasetSetup(int max_views = 40) {
  BoardViews s;
  Dataset d;
  EXPECT_TRUE(MakeDataset("calibration", DatasetOptions{1, false}, &d).ok());
  for (const View& v : d.scenes[0].second.views)
    if (static_cast<int>(s.cam_from_board.size()) < max_views)
      s.cam_from_board.push_back(v.cam_from_world);
  return s;
}

// Projects every marker whose four corners land in the image; adds Gaussian noise.
std::vector<ViewObservations> Synthesise(const BoardViews& s, const CameraModel& cam, double noise,
                                         uint64_t seed, const Eigen::Vector2d& warp = {0, 0}) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g(0, 1);
  BoardExtent extent;  // as Calibrate computes it: over the corners
  extent.x_min = extent.y_min = 1e300, extent.x_max = extent.y_max = -1e300;
  for (const LayoutEntry& e : s.layout.markers)
    for (const auto& c : e.marker.Corners()) {
      const Eigen::Vector3d p = e.object_from_marker * c;
      extent.x_min = std::min(extent.x_min, p.x()), extent.x_max = std::max(extent.x_max, p.x());
      extent.y_min = std::min(extent.y_min, p.y()), extent.y_max = std::max(extent.y_max, p.y());
    }
  std::vector<ViewObservations> views;
  for (size_t v = 0; v < s.cam_from_board.size(); ++v) {
    ViewObservations view;
    view.name = "view" + std::to_string(v);
    for (const LayoutEntry& e : s.layout.markers) {
      std::vector<PointObservation> pts;
      for (int k = 0; k < 4; ++k) {
        const Eigen::Vector3d pb = e.object_from_marker * e.marker.Corners()[k];
        // mrcal's board warp (synthetic_data.py, ref_calibration_object): the board's z moves by
        // k_x 4 x_r (1 - x_r) + k_y 4 y_r (1 - y_r), x_r and y_r running 0 to 1 over the board.
        // Written here from that definition, not through ProjectionCost::WarpedPoint, so that
        // a wrong warp in the solver fails this test instead of being mirrored by it.
        const double xr = (pb.x() - extent.x_min) / (extent.x_max - extent.x_min);
        const double yr = (pb.y() - extent.y_min) / (extent.y_max - extent.y_min);
        const Eigen::Vector3d warped =
            pb + Eigen::Vector3d(0, 0, warp.x() * 4 * xr * (1 - xr) + warp.y() * 4 * yr * (1 - yr));
        Eigen::Vector2d q;
        if (!cam.Project(s.cam_from_board[v] * warped, &q)) break;
        if (q.x() < 0 || q.y() < 0 || q.x() > cam.width() - 1 || q.y() > cam.height() - 1) break;
        pts.push_back(PointObservation{pb, q + noise * DrawVector2(g, rng), 0.1, e.marker.id, k,
                                       Eigen::Vector2d::Zero()});
      }
      if (pts.size() == 4) {
        view.points.insert(view.points.end(), pts.begin(), pts.end());
        ++view.markers;
      }
    }
    views.push_back(view);
  }
  return views;
}

CalibrationOptions Options(const std::string& lensmodel) {
  CalibrationOptions o;
  o.lensmodel = lensmodel;
  o.width = o.height = 1024;
  return o;
}

std::vector<Pose> UsedTruth(const BoardViews& s, const CalibrationResult& r) {
  std::vector<Pose> out;
  for (int v : r.views) out.push_back(s.cam_from_board[v]);
  return out;
}

// RMS over a grid of the image of the aligned projection error at `range`, and of the
// predicted error sqrt(trace(covariance)).
void CompareOverImage(const CalibrationResult& r, const CameraModel& truth,
                      const std::vector<Pose>& true_poses, double range, double* rms_error,
                      double* rms_predicted) {
  double e2 = 0, p2 = 0;
  int n = 0;
  for (int y = 64; y < 1024; y += 128)
    for (int x = 64; x < 1024; x += 128) {
      const Eigen::Vector2d px(x, y);
      Eigen::Vector2d err;
      Eigen::Matrix2d cov;
      if (!AlignedProjectionError(r, truth, true_poses, px, range, &err)) continue;
      if (!ProjectionCovariance(r, px, range, &cov)) continue;
      e2 += err.squaredNorm(), p2 += cov.trace(), ++n;
    }
  ASSERT_GT(n, 50);
  *rms_error = std::sqrt(e2 / n), *rms_predicted = std::sqrt(p2 / n);
}

TEST(Calibrate, PinholeExactWithoutNoise) {
  const BoardViews s = DatasetSetup(12);
  const CameraModel truth = CameraModel::Pinhole(1000, 1024, 1024);
  CalibrationResult r;
  const Status st = Calibrate(Synthesise(s, truth, 0, 1), Options("LENSMODEL_PINHOLE"), &r);
  ASSERT_TRUE(st.ok()) << st.message();
  for (int k = 0; k < 4; ++k) EXPECT_NEAR(r.camera.intrinsics()[k], truth.intrinsics()[k], 1e-6);
  EXPECT_LT(r.rms_px, 1e-6);
  EXPECT_EQ(r.num_outliers, 0);
  for (size_t i = 0; i < r.views.size(); ++i) {
    EXPECT_LT((r.cam_from_board[i].tvec - s.cam_from_board[r.views[i]].tvec).norm(), 1e-8);
  }
}

TEST(Calibrate, OpenCV8KnownAnswerWithNoise) {
  const BoardViews s = DatasetSetup();
  const CameraModel truth = DistortedCamera();
  CalibrationResult r;
  const Status st = Calibrate(Synthesise(s, truth, 0.1, 2), Options("LENSMODEL_OPENCV8"), &r);
  ASSERT_TRUE(st.ok()) << st.message();
  EXPECT_EQ(r.camera.lensmodel(), "LENSMODEL_OPENCV8");
  EXPECT_NEAR(r.rms_px, 0.1 * std::sqrt(2.0), 0.01);
  EXPECT_NEAR(r.sigma_px, 0.1, 0.01);
  EXPECT_LT(r.num_outliers, 10);  // 4 sigma in 2-D: a few in ten thousand
  EXPECT_NEAR(r.camera.intrinsics()[0], 1111.0, 2.0);
  EXPECT_NEAR(r.camera.intrinsics()[2], 515.3, 2.0);
  double err = 0, pred = 0;
  CompareOverImage(r, truth, UsedTruth(s, r), 2.0, &err, &pred);
  EXPECT_LT(err, 0.1);
  EXPECT_GT(pred, 0.005);
  // One noise sample: the realised error is within a factor 3 of the predicted spread.
  EXPECT_LT(err / pred, 3.0);
  EXPECT_GT(err / pred, 1 / 3.0);
}

// Every marker's corners as if each side were seen `bias_px` further out of its black square
// (PointObservation::edge_shift from the noise-free corners), and that shift recorded.
std::vector<ViewObservations> WithEdgeBias(std::vector<ViewObservations> views, const BoardViews& s,
                                           const CameraModel& cam, double bias_px) {
  for (size_t v = 0; v < views.size(); ++v) {
    for (size_t i = 0; i + 4 <= views[v].points.size(); i += 4) {
      std::array<Eigen::Vector2d, 4> exact;
      for (int k = 0; k < 4; ++k)
        EXPECT_TRUE(cam.Project(s.cam_from_board[v] * views[v].points[i + k].point_in_board,
                                &exact[k]));  // every synthesised point projected
      const std::array<Eigen::Vector2d, 4> shift = QuadEdgeShifts(exact);
      for (int k = 0; k < 4; ++k) {
        views[v].points[i + k].pixel += bias_px * shift[k];
        views[v].points[i + k].edge_shift = shift[k];
      }
    }
  }
  return views;
}

TEST(Calibrate, EdgeBiasIsFittedWithItsUncertainty) {
  // Sides seen 0.01 px outside their squares (a response curve about 0.04 off in gamma at
  // 0.7 px of blur, docs/detector.md, or 0.01 px of dot gain), corner noise 0.01 px. With the edge
  // bias fitted, it is found within its predicted sigma, the a-posteriori noise is the corners' and
  // the lens is as good as the noise allows. Without it, the bias stays in the residuals (the
  // board's geometry keeps the lens from taking it up), where it inflates the noise estimate
  // and with it every uncertainty the camera carries.
  const BoardViews s = DatasetSetup(24);
  CameraModel truth;
  ASSERT_TRUE(CameraModel::Create("LENSMODEL_OPENCV4",
                                  {1111, 1109, 515.3, 508.7, -0.12, 0.05, 0.0006, -0.0004}, 1024,
                                  1024, &truth)
                  .ok());
  const double bias = 0.01, noise = 0.01;
  const std::vector<ViewObservations> views =
      WithEdgeBias(Synthesise(s, truth, noise, 11), s, truth, bias);
  CalibrationOptions o = Options("LENSMODEL_OPENCV4");
  o.edge_bias = true;
  CalibrationResult fitted;
  const Status st = Calibrate(views, o, &fitted);
  ASSERT_TRUE(st.ok()) << st.message();
  EXPECT_GT(fitted.edge_bias_sigma_px, 0);
  EXPECT_LT(fitted.edge_bias_sigma_px, 0.001);
  EXPECT_NEAR(fitted.edge_bias_px, bias, 4 * fitted.edge_bias_sigma_px);
  EXPECT_NEAR(fitted.noise_sigma_px, noise, 0.05 * noise);
  const int nstate = static_cast<int>(fitted.covariance.rows());
  EXPECT_EQ(nstate, 8 + 6 * static_cast<int>(fitted.views.size()) + 1);
  double err = 0, pred = 0;
  CompareOverImage(fitted, truth, UsedTruth(s, fitted), 2.0, &err, &pred);
  EXPECT_LT(err / pred, 3.0);
  EXPECT_GT(err / pred, 1 / 3.0);

  o.edge_bias = false;
  CalibrationResult ignored;
  ASSERT_TRUE(Calibrate(views, o, &ignored).ok());
  EXPECT_EQ(ignored.edge_bias_px, 0);
  EXPECT_EQ(ignored.edge_bias_sigma_px, 0);
  EXPECT_EQ(ignored.covariance.rows(), nstate - 1);
  // 0.01 px along each diagonal (sqrt(2) x 0.01 in 2-D) added to 0.01 px of noise per axis.
  EXPECT_GT(ignored.noise_sigma_px, 1.3 * noise);
}

TEST(Calibrate, NoEdgeBiasIsFoundWhereThereIsNone) {
  const BoardViews s = DatasetSetup(24);
  const CameraModel truth = DistortedCamera();
  CalibrationOptions o = Options("LENSMODEL_OPENCV8");
  o.edge_bias = true;
  CalibrationResult r;
  ASSERT_TRUE(Calibrate(WithEdgeBias(Synthesise(s, truth, 0.05, 12), s, truth, 0.0), o, &r).ok());
  EXPECT_GT(r.edge_bias_sigma_px, 0);
  EXPECT_NEAR(r.edge_bias_px, 0, 4 * r.edge_bias_sigma_px);
}

TEST(Calibrate, EdgeBiasWithTheBoardWarp) {
  // Both optional parts of the state: [intrinsics, 6 per view, warp (2), edge bias (1)].
  const BoardViews s = DatasetSetup(24);
  const CameraModel truth = DistortedCamera();
  const Eigen::Vector2d warp(0.002, -0.001);
  CalibrationOptions o = Options("LENSMODEL_OPENCV8");
  o.edge_bias = true;
  o.board_warp = true;
  CalibrationResult r;
  const Status st =
      Calibrate(WithEdgeBias(Synthesise(s, truth, 0.02, 13, warp), s, truth, 0.01), o, &r);
  ASSERT_TRUE(st.ok()) << st.message();
  EXPECT_EQ(r.covariance.rows(), 12 + 6 * static_cast<int>(r.views.size()) + 3);
  EXPECT_NEAR(r.edge_bias_px, 0.01, 4 * r.edge_bias_sigma_px);
  const int last = static_cast<int>(r.covariance.rows()) - 1;
  EXPECT_NEAR(r.edge_bias_sigma_px, std::sqrt(r.covariance(last, last)), 1e-15);
  EXPECT_NEAR(r.warp.x(), warp.x(), 4 * std::sqrt(r.covariance(last - 2, last - 2)));
  EXPECT_NEAR(r.warp.y(), warp.y(), 4 * std::sqrt(r.covariance(last - 1, last - 1)));
}

TEST(Calibrate, ProjectionCovarianceIsPositiveWhereTheModelExtrapolates) {
  // The dataset's views leave the image corners empty; there the rational model's projection
  // hangs on directions the data barely see (condition numbers near 1e15). The covariance must
  // still be a covariance: finite and positive semi-definite, and larger than in the middle.
  const BoardViews s = DatasetSetup();
  const CameraModel truth = DistortedCamera();
  CalibrationResult r;
  ASSERT_TRUE(Calibrate(Synthesise(s, truth, 0.05, 6), Options("LENSMODEL_OPENCV8"), &r).ok());
  ASSERT_EQ(r.covariance_factor.rows(), r.covariance.rows());
  EXPECT_NEAR(r.noise_sigma_px, 0.05, 0.005);
  Eigen::Matrix2d centre;
  ASSERT_TRUE(ProjectionCovariance(r, Eigen::Vector2d(511.5, 511.5), 2.0, &centre));
  for (int y = 0; y < 1024; y += 31)
    for (int x = 0; x < 1024; x += 31) {
      Eigen::Matrix2d C;
      if (!ProjectionCovariance(r, Eigen::Vector2d(x, y), 2.0, &C)) continue;
      ASSERT_TRUE(C.allFinite()) << x << " " << y;
      const Eigen::Vector2d l = Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(C).eigenvalues();
      EXPECT_GE(l(0), -1e-12 * std::max(1.0, l(1))) << x << " " << y;
    }
  Eigen::Matrix2d corner;
  ASSERT_TRUE(ProjectionCovariance(r, Eigen::Vector2d(5, 5), 2.0, &corner));
  EXPECT_GT(corner.trace(), 10 * centre.trace());
}

TEST(Calibrate, PredictedUncertaintyMatchesMonteCarlo) {
  // mrcal's uncertainty claims: over noise samples, the aligned projection error has the
  // predicted covariance. Pinhole and 10 views keep each solve to milliseconds.
  const BoardViews s = DatasetSetup(10);
  const CameraModel truth = CameraModel::Pinhole(1100, 1024, 1024);
  double e2 = 0, p2 = 0, nees = 0;
  const int trials = 40;
  for (int t = 0; t < trials; ++t) {
    CalibrationResult r;
    ASSERT_TRUE(
        Calibrate(Synthesise(s, truth, 0.3, 100 + t), Options("LENSMODEL_PINHOLE"), &r).ok());
    double err = 0, pred = 0;
    CompareOverImage(r, truth, UsedTruth(s, r), 1.5, &err, &pred);
    e2 += err * err, p2 += pred * pred;
    // The camera carries its intrinsics' marginal covariance (what a pose inherits) as a factor.
    const Eigen::MatrixXd& L = r.camera.intrinsics_covariance_factor();
    ASSERT_EQ(L.rows(), 4);
    ASSERT_EQ(L.cols(), 4);
    const Eigen::Matrix4d block = r.covariance.topLeftCorner<4, 4>();
    EXPECT_LT((L * L.transpose() - block).norm(), 1e-9 * block.norm());
    Eigen::Vector4d error;
    for (int k = 0; k < 4; ++k) error[k] = r.camera.intrinsics()[k] - truth.intrinsics()[k];
    nees += L.triangularView<Eigen::Lower>().solve(error).squaredNorm();
  }
  const double ratio = std::sqrt(e2 / p2);
  EXPECT_GT(ratio, 0.8);
  EXPECT_LT(ratio, 1.25);
  // Mean of 40 chi-square(4) draws: 4 +- 0.45 (1 sigma); allow 4 sigma.
  EXPECT_NEAR(nees / trials, 4.0, 1.8);
}

TEST(Calibrate, RejectsOutliers) {
  const BoardViews s = DatasetSetup(20);
  const CameraModel truth = DistortedCamera();
  std::vector<ViewObservations> views = Synthesise(s, truth, 0.1, 3);
  int corrupted = 0;
  for (ViewObservations& v : views)
    for (size_t i = 0; i < v.points.size(); i += 97) v.points[i].pixel.x() += 6.0, ++corrupted;
  CalibrationResult r;
  const Status st = Calibrate(views, Options("LENSMODEL_OPENCV8"), &r);
  ASSERT_TRUE(st.ok()) << st.message();
  EXPECT_GE(r.num_outliers, corrupted);
  EXPECT_LT(r.num_outliers, corrupted + 10);
  for (size_t v = 0; v < r.views.size(); ++v)
    for (size_t i = 0; i < views[r.views[v]].points.size(); i += 97) EXPECT_TRUE(r.outlier[v][i]);
  EXPECT_LT(r.rms_px, 0.16);
  EXPECT_NEAR(r.camera.intrinsics()[0], 1111.0, 3.0);
}

TEST(Calibrate, EstimatesBoardWarp) {
  const BoardViews s = DatasetSetup(25);
  const CameraModel truth = DistortedCamera();
  const Eigen::Vector2d warp(0.003, -0.002);
  CalibrationOptions o = Options("LENSMODEL_OPENCV8");
  o.board_warp = true;
  CalibrationResult r;
  const Status st = Calibrate(Synthesise(s, truth, 0.05, 4, warp), o, &r);
  ASSERT_TRUE(st.ok()) << st.message();
  EXPECT_NEAR(r.warp.x(), warp.x(), 3e-4);
  EXPECT_NEAR(r.warp.y(), warp.y(), 3e-4);
  EXPECT_LT(r.rms_px, 0.1);
}

TEST(Calibrate, SplinedModelFitsTheDistortedLens) {
  const BoardViews s = DatasetSetup(24);
  const CameraModel truth = DistortedCamera();
  CalibrationResult r;
  const Status st =
      Calibrate(Synthesise(s, truth, 0.1, 5),
                Options("LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=10_Ny=10_fov_x_deg=70"), &r);
  ASSERT_TRUE(st.ok()) << st.message();
  EXPECT_LT(r.rms_px, 0.16);
  // Where the data are (the central part of the image), the fit is good.
  double e2 = 0;
  int n = 0;
  for (int y = 256; y <= 768; y += 64)
    for (int x = 256; x <= 768; x += 64) {
      Eigen::Vector2d err;
      ASSERT_TRUE(
          AlignedProjectionError(r, truth, UsedTruth(s, r), Eigen::Vector2d(x, y), 2.0, &err));
      e2 += err.squaredNorm(), ++n;
    }
  EXPECT_LT(std::sqrt(e2 / n), 0.15);
}

TEST(Calibrate, BareSplinedNameGetsAConfiguration) {
  EXPECT_EQ(ResolveLensModel("LENSMODEL_SPLINED_STEREOGRAPHIC", 1024, 768, 1000),
            "LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=16_Ny=12_fov_x_deg=71");
  EXPECT_EQ(ResolveLensModel("LENSMODEL_OPENCV4", 1024, 768, 1000), "LENSMODEL_OPENCV4");
  EXPECT_NE(LensModel::Parse(ResolveLensModel("LENSMODEL_SPLINED_STEREOGRAPHIC", 640, 480, 300)),
            nullptr);
}

TEST(Calibrate, WritesAModelMrcalsPythonReads) {
  const BoardViews s = DatasetSetup(10);
  CalibrationResult r;
  ASSERT_TRUE(
      Calibrate(Synthesise(s, DistortedCamera(), 0.1, 7), Options("LENSMODEL_OPENCV8"), &r).ok());
  const svms_testing::ScratchDir dir("svms_calib_test");
  const std::string path = dir.File("camera.cameramodel");
  ASSERT_TRUE(r.camera.Write(path).ok());
  const std::string cmd = std::string(SVMS_PYTHON) +
                          " -c 'import mrcal,sys; m = mrcal.cameramodel(sys.argv[1]); "
                          "assert m.intrinsics()[0] == \"LENSMODEL_OPENCV8\"; "
                          "print(m.intrinsics()[1][0])' " +
                          path + " > " + path + ".out";
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  FILE* f = std::fopen((path + ".out").c_str(), "r");
  ASSERT_NE(f, nullptr);
  double fx = 0;
  ASSERT_EQ(std::fscanf(f, "%lf", &fx), 1);
  std::fclose(f);
  EXPECT_DOUBLE_EQ(fx, r.camera.intrinsics()[0]);
}

TEST(Calibrate, TooFewViews) {
  const BoardViews s = DatasetSetup(2);
  CalibrationResult r;
  const Status st =
      Calibrate(Synthesise(s, DistortedCamera(), 0.1, 8), Options("LENSMODEL_OPENCV8"), &r);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.message().find("too few views"), std::string::npos) << st.message();
}

TEST(Calibrate, AllFrontoParallelIsDegenerate) {
  BoardViews s;
  for (int i = 0; i < 8; ++i) {
    Pose p;
    // The board facing the camera, turned in its plane.
    p = Pose::FromRotation(
        Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix() *
            Eigen::AngleAxisd(0.1 * i, Eigen::Vector3d::UnitZ()).toRotationMatrix(),
        Eigen::Vector3d::Zero());
    p.tvec = Eigen::Vector3d(0.1 * (i % 3 - 1), 0.1 * (i % 2), 1.5 + 0.1 * i);
    s.cam_from_board.push_back(p);
  }
  CalibrationResult r;
  const Status st = Calibrate(Synthesise(s, CameraModel::Pinhole(1000, 1024, 1024), 0.1, 9),
                              Options("LENSMODEL_PINHOLE"), &r);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.message().find("degenerate"), std::string::npos) << st.message();
}

TEST(Calibrate, AllAtTheCentreIsDegenerateForDistortion) {
  BoardViews s = DatasetSetup(10);
  for (Pose& p : s.cam_from_board) {
    // Far away and straight ahead: the board covers only the middle of the image.
    const Eigen::Vector3d centre = p * Eigen::Vector3d::Zero();
    p.tvec += Eigen::Vector3d(-centre.x(), -centre.y(), 2.0);
  }
  CalibrationResult r;
  const Status st =
      Calibrate(Synthesise(s, DistortedCamera(), 0.1, 10), Options("LENSMODEL_OPENCV8"), &r);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.message().find("distortion cannot be determined"), std::string::npos)
      << st.message();
}

TEST(Calibrate, BoardMismatchIsReported) {
  const BoardViews s = DatasetSetup(12);
  std::vector<ViewObservations> views = Synthesise(s, DistortedCamera(), 0.1, 11);
  // The images show the 0.015 m gap board; claim a 0.03 m gap.
  const Layout wrong = MakeBoardLayout(BoardSpec{5, 6, 0.06, 0.03, 100});
  for (ViewObservations& v : views)
    for (PointObservation& p : v.points) {
      const LayoutEntry* e = wrong.Find(p.marker_id);
      p.point_in_board = e->object_from_marker * e->marker.Corners()[p.corner];
    }
  CalibrationResult r;
  const Status st = Calibrate(views, Options("LENSMODEL_OPENCV8"), &r);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.message().find("does not match"), std::string::npos) << st.message();
}

TEST(Calibrate, NonConvergenceIsReported) {
  const BoardViews s = DatasetSetup(12);
  CalibrationOptions o = Options("LENSMODEL_OPENCV8");
  o.max_iterations = 1;
  CalibrationResult r;
  const Status st = Calibrate(Synthesise(s, DistortedCamera(), 0.1, 12), o, &r);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.message().find("did not converge"), std::string::npos) << st.message();
  // Stopped after one iteration, far from any valley: no hint about one.
  EXPECT_EQ(st.message().find("rational"), std::string::npos) << st.message();
}

// The hint names the valley with the last k1 (index 4) and k4 (index 9) when both have grown,
// and only for the rational models.
TEST(Calibrate, RationalDistortionValleyHint) {
  std::vector<double> valley = {1109, 1107,  515.3, 508.7,   3.295e4, 8691,
                                6e-4, -4e-4, 3814,  3.291e4, 25097,   6219};
  const std::string h = RationalDistortionValleyHint("LENSMODEL_OPENCV8", valley);
  EXPECT_NE(h.find("LENSMODEL_OPENCV8's rational distortion"), std::string::npos) << h;
  EXPECT_NE(h.find("(now k1 = 3.295e+04, k4 = 3.291e+04)"), std::string::npos) << h;
  valley.resize(16, 0.0);  // OPENCV12: k1 k2 p1 p2 k3 k4 k5 k6 s1..s4 after the core
  EXPECT_NE(RationalDistortionValleyHint("LENSMODEL_OPENCV12", valley).find("OPENCV12"),
            std::string::npos);
  EXPECT_EQ(RationalDistortionValleyHint("LENSMODEL_OPENCV5", valley), "");
  valley.resize(12);
  valley[9] = 0.01;  // only the numerator large: a wide lens, not the valley
  EXPECT_EQ(RationalDistortionValleyHint("LENSMODEL_OPENCV8", valley), "");
  EXPECT_EQ(RationalDistortionValleyHint("LENSMODEL_OPENCV8", {1109, 1107, 515.3, 508.7}), "");
}

}  // namespace
}  // namespace svms
