#include "svms/bundle/rig_survey.h"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>

#include "svms/base/random_draws.h"
#include "svms/base/statistics.h"
#include "svms/bundle/synthetic.h"
#include "svms/geometry/so3.h"

namespace svms {
namespace {

using Vec3 = Eigen::Vector3d;

// A two-camera rig (the rig frame is camera 0's; camera 1 0.4 m to its right, turned 8 degrees
// toward it) seeing the synthetic box's markers (MakeSyntheticScene) at `frames` time steps,
// the box 2.5-3.5 m away at varied angles. The observations are exact projections plus
// Gaussian noise: corners 0.1 px, tips 0.3 px (SynthesiseImages).
struct SyntheticRig {
  Layout layout;
  CameraModel cameras[2];
  Pose rig_from_cam[2];
  std::vector<Pose> rig_from_object;
  RigSurveyOptions options;

  explicit SyntheticRig(int frames) {
    layout = MakeSyntheticScene(12, 1, 1).layout;
    cameras[0] = CameraModel::Pinhole(600, 640, 480);
    cameras[1] = CameraModel::Pinhole(450, 640, 480);
    rig_from_cam[0] = Pose{};
    rig_from_cam[1] = Pose{Vec3(0.01, -8 * M_PI / 180, 0.02), Vec3(0.4, 0.02, -0.01)};
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(-1, 1);
    for (int f = 0; f < frames; ++f) {
      // The rig sits at `eye` in the object frame, looking at the box's front.
      const Vec3 eye = Vec3(0.8, 0.6, 0.5).cwiseProduct(DrawVector3(u, rng)) + Vec3(0, 0, 3);
      const Eigen::Vector2d aim = DrawVector2(u, rng);
      const Vec3 target(0.2 + 0.1 * aim.x(), 0.1 * aim.y(), 0.5);
      rig_from_object.push_back(LookAtPose(eye, target, Vec3(0, 1, 0.1 * u(rng))));
    }
    // The fused pose's measurement model with the synthetic noise: every corner 0.1 px.
    options.measurement.corner_sigma_from_fit = false;
    options.measurement.corner_sigma_px = 0.1;
    options.measurement.corner_sigma_exponent = 0;
    options.measurement.min_tip_sigma_px = 0.3;
  }

  // The observations of every frame, noise drawn from `seed`; `layout_seen` is the layout the
  // observations are matched against (what the survey is told).
  std::vector<RigSurveyFrame> Frames(uint64_t seed, const Layout& truth, const Layout& layout_seen,
                                     const CameraModel* true_cameras = nullptr) const {
    std::vector<RigSurveyFrame> frames(rig_from_object.size());
    SyntheticOptions so;
    so.corner_sigma_px = 0.1;
    so.tip_sigma_px = 0.3;
    for (int c = 0; c < 2; ++c) {
      std::vector<std::pair<std::string, Pose>> views;
      for (size_t f = 0; f < rig_from_object.size(); ++f)
        views.emplace_back("f" + std::to_string(f), rig_from_cam[c].Inverse() * rig_from_object[f]);
      const std::vector<SurveyImage> images = SynthesiseImages(
          truth, true_cameras ? true_cameras[c] : cameras[c], views, so, seed * 2 + c);
      for (size_t f = 0; f < images.size(); ++f) {
        std::vector<MarkerObservation> obs =
            ObservationsFromDetections(images[f].detections, layout_seen);
        for (MarkerObservation& m : obs) m.camera = c;
        frames[f].timestamp = static_cast<double>(f);
        frames[f].observations.insert(frames[f].observations.end(), obs.begin(), obs.end());
      }
    }
    return frames;
  }

  std::vector<RigCameraView> Views(const Pose& start1) const {
    return {{&cameras[0], rig_from_cam[0], std::nullopt}, {&cameras[1], start1, std::nullopt}};
  }
};

TEST(SurveyRig, RecoversTheExtrinsicsWithinTheirCovariance) {
  const SyntheticRig s(8);
  const std::vector<RigSurveyFrame> frames = s.Frames(1, s.layout, s.layout);
  // The start given for camera 1 is far off: the survey starts from the cameras' own poses.
  const Pose wrong{Vec3(0, 0.3, 0), Vec3(0, 0, 0)};
  RigSurveyResult r;
  const Status st = SurveyRig(s.Views(wrong), frames, s.options, &r);
  ASSERT_TRUE(st.ok()) << st.message();
  ASSERT_EQ(r.cameras.size(), 2u);
  EXPECT_TRUE(r.cameras[0].reference);
  EXPECT_FALSE(r.cameras[0].covariance);  // none given
  EXPECT_LT(PoseError(s.rig_from_cam[0], r.cameras[0].rig_from_cam).norm(), 1e-15);
  ASSERT_TRUE(r.cameras[1].covariance);
  const PoseCovariance& C = *r.cameras[1].covariance;
  const Eigen::Matrix<double, 6, 1> e = PoseError(s.rig_from_cam[1], r.cameras[1].rig_from_cam);
  const double nees = Nees(s.rig_from_cam[1], r.cameras[1].rig_from_cam, C);
  std::printf(
      "rig survey, 8 frames: error %.4f mrad %.4f mm, sigma %.4f mrad %.4f mm, NEES %.2f, "
      "RMS %.3f sigma, chi2/dof %.3f, points %d + %d\n",
      e.head<3>().norm() * 1e3, e.tail<3>().norm() * 1e3,
      std::sqrt(C.topLeftCorner<3, 3>().trace()) * 1e3,
      std::sqrt(C.bottomRightCorner<3, 3>().trace()) * 1e3, nees, r.summary.rms_normalised,
      r.summary.variance_factor, r.cameras[0].points, r.cameras[1].points);
  EXPECT_LT(nees, ChiSquareQuantile(0.999, 6));
  // About a milliradian and a few millimetres from 8 frames of 0.1 px corners at 3 m.
  EXPECT_LT(e.head<3>().norm(), 2e-3);
  EXPECT_LT(e.tail<3>().norm(), 4e-3);
  EXPECT_EQ(r.summary.frames_used, 8);
  EXPECT_EQ(r.summary.dof, r.summary.residuals - 6 * 8 - 6);
  EXPECT_NEAR(r.summary.rms_normalised, 1, 0.15);
  for (const RigSurveyCamera& c : r.cameras) {
    EXPECT_EQ(c.frames, 8);
    EXPECT_GT(c.markers, 8);
    EXPECT_EQ(c.points_rejected, 0);
    EXPECT_NEAR(c.rms_normalised, 1, 0.2);
  }
  ASSERT_EQ(r.rig_from_object.size(), 8u);
  for (size_t f = 0; f < 8; ++f) {
    ASSERT_TRUE(r.rig_from_object[f]);
    EXPECT_LT(PoseError(s.rig_from_object[f], *r.rig_from_object[f]).tail<3>().norm(), 0.02);
  }
}

TEST(SurveyRig, NeesOfTheExtrinsicsIsInItsChiSquareBandMonteCarlo) {
  // 150 trials of 5 frames each, fresh noise per trial: the mean 6-dof NEES of camera 1's
  // rig_from_cam is in the 95 % band of chi-square(900) / 150, [5.47, 6.57].
  const auto start = std::chrono::steady_clock::now();
  const SyntheticRig s(5);
  const int trials = 150;
  double sum = 0;
  int failed = 0;
  for (int t = 0; t < trials; ++t) {
    RigSurveyResult r;
    if (!SurveyRig(s.Views(s.rig_from_cam[1]), s.Frames(100 + t, s.layout, s.layout), s.options, &r)
             .ok() ||
        !r.cameras[1].covariance) {
      ++failed;
      continue;
    }
    sum += Nees(s.rig_from_cam[1], r.cameras[1].rig_from_cam, *r.cameras[1].covariance);
  }
  EXPECT_EQ(failed, 0);
  const double mean = sum / (trials - failed);
  const double lo = ChiSquareQuantile(0.025, 6.0 * trials) / trials;
  const double hi = ChiSquareQuantile(0.975, 6.0 * trials) / trials;
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("rig survey Monte Carlo: %d trials, mean NEES %.3f, band [%.2f, %.2f], %.2f s\n",
              trials, mean, lo, hi, seconds);
  EXPECT_GT(mean, lo);
  EXPECT_LT(mean, hi);
}

TEST(SurveyRig, TheLayoutsUncertaintyIsInTheCovarianceMonteCarlo) {
  // The layout the survey is told is off by draws from its own covariance (1 mrad, 0.5 mm per
  // axis), the same in every frame: over 60 trials with fresh layout errors and noise, the
  // covariance with the layout's share gives a mean NEES in the 95 % band of
  // chi-square(360) / 60, and without that share the NEES is far above it.
  const SyntheticRig s(5);
  const int trials = 60;
  PoseCovariance L = PoseCovariance::Zero();
  L.diagonal() << 1e-6, 1e-6, 1e-6, 0.25e-6, 0.25e-6, 0.25e-6;
  const Eigen::Matrix<double, 6, 6> chol = L.llt().matrixL();
  std::mt19937_64 rng(11);
  std::normal_distribution<double> g(0, 1);
  double sum = 0, sum_without = 0;
  for (int t = 0; t < trials; ++t) {
    Layout told = s.layout;
    for (LayoutEntry& e : told.markers) {
      Eigen::Matrix<double, 6, 1> z;
      for (int i = 0; i < 6; ++i) z(i) = g(rng);
      const Eigen::Matrix<double, 6, 1> d = chol * z;
      e.object_from_marker = Pose::FromRotation(Exp(d.head<3>()) * e.object_from_marker.Rotation(),
                                                e.object_from_marker.tvec + d.tail<3>());
      e.covariance = L;
    }
    RigSurveyResult r;
    ASSERT_TRUE(
        SurveyRig(s.Views(s.rig_from_cam[1]), s.Frames(500 + t, s.layout, told), s.options, &r)
            .ok())
        << r.summary.message;
    ASSERT_TRUE(r.summary.layout_in_covariance);
    sum += Nees(s.rig_from_cam[1], r.cameras[1].rig_from_cam, *r.cameras[1].covariance);
    RigSurveyOptions without = s.options;
    without.measurement.use_layout_covariance = false;
    RigSurveyResult r2;
    ASSERT_TRUE(
        SurveyRig(s.Views(s.rig_from_cam[1]), s.Frames(500 + t, s.layout, told), without, &r2)
            .ok());
    sum_without += Nees(s.rig_from_cam[1], r2.cameras[1].rig_from_cam, *r2.cameras[1].covariance);
  }
  const double mean = sum / trials, mean_without = sum_without / trials;
  const double lo = ChiSquareQuantile(0.025, 6.0 * trials) / trials;
  const double hi = ChiSquareQuantile(0.975, 6.0 * trials) / trials;
  std::printf(
      "rig survey with layout errors: mean NEES %.3f (band [%.2f, %.2f]); %.3f without "
      "the layout's share\n",
      mean, lo, hi, mean_without);
  EXPECT_GT(mean, lo);
  EXPECT_LT(mean, hi);
  EXPECT_GT(mean_without, hi);
}

TEST(SurveyRig, TheCalibrationsUncertaintyIsInTheCovarianceMonteCarlo) {
  // The cameras the frames come from differ from the models the survey is given by draws from
  // the models' own calibration covariance (1 px on the focal lengths, 0.5 px on the centre),
  // the same in every frame: over 80 trials the mean NEES with the calibration's share is in the
  // 95 % band of chi-square(480) / 80, and far above it without.
  SyntheticRig s(5);
  const Eigen::MatrixXd L = Eigen::Vector4d(1, 1, 0.5, 0.5).asDiagonal();
  for (CameraModel& c : s.cameras) ASSERT_TRUE(c.set_intrinsics_covariance_factor(L).ok());
  const int trials = 80;
  std::mt19937_64 rng(14);
  std::normal_distribution<double> g(0, 1);
  double sum = 0, sum_without = 0;
  RigSurveyOptions without = s.options;
  without.measurement.use_calibration_covariance = false;
  for (int t = 0; t < trials; ++t) {
    CameraModel truth[2];
    for (int c = 0; c < 2; ++c) {
      std::vector<double> k = s.cameras[c].intrinsics();
      for (int i = 0; i < 4; ++i) k[i] += L(i, i) * g(rng);
      ASSERT_TRUE(CameraModel::Create("LENSMODEL_PINHOLE", k, 640, 480, &truth[c]).ok());
    }
    const std::vector<RigSurveyFrame> frames = s.Frames(700 + t, s.layout, s.layout, truth);
    RigSurveyResult r, r2;
    ASSERT_TRUE(SurveyRig(s.Views(s.rig_from_cam[1]), frames, s.options, &r).ok())
        << r.summary.message;
    ASSERT_TRUE(r.summary.calibration_in_covariance);
    sum += Nees(s.rig_from_cam[1], r.cameras[1].rig_from_cam, *r.cameras[1].covariance);
    ASSERT_TRUE(SurveyRig(s.Views(s.rig_from_cam[1]), frames, without, &r2).ok());
    EXPECT_FALSE(r2.summary.calibration_in_covariance);
    sum_without += Nees(s.rig_from_cam[1], r2.cameras[1].rig_from_cam, *r2.cameras[1].covariance);
  }
  const double mean = sum / trials, mean_without = sum_without / trials;
  const double lo = ChiSquareQuantile(0.025, 6.0 * trials) / trials;
  const double hi = ChiSquareQuantile(0.975, 6.0 * trials) / trials;
  std::printf(
      "rig survey with calibration errors: mean NEES %.3f (band [%.2f, %.2f]); %.3f "
      "without the calibration's share\n",
      mean, lo, hi, mean_without);
  EXPECT_GT(mean, lo);
  EXPECT_LT(mean, hi);
  EXPECT_GT(mean_without, hi);
}

TEST(SurveyRig, TheReferenceCamerasCovarianceMovesTheOthers) {
  const SyntheticRig s(4);
  const std::vector<RigSurveyFrame> frames = s.Frames(3, s.layout, s.layout);
  std::vector<RigCameraView> views = s.Views(s.rig_from_cam[1]);
  RigSurveyResult plain, with;
  ASSERT_TRUE(SurveyRig(views, frames, s.options, &plain).ok());
  PoseCovariance ref = PoseCovariance::Identity() * 1e-6;
  views[0].rig_from_cam_covariance = ref;
  ASSERT_TRUE(SurveyRig(views, frames, s.options, &with).ok());
  EXPECT_TRUE(with.summary.reference_in_covariance);
  ASSERT_TRUE(with.cameras[0].covariance);
  EXPECT_EQ(*with.cameras[0].covariance, ref);
  // Camera 1 is 0.4 m from the reference: a 1 mrad sigma about the rig axes moves it by 0.4 mm.
  const PoseCovariance d = *with.cameras[1].covariance - *plain.cameras[1].covariance;
  EXPECT_NEAR(d(0, 0), 1e-6, 1e-12);
  EXPECT_NEAR(d(3, 3), 1e-6 * (1 + 0.02 * 0.02 + 0.01 * 0.01), 1e-9);
  EXPECT_NEAR(d(4, 4), 1e-6 * (1 + 0.4 * 0.4 + 0.01 * 0.01), 1e-9);
}

TEST(SurveyRig, ACameraNeverSeenWithAnotherIsAnErrorNamingIt) {
  const SyntheticRig s(4);
  std::vector<RigSurveyFrame> frames = s.Frames(5, s.layout, s.layout);
  // Camera 0 sees the first two frames, camera 1 the last two only.
  for (size_t f = 0; f < frames.size(); ++f) {
    std::vector<MarkerObservation>& obs = frames[f].observations;
    obs.erase(
        std::remove_if(obs.begin(), obs.end(),
                       [&](const MarkerObservation& m) { return (f < 2) != (m.camera == 0); }),
        obs.end());
  }
  RigSurveyResult r;
  const Status st = SurveyRig(s.Views(s.rig_from_cam[1]), frames, s.options, &r);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.message().find("camera 1"), std::string::npos) << st.message();
  EXPECT_EQ(r.summary.message, st.message());
  // A rig of one camera has no extrinsics to survey: an error, not a crash.
  std::vector<RigCameraView> one = s.Views(s.rig_from_cam[1]);
  one.resize(1);
  const Status lone = SurveyRig(one, frames, s.options, &r);
  EXPECT_FALSE(lone.ok());
  EXPECT_NE(lone.message().find("at least 2"), std::string::npos) << lone.message();
  // An observation naming a camera the rig does not have.
  frames[0].observations[0].camera = 5;
  EXPECT_NE(
      SurveyRig(s.Views(s.rig_from_cam[1]), frames, s.options, &r).message().find("names camera 5"),
      std::string::npos);
}

}  // namespace
}  // namespace svms
