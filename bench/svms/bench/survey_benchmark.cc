#include "svms/bench/survey_benchmark.h"

#include <atomic>
#include <chrono>
#include <filesystem>
#include <iostream>
#include <mutex>
#include <opencv2/imgcodecs.hpp>
#include <random>
#include <thread>

#include "svms/base/statistics.h"
#include "svms/bench/survey_benchmark_report.h"
#include "svms/bench/truth_poses.h"
#include "svms/bundle/survey_report.h"
#include "svms/bundle/synthetic.h"
#include "svms/detect/detector.h"
#include "svms/marker/model_io.h"
#include "svms/pipelines/dataset_run.h"
#include "svms/pipelines/exit_codes.h"
#include "svms/pipelines/gnuplot.h"
#include "svms/pipelines/progress.h"
#include "svms/pipelines/report_file.h"

namespace svms {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

// The rendered mockup dataset and its truth.
struct MockupData {
  std::string dir;
  CameraModel camera;
  ModelFile models, truth_file;
  std::vector<std::pair<std::string, Pose>> cam_from_object;  // per image, its name
};

// The mockup dataset, rendered here unless options.data names one. kExitOk to go on.
int ReadMockup(const SurveyBenchmarkOptions& o, MockupData* m) {
  const std::string D = o.data.empty() ? (fs::path(o.out) / "mockup").string() : o.data;
  m->dir = D;
  if (!fs::exists(fs::path(D) / "truth.json")) {
    DatasetRunOptions d;
    d.name = "mockup", d.out = D, d.threads = o.threads, d.quick = o.quick, d.quiet = true;
    std::cerr << "svms bench survey: rendering the mockup dataset into " << D << "\n";
    if (RunDataset(d) != kExitOk) {
      std::cerr << "svms bench survey: rendering failed\n";
      return kExitFailed;
    }
  }
  for (Status s : {CameraModel::Read(D + "/true.cameramodel", &m->camera),
                   ReadModelFile(D + "/markers.json", &m->models),
                   ReadModelFile(D + "/true_layout.json", &m->truth_file),
                   ReadTruthPoses(D + "/truth.json", "module", &m->cam_from_object)})
    if (!s) {
      std::cerr << "svms bench survey: " << s.message() << "\n";
      return kExitBadInput;
    }
  return kExitOk;
}

// Detects every image on o.threads threads.
void DetectImages(const SurveyBenchmarkOptions& o, const MockupData& m, SurveyFindings* f) {
  const Detector detector(DetectorOptions{}, m.camera, m.models.markers);
  std::vector<SurveyImage>& images = f->images;
  images.resize(m.cam_from_object.size());
  std::atomic<size_t> next{0};
  size_t done = 0;  // under io
  std::mutex io;
  Progress detecting("svms bench survey: detecting", images.size());
  const auto t_detect = Clock::now();
  auto worker = [&] {
    for (size_t i; (i = next++) < images.size();) {
      images[i].name = m.cam_from_object[i].first;
      const cv::Mat img = cv::imread(m.dir + "/" + images[i].name + ".png", cv::IMREAD_GRAYSCALE);
      if (!img.empty()) images[i].detections = detector.Detect(img);
      std::lock_guard<std::mutex> lock(io);
      detecting.Update(++done);
    }
  };
  std::vector<std::thread> pool;
  for (int t = 0; t < o.threads; ++t) pool.emplace_back(worker);
  for (auto& t : pool) t.join();
  detecting.Finish();
  f->detect_s = std::chrono::duration<double>(Clock::now() - t_detect).count();
  for (const auto& im : images)
    for (const Detection& d : im.detections) ++f->detections_of[d.id];
}

// The survey on the detections (one thread), its own report and layout, and its errors against
// the truth, the initialisation's and the naive baseline's. kExitOk to go on.
int SurveyDetections(const SurveyBenchmarkOptions& o, const MockupData& m, SurveyFindings* f) {
  const Layout& truth = m.truth_file.layout;
  const std::vector<SurveyImage>& images = f->images;
  const int ref = f->ref = truth.markers.front().marker.id;
  SurveyConfig cfg;
  cfg.reference_id = ref;
  const auto t0 = Clock::now();
  f->solved = RunSurvey(images, m.models.markers, m.camera, f->options, cfg, &f->result);
  f->solve_s = std::chrono::duration<double>(Clock::now() - t0).count();
  const SurveyResult& result = f->result;
  std::cerr << result.summary.BriefReport();
  if (Status w = WriteSurveyReport(result, (fs::path(o.out) / "survey_report").string(), Gnuplot);
      !w) {
    std::cerr << "svms bench survey: " << w.message() << "\n";
    return kExitFailed;
  }
  if (f->solved) {
    if (Status w =
            WriteTextFile((fs::path(o.out) / "layout.json").string(), LayoutToJson(result.layout));
        !w) {
      std::cerr << "svms bench survey: " << w.message() << "\n";
      return kExitFailed;
    }
  }
  std::set<int> surveyed;
  for (const LayoutEntry& e : result.layout.markers) surveyed.insert(e.marker.id);
  f->ba = f->solved ? Errors(result.layout, truth, ref) : std::vector<MarkerError>{};
  f->init = Errors(result.initial_layout, truth, ref);
  // The same survey without the repeated corner error in its covariance, for its NEES.
  SurveyOptions plain = f->options;
  plain.corner_repeat_px_grey = 0;
  SurveyResult r;
  if (RunSurvey(images, m.models.markers, m.camera, plain, cfg, &r))
    for (const MarkerError& e : Errors(r.layout, truth, ref))
      if (e.nees >= 0) f->nees_without_repeat.push_back(e.nees);
  f->outward = OutwardCornerErrors(images, m.cam_from_object, truth, m.camera);
  f->naive = Errors(
      LayoutFromPoses(PairwiseAverageLayout(Sightings(images, surveyed), ref), result.layout),
      truth, ref);
  return kExitOk;
}

// The NEES Monte-Carlo: observations synthesised from the truth for exactly the markers the
// detector found in each image (and tips where it found them), fresh noise each run.
void MonteCarlo(const SurveyBenchmarkOptions& o, const MockupData& m, SurveyFindings* f) {
  const Layout& truth = m.truth_file.layout;
  const std::vector<SurveyImage>& images = f->images;
  const int ref = f->ref;
  const SurveyOptions& sopt = f->options;
  SurveyConfig cfg;
  cfg.reference_id = ref;
  std::set<int> surveyed;
  for (const LayoutEntry& e : f->result.layout.markers) surveyed.insert(e.marker.id);
  std::vector<std::vector<int>> only(images.size());
  std::vector<std::vector<bool>> tips(images.size());
  for (size_t i = 0; i < images.size(); ++i)
    for (const Detection& d : images[i].detections)
      if (surveyed.count(d.id) && d.cam_from_marker) {
        only[i].push_back(d.id);
        tips[i].push_back(d.tip.has_value());
      }
  SyntheticOptions syn;  // corners 0.1 px, tips 0.3 px
  const int runs = f->runs = o.quick ? 10 : o.runs;
  Progress monte_carlo("svms bench survey: Monte-Carlo", runs);
  for (int run = 0; run < runs && f->solved; ++run) {
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
        SynthesiseImages(built, m.camera, m.cam_from_object, syn, 1000 + run, &only, &tips);
    SurveyResult r;
    if (!RunSurvey(sim, m.models.markers, m.camera, sopt, cfg, &r)) {
      ++f->mc_failed;
      continue;
    }
    for (const MarkerError& e : Errors(r.layout, built, ref)) {
      if (e.nees >= 0) f->nees[e.id].push_back(e.nees);
      f->mc_pos_ba[e.id].push_back(e.position_mm);
      f->mc_ang_ba[e.id].push_back(e.orientation_deg);
    }
    for (const MarkerError& e :
         Errors(LayoutFromPoses(PairwiseAverageLayout(Sightings(sim, surveyed), ref),
                                f->result.layout),
                truth, ref)) {
      f->mc_pos_naive[e.id].push_back(e.position_mm);
      f->mc_ang_naive[e.id].push_back(e.orientation_deg);
    }
  }
  monte_carlo.Finish();
  const int n_ok = runs - f->mc_failed;
  f->lo = n_ok ? ChiSquareQuantile(0.025, 6.0 * n_ok) / n_ok : 0;
  f->hi = n_ok ? ChiSquareQuantile(0.975, 6.0 * n_ok) / n_ok : 0;
}

// Timing: synthetic 200 x 8 and 2000 x 40 (300 x 40 with --quick), one thread, the covariance
// from the Schur complement (the default); the large case again with ceres::Covariance's
// SPARSE_QR on the whole Jacobian, for comparison (not with --quick). (DENSE_SVD is cubic in all
// parameters, cameras included: 12,000+ for 2000 images; not run.)
void Timings(const SurveyBenchmarkOptions& o, const CameraModel& camera, SurveyFindings* f) {
  using Algorithm = SurveyOptions::CovarianceAlgorithm;
  struct TimingCase {
    int markers, views;
    Algorithm algorithm;
    const char* algorithm_name;
  };
  const SyntheticOptions syn;  // corners 0.1 px, tips 0.3 px
  const int big = o.quick ? 300 : 2000;
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
    SurveyOptions topt = f->options;
    topt.covariance_algorithm = tc.algorithm;
    SurveyResult r;
    const auto a = Clock::now();
    SurveyTiming t;
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
    f->timings.push_back(t);
  }
}

int RunBenchmark(const SurveyBenchmarkOptions& o) {
  std::error_code ec;
  fs::create_directories(o.out, ec);
  if (!fs::is_directory(o.out)) {
    std::cerr << "svms bench survey: --out " << o.out << ": cannot create the directory\n";
    return kExitBadInput;
  }
  MockupData mockup;
  if (const int rc = ReadMockup(o, &mockup); rc != kExitOk) return rc;
  SurveyFindings f;
  DetectImages(o, mockup, &f);
  if (const int rc = SurveyDetections(o, mockup, &f); rc != kExitOk) return rc;
  MonteCarlo(o, mockup, &f);
  Timings(o, mockup.camera, &f);
  return WriteSurveyBenchmarkReport(o, &f);
}

}  // namespace

int RunSurveyBenchmark(const SurveyBenchmarkOptions& options) {
  return FinishOutputs("svms bench survey", RunBenchmark(options));
}

}  // namespace svms
