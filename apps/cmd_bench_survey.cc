// svms bench survey: the survey (bundle/) on the rendered mockup dataset against its truth,
// NEES Monte-Carlo, timing, and the naive pairwise-averaging approach as the baseline.
#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <random>
#include <set>
#include <sstream>
#include <thread>

#include "bench_targets.h"
#include "bench_util.h"
#include "cli_io.h"
#include "commands.h"
#include "svms/base/statistics.h"
#include "svms/bundle/survey.h"
#include "svms/bundle/survey_report.h"
#include "svms/bundle/synthetic.h"
#include "svms/bundle/view_graph.h"
#include "svms/detect/detector.h"
#include "svms/marker/model_io.h"
#include "svms/pipelines/dataset_run.h"
#include "svms/pipelines/gnuplot.h"
#include "svms/pipelines/item_failure.h"
#include "svms/pipelines/json_text.h"
#include "svms/pipelines/output_checks.h"
#include "svms/pipelines/progress.h"
#include "svms/pipelines/report_file.h"

namespace svms::cli {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

struct BenchSurveyOptions {
  std::string out, data;
  bool quick = false;
  int runs = 100;
  int threads = 2;
};

std::string F(double v, int digits) { return Fixed(v, digits); }

struct MarkerError {
  int id = -1;
  double position_mm = 0, orientation_deg = 0, nees = -1;
  double post_error_mm = 0;  // estimated - true post height
  double post_sigma_mm = 0;  // the survey's sigma of the post height (0: none)
  bool has_post = false;
};

// Errors of `layout` (frame of marker `ref`) against `truth` (any frame; re-expressed).
std::vector<MarkerError> Errors(const Layout& layout, const Layout& truth, int ref) {
  const Pose ref_from_truth = truth.Find(ref)->object_from_marker.Inverse();
  std::vector<MarkerError> out;
  for (const LayoutEntry& e : layout.markers) {
    const LayoutEntry* t = truth.Find(e.marker.id);
    if (!t || e.marker.id == ref) continue;
    const Pose true_pose = ref_from_truth * t->object_from_marker;
    MarkerError m;
    m.id = e.marker.id;
    const Eigen::AngleAxisd aa(e.object_from_marker.Rotation() * true_pose.Rotation().transpose());
    Eigen::Matrix<double, 6, 1> err;
    err << aa.axis() * aa.angle(), e.object_from_marker.tvec - true_pose.tvec;
    m.position_mm = 1000 * err.tail<3>().norm();
    m.orientation_deg = aa.angle() * 180 / M_PI;
    if (e.covariance && !e.covariance->isZero()) m.nees = err.dot(e.covariance->ldlt().solve(err));
    const MarkerModel true_model =
        t->marker.id == e.marker.id ? t->marker : *t->marker.InnerModel();
    if (e.marker.post && true_model.post) {
      m.has_post = true;
      m.post_error_mm = 1000 * (e.marker.post->height - true_model.post->height);
      if (e.post_height_sigma) m.post_sigma_mm = 1000 * *e.post_height_sigma;
    }
    out.push_back(m);
  }
  return out;
}

double Rms(const std::vector<MarkerError>& v, double MarkerError::*f) {
  double s = 0;
  for (const MarkerError& m : v) s += (m.*f) * (m.*f);
  return v.empty() ? 0 : std::sqrt(s / v.size());
}

// A layout (poses only) from root_from_marker poses and models.
Layout LayoutFromPoses(const std::map<int, Pose>& poses, const Layout& like) {
  Layout l;
  for (const LayoutEntry& e : like.markers)
    if (poses.count(e.marker.id))
      l.markers.push_back(LayoutEntry{e.marker, poses.at(e.marker.id), std::nullopt, std::nullopt});
  return l;
}

std::vector<ImageSightings> Sightings(const std::vector<SurveyImage>& images,
                                      const std::set<int>& ids) {
  std::vector<ImageSightings> out;
  for (const SurveyImage& im : images) {
    ImageSightings s;
    for (const Detection& d : im.detections)
      if (d.cam_from_marker && ids.count(d.id))
        s.push_back({d.id, *d.cam_from_marker, d.side_px(), d.pose_ambiguous});
    out.push_back(s);
  }
  return out;
}

// Draws NAME.png and NAME.svg (900 x 450) in `dir`; false (with a message) if gnuplot fails.
bool Plot(const std::string& dir, const std::string& name, const std::string& body) {
  if (Status s = Gnuplot(dir, name, body, "900,450"); !s) {
    std::cerr << "svms bench survey: " << s.message() << "\n";
    return false;
  }
  return true;
}

// Each detected corner's error against the truth along its marker's outward diagonal (pixels;
// negative: the black square found smaller than it is), per marker ID. The survey's covariance
// takes corner errors to be independent from view to view: a mean that stands out from its
// standard error is an error that repeats, and no number of views averages it away.
std::map<int, std::vector<double>> OutwardCornerErrors(
    const std::vector<SurveyImage>& images,
    const std::vector<std::pair<std::string, Pose>>& cam_from_object, const Layout& truth,
    const CameraModel& camera) {
  std::map<int, std::vector<double>> out;
  for (size_t i = 0; i < images.size(); ++i) {
    for (const Detection& d : images[i].detections) {
      const LayoutEntry* t = truth.Find(d.id);
      if (!t) continue;
      const MarkerModel model = t->marker.id == d.id ? t->marker : *t->marker.InnerModel();
      const Pose cam_from_marker = cam_from_object[i].second * t->object_from_marker;
      std::array<Eigen::Vector2d, 4> q;
      bool ok = true;
      for (int k = 0; k < 4 && ok; ++k)
        ok = camera.Project(cam_from_marker * model.Corners()[k], &q[k]);
      if (!ok) continue;
      const Eigen::Vector2d centre = 0.25 * (q[0] + q[1] + q[2] + q[3]);
      for (int k = 0; k < 4; ++k) {
        const Eigen::Vector2d e = d.corners[k] - q[k];
        if (e.norm() < 3) out[d.id].push_back(e.dot((q[k] - centre).normalized()));
      }
    }
  }
  return out;
}

// Mean of v and its standard error, "m +- se" (pixels, 4 decimals).
std::string MeanAndStandardError(const std::vector<double>& v) {
  if (v.size() < 2) return "-";
  const double m = Mean(v);
  double ss = 0;
  for (double x : v) ss += (x - m) * (x - m);
  return F(m, 4) + " +- " + F(std::sqrt(ss / (v.size() - 1) / v.size()), 4);
}

int RunBenchSurvey(const BenchSurveyOptions& o) {
  std::error_code ec;
  fs::create_directories(o.out, ec);
  if (!fs::is_directory(o.out)) {
    std::cerr << "svms bench survey: --out " << o.out << ": cannot create the directory\n";
    return kExitBadInput;
  }
  // 1. The rendered mockup dataset (rendered here unless --data names one).
  std::string D = o.data.empty() ? (fs::path(o.out) / "mockup").string() : o.data;
  if (!fs::exists(fs::path(D) / "truth.json")) {
    DatasetRunOptions d;
    d.name = "mockup", d.out = D, d.threads = o.threads, d.quick = o.quick, d.quiet = true;
    std::cerr << "svms bench survey: rendering the mockup dataset into " << D << "\n";
    if (RunDataset(d) != kExitOk) {
      std::cerr << "svms bench survey: rendering failed\n";
      return kExitFailed;
    }
  }
  CameraModel camera;
  ModelFile models, truth_file;
  std::vector<std::pair<std::string, Pose>> cam_from_object;
  for (Status s : {CameraModel::Read(D + "/true.cameramodel", &camera),
                   ReadModelFile(D + "/markers.json", &models),
                   ReadModelFile(D + "/true_layout.json", &truth_file),
                   ReadTruthPoses(D + "/truth.json", "module", &cam_from_object)})
    if (!s) {
      std::cerr << "svms bench survey: " << s.message() << "\n";
      return kExitBadInput;
    }
  const Layout& truth = truth_file.layout;

  // 2. Detect every image.
  const Detector detector(DetectorOptions{}, camera, models.markers);
  std::vector<SurveyImage> images(cam_from_object.size());
  std::atomic<size_t> next{0};
  size_t done = 0;  // under io
  std::mutex io;
  Progress detecting("svms bench survey: detecting", images.size());
  const auto t_detect = Clock::now();
  auto worker = [&] {
    for (size_t i; (i = next++) < images.size();) {
      images[i].name = cam_from_object[i].first;
      const cv::Mat img = cv::imread(D + "/" + images[i].name + ".png", cv::IMREAD_GRAYSCALE);
      if (!img.empty()) images[i].detections = detector.Detect(img);
      std::lock_guard<std::mutex> lock(io);
      detecting.Update(++done);
    }
  };
  std::vector<std::thread> pool;
  for (int t = 0; t < o.threads; ++t) pool.emplace_back(worker);
  for (auto& t : pool) t.join();
  detecting.Finish();
  const double detect_s = std::chrono::duration<double>(Clock::now() - t_detect).count();
  std::map<int, int> detections_of;
  for (const auto& im : images)
    for (const Detection& d : im.detections) ++detections_of[d.id];

  // 3. The survey on the detections (one thread), against the truth.
  const int ref = truth.markers.front().marker.id;
  SurveyOptions sopt;
  SurveyConfig cfg;
  cfg.reference_id = ref;
  SurveyResult result;
  const auto t0 = Clock::now();
  const Status st = RunSurvey(images, models.markers, camera, sopt, cfg, &result);
  const double solve_s = std::chrono::duration<double>(Clock::now() - t0).count();
  std::cerr << result.summary.BriefReport();
  if (Status w = WriteSurveyReport(result, (fs::path(o.out) / "survey_report").string(), Gnuplot);
      !w) {
    std::cerr << "svms bench survey: " << w.message() << "\n";
    return kExitFailed;
  }
  if (st) {
    if (Status w =
            WriteTextFile((fs::path(o.out) / "layout.json").string(), LayoutToJson(result.layout));
        !w) {
      std::cerr << "svms bench survey: " << w.message() << "\n";
      return kExitFailed;
    }
  }
  std::set<int> surveyed;
  for (const LayoutEntry& e : result.layout.markers) surveyed.insert(e.marker.id);
  const std::vector<MarkerError> ba =
      st ? Errors(result.layout, truth, ref) : std::vector<MarkerError>{};
  const std::vector<MarkerError> init = Errors(result.initial_layout, truth, ref);
  // The same survey without the repeated corner error in its covariance, for its NEES.
  std::vector<double> nees_without_repeat;
  {
    SurveyOptions plain = sopt;
    plain.corner_repeat_px_grey = 0;
    SurveyResult r;
    if (RunSurvey(images, models.markers, camera, plain, cfg, &r))
      for (const MarkerError& m : Errors(r.layout, truth, ref))
        if (m.nees >= 0) nees_without_repeat.push_back(m.nees);
  }
  std::map<int, std::vector<double>> outward =
      OutwardCornerErrors(images, cam_from_object, truth, camera);
  const std::vector<MarkerError> naive = Errors(
      LayoutFromPoses(PairwiseAverageLayout(Sightings(images, surveyed), ref), result.layout),
      truth, ref);

  // 4. NEES Monte-Carlo: observations synthesised from the truth for exactly the markers the
  // detector found in each image (and tips where it found them), fresh noise each run.
  std::vector<std::vector<int>> only(images.size());
  std::vector<std::vector<bool>> tips(images.size());
  for (size_t i = 0; i < images.size(); ++i)
    for (const Detection& d : images[i].detections)
      if (surveyed.count(d.id) && d.cam_from_marker) {
        only[i].push_back(d.id);
        tips[i].push_back(d.tip.has_value());
      }
  SyntheticOptions syn;  // corners 0.1 px, tips 0.3 px
  const int runs = o.quick ? 10 : o.runs;
  std::map<int, std::vector<double>> nees;
  std::map<int, std::vector<double>> mc_pos_ba, mc_pos_naive, mc_ang_ba, mc_ang_naive;
  int mc_failed = 0;
  Progress monte_carlo("svms bench survey: Monte-Carlo", runs);
  for (int run = 0; run < runs && st; ++run) {
    monte_carlo.Update(run + 1);  // starting run + 1
    // As built is not as drawn: each run's post heights are drawn from the survey's prior
    // (the drawing, sigma post_height_prior_sigma), which the covariance counts as a
    // measurement; with the drawn heights exact, the prior would be a noise-free measurement
    // and the NEES too low by construction.
    Layout built = truth;
    std::mt19937_64 rng(2000 + run);
    std::normal_distribution<double> height_noise(0, sopt.post_height_prior_sigma);
    for (LayoutEntry& e : built.markers)
      if (e.marker.post) e.marker.post->height += height_noise(rng);
    const auto sim =
        SynthesiseImages(built, camera, cam_from_object, syn, 1000 + run, &only, &tips);
    SurveyResult r;
    if (!RunSurvey(sim, models.markers, camera, sopt, cfg, &r)) {
      ++mc_failed;
      continue;
    }
    for (const MarkerError& m : Errors(r.layout, built, ref)) {
      if (m.nees >= 0) nees[m.id].push_back(m.nees);
      mc_pos_ba[m.id].push_back(m.position_mm);
      mc_ang_ba[m.id].push_back(m.orientation_deg);
    }
    for (const MarkerError& m : Errors(
             LayoutFromPoses(PairwiseAverageLayout(Sightings(sim, surveyed), ref), result.layout),
             truth, ref)) {
      mc_pos_naive[m.id].push_back(m.position_mm);
      mc_ang_naive[m.id].push_back(m.orientation_deg);
    }
  }
  monte_carlo.Finish();
  const int n_ok = runs - mc_failed;
  const double lo = n_ok ? ChiSquareQuantile(0.025, 6.0 * n_ok) / n_ok : 0;
  const double hi = n_ok ? ChiSquareQuantile(0.975, 6.0 * n_ok) / n_ok : 0;
  auto mean = [](const std::vector<double>& v) {
    double s = 0;
    for (double x : v) s += x;
    return v.empty() ? 0.0 : s / v.size();
  };
  auto rms = [](const std::vector<double>& v) {
    double s = 0;
    for (double x : v) s += x * x;
    return v.empty() ? 0.0 : std::sqrt(s / v.size());
  };

  // 5. Timing: synthetic 200 x 8 and 2000 x 40 (300 x 40 with --quick), one thread, the
  // covariance from the Schur complement (the default); the large case again with
  // ceres::Covariance's SPARSE_QR on the whole Jacobian, for comparison (not with --quick).
  // (DENSE_SVD is cubic in all parameters, cameras included: 12,000+ for 2000 images; not run.)
  using Algorithm = SurveyOptions::CovarianceAlgorithm;
  struct Timing {
    std::string name, covariance_algorithm;
    int images = 0, markers = 0, detections = 0;
    double init = 0, solve = 0, covariance = 0, total = 0;
    bool ok = false;
  };
  struct TimingCase {
    int markers, views;
    Algorithm algorithm;
    const char* algorithm_name;
  };
  const int big = o.quick ? 300 : 2000;
  std::vector<Timing> timings;
  std::vector<TimingCase> cases = {{8, 200, Algorithm::kSchurComplement, "Schur complement"},
                                   {40, big, Algorithm::kSchurComplement, "Schur complement"}};
  if (!o.quick) cases.push_back({40, big, Algorithm::kSparseQr, "ceres SPARSE_QR"});
  for (const TimingCase& tc : cases) {
    std::cerr << "svms bench survey: timing " << tc.views << " images x " << tc.markers
              << " markers, covariance: " << tc.algorithm_name << "\n";
    const SyntheticScene sc = MakeSyntheticScene(tc.markers, tc.views, 77);
    const auto sim = SynthesiseImages(sc.layout, camera, sc.cam_from_object, syn, 5);
    std::vector<MarkerModel> ms;
    for (const LayoutEntry& e : sc.layout.markers) ms.push_back(e.marker);
    SurveyConfig c;
    c.reference_id = ms.front().id;
    c.drop_disconnected = true;
    SurveyOptions topt = sopt;
    topt.covariance_algorithm = tc.algorithm;
    SurveyResult r;
    const auto a = Clock::now();
    Timing t;
    t.ok = static_cast<bool>(RunSurvey(sim, ms, camera, topt, c, &r));
    t.total = std::chrono::duration<double>(Clock::now() - a).count();
    t.name = "synthetic";
    t.covariance_algorithm = tc.algorithm_name;
    t.images = tc.views;
    t.markers = r.summary.markers_surveyed;
    t.detections = r.summary.detections_used;
    t.init = r.summary.seconds_init;
    t.solve = r.summary.seconds_first + r.summary.seconds_second;
    t.covariance = r.summary.seconds_covariance;
    if (!t.ok) std::cerr << r.summary.message << "\n";
    timings.push_back(t);
  }

  // 6. Tables, plots, report.
  OutputFile csv(fs::path(o.out) / "markers.csv");
  csv << "id,detections,ba_position_mm,ba_orientation_deg,ba_post_error_mm,init_position_mm,"
         "naive_position_mm,naive_orientation_deg,mc_nees_mean,mc_ba_position_rms_mm,"
         "mc_naive_position_rms_mm,mc_ba_orientation_rms_deg,mc_naive_orientation_rms_deg\n";
  OutputFile dat(fs::path(o.out) / "errors.dat");
  dat << "# id ba_mm naive_mm init_mm mc_ba_mm mc_naive_mm nees\n";
  for (size_t i = 0; i < ba.size(); ++i) {
    const MarkerError& b = ba[i];
    const auto find = [&](const std::vector<MarkerError>& v) {
      for (const MarkerError& m : v)
        if (m.id == b.id) return m;
      return MarkerError{};
    };
    const MarkerError n = find(naive), in = find(init);
    csv << b.id << "," << detections_of[b.id] << "," << b.position_mm << "," << b.orientation_deg
        << "," << (b.has_post ? b.post_error_mm : 0) << "," << in.position_mm << ","
        << n.position_mm << "," << n.orientation_deg << "," << mean(nees[b.id]) << ","
        << rms(mc_pos_ba[b.id]) << "," << rms(mc_pos_naive[b.id]) << "," << rms(mc_ang_ba[b.id])
        << "," << rms(mc_ang_naive[b.id]) << "\n";
    dat << b.id << " " << b.position_mm << " " << n.position_mm << " " << in.position_mm << " "
        << rms(mc_pos_ba[b.id]) << " " << rms(mc_pos_naive[b.id]) << " " << mean(nees[b.id])
        << "\n";
  }
  csv.close();
  dat.close();
  Plot(o.out, "survey_errors",
       "set title 'Marker position error vs truth, rendered mockup (mm, log scale)'\n"
       "set style data histograms\nset style fill solid 0.8\nset logscale y\n"
       "set ylabel 'mm'\nset xlabel 'marker'\nset key top left\n"
       "plot 'errors.dat' using 2:xtic(1) title 'bundle adjustment', '' using 3 title "
       "'naive pairwise averaging', '' using 4 title 'initialisation (spanning tree)'\n");
  Plot(o.out, "survey_nees",
       "set title 'Mean NEES per marker over " + std::to_string(n_ok) +
           " Monte-Carlo surveys (6-DOF pose)'\nset style data histograms\n"
           "set style fill solid 0.8\nset ylabel 'mean NEES'\nset xlabel 'marker'\n"
           "set yrange [0:*]\nplot 'errors.dat' using 7:xtic(1) title 'mean NEES', " +
           F(lo, 3) + " with lines lw 2 title 'chi-square 95 % bounds', " + F(hi, 3) +
           " with lines lw 2 notitle\n");

  std::ostringstream md;
  md << "## Survey\n\n";
  md << "Targets (mockup dataset: 8 markers, 200 images): marker position error <= 0.2 mm RMS, "
        "orientation <= 0.02 deg, post heights within 0.1 mm; NEES mean within the chi-square "
        "95 % bounds over 100 Monte-Carlo surveys; 200 x 8 in <= 5 s and 2000 x 40 in <= 60 s on "
        "one core.\n\n";
  md << "**Rendered mockup** (`svms dataset mockup" << (o.quick ? " --quick" : "") << "`, "
     << images.size() << " images, detected with `svms::Detector` in " << F(detect_s, 1) << " s on "
     << o.threads << " threads). Detections per marker:";
  for (const auto& [id, n] : detections_of) md << " " << id << ": " << n << ";";
  md << " markers never detected are left out by the survey (seen in fewer than 2 images):";
  for (const auto& [id, why] : result.summary.left_out) md << " " << id;
  md << ".\n\n";
  if (!st) md << "**The survey failed:** " << st.message() << "\n\n";
  md << "Survey (reference marker " << ref << ", one thread): " << F(solve_s, 2) << " s, "
     << result.summary.images_used << " images, " << result.summary.detections_used
     << " detections, RMS " << F(result.summary.rms_px, 3) << " px, variance factor "
     << F(result.summary.variance_factor, 3) << ", " << result.summary.rejected.size()
     << " points rejected.\n\n";
  md << "| marker | detections | BA position error (mm) | BA orientation error (deg) | BA post "
        "height error (mm) | BA NEES | corners: mean outward error (px) +- s.e. | naive "
        "position error (mm) | naive orientation error (deg) | initialisation position error "
        "(mm) |\n|---|---|---|---|---|---|---|---|---|---|\n";
  std::vector<double> ba_nees;
  for (const MarkerError& b : ba) {
    MarkerError n, in;
    for (const MarkerError& m : naive)
      if (m.id == b.id) n = m;
    for (const MarkerError& m : init)
      if (m.id == b.id) in = m;
    if (b.nees >= 0) ba_nees.push_back(b.nees);
    md << "| " << b.id << " | " << detections_of[b.id] << " | " << F(b.position_mm, 3) << " | "
       << F(b.orientation_deg, 4) << " | " << (b.has_post ? F(b.post_error_mm, 3) : "-") << " | "
       << F(b.nees, 1) << " | " << MeanAndStandardError(outward[b.id]) << " | "
       << F(n.position_mm, 3) << " | " << F(n.orientation_deg, 4) << " | " << F(in.position_mm, 3)
       << " |\n";
  }
  std::vector<MarkerError> posts;
  for (const MarkerError& m : ba)
    if (m.has_post) posts.push_back(m);
  md << "\nRMS over the " << ba.size() << " surveyed markers (reference excluded): bundle "
     << "adjustment **" << F(Rms(ba, &MarkerError::position_mm), 3) << " mm, "
     << F(Rms(ba, &MarkerError::orientation_deg), 4) << " deg**, post heights "
     << F(Rms(posts, &MarkerError::post_error_mm), 3) << " mm RMS; naive pairwise averaging "
     << F(Rms(naive, &MarkerError::position_mm), 3) << " mm, "
     << F(Rms(naive, &MarkerError::orientation_deg), 4) << " deg; initialisation "
     << F(Rms(init, &MarkerError::position_mm), 3) << " mm, "
     << F(Rms(init, &MarkerError::orientation_deg), 4) << " deg.\n\n";
  if (!ba_nees.empty())
    md << "Mean NEES of the " << ba_nees.size() << " surveyed markers on these rendered images: **"
       << F(Mean(ba_nees), 1) << "** (chi-square(6): 6, give or take "
       << F(2 * std::sqrt(12.0 / ba_nees.size()), 1) << " for " << ba_nees.size()
       << " markers at 2 sigmas; "
       << (nees_without_repeat.empty() ? std::string("-") : F(Mean(nees_without_repeat), 1))
       << " without the repeated corner error term). The covariance holds the random part of "
          "the corner and tip noise, scaled by the variance factor, and each marker's repeated "
          "corner error, one outward shift common to its views that moves a detection's corners "
          "by SurveyOptions::corner_repeat_px_grey ("
       << F(sopt.corner_repeat_px_grey, 2)
       << " px, fitted on this dataset) over its contrast in grey levels: a corner's mean "
          "outward error that stands several standard errors from zero (column above) is such "
          "an error, which no number of views averages away. The Monte-Carlo below, with "
          "independent noise and no grey levels, checks the rest of the covariance.\n\n";
  md << "![](survey_errors.png)\n\n";
  md << "**Monte-Carlo** (" << n_ok << " surveys, " << mc_failed << " failed): observations "
     << "synthesised from the truth (true camera poses and layout, the dataset's camera) for "
        "exactly the markers and tips the detector found in each image, with fresh Gaussian "
        "noise each run (corners 0.1 px, tips 0.3 px) and each post's built height drawn from "
        "the survey's prior (the drawing, sigma "
     << F(1000 * sopt.post_height_prior_sigma, 1)
     << " mm); the survey then runs as on real detections. Chi-square 95 % bounds on the mean "
        "NEES of "
     << n_ok << " runs: [" << F(lo, 2) << ", " << F(hi, 2) << "].\n\n";
  md << "| marker | mean NEES | within bounds | BA position RMS (mm) | naive position RMS (mm) | "
        "BA orientation RMS (deg) | naive orientation RMS (deg) |\n|---|---|---|---|---|---|---|\n";
  for (const auto& [id, v] : nees) {
    const double m = mean(v);
    md << "| " << id << " | " << F(m, 2) << " | " << (m >= lo && m <= hi ? "yes" : "**no**")
       << " | " << F(rms(mc_pos_ba[id]), 4) << " | " << F(rms(mc_pos_naive[id]), 4) << " | "
       << F(rms(mc_ang_ba[id]), 5) << " | " << F(rms(mc_ang_naive[id]), 5) << " |\n";
  }
  md << "\n![](survey_nees.png)\n\n";
  md << "**Timing** (one thread; synthetic objects from `MakeSyntheticScene`, "
        "observations from `SynthesiseImages`; the total includes initialisation, both "
        "solves and the covariance; the covariance by the Schur complement, i.e. the "
        "camera-eliminated normal matrix inverted, unless the row says otherwise):\n\n| case | "
        "images | markers | detections | init (s) | solves (s) | covariance (s) | total (s) "
        "|\n|---|---|---|---|---|---|---|---|\n";
  md << "| rendered mockup | " << images.size() << " | " << result.summary.markers_surveyed << " | "
     << result.summary.detections_used << " | " << F(result.summary.seconds_init, 2) << " | "
     << F(result.summary.seconds_first + result.summary.seconds_second, 2) << " | "
     << F(result.summary.seconds_covariance, 2) << " | " << F(solve_s, 2) << " |\n";
  for (const Timing& t : timings)
    md << "| synthetic"
       << (t.covariance_algorithm == "Schur complement"
               ? ""
               : ", covariance by " + t.covariance_algorithm)
       << (t.ok ? "" : " (failed)") << " | " << t.images << " | " << t.markers << " | "
       << t.detections << " | " << F(t.init, 2) << " | " << F(t.solve, 2) << " | "
       << F(t.covariance, 2) << " | " << F(t.total, 2) << " |\n";
  // The targets, judged on this run's numbers. The absolute accuracy targets are those of the
  // full mockup (200 views); the quick one (8 views) cannot reach the orientation and post-height
  // ones, so with --quick every marker is held to its own covariance instead.
  BenchTargets targets;
  {
    const double pos_rms = Rms(ba, &MarkerError::position_mm);
    const double ang_rms = Rms(ba, &MarkerError::orientation_deg);
    double post_worst = 0;
    for (const MarkerError& m : posts) post_worst = std::max(post_worst, std::abs(m.post_error_mm));
    // Judged for the family of markers, not each alone: with 8 markers at 95 % each, a right
    // covariance would miss one about a third of the time. Bonferroni: 95 % for the family.
    const double k = std::max<double>(1, static_cast<double>(nees.size()));
    const double family_lo = n_ok ? ChiSquareQuantile(0.025 / k, 6.0 * n_ok) / n_ok : 0;
    const double family_hi = n_ok ? ChiSquareQuantile(1 - 0.025 / k, 6.0 * n_ok) / n_ok : 0;
    int nees_in = 0;
    for (const auto& [id, v] : nees)
      if (mean(v) >= family_lo && mean(v) <= family_hi) ++nees_in;
    md << "\nTargets, on this run";
    if (!result.summary.left_out.empty())
      md << " (over the " << ba.size() << " markers surveyed; " << result.summary.left_out.size()
         << " left out)";
    md << ":\n\n";
    targets.Add("Marker position error <= 0.2 mm RMS", st && pos_rms <= 0.2, F(pos_rms, 3) + " mm");
    const std::string why = "the quick mockup's " + std::to_string(images.size()) +
                            " views are too few; the full run judges it";
    if (o.quick) {
      targets.NotJudged("Orientation error <= 0.02 deg RMS", why);
      targets.NotJudged("Post heights within 0.1 mm", why);
      // chi-square(6) 99.9 %: 22.46; a post height within 4 of its sigmas (+ 0.01 mm).
      int beyond = 0, posts_beyond = 0;
      for (const MarkerError& m : ba) beyond += !(m.nees >= 0 && m.nees < 22.46);
      for (const MarkerError& m : posts)
        posts_beyond += !(std::abs(m.post_error_mm) <= 4 * m.post_sigma_mm + 0.01);
      targets.Add(
          "Every marker's pose within its covariance (NEES below 22.46, chi-square 6 dof "
          "99.9 %) and every post height within 4 sigma",
          st && beyond == 0 && posts_beyond == 0,
          std::to_string(beyond) + " of " + std::to_string(ba.size()) + " poses and " +
              std::to_string(posts_beyond) + " of " + std::to_string(posts.size()) +
              " posts beyond");
    } else {
      targets.Add("Orientation error <= 0.02 deg RMS", st && ang_rms <= 0.02,
                  F(ang_rms, 4) + " deg");
      targets.Add(
          "Post heights within 0.1 mm", st && post_worst <= 0.1,
          "worst " + F(post_worst, 3) + " mm over " + std::to_string(posts.size()) + " posts");
    }
    targets.Add("Every marker's mean NEES within the chi-square bounds over " +
                    std::to_string(n_ok) + " Monte-Carlo surveys, 95 % for the " +
                    std::to_string(nees.size()) + " markers together ([" + F(family_lo, 2) + ", " +
                    F(family_hi, 2) + "])",
                !nees.empty() && nees_in == static_cast<int>(nees.size()),
                std::to_string(nees_in) + " of " + std::to_string(nees.size()) + " markers");
    if (timings.size() >= 2) {
      targets.Add(std::to_string(timings[0].images) + " images x 8 markers in <= 5 s",
                  timings[0].ok && timings[0].total <= 5, F(timings[0].total, 2) + " s");
      const std::string what =
          std::to_string(timings[1].images) + " images x 40 markers in <= 60 s";
      if (o.quick)
        targets.NotJudged(
            what, "the quick run has 300 images, not 2000 (" + F(timings[1].total, 2) + " s)");
      else
        targets.Add(what, timings[1].ok && timings[1].total <= 60, F(timings[1].total, 2) + " s");
    }
    md << targets.Markdown();
  }
  md << "\nThe naive approach: for every pair of markers seen in the same image, the plain mean "
        "of the relative poses from the single-marker poses, chained from the reference along "
        "the fewest hops (`PairwiseAverageLayout`); no robust step, no adjustment, no "
        "covariance. Per-marker numbers: markers.csv; the survey's own report: "
        "survey_report/report.md.\n";
  OutputFile(fs::path(o.out) / "report.md") << md.str();
  std::cout << md.str();
  return st ? targets.ExitCode("svms bench survey", kExitOk) : kExitFailed;
}

}  // namespace

void AddBenchSurvey(CLI::App& bench, int* exit_code) {
  auto o = std::make_shared<BenchSurveyOptions>();
  CLI::App* cmd = bench.add_subcommand(
      "survey", "The survey on the rendered mockup vs truth, NEES Monte-Carlo, timing, baseline");
  cmd->add_option("--out", o->out, "Output directory (report.md, CSV, plots)")->required();
  cmd->add_flag("--quick", o->quick, "Quick mockup (6 views), 10 Monte-Carlo runs, 300 x 40");
  cmd->add_option("--data", o->data,
                  "A rendered mockup dataset to reuse (default: render one into OUT/mockup)");
  cmd->add_option("--runs", o->runs, "Monte-Carlo runs")->capture_default_str();
  cmd->add_option("--threads", o->threads, "Threads for rendering and detection")
      ->check(CLI::Range(1, 256))
      ->capture_default_str();
  cmd->footer("Example:\n  svms bench survey --out out/bench/survey");
  cmd->callback(
      [o, exit_code] { *exit_code = FinishOutputs("svms bench survey", RunBenchSurvey(*o)); });
}

}  // namespace svms::cli
