#include "svms/bundle/survey.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <random>

#include "svms/base/random_draws.h"
#include "svms/bundle/synthetic.h"
#include "svms/bundle/view_graph.h"
#include "svms/datasets/datasets.h"
#include "svms/geometry/pose.h"
#include "svms/marker/model_io.h"

namespace svms {
namespace {

// A synthetic object (synthetic.h) of 8 markers whose first is a dual marker 100 / 150 with a
// shared post, and marker 104 a concave well; 150 camera poses; the distorted 1024 x 1024
// camera of the datasets.
struct TestObject {
  Layout truth;
  std::vector<std::pair<std::string, Pose>> cam_from_object;
  CameraModel camera = DistortedCamera();
  std::vector<MarkerModel> models;  // as drawn: the models of the true layout
};

TestObject MakeTestObject(int views = 150) {
  TestObject m;
  SyntheticScene s = MakeSyntheticScene(8, views, 1);
  // 0.2 m (printed 0.4 m) so that it stays clear of marker 105 on the same face whatever their
  // spins (Layout::Validate refuses overlapping markers).
  MarkerModel dual = MarkerModel::Standard(100, 0.2, 0.25 * 0.05);
  dual.AddInner(150, 0.05);
  dual.post->radius = dual.post->tip_radius = 0.05 / 20;
  s.layout.markers[0].marker = dual;
  m.truth = s.layout;
  m.cam_from_object = s.cam_from_object;
  for (const LayoutEntry& e : m.truth.markers) m.models.push_back(e.marker);
  return m;
}

// object_from_marker of `id` in `layout` (inner markers share the outer's pose).
Pose TruePose(const Layout& layout, int id) {
  const LayoutEntry* e = layout.Find(id);
  EXPECT_NE(e, nullptr) << id;
  return e ? e->object_from_marker : Pose();
}

// The pose error [rotation (left, object axes), translation] of an estimate.
Eigen::Matrix<double, 6, 1> PoseError(const Pose& estimate, const Pose& truth) {
  Eigen::Matrix<double, 6, 1> e;
  e << Log(estimate.Rotation() * truth.Rotation().transpose()), estimate.tvec - truth.tvec;
  return e;
}

// The sum of the NEES of every surveyed marker but the reference (zero covariance) against
// `truth` (in the reference's frame); *count (if given) grows by the number of markers summed.
double SumNees(const SurveyResult& r, const Layout& truth, int* count) {
  double sum = 0;
  for (const LayoutEntry& e : r.layout.markers) {
    if (!e.covariance || e.covariance->isZero()) continue;
    const Eigen::Matrix<double, 6, 1> err =
        PoseError(e.object_from_marker, TruePose(truth, e.marker.id));
    sum += err.dot(e.covariance->ldlt().solve(err));
    if (count) ++*count;
  }
  return sum;
}

// Expects every surveyed marker within its covariance: NEES below the chi-square(6) 99.9 %
// quantile; returns the largest NEES.
double ExpectWithinSigmas(const SurveyResult& r, const Layout& truth_in_object_frame) {
  double worst = 0;
  for (const LayoutEntry& e : r.layout.markers) {
    const Pose truth = TruePose(truth_in_object_frame, e.marker.id);
    const Eigen::Matrix<double, 6, 1> err = PoseError(e.object_from_marker, truth);
    EXPECT_TRUE(e.covariance.has_value()) << e.marker.id;
    if (!e.covariance) continue;
    if (e.covariance->isZero()) {  // the reference: exact by definition
      EXPECT_LT(err.norm(), 1e-12) << e.marker.id;
      continue;
    }
    const double nees = err.dot(e.covariance->ldlt().solve(err));
    EXPECT_LT(nees, 22.46) << "marker " << e.marker.id << " error " << err.transpose();
    worst = std::max(worst, nees);
  }
  return worst;
}

// `truth` re-expressed in the frame of marker `ref`.
Layout InFrameOf(const Layout& truth, int ref) {
  const Pose ref_from_object = TruePose(truth, ref).Inverse();
  Layout out = truth;
  for (LayoutEntry& e : out.markers) e.object_from_marker = ref_from_object * e.object_from_marker;
  return out;
}

SurveyConfig ReferenceConfig(int id) {
  SurveyConfig c;
  c.reference_id = id;
  return c;
}

TEST(Survey, SyntheticObjectRecoversTheTruthWithinItsSigmas) {
  TestObject m = MakeTestObject();
  // As built is not as drawn: every post 1.5 mm longer (the well 1.5 mm deeper) than drawn.
  Layout built = m.truth;
  for (LayoutEntry& e : built.markers)
    e.marker.post->height += e.marker.post->concave() ? -0.0015 : 0.0015;
  const std::vector<SurveyImage> images =
      SynthesiseImages(built, m.camera, m.cam_from_object, SyntheticOptions{}, 7);
  SurveyResult r;
  const Status s = RunSurvey(images, m.models, m.camera, SurveyOptions{}, ReferenceConfig(100), &r);
  ASSERT_TRUE(s) << s.message();
  EXPECT_TRUE(r.summary.success);
  EXPECT_TRUE(r.summary.covariance_ok);
  // The dual is split into its outer and inner markers: 9 entries.
  EXPECT_EQ(r.layout.markers.size(), 9u);
  EXPECT_TRUE(r.layout.Validate()) << r.layout.Validate().message();
  EXPECT_NEAR(r.summary.variance_factor, 1.0, 0.1);
  EXPECT_LT(r.summary.rejected.size(), 10u);  // Gaussian noise: only the odd 5-sigma point
  const Layout truth = InFrameOf(built, 100);
  ExpectWithinSigmas(r, truth);
  for (const LayoutEntry& e : r.layout.markers) {
    if (e.marker.post->concave()) continue;  // its well's bottom is hidden at these angles
    const double h_true = truth.Find(e.marker.id)->marker.post->height;
    ASSERT_TRUE(e.post_height_sigma.has_value());
    EXPECT_LT(std::abs(e.marker.post->height - h_true), 4 * *e.post_height_sigma + 1e-6)
        << "marker " << e.marker.id;
    EXPECT_LT(*e.post_height_sigma, 0.0015)
        << "marker " << e.marker.id << ": the tips must tell more than the drawing";
  }
  // The reference marker defines the frame.
  const LayoutEntry* ref = r.layout.Find(100);
  ASSERT_NE(ref, nullptr);
  EXPECT_LT(ref->object_from_marker.tvec.norm() + ref->object_from_marker.rvec.norm(), 1e-12);
  // Sub-millimetre agreement overall (the target is on rendered images; here a sanity bound).
  for (const LayoutEntry& e : r.layout.markers)
    EXPECT_LT((e.object_from_marker.tvec - TruePose(truth, e.marker.id).tvec).norm(), 1e-3);
}

TEST(Survey, ControlPointsFixTheGaugeAndScaleBarsTheDistance) {
  TestObject m = MakeTestObject(120);
  const std::vector<SurveyImage> images =
      SynthesiseImages(m.truth, m.camera, m.cam_from_object, SyntheticOptions{}, 3);
  SurveyConfig c;
  c.gauge = SurveyConfig::Gauge::kControlPoints;
  for (const char* name : {"100.tl", "100.br", "101", "105"}) {
    ControlPoint cp;
    ASSERT_TRUE(ParseNamedPoint(name, &cp.point));
    const LayoutEntry* e = m.truth.Find(cp.point.marker_id);
    Eigen::Vector3d in_marker;
    ASSERT_TRUE(NamedPointInMarker(cp.point, e->marker, &in_marker));
    cp.point_in_object = e->object_from_marker * in_marker;
    cp.sigma = 2e-4;
    c.control_points.push_back(cp);
  }
  // A scale bar between two side markers, exact to 10 microns.
  ScaleBar bar;
  ASSERT_TRUE(ParseNamedPoint("101.tl", &bar.a));
  ASSERT_TRUE(ParseNamedPoint("103.tl", &bar.b));
  const Eigen::Vector3d a = TruePose(m.truth, 101) * m.truth.Find(101)->marker.Corners()[0];
  const Eigen::Vector3d b = TruePose(m.truth, 103) * m.truth.Find(103)->marker.Corners()[0];
  bar.distance = (a - b).norm();
  bar.sigma = 1e-5;
  c.scale_bars.push_back(bar);
  SurveyResult r;
  const Status s = RunSurvey(images, m.models, m.camera, SurveyOptions{}, c, &r);
  ASSERT_TRUE(s) << s.message();
  // No marker is held: every one has a non-zero covariance, and the truth is in the frame of
  // the control points (the dataset's object frame) without any transform.
  for (const LayoutEntry& e : r.layout.markers) EXPECT_GT(e.covariance->trace(), 0);
  ExpectWithinSigmas(r, m.truth);
  const Eigen::Vector3d ea = r.layout.Find(101)->object_from_marker * a.Zero();
  const Eigen::Vector3d got_a =
      r.layout.Find(101)->object_from_marker * m.truth.Find(101)->marker.Corners()[0];
  const Eigen::Vector3d got_b =
      r.layout.Find(103)->object_from_marker * m.truth.Find(103)->marker.Corners()[0];
  (void)ea;
  EXPECT_NEAR((got_a - got_b).norm(), bar.distance, 5e-5);
}

TEST(Survey, ScaleComesFromTheMarkerSizes) {
  // The same images with every model (and so every size) 1 % larger: the whole layout, in the
  // reference's frame, comes out 1 % larger.
  TestObject m = MakeTestObject(100);
  const std::vector<SurveyImage> images =
      SynthesiseImages(m.truth, m.camera, m.cam_from_object, SyntheticOptions{}, 5);
  std::vector<MarkerModel> big = m.models;
  for (MarkerModel& model : big) {
    model.size *= 1.01;
    model.stripe_width *= 1.01;
    model.cell_size *= 1.01;
    if (model.post) model.post->height *= 1.01;
    if (model.inner) {
      model.inner->size *= 1.01;
      model.inner->stripe_width *= 1.01;
      model.inner->cell_size *= 1.01;
    }
  }
  SurveyResult r1, r2;
  ASSERT_TRUE(RunSurvey(images, m.models, m.camera, SurveyOptions{}, ReferenceConfig(100), &r1));
  ASSERT_TRUE(RunSurvey(images, big, m.camera, SurveyOptions{}, ReferenceConfig(100), &r2));
  const double d1 = r1.layout.Find(105)->object_from_marker.tvec.norm();
  const double d2 = r2.layout.Find(105)->object_from_marker.tvec.norm();
  EXPECT_NEAR(d2 / d1, 1.01, 2e-4);
}

TEST(Survey, OutliersAreRejectedAndNamed) {
  TestObject m = MakeTestObject(120);
  std::vector<SurveyImage> images =
      SynthesiseImages(m.truth, m.camera, m.cam_from_object, SyntheticOptions{}, 11);
  // Three corners knocked 3 px off, and one detection with its corners in the wrong order
  // (a rotation misread): its single-marker pose is kept, so the initialisation sees it too.
  int knocked = 0;
  std::string rotated_image;
  for (SurveyImage& im : images)
    for (Detection& d : im.detections) {
      if (knocked < 3 && d.id == 105 && im.name.back() == '7') {
        d.corners[1] += Eigen::Vector2d(3, -2);
        ++knocked;
      } else if (rotated_image.empty() && d.id == 101) {
        std::rotate(d.corners.begin(), d.corners.begin() + 1, d.corners.end());
        rotated_image = im.name;
      }
    }
  ASSERT_EQ(knocked, 3);
  ASSERT_FALSE(rotated_image.empty());
  SurveyResult r;
  const Status s = RunSurvey(images, m.models, m.camera, SurveyOptions{}, ReferenceConfig(100), &r);
  ASSERT_TRUE(s) << s.message();
  int tr_of_105 = 0, of_101 = 0;
  for (const RejectedPoint& p : r.summary.rejected) {
    tr_of_105 += p.marker_id == 105 && p.point == "tr";
    of_101 += p.marker_id == 101 && p.image == rotated_image;
  }
  EXPECT_EQ(tr_of_105, 3);
  EXPECT_GE(of_101, 4);  // the whole detection
  ExpectWithinSigmas(r, InFrameOf(m.truth, 100));
}

TEST(Survey, MarkerSeenInOneImageIsNamedAndLeftOut) {
  TestObject m = MakeTestObject(80);
  std::vector<SurveyImage> images =
      SynthesiseImages(m.truth, m.camera, m.cam_from_object, SyntheticOptions{}, 2);
  // A ninth marker, seen once.
  std::vector<MarkerModel> models = m.models;
  models.push_back(MarkerModel::Standard(40, 0.1, 0.025));
  Detection extra = images[40].detections.front();
  extra.id = 40;
  for (auto& p : extra.corners) p += Eigen::Vector2d(200, 0);
  images[40].detections.push_back(extra);
  SurveyResult r;
  const Status s = RunSurvey(images, models, m.camera, SurveyOptions{}, ReferenceConfig(100), &r);
  ASSERT_TRUE(s) << s.message();
  EXPECT_EQ(r.layout.Find(40), nullptr);
  bool named = false;
  for (const auto& [id, why] : r.summary.left_out)
    named |= id == 40 && why.find("seen in 1 image") != std::string::npos;
  EXPECT_TRUE(named) << r.summary.BriefReport();
  EXPECT_NE(r.summary.BriefReport().find("marker 40 left out: seen in 1 image"), std::string::npos);
}

TEST(Survey, DisconnectedViewGraphNamesItsComponents) {
  TestObject m = MakeTestObject(120);
  std::vector<SurveyImage> images =
      SynthesiseImages(m.truth, m.camera, m.cam_from_object, SyntheticOptions{}, 4);
  // Keep 102 and 107 (the -x face) only in images that see nothing else, and the
  // others only where 17 and 18 are not.
  for (SurveyImage& im : images) {
    bool back = false;
    for (const Detection& d : im.detections) back |= d.id == 102 || d.id == 107;
    std::vector<Detection> keep;
    for (const Detection& d : im.detections)
      if ((d.id == 102 || d.id == 107) == back) keep.push_back(d);
    im.detections = keep;
  }
  SurveyResult r;
  Status s = RunSurvey(images, m.models, m.camera, SurveyOptions{}, ReferenceConfig(100), &r);
  ASSERT_FALSE(s);
  EXPECT_NE(s.message().find("disconnected"), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("{102 107}"), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("{100 101 103 104 105 106 150}"), std::string::npos) << s.message();
  EXPECT_EQ(r.summary.components.size(), 2u);
  // Asked to, the survey keeps the reference's group and lists the others as left out.
  SurveyConfig c = ReferenceConfig(100);
  c.drop_disconnected = true;
  s = RunSurvey(images, m.models, m.camera, SurveyOptions{}, c, &r);
  ASSERT_TRUE(s) << s.message();
  EXPECT_EQ(r.layout.Find(102), nullptr);
  EXPECT_EQ(r.summary.left_out.size(), 2u);
}

TEST(Survey, RankDeficiencyNamesTheUndeterminedParameters) {
  TestObject m = MakeTestObject(80);
  // Three control points on one line: the top edge of marker 100 and the centre of marker
  // 105, moved onto that line (both on the front face). The rotation of everything about the
  // line is then not determined.
  const LayoutEntry* e = m.truth.Find(100);
  const Eigen::Vector3d tl = e->object_from_marker * e->marker.Corners()[0];
  const Eigen::Vector3d tr = e->object_from_marker * e->marker.Corners()[1];
  for (LayoutEntry& entry : m.truth.markers)
    if (entry.marker.id == 105) entry.object_from_marker.tvec = tl + 2.5 * (tr - tl);
  const std::vector<SurveyImage> images =
      SynthesiseImages(m.truth, m.camera, m.cam_from_object, SyntheticOptions{}, 9);
  SurveyConfig c;
  c.gauge = SurveyConfig::Gauge::kControlPoints;
  const std::vector<std::pair<const char*, Eigen::Vector3d>> points = {
      {"100.tl", tl}, {"100.tr", tr}, {"105", tl + 2.5 * (tr - tl)}};
  for (const auto& [name, where] : points) {
    ControlPoint cp;
    ASSERT_TRUE(ParseNamedPoint(name, &cp.point));
    cp.point_in_object = where;
    c.control_points.push_back(cp);
  }
  SurveyResult r;
  const Status s = RunSurvey(images, m.models, m.camera, SurveyOptions{}, c, &r);
  ASSERT_FALSE(s);
  EXPECT_NE(s.message().find("rank deficient"), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("marker 100 (r"), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("marker 101 "), std::string::npos) << s.message();
  EXPECT_FALSE(r.summary.covariance_ok);
}

// A camera whose intrinsics are off by draws from its calibration's covariance: with that
// covariance on the camera, the layout's NEES stays near 6; without it, the layout is
// overconfident. The images are synthesised through the true camera.
TEST(Survey, CalibrationUncertaintyIsPropagated) {
  const TestObject m = MakeTestObject(60);
  const Layout truth = InFrameOf(m.truth, 100);
  const int n = static_cast<int>(m.camera.intrinsics().size());
  Eigen::VectorXd sigma = Eigen::VectorXd::Constant(n, 1e-3);
  sigma.head<4>() << 1.5, 1.5, 1.0, 1.0;
  const Eigen::MatrixXd L = sigma.asDiagonal().toDenseMatrix();
  std::mt19937_64 rng(17);
  std::normal_distribution<double> g(0, 1);
  SurveyOptions with, without;
  without.use_calibration_covariance = false;
  const int trials = 30;
  double nees_with = 0, nees_without = 0;
  int count = 0;
  for (int t = 0; t < trials; ++t) {
    std::vector<double> intrinsics = m.camera.intrinsics();
    for (int k = 0; k < n; ++k) intrinsics[k] += sigma[k] * g(rng);
    CameraModel calibrated;
    ASSERT_TRUE(CameraModel::Create(m.camera.lensmodel(), intrinsics, m.camera.width(),
                                    m.camera.height(), &calibrated)
                    .ok());
    ASSERT_TRUE(calibrated.set_intrinsics_covariance_factor(L).ok());
    const std::vector<SurveyImage> images =
        SynthesiseImages(m.truth, m.camera, m.cam_from_object, SyntheticOptions{}, 100 + t);
    SurveyResult a, b;
    ASSERT_TRUE(RunSurvey(images, m.models, calibrated, with, ReferenceConfig(100), &a).ok());
    ASSERT_TRUE(RunSurvey(images, m.models, calibrated, without, ReferenceConfig(100), &b).ok());
    EXPECT_TRUE(a.summary.calibration_in_covariance);
    EXPECT_FALSE(b.summary.calibration_in_covariance);
    nees_with += SumNees(a, truth, &count);
    nees_without += SumNees(b, truth, nullptr);
  }
  // 30 draws of the intrinsics, 8 markers each (correlated within a draw): a loose band.
  // (Below 6 rather than above: the wrong intrinsics also raise the variance factor.)
  EXPECT_GT(nees_with / count, 4.0);
  EXPECT_LT(nees_with / count, 8.0);
  EXPECT_GT(nees_without / count, 12.0);  // the calibration's error dominates here
}

// Refined intrinsics come with their covariance (the intrinsics' block of the survey's,
// scaled): positive definite, and the refined intrinsics' error against the truth inside it
// (one draw: below the chi-square(N) 99.9 % quantile, N = 8: 26.1).
TEST(Survey, RefinedIntrinsicsCarryTheirCovariance) {
  TestObject m = MakeTestObject(60);
  // OPENCV4 (the datasets' camera without its rational terms, which 60 views of 8 markers
  // do not determine).
  const std::vector<double> in8(m.camera.intrinsics().begin(), m.camera.intrinsics().begin() + 8);
  ASSERT_TRUE(
      CameraModel::Create("LENSMODEL_OPENCV4", in8, m.camera.width(), m.camera.height(), &m.camera)
          .ok());
  std::vector<double> start = m.camera.intrinsics();
  start[0] += 3, start[1] -= 2, start[2] += 1.5, start[3] -= 1;
  CameraModel off;
  ASSERT_TRUE(
      CameraModel::Create(m.camera.lensmodel(), start, m.camera.width(), m.camera.height(), &off)
          .ok());
  const std::vector<SurveyImage> images =
      SynthesiseImages(m.truth, m.camera, m.cam_from_object, SyntheticOptions{}, 31);
  SurveyConfig config = ReferenceConfig(100);
  config.refine_intrinsics = true;
  SurveyResult r;
  const Status s = RunSurvey(images, m.models, off, SurveyOptions{}, config, &r);
  ASSERT_TRUE(s) << s.message();
  EXPECT_TRUE(r.summary.intrinsics_refined);
  EXPECT_FALSE(r.summary.calibration_in_covariance);
  const int n = static_cast<int>(m.camera.intrinsics().size());
  const Eigen::MatrixXd& L = r.camera.intrinsics_covariance_factor();
  ASSERT_EQ(L.rows(), n);
  const Eigen::MatrixXd C = L * L.transpose();
  EXPECT_GT(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(C).eigenvalues().minCoeff(), 0);
  Eigen::VectorXd err(n);
  for (int k = 0; k < n; ++k) err[k] = r.camera.intrinsics()[k] - m.camera.intrinsics()[k];
  const double nees = err.dot(C.ldlt().solve(err));
  EXPECT_LT(nees, 26.1) << "intrinsics error " << err.transpose();
  EXPECT_LT(std::abs(err[0]), 4 * L.row(0).norm()) << "fx started 3 px off";
}

// The term's Jacobian against finite differences: only marker 103's detections have grey
// levels, so the covariance the term adds to every marker j is s_j s_j^T, s_j = d pose_j / d
// (the shift's unit); moving 103's corners outward by delta times their repeat_px in every view
// and surveying again moves marker j by delta s_j. A wrong scale, sign of one axis or an axis
// mix-up in the term shows here.
TEST(Survey, RepeatedCornerErrorMatchesFiniteDifferences) {
  const TestObject m = MakeTestObject(40);
  const int shifted = 103;
  const double contrast = 4, delta = 0.5;
  const double repeat_px = SurveyOptions{}.corner_repeat_px_grey / contrast;
  std::vector<SurveyImage> images =
      SynthesiseImages(m.truth, m.camera, m.cam_from_object, SyntheticOptions{}, 41);
  std::vector<SurveyImage> moved = images;
  for (size_t i = 0; i < images.size(); ++i)
    for (size_t k = 0; k < images[i].detections.size(); ++k) {
      Detection& d = images[i].detections[k];
      if (d.id != shifted) continue;
      d.black = 1;
      d.white = 1 + contrast;
      const Eigen::Vector2d centre =
          0.25 * (d.corners[0] + d.corners[1] + d.corners[2] + d.corners[3]);
      for (int c = 0; c < 4; ++c)
        moved[i].detections[k].corners[c] +=
            delta * repeat_px * (d.corners[c] - centre).normalized();
    }
  SurveyOptions without;
  without.corner_repeat_px_grey = 0;
  without.reject_outliers = false;  // the same points in both solves
  SurveyOptions with = without;
  with.corner_repeat_px_grey = SurveyOptions{}.corner_repeat_px_grey;
  SurveyResult a, b, c;
  ASSERT_TRUE(RunSurvey(images, m.models, m.camera, with, ReferenceConfig(100), &a).ok());
  ASSERT_TRUE(RunSurvey(images, m.models, m.camera, without, ReferenceConfig(100), &b).ok());
  ASSERT_TRUE(RunSurvey(moved, m.models, m.camera, without, ReferenceConfig(100), &c).ok());
  ASSERT_TRUE(a.summary.corner_repeat_in_covariance);
  int compared = 0;
  for (const LayoutEntry& e : a.layout.markers) {
    if (!e.covariance || e.covariance->isZero()) continue;  // the reference
    const LayoutEntry* plain = b.layout.Find(e.marker.id);
    const LayoutEntry* shifted_pose = c.layout.Find(e.marker.id);
    ASSERT_TRUE(plain && shifted_pose && plain->covariance);
    // The term changes covariances only, not the solution.
    EXPECT_LT(PoseError(e.object_from_marker, plain->object_from_marker).norm(), 1e-9);
    const PoseCovariance added = *e.covariance - *plain->covariance;
    const Eigen::Matrix<double, 6, 1> s =
        PoseError(shifted_pose->object_from_marker, plain->object_from_marker) / delta;
    const PoseCovariance expected = s * s.transpose();
    if (expected.norm() < 1e-3 * plain->covariance->norm()) continue;  // too small to compare
    EXPECT_LT((added - expected).norm(), 0.03 * expected.norm())
        << "marker " << e.marker.id << "\nadded\n"
        << added << "\nexpected\n"
        << expected;
    ++compared;
  }
  EXPECT_GE(compared, 3);
}

TEST(Survey, CovarianceAlgorithmsAgree) {
  // The Schur complement (cameras eliminated, the reduced system inverted) gives the same
  // marker and post covariances as ceres::Covariance on the whole Jacobian, SPARSE_QR and
  // DENSE_SVD, on a problem small enough for the dense SVD; with control points too, so that
  // no marker is held and the control-point residuals are in the reduced system.
  TestObject m = MakeTestObject(30);
  const std::vector<SurveyImage> images =
      SynthesiseImages(m.truth, m.camera, m.cam_from_object, SyntheticOptions{}, 4);
  SurveyConfig control;
  control.gauge = SurveyConfig::Gauge::kControlPoints;
  for (const char* name : {"100.tl", "100.br", "101", "105"}) {
    ControlPoint cp;
    ASSERT_TRUE(ParseNamedPoint(name, &cp.point));
    const LayoutEntry* e = m.truth.Find(cp.point.marker_id);
    Eigen::Vector3d in_marker;
    ASSERT_TRUE(NamedPointInMarker(cp.point, e->marker, &in_marker));
    cp.point_in_object = e->object_from_marker * in_marker;
    control.control_points.push_back(cp);
  }
  using Algorithm = SurveyOptions::CovarianceAlgorithm;
  for (const SurveyConfig& config : {ReferenceConfig(100), control}) {
    std::vector<SurveyResult> r(3);
    const Algorithm algorithms[3] = {Algorithm::kSchurComplement, Algorithm::kSparseQr,
                                     Algorithm::kDenseSvd};
    for (int a = 0; a < 3; ++a) {
      SurveyOptions o;
      o.covariance_algorithm = algorithms[a];
      const Status s = RunSurvey(images, m.models, m.camera, o, config, &r[a]);
      ASSERT_TRUE(s) << s.message();
      ASSERT_TRUE(r[a].summary.covariance_ok);
    }
    for (int a = 1; a < 3; ++a) {
      ASSERT_EQ(r[a].layout.markers.size(), r[0].layout.markers.size());
      for (size_t i = 0; i < r[0].layout.markers.size(); ++i) {
        const LayoutEntry& x = r[0].layout.markers[i];
        const LayoutEntry& y = r[a].layout.markers[i];
        ASSERT_TRUE(x.covariance && y.covariance) << x.marker.id;
        const double scale = std::max(1e-30, y.covariance->norm());
        EXPECT_LT((*x.covariance - *y.covariance).norm() / scale, 1e-6)
            << "marker " << x.marker.id << ", algorithm " << a;
        ASSERT_EQ(x.post_height_sigma.has_value(), y.post_height_sigma.has_value());
        if (x.post_height_sigma) {
          EXPECT_NEAR(*x.post_height_sigma / *y.post_height_sigma, 1, 1e-6)
              << "marker " << x.marker.id << ", algorithm " << a;
        }
      }
    }
  }
}

TEST(Survey, BadInputIsNamed) {
  TestObject m = MakeTestObject(20);
  const std::vector<SurveyImage> images =
      SynthesiseImages(m.truth, m.camera, m.cam_from_object, SyntheticOptions{}, 1);
  SurveyResult r;
  Status s = RunSurvey(images, m.models, m.camera, SurveyOptions{}, ReferenceConfig(99), &r);
  EXPECT_FALSE(s);
  EXPECT_NE(s.message().find("reference marker 99 has no model"), std::string::npos) << s.message();
  SurveyOptions o;
  o.corner_sigma_px = -1;
  s = RunSurvey(images, m.models, m.camera, o, ReferenceConfig(100), &r);
  EXPECT_NE(s.message().find("corner_sigma_px"), std::string::npos) << s.message();
  s = RunSurvey({}, m.models, m.camera, SurveyOptions{}, ReferenceConfig(100), &r);
  EXPECT_NE(s.message().find("nothing to survey"), std::string::npos) << s.message();
  s = RunSurvey(images, m.models, CameraModel(), SurveyOptions{}, ReferenceConfig(100), &r);
  EXPECT_NE(s.message().find("camera"), std::string::npos) << s.message();
  o = SurveyOptions{};
  o.corner_repeat_px_grey = -0.1;
  s = RunSurvey(images, m.models, m.camera, o, ReferenceConfig(100), &r);
  EXPECT_NE(s.message().find("corner_repeat_px_grey: expected >= 0 pixels per grey level"),
            std::string::npos)
      << s.message();
}

// Every corner of a marker shifted outward by the same amount in every view (what coarse grey
// levels do to a marker in shadow), the shift drawn per marker from N(0, sigma^2) with sigma =
// corner_repeat_px_grey / contrast: with the term, the layout's NEES stays near 6; without it,
// the repeated error, which no number of views averages away, makes the layout overconfident.
// Detections without grey levels get no term (the synthetic default).
TEST(Survey, RepeatedCornerErrorIsPropagated) {
  const TestObject m = MakeTestObject(60);
  const Layout truth = InFrameOf(m.truth, 100);
  const double contrast = 4;  // grey levels: white 4.5, black 0.5
  // A repeated error of its own (not the default, which is fitted to the rendered mockup), so
  // that leaving it out must show.
  const double repeat_px_grey = 0.29;
  const double sigma = repeat_px_grey / contrast;
  std::mt19937_64 rng(23);
  std::normal_distribution<double> g(0, 1);
  SurveyOptions with, without;
  with.corner_repeat_px_grey = repeat_px_grey;
  without.corner_repeat_px_grey = 0;
  const int trials = 30;
  double nees_with = 0, nees_without = 0;
  int count = 0;
  for (int t = 0; t < trials; ++t) {
    std::vector<SurveyImage> images =
        SynthesiseImages(m.truth, m.camera, m.cam_from_object, SyntheticOptions{}, 300 + t);
    {
      SurveyResult plain;
      ASSERT_TRUE(RunSurvey(images, m.models, m.camera, with, ReferenceConfig(100), &plain).ok());
      EXPECT_FALSE(plain.summary.corner_repeat_in_covariance);  // no grey levels: no term
    }
    std::map<int, double> shift;
    for (SurveyImage& image : images)
      for (Detection& d : image.detections) {
        if (!shift.count(d.id)) shift[d.id] = sigma * g(rng);
        const Eigen::Vector2d centre =
            0.25 * (d.corners[0] + d.corners[1] + d.corners[2] + d.corners[3]);
        for (Eigen::Vector2d& c : d.corners) c += shift[d.id] * (c - centre).normalized();
        d.black = 0.5;
        d.white = 0.5 + contrast;
      }
    SurveyResult a, b;
    ASSERT_TRUE(RunSurvey(images, m.models, m.camera, with, ReferenceConfig(100), &a).ok());
    ASSERT_TRUE(RunSurvey(images, m.models, m.camera, without, ReferenceConfig(100), &b).ok());
    EXPECT_TRUE(a.summary.corner_repeat_in_covariance);
    EXPECT_FALSE(b.summary.corner_repeat_in_covariance);
    nees_with += SumNees(a, truth, &count);
    nees_without += SumNees(b, truth, nullptr);
  }
  // 30 surveys, 8 markers each (their shifts independent, their errors correlated through the
  // shared cameras): a loose band around 6.
  EXPECT_GT(nees_with / count, 4.0) << nees_with / count;
  EXPECT_LT(nees_with / count, 8.5) << nees_with / count;
  EXPECT_GT(nees_without / count, 12.0) << nees_without / count;
  std::printf("NEES with the repeated corner error %.2f, without %.2f\n", nees_with / count,
              nees_without / count);
}

TEST(ViewGraph, RobustAverageIgnoresABadSample) {
  std::vector<Pose> samples;
  std::mt19937_64 rng(1);
  std::normal_distribution<double> g(0, 1);
  const Pose truth{Eigen::Vector3d(0.1, 0.2, 0.3), Eigen::Vector3d(0.5, 0, 0.1)};
  for (int i = 0; i < 9; ++i)
    samples.push_back(
        Pose{truth.rvec + 1e-3 * DrawVector3(g, rng), truth.tvec + 1e-3 * DrawVector3(g, rng)});
  samples.push_back(Pose{truth.rvec + Eigen::Vector3d(0.5, 0, 0), truth.tvec});  // a flip
  const RelativePoseAverage a = RobustAverage(samples, 3 * M_PI / 180, 0.05);
  EXPECT_EQ(a.inliers, 9);
  EXPECT_LT(AngleBetweenRad(a.a_from_b, truth), 2e-3);
  EXPECT_GT(AngleBetweenRad(PlainAverage(samples), truth), 0.03);
}

// The inlier test's angle is the angle between rotations (AngleBetweenRad): a sample turned by
// 0.9 of the threshold from the others is kept, one turned by 1.1 of it and one turned by
// nearly 180 degrees (where a quaternion's sign flips) are not.
TEST(ViewGraph, RobustAverageMeasuresAnglesBetweenRotations) {
  const double threshold = 3 * M_PI / 180;
  const Pose truth{Eigen::Vector3d(0.4, -0.2, 0.3), Eigen::Vector3d(0.5, 0, 0.1)};
  auto turned = [&](double angle, const Eigen::Vector3d& axis) {
    return Pose::FromRotation(
        Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix() * truth.Rotation(),
        truth.tvec);
  };
  std::vector<Pose> samples(5, truth);
  const Pose inside = turned(0.9 * threshold, Eigen::Vector3d(1, 2, 3));
  const Pose outside = turned(1.1 * threshold, Eigen::Vector3d(-3, 1, 2));
  const Pose flipped = turned(M_PI - 1e-3, Eigen::Vector3d(0, 1, 1));
  ASSERT_NEAR(AngleBetweenRad(inside, truth), 0.9 * threshold, 1e-12);
  ASSERT_NEAR(AngleBetweenRad(outside, truth), 1.1 * threshold, 1e-12);
  ASSERT_NEAR(AngleBetweenRad(flipped, truth), M_PI - 1e-3, 1e-9);
  samples.insert(samples.end(), {inside, outside, flipped});
  const RelativePoseAverage a = RobustAverage(samples, threshold, 0.05);
  EXPECT_EQ(a.samples, 8);
  EXPECT_EQ(a.inliers, 6);
  EXPECT_LT(AngleBetweenRad(a.a_from_b, truth), 0.2 * threshold);
}

// Samples of a relative rotation near a half turn about (1, -1, 0), where Eigen gives
// neighbouring rotations quaternions of opposite sign: all are within the inlier angle of each
// other and all are kept.
TEST(ViewGraph, RobustAverageKeepsSamplesNearAHalfTurn) {
  const Eigen::Vector3d half = Eigen::Vector3d(1, -1, 0).normalized();
  std::vector<Pose> samples;
  for (const Eigen::Vector3d& nudge :
       {Eigen::Vector3d(1e-3, 0, 0), Eigen::Vector3d(0, -1e-3, 0), Eigen::Vector3d(0, 0, 1e-3),
        Eigen::Vector3d(-1e-3, 0, 0), Eigen::Vector3d(0, 1e-3, 0)})
    samples.push_back(Pose{(M_PI - 1e-3) * (half + nudge).normalized(), Eigen::Vector3d(0, 0, 1)});
  int opposite = 0;
  for (const Pose& a : samples)
    for (const Pose& b : samples)
      opposite +=
          Eigen::Quaterniond(a.Rotation()).coeffs().dot(Eigen::Quaterniond(b.Rotation()).coeffs()) <
          0;
  ASSERT_GT(opposite, 0);  // the case this checks
  const RelativePoseAverage a = RobustAverage(samples, 1 * M_PI / 180, 0.05);
  EXPECT_EQ(a.inliers, 5);
  EXPECT_LT(AngleBetweenRad(a.a_from_b, samples[2]), 2e-3);  // the average: 1.6e-3 from it
}

}  // namespace
}  // namespace svms
