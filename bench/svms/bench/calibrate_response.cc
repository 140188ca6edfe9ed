#include "svms/bench/calibrate_response.h"

#include <filesystem>
#include <utility>
#include <vector>

#include "svms/base/format.h"
#include "svms/pipelines/exit_codes.h"
#include "svms/pipelines/render_scene.h"

namespace svms {
namespace {

namespace fs = std::filesystem;

// The board's scene through the gamma camera and its linear twin, both behind the same defocus,
// rendered into OUT/data/GAMMA_DIR and OUT/data/LINEAR_DIR unless their images are there: one
// ray cast exposed through both sensors (RenderSceneThrough), as two renders would write them.
// kExitOk to go on.
int RenderBoards(const CalibrateBenchmarkOptions& o, const CalibrationData& data,
                 const std::string& gamma_dir, const std::string& linear_dir) {
  Scene scene = data.dataset.scenes[0].second;
  scene.sensor.defocus_sigma_px = kCheckedDefocusPx;
  std::vector<SensorOutput> outputs;
  const std::pair<std::string, std::string> boards[] = {
      {gamma_dir, "gamma:" + Fixed(kCheckedGamma, 1)}, {linear_dir, "linear"}};
  for (const auto& [subdir, response] : boards) {
    const fs::path dir = fs::path(o.out) / "data" / subdir;
    bool have = true;
    for (const View& v : scene.views) have &= fs::exists(dir / (v.name + ".png"));
    if (have) continue;
    SensorOutput out{scene.sensor, dir.string()};
    out.sensor.response = response;
    outputs.push_back(out);
  }
  if (outputs.empty()) return kExitOk;
  std::cerr << "svms bench calibrate: rendering " << scene.views.size() << " board views ("
            << Fixed(kCheckedDefocusPx, 1) << " px of defocus) through " << outputs.size()
            << " camera response(s)\n";
  return RenderSceneThrough(scene, outputs, "calibration/board", o.threads, false);
}

}  // namespace

ResponseCheck RunResponseCheck(const CalibrateBenchmarkOptions& o, const CalibrationData& data) {
  ResponseCheck check;
  const std::string gamma_dir = "board_gamma" + Fixed(kCheckedGamma, 1);
  const std::string linear_dir = "board_linear_defocus";
  if (RenderBoards(o, data, gamma_dir, linear_dir) != kExitOk) {
    check.failure = "rendering the response check's boards failed";
    return check;
  }
  check.rendered = true;
  // `output`: the name of the run's camera model in OUT (each run its own).
  auto calibrate = [&](const std::string& subdir, const std::string& output,
                       const std::string& response, const std::string& name,
                       CalibrateRunOutcome* out) {
    CalibrateRunOptions ro = SvmsCalibrateOptions(o, data, subdir, output);
    ro.photometry.response = response;
    ro.quiet = true;
    ro.mrcal_inputs = false;
    const double t0 = Now();
    const int rc = RunCalibration(ro, out);
    ToolResult t = MeasuredSvmsResult(data, name, rc, *out);
    t.seconds = Now() - t0;
    if (t.ok) Measure(data, &t);
    if (!t.ok) t.failure = name + ": " + t.failure;
    return t;
  };
  CalibrateRunOutcome gamma_out, linear_out;
  check.gamma =
      calibrate(gamma_dir, gamma_dir, "estimate",
                "svms calibrate --response estimate (gamma " + Fixed(kCheckedGamma, 1) + " camera)",
                &gamma_out);
  check.linear = calibrate(linear_dir, linear_dir, "linear",
                           "svms calibrate --response linear (its twin)", &linear_out);
  CalibrateRunOutcome known_out;
  const std::string true_curve = "gamma:" + Fixed(kCheckedGamma, 1);
  check.known =
      calibrate(gamma_dir, gamma_dir + "_true_curve", true_curve,
                "svms calibrate --response " + true_curve + " (the true curve)", &known_out);
  check.estimate = gamma_out.response;
  check.refined_gamma = gamma_out.refined_gamma;
  check.refined_sigma = gamma_out.refined_gamma_sigma;
  check.refine_note = gamma_out.refine_note;
  check.gamma_corners = MeasureCornerNoise(data.truth, check.gamma, gamma_out.views);
  check.linear_corners = MeasureCornerNoise(data.truth, check.linear, linear_out.views);
  check.known_corners = MeasureCornerNoise(data.truth, check.known, known_out.views);
  check.ok = check.gamma.ok && check.linear.ok;
  if (!check.ok) check.failure = check.gamma.ok ? check.linear.failure : check.gamma.failure;
  return check;
}

}  // namespace svms
