#include "svms/camera/camera_info.h"

#include <cmath>
#include <filesystem>
#include <limits>

#include "svms/base/file_io.h"
#include "svms/camera/camera_covariance.h"

namespace svms {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The angle (degrees) between the rays through pixels a and b; NaN if either has none.
double AngleDeg(const CameraModel& c, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  Eigen::Vector3d da, db;
  if (!c.Unproject(a, &da) || !c.Unproject(b, &db)) return kNaN;
  return std::atan2(da.cross(db).norm(), da.dot(db)) * 180 / M_PI;
}

}  // namespace

bool HasOptimizationInputs(const std::string& text) {
  // Keys of the Python-literal dict are quoted strings; '#' starts a comment to the end of the
  // line (the comments mrcal writes above the key mention it too).
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '#') {
      while (i < text.size() && text[i] != '\n') ++i;
    } else if (c == '\'' || c == '"') {
      std::size_t k = i + 1;
      while (k < text.size() && text[k] != c) ++k;
      if (text.compare(i + 1, k - i - 1, "optimization_inputs") == 0) {
        std::size_t j = k + 1;
        while (j < text.size() && (text[j] == ' ' || text[j] == '\t')) ++j;
        if (j < text.size() && text[j] == ':') return true;
      }
      i = k;
    }
  }
  return false;
}

Status ReadCameraInfo(const std::string& path, CameraInfo* out) {
  CameraInfo info;
  if (Status s = CameraModel::Read(path, &info.camera); !s) return s;
  const CameraModel& c = info.camera;
  std::string text;
  if (Status s = ReadTextFile(path, &text); !s) return s;
  info.has_optimization_inputs = HasOptimizationInputs(text);

  const double W = c.width(), H = c.height();
  info.fov_x_deg = AngleDeg(c, {-0.5, 0.5 * (H - 1)}, {W - 0.5, 0.5 * (H - 1)});
  info.fov_y_deg = AngleDeg(c, {0.5 * (W - 1), -0.5}, {0.5 * (W - 1), H - 0.5});

  const std::vector<double>& in = c.intrinsics();
  const std::string& lm = c.lensmodel();
  const bool opencv = lm.rfind("LENSMODEL_OPENCV", 0) == 0;
  const bool has_core = lm != "LENSMODEL_CAHVORE" && lm.rfind("LENSMODEL_CAHVORE", 0) != 0 &&
                        in.size() >= 4;
  info.distortion_count = static_cast<int>(in.size()) - 4;
  if (opencv) {
    static const char* const kNames[] = {"k1", "k2", "p1", "p2", "k3", "k4",
                                         "k5", "k6", "s1", "s2", "s3", "s4"};
    for (std::size_t i = 4; i < in.size(); ++i) info.distortion.emplace_back(kNames[i - 4], in[i]);
  }
  if (lm == "LENSMODEL_PINHOLE") {
    info.max_distortion_px = 0;
  } else if (!has_core) {
    info.max_distortion_px = kNaN;
  } else {
    // Pinhole through the core: the same ray, no distortion.
    const double fx = in[0], fy = in[1], cx = in[2], cy = in[3];
    double worst = 0;
    constexpr int kSteps = 16;
    for (int i = 0; i <= kSteps && std::isfinite(worst); ++i) {
      for (int j = 0; j <= kSteps; ++j) {
        const Eigen::Vector2d px((W - 1) * i / kSteps, (H - 1) * j / kSteps);
        Eigen::Vector3d d;
        if (!c.Unproject(px, &d) || !(d.z() > 0)) {
          worst = kNaN;
          break;
        }
        const Eigen::Vector2d q(fx * d.x() / d.z() + cx, fy * d.y() / d.z() + cy);
        worst = std::max(worst, (q - px).norm());
      }
    }
    info.max_distortion_px = worst;
  }

  const std::string sidecar = CovarianceSidecarPath(path);
  std::error_code ec;
  if (std::filesystem::exists(sidecar, ec)) {
    info.sidecar_path = sidecar;
    CameraModel copy = c;
    if (Status s = ReadCovarianceSidecar(sidecar, &copy); !s) info.sidecar_error = s.message();
  }
  *out = std::move(info);
  return Status::Ok();
}

}  // namespace svms
