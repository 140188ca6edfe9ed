// svms survey: where the markers sit on one object, from many images of it (bundle/).
#include <memory>

#include "commands.h"
#include "photometry_options.h"
#include "rig_survey_run.h"
#include "svms/base/format.h"
#include "svms/bundle/survey_options.h"
#include "svms/pipelines/survey_run.h"

namespace svms::cli {

namespace {

// `svms survey rig`: the extrinsics of a camera rig from frames of a surveyed layout.
CLI::App* AddSurveyRigCommand(CLI::App* survey, int* exit_code) {
  auto o = std::make_shared<RigSurveyRunOptions>();
  CLI::App* cmd = survey->add_subcommand(
      "rig",
      "Survey a camera rig's extrinsics (rig_from_cam with covariance) from frames of a "
      "surveyed layout");
  cmd->add_option("--rig", o->rig, "The rig file (svms.rig): cameras, models, starting poses")
      ->required();
  cmd->add_option("--layout", o->layout, "The object's surveyed layout (svms.layout)")->required();
  cmd->add_option("--frames-list", o->frames_list,
                  "One line per time stamp: [TIMESTAMP] IMAGE_0 ... IMAGE_N-1, one per camera "
                  "in the rig's order, '-' for none (as svms pose --rig)")
      ->required();
  cmd->add_option("--out", o->out, "The surveyed rig file to write (not the input)")->required();
  cmd->add_option("--reference", o->reference,
                  "Name of the camera whose rig_from_cam is kept (the gauge); default the first");
  cmd->add_option("--report", o->report, "Also write the fit's figures to this markdown file");
  cmd->add_option("--corner-sigma", o->corner_sigma_px,
                  "Standard deviation of every corner (px) where the detector gives none")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--max-megapixels", o->max_megapixels, "Refuse larger images")
      ->capture_default_str();
  cmd->add_flag("--quiet", o->quiet, "No report on stderr");
  cmd->footer(
      "Every camera's rig_from_cam is estimated jointly with the object's pose at each time\n"
      "stamp (Ceres, the fused pose's corners and tips); the reference camera is held where the\n"
      "rig file puts it. The new rig file carries each camera's covariance ([rotation,\n"
      "translation], rotation about the rig axes; the layout's, the calibrations' and the\n"
      "reference's uncertainty included). Exit codes: 0 ok; 1 the survey failed (a camera never\n"
      "seen with another, ...) or a write failed; 2 bad input.\n"
      "Example:\n"
      "  svms survey rig --rig port.rig --layout layout.json --frames-list frames.txt --out "
      "port_surveyed.rig --report port_surveyed.md");
  cmd->callback([o, exit_code] { *exit_code = RunRigSurvey(*o); });
  return cmd;
}

}  // namespace

void AddSurveyCommands(CLI::App& app, int* exit_code) {
  auto o = std::make_shared<SurveyRunOptions>();
  CLI::App* cmd = app.add_subcommand(
      "survey", "Survey where several markers sit on one object, from many images of it");
  CLI::Option* images =
      cmd->add_option("IMAGES", o->inputs, "Image files, directories or globs (required)");
  CLI::Option* camera =
      cmd->add_option("--camera", o->camera, "mrcal .cameramodel of the images (required)");
  CLI::Option* markers = cmd->add_option("--markers", o->markers,
                                         "Marker models (svms.markers or svms.layout; required)");
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
  CLI::Option* out = cmd->add_option(
      "--out", o->out, "The layout JSON to write (svms.layout, with covariances; required)");
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
      "--scale-bar 3.tl:7.tl:1.2031 --out layout.json\n"
      "  svms survey rig --rig port.rig --layout layout.json --frames-list frames.txt --out "
      "port2.rig   (a camera rig's extrinsics: svms survey rig --help)");
  CLI::App* rig = AddSurveyRigCommand(cmd, exit_code);
  // IMAGES, --camera, --markers and --out are required unless the rig survey runs instead.
  cmd->callback([o, exit_code, rig, images, camera, markers, out] {
    if (rig->parsed()) return;
    for (const CLI::Option* required : {images, camera, markers, out})
      if (required->count() == 0) throw CLI::RequiredError(required->get_name());
    *exit_code = RunSurveyFromImages(*o);
  });
}

}  // namespace svms::cli
