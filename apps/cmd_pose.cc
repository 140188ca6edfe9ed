// svms pose: the fused object pose of every frame, streamed as JSON Lines (pose_stream.h does
// the work).
#include <iostream>
#include <memory>

#include "commands.h"
#include "photometry_options.h"
#include "pose_stream.h"
#include "rig_pose_stream.h"
#include "svms/detect/detector.h"

namespace svms::cli {

void AddPoseCommands(CLI::App& app, int* exit_code) {
  auto o = std::make_shared<PoseOptions>();
  auto rig = std::make_shared<RigPoseOptions>();
  CLI::App* cmd = app.add_subcommand(
      "pose",
      "The object's pose in each frame from every visible marker of a surveyed layout (several "
      "layouts: each object's pose from one detection)");
  cmd->add_option("IMAGES", o->inputs, "Image files, directories or globs (in this order)");
  cmd->add_flag("--stdin", o->from_stdin,
                "Read frames from stdin: a path per line, optionally followed by a timestamp "
                "(seconds)");
  CLI::Option* camera = cmd->add_option("--camera", o->camera, "mrcal .cameramodel");
  CLI::Option* rig_option = cmd->add_option(
      "--rig", rig->rig,
      "Camera rig (*.rig, docs/conventions.md): fuse every camera's markers into one "
      "rig_from_object per time stamp; frames from --frames-list");
  camera->excludes(rig_option);
  cmd->add_option("--frames-list", rig->frames_list,
                  "With --rig: one line per time stamp, '[TIMESTAMP] IMAGE_CAM0 IMAGE_CAM1 ...' "
                  "in the rig's camera order ('-': no frame; paths relative to the list)")
      ->needs(rig_option);
  cmd->add_option("--layout", o->layouts,
                  "Surveyed layout (svms survey --out); repeat for several objects in one "
                  "detection pass (an ID in two layouts is refused)")
      ->required()
      ->allow_extra_args(false);
  cmd->add_flag("--unknown-ids", o->unknown_ids,
                "Detect markers of every ID, not only the layouts', and list those of no layout "
                "in unassigned_markers");
  cmd->add_option("--corner-sigma", o->corner_sigma_px,
                  "Pixel noise of a detected corner, each axis (see docs/flight-interface.md)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--budget-ms", o->budget_ms, "Time budget per frame (0: none)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--frame-threads", o->frame_threads,
                  "Threads sharing each frame (large frames; same poses as 1)")
      ->check(CLI::Range(1, 64))
      ->capture_default_str();
  cmd->add_option(
         "--decimate", o->decimate,
         "Find edges and quads on the frame averaged over N x N blocks (faster, for "
         "markers of 8 N px and more, most of them; corners and poses still from the full frame)")
      ->check(CLI::Range(1, kMaxDecimate))
      ->capture_default_str();
  cmd->add_option("--overlay", o->overlay, "Write overlay PNGs to this directory");
  cmd->add_option("--max-megapixels", o->max_megapixels, "Refuse larger images")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  AddPhotometryOptions(cmd, &o->photometry);
  cmd->add_flag("--quiet", o->quiet, "No progress on stderr");
  cmd->footer(
      "Output: one JSON line per frame, flushed: image, timestamp (given, or the frame index),\n"
      "valid, cam_from_object {rvec, tvec, quaternion [w, x, y, z]}, covariance (36 numbers,\n"
      "row-major, [rotation, translation], rotation about the camera axes), markers (IDs used),\n"
      "markers_rejected, points_rejected, markers_seen, points, rms (px), chi2, dof, flags "
      "{ambiguous,\n"
      "poorly_conditioned, budget_exceeded, calibration_in_covariance, marker_pose_with_edges:\n"
      "one marker, its own pose with its stripe and decal edges}, latency_ms, detect_ms;\n"
      "alternative {rvec, tvec, quaternion, weight} where ambiguous: the pose under the one\n"
      "marker's other planar pose and its share of the likelihood; message when not valid.\n"
      "The covariance includes the camera calibration's uncertainty\n"
      "when CAMERA.covariance.json (written by svms calibrate) is next to the camera model.\n"
      "An unreadable frame gets an \"error\" field and a line on stderr; the stream goes on;\n"
      "a --stdin line longer than 65536 bytes is such an error. A path that is not valid UTF-8\n"
      "is written with U+FFFD for its bad bytes and its exact bytes in image_hex.\n"
      "exit code 1 at the end. A video file gives every frame, timestamp from the container.\n"
      "photometry: how the frame was turned into linear light (docs/conventions.md).\n"
      "With several --layout: one line per object per frame, in the order of the layouts, each\n"
      "with object (the layout's name, else its file's stem), layout (the file) and\n"
      "unassigned_markers (IDs detected that belong to no layout; only the layouts' IDs are\n"
      "detected unless --unknown-ids). One --layout: the line above (unassigned_markers with\n"
      "--unknown-ids).\n"
      "See docs/flight-interface.md.\n"
      "Examples:\n"
      "  svms pose out/approach --camera cam.cameramodel --layout layout.json\n"
      "  ls frames/*.png | svms pose --stdin --camera cam.cameramodel --layout layout.json\n"
      "  svms pose frames/ --camera cam.cameramodel --layout target.json --layout fixture.json\n"
      "  svms pose --rig port.rig --layout layout.json --frames-list frames.txt\n"
      "With --rig: one line per time stamp (per object), rig_from_object and its covariance\n"
      "(rotation about the RIG axes), cameras [{name, markers, markers_rejected, markers_seen,\n"
      "valid_alone, detect_ms}], flags {poorly_conditioned, calibration_in_covariance,\n"
      "extrinsics_in_covariance}, line, images (docs/flight-interface.md).");
  cmd->callback([o, rig, exit_code] {
    if (!rig->rig.empty()) {
      if (!o->inputs.empty() || o->from_stdin) {
        std::cerr
            << "svms pose: --rig: give the frames with --frames-list, not IMAGES or --stdin\n";
        *exit_code = kExitBadInput;
        return;
      }
      rig->layouts = o->layouts;
      rig->corner_sigma_px = o->corner_sigma_px;
      rig->budget_ms = o->budget_ms;
      rig->frame_threads = o->frame_threads;
      rig->decimate = o->decimate;
      rig->max_megapixels = o->max_megapixels;
      rig->quiet = o->quiet;
      *exit_code = RunRigPose(*rig);
      return;
    }
    if (o->camera.empty()) {
      std::cerr << "svms pose: --camera: expected an mrcal .cameramodel (or --rig RIG.rig)\n";
      *exit_code = kExitBadInput;
      return;
    }
    *exit_code = RunPose(*o);
  });
}

}  // namespace svms::cli
