// The sensor-profile benchmark's scoring (profiles_benchmark.h): each marker of each view,
// per profile, against the renderer's truth, and each detection's time and noise estimate.
#pragma once

#include <limits>
#include <string>
#include <vector>

#include "svms/bench/profiles_benchmark.h"
#include "svms/detect/noise_model.h"

namespace svms {

// The small set again, exposed this much shorter (the marker's white at about 1/24 of full
// scale instead of 2/3, as in a frame exposed for a sun glint or the sunlit Earth): where a raw
// frame's extra bits carry signal that 8-bit codes round away. Its rows are scored apart (set
// "small_dim").
inline constexpr double kDimExposureScale = 1.0 / 16;
inline constexpr const char* kDimSet = "small_dim";

// One marker of one view through one profile.
struct ProfileRow {
  static constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  std::string profile, set, view;
  int id = -1;
  double min_side_px = 0, view_angle_deg = 0;
  bool fully_visible = false, found = false;
  double corner_rms_px = kNaN, corner_bias_px = kNaN;  // bias: mean outward error of the 4
  double orient_err_deg = kNaN, range_err_rel = kNaN, nees = kNaN;
  // Diagnostics in markers.csv: the corners' errors against their own sigmas (sum of the 8
  // squared components over corner_sigma^2, / 8: 1 when honest); the NEES of the orientation
  // alone (3 dof: mean 3 when honest); the smallest angle between a true side and the pixel
  // rows or columns (degrees, 0-45), where a side's sub-pixel phase is the same all along it.
  double corner_z2 = kNaN, nees_rotation = kNaN, side_axis_deg = kNaN;
};

// One detection of one view through one profile: its time and the noise it estimated.
struct ViewTiming {
  std::string profile, set;
  bool textured = false;
  double ms = 0;
  NoiseModel noise;
};

// What a lossy codec adds where the corners are measured: a JPEG profile against its twin, the
// profile whose camera differs only in storing losslessly (jpeg_srgb and srgb8), on the same
// exposures of the well-exposed sets. Over the pixels within 1.5 px of the true sides of fully
// visible markers of 12-30 px: the sum of squared differences between the two decoded frames
// (the codec's error, stored codes) and half that between the twin's frame and a second
// exposure of the same light with its own noise draw (the sensor's noise there).
struct CodecTally {
  std::string profile, twin;
  double defocus_px = 0;            // the two profiles' lens blur (sigma, px)
  double reference_defocus_px = 0;  // the linear profile's, where it ran (else NaN)
  double codec_sq = 0, noise_sq = 0;
  long pixels = 0;
};

// Writes summary.json, report.md (also on stdout) and markers.csv; `seconds` the run's wall
// time. Returns the benchmark's exit code (exit_codes.h).
int WriteProfilesReport(const ProfilesBenchmarkOptions& options,
                        const std::vector<std::string>& profiles,
                        const std::vector<ProfileRow>& rows, const std::vector<ViewTiming>& timings,
                        const std::vector<CodecTally>& codec, double seconds);

}  // namespace svms
