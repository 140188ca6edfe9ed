// svms calibrate: camera intrinsics from images of a marker board (or any surveyed layout).
#include <iostream>
#include <map>
#include <memory>
#include <thread>

#include "commands.h"
#include "photometry_options.h"
#include "svms/camera/camera_covariance.h"
#include "svms/camera/photometric.h"
#include "svms/marker/model_io.h"
#include "svms/pipelines/calibration_run.h"
#include "svms/pipelines/image_inputs.h"
#include "svms/pipelines/photometry.h"
#include "svms/pipelines/video_frames.h"

namespace svms::cli {
namespace {

struct CalibrateCliOptions {
  std::vector<std::string> inputs;
  std::string board, lensmodel = "LENSMODEL_OPENCV8", out, report, python = "/usr/bin/python3";
  bool warp = false, quiet = false, no_redetect = false, no_mrcal_inputs = false;
  double range = 0, max_rms = 2.0;
  int threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  PhotometryOptions photometry;
  std::string edge_bias = "auto";
};

int RunCalibrate(const CalibrateCliOptions& c) {
  const std::map<std::string, CalibrateRunOptions::EdgeBias> edge_bias_modes = {
      {"auto", CalibrateRunOptions::EdgeBias::kAuto},
      {"on", CalibrateRunOptions::EdgeBias::kOn},
      {"off", CalibrateRunOptions::EdgeBias::kOff}};
  const auto edge_bias = edge_bias_modes.find(c.edge_bias);
  if (edge_bias == edge_bias_modes.end()) {
    std::cerr << "svms calibrate: --edge-bias \"" << c.edge_bias
              << "\": expected auto, on or off\n";
    return kExitBadInput;
  }
  ModelFile f;
  if (Status s = ReadModelFile(c.board, &f); !s) {
    std::cerr << "svms calibrate: --board: " << s.message() << "\n";
    return kExitBadInput;
  }
  if (f.kind != ModelFile::Kind::kLayout) {
    std::cerr << "svms calibrate: --board " << c.board
              << ": expected a layout (\"type\": \"svms.layout\", e.g. from svms generate board), "
                 "got "
              << f.Summary() << "\n";
    return kExitBadInput;
  }
  CalibrateRunOptions o;
  o.images = ExpandImageInputs(c.inputs);
  o.board = c.board;
  o.layout = f.layout;
  o.calib.lensmodel = c.lensmodel;
  o.calib.board_warp = c.warp;
  o.calib.max_rms_px = c.max_rms;
  o.out = c.out;
  o.report_dir = c.report;
  o.uncertainty_range = c.range;
  o.threads = c.threads;
  o.quiet = c.quiet;
  o.redetect = !c.no_redetect;
  o.photometry = c.photometry;
  o.edge_bias = edge_bias->second;
  o.python = c.python;
  o.mrcal_inputs = !c.no_mrcal_inputs;
  CalibrateRunOutcome out;
  const int rc = RunCalibration(o, &out);
  if (rc == kExitBadInput || out.result.camera.empty() || out.result.num_inliers == 0) return rc;
  if (rc == kExitOk || !out.errors.empty()) {
    const CalibrationResult& r = out.result;
    std::printf("%s: %zu views, %d points (%d outliers), RMS %.3f px, worst %.3f px\n",
                r.camera.Summary().c_str(), r.views.size(), r.num_inliers, r.num_outliers, r.rms_px,
                r.worst_px);
    if (!c.out.empty())
      std::printf("wrote %s%s and its intrinsics' covariance %s\n", c.out.c_str(),
                  out.has_optimization_inputs ? " (with mrcal's optimization_inputs)" : "",
                  CovarianceSidecarPath(c.out).c_str());
    // The curve stored with the camera: the refined one when there is one.
    if (out.response.patches > 0)
      std::printf("response: gamma %.3f +- %.3f from %d edge patches%s\n", out.response.gamma,
                  out.response.sigma, out.response.patches,
                  out.refined_gamma > 0 ? "" : (" (" + PhotometricPath(c.out) + ")").c_str());
    if (out.refined_gamma > 0)
      std::printf("response refined by the board's geometry: gamma %.4f +- %.4f (%s)\n",
                  out.refined_gamma, out.refined_gamma_sigma, PhotometricPath(c.out).c_str());
    else if (!out.refine_note.empty())
      std::printf("response not refined: %s\n", out.refine_note.c_str());
    if (r.edge_bias_sigma_px > 0)
      std::printf(
          "edge bias: %+.4f +- %.4f px (> 0: marker sides seen outside their black squares)\n",
          r.edge_bias_px, r.edge_bias_sigma_px);
    // calib/svms/calib/frame_alignment.h: measured 0.43 deg against the true camera of the
    // simulated calibration set (docs/flight-interface.md, "The camera frame").
    if (r.camera.lensmodel().rfind("LENSMODEL_SPLINED", 0) == 0)
      std::printf(
          "note: a splined model's camera frame is fixed by its regularisation, not by the "
          "data: it may be rotated by tenths of a degree against another model of this camera "
          "(mrcal-show-projection-diff A B shows the rotation); poses computed with it are in "
          "its own frame\n");
    if (!c.report.empty())
      std::printf("wrote %s/summary.json (uncertainty at %.2f m: RMS %.3f px, max %.3f px)\n",
                  c.report.c_str(), out.uncertainty_range, out.uncertainty_rms,
                  out.uncertainty_max);
    if (!out.errors.empty())
      std::fprintf(stderr, "svms calibrate: %zu images failed (listed above)\n", out.errors.size());
  }
  return rc;
}

}  // namespace

void AddCalibrateCommands(CLI::App& app, int* exit_code) {
  auto c = std::make_shared<CalibrateCliOptions>();
  CLI::App* cmd = app.add_subcommand(
      "calibrate", "Camera intrinsics from images of a marker board -> mrcal .cameramodel");
  cmd->add_option("images", c->inputs, "Images, directories of images, or globs")->required();
  cmd->add_option("--board", c->board, "The board's layout JSON (svms generate board)")->required();
  cmd->add_option("--lensmodel", c->lensmodel,
                  "mrcal lens model: LENSMODEL_PINHOLE, LENSMODEL_OPENCV4/5/8/12, "
                  "LENSMODEL_SPLINED_STEREOGRAPHIC[_order=..._Nx=..._Ny=..._fov_x_deg=...]")
      ->capture_default_str();
  cmd->add_option("--out", c->out,
                  "The camera model to write (.cameramodel); its intrinsics' covariance goes "
                  "next to it, as OUT.covariance.json (read by svms pose)")
      ->required();
  cmd->add_option("--report", c->report,
                  "Directory for the report: summary.json and PNG/SVG plots (residual histogram "
                  "and vectors, coverage, projection uncertainty)");
  cmd->add_flag("--warp", c->warp, "Also estimate the board's flatness deviation (mrcal's warp)");
  cmd->add_option("--uncertainty-range", c->range,
                  "Range (m) of the projection-uncertainty map [default: median board distance]")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--max-rms", c->max_rms,
                  "Fail (no model) if the final RMS residual exceeds this many pixels")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--threads", c->threads, "Detection threads")->check(CLI::Range(1, 256));
  AddPhotometryOptions(cmd, &c->photometry);
  cmd->get_option("--response")
      ->description(
          "The images' response curve: linear, srgb, gamma:G, table:FILE, or estimate (from "
          "the symmetry of the markers' edges; docs/detector.md). Given or estimated, it is "
          "stored with the camera as OUT.photometric.json");
  cmd->add_option("--edge-bias", c->edge_bias,
                  "Also fit one edge bias in pixels, every marker side seen that far outside its "
                  "black square (what a response curve a little off does to blurred edges): "
                  "auto (with --response estimate), on, off")
      ->capture_default_str();
  cmd->add_option("--python", c->python,
                  "The Python (with numpy and mrcal 2.2) that writes the calibration into the "
                  "model as mrcal's optimization_inputs, for mrcal's own tools")
      ->capture_default_str();
  cmd->add_flag("--no-optimization-inputs", c->no_mrcal_inputs,
                "Write the model without mrcal's optimization_inputs (no Python is run)");
  cmd->add_flag("--quiet", c->quiet, "No progress on stderr");
  cmd->add_flag("--no-redetect", c->no_redetect,
                "One pass only: do not re-detect the corners with the first pass's lens model");
  cmd->footer(
      "Examples:\n"
      "  svms generate board --rows 5 --cols 6 --size 0.06 --gap 0.015 --first-id 100 --out board\n"
      "  svms calibrate 'images/*.png' --board board.json --lensmodel LENSMODEL_OPENCV8 "
      "--out cam.cameramodel --report report\n"
      "Exit codes: 0 ok; 1 the calibration failed (too few or degenerate views, no convergence: "
      "no model written) or some images failed; 2 bad input.");
  cmd->callback([c, exit_code] { *exit_code = RunCalibrate(*c); });
}

}  // namespace svms::cli
