// The detector benchmark's scoring (detect_benchmark.h): each marker of a view against the
// renderer's truth, and what each view held.
#pragma once

#include <limits>
#include <string>
#include <vector>

#include "svms/detect/detector.h"
#include "svms/sim/truth.h"

namespace svms {

// One marker of one view, scored.
struct MarkerRow {
  static constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  std::string set, view;
  int id = -1, nested_in = -1;
  double min_side_px = 0, side_px = 0, view_angle_deg = 0, distance_m = 0;
  int bits_occluded = 0, bits_in_shadow = 0;
  bool fully_visible = false, corners_visible = false, has_tip = false, within_75 = true;
  bool found = false, tip_found = false, ambiguous = false;
  int bit_errors = -1;
  double corner_rms_px = kNaN, corner_max_px = kNaN;
  double range_err_m = kNaN, orient_err_deg = kNaN;
  double range_sigma_m = kNaN, trace_t = kNaN;  // predicted: sigma along the line of sight
  double orient_sigma_deg = kNaN;  // predicted RMS of the rotation angle: sqrt(trace(cov_rot))
};

// One view: its time and what went wrong in it.
struct ViewRow {
  std::string set, view;
  double detect_ms = 0;
  int detections = 0, false_positives = 0;
  std::vector<std::string> problems;  // "missed 12 (31.0 px)", "false 977 at (x, y)"
};

// Every marker and view of one set, in view order.
struct SetResult {
  std::vector<MarkerRow> markers;
  std::vector<ViewRow> views;
};

// Scores the detections of one view of the set `set` against its truth: a row per true
// marker into *rows, the view's detections, false positives and problems into *view. A marker
// counts as found when a detection has its ID and every corner within max(3 px, 10 % of the
// side) of the truth; any other detection is a false positive.
void Score(const std::string& set, const ViewTruth& truth, const std::vector<Detection>& found,
           std::vector<MarkerRow>* rows, ViewRow* view);

}  // namespace svms
