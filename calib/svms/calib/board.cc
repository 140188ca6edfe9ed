#include "svms/calib/board.h"

#include <cassert>
#include <cmath>
#include <cstdio>

#include "svms/codec/svms44.h"

namespace svms {

Status BoardSpec::Validate() const {
  auto num = [](double v) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%g", v);
    return std::string(buf);
  };
  if (rows < 1) return Status::Error("--rows: expected at least 1, got " + std::to_string(rows));
  if (cols < 1) return Status::Error("--cols: expected at least 1, got " + std::to_string(cols));
  if (!(std::isfinite(size) && size > 0))
    return Status::Error("--size: expected a positive side in metres, got " + num(size));
  if (!(std::isfinite(gap) && gap >= 0))
    return Status::Error("--gap: expected a non-negative gap in metres, got " + num(gap));
  const long long last = static_cast<long long>(first_id) + static_cast<long long>(rows) * cols - 1;
  if (first_id < 0 || last >= Svms44::kNumIds)
    return Status::Error("--first-id: the board needs IDs " + std::to_string(first_id) + " to " +
                         std::to_string(last) + "; expected all in [0, " +
                         std::to_string(Svms44::kNumIds - 1) + "]");
  return Status::Ok();
}

Layout MakeBoardLayout(const BoardSpec& spec) {
  assert(spec.Validate().ok());
  Layout layout;
  char name[128];
  std::snprintf(name, sizeof name, "calibration board %dx%d, %g m", spec.cols, spec.rows,
                spec.size);
  layout.name = name;
  const double pitch = spec.pitch();
  for (int r = 0; r < spec.rows; ++r) {
    for (int c = 0; c < spec.cols; ++c) {
      Pose board_from_marker;
      board_from_marker.tvec = Eigen::Vector3d((c - 0.5 * (spec.cols - 1)) * pitch,
                                               (0.5 * (spec.rows - 1) - r) * pitch, 0);
      const MarkerModel m = MarkerModel::Standard(spec.first_id + r * spec.cols + c, spec.size, 0);
      layout.markers.push_back(LayoutEntry{m, board_from_marker, std::nullopt, std::nullopt});
    }
  }
  return layout;
}

}  // namespace svms
