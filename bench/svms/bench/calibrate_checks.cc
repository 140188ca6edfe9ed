#include "svms/bench/calibrate_checks.h"

#include <filesystem>
#include <fstream>
#include <iostream>
#include <random>

#include "svms/base/format.h"
#include "svms/base/random_draws.h"
#include "svms/pipelines/progress.h"
#include "svms/pipelines/report_file.h"
#include "svms/pipelines/run_program.h"

namespace svms {
namespace {

namespace fs = std::filesystem;

// The largest circle about the image centre that holds only region cells: its radius, px.
double FocusRadius(const CalibrationData& data) {
  const int W = data.truth.width(), H = data.truth.height();
  double focus_radius = 1e9;
  for (size_t g = 0; g < data.grid.size(); ++g)
    if (data.cells[g] != kBothBoards)
      focus_radius = std::min(
          focus_radius, (data.grid[g] - Eigen::Vector2d(0.5 * (W - 1), 0.5 * (H - 1))).norm());
  return focus_radius;
}

}  // namespace

// mrcal.projection_diff of each solved model against the true one, the implied transform
// fitted within the focus radius (no board poses involved), then evaluated at the grid.
ProjectionDiff RunProjectionDiff(const CalibrateBenchmarkOptions& o, const CalibrationData& data,
                                 const std::vector<ToolResult>& tools) {
  ProjectionDiff pd;
  pd.focus_radius = FocusRadius(data);
  pd.rms.assign(tools.size(), {NAN, NAN, NAN});
  const fs::path dir = fs::path(o.out) / "projection_diff";
  std::error_code ec;
  fs::create_directories(dir, ec);
  data.truth.Write((dir / "true.cameramodel").string());
  std::vector<std::string> models;
  for (size_t k = 0; k < tools.size(); ++k) {
    const std::string f = (dir / ("tool" + std::to_string(k) + ".cameramodel")).string();
    if (tools[k].ok && tools[k].r.camera.Write(f).ok()) models.push_back(f);
  }
  OutputFile(dir / "diff.py")
      << "import sys, numpy as np, mrcal\n"
         "mt = mrcal.cameramodel(sys.argv[1]); R = float(sys.argv[2]); rad = float(sys.argv[3])\n"
         "grid = np.loadtxt(sys.argv[4]); cells = np.loadtxt(sys.argv[5])\n"
         "W, H = mt.imagersize(); c = np.array(((W - 1) / 2., (H - 1) / 2.))\n"
         "for f in sys.argv[6:]:\n"
         "    m = mrcal.cameramodel(f)\n"
         "    Rt = mrcal.projection_diff((mt, m), gridn_width=48, distance=R,\n"
         "        use_uncertainties=False, focus_center=c, focus_radius=rad)[3]\n"
         "    v = mrcal.unproject(grid, *mt.intrinsics(), normalize=True) * R\n"
         "    d = np.linalg.norm(mrcal.project(mrcal.transform_point_Rt(Rt, v),\n"
         "        *m.intrinsics()) - grid, axis=-1)\n"
         "    print(f, np.sqrt(np.mean(d[cells == 3]**2)), np.sqrt(np.mean(d**2)), d.max())\n";
  if (models.empty()) return pd;
  {
    OutputFile cf(dir / "cells.txt");
    for (int c : data.cells) cf << c << "\n";
  }
  std::vector<std::string> argv{"/usr/bin/python3",
                                (dir / "diff.py").string(),
                                (dir / "true.cameramodel").string(),
                                Fixed(kCalibrateRange, 6),
                                Fixed(pd.focus_radius, 6),
                                (fs::path(o.out) / "grid.txt").string(),
                                (dir / "cells.txt").string()};
  argv.insert(argv.end(), models.begin(), models.end());
  RunProgramOptions dro;
  dro.stdout_path = (dir / "diff.txt").string();
  dro.stderr_path = (dir / "diff.log").string();
  if (RunProgram(argv, dro) != 0)
    std::cerr << "svms bench calibrate: mrcal.projection_diff failed (see "
              << (dir / "diff.log").string() << ")\n";
  std::ifstream in(dir / "diff.txt");
  std::string f;
  double r0, r1, r2;
  while (in >> f >> r0 >> r1 >> r2) {
    const size_t k = f[f.size() - 13] - '0';  // ".../toolK.cameramodel"
    if (k < pd.rms.size()) pd.rms[k] = {r0, r1, r2};
  }
  return pd;
}

// Each inlier's detected pixel minus the true camera's projection of its board point through
// the view's true pose.
CornerNoise MeasureCornerNoise(const CameraModel& truth, const ToolResult& t,
                               const std::vector<ViewObservations>& views) {
  CornerNoise cn;
  double s2 = 0, sx = 0, sy = 0;
  int count = 0;
  for (size_t v = 0; t.ok && v < t.r.views.size(); ++v) {
    const auto& pts = views[t.r.views[v]].points;
    for (size_t i = 0; i < pts.size(); ++i) {
      Eigen::Vector2d q;
      if (t.r.outlier[v][i] || !truth.Project(t.true_cam_from_frame[v] * pts[i].point_in_board, &q))
        continue;
      const Eigen::Vector2d e = pts[i].pixel - q;
      s2 += e.squaredNorm(), sx += e.x(), sy += e.y(), ++count;
    }
  }
  if (count > 0)
    cn.rms = std::sqrt(s2 / (2.0 * count)), cn.mean_x = sx / count, cn.mean_y = sy / count;
  return cn;
}

// The RMS of the aligned error over the region and the trials against the RMS of the
// predictions. One calibration is one draw of an error that is correlated across the image, so
// the single-run ratio of the report is itself a noisy number; this checks the propagation.
MonteCarlo RunMonteCarlo(const CalibrateBenchmarkOptions& o, const CalibrationData& data,
                         const CalibrationOptions& calib, const ToolResult& a0,
                         const std::vector<ViewObservations>& views) {
  MonteCarlo mc;
  mc.trials = o.quick ? 4 : 12;
  if (!a0.ok) return mc;
  const CameraModel& truth = data.truth;
  double mc_e2 = 0, mc_p2 = 0;
  int mc_n = 0;
  std::mt19937_64 rng(20261122);
  std::normal_distribution<double> gauss(0, 1);
  const double t0 = Now();
  Progress progress("svms bench calibrate: Monte-Carlo", mc.trials);
  for (int trial = 0; trial < mc.trials; ++trial) {
    std::vector<ViewObservations> syn;
    std::vector<Pose> syn_true;
    for (size_t v = 0; v < a0.r.views.size(); ++v) {
      ViewObservations w = views[a0.r.views[v]];
      w.points.clear();
      const auto& pts = views[a0.r.views[v]].points;
      for (size_t i = 0; i < pts.size(); ++i) {
        Eigen::Vector2d q;
        if (a0.r.outlier[v][i] ||
            !truth.Project(a0.true_cam_from_frame[v] * pts[i].point_in_board, &q))
          continue;
        PointObservation p = pts[i];
        // y drawn first, whatever the compiler (random_draws.h).
        p.pixel = q + a0.r.noise_sigma_px * DrawVector2(gauss, rng);
        w.points.push_back(p);
      }
      syn.push_back(std::move(w));
      syn_true.push_back(a0.true_cam_from_frame[v]);
    }
    CalibrationOptions co = calib;
    co.width = truth.width(), co.height = truth.height(), co.verbose = false,
    co.threads = o.threads;
    CalibrationResult rr;
    if (const Status st = Calibrate(syn, co, &rr); !st.ok()) {
      mc.failures.push_back("trial " + std::to_string(trial + 1) + ": " + st.message());
      std::cerr << "svms bench calibrate: Monte-Carlo " << mc.failures.back() << "\n";
      progress.Update(trial + 1);
      continue;
    }
    ++mc.solved;
    std::vector<Pose> used_true;
    for (int v : rr.views) used_true.push_back(syn_true[v]);
    for (size_t g = 0; g < data.grid.size(); ++g) {
      Eigen::Vector2d e;
      Eigen::Matrix2d C;
      if (data.cells[g] != kBothBoards ||
          !AlignedProjectionError(rr, truth, used_true, data.grid[g], kCalibrateRange, &e) ||
          !ProjectionCovariance(rr, data.grid[g], kCalibrateRange, &C))
        continue;
      mc_e2 += e.squaredNorm(), mc_p2 += C.trace(), ++mc_n;
    }
    progress.Update(trial + 1);
  }
  progress.Finish();
  mc.seconds = Now() - t0;
  mc.error_rms = mc_n ? std::sqrt(mc_e2 / mc_n) : NAN;
  mc.predicted_rms = mc_n ? std::sqrt(mc_p2 / mc_n) : NAN;
  return mc;
}

}  // namespace svms
