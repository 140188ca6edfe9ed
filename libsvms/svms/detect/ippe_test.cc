#include "svms/detect/ippe.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <random>
#include <vector>

#include "svms/base/random_draws.h"
#include "svms/geometry/pose.h"

namespace svms {
namespace {

using Corners = std::array<Eigen::Vector2d, 4>;

// cv::solvePnPGeneric(SOLVEPNP_IPPE_SQUARE) called as EstimateMarkerPose calls it (identity
// intrinsics, normalized points), plus its reprojectionError output.
struct OpenCvResult {
  int n = 0;
  Eigen::Vector3d rvec[2], t[2];
  Eigen::Matrix3d R[2];  // Rodrigues(rvec)
  double err[2] = {0, 0};
  bool Finite() const {
    for (int i = 0; i < n; ++i)
      if (!rvec[i].allFinite() || !t[i].allFinite()) return false;
    return true;
  }
};

OpenCvResult RunOpenCv(const Corners& p, double s) {
  const std::vector<cv::Point3d> object = {
      {-s / 2, s / 2, 0}, {s / 2, s / 2, 0}, {s / 2, -s / 2, 0}, {-s / 2, -s / 2, 0}};
  std::vector<cv::Point2d> normalized;
  for (const auto& q : p) normalized.emplace_back(q.x(), q.y());
  std::vector<cv::Mat> rvecs, tvecs;
  cv::Mat err;
  OpenCvResult r;
  r.n = cv::solvePnPGeneric(object, normalized, cv::Matx33d::eye(), cv::noArray(), rvecs, tvecs,
                            false, cv::SOLVEPNP_IPPE_SQUARE, cv::noArray(), cv::noArray(), err);
  for (int i = 0; i < r.n; ++i) {
    cv::Matx33d R;
    cv::Rodrigues(rvecs[i], R);
    for (int a = 0; a < 3; ++a) {
      for (int b = 0; b < 3; ++b) r.R[i](a, b) = R(a, b);
      r.rvec[i](a) = rvecs[i].at<double>(a);
      r.t[i](a) = tvecs[i].at<double>(a);
    }
    r.err[i] = err.at<double>(i);
  }
  return r;
}

// OpenCV's PoseSolver::rot2vec (ippe.cpp), the rotation vector solvePnPGeneric returns: applied
// to our rotation it must give OpenCV's rvec if the two rotation matrices are the same.
Eigen::Vector3d OpenCvRot2Vec(const Eigen::Matrix3d& R) {
  const double trace = R(0, 0) + R(1, 1) + R(2, 2);
  const double w = std::acos((trace - 1.0) / 2.0);
  const double d = 1 / (2 * std::sin(w)) * w;
  if (w < std::numeric_limits<float>::epsilon()) return Eigen::Vector3d::Zero();
  return d * Eigen::Vector3d(R(2, 1) - R(1, 2), R(0, 2) - R(2, 0), R(1, 0) - R(0, 1));
}

// How far the rotation angle is from pi. OpenCV's rot2vec loses accuracy there (its error
// grows like 1e-17 / gap^2 in this test set), and a marker facing the camera is a half-turn.
double GapToPi(const Eigen::Matrix3d& R) { return M_PI - Eigen::AngleAxisd(R).angle(); }

std::array<Eigen::Vector3d, 4> SquareCorners(double s) {
  const double h = s / 2;
  return {Eigen::Vector3d(-h, h, 0), Eigen::Vector3d(h, h, 0), Eigen::Vector3d(h, -h, 0),
          Eigen::Vector3d(-h, -h, 0)};
}

Corners Project(const Eigen::Matrix3d& R, const Eigen::Vector3d& t, double s) {
  Corners p;
  const auto X = SquareCorners(s);
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector3d c = R * X[k] + t;
    p[k] = c.head<2>() / c.z();
  }
  return p;
}

double Rms(const Corners& p, const Eigen::Matrix3d& R, const Eigen::Vector3d& t, double s) {
  const Corners q = Project(R, t, s);
  double ss = 0;
  for (int k = 0; k < 4; ++k) ss += (q[k] - p[k]).squaredNorm();
  return std::sqrt(ss / 8);
}

// An upright marker facing the camera: marker x -> camera x, y -> -y, z -> -z.
Eigen::Matrix3d Facing() { return Eigen::Vector3d(1, -1, -1).asDiagonal(); }

struct Sample {
  Corners p;
  double side;
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
  double tilt;   // between the marker's normal and the line of sight, radians
  bool visible;  // corners 0.1 m or more in front, within |x|,|y| <= 1, sides >= 0.01
};

// Side 0.01-0.5 m and distance 0.3-20 m (log-uniform), centre within 30 degrees of the optical
// axis, the normal `tilt` from the line of sight (uniform 0-80 degrees if negative) about a
// random axis, any roll; Gaussian noise of `noise` (normalized units) on each coordinate.
Sample RandomSample(std::mt19937_64& rng, double noise, double tilt = -1) {
  std::uniform_real_distribution<double> u(0, 1);
  Sample o;
  o.side = std::exp(std::log(0.01) + u(rng) * std::log(50.0));
  const double distance = std::exp(std::log(0.3) + u(rng) * std::log(20 / 0.3));
  const double off = u(rng) * 30 * M_PI / 180, azimuth = u(rng) * 2 * M_PI;
  const Eigen::Vector3d dir(std::sin(off) * std::cos(azimuth), std::sin(off) * std::sin(azimuth),
                            std::cos(off));
  o.t = distance * dir;
  const Eigen::Matrix3d face =
      Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d(0, 0, -1), -dir).toRotationMatrix();
  o.tilt = tilt >= 0 ? tilt : u(rng) * 80 * M_PI / 180;
  const double axis_angle = u(rng) * 2 * M_PI, roll = u(rng) * 2 * M_PI;
  const Eigen::Vector3d axis =
      (face * Eigen::Vector3d(std::cos(axis_angle), std::sin(axis_angle), 0)).normalized();
  o.R = Eigen::AngleAxisd(o.tilt, axis).toRotationMatrix() * face * Facing() *
        Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  o.visible = true;
  const auto X = SquareCorners(o.side);
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector3d c = o.R * X[k] + o.t;
    if (c.z() < 0.1) o.visible = false;
    o.p[k] = c.head<2>() / c.z();
    if (o.p[k].cwiseAbs().maxCoeff() > 1) o.visible = false;
  }
  for (int k = 0; k < 4; ++k)
    if ((o.p[k] - o.p[(k + 1) % 4]).norm() < 0.01) o.visible = false;
  std::normal_distribution<double> g(0, noise > 0 ? noise : 1);
  if (noise > 0)
    for (auto& q : o.p) q += DrawVector2(g, rng);
  return o;
}

// Which of OpenCV's two solutions is our candidate k: the one with the nearer translation
// (translations do not go through rot2vec, and agree exactly).
int Match(const std::array<PlanarPoseCandidate, 2>& o, int k, const OpenCvResult& cv) {
  return (o[k].cam_from_marker_t - cv.t[0]).norm() <= (o[k].cam_from_marker_t - cv.t[1]).norm() ? 0
                                                                                                : 1;
}

// Noise of 0, 0.5 and 2 pixels at a focal length of 1000 pixels.
class RandomPoses : public ::testing::TestWithParam<double> {};

TEST_P(RandomPoses, AgreeWithOpenCv) {
  const double noise = GetParam();
  std::mt19937_64 rng(20240611);
  int compared = 0, near_pi = 0;
  double max_dt = 0, max_drvec = 0, max_dR = 0, max_derr = 0;
  while (compared < 4000) {
    const Sample s = RandomSample(rng, noise);
    if (!s.visible) continue;
    const OpenCvResult cv = RunOpenCv(s.p, s.side);
    std::array<PlanarPoseCandidate, 2> o;
    IppeStatus status;
    ASSERT_TRUE(SolveSquareIppe(s.p, s.side, &o, &status)) << IppeStatusName(status);
    ASSERT_EQ(cv.n, 2);
    ASSERT_TRUE(cv.Finite());
    ++compared;
    // Same order.
    EXPECT_EQ(Match(o, 0, cv), 0);
    for (int k = 0; k < 2; ++k) {
      const PlanarPoseCandidate& c = o[k];
      const double dt = (c.cam_from_marker_t - cv.t[k]).cwiseAbs().maxCoeff();
      EXPECT_LE(dt, 1e-12 * (1 + cv.t[k].norm()));
      max_dt = std::max(max_dt, dt);
      // The same rotation matrix as OpenCV's before its conversion to a rotation vector.
      const double drvec = (OpenCvRot2Vec(c.cam_from_marker_R) - cv.rvec[k]).cwiseAbs().maxCoeff();
      EXPECT_LE(drvec, 1e-9);
      max_drvec = std::max(max_drvec, drvec);
      // And the rotation OpenCV returns, where its rvec is accurate: rot2vec amplifies the
      // departure of IPPE's matrix from orthonormality (up to ~1e-11 here) by ~1 / gap^2.
      const double gap = GapToPi(c.cam_from_marker_R);
      if (gap < 1e-2) {
        ++near_pi;
        continue;
      }
      const double tol = 1e-9 * std::max(1.0, 0.01 / (gap * gap));
      const double dR = (c.cam_from_marker_R - cv.R[k]).cwiseAbs().maxCoeff();
      EXPECT_LE(dR, tol);
      if (gap >= 0.1) max_dR = std::max(max_dR, dR);
      // OpenCV computes its error from its rvec.
      const double derr = std::abs(c.reprojection_error - cv.err[k]);
      EXPECT_LE(derr, tol);
      if (gap >= 0.1) max_derr = std::max(max_derr, derr);
      // The error is what it says.
      EXPECT_NEAR(c.reprojection_error, Rms(s.p, c.cam_from_marker_R, c.cam_from_marker_t, s.side),
                  1e-12 + 1e-9 * c.reprojection_error);
    }
    // On exact data the first is the truth: to rounding, except within a degree of the view
    // where the two coincide (IPPE's rotation there is only ~sqrt(rounding) accurate).
    if (noise == 0) {
      const double tol = s.tilt > M_PI / 180 ? 1e-8 : 1e-3;
      EXPECT_LE((o[0].cam_from_marker_R - s.R).cwiseAbs().maxCoeff(), tol);
      EXPECT_LE((o[0].cam_from_marker_t - s.t).norm(), 1e-6 * s.t.norm());
      EXPECT_LE(o[0].reprojection_error, 1e-8 * s.side / s.t.norm());
      EXPECT_TRUE(o[0].in_front);
    }
  }
  EXPECT_LE(near_pi, compared / 20);
  // Shown by --gtest_output=xml (max_dR and max_derr: at least 0.1 rad from pi).
  auto record = [&](const char* key, double v) {
    char text[32];
    std::snprintf(text, sizeof text, "%.3g", v);
    RecordProperty(key, text);
  };
  record("max_dt", max_dt);
  record("max_drvec", max_drvec);
  record("max_dR", max_dR);
  record("max_derr", max_derr);
  RecordProperty("near_pi", near_pi);
}

INSTANTIATE_TEST_SUITE_P(Noise, RandomPoses, ::testing::Values(0.0, 5e-4, 2e-3));

// The whole ranges, including squares partly behind the camera, off the image or far below a
// pixel, with noise up to their size: where OpenCV gives up we do (and only there, apart from
// degenerate quadrilaterals), and where both answer they agree.
TEST(IppeSquare, AgreesWithOpenCvOnUnrestrictedSamples) {
  std::mt19937_64 rng(7);
  int both = 0, rejected_like_opencv = 0;
  for (int i = 0; i < 6000; ++i) {
    const Sample s = RandomSample(rng, i % 3 == 0 ? 0 : i % 3 == 1 ? 5e-4 : 2e-3);
    const OpenCvResult cv = RunOpenCv(s.p, s.side);
    std::array<PlanarPoseCandidate, 2> o;
    IppeStatus status;
    const bool ok = SolveSquareIppe(s.p, s.side, &o, &status);
    EXPECT_EQ(cv.n == 0, status == IppeStatus::kBelowOpenCvDeterminant) << IppeStatusName(status);
    if (cv.n == 0) ++rejected_like_opencv;
    if (!ok) {
      EXPECT_TRUE(status == IppeStatus::kBelowOpenCvDeterminant ||
                  status == IppeStatus::kDegenerate)
          << IppeStatusName(status);
      continue;
    }
    ASSERT_EQ(cv.n, 2);
    if (!cv.Finite()) continue;  // OpenCV's NaN where the two solutions coincide
    ++both;
    for (int k = 0; k < 2; ++k) {
      EXPECT_TRUE(o[k].cam_from_marker_R.allFinite() && o[k].cam_from_marker_t.allFinite());
      EXPECT_TRUE(std::isfinite(o[k].reprojection_error));
      const int j = Match(o, k, cv);
      if (GapToPi(o[k].cam_from_marker_R) > 1e-2) {
        EXPECT_EQ(j, k);
      }
      EXPECT_LE((o[k].cam_from_marker_t - cv.t[j]).cwiseAbs().maxCoeff(),
                1e-12 * (1 + cv.t[j].norm()));
      EXPECT_LE((OpenCvRot2Vec(o[k].cam_from_marker_R) - cv.rvec[j]).cwiseAbs().maxCoeff(), 1e-9);
    }
  }
  EXPECT_GT(both, 5000);
  EXPECT_GT(rejected_like_opencv, 0);
}

TEST(IppeSquare, FrontoParallelOnAxisKnownAnswer) {
  // A 0.1 m square facing the camera 1 m ahead: the two IPPE solutions coincide.
  const Corners p = {Eigen::Vector2d(-0.05, -0.05), Eigen::Vector2d(0.05, -0.05),
                     Eigen::Vector2d(0.05, 0.05), Eigen::Vector2d(-0.05, 0.05)};
  std::array<PlanarPoseCandidate, 2> o;
  ASSERT_TRUE(SolveSquareIppe(p, 0.1, &o));
  for (const auto& c : o) {
    EXPECT_LE((c.cam_from_marker_R - Facing()).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_LE((c.cam_from_marker_t - Eigen::Vector3d(0, 0, 1)).norm(), 1e-12);
    EXPECT_LE(c.reprojection_error, 1e-15);
    EXPECT_TRUE(c.in_front);
  }
  // OpenCV has the same translations; its rotation vectors here are (0, 0, 0), the identity (its
  // rot2vec at an angle of exactly pi), hence its reprojection errors of 0.07.
  const OpenCvResult cv = RunOpenCv(p, 0.1);
  ASSERT_EQ(cv.n, 2);
  for (int k = 0; k < 2; ++k) EXPECT_LE((cv.t[k] - Eigen::Vector3d(0, 0, 1)).norm(), 1e-12);
}

TEST(IppeSquare, FrontoParallelOffAxisKnownAnswer) {
  const Eigen::Vector3d t(0.2, -0.1, 2);
  const Corners p = Project(Facing(), t, 0.1);
  std::array<PlanarPoseCandidate, 2> o;
  ASSERT_TRUE(SolveSquareIppe(p, 0.1, &o));
  EXPECT_LE((o[0].cam_from_marker_R - Facing()).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LE((o[0].cam_from_marker_t - t).norm(), 1e-12);
  EXPECT_LE(o[0].reprojection_error, 1e-15);
  EXPECT_GT(o[1].reprojection_error, 1e-5);
  // OpenCV finds the same two poses but lists this one second, with a meaningless rvec: its
  // rot2vec is ill-conditioned at an angle of pi, and it sorts by the error of that rvec.
  const OpenCvResult cv = RunOpenCv(p, 0.1);
  ASSERT_EQ(cv.n, 2);
  EXPECT_LE((cv.t[1] - t).norm(), 1e-12);
  EXPECT_LE((cv.t[0] - o[1].cam_from_marker_t).norm(), 1e-12);
}

TEST(IppeSquare, TiltedKnownAnswer) {
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(0.5, Eigen::Vector3d(0.3, 1, 0.1).normalized()).toRotationMatrix() *
      Facing();
  const Eigen::Vector3d t(0.05, -0.02, 1.5);
  const Corners p = Project(R, t, 0.16);
  std::array<PlanarPoseCandidate, 2> o;
  IppeStatus status;
  ASSERT_TRUE(SolveSquareIppe(p, 0.16, &o, &status));
  EXPECT_EQ(status, IppeStatus::kOk);
  EXPECT_LE((o[0].cam_from_marker_R - R).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LE((o[0].cam_from_marker_t - t).norm(), 1e-12);
  EXPECT_LE(o[0].reprojection_error, 1e-15);
  // The other: a distinct pose (the flip about the line of sight), also in front.
  EXPECT_GT((o[1].cam_from_marker_R - R).norm(), 0.1);
  EXPECT_TRUE(o[0].in_front && o[1].in_front);
  const OpenCvResult cv = RunOpenCv(p, 0.16);
  ASSERT_EQ(cv.n, 2);
  for (int k = 0; k < 2; ++k) {
    EXPECT_LE((o[k].cam_from_marker_R - cv.R[k]).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_LE((o[k].cam_from_marker_t - cv.t[k]).norm(), 1e-14);
  }
}

// The normal along the line of sight (or within 1e-6 rad of it), where the two solutions
// coincide: OpenCV returns NaN for a few percent of these (the square root of a negative
// rounding error in computeRotations), we never do.
TEST(IppeSquare, NearFrontoParallel) {
  std::mt19937_64 rng(11);
  int opencv_nan = 0, n = 0;
  for (double tilt : {0.0, 1e-9, 1e-6}) {
    for (int i = 0; i < 1000; ++i) {
      const Sample s = RandomSample(rng, 0, tilt);
      if (!s.visible) continue;
      ++n;
      std::array<PlanarPoseCandidate, 2> o;
      IppeStatus status;
      ASSERT_TRUE(SolveSquareIppe(s.p, s.side, &o, &status)) << IppeStatusName(status);
      for (const auto& c : o) {
        EXPECT_LE((c.cam_from_marker_R - s.R).cwiseAbs().maxCoeff(), 1e-3);
        EXPECT_LE((c.cam_from_marker_t - s.t).norm(), 1e-6 * s.t.norm());
        EXPECT_LE(c.reprojection_error, 1e-6 * s.side / s.t.norm());
        EXPECT_TRUE(c.in_front);
      }
      const OpenCvResult cv = RunOpenCv(s.p, s.side);
      ASSERT_EQ(cv.n, 2);
      if (!cv.Finite()) {
        ++opencv_nan;
        continue;
      }
      for (int k = 0; k < 2; ++k)
        EXPECT_LE((o[k].cam_from_marker_t - cv.t[Match(o, k, cv)]).norm(), 1e-12 * s.t.norm());
    }
  }
  EXPECT_GT(n, 1000);
  RecordProperty("opencv_nan", opencv_nan);
}

TEST(IppeSquare, DegenerateInputsReturnFalse) {
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 0.2, 0).normalized()).toRotationMatrix() * Facing();
  const Corners good = Project(R, Eigen::Vector3d(0.1, 0.05, 2), 0.1);
  std::array<PlanarPoseCandidate, 2> sentinel;
  sentinel[0].reprojection_error = sentinel[1].reprojection_error = 123;
  auto expect = [&](const Corners& p, double side, IppeStatus want) {
    std::array<PlanarPoseCandidate, 2> o = sentinel;
    IppeStatus status;
    EXPECT_FALSE(SolveSquareIppe(p, side, &o, &status));
    EXPECT_EQ(status, want) << IppeStatusName(status) << " want " << IppeStatusName(want);
    EXPECT_EQ(o[0].reprojection_error, 123);  // untouched
    EXPECT_EQ(o[1].reprojection_error, 123);
    EXPECT_FALSE(SolveSquareIppe(p, side, &o));  // status is optional
  };
  Corners p = good;
  for (auto& q : p) q = good[0];
  expect(p, 0.1, IppeStatus::kBelowOpenCvDeterminant);  // all equal (OpenCV: no solution)
  p = good;
  p[2] = p[1] + 0.5 * (p[1] - p[0]);
  expect(p, 0.1, IppeStatus::kDegenerate);  // 0, 1, 2 collinear
  p = good;
  p[3] = 0.5 * (p[0] + p[2]);
  expect(p, 0.1, IppeStatus::kDegenerate);  // 3 on the diagonal 0-2
  p = good;
  p[3] = p[0];
  expect(p, 0.1, IppeStatus::kDegenerate);  // two coincide
  p = good;
  p[1] = p[0] + 1e-12 * Eigen::Vector2d(1, 2);
  expect(p, 0.1, IppeStatus::kDegenerate);  // two nearly coincide
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 4; ++k)
    for (int c = 0; c < 2; ++c) {
      p = good;
      p[k](c) = nan;
      expect(p, 0.1, IppeStatus::kNonFiniteInput);
      p[k](c) = -inf;
      expect(p, 0.1, IppeStatus::kNonFiniteInput);
    }
  for (double side : {0.0, -0.1, nan, inf}) expect(good, side, IppeStatus::kInvalidSide);

  // Where OpenCV returns NaN or meaningless poses rather than nothing: NaN input, three
  // collinear corners.
  p = good;
  p[1].x() = nan;
  EXPECT_EQ(RunOpenCv(p, 0.1).n, 2);
  EXPECT_FALSE(RunOpenCv(p, 0.1).Finite());
}

TEST(IppeSquare, TinyDistantSquareIsRejectedLikeOpenCv) {
  // 1 cm at 40 m: |s/2 cross(diagonals)| ~ s^3 / Z^2 = 6e-10 < 1e-9, OpenCV's threshold.
  const Corners p = Project(Facing(), Eigen::Vector3d(0.3, 0.2, 40), 0.01);
  std::array<PlanarPoseCandidate, 2> o;
  IppeStatus status;
  EXPECT_FALSE(SolveSquareIppe(p, 0.01, &o, &status));
  EXPECT_EQ(status, IppeStatus::kBelowOpenCvDeterminant);
  EXPECT_EQ(RunOpenCv(p, 0.01).n, 0);
  // The threshold is in the units of the side: the same view in millimetres passes.
  std::array<Eigen::Vector2d, 4> same = p;
  EXPECT_TRUE(SolveSquareIppe(same, 10.0, &o));
  EXPECT_LE((o[0].cam_from_marker_t - Eigen::Vector3d(300, 200, 40000)).norm(), 1e-6 * 40000);
}

TEST(IppeSquare, BehindTheCamera) {
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(0.6, Eigen::Vector3d(1, 0.3, 0).normalized()).toRotationMatrix() * Facing();
  const Eigen::Vector3d t(0.1, 0.05, 2);
  // The whole square behind the camera: its image is that of the square in front turned by a
  // half-turn in its plane (corner k where corner k + 2 was), which is what comes back.
  const Corners behind = Project(R, -t, 0.1);
  std::array<PlanarPoseCandidate, 2> o;
  ASSERT_TRUE(SolveSquareIppe(behind, 0.1, &o));
  const Eigen::Matrix3d half_turn = Eigen::Vector3d(-1, -1, 1).asDiagonal();
  EXPECT_LE((o[0].cam_from_marker_R - R * half_turn).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LE((o[0].cam_from_marker_t - t).norm(), 1e-12);
  EXPECT_TRUE(o[0].in_front);

  // Corners 1 and 2 swapped: a self-intersecting quadrilateral, no square in front of the
  // camera. Both candidates (as OpenCV's) put corners behind it, which in_front says.
  Corners bowtie = Project(R, t, 0.1);
  std::swap(bowtie[1], bowtie[2]);
  ASSERT_TRUE(SolveSquareIppe(bowtie, 0.1, &o));
  const OpenCvResult cv = RunOpenCv(bowtie, 0.1);
  ASSERT_EQ(cv.n, 2);
  for (int k = 0; k < 2; ++k) {
    EXPECT_FALSE(o[k].in_front);
    EXPECT_LE((o[k].cam_from_marker_t - cv.t[k]).norm(), 1e-12);
    EXPECT_LE((o[k].cam_from_marker_R - cv.R[k]).cwiseAbs().maxCoeff(), 1e-9);
  }
}

TEST(IppeSquare, BothSolutionsReprojectTheCorners) {
  // The planar ambiguity: a 5 cm square 4 m away, 35 degrees from facing the camera, with 0.5 px
  // of noise at f = 1000 px (15 px across): both candidates explain the corners about equally.
  std::mt19937_64 rng(3);
  std::normal_distribution<double> g(0, 5e-4);
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(35 * M_PI / 180, Eigen::Vector3d(0.2, 1, 0).normalized())
          .toRotationMatrix() *
      Facing();
  const Eigen::Vector3d t(0.3, -0.2, 4);
  for (int trial = 0; trial < 20; ++trial) {
    Corners p = Project(R, t, 0.05);
    for (auto& q : p) q += DrawVector2(g, rng);
    std::array<PlanarPoseCandidate, 2> o;
    ASSERT_TRUE(SolveSquareIppe(p, 0.05, &o));
    EXPECT_LE(o[0].reprojection_error, o[1].reprojection_error);
    for (const auto& c : o) {
      EXPECT_TRUE(c.in_front);
      EXPECT_NEAR(c.reprojection_error, Rms(p, c.cam_from_marker_R, c.cam_from_marker_t, 0.05),
                  1e-15);
      const Corners q = Project(c.cam_from_marker_R, c.cam_from_marker_t, 0.05);
      for (int k = 0; k < 4; ++k) EXPECT_LE((q[k] - p[k]).norm(), 4e-3);  // 4 px
    }
    EXPECT_GT(AngleBetweenRad(o[0].cam_from_marker_R, o[1].cam_from_marker_R), 0.2);
  }
}

TEST(IppeSquare, StatusNames) {
  EXPECT_STREQ(IppeStatusName(IppeStatus::kOk), "ok");
  EXPECT_STREQ(IppeStatusName(IppeStatus::kDegenerate), "degenerate quadrilateral");
  EXPECT_STREQ(IppeStatusName(IppeStatus::kBelowOpenCvDeterminant),
               "determinant below OpenCV's threshold");
}

// The twin is what IPPE returns as the other solution for a small, distant, tilted square.
TEST(PlanarTwin, IsIppesOtherSolution) {
  Pose truth;
  truth.tvec = Eigen::Vector3d(0.8, -0.5, 15);
  truth.rvec = Eigen::Vector3d(M_PI, 0, 0) + Eigen::Vector3d(0.25, 0.2, 0.1);
  const cv::Matx33d K(1000, 0, 512, 0, 1000, 512, 0, 0, 1);
  const double s = 0.05;
  std::vector<cv::Point3d> object = {{-s, s, 0}, {s, s, 0}, {s, -s, 0}, {-s, -s, 0}};
  std::vector<cv::Point2d> image;
  cv::projectPoints(object, cv::Vec3d(truth.rvec.data()), cv::Vec3d(truth.tvec.data()), K,
                    cv::noArray(), image);
  std::vector<cv::Mat> rvecs, tvecs;
  ASSERT_EQ(cv::solvePnPGeneric(object, image, K, cv::noArray(), rvecs, tvecs, false,
                                cv::SOLVEPNP_IPPE_SQUARE),
            2);
  const Eigen::Matrix3d twin = PlanarTwin(truth).Rotation();
  const double apart = AngleBetweenDeg(twin, truth.Rotation());
  EXPECT_GT(apart, 20);  // twice the view angle
  double to_truth = 1e9, to_twin = 1e9;
  for (const cv::Mat& r : rvecs) {
    Pose p;
    p.rvec = Eigen::Vector3d(r.at<double>(0), r.at<double>(1), r.at<double>(2));
    to_truth = std::min(to_truth, AngleBetweenDeg(p, truth));
    to_twin = std::min(to_twin, AngleBetweenDeg(p.Rotation(), twin));
  }
  EXPECT_LT(to_truth, 1e-6);
  EXPECT_LT(to_twin, 0.5);  // weak perspective: exact only at infinite distance
}

}  // namespace
}  // namespace svms
