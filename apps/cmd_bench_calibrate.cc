// svms bench calibrate: calibration accuracy on the simulator's calibration dataset, whose true
// camera is known. (a) svms calibrate on the SVMS board; (b) mrcal's own optimizer
// (mrcal-calibrate-cameras) on a chessboard rendered with the same camera and poses, corners by
// OpenCV's findChessboardCornersSB; (c) OpenCV's calibrateCamera on the same corners. For each:
// the projection error against the true camera over the image, and the tool's own predicted
// uncertainty.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <random>
#include <thread>

#include "bench_targets.h"
#include "cli_io.h"
#include "commands.h"
#include "svms/base/format.h"
#include "svms/base/random_draws.h"
#include "svms/datasets/datasets.h"
#include "svms/geometry/alignment.h"
#include "svms/marker/model_io.h"
#include "svms/pipelines/calibration_run.h"
#include "svms/pipelines/gnuplot.h"
#include "svms/pipelines/item_failure.h"
#include "svms/pipelines/json_text.h"
#include "svms/pipelines/output_checks.h"
#include "svms/pipelines/progress.h"
#include "svms/pipelines/render_scene.h"
#include "svms/pipelines/report_file.h"
#include "svms/pipelines/run_program.h"

namespace svms::cli {
namespace {

namespace fs = std::filesystem;

struct BenchOptions {
  std::string out;
  bool quick = false;
  int threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
};

constexpr int kCornersX = 9, kCornersY = 7;  // inner corners of the 10 x 8 chessboard
constexpr double kSquare = 0.075;
constexpr double kRange = 2.0;  // metres: the middle of the dataset's 1.3-2.4 m
constexpr int kGrid = 24;

// What one tool produced, as a CalibrationResult (camera, used views, cam_from_frame) so that
// AlignedProjectionError applies; `predicted` is sqrt(trace) per grid pixel.
struct ToolResult {
  std::string name;
  bool ok = false;
  std::string failure;
  CalibrationResult r;
  std::vector<Pose> true_cam_from_frame;  // per used view
  std::vector<double> predicted;          // per grid pixel, px (NaN where unavailable)
  std::vector<double> error;              // per grid pixel, |aligned error| px (NaN: none)
  double rms_reproj = 0;
  double seconds = 0;
  // Measured over the whole grid, and over the covered cells (the region):
  double err_rms = 0, err_worst = 0, direct_rms = 0, pred_rms = 0;
  double region_err_rms = 0, region_err_worst = 0, region_pred_rms = 0;
};

// Where each grid cell's data come from: bit 1 an SVMS board corner (inlier) fell in the cell,
// bit 2 a chessboard corner did. The evaluation region is the cells with both (kBoth): every
// tool is judged where both boards put data, none on extrapolation into empty corners.
constexpr int kBoard = 1, kChess = 2, kBoth = 3;

int CellOf(const Eigen::Vector2d& px, int W, int H) {
  const int cx = std::clamp(static_cast<int>((px.x() + 0.5) * kGrid / W), 0, kGrid - 1);
  const int cy = std::clamp(static_cast<int>((px.y() + 0.5) * kGrid / H), 0, kGrid - 1);
  return cy * kGrid + cx;
}

std::vector<Eigen::Vector2d> GridPixels(int W, int H) {
  std::vector<Eigen::Vector2d> g;
  for (int y = 0; y < kGrid; ++y)
    for (int x = 0; x < kGrid; ++x)
      g.emplace_back((x + 0.5) * W / kGrid - 0.5, (y + 0.5) * H / kGrid - 0.5);
  return g;
}

// The chessboard's inner corners in its object frame (x right, y up, centred), index j*9+i with
// i along x and j down the rows as printed.
Eigen::Vector3d ChessCorner(int i, int j) {
  return {(i - 0.5 * (kCornersX - 1)) * kSquare, (0.5 * (kCornersY - 1) - j) * kSquare, 0};
}

// mrcal's (and our OpenCV objectPoints') frame: corner k = j*9+i at (i*s, j*s, 0).
Eigen::Vector3d FrameCorner(int k) {
  return {(k % kCornersX) * kSquare, (k / kCornersX) * kSquare, 0};
}

// The true cam_from_frame of one chessboard view: each detected corner is matched to the nearest
// true projection, then board_from_frame is the rigid fit (Kabsch) of frame to board points.
bool TrueFrame(const CameraModel& truth, const Pose& cam_from_board,
               const std::vector<cv::Point2f>& corners, Pose* cam_from_frame) {
  std::vector<Eigen::Vector2d> proj;
  std::vector<Eigen::Vector3d> board;
  for (int j = 0; j < kCornersY; ++j)
    for (int i = 0; i < kCornersX; ++i) {
      Eigen::Vector2d q;
      if (!truth.Project(cam_from_board * ChessCorner(i, j), &q)) return false;
      proj.push_back(q), board.push_back(ChessCorner(i, j));
    }
  Eigen::Matrix3Xd A(3, corners.size()), B(3, corners.size());
  for (size_t k = 0; k < corners.size(); ++k) {
    size_t best = 0;
    for (size_t m = 1; m < proj.size(); ++m)
      if ((proj[m] - Eigen::Vector2d(corners[k].x, corners[k].y)).norm() <
          (proj[best] - Eigen::Vector2d(corners[k].x, corners[k].y)).norm())
        best = m;
    if ((proj[best] - Eigen::Vector2d(corners[k].x, corners[k].y)).norm() > 3) return false;
    A.col(k) = FrameCorner(static_cast<int>(k)), B.col(k) = board[best];
  }
  *cam_from_frame = cam_from_board * FitRigidTransform(A, B);
  return true;
}

void Measure(const CameraModel& truth, const std::vector<Eigen::Vector2d>& grid,
             const std::vector<int>& cells, ToolResult* t) {
  double e2 = 0, d2 = 0, p2 = 0, worst = 0, re2 = 0, rp2 = 0, rworst = 0;
  int n = 0, np = 0, rn = 0;
  t->error.assign(grid.size(), NAN);
  for (size_t g = 0; g < grid.size(); ++g) {
    Eigen::Vector2d e;
    if (!AlignedProjectionError(t->r, truth, t->true_cam_from_frame, grid[g], kRange, &e)) continue;
    t->error[g] = e.norm();
    Eigen::Vector3d dir;
    Eigen::Vector2d q;
    truth.Unproject(grid[g], &dir);
    t->r.camera.Project(kRange * dir, &q);
    e2 += e.squaredNorm(), d2 += (q - grid[g]).squaredNorm(), ++n;
    worst = std::max(worst, e.norm());
    const bool pred = g < t->predicted.size() && std::isfinite(t->predicted[g]);
    if (pred) p2 += std::pow(t->predicted[g], 2), ++np;
    if (cells[g] == kBoth && pred) {
      re2 += e.squaredNorm(), rp2 += std::pow(t->predicted[g], 2), ++rn;
      rworst = std::max(rworst, e.norm());
    }
  }
  t->err_rms = n ? std::sqrt(e2 / n) : NAN;
  t->direct_rms = n ? std::sqrt(d2 / n) : NAN;
  t->err_worst = worst;
  t->pred_rms = np ? std::sqrt(p2 / np) : NAN;
  t->region_err_rms = rn ? std::sqrt(re2 / rn) : NAN;
  t->region_pred_rms = rn ? std::sqrt(rp2 / rn) : NAN;
  t->region_err_worst = rworst;
}

double Now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

int RunBench(const BenchOptions& o) {
  std::error_code ec;
  fs::create_directories(o.out, ec);
  if (!fs::is_directory(o.out)) {
    std::cerr << "svms bench calibrate: --out " << o.out << ": cannot create the directory\n";
    return kExitBadInput;
  }
  // 1. The dataset (a subset of its views with --quick), rendered.
  Dataset d;
  if (Status s = MakeDataset("calibration", DatasetOptions{1, false}, &d); !s) {
    std::cerr << "svms bench calibrate: " << s.message() << "\n";
    return kExitFailed;
  }
  const size_t nviews = o.quick ? 12 : d.scenes[0].second.views.size();
  const CameraModel truth = d.scenes[0].second.camera;
  std::vector<Pose> true_cam_from_board;  // the boards sit at the world origin
  for (auto& [sub, scene] : d.scenes) {
    scene.views.resize(nviews);
    const fs::path dir = fs::path(o.out) / "data" / sub;
    fs::create_directories(dir, ec);
    bool have = true;
    for (const View& v : scene.views) have &= fs::exists(dir / (v.name + ".png"));
    if (!have) {
      std::cerr << "svms bench calibrate: rendering " << nviews << " " << sub << " views\n";
      if (RenderScene(scene, "calibration/" + sub, dir.string(), o.threads, false, false) !=
          kExitOk)
        return kExitFailed;
    }
  }
  for (const View& v : d.scenes[0].second.views) true_cam_from_board.push_back(v.cam_from_world);
  const int W = truth.width(), H = truth.height();
  const std::vector<Eigen::Vector2d> grid = GridPixels(W, H);
  {
    OutputFile g(fs::path(o.out) / "grid.txt");
    g.precision(17);
    for (const auto& p : grid) g << p.x() << " " << p.y() << "\n";
  }
  std::vector<ToolResult> tools(3);
  std::vector<int> cells(grid.size(), 0);  // kBoard | kChess per grid cell
  CalibrateRunOutcome out;                 // svms calibrate's run: observations and result
  CalibrateRunOptions ro;
  ToolResult pass1;  // (a)'s first pass, for the report

  // (a) svms calibrate on the marker board.
  {
    ToolResult& t = tools[0];
    t.name = "svms calibrate (SVMS board)";
    for (const View& v : d.scenes[0].second.views)
      ro.images.push_back((fs::path(o.out) / "data" / "board" / (v.name + ".png")).string());
    ro.board = "board_layout.json";
    ModelFile f;
    for (const auto& [rel, text] : d.files)
      if (rel == "board_layout.json") ParseModelJson(text, rel, &f);
    ro.layout = f.layout;
    ro.calib.lensmodel = truth.lensmodel();
    ro.out = (fs::path(o.out) / "svms.cameramodel").string();
    ro.report_dir = (fs::path(o.out) / "svms_report").string();
    ro.uncertainty_range = kRange;
    ro.threads = o.threads;
    const double t0 = Now();
    const int rc = RunCalibration(ro, &out);
    t.seconds = Now() - t0;
    t.ok = rc == kExitOk;
    if (!t.ok) t.failure = "svms calibrate failed (exit " + std::to_string(rc) + ")";
    t.r = out.result;
    t.rms_reproj = t.r.rms_px;
    for (int v : t.r.views) {
      int idx = 0;
      std::sscanf(fs::path(out.image_of_view[v]).filename().c_str(), "calib_%d", &idx);
      t.true_cam_from_frame.push_back(true_cam_from_board[idx]);
    }
    auto true_poses = [&](const CalibrationResult& r) {
      std::vector<Pose> poses;
      for (int v : r.views) {
        int idx = 0;
        std::sscanf(fs::path(out.image_of_view[v]).filename().c_str(), "calib_%d", &idx);
        poses.push_back(true_cam_from_board[idx]);
      }
      return poses;
    };
    // The first pass (corners fitted in pixels, before re-detection with its lens model).
    pass1.name = "svms calibrate, pass 1 only (corners fitted in pixels)";
    pass1.ok = t.ok;
    pass1.r = out.pass1;
    pass1.rms_reproj = pass1.r.rms_px;
    pass1.true_cam_from_frame = true_poses(pass1.r);
    for (const auto& px : grid) {
      Eigen::Matrix2d C;
      pass1.predicted.push_back(
          t.ok && ProjectionCovariance(pass1.r, px, kRange, &C) ? std::sqrt(C.trace()) : NAN);
    }
    for (size_t v = 0; v < t.r.views.size(); ++v) {
      const auto& pts = out.views[t.r.views[v]].points;
      for (size_t i = 0; i < pts.size(); ++i)
        if (!t.r.outlier[v][i]) cells[CellOf(pts[i].pixel, W, H)] |= kBoard;
    }
    for (const auto& px : grid) {
      Eigen::Matrix2d C;
      t.predicted.push_back(t.ok && ProjectionCovariance(t.r, px, kRange, &C) ? std::sqrt(C.trace())
                                                                              : NAN);
    }
  }

  // Chessboard corners (OpenCV), shared by (b) and (c).
  std::vector<std::string> chess_files;
  std::vector<std::vector<cv::Point2f>> chess_corners;
  std::vector<Pose> chess_true;
  {
    OutputFile vnl(fs::path(o.out) / "corners.vnl");
    vnl << "# filename x y level\n";
    vnl.precision(10);
    const auto& views = d.scenes[1].second.views;
    for (size_t i = 0; i < views.size(); ++i) {
      const std::string file =
          (fs::path(o.out) / "data" / "chessboard" / (views[i].name + ".png")).string();
      const cv::Mat img = cv::imread(file, cv::IMREAD_GRAYSCALE);
      std::vector<cv::Point2f> corners;
      const bool found = !img.empty() && cv::findChessboardCornersSB(
                                             img, cv::Size(kCornersX, kCornersY), corners,
                                             cv::CALIB_CB_EXHAUSTIVE | cv::CALIB_CB_ACCURACY);
      Pose cam_from_frame;
      if (!found || !TrueFrame(truth, true_cam_from_board[i], corners, &cam_from_frame)) {
        std::cerr << "svms bench calibrate: " << file << ": chessboard not found\n";
        vnl << views[i].name << ".png - - -\n";
        continue;
      }
      for (const cv::Point2f& c : corners) {
        vnl << views[i].name << ".png " << c.x << " " << c.y << " 0\n";
        cells[CellOf(Eigen::Vector2d(c.x, c.y), W, H)] |= kChess;
      }
      chess_files.push_back(views[i].name + ".png");
      chess_corners.push_back(corners);
      chess_true.push_back(cam_from_frame);
    }
  }
  std::cerr << "svms bench calibrate: chessboard found in " << chess_files.size() << " of "
            << nviews << " images\n";

  // (b) mrcal-calibrate-cameras on those corners.
  {
    ToolResult& t = tools[1];
    t.name = "mrcal (chessboard)";
    const fs::path mdir = fs::path(o.out) / "mrcal";
    fs::create_directories(mdir, ec);
    char focal[32], spacing[32];
    std::snprintf(focal, sizeof focal, "%.0f", truth.intrinsics()[0]);
    std::snprintf(spacing, sizeof spacing, "%g", kSquare);
    RunProgramOptions ro;
    ro.cwd = fs::absolute(fs::path(o.out) / "data" / "chessboard").string();
    ro.stdout_path = ro.stderr_path = fs::absolute(mdir / "mrcal.log").string();
    // mrcal-calibrate-cameras expands the image glob itself.
    const std::vector<std::string> argv{"mrcal-calibrate-cameras",
                                        "--corners-cache",
                                        fs::absolute(fs::path(o.out) / "corners.vnl").string(),
                                        "--lensmodel",
                                        truth.lensmodel(),
                                        "--focal",
                                        focal,
                                        "--object-spacing",
                                        spacing,
                                        "--object-width-n",
                                        std::to_string(kCornersX),
                                        "--object-height-n",
                                        std::to_string(kCornersY),
                                        "--outdir",
                                        fs::absolute(mdir).string(),
                                        "calib_*.png"};
    const double t0 = Now();
    const int rc = RunProgram(argv, ro);
    t.seconds = Now() - t0;
    const std::string model = (mdir / "camera-0.cameramodel").string();
    if (rc != 0 || !CameraModel::Read(model, &t.r.camera).ok()) {
      t.failure = "mrcal-calibrate-cameras failed (see mrcal/mrcal.log)";
    } else {
      // Frames, residual RMS and mrcal's own projection uncertainty from its Python API.
      const std::string py = (mdir / "uncertainty.py").string();
      OutputFile(py) << "import sys, numpy as np, mrcal\n"
                        "m = mrcal.cameramodel(sys.argv[1]); R = float(sys.argv[2])\n"
                        "grid = np.loadtxt(sys.argv[3])\n"
                        "oi = m.optimization_inputs()\n"
                        "np.savetxt(sys.argv[4], oi['frames_rt_toref'])\n"
                        "v = mrcal.unproject(grid, *m.intrinsics(), normalize=True)\n"
                        "s = mrcal.projection_uncertainty(v*R, model=m, what='rms-stdev')\n"
                        "np.savetxt(sys.argv[5], s*np.sqrt(2.))\n"
                        "x = mrcal.optimizer_callback(**oi)[1]\n"
                        "r = mrcal.residuals_chessboard(oi, residuals=x).reshape(-1,2)\n"
                        "print(np.sqrt(np.mean(np.sum(r*r,axis=-1))))\n";
      RunProgramOptions pro;
      pro.stdout_path = (mdir / "rms.txt").string();
      pro.stderr_path = (mdir / "py.log").string();
      if (RunProgram({"/usr/bin/python3", py, model, std::to_string(kRange),
                      (fs::path(o.out) / "grid.txt").string(), (mdir / "frames.txt").string(),
                      (mdir / "predicted.txt").string()},
                     pro) != 0) {
        t.failure = "mrcal's Python uncertainty failed (see mrcal/py.log)";
      } else {
        std::ifstream fr(mdir / "frames.txt"), pr(mdir / "predicted.txt"), rr(mdir / "rms.txt");
        double a[6];
        while (fr >> a[0] >> a[1] >> a[2] >> a[3] >> a[4] >> a[5])
          t.r.cam_from_board.push_back(
              Pose{Eigen::Vector3d(a[0], a[1], a[2]), Eigen::Vector3d(a[3], a[4], a[5])});
        for (double p; pr >> p;) t.predicted.push_back(p);
        rr >> t.rms_reproj;
        t.true_cam_from_frame = chess_true;
        t.ok = t.r.cam_from_board.size() == chess_true.size();
        if (!t.ok) t.failure = "mrcal's frames do not match the images with corners";
      }
    }
  }

  // (c) OpenCV calibrateCamera on the same corners (rational model = OPENCV8).
  {
    ToolResult& t = tools[2];
    t.name = "OpenCV calibrateCamera (chessboard)";
    std::vector<std::vector<cv::Point3f>> obj(chess_corners.size());
    for (auto& v : obj)
      for (int k = 0; k < kCornersX * kCornersY; ++k) {
        const Eigen::Vector3d p = FrameCorner(k);
        v.emplace_back(p.x(), p.y(), 0);
      }
    cv::Mat K, D, sd_in, sd_ex, per_view;
    std::vector<cv::Mat> rvecs, tvecs;
    const double t0 = Now();
    const double rms = cv::calibrateCamera(obj, chess_corners, cv::Size(W, H), K, D, rvecs, tvecs,
                                           sd_in, sd_ex, per_view, cv::CALIB_RATIONAL_MODEL);
    t.seconds = Now() - t0;
    std::vector<double> in = {K.at<double>(0, 0), K.at<double>(1, 1), K.at<double>(0, 2),
                              K.at<double>(1, 2)};
    for (int k = 0; k < 8; ++k) in.push_back(D.at<double>(k));
    t.ok = CameraModel::Create("LENSMODEL_OPENCV8", in, W, H, &t.r.camera).ok();
    t.rms_reproj = rms;  // OpenCV's RMS is per point (2-D norm)
    for (size_t v = 0; v < rvecs.size(); ++v)
      t.r.cam_from_board.push_back(Pose{
          Eigen::Vector3d(rvecs[v].at<double>(0), rvecs[v].at<double>(1), rvecs[v].at<double>(2)),
          Eigen::Vector3d(tvecs[v].at<double>(0), tvecs[v].at<double>(1), tvecs[v].at<double>(2))});
    t.true_cam_from_frame = chess_true;
    // OpenCV's prediction: its per-parameter sigmas (no correlations) through the projection.
    for (const auto& px : grid) {
      Eigen::Vector3d dir;
      Eigen::Vector2d q;
      Eigen::Matrix<double, 2, 3> dq_dp;
      Eigen::Matrix<double, 2, Eigen::Dynamic> dq_di;
      double s = NAN;
      if (t.ok && t.r.camera.Unproject(px, &dir) &&
          t.r.camera.Project(kRange * dir, &q, &dq_dp, &dq_di)) {
        double tr = 0;
        for (int k = 0; k < 12; ++k)
          tr += dq_di.col(k).squaredNorm() * std::pow(sd_in.at<double>(k), 2);
        s = std::sqrt(tr);
      }
      t.predicted.push_back(s);
    }
  }

  for (ToolResult& t : tools)
    if (t.ok) Measure(truth, grid, cells, &t);
  if (pass1.ok) Measure(truth, grid, cells, &pass1);

  // Cross-check with mrcal's own comparison: mrcal.projection_diff of each solved model against
  // the true one, the implied transform fitted within the largest circle about the image centre
  // that holds only region cells (no board poses involved), then evaluated at the grid.
  double focus_radius = 1e9;
  for (size_t g = 0; g < grid.size(); ++g)
    if (cells[g] != kBoth)
      focus_radius =
          std::min(focus_radius, (grid[g] - Eigen::Vector2d(0.5 * (W - 1), 0.5 * (H - 1))).norm());
  std::vector<std::array<double, 3>> pdiff(tools.size(), {NAN, NAN, NAN});  // region, whole, worst
  {
    const fs::path dir = fs::path(o.out) / "projection_diff";
    fs::create_directories(dir, ec);
    truth.Write((dir / "true.cameramodel").string());
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
    if (!models.empty()) {
      {
        OutputFile cf(dir / "cells.txt");
        for (int c : cells) cf << c << "\n";
      }
      std::vector<std::string> argv{"/usr/bin/python3",
                                    (dir / "diff.py").string(),
                                    (dir / "true.cameramodel").string(),
                                    std::to_string(kRange),
                                    std::to_string(focus_radius),
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
        if (k < pdiff.size()) pdiff[k] = {r0, r1, r2};
      }
    }
  }

  // The SVMS board's corners against the truth: what the a-posteriori noise estimates. Each
  // inlier's detected pixel minus the true camera's projection of its board point through the
  // view's true pose.
  const ToolResult& a0 = tools[0];
  struct CornerNoise {
    double rms = NAN, mean_x = NAN, mean_y = NAN;
  };
  auto corner_noise = [&](const ToolResult& t, const std::vector<ViewObservations>& views) {
    CornerNoise cn;
    double s2 = 0, sx = 0, sy = 0;
    int count = 0;
    for (size_t v = 0; t.ok && v < t.r.views.size(); ++v) {
      const auto& pts = views[t.r.views[v]].points;
      for (size_t i = 0; i < pts.size(); ++i) {
        Eigen::Vector2d q;
        if (t.r.outlier[v][i] ||
            !truth.Project(t.true_cam_from_frame[v] * pts[i].point_in_board, &q))
          continue;
        const Eigen::Vector2d e = pts[i].pixel - q;
        s2 += e.squaredNorm(), sx += e.x(), sy += e.y(), ++count;
      }
    }
    if (count > 0)
      cn.rms = std::sqrt(s2 / (2.0 * count)), cn.mean_x = sx / count, cn.mean_y = sy / count;
    return cn;
  };
  const CornerNoise cn = corner_noise(a0, out.views), cn1 = corner_noise(pass1, out.pass1_views);
  const double cn_rms = cn.rms, cn_mean_x = cn.mean_x, cn_mean_y = cn.mean_y;

  // svms's predicted uncertainty against a Monte-Carlo on the same geometry: the used views'
  // inlier points put at their true projections plus Gaussian noise of the a-posteriori sigma,
  // re-solved `trials` times; the RMS of the aligned error over the region and the trials
  // against the RMS of the predictions. One calibration is one draw of an error that is
  // correlated across the image, so the single-run ratio above is itself a noisy number; this
  // checks the propagation itself.
  const int trials = o.quick ? 4 : 12;
  double mc_e2 = 0, mc_p2 = 0, mc_seconds = 0;
  int mc_n = 0, mc_ok = 0;
  if (a0.ok) {
    std::mt19937_64 rng(20261122);
    std::normal_distribution<double> gauss(0, 1);
    const double t0 = Now();
    Progress progress("svms bench calibrate: Monte-Carlo", trials);
    for (int trial = 0; trial < trials; ++trial) {
      std::vector<ViewObservations> syn;
      std::vector<Pose> syn_true;
      for (size_t v = 0; v < a0.r.views.size(); ++v) {
        ViewObservations w = out.views[a0.r.views[v]];
        w.points.clear();
        const auto& pts = out.views[a0.r.views[v]].points;
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
      CalibrationOptions co = ro.calib;
      co.width = W, co.height = H, co.verbose = false, co.threads = o.threads;
      CalibrationResult rr;
      if (!Calibrate(syn, co, &rr).ok()) continue;
      ++mc_ok;
      std::vector<Pose> used_true;
      for (int v : rr.views) used_true.push_back(syn_true[v]);
      for (size_t g = 0; g < grid.size(); ++g) {
        Eigen::Vector2d e;
        Eigen::Matrix2d C;
        if (cells[g] != kBoth ||
            !AlignedProjectionError(rr, truth, used_true, grid[g], kRange, &e) ||
            !ProjectionCovariance(rr, grid[g], kRange, &C))
          continue;
        mc_e2 += e.squaredNorm(), mc_p2 += C.trace(), ++mc_n;
      }
      progress.Update(trial + 1);
    }
    progress.Finish();
    mc_seconds = Now() - t0;
  }
  const double mc_err = mc_n ? std::sqrt(mc_e2 / mc_n) : NAN;
  const double mc_pred = mc_n ? std::sqrt(mc_p2 / mc_n) : NAN;

  // Outputs: CSV, JSON, plots and report.md.
  int region_cells = 0;
  for (int c : cells) region_cells += c == kBoth;
  {
    OutputFile csv(fs::path(o.out) / "calibrate.csv");
    csv << "tool,ok,views,reprojection_rms_px,region_error_rms_px,region_error_worst_px,"
           "region_predicted_rms_px,error_rms_px,error_worst_px,direct_error_rms_px,"
           "predicted_rms_px,seconds\n";
    for (const ToolResult& t : tools)
      csv << '"' << t.name << "\"," << t.ok << "," << t.r.cam_from_board.size() << ","
          << t.rms_reproj << "," << t.region_err_rms << "," << t.region_err_worst << ","
          << t.region_pred_rms << "," << t.err_rms << "," << t.err_worst << "," << t.direct_rms
          << "," << t.pred_rms << "," << t.seconds << "\n";
    // Per grid cell: x y, then |error| and predicted for svms, mrcal, OpenCV, then the cell's
    // data flags (1 SVMS board, 2 chessboard, 3 both = the region).
    OutputFile g(fs::path(o.out) / "calibrate_grid.dat");
    for (size_t k = 0; k < grid.size(); ++k) {
      g << grid[k].x() << " " << grid[k].y();
      for (const ToolResult& t : tools)
        g << " " << (k < t.error.size() ? t.error[k] : NAN) << " "
          << (k < t.predicted.size() ? t.predicted[k] : NAN);
      g << " " << cells[k] << "\n";
    }
  }
  nlohmann::json j;
  j["region"] = {{"what", "cells of the " + std::to_string(kGrid) + "x" + std::to_string(kGrid) +
                              " grid holding both SVMS board and chessboard corners"},
                 {"cells", region_cells}};
  j["tools"] = nlohmann::json::array();
  for (const ToolResult& t : tools)
    j["tools"].push_back({{"tool", t.name},
                          {"ok", t.ok},
                          {"failure", t.failure},
                          {"views", t.r.cam_from_board.size()},
                          {"reprojection_rms_px", t.rms_reproj},
                          {"region_error_rms_px", t.region_err_rms},
                          {"region_error_worst_px", t.region_err_worst},
                          {"region_predicted_rms_px", t.region_pred_rms},
                          {"error_rms_px", t.err_rms},
                          {"error_worst_px", t.err_worst},
                          {"direct_error_rms_px", t.direct_rms},
                          {"predicted_rms_px", t.pred_rms},
                          {"seconds", t.seconds}});
  j["projection_diff"] = nlohmann::json::array();
  for (size_t k = 0; k < tools.size(); ++k)
    j["projection_diff"].push_back({{"tool", tools[k].name},
                                    {"focus_radius_px", focus_radius},
                                    {"region_rms_px", pdiff[k][0]},
                                    {"whole_image_rms_px", pdiff[k][1]},
                                    {"whole_image_worst_px", pdiff[k][2]}});
  j["svms_corner_noise"] = {{"a_posteriori_sigma_px", tools[0].r.noise_sigma_px},
                            {"true_rms_per_axis_px", cn_rms},
                            {"true_mean_px", {cn_mean_x, cn_mean_y}},
                            {"pass1_a_posteriori_sigma_px", pass1.r.noise_sigma_px},
                            {"pass1_true_rms_per_axis_px", cn1.rms}};
  if (pass1.ok)
    j["svms_pass1"] = {{"region_error_rms_px", pass1.region_err_rms},
                       {"region_predicted_rms_px", pass1.region_pred_rms},
                       {"error_rms_px", pass1.err_rms}};
  j["monte_carlo"] = {{"trials", trials},
                      {"solved", mc_ok},
                      {"region_error_rms_px", mc_err},
                      {"region_predicted_rms_px", mc_pred},
                      {"seconds", mc_seconds}};
  OutputFile(fs::path(o.out) / "calibrate.json") << j.dump(2) << "\n";
  char body[4096];
  std::snprintf(
      body, sizeof body,
      "set title 'Projection error vs the true camera at %.1f m (filled: in the region)'\n"
      "set xlabel 'distance of the pixel from the image centre (px)'\nset ylabel 'px'\n"
      "set logscale y\nset grid\nset key top left\n"
      "c(x,y) = sqrt((x-%g)**2 + (y-%g)**2)\n"
      "plot 'calibrate_grid.dat' u (c($1,$2)):($9==3?$3:1/0) w p pt 7 ps 0.5 lc rgb '#3060c0' "
      "t 'svms', '' u (c($1,$2)):($9==3?1/0:$3) w p pt 6 ps 0.5 lc rgb '#3060c0' t '', "
      "'' u (c($1,$2)):($9==3?$5:1/0) w p pt 7 ps 0.5 lc rgb '#20a040' t 'mrcal', "
      "'' u (c($1,$2)):($9==3?1/0:$5) w p pt 6 ps 0.5 lc rgb '#20a040' t '', "
      "'' u (c($1,$2)):($9==3?$7:1/0) w p pt 7 ps 0.5 lc rgb '#d04020' t 'OpenCV', "
      "'' u (c($1,$2)):($9==3?1/0:$7) w p pt 6 ps 0.5 lc rgb '#d04020' t ''",
      kRange, 0.5 * (W - 1), 0.5 * (H - 1));
  if (Status s = Gnuplot(o.out, "calibrate_error", body); !s)
    std::cerr << "svms bench calibrate: " << s.message() << "\n";
  std::snprintf(
      body, sizeof body,
      "set title 'Predicted vs true projection error per grid cell in the region (%.1f m)'\n"
      "set xlabel 'true |error| (px)'\nset ylabel 'predicted sqrt(trace Var q) (px)'\n"
      "set logscale xy\nset grid\nset key top left\nset size ratio -1\n"
      "set xrange [1e-4:0.1]\nset yrange [1e-4:0.1]\n"
      "plot 'calibrate_grid.dat' u ($9==3?$3:1/0):4 w p pt 7 ps 0.5 lc rgb '#3060c0' t 'svms', "
      "'' u ($9==3?$5:1/0):6 w p pt 7 ps 0.5 lc rgb '#20a040' t 'mrcal', "
      "x w l lc rgb 'black' t 'predicted = true', 0.7*x w l dt 2 lc rgb 'gray' t '0.7, 1.4', "
      "1.4*x w l dt 2 lc rgb 'gray' t ''",
      kRange);
  if (Status s = Gnuplot(o.out, "calibrate_predicted_vs_true", body); !s)
    std::cerr << "svms bench calibrate: " << s.message() << "\n";
  std::snprintf(body, sizeof body,
                "set title 'The evaluation region: grid cells with data'\nset xrange [0:%d]\n"
                "set yrange [%d:0]\nset size ratio -1\nset key outside bottom center horizontal\n"
                "plot 'calibrate_grid.dat' u 1:($9==3?$2:1/0) w p pt 5 ps 1.2 lc rgb '#3060c0' "
                "t 'both (region)', '' u 1:($9==1?$2:1/0) w p pt 5 ps 1.2 lc rgb '#a0b0e0' t "
                "'SVMS board only', '' u 1:($9==2?$2:1/0) w p pt 5 ps 1.2 lc rgb '#a0e0b0' t "
                "'chessboard only', '' u 1:($9==0?$2:1/0) w p pt 4 ps 1.2 lc rgb '#c0c0c0' t "
                "'no data'",
                W, H);
  if (Status s = Gnuplot(o.out, "calibrate_region", body); !s)
    std::cerr << "svms bench calibrate: " << s.message() << "\n";
  for (const char* f : {"residual_histogram", "residual_vectors", "coverage", "uncertainty"}) {
    for (const char* ext : {".png", ".svg"})
      fs::copy_file(fs::path(o.out) / "svms_report" / (std::string(f) + ext),
                    fs::path(o.out) / ("calibrate_" + std::string(f) + ext),
                    fs::copy_options::overwrite_existing, ec);
  }

  OutputFile md(fs::path(o.out) / "report.md");
  md << "## Camera calibration\n\n"
     << "`svms bench calibrate" << (o.quick ? " --quick" : "")
     << "` on the simulator's calibration dataset: " << nviews
     << " views of a 6x5 SVMS marker board and, at the same poses, of a 10x8 chessboard, "
     << "1024x1024 " << truth.lensmodel()
     << " camera (the true model is known and all three tools solve for that same model). "
     << "(a) `svms calibrate` on the marker board (two passes: the second re-detects the corners "
        "with the first pass's lens model, see the pass-1 row); (b) mrcal 2.2's "
        "`mrcal-calibrate-cameras` on "
        "the chessboard corners found by OpenCV's `findChessboardCornersSB`; (c) OpenCV's "
        "`calibrateCamera` (`CALIB_RATIONAL_MODEL`, the same 8 distortion terms) on the same "
        "corners.\n\n"
     << "Error: the projection error against the true camera at " << kRange << " m at the "
     << "centres of a " << kGrid << "x" << kGrid
     << " grid of cells over the image, after mapping through the solved board poses as "
        "mrcal's uncertainty does (`AlignedProjectionError`). **Region**: the "
     << region_cells << " of the " << kGrid * kGrid
     << " cells that hold both SVMS board corners and chessboard corners "
     << "(map below); in the cells outside it "
        "a rational model only extrapolates, so the whole-image figures are given too but "
        "judge that extrapolation as well as the calibration (mrcal likewise evaluates where "
        "the data are: "
        "`valid_intrinsics_region`, `projection_diff`'s focus radius). \"Direct\" compares "
        "the two cameras over the whole image with no alignment. Predicted: each tool's own "
        "predicted standard deviation of that error, sqrt(trace(Var q)) (svms: propagated "
        "from the a-posteriori corner noise through the optimum as mrcal does; mrcal: "
        "`mrcal.projection_uncertainty`; OpenCV: its per-parameter sigmas through the "
        "projection, no correlations).\n\n"
     << "| tool | views | reprojection RMS (px) | region: error RMS (px) | region: error worst "
        "(px) | region: predicted RMS (px) | region: predicted / error | whole image: error "
        "RMS (px) | whole image: error worst (px) | whole image: predicted RMS (px) | direct "
        "error RMS (px) | time (s) |\n"
     << "|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  char line[1024];
  for (const ToolResult& t : tools) {
    if (!t.ok) {
      md << "| " << t.name << " | failed: " << t.failure << " | | | | | | | | | | |\n";
      continue;
    }
    std::snprintf(line, sizeof line,
                  "| %s | %zu | %.3f | %.4f | %.4f | %.4f | %.2f | %.3f | %.2f | %.3g | %.3f | "
                  "%.1f |\n",
                  t.name.c_str(), t.r.cam_from_board.size(), t.rms_reproj, t.region_err_rms,
                  t.region_err_worst, t.region_pred_rms, t.region_pred_rms / t.region_err_rms,
                  t.err_rms, t.err_worst, t.pred_rms, t.direct_rms, t.seconds);
    md << line;
  }
  if (pass1.ok) {
    std::snprintf(line, sizeof line,
                  "| *%s* | %zu | %.3f | %.4f | %.4f | %.4f | %.2f | %.3f | %.2f | %.3g | %.3f | "
                  "|\n",
                  pass1.name.c_str(), pass1.r.cam_from_board.size(), pass1.rms_reproj,
                  pass1.region_err_rms, pass1.region_err_worst, pass1.region_pred_rms,
                  pass1.region_pred_rms / pass1.region_err_rms, pass1.err_rms, pass1.err_worst,
                  pass1.pred_rms, pass1.direct_rms);
    md << line;
  }
  const ToolResult &a = tools[0], &b = tools[1], &c = tools[2];
  // The region error's predicted/true ratio of one calibration is one draw (its true error is
  // one sample of the spread the covariance predicts): only the Monte-Carlo's ratio is judged.
  BenchTargets targets;
  if (a.ok && b.ok && c.ok) {
    const double ratio = a.region_pred_rms / a.region_err_rms;
    const double mc_ratio = mc_pred / mc_err;
    targets.Add("Our region error within 10 % of mrcal's",
                a.region_err_rms <= 1.1 * b.region_err_rms,
                Fixed(a.region_err_rms, 4) + " vs " + Fixed(b.region_err_rms, 4) + " px");
    targets.Add("Below OpenCV's", a.region_err_rms < c.region_err_rms,
                Fixed(c.region_err_rms, 4) + " px");
    targets.NotJudged("Predicted / true region error in [0.7, 1.4] in this one calibration",
                      Fixed(ratio, 2) + ", one draw; the Monte-Carlo below judges the prediction");
    targets.Add("Predicted / true region error in [0.7, 1.4] over a " + std::to_string(mc_ok) +
                    "-trial Monte-Carlo on the same geometry",
                mc_ratio >= 0.7 && mc_ratio <= 1.4, Fixed(mc_ratio, 2));
    md << "\nTargets, over the region:\n\n" << targets.Markdown();
  }
  md << "\nCross-check with mrcal's own comparison, `mrcal.projection_diff` against the true "
        "model (the implied rotation fitted within "
     << static_cast<int>(focus_radius)
     << " px of the image centre, the largest circle holding only region cells; no board poses "
        "involved):\n\n| tool | region RMS (px) | whole image RMS (px) | whole image worst (px) "
        "|\n|---|---|---|---|\n";
  for (size_t k = 0; k < tools.size(); ++k) {
    std::snprintf(line, sizeof line, "| %s | %.4f | %.3f | %.2f |\n", tools[k].name.c_str(),
                  pdiff[k][0], pdiff[k][1], pdiff[k][2]);
    md << line;
  }
  md << "\nOutside the region every tool extrapolates an 8-term rational model into cells "
        "no view reached, and the whole-image figures rank that extrapolation too. OpenCV "
        "and mrcal see identical corners; mrcal additionally regularises the distortion terms "
        "(its optimisation_inputs: `do_apply_regularization`), which biases its solution "
        "without showing in its predicted uncertainty. Where the data barely see a direction "
        "of the state (eigenvalues near svms's pseudo-inverse cutoff of 1e-15 of the largest), "
        "svms's prediction says 'unknown' (large) or, when a direction falls below the cutoff, "
        "too little: it means little outside the data.\n";
  std::snprintf(line, sizeof line,
                "\nsvms's corner noise: a-posteriori sigma %.4f px per axis (from the residuals "
                "of the fit, what the prediction uses); the detected corners against the true "
                "projections: %.4f px RMS per axis, mean (%+.4f, %+.4f) px. In pass 1 (sides "
                "fitted as straight lines in pixels): a-posteriori %.4f px, against the truth "
                "%.4f px RMS per axis.\n",
                a.r.noise_sigma_px, cn_rms, cn_mean_x, cn_mean_y, pass1.r.noise_sigma_px, cn1.rms);
  md << line;
  std::snprintf(line, sizeof line,
                "\nMonte-Carlo: the same %zu views and points, put at their true projections "
                "plus Gaussian noise of that sigma, calibrated %d times (%d solved, %.0f s): "
                "aligned error over the region %.4f px RMS, predicted %.4f px RMS (ratio "
                "predicted / true %.2f). A single calibration's error is one draw, correlated "
                "over the image; this checks the propagation itself.\n",
                a.r.views.size(), trials, mc_ok, mc_seconds, mc_err, mc_pred, mc_pred / mc_err);
  md << line;
  md << "\nThe boards differ: the SVMS board gives " << a.r.num_inliers << " corners ("
     << a.r.num_outliers << " rejected as outliers) in " << a.r.views.size() << " of " << nviews
     << " views, the chessboard " << 63 * chess_corners.size() << " corners in "
     << chess_corners.size() << " views, so (a) and (b) do not see the same number of points.\n\n"
     << "![](calibrate_region.png)\n\n"
     << "Error per grid cell against the distance from the image centre (filled: region; "
        "open: outside it):\n\n![](calibrate_error.png)\n\n"
     << "Predicted against true error per cell of the region (one calibration: the true error "
        "of a cell is one draw of a zero-mean variable of that predicted spread, so the points "
        "scatter about the diagonal):\n\n![](calibrate_predicted_vs_true.png)\n\n"
     << "svms calibrate's own report on the board: residuals, residual vectors, coverage and the "
     << "projection uncertainty map.\n\n"
     << "![](calibrate_residual_histogram.png)\n![](calibrate_residual_vectors.png)\n"
     << "![](calibrate_coverage.png)\n![](calibrate_uncertainty.png)\n";
  md.close();
  std::cout << "wrote " << (fs::path(o.out) / "report.md").string() << "\n";
  for (const ToolResult& t : tools)
    std::printf(
        "%-38s %s region (%d cells): error RMS %.4f px, worst %.4f, predicted %.4f; whole "
        "image: error RMS %.4f, worst %.4f, predicted %.4g\n",
        t.name.c_str(), t.ok ? "ok    " : "FAILED", region_cells, t.region_err_rms,
        t.region_err_worst, t.region_pred_rms, t.err_rms, t.err_worst, t.pred_rms);
  if (pass1.ok)
    std::printf(
        "%-38s region: error RMS %.4f px, predicted %.4f; corner noise a-posteriori "
        "%.4f px, true %.4f px\n",
        "svms pass 1 (corners fitted in pixels)", pass1.region_err_rms, pass1.region_pred_rms,
        pass1.r.noise_sigma_px, cn1.rms);
  std::printf(
      "svms corner noise: a-posteriori %.4f px, true %.4f px; Monte-Carlo (%d/%d): "
      "error %.4f px, predicted %.4f px\n",
      a.r.noise_sigma_px, cn_rms, mc_ok, trials, mc_err, mc_pred);
  return (a.ok && b.ok && c.ok) ? targets.ExitCode("svms bench calibrate", kExitOk) : kExitFailed;
}

}  // namespace

void AddBenchCalibrate(CLI::App& bench, int* exit_code) {
  auto o = std::make_shared<BenchOptions>();
  CLI::App* cmd = bench.add_subcommand(
      "calibrate", "Calibration accuracy vs the true camera: svms, mrcal and OpenCV side by side");
  cmd->add_option("--out", o->out, "Output directory (data/, CSV, JSON, plots, report.md)")
      ->required();
  cmd->add_flag("--quick", o->quick, "The first 12 views only (smoke test)");
  cmd->add_option("--threads", o->threads, "Rendering and detection threads")
      ->check(CLI::Range(1, 256));
  cmd->footer("Example:\n  svms bench calibrate --out out/bench/calibrate");
  cmd->callback(
      [o, exit_code] { *exit_code = FinishOutputs("svms bench calibrate", RunBench(*o)); });
}

}  // namespace svms::cli
