#include "svms/bench/compare_records.h"

#include <cmath>

#include "svms/base/statistics.h"

namespace svms {

// The condition a sweep bins a marker by.
std::string Condition(const std::string& sweep, const std::string& view, const MarkerOutcome& m) {
  if (sweep == "size") return view.substr(5, 3);   // "size_030px_.." -> "030"
  if (sweep == "angle") return view.substr(6, 2);  // "angle_60deg_.." -> "60"
  if (sweep == "occlusion") {
    const double f = m.occluded_fraction;
    return f <= 0 ? "0" : f <= 0.1 ? "0-10%" : f <= 0.2 ? "10-20%" : f <= 0.35 ? "20-35%" : ">35%";
  }
  return view.substr(0, view.find('_'));  // sun, lowsun, edge, shadow
}

void Tally::Add(const MarkerOutcome& m) {
  if (!m.eligible) return;
  ++eligible;
  side.push_back(m.min_side_px);
  if (m.wrong_id) ++wrong;
  if (!m.detected) return;
  ++detected;
  corner.push_back(m.corner_rms_px);
  if (std::isfinite(m.orientation_err_deg)) {
    ++posed;
    range_rel.push_back(100 * m.range_err_m / m.distance_m);
    orient.push_back(m.orientation_err_deg);
    flips += m.orientation_err_deg > kFlipDeg;
    planar_flips += m.planar_flip();
    unflagged_flips += m.orientation_err_deg > kFlipDeg && !m.pose_ambiguous;
    flips_alternative_right +=
        m.orientation_err_deg > kFlipDeg && m.alternative_err_deg <= kFlipDeg;
    if (m.alternative_sep_deg > kFlipDeg) expected_flips += m.alternative_weight;
    flagged += m.pose_ambiguous;
    if (std::isfinite(m.pose_nees)) nees.push_back(m.pose_nees);
  }
}

double Tally::nees_mean() const {
  double s = 0;
  for (double x : nees) s += x;
  return nees.empty() ? NAN : s / nees.size();
}
double Tally::nees_within_95() const {
  int k = 0;
  for (double x : nees) k += x <= kChi2Dof6P95;
  return nees.empty() ? NAN : static_cast<double>(k) / nees.size();
}
nlohmann::json Tally::Json() const {
  using json = nlohmann::json;
  return {{"eligible", eligible},
          {"detected", detected},
          {"detection_rate", eligible ? json(rate()) : json()},
          {"wrong_id_markers", wrong},
          {"mean_min_side_px", side.empty() ? json() : json(Median(side))},
          {"corner_rms_px_median", corner.empty() ? json() : json(Median(corner))},
          {"corner_rms_px_p95", corner.empty() ? json() : json(Percentile(corner, 0.95))},
          {"range_err_percent_median", range_rel.empty() ? json() : json(Median(range_rel))},
          {"orientation_err_deg_median", orient.empty() ? json() : json(Median(orient))},
          {"orientation_err_deg_p95", orient.empty() ? json() : json(Percentile(orient, 0.95))},
          {"pose_flips", flips},
          {"planar_flips", planar_flips},
          {"unflagged_flips", unflagged_flips},
          {"poses_flagged_ambiguous", flagged},
          {"flips_alternative_right", flips_alternative_right},
          {"expected_flips", expected_flips},
          {"posed", posed},
          {"flip_rate", posed ? json(static_cast<double>(flips) / posed) : json()},
          {"pose_nees_count", nees.size()},
          {"pose_nees_mean", nees.empty() ? json() : json(nees_mean())},
          {"pose_nees_median", nees.empty() ? json() : json(Median(nees))},
          {"pose_nees_within_chi2_95", nees.empty() ? json() : json(nees_within_95())}};
}

CompareTallies TallyRun(const CompareRun& run) {
  CompareTallies t;
  auto& [overall, small, by, timing] = t;
  for (const MarkerRecord& r : run.markers) {
    overall[r.config].Add(r.m);
    if (r.sweep == "size" && r.m.min_side_px <= 30) small[r.config].Add(r.m);
    by[r.sweep][r.condition][r.config].Add(r.m);
  }
  for (const ImageRecord& r : run.images) {
    Timing& tm = timing[r.config];
    tm.all.push_back(r.ms);
    tm.wrong += r.wrong_ids;
    if (r.sweep == "clutter") {
      tm.clutter.push_back(r.ms);
      tm.fp_clutter += r.false_positives;
      ++tm.clutter_images;
    } else {
      tm.fp_scenes += r.false_positives;
    }
  }
  return t;
}

double Ms(std::chrono::steady_clock::duration d) {
  return std::chrono::duration<double, std::milli>(d).count();
}

}  // namespace svms
