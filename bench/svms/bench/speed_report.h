// The speed benchmark's records (speed_benchmark.h) and its report: tables, plot, targets.
#pragma once

#include <array>
#include <chrono>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "svms/bench/speed_benchmark.h"
#include "svms/bench/speed_photos.h"
#include "svms/detect/detector.h"

namespace svms {

// The image classes, in report order: marker-free crops ("photo_1024", "photo_640") and the
// same crops with markers ("markers_1024", "markers_640").
const std::vector<std::string>& SpeedClasses();

// One image as one system saw it. `system` is a detector's name, or "svms_b5" / "svms_b10" for
// svms under a deadline of 5 / 10 ms from the start of the call.
struct SpeedRecord {
  std::string cls, image, system;
  std::string source;  // the photograph's package
  double ms = 0;       // the Detect call, one core
  int detections = 0, false_positives = 0, wrong_ids = 0;
  bool budget_exceeded = false;  // svms under a deadline: the frame ended flagged
  // svms: the time of each of its steps (DetectionStats::ms), to tell where a slow frame went.
  std::array<double, DetectionStats::kSteps> step_ms{};
};

// One true marker of a markers_* image as one system saw it.
struct SpeedMarker {
  std::string cls, image, system;
  double min_side_px = 0;  // the projected square's shortest side
  bool eligible = false;   // facing the camera, all four corners in the image
  bool detected = false, wrong_id = false;
};

struct SpeedRun {
  std::vector<PhotoSource> sources;
  int photos_used = 0;
  std::vector<std::string> photo_failures;  // photographs that could not be read, one line each
  std::vector<std::string> systems;         // the detectors, svms first
  std::vector<double> budgets_ms;           // svms's deadlines
  nlohmann::json settings = nlohmann::json::array();
  std::vector<SpeedRecord> images;
  std::vector<SpeedMarker> markers;
  int markers_placed = 0, markers_not_placed = 0;  // per rendered crop (no room left)
  int render_failures = 0;
  std::chrono::steady_clock::time_point start;
};

// The budget system's name ("svms_b5").
std::string BudgetSystem(double budget_ms);

// Writes report.md (also to stdout), summary.json, images.csv, markers.csv and the plot;
// returns kExitTargetMissed when a judged target was missed, else kExitOk (output failures are
// the caller's FinishOutputs).
int WriteSpeedReport(const SpeedBenchmarkOptions& options, const SpeedRun& run);

}  // namespace svms
