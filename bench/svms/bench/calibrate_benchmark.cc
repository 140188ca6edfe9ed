#include "svms/bench/calibrate_benchmark.h"

#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include "svms/base/format.h"
#include "svms/bench/calibrate_checks.h"
#include "svms/bench/calibrate_report.h"
#include "svms/bench/calibrate_response.h"
#include "svms/bench/calibrate_tools.h"
#include "svms/pipelines/exit_codes.h"
#include "svms/pipelines/report_file.h"
#include "svms/sim/render.h"

namespace svms {
namespace {

namespace fs = std::filesystem;

// The cell centres of the evaluation grid, px (mrcal's convention: pixel (0,0) is the centre of
// the top-left pixel).
std::vector<Eigen::Vector2d> GridPixels(int W, int H) {
  std::vector<Eigen::Vector2d> g;
  for (int y = 0; y < kCalibrateGrid; ++y)
    for (int x = 0; x < kCalibrateGrid; ++x)
      g.emplace_back((x + 0.5) * W / kCalibrateGrid - 0.5, (y + 0.5) * H / kCalibrateGrid - 0.5);
  return g;
}

// What OUT/data/ holds, in OUT/data/stamp.txt: the dataset's seed and the response check's
// camera pipelines, the renderer's defocus grid included (the views themselves are the seed's,
// a --quick run's a prefix of them).
std::string DataStamp(const CalibrateBenchmarkOptions& o) {
  return "calibration dataset seed " + std::to_string(o.seed) + "; response check gamma " +
         Fixed(kCheckedGamma, 3) + ", defocus " + Fixed(kCheckedDefocusPx, 3) +
         " px, blurred on a grid " + std::to_string(kRadianceSupersample) +
         " times finer than the pixels\n";
}
std::string ReadStamp(const CalibrateBenchmarkOptions& o) {
  std::ifstream in(fs::path(o.out) / "data" / "stamp.txt");
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// The calibration dataset (a subset of its views with --quick), rendered into OUT/data/ unless
// its images are there under the same stamp, and the evaluation grid (OUT/grid.txt). kExitOk
// to go on.
int PrepareData(const CalibrateBenchmarkOptions& o, CalibrationData* data) {
  if (Status s = MakeDataset("calibration", DatasetOptions{o.seed, false}, &data->dataset); !s) {
    std::cerr << "svms bench calibrate: " << s.message() << "\n";
    return kExitFailed;
  }
  Dataset& d = data->dataset;
  data->views = o.quick ? 12 : d.scenes[0].second.views.size();
  data->truth = d.scenes[0].second.camera;
  std::error_code ec;
  // Images rendered for another stamp (another seed, or from before stamps), or whose run did
  // not finish rendering, are rendered again: every subdirectory of data/, the response check's
  // too. The stamp is written once everything is rendered (RunBenchmark).
  const fs::path data_dir = fs::path(o.out) / "data";
  if (fs::exists(data_dir) && ReadStamp(o) != DataStamp(o)) {
    std::cerr << "svms bench calibrate: " << data_dir.string()
              << " holds views of another seed or an unfinished run: rendering them again\n";
    fs::remove_all(data_dir, ec);
    if (ec) {
      std::cerr << "svms bench calibrate: " << data_dir.string() << ": cannot remove ("
                << ec.message() << ")\n";
      return kExitFailed;
    }
  }
  for (auto& [sub, scene] : d.scenes) {
    scene.views.resize(data->views);
    if (RenderUnlessPresent(o, scene, sub, sub) != kExitOk) return kExitFailed;
  }
  for (const View& v : d.scenes[0].second.views)
    data->true_cam_from_board.push_back(v.cam_from_world);
  data->grid = GridPixels(data->truth.width(), data->truth.height());
  data->cells.assign(data->grid.size(), 0);
  OutputFile g(fs::path(o.out) / "grid.txt");
  for (const auto& p : data->grid)
    g << Significant(p.x(), 17) << " " << Significant(p.y(), 17) << "\n";
  return kExitOk;
}

int RunBenchmark(const CalibrateBenchmarkOptions& o) {
  std::error_code ec;
  fs::create_directories(o.out, ec);
  if (!fs::is_directory(o.out)) {
    std::cerr << "svms bench calibrate: --out " << o.out << ": cannot create the directory\n";
    return kExitBadInput;
  }
  CalibrationData data;
  if (const int rc = PrepareData(o, &data); rc != kExitOk) return rc;
  CalibrateFindings f;
  CalibrateRunOptions svms_run;  // svms calibrate's run: options, observations and result
  CalibrateRunOutcome svms_outcome;
  f.tools.push_back(RunSvmsCalibrate(o, &data, &svms_run, &svms_outcome, &f.pass1));
  f.chess = FindChessboards(o, &data);
  f.tools.push_back(RunMrcal(o, data, f.chess));
  f.tools.push_back(RunOpenCv(data, f.chess));
  for (ToolResult& t : f.tools)
    if (t.ok) Measure(data, &t);
  if (f.pass1.ok) Measure(data, &f.pass1);
  f.projection_diff = RunProjectionDiff(o, data, f.tools);
  f.corner_noise = MeasureCornerNoise(data.truth, f.tools[0], svms_outcome.views);
  f.pass1_corner_noise = MeasureCornerNoise(data.truth, f.pass1, svms_outcome.pass1_views);
  f.monte_carlo = RunMonteCarlo(o, data, svms_run.calib, f.tools[0], svms_outcome.views);
  f.response = RunResponseCheck(o, data);
  if (f.response.rendered) OutputFile(fs::path(o.out) / "data" / "stamp.txt") << DataStamp(o);
  return WriteCalibrateReport(o, data, f);
}

}  // namespace

int RunCalibrateBenchmark(const CalibrateBenchmarkOptions& options) {
  return FinishOutputs("svms bench calibrate", RunBenchmark(options));
}

}  // namespace svms
