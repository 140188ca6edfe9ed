// svms detect: markers in images, one JSON line per image (detect_batch.h does the work).
#include <memory>

#include "commands.h"
#include "detect_batch.h"
#include "photometry_options.h"
#include "svms/detect/detector.h"

namespace svms::cli {

void AddDetectCommands(CLI::App& app, int* exit_code) {
  auto o = std::make_shared<DetectOptions>();
  CLI::App* det = app.add_subcommand("detect", "Find, identify and measure markers in images");
  det->add_option("IMAGES", o->inputs, "Image files, directories, globs or video files")
      ->required();
  det->add_option("--camera", o->camera,
                  "mrcal .cameramodel: enables poses and undistorted corner fits");
  det->add_option("--markers", o->markers,
                  "Marker models (svms.marker, svms.markers or svms.layout)");
  det->add_option("--overlay", o->overlay,
                  "Write overlay PNGs (outline, tip star, ID) to this directory");
  det->add_option("--threads", o->threads, "Images processed in parallel")
      ->check(CLI::Range(1, 256))
      ->capture_default_str();
  det->add_option("--frame-threads", o->frame_threads,
                  "Threads sharing each image (large frames; same detections as 1)")
      ->check(CLI::Range(1, 64))
      ->capture_default_str();
  det->add_option(
         "--decimate", o->decimate,
         "Find edges and quads on the image averaged over N x N blocks (faster, for "
         "markers of 8 N px and more, most of them; their corners and poses still from the full "
         "image)")
      ->check(CLI::Range(1, kMaxDecimate))
      ->capture_default_str();
  det->add_option("--max-megapixels", o->max_megapixels,
                  "Refuse larger images (checked from the file header, before decoding)")
      ->check(CLI::Range(1e-6, 1e5))
      ->capture_default_str();
  det->add_option("--debug", o->debug,
                  "Write each step's picture of the last image to this directory");
  AddPhotometryOptions(det, &o->photometry);
  det->add_flag("--json", o->json, "JSON Lines output (the only format; accepted for clarity)");
  det->add_flag("--quiet", o->quiet, "No progress on stderr");
  det->footer(
      "Output: one JSON line per image: image, ms, detections (id, corners TL/TR/BR/BL as "
      "printed,\n"
      "corner_sigma (each corner's sigma in px from its line fits), penumbra_sides (where any:\n"
      "the sides, 0-3 from corner k to k + 1, found under a shadow's penumbra), tip (px), "
      "tip_sigma (px, each "
      "axis), bit_errors, "
      "cam_from_marker {rvec, tvec}, covariance (36 numbers, row-major,\n"
      "[rotation, translation] in camera axes), pose_ambiguous (and then alternative_pose\n"
      "{rvec, tvec, weight}: the other planar pose and its share of the likelihood),\n"
      "calibration_in_covariance (the\n"
      "covariance includes the calibration's uncertainty: CAMERA.covariance.json was next to the\n"
      "camera model), edge_points (stripe and decal edge points in the pose's fit, 0: corners\n"
      "and tip only), pose_error (with --camera, why a detection has no pose), nested_in),\n"
      "photometry {response, black_level, white_level, bayer, source}: how the pixels were\n"
      "turned into linear light before measuring (option, camera, image or default).\n"
      "A video file (.mp4 .mkv .avi .mov ...) gives one line per frame with frame and timestamp\n"
      "(seconds, from the container), read on one thread.\n"
      "Without --camera: IDs and corners only. A path that is not valid UTF-8 is written with\n"
      "U+FFFD for its bad bytes and its exact bytes in image_hex.\n"
      "A bad image gets an \"error\" field and a line on stderr; the batch goes on; exit code 1.\n"
      "Output files (overlays, debug pictures) never replace an input, and are written whole\n"
      "or not at all; a failed write is exit code 1.\n"
      "Examples:\n"
      "  svms detect frame.png\n"
      "  svms detect out/mockup --camera out/mockup/true.cameramodel --markers "
      "out/mockup/true_layout.json --overlay out/ov");
  det->callback([o, exit_code] { *exit_code = RunDetect(*o); });
}

}  // namespace svms::cli
