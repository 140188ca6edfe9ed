#include "svms/bench/calibrate_tools.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>

#include "svms/base/format.h"
#include "svms/geometry/alignment.h"
#include "svms/marker/model_io.h"
#include "svms/pipelines/exit_codes.h"
#include "svms/pipelines/render_scene.h"
#include "svms/pipelines/report_file.h"
#include "svms/pipelines/run_program.h"

namespace svms {
namespace {

namespace fs = std::filesystem;

// The chessboard's inner corners in its object frame (x right, y up, centred), index j*9+i with
// i along x and j down the rows as printed.
Eigen::Vector3d ChessCorner(int i, int j) {
  return {(i - 0.5 * (kChessCornersX - 1)) * kChessSquare,
          (0.5 * (kChessCornersY - 1) - j) * kChessSquare, 0};
}

// mrcal's (and our OpenCV objectPoints') frame: corner k = j*9+i at (i*s, j*s, 0).
Eigen::Vector3d FrameCorner(int k) {
  return {(k % kChessCornersX) * kChessSquare, (k / kChessCornersX) * kChessSquare, 0};
}

// The true cam_from_frame of one chessboard view: each detected corner is matched to the nearest
// true projection, then board_from_frame is the rigid fit (Kabsch) of frame to board points.
bool TrueFrame(const CameraModel& truth, const Pose& cam_from_board,
               const std::vector<cv::Point2f>& corners, Pose* cam_from_frame) {
  std::vector<Eigen::Vector2d> proj;
  std::vector<Eigen::Vector3d> board;
  for (int j = 0; j < kChessCornersY; ++j)
    for (int i = 0; i < kChessCornersX; ++i) {
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

// The view index of a rendered calibration image ("calib_0007.png": 7).
int ViewIndex(const std::string& image) {
  int idx = 0;
  std::sscanf(fs::path(image).filename().c_str(), "calib_%d", &idx);
  return idx;
}

// The true cam_from_board of each view `r` used (a run of svms calibrate, `out`).
std::vector<Pose> TrueFrames(const CalibrationData& data, const CalibrateRunOutcome& out,
                             const CalibrationResult& r) {
  std::vector<Pose> poses;
  for (int v : r.views) poses.push_back(data.true_cam_from_board[ViewIndex(out.image_of_view[v])]);
  return poses;
}

// sqrt(trace) of `r`'s projection covariance at each grid pixel at kCalibrateRange (NaN where
// there is none, or when `ok` is false).
std::vector<double> PredictedOverGrid(const CalibrationResult& r, bool ok,
                                      const std::vector<Eigen::Vector2d>& grid) {
  std::vector<double> predicted;
  for (const auto& px : grid) {
    Eigen::Matrix2d C;
    predicted.push_back(
        ok && ProjectionCovariance(r, px, kCalibrateRange, &C) ? std::sqrt(C.trace()) : NAN);
  }
  return predicted;
}

}  // namespace

int GridCellOf(const Eigen::Vector2d& px, int W, int H) {
  const int cx =
      std::clamp(static_cast<int>((px.x() + 0.5) * kCalibrateGrid / W), 0, kCalibrateGrid - 1);
  const int cy =
      std::clamp(static_cast<int>((px.y() + 0.5) * kCalibrateGrid / H), 0, kCalibrateGrid - 1);
  return cy * kCalibrateGrid + cx;
}

void Measure(const CalibrationData& data, ToolResult* t) {
  const CameraModel& truth = data.truth;
  const std::vector<Eigen::Vector2d>& grid = data.grid;
  const std::vector<int>& cells = data.cells;
  double e2 = 0, d2 = 0, p2 = 0, worst = 0, re2 = 0, rp2 = 0, rworst = 0;
  int n = 0, np = 0, rn = 0;
  t->error.assign(grid.size(), NAN);
  for (size_t g = 0; g < grid.size(); ++g) {
    Eigen::Vector2d e;
    if (!AlignedProjectionError(t->r, truth, t->true_cam_from_frame, grid[g], kCalibrateRange, &e))
      continue;
    t->error[g] = e.norm();
    Eigen::Vector3d dir;
    Eigen::Vector2d q;
    truth.Unproject(grid[g], &dir);
    t->r.camera.Project(kCalibrateRange * dir, &q);
    e2 += e.squaredNorm(), d2 += (q - grid[g]).squaredNorm(), ++n;
    worst = std::max(worst, e.norm());
    const bool pred = g < t->predicted.size() && std::isfinite(t->predicted[g]);
    if (pred) p2 += std::pow(t->predicted[g], 2), ++np;
    if (cells[g] == kBothBoards && pred) {
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

int RenderUnlessPresent(const CalibrateBenchmarkOptions& o, const Scene& scene,
                        const std::string& subdir, const std::string& what) {
  const fs::path dir = fs::path(o.out) / "data" / subdir;
  std::error_code ec;
  fs::create_directories(dir, ec);
  bool have = true;
  for (const View& v : scene.views) have &= fs::exists(dir / (v.name + ".png"));
  if (have) return kExitOk;
  std::cerr << "svms bench calibrate: rendering " << scene.views.size() << " " << what
            << " views\n";
  return RenderScene(scene, "calibration/" + subdir, dir.string(), o.threads, false, false);
}

CalibrateRunOptions SvmsCalibrateOptions(const CalibrateBenchmarkOptions& o,
                                         const CalibrationData& data, const std::string& subdir,
                                         const std::string& out_name) {
  CalibrateRunOptions ro;
  for (const View& v : data.dataset.scenes[0].second.views)
    ro.images.push_back((fs::path(o.out) / "data" / subdir / (v.name + ".png")).string());
  ro.board = "board_layout.json";
  ModelFile f;
  for (const auto& [rel, text] : data.dataset.files)
    if (rel == "board_layout.json") ParseModelJson(text, rel, &f);
  ro.layout = f.layout;
  ro.calib.lensmodel = data.truth.lensmodel();
  ro.out = (fs::path(o.out) / (out_name + ".cameramodel")).string();
  ro.uncertainty_range = kCalibrateRange;
  ro.threads = o.threads;
  return ro;
}

ToolResult MeasuredSvmsResult(const CalibrationData& data, const std::string& name, int rc,
                              const CalibrateRunOutcome& out) {
  ToolResult t;
  t.name = name;
  t.ok = rc == kExitOk;
  if (!t.ok) t.failure = "svms calibrate failed (exit " + std::to_string(rc) + ")";
  t.r = out.result;
  t.rms_reproj = t.r.rms_px;
  t.true_cam_from_frame = TrueFrames(data, out, t.r);
  t.predicted = PredictedOverGrid(t.r, t.ok, data.grid);
  return t;
}

ToolResult RunSvmsCalibrate(const CalibrateBenchmarkOptions& o, CalibrationData* data,
                            CalibrateRunOptions* ro, CalibrateRunOutcome* out, ToolResult* pass1) {
  const CameraModel& truth = data->truth;
  const int W = truth.width(), H = truth.height();
  *ro = SvmsCalibrateOptions(o, *data, "board", "svms");
  ro->report_dir = (fs::path(o.out) / "svms_report").string();
  const double t0 = Now();
  const int rc = RunCalibration(*ro, out);
  ToolResult t = MeasuredSvmsResult(*data, "svms calibrate (SVMS board)", rc, *out);
  t.seconds = Now() - t0;
  // The first pass (corners fitted in pixels, before re-detection with its lens model).
  pass1->name = "svms calibrate, pass 1 only (corners fitted in pixels)";
  pass1->ok = t.ok;
  pass1->r = out->pass1;
  pass1->rms_reproj = pass1->r.rms_px;
  pass1->true_cam_from_frame = TrueFrames(*data, *out, pass1->r);
  pass1->predicted = PredictedOverGrid(pass1->r, t.ok, data->grid);
  for (size_t v = 0; v < t.r.views.size(); ++v) {
    const auto& pts = out->views[t.r.views[v]].points;
    for (size_t i = 0; i < pts.size(); ++i)
      if (!t.r.outlier[v][i]) data->cells[GridCellOf(pts[i].pixel, W, H)] |= kSvmsBoard;
  }
  return t;
}

ChessCorners FindChessboards(const CalibrateBenchmarkOptions& o, CalibrationData* data) {
  const int W = data->truth.width(), H = data->truth.height();
  ChessCorners chess;
  {
    OutputFile vnl(fs::path(o.out) / "corners.vnl");
    vnl << "# filename x y level\n";
    const auto& views = data->dataset.scenes[1].second.views;
    for (size_t i = 0; i < views.size(); ++i) {
      const std::string file =
          (fs::path(o.out) / "data" / "chessboard" / (views[i].name + ".png")).string();
      const cv::Mat img = cv::imread(file, cv::IMREAD_GRAYSCALE);
      std::vector<cv::Point2f> corners;
      const bool found = !img.empty() && cv::findChessboardCornersSB(
                                             img, cv::Size(kChessCornersX, kChessCornersY), corners,
                                             cv::CALIB_CB_EXHAUSTIVE | cv::CALIB_CB_ACCURACY);
      Pose cam_from_frame;
      if (!found ||
          !TrueFrame(data->truth, data->true_cam_from_board[i], corners, &cam_from_frame)) {
        std::cerr << "svms bench calibrate: " << file << ": chessboard not found\n";
        vnl << views[i].name << ".png - - -\n";
        continue;
      }
      for (const cv::Point2f& c : corners) {
        vnl << views[i].name << ".png " << Significant(c.x, 10) << " " << Significant(c.y, 10)
            << " 0\n";
        data->cells[GridCellOf(Eigen::Vector2d(c.x, c.y), W, H)] |= kChessboard;
      }
      chess.files.push_back(views[i].name + ".png");
      chess.corners.push_back(corners);
      chess.true_cam_from_frame.push_back(cam_from_frame);
    }
  }
  std::cerr << "svms bench calibrate: chessboard found in " << chess.files.size() << " of "
            << data->views << " images\n";
  return chess;
}

ToolResult RunMrcal(const CalibrateBenchmarkOptions& o, const CalibrationData& data,
                    const ChessCorners& chess) {
  const CameraModel& truth = data.truth;
  ToolResult t;
  t.name = "mrcal (chessboard)";
  const fs::path mdir = fs::path(o.out) / "mrcal";
  std::error_code ec;
  fs::create_directories(mdir, ec);
  const std::string focal = Fixed(truth.intrinsics()[0], 0);
  const std::string spacing = Significant(kChessSquare, 6);
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
                                      std::to_string(kChessCornersX),
                                      "--object-height-n",
                                      std::to_string(kChessCornersY),
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
    if (RunProgram({"/usr/bin/python3", py, model, Fixed(kCalibrateRange, 6),
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
      t.true_cam_from_frame = chess.true_cam_from_frame;
      t.ok = t.r.cam_from_board.size() == chess.true_cam_from_frame.size();
      if (!t.ok) t.failure = "mrcal's frames do not match the images with corners";
    }
  }
  return t;
}

ToolResult RunOpenCv(const CalibrationData& data, const ChessCorners& chess) {
  const int W = data.truth.width(), H = data.truth.height();
  ToolResult t;
  t.name = "OpenCV calibrateCamera (chessboard)";
  std::vector<std::vector<cv::Point3f>> obj(chess.corners.size());
  for (auto& v : obj)
    for (int k = 0; k < kChessCornersX * kChessCornersY; ++k) {
      const Eigen::Vector3d p = FrameCorner(k);
      v.emplace_back(p.x(), p.y(), 0);
    }
  cv::Mat K, D, sd_in, sd_ex, per_view;
  std::vector<cv::Mat> rvecs, tvecs;
  const double t0 = Now();
  const double rms = cv::calibrateCamera(obj, chess.corners, cv::Size(W, H), K, D, rvecs, tvecs,
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
  t.true_cam_from_frame = chess.true_cam_from_frame;
  // OpenCV's prediction: its per-parameter sigmas (no correlations) through the projection.
  for (const auto& px : data.grid) {
    Eigen::Vector3d dir;
    Eigen::Vector2d q;
    Eigen::Matrix<double, 2, 3> dq_dp;
    Eigen::Matrix<double, 2, Eigen::Dynamic> dq_di;
    double s = NAN;
    if (t.ok && t.r.camera.Unproject(px, &dir) &&
        t.r.camera.Project(kCalibrateRange * dir, &q, &dq_dp, &dq_di)) {
      double tr = 0;
      for (int k = 0; k < 12; ++k)
        tr += dq_di.col(k).squaredNorm() * std::pow(sd_in.at<double>(k), 2);
      s = std::sqrt(tr);
    }
    t.predicted.push_back(s);
  }
  return t;
}

}  // namespace svms
