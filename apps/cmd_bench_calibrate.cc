// svms bench calibrate: calibration accuracy on the simulator's calibration dataset, whose true
// camera is known. (a) svms calibrate on the SVMS board; (b) mrcal's own optimizer
// (mrcal-calibrate-cameras) on a chessboard rendered with the same camera and poses, corners by
// OpenCV's findChessboardCornersSB; (c) OpenCV's calibrateCamera on the same corners. For each:
// the projection error against the true camera over the image, and the tool's own predicted
// uncertainty.
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <thread>

#include "calibrate_run.h"
#include "commands.h"
#include "gnuplot.h"
#include "svms/datasets.h"
#include "svms/model_io.h"

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
// calib::AlignedProjectionError applies; `predicted` is sqrt(trace) per grid pixel.
struct ToolResult {
  std::string name;
  bool ok = false;
  std::string failure;
  calib::CalibrationResult r;
  std::vector<Pose> true_cam_from_frame;  // per used view
  std::vector<double> predicted;          // per grid pixel, px (NaN where unavailable)
  double rms_reproj = 0;
  double seconds = 0;
  // Measured over the grid:
  double err_rms = 0, err_worst = 0, direct_rms = 0, pred_rms = 0;
};

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
  const Eigen::Vector3d ca = A.rowwise().mean(), cb = B.rowwise().mean();
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd((B.colwise() - cb) * (A.colwise() - ca).transpose(),
                                              Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d R = svd.matrixU() * svd.matrixV().transpose();
  if (R.determinant() < 0) {
    Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
    D(2, 2) = -1;
    R = svd.matrixU() * D * svd.matrixV().transpose();
  }
  *cam_from_frame = cam_from_board * Pose::FromRotation(R, cb - R * ca);
  return true;
}

void Measure(const CameraModel& truth, const std::vector<Eigen::Vector2d>& grid, ToolResult* t) {
  double e2 = 0, d2 = 0, p2 = 0, worst = 0;
  int n = 0, np = 0;
  for (size_t g = 0; g < grid.size(); ++g) {
    Eigen::Vector2d e;
    if (!calib::AlignedProjectionError(t->r, truth, t->true_cam_from_frame, grid[g], kRange, &e))
      continue;
    Eigen::Vector3d dir;
    Eigen::Vector2d q;
    truth.Unproject(grid[g], &dir);
    t->r.camera.Project(kRange * dir, &q);
    e2 += e.squaredNorm(), d2 += (q - grid[g]).squaredNorm(), ++n;
    worst = std::max(worst, e.norm());
    if (g < t->predicted.size() && std::isfinite(t->predicted[g]))
      p2 += std::pow(t->predicted[g], 2), ++np;
  }
  t->err_rms = n ? std::sqrt(e2 / n) : NAN;
  t->direct_rms = n ? std::sqrt(d2 / n) : NAN;
  t->err_worst = worst;
  t->pred_rms = np ? std::sqrt(p2 / np) : NAN;
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
    std::ofstream g(fs::path(o.out) / "grid.txt");
    g.precision(17);
    for (const auto& p : grid) g << p.x() << " " << p.y() << "\n";
  }
  std::vector<ToolResult> tools(3);

  // (a) svms calibrate on the marker board.
  {
    ToolResult& t = tools[0];
    t.name = "svms calibrate (SVMS board)";
    CalibrateRunOptions ro;
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
    CalibrateRunOutcome out;
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
    for (const auto& px : grid) {
      Eigen::Matrix2d C;
      t.predicted.push_back(
          t.ok && calib::ProjectionCovariance(t.r, px, kRange, &C) ? std::sqrt(C.trace()) : NAN);
    }
  }

  // Chessboard corners (OpenCV), shared by (b) and (c).
  std::vector<std::string> chess_files;
  std::vector<std::vector<cv::Point2f>> chess_corners;
  std::vector<Pose> chess_true;
  {
    std::ofstream vnl(fs::path(o.out) / "corners.vnl");
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
      for (const cv::Point2f& c : corners)
        vnl << views[i].name << ".png " << c.x << " " << c.y << " 0\n";
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
    char cmd[2048];
    std::snprintf(cmd, sizeof cmd,
                  "cd '%s' && mrcal-calibrate-cameras --corners-cache '%s' --lensmodel %s "
                  "--focal %.0f --object-spacing %g --object-width-n %d --object-height-n %d "
                  "--outdir '%s' 'calib_*.png' > '%s/mrcal.log' 2>&1",
                  fs::absolute(fs::path(o.out) / "data" / "chessboard").c_str(),
                  fs::absolute(fs::path(o.out) / "corners.vnl").c_str(), truth.lensmodel().c_str(),
                  truth.intrinsics()[0], kSquare, kCornersX, kCornersY, fs::absolute(mdir).c_str(),
                  fs::absolute(mdir).c_str());
    const double t0 = Now();
    const int rc = std::system(cmd);
    t.seconds = Now() - t0;
    const std::string model = (mdir / "camera-0.cameramodel").string();
    if (rc != 0 || !CameraModel::Read(model, &t.r.camera).ok()) {
      t.failure = "mrcal-calibrate-cameras failed (see mrcal/mrcal.log)";
    } else {
      // Frames, residual RMS and mrcal's own projection uncertainty from its Python API.
      const std::string py = (mdir / "uncertainty.py").string();
      std::ofstream(py) << "import sys, numpy as np, mrcal\n"
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
      const std::string pycmd =
          "/usr/bin/python3 '" + py + "' '" + model + "' " + std::to_string(kRange) + " '" +
          (fs::path(o.out) / "grid.txt").string() + "' '" + (mdir / "frames.txt").string() + "' '" +
          (mdir / "predicted.txt").string() + "' > '" + (mdir / "rms.txt").string() + "' 2>'" +
          (mdir / "py.log").string() + "'";
      if (std::system(pycmd.c_str()) != 0) {
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
    if (t.ok) Measure(truth, grid, &t);

  // Outputs: CSV, JSON, a plot and report.md.
  {
    std::ofstream csv(fs::path(o.out) / "calibrate.csv");
    csv << "tool,ok,views,reprojection_rms_px,error_rms_px,error_worst_px,direct_error_rms_px,"
           "predicted_rms_px,seconds\n";
    for (const ToolResult& t : tools)
      csv << '"' << t.name << "\"," << t.ok << "," << t.r.cam_from_board.size() << ","
          << t.rms_reproj << "," << t.err_rms << "," << t.err_worst << "," << t.direct_rms << ","
          << t.pred_rms << "," << t.seconds << "\n";
    std::ofstream g(fs::path(o.out) / "calibrate_grid.dat");
    for (size_t k = 0; k < grid.size(); ++k) {
      g << grid[k].x() << " " << grid[k].y();
      for (const ToolResult& t : tools) {
        Eigen::Vector2d e(NAN, NAN);
        if (t.ok)
          calib::AlignedProjectionError(t.r, truth, t.true_cam_from_frame, grid[k], kRange, &e);
        g << " " << e.norm() << " " << (k < t.predicted.size() ? t.predicted[k] : NAN);
      }
      g << "\n";
    }
  }
  nlohmann::json j = nlohmann::json::array();
  for (const ToolResult& t : tools)
    j.push_back({{"tool", t.name},
                 {"ok", t.ok},
                 {"failure", t.failure},
                 {"views", t.r.cam_from_board.size()},
                 {"reprojection_rms_px", t.rms_reproj},
                 {"error_rms_px", t.err_rms},
                 {"error_worst_px", t.err_worst},
                 {"direct_error_rms_px", t.direct_rms},
                 {"predicted_rms_px", t.pred_rms},
                 {"seconds", t.seconds}});
  std::ofstream(fs::path(o.out) / "calibrate.json") << j.dump(2) << "\n";
  char body[2048];
  std::snprintf(
      body, sizeof body,
      "set title 'Projection error vs the true camera at %.1f m, along the image diagonal "
      "band'\nset xlabel 'distance of the pixel from the image centre (px)'\nset ylabel "
      "'px'\nset logscale y\nset grid\nset key top left\n"
      "c(x,y) = sqrt((x-%g)**2 + (y-%g)**2)\n"
      "plot 'calibrate_grid.dat' u (c($1,$2)):3 w p pt 7 ps 0.5 lc rgb '#3060c0' t 'svms error', "
      "'' u (c($1,$2)):4 w p pt 6 ps 0.5 lc rgb '#3060c0' t 'svms predicted', "
      "'' u (c($1,$2)):5 w p pt 7 ps 0.5 lc rgb '#20a040' t 'mrcal error', "
      "'' u (c($1,$2)):6 w p pt 6 ps 0.5 lc rgb '#20a040' t 'mrcal predicted', "
      "'' u (c($1,$2)):7 w p pt 7 ps 0.5 lc rgb '#d04020' t 'OpenCV error', "
      "'' u (c($1,$2)):8 w p pt 6 ps 0.5 lc rgb '#d04020' t 'OpenCV predicted'",
      kRange, 0.5 * (W - 1), 0.5 * (H - 1));
  if (Status s = Gnuplot(o.out, "calibrate_error", body); !s)
    std::cerr << "svms bench calibrate: " << s.message() << "\n";
  for (const char* f : {"residual_histogram", "residual_vectors", "coverage", "uncertainty"}) {
    for (const char* ext : {".png", ".svg"})
      fs::copy_file(fs::path(o.out) / "svms_report" / (std::string(f) + ext),
                    fs::path(o.out) / ("calibrate_" + std::string(f) + ext),
                    fs::copy_options::overwrite_existing, ec);
  }

  std::ofstream md(fs::path(o.out) / "report.md");
  md << "## Camera calibration (issue 6)\n\n"
     << "`svms bench calibrate" << (o.quick ? " --quick" : "")
     << "` on the simulator's calibration dataset: " << nviews
     << " views of a 6x5 SVMS marker board and, at the same poses, of a 10x8 chessboard, "
     << "1024x1024 " << truth.lensmodel()
     << " camera (the true model is known and the lens model solved for is the same). "
     << "(a) `svms calibrate` on the marker board; (b) mrcal 2.2's `mrcal-calibrate-cameras` on "
        "the chessboard "
     << "corners found by OpenCV's `findChessboardCornersSB`; (c) OpenCV's `calibrateCamera` "
     << "(`CALIB_RATIONAL_MODEL`) on the same corners.\n\n"
     << "Error: the projection error against the true camera at " << kRange << " m over a " << kGrid
     << "x" << kGrid
     << " grid of the whole image, after mapping through the solved board poses as mrcal's "
        "uncertainty does "
     << "(`calib::AlignedProjectionError`); \"direct\" compares the two cameras with no alignment. "
     << "Predicted: each tool's own predicted standard deviation of that error, sqrt(trace(Var q)) "
     << "(svms: propagated from the input noise through the optimum as mrcal does; mrcal: "
     << "`mrcal.projection_uncertainty`; OpenCV: its per-parameter sigmas through the projection, "
        "no correlations).\n\n"
     << "| tool | views | reprojection RMS (px) | error RMS (px) | error worst (px) | direct error "
        "RMS (px) | predicted RMS (px) | predicted / error | time (s) |\n"
     << "|---|---|---|---|---|---|---|---|---|\n";
  char line[512];
  for (const ToolResult& t : tools) {
    if (!t.ok) {
      md << "| " << t.name << " | failed: " << t.failure << " | | | | | | | |\n";
      continue;
    }
    std::snprintf(line, sizeof line,
                  "| %s | %zu | %.3f | %.4f | %.4f | %.4f | %.4f | %.2f | %.1f |\n", t.name.c_str(),
                  t.r.cam_from_board.size(), t.rms_reproj, t.err_rms, t.err_worst, t.direct_rms,
                  t.pred_rms, t.pred_rms / t.err_rms, t.seconds);
    md << line;
  }
  const ToolResult &a = tools[0], &b = tools[1], &c = tools[2];
  if (a.ok && b.ok && c.ok) {
    std::snprintf(
        line, sizeof line,
        "\nTargets: our error within 10 %% of mrcal's: %.4f vs %.4f px (%+.0f %%) -> %s; below "
        "OpenCV's (%.4f px) -> %s; predicted / true error in [0.7, 1.4]: %.2f -> %s.\n",
        a.err_rms, b.err_rms, 100 * (a.err_rms / b.err_rms - 1),
        a.err_rms <= 1.1 * b.err_rms ? "met" : "NOT met", c.err_rms,
        a.err_rms < c.err_rms ? "met" : "NOT met", a.pred_rms / a.err_rms,
        a.pred_rms / a.err_rms >= 0.7 && a.pred_rms / a.err_rms <= 1.4 ? "met" : "NOT met");
    md << line;
  }
  md << "\nThe boards differ: the SVMS board gives " << a.r.num_inliers << " corners ("
     << a.r.num_outliers << " rejected as outliers) and the chessboard "
     << 63 * chess_corners.size()
     << " corners, so (a) and (b) do not see the same number of points.\n\n"
     << "![](calibrate_error.png)\n\n"
     << "svms calibrate's own report on the board: residuals, residual vectors, coverage and the "
     << "projection uncertainty map.\n\n"
     << "![](calibrate_residual_histogram.png)\n![](calibrate_residual_vectors.png)\n"
     << "![](calibrate_coverage.png)\n![](calibrate_uncertainty.png)\n";
  md.close();
  std::cout << "wrote " << (fs::path(o.out) / "report.md").string() << "\n";
  for (const ToolResult& t : tools)
    std::printf("%-40s %s error RMS %.4f px, worst %.4f px, predicted %.4f px\n", t.name.c_str(),
                t.ok ? "ok    " : "FAILED", t.err_rms, t.err_worst, t.pred_rms);
  return (a.ok && b.ok && c.ok) ? kExitOk : kExitFailed;
}

}  // namespace

void AddBenchCalibrate(CLI::App& bench, int* exit_code) {
  auto o = std::make_shared<BenchOptions>();
  CLI::App* cmd = bench.add_subcommand(
      "calibrate", "Calibration accuracy vs the true camera: svms, mrcal and OpenCV side by side");
  cmd->add_option("--out", o->out, "Output directory (data/, CSV, JSON, plots, report.md)")
      ->required();
  cmd->add_flag("--quick", o->quick, "12 views instead of 40 (smoke test)");
  cmd->add_option("--threads", o->threads, "Rendering and detection threads")
      ->check(CLI::Range(1, 256));
  cmd->footer("Example:\n  svms bench calibrate --out out/bench/calibrate");
  cmd->callback([o, exit_code] { *exit_code = RunBench(*o); });
}

}  // namespace svms::cli
