// svms survey: where the markers sit on one object, from many images of it (bundle/).
#include <memory>

#include "commands.h"
#include "photometry_options.h"
#include "svms/base/format.h"
#include "svms/bundle/survey_options.h"
#include "svms/pipelines/survey_run.h"

namespace svms::cli {

void AddSurveyCommands(CLI::App& app, int* exit_code) {
  auto o = std::make_shared<SurveyRunOptions>();
  CLI::App* cmd = app.add_subcommand(
      "survey", "Survey where several markers sit on one object, from many images of it");
  cmd->add_option("IMAGES", o->inputs, "Image files, directories or globs")->required();
  cmd->add_option("--camera", o->camera, "mrcal .cameramodel of the images")->required();
  cmd->add_option("--markers", o->markers, "Marker models (svms.markers or svms.layout)")
      ->required();
  cmd->add_option("--reference", o->reference, "ID of the marker whose frame is the object frame");
  cmd->add_option("--control-point", o->control_points,
                  "NAME=X,Y,Z[,SIGMA]: a point with known object coordinates (three or more "
                  "instead of --reference); NAME is ID, ID.tl/.tr/.br/.bl or ID.tip");
  cmd->add_option("--scale-bar", o->scale_bars,
                  "A:B:DISTANCE[:SIGMA]: a measured distance between two named points (metres; "
                  "sigma 1e-4 by default)");
  cmd->add_flag("--refine-intrinsics", o->refine_intrinsics, "Refine the camera's intrinsics too");
  cmd->add_option("--out-camera", o->out_camera,
                  "With --refine-intrinsics: write the refined camera (CAM2.cameramodel and its "
                  "covariance sidecar) that the layout belongs to");
  cmd->add_flag("--drop-disconnected", o->drop_disconnected,
                "Survey only the reference's group when the view graph is disconnected");
  cmd->add_option("--corner-sigma", o->corner_sigma,
                  "Standard deviation of every corner (px); by default each corner's own, from "
                  "the detector's line fits (x " +
                      Fixed(kCornerFitScale, 2) + ")");
  cmd->add_option("--out", o->out, "The layout JSON to write (svms.layout, with covariances)")
      ->required();
  cmd->add_option("--report", o->report, "Write report.md, tables and pictures to this directory");
  cmd->add_option("--threads", o->threads, "Threads for detection and the solver")
      ->check(CLI::Range(1, 256))
      ->capture_default_str();
  AddPhotometryOptions(cmd, &o->photometry);
  cmd->add_flag("--quiet", o->quiet, "No progress on stderr");
  cmd->footer(
      "Each marker's pose in the object frame with a 6x6 covariance ([rotation, translation],\n"
      "object axes, scaled by the a-posteriori variance factor), each post's height with its\n"
      "sigma. A dual marker is written as two entries (outer and inner) with their own poses.\n"
      "Exit codes: 0 ok; 1 the survey failed (disconnected views, rank deficiency, ...);\n"
      "2 bad input.\n"
      "Examples:\n"
      "  svms survey out/mockup --camera out/mockup/true.cameramodel --markers "
      "out/mockup/markers.json --reference 10 --out layout.json --report out/survey\n"
      "  svms survey imgs/ --camera cam.cameramodel --markers m.json --reference 3 "
      "--scale-bar 3.tl:7.tl:1.2031 --out layout.json");
  cmd->callback([o, exit_code] { *exit_code = RunSurveyFromImages(*o); });
}

}  // namespace svms::cli
