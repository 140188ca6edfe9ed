#include "svms/bundle/survey_options.h"

#include <cmath>
#include <set>
#include <sstream>

#include "svms/base/format.h"

namespace svms {
namespace {

bool Positive(double v) { return std::isfinite(v) && v > 0; }

}  // namespace

Status SurveyOptions::Check() const {
  auto bad = [](const std::string& field, const std::string& expected, double got) {
    return Status::Error("survey options: " + field + ": expected " + expected + ", got " +
                         Significant(got, 6));
  };
  if (!Positive(corner_sigma_px)) return bad("corner_sigma_px", "> 0 pixels", corner_sigma_px);
  if (!Positive(corner_fit_scale)) return bad("corner_fit_scale", "> 0", corner_fit_scale);
  if (!Positive(min_corner_sigma_px))
    return bad("min_corner_sigma_px", "> 0 pixels", min_corner_sigma_px);
  if (!Positive(min_tip_sigma_px)) return bad("min_tip_sigma_px", "> 0 pixels", min_tip_sigma_px);
  if (!Positive(post_height_prior_sigma))
    return bad("post_height_prior_sigma", "> 0 metres", post_height_prior_sigma);
  if (loss != "cauchy" && loss != "huber" && loss != "trivial")
    return Status::Error(
        "survey options: loss: expected \"cauchy\", \"huber\" or \"trivial\", got \"" + loss +
        "\"");
  if (!Positive(loss_scale)) return bad("loss_scale", "> 0 sigmas", loss_scale);
  if (!Positive(outlier_sigmas) || outlier_sigmas < 2)
    return bad("outlier_sigmas", ">= 2 sigmas", outlier_sigmas);
  if (outlier_points_per_detection < 1)
    return bad("outlier_points_per_detection", ">= 1", outlier_points_per_detection);
  if (!Positive(init_inlier_angle_deg))
    return bad("init_inlier_angle_deg", "> 0 degrees", init_inlier_angle_deg);
  if (!Positive(init_inlier_distance))
    return bad("init_inlier_distance", "> 0 metres", init_inlier_distance);
  if (max_iterations < 1) return bad("max_iterations", ">= 1", max_iterations);
  if (!Positive(function_tolerance) || !Positive(gradient_tolerance) ||
      !Positive(parameter_tolerance))
    return Status::Error("survey options: tolerances: expected > 0");
  if (num_threads < 1) return bad("num_threads", ">= 1", num_threads);
  if (!(corner_repeat_px_grey >= 0) || !std::isfinite(corner_repeat_px_grey))
    return bad("corner_repeat_px_grey", ">= 0 pixels per grey level", corner_repeat_px_grey);
  return Status::Ok();
}

Status ParseNamedPoint(const std::string& name, NamedPoint* out) {
  const auto fail = [&] {
    return Status::Error("point \"" + name +
                         "\": expected a marker ID, optionally followed by .tl, .tr, .br, .bl "
                         "(a corner as printed) or .tip (the post tip), e.g. 12.tl");
  };
  const size_t dot = name.find('.');
  const std::string id = name.substr(0, dot);
  if (id.empty() || id.size() > 9 || id.find_first_not_of("0123456789") != std::string::npos)
    return fail();
  NamedPoint p;
  p.name = name;
  p.marker_id = std::stoi(id);
  if (dot != std::string::npos) {
    const std::string what = name.substr(dot + 1);
    static const char* kCorners[4] = {"tl", "tr", "br", "bl"};
    bool found = false;
    for (int k = 0; k < 4; ++k)
      if (what == kCorners[k]) {
        p.kind = NamedPoint::Kind::kCorner;
        p.corner = k;
        found = true;
      }
    if (what == "tip") {
      p.kind = NamedPoint::Kind::kTip;
      found = true;
    }
    if (!found) return fail();
  }
  *out = p;
  return Status::Ok();
}

Status SurveyConfig::Check() const {
  if (gauge == Gauge::kReferenceMarker && reference_id < 0)
    return Status::Error(
        "survey config: reference_id: expected a marker ID >= 0 for the "
        "reference-marker gauge, got " +
        std::to_string(reference_id));
  if (gauge == Gauge::kControlPoints && control_points.size() < 3)
    return Status::Error(
        "survey config: control_points: expected 3 or more for the "
        "control-point gauge, got " +
        std::to_string(control_points.size()));
  std::set<std::string> names;
  for (const ControlPoint& c : control_points) {
    if (!Positive(c.sigma))
      return Status::Error("survey config: control point " + c.point.name +
                           ": sigma: expected > 0 metres, got " + Significant(c.sigma, 6));
    if (!c.point_in_object.allFinite())
      return Status::Error("survey config: control point " + c.point.name +
                           ": coordinates must be finite");
    if (!names.insert(c.point.name).second)
      return Status::Error("survey config: control point " + c.point.name + " is given twice");
  }
  for (const ScaleBar& b : scale_bars) {
    const std::string n = "scale bar " + b.a.name + ":" + b.b.name;
    if (!Positive(b.distance))
      return Status::Error("survey config: " + n + ": distance: expected > 0 metres, got " +
                           Significant(b.distance, 6));
    if (!Positive(b.sigma))
      return Status::Error("survey config: " + n + ": sigma: expected > 0 metres, got " +
                           Significant(b.sigma, 6));
    if (b.a.marker_id == b.b.marker_id)
      return Status::Error("survey config: " + n + ": both ends on marker " +
                           std::to_string(b.a.marker_id) +
                           "; expected points on two different markers (one marker's size is "
                           "already known)");
  }
  return Status::Ok();
}

std::string SurveySummary::LayoutName() const {
  return "survey of " + std::to_string(images_used) +
         " images; covariances scaled by the a-posteriori variance factor " +
         std::to_string(variance_factor) +
         (calibration_in_covariance ? ", plus the camera calibration's uncertainty" : "") +
         (corner_repeat_in_covariance
              ? ", plus the repeated corner error of the markers seen with grey levels"
              : "") +
         (intrinsics_refined
              ? "; intrinsics refined: it belongs to the camera " +
                    (refined_camera.empty() ? std::string("the survey refined (not written)")
                                            : refined_camera)
              : "");
}

std::string SurveySummary::BriefReport() const {
  std::ostringstream s;
  s.precision(4);
  if (!success) s << "survey FAILED: " << message << "\n";
  s << "images: " << images_used << " of " << images_total << " used, " << detections_used
    << " detections; markers surveyed: " << markers_surveyed << "\n";
  for (const auto& [id, why] : left_out) s << "  marker " << id << " left out: " << why << "\n";
  s << "solve: cost " << initial_cost << " -> " << first_cost << " (robust, " << iterations_first
    << " iterations), " << rejected.size() << " points rejected, -> " << final_cost << " ("
    << iterations_second << " iterations)\n";
  s << "residuals m = " << residuals << ", parameters n = " << parameters << ", RMS " << rms_px
    << " px, variance factor " << variance_factor << "\n";
  s << "covariance: " << (covariance_ok ? "ok" : "not computed")
    << (covariance_ok && covariance_scaled ? " (scaled by the variance factor)" : "")
    << (covariance_ok && calibration_in_covariance ? ", plus the camera calibration's uncertainty"
                                                   : "")
    << (covariance_ok && corner_repeat_in_covariance
            ? ", plus the repeated corner error of the markers seen with grey levels"
            : "")
    << "\n";
  s << "time: init " << seconds_init << " s, solve " << seconds_first << " + " << seconds_second
    << " s, covariance " << seconds_covariance << " s\n";
  return s.str();
}

}  // namespace svms
