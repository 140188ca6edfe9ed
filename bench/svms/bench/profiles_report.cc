#include "svms/bench/profiles_report.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <tuple>

#include "svms/base/file_io.h"
#include "svms/base/statistics.h"
#include "svms/bench/edge_information.h"
#include "svms/bench/report_numbers.h"
#include "svms/datasets/datasets.h"
#include "svms/detect/marker_pose.h"
#include "svms/pipelines/exit_codes.h"
#include "svms/pipelines/json_text.h"
#include "svms/pipelines/report_file.h"

namespace svms {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

const double kNaN = std::numeric_limits<double>::quiet_NaN();

// The size buckets of the detection-rate table (shortest projected side, px).
const std::vector<std::pair<double, double>>& SizeBuckets() {
  static const std::vector<std::pair<double, double>> b = {{8, 12},  {12, 20},  {20, 30},
                                                           {30, 60}, {60, 120}, {120, 1e9}};
  return b;
}

// The RMS of the corner errors (each marker's RMS over its 4 corners) of the markers of
// 14-18 px that `keep` accepts; NaN for none.
template <typename Keep>
void CornerRms16(const std::vector<ProfileRow>& rows, const Keep& keep, const std::string& key,
                 json* out) {
  std::vector<double> v;
  for (const ProfileRow& r : rows)
    if (r.found && r.min_side_px >= 14 && r.min_side_px < 18 && keep(r))
      v.push_back(r.corner_rms_px);
  (*out)[key] = Rms(v);
  (*out)[key + "_markers"] = v.size();
}

// Per profile: detection rate by size, corner bias and RMS, orientation error, NEES, times;
// over the well-exposed sets (range, angle, small). The dim set's rate and corner RMS go into
// "dim" apart.
std::map<std::string, json> ProfileFigures(const std::vector<std::string>& profiles,
                                           const std::vector<ProfileRow>& rows,
                                           const std::vector<ViewTiming>& timings) {
  std::map<std::string, json> per;
  // The markers every profile found (set, view, id): comparing a figure over them compares
  // the same markers, not also what one profile found that another missed (hard, small ones).
  std::map<std::tuple<std::string, std::string, int>, size_t> found_by, posed_by;
  for (const ProfileRow& r : rows) {
    if (r.found) ++found_by[{r.set, r.view, r.id}];
    if (r.found && std::isfinite(r.orient_err_deg)) ++posed_by[{r.set, r.view, r.id}];
  }
  auto by_all = [&](const auto& counts, const ProfileRow& r) {
    auto it = counts.find({r.set, r.view, r.id});
    return it != counts.end() && it->second == profiles.size();
  };
  auto posed_by_all = [&](const ProfileRow& r) { return by_all(posed_by, r); };
  auto lit = [](const ProfileRow& r) { return r.set != kDimSet; };
  for (const std::string& p : profiles) {
    json j;
    std::vector<double> bias20, orient, orient_common, nees;
    std::vector<json> rate;
    for (const auto& [lo, hi] : SizeBuckets()) {
      int hit = 0, total = 0;
      for (const ProfileRow& r : rows)
        if (r.profile == p && lit(r) && r.fully_visible && r.min_side_px >= lo &&
            r.min_side_px < hi)
          ++total, hit += r.found;
      rate.push_back({{"lo", lo}, {"hi", hi}, {"found", hit}, {"total", total}});
    }
    for (const ProfileRow& r : rows) {
      if (r.profile != p || !r.found || !lit(r)) continue;
      if (r.min_side_px >= 20) bias20.push_back(r.corner_bias_px);
      if (std::isfinite(r.orient_err_deg)) orient.push_back(r.orient_err_deg);
      if (std::isfinite(r.orient_err_deg) && posed_by_all(r))
        orient_common.push_back(r.orient_err_deg);
      if (std::isfinite(r.nees)) nees.push_back(r.nees);
    }
    const auto mine = [&p](const ProfileRow& r) { return r.profile == p; };
    CornerRms16(
        rows, [&](const ProfileRow& r) { return mine(r) && lit(r); }, "corner_rms_px_16", &j);
    CornerRms16(
        rows, [&](const ProfileRow& r) { return mine(r) && lit(r) && by_all(found_by, r); },
        "corner_rms_px_16_common", &j);
    json dim;
    int hit = 0, total = 0;
    for (const ProfileRow& r : rows)
      if (r.profile == p && r.set == kDimSet && r.fully_visible) ++total, hit += r.found;
    dim["found"] = hit, dim["total"] = total;
    CornerRms16(
        rows, [&](const ProfileRow& r) { return mine(r) && !lit(r); }, "corner_rms_px_16", &dim);
    CornerRms16(
        rows, [&](const ProfileRow& r) { return mine(r) && !lit(r) && by_all(found_by, r); },
        "corner_rms_px_16_common", &dim);
    j["dim"] = dim;
    j["rate_by_size"] = rate;
    j["corner_bias_px_20plus"] = Mean(bias20);
    j["orientation_median_deg"] = Median(orient);
    j["orientation_median_common_deg"] = Median(orient_common);
    j["orientation_common_markers"] = orient_common.size();
    j["nees_mean"] = Mean(nees);
    j["nees_below_12_59"] =
        nees.empty() ? kNaN : std::count_if(nees.begin(), nees.end(), [](double x) {
                                return x < kChi2Dof6P95;
                              }) / static_cast<double>(nees.size());
    j["poses"] = nees.size();
    j["nees_median"] = Median(nees);
    // By size and at grazing views: a mean near 6 can hide a conservative bulk (median below
    // chi-square(6)'s 5.35) and an optimistic tail (a few NEES in the hundreds).
    std::vector<json> by_size;
    auto nees_where = [&](const auto& keep) {
      std::vector<double> v;
      for (const ProfileRow& r : rows)
        if (r.profile == p && lit(r) && r.found && std::isfinite(r.nees) && keep(r))
          v.push_back(r.nees);
      return json{{"mean", Mean(v)}, {"median", Median(v)}, {"poses", v.size()}};
    };
    for (const auto& [lo, hi] : SizeBuckets()) {
      json b = nees_where([&, lo = lo, hi = hi](const ProfileRow& r) {
        return r.min_side_px >= lo && r.min_side_px < hi;
      });
      b["lo"] = lo, b["hi"] = hi;
      by_size.push_back(b);
    }
    j["nees_by_size"] = by_size;
    j["nees_grazing"] = nees_where([](const ProfileRow& r) { return r.view_angle_deg >= 60; });
    std::vector<double> black_ms, earth_ms;
    for (const ViewTiming& t : timings) {
      if (t.profile != p || (t.set != "angle" && t.set != "angle_earth")) continue;
      (t.textured ? earth_ms : black_ms).push_back(t.ms);
    }
    j["ms_median_black"] = Median(black_ms);
    j["ms_median_textured"] = Median(earth_ms);
    per[p] = j;
  }
  return per;
}

// The sensor of the dataset `name` through `profile`, exposed `scale` as long.
// The names and profiles are the benchmark's own, checked before the run: a failure here is a
// programming error.
Sensor DatasetSensor(const ProfilesBenchmarkOptions& o, const std::string& name,
                     const std::string& profile, double scale = 1) {
  Dataset d;
  DatasetOptions dopt;
  dopt.seed = o.seed;
  dopt.quick = true;
  Sensor s;
  if (!MakeDataset(name, dopt, &d).ok() || d.scenes.empty()) __builtin_trap();
  s = d.scenes.front().second.sensor;
  if (!ApplySensorProfile(profile, &s).ok()) __builtin_trap();
  s.exposure *= scale;
  return s;
}

// The noise the detector estimated on 16-bit images against the sensor's, in linear 16-bit
// units: read sigma and the sigma at mid-grey, per profile into *per.
void AddNoiseFigures(const ProfilesBenchmarkOptions& o, const std::vector<std::string>& profiles,
                     const std::vector<ViewTiming>& timings, std::map<std::string, json>* per_out) {
  std::map<std::string, json>& per = *per_out;
  for (const std::string& p : profiles) {
    const Sensor s = DatasetSensor(o, "angle", p);
    const double unit = 65535.0 / s.full_well;  // linear units per electron
    std::vector<double> read_ratio, mid_ratio;
    int hidden = 0;
    for (const ViewTiming& t : timings) {
      if (t.profile != p || !t.noise.valid()) continue;
      // The codes hid the noise (a JPEG's smoothed flats): no estimate, counted apart.
      if (t.noise.read_sigma == 0 && t.noise.shot_gain == 0) {
        ++hidden;
        continue;
      }
      const double true_read = s.read_noise * unit;
      const double mid = 0.25 * 65535, true_mid = std::sqrt(true_read * true_read + unit * mid);
      read_ratio.push_back(t.noise.read_sigma / true_read);
      mid_ratio.push_back(t.noise.Sigma(mid) / true_mid);
    }
    if (!read_ratio.empty()) {
      per[p]["noise_read_ratio_median"] = Median(read_ratio);
      per[p]["noise_mid_ratio_median"] = Median(mid_ratio);
    }
    per[p]["noise_views"] = read_ratio.size();
    per[p]["noise_hidden_views"] = hidden;
  }
}

// An estimate of what `raw`'s extra bits can give over `eight`'s codes, from the noise budget of
// a pixel half way up an edge to a sunlit white (about 0.85 of the exposure: datasets.cc,
// StandardSensor): 1 - the ratio of its noise (shot, read, and the rounding of the codes taken
// as white noise, step^2 / 12) at the two depths. The corners are fitted to such pixels. Not a
// bound: where the noise is below a code's step (the dim set at 8 bits) the rounding is not
// white but the same along an edge, and the 8-bit frames also lose detections and take the
// 8-bit path (no noise model), so a measured gain can exceed it.
double BitsGainBudget(const Sensor& raw, const Sensor& eight) {
  const double level = 0.42 * raw.exposure;  // electrons
  auto variance = [level](const Sensor& s) {
    const double step = s.full_well / (s.white_level() - s.black_level);  // electrons per code
    return level + s.read_noise * s.read_noise + step * step / 12;
  };
  return 1 - std::sqrt(variance(raw) / variance(eight));
}

// The introduction and the table of figures per profile.
void Table(const ProfilesBenchmarkOptions& o, const std::vector<std::string>& profiles, size_t rows,
           double seconds, std::map<std::string, json>& per, std::ostream* md) {
  *md << "## Sensor profiles (`svms bench profiles" << (o.quick ? " --quick" : "")
      << (o.correlated_corners ? " --correlated-corners" : "")
      << (o.corner_fit_scale > 0 ? " --corner-fit-scale " + Cell(o.corner_fit_scale, 3) : "")
      << (o.decimate > 1 ? " --decimate " + std::to_string(o.decimate) : "") << "`)\n\n";
  *md << "Every view of the range, angle and small sets rendered once and exposed through "
         "each profile's camera pipeline and codec (docs/simulator.md), read back into linear "
         "light with the camera's photometric model (photometric.h), then detected; "
      << rows / std::max<size_t>(profiles.size(), 1) << " markers per profile, seed " << o.seed
      << ", " << Cell(seconds, 0) << " s. The small set is also exposed 1/"
      << Cell(1 / kDimExposureScale, 0)
      << " as long (the dim rows: white at about 1/24 of full scale, as in a frame exposed for "
         "a glint or the sunlit Earth); every other row is over the well-exposed sets."
      << (o.correlated_corners
              ? " The single-marker pose takes each marker's corners with their joint covariance "
                "where the detector gives one (MarkerPoseOptions::corner_covariance_from_fit)."
              : "")
      << "\n\n";
  *md << "| figure |";
  for (const std::string& p : profiles) *md << " " << p << " |";
  *md << "\n|---|";
  for (size_t i = 0; i < profiles.size(); ++i) *md << "---|";
  *md << "\n";
  for (size_t b = 0; b < SizeBuckets().size(); ++b) {
    const auto [lo, hi] = SizeBuckets()[b];
    *md << "| found, " << lo << (hi > 1e8 ? "+" : "-" + Cell(hi, 0)) << " px |";
    for (const std::string& p : profiles) {
      const json& r = per[p]["rate_by_size"][b];
      const int tot = r["total"];
      *md << " "
          << (tot ? Cell(100.0 * r["found"].get<int>() / tot, 1) + " % (" +
                        std::to_string(r["found"].get<int>()) + "/" + std::to_string(tot) + ")"
                  : "-")
          << " |";
    }
    *md << "\n";
  }
  auto line = [&](const std::string& name, const std::string& key, int digits) {
    *md << "| " << name << " |";
    for (const std::string& p : profiles)
      *md << " " << (per[p][key].is_number() ? Cell(per[p][key].get<double>(), digits) : "-")
          << " |";
    *md << "\n";
  };
  line("corner bias outward, >= 20 px (px)", "corner_bias_px_20plus", 4);
  // An RMS over a few hundred markers follows its worst few: the markers beside it.
  auto rms_line = [&](const std::string& name, const json& (*of)(const json&),
                      const std::string& key) {
    *md << "| " << name << " |";
    for (const std::string& p : profiles) {
      const json& j = of(per[p]);
      *md << " "
          << (j[key].is_number() ? Cell(j[key].get<double>(), 4) + " (" +
                                       std::to_string(j[key + "_markers"].get<size_t>()) + ")"
                                 : "-")
          << " |";
    }
    *md << "\n";
  };
  auto top = [](const json& j) -> const json& { return j; };
  auto dim = [](const json& j) -> const json& { return j["dim"]; };
  rms_line("corner RMS, 14-18 px (px; markers)", top, "corner_rms_px_16");
  rms_line("corner RMS, 14-18 px, markers every profile found (px; markers)", top,
           "corner_rms_px_16_common");
  line("orientation error median (deg)", "orientation_median_deg", 3);
  line("orientation error median, markers every profile found (deg)",
       "orientation_median_common_deg", 3);
  line("pose NEES mean (6 dof: 6)", "nees_mean", 2);
  line("pose NEES median (chi-square(6): 5.35)", "nees_median", 2);
  line("share of NEES below 12.59 (0.95)", "nees_below_12_59", 3);
  line("detect ms median, black background", "ms_median_black", 2);
  line("detect ms median, textured background", "ms_median_textured", 2);
  line("noise estimate / truth, read (16-bit)", "noise_read_ratio_median", 2);
  line("noise estimate / truth, mid grey (16-bit)", "noise_mid_ratio_median", 2);
  line("views whose codes hid the noise (no estimate; not in the ratios)", "noise_hidden_views", 0);
  *md << "| dim: found |";
  for (const std::string& p : profiles) {
    const json& d = per[p]["dim"];
    const int tot = d["total"];
    *md << " "
        << (tot ? Cell(100.0 * d["found"].get<int>() / tot, 1) + " % (" +
                      std::to_string(d["found"].get<int>()) + "/" + std::to_string(tot) + ")"
                : "-")
        << " |";
  }
  *md << "\n";
  rms_line("dim: corner RMS, 14-18 px (px; markers)", dim, "corner_rms_px_16");
  rms_line("dim: corner RMS, 14-18 px, markers every profile found (px; markers)", dim,
           "corner_rms_px_16_common");
}

// The single-marker pose's NEES by marker size and at grazing views, mean / median (markers):
// where the covariance is too large for most markers and too small for a few.
void NeesTable(const std::vector<std::string>& profiles, std::map<std::string, json>& per,
               std::ostream* md) {
  *md << "\nPose NEES by marker size (shortest side) and at grazing views: mean / median "
         "(poses). An honest 6x6 covariance gives 6 / 5.35 in every row.\n\n| markers |";
  for (const std::string& p : profiles) *md << " " << p << " |";
  *md << "\n|---|";
  for (size_t i = 0; i < profiles.size(); ++i) *md << "---|";
  *md << "\n";
  auto cell = [](const json& b) {
    const size_t n = b["poses"].get<size_t>();
    return n == 0 ? std::string("-")
                  : Cell(b["mean"].get<double>(), 2) + " / " + Cell(b["median"].get<double>(), 2) +
                        " (" + std::to_string(n) + ")";
  };
  for (size_t b = 0; b < SizeBuckets().size(); ++b) {
    const auto [lo, hi] = SizeBuckets()[b];
    *md << "| " << lo << (hi > 1e8 ? "+" : "-" + Cell(hi, 0)) << " px |";
    for (const std::string& p : profiles) *md << " " << cell(per[p]["nees_by_size"][b]) << " |";
    *md << "\n";
  }
  *md << "| seen at 60 deg or more |";
  for (const std::string& p : profiles) *md << " " << cell(per[p]["nees_grazing"]) << " |";
  *md << "\n";
}

// The real-camera targets, where the profiles they name were run, and the notes. Returns
// whether every target was met.
bool Targets(const ProfilesBenchmarkOptions& o, const std::vector<std::string>& profiles,
             std::map<std::string, json>& per, const std::vector<CodecTally>& codec,
             std::ostream* md) {
  auto has = [&](const std::string& p) { return per.count(p) > 0; };
  auto num = [&](const std::string& p, const std::string& k) {
    return per[p][k].is_number() ? per[p][k].get<double>() : kNaN;
  };
  bool all_met = true;  // a missed target: exit kExitTargetMissed after writing everything
  auto verdict = [&all_met](bool ok) {
    all_met = all_met && ok;
    return ok ? "**met**" : "**not met**";
  };
  *md << "\nTargets:\n\n";
  if (has("linear") && has("jpeg_srgb")) {
    double worst = 0;
    std::string where;
    for (size_t b = 0; b < SizeBuckets().size(); ++b) {
      const json &l = per["linear"]["rate_by_size"][b], &g = per["jpeg_srgb"]["rate_by_size"][b];
      if (l["total"].get<int>() == 0) continue;
      const double d = 100.0 * l["found"].get<int>() / l["total"].get<int>() -
                       100.0 * g["found"].get<int>() / std::max(1, g["total"].get<int>());
      if (d > worst) worst = d, where = Cell(SizeBuckets()[b].first, 0) + " px";
    }
    *md << "- jpeg_srgb detection within 2 points of linear at every size: " << verdict(worst <= 2)
        << " (largest shortfall " << Cell(worst, 1) << " points"
        << (where.empty() ? "" : ", " + where) << ")\n";
    const double bias = num("jpeg_srgb", "corner_bias_px_20plus");
    *md << "- jpeg_srgb corner bias below 0.01 px at 20 px and more: "
        << verdict(std::abs(bias) < 0.01) << " (" << Cell(bias, 4) << ")\n";
    const double nees = num("jpeg_srgb", "nees_mean"), below = num("jpeg_srgb", "nees_below_12_59");
    *md << "- jpeg_srgb NEES mean in [4.5, 7.5] with 90 % below 12.59: "
        << verdict(nees >= 4.5 && nees <= 7.5 && below >= 0.9) << " (" << Cell(nees, 2) << ", "
        << Cell(100 * below, 1) << " %)\n";
    // On the same markers: over all it found, the profile that finds more small markers would
    // have the larger median.
    const double ratio = num("jpeg_srgb", "orientation_median_common_deg") /
                         num("linear", "orientation_median_common_deg");
    *md << "- jpeg_srgb orientation median within 1.5x linear's (markers every profile found): "
        << verdict(ratio <= 1.5) << " (" << Cell(ratio, 2) << "x, "
        << per["linear"]["orientation_common_markers"].get<size_t>() << " markers)\n";
    for (const CodecTally& t : codec) {
      if (t.profile != "jpeg_srgb" || t.pixels == 0 || !std::isfinite(t.reference_defocus_px))
        continue;
      const double blur = EdgeBlurBoundFactor(t.defocus_px, t.reference_defocus_px);
      const double twin = num(t.twin, "orientation_median_common_deg") /
                          num("linear", "orientation_median_common_deg");
      const double lossy = num(t.profile, "orientation_median_common_deg") /
                           num(t.twin, "orientation_median_common_deg");
      const double e = std::sqrt(t.codec_sq / t.pixels), n = std::sqrt(t.noise_sq / t.pixels);
      *md << "  - what bounds it: jpeg_srgb's optics blur by " << Cell(t.defocus_px, 2)
          << " px (sigma), linear's by " << Cell(t.reference_defocus_px, 2)
          << " px. Behind that blur the Cramer-Rao bound on an edge's place is " << Cell(blur, 2)
          << "x linear's at the same noise (edge_information.h: for estimators equally "
             "efficient on both); "
          << t.twin << ", jpeg_srgb's camera without the codec, measures " << Cell(twin, 2)
          << "x linear's orientation median. The codec adds " << Cell(e, 2)
          << " codes RMS within 1.5 px of the sides of the 12-30 px markers (jpeg_srgb - " << t.twin
          << " on the same exposures, " << t.pixels << " pixels) to the sensor's " << Cell(n, 2)
          << " there (two exposures of the same light); jpeg_srgb's orientation "
          << "median is " << Cell(lossy, 2) << "x " << t.twin << "'s\n";
    }
  }
  if (has("linear") && has("raw12")) {
    // On the markers every profile found, so that neither RMS holds a marker the other missed.
    auto rms = [&](const std::string& p, bool dim) {
      const json& v =
          dim ? per[p]["dim"]["corner_rms_px_16_common"] : per[p]["corner_rms_px_16_common"];
      return v.is_number() ? v.get<double>() : kNaN;
    };
    const double gain_dim = 1 - rms("raw12", true) / rms("linear", true);
    const double budget_dim =
        BitsGainBudget(DatasetSensor(o, "small", "raw12", kDimExposureScale),
                       DatasetSensor(o, "small", "linear", kDimExposureScale));
    *md << "- raw12 corner RMS at 14-18 px at least 20 % better than 8 bits, dim set (markers "
           "every profile found): "
        << verdict(gain_dim >= 0.2) << " (" << Cell(100 * gain_dim, 0)
        << " %; the noise budget estimates " << Cell(100 * budget_dim, 0) << " %)\n";
    const double gain = 1 - rms("raw12", false) / rms("linear", false);
    const double budget =
        BitsGainBudget(DatasetSensor(o, "small", "raw12"), DatasetSensor(o, "small", "linear"));
    *md << "- (not a target) the same on the well-exposed sets: " << Cell(100 * gain, 0)
        << " %; the noise budget estimates " << Cell(100 * budget, 0)
        << " %: there 8-bit codes round less than the shot noise spreads\n";
  }
  for (const std::string& p : profiles) {
    const double r = num(p, "ms_median_black") / num(p, "ms_median_textured");
    *md << "- " << p << ": black-background frames within 30 % of textured ones' median time: "
        << verdict(std::abs(r - 1) <= 0.3) << " (" << Cell(r, 2) << "x)\n";
  }
  *md << "\nCorner bias: each found marker's four corner errors along their outward diagonal, "
         "averaged (positive: the square found too large). NEES: the single-marker pose's error "
         "against its own 6x6 covariance. The noise rows compare the detector's estimate "
         "(noise_model.h, made only for 16-bit images) with the sensor's read noise and its "
         "noise at a quarter of full scale, in linear units; a view whose codes hid the noise "
         "(read and gain 0: a JPEG's smoothed flats) is counted apart.\n";
  return all_met;
}

}  // namespace

int WriteProfilesReport(const ProfilesBenchmarkOptions& o, const std::vector<std::string>& profiles,
                        const std::vector<ProfileRow>& rows, const std::vector<ViewTiming>& timings,
                        const std::vector<CodecTally>& codec, double seconds) {
  json summary;
  summary["profiles"] = profiles;
  summary["seed"] = o.seed;
  summary["quick"] = o.quick;
  summary["correlated_corners"] = o.correlated_corners;
  summary["decimate"] = o.decimate;
  // The corner sigma's scale the single-marker pose used.
  summary["corner_fit_scale"] =
      o.corner_fit_scale > 0 ? o.corner_fit_scale
                             : (o.correlated_corners ? kCornerCovarianceScale : kCornerFitScale);
  std::map<std::string, json> per = ProfileFigures(profiles, rows, timings);
  AddNoiseFigures(o, profiles, timings, &per);
  for (const std::string& p : profiles) summary["per_profile"][p] = per[p];
  summary["seconds"] = seconds;
  for (const CodecTally& t : codec)
    summary["codec"][t.profile] = {
        {"twin", t.twin},
        {"defocus_px", t.defocus_px},
        {"reference_defocus_px", t.reference_defocus_px},
        {"edge_bound_factor", std::isfinite(t.reference_defocus_px)
                                  ? EdgeBlurBoundFactor(t.defocus_px, t.reference_defocus_px)
                                  : kNaN},
        {"codec_error_rms", t.pixels ? std::sqrt(t.codec_sq / t.pixels) : kNaN},
        {"sensor_noise_rms", t.pixels ? std::sqrt(t.noise_sq / t.pixels) : kNaN},
        {"pixels", t.pixels}};
  std::ostringstream md;
  Table(o, profiles, rows.size(), seconds, per, &md);
  NeesTable(profiles, per, &md);
  const bool all_met = Targets(o, profiles, per, codec, &md);
  if (Status s = WriteFileAtomically((fs::path(o.out) / "report.md").string(), md.str()); !s)
    NoteOutputFailure(s.message());
  if (Status s = WriteFileAtomically((fs::path(o.out) / "summary.json").string(),
                                     DumpJson(summary, 2) + "\n");
      !s)
    NoteOutputFailure(s.message());
  OutputFile csv((fs::path(o.out) / "markers.csv").string());
  csv << std::setprecision(10);  // what the summary is computed from, to be recomputed from it
  csv << "profile,set,view,id,min_side_px,view_angle_deg,fully_visible,found,corner_rms_px,"
         "corner_bias_px,orient_err_deg,range_err_rel,nees,corner_z2,nees_rotation,"
         "side_axis_deg\n";
  for (const ProfileRow& r : rows)
    csv << r.profile << "," << r.set << "," << r.view << "," << r.id << "," << r.min_side_px << ","
        << r.view_angle_deg << "," << r.fully_visible << "," << r.found << "," << r.corner_rms_px
        << "," << r.corner_bias_px << "," << r.orient_err_deg << "," << r.range_err_rel << ","
        << r.nees << "," << r.corner_z2 << "," << r.nees_rotation << "," << r.side_axis_deg << "\n";
  csv.close();
  std::cout << md.str();
  if (!all_met) std::cerr << "svms bench profiles: some targets not met (report.md)\n";
  return all_met ? kExitOk : kExitTargetMissed;
}

}  // namespace svms
