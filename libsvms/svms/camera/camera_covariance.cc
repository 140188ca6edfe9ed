#include "svms/camera/camera_covariance.h"

#include <Eigen/QR>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "svms/base/file_io.h"
#include "svms/base/json_fields.h"

namespace svms {

using json_fields::FieldError;
using nlohmann::json;

namespace {

constexpr const char* kType = "svms.intrinsics_covariance";

// The rows of a square matrix field (n rows of n finite numbers) into *m (resized).
void ReadSquareRows(const json& j, const char* key, Eigen::Index n, Eigen::MatrixXd* m) {
  using namespace json_fields;
  const json& rows = Required(j, "", key);
  const std::string shape = std::to_string(n) + " rows of " + std::to_string(n) + " numbers";
  if (!rows.is_array() || static_cast<Eigen::Index>(rows.size()) != n) Fail(key, shape, rows);
  m->resize(n, n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const json& row = rows[i];
    const std::string field = std::string(key) + "[" + std::to_string(i) + "]";
    if (!row.is_array() || static_cast<Eigen::Index>(row.size()) != n)
      Fail(field, "an array of " + std::to_string(n) + " numbers", row);
    for (Eigen::Index k = 0; k < n; ++k) {
      if (!row[k].is_number() || !std::isfinite(row[k].get<double>()))
        Fail(field + "[" + std::to_string(k) + "]", "a finite number", row[k]);
      (*m)(i, k) = row[k].get<double>();
    }
  }
}

// A matrix as one row per line, indented as the sidecar's fields.
std::string RowsText(const Eigen::MatrixXd& m) {
  std::string text = "[\n";
  for (Eigen::Index i = 0; i < m.rows(); ++i) {
    json row = json::array();
    for (Eigen::Index k = 0; k < m.cols(); ++k) row.push_back(m(i, k) + 0.0);  // no -0
    text += "    " + row.dump() + (i + 1 < m.rows() ? ",\n" : "\n");
  }
  return text + "  ]";
}

}  // namespace

std::string CovarianceSidecarPath(const std::string& cameramodel_path) {
  return cameramodel_path + ".covariance.json";
}

Status ReadCameraWithSidecar(const std::string& path, CameraModel* camera) {
  CameraModel c;
  if (Status s = CameraModel::Read(path, &c); !s) return s;
  if (std::string why = c.UnusableReason(); !why.empty()) return Status::Error(path + ": " + why);
  const std::string sidecar = CovarianceSidecarPath(path);
  std::error_code ec;
  if (std::filesystem::exists(sidecar, ec)) {
    if (Status s = ReadCovarianceSidecar(sidecar, &c); !s) return s;
  }
  *camera = std::move(c);
  return Status::Ok();
}

Eigen::MatrixXd CompactFactor(const Eigen::MatrixXd& rows_of_factor) {
  // With F^T = Q R (Householder): F F^T = R^T Q^T Q R = R^T R, so L = R^T.
  const Eigen::Index n = rows_of_factor.rows();
  Eigen::HouseholderQR<Eigen::MatrixXd> qr(rows_of_factor.transpose());
  Eigen::MatrixXd R = Eigen::MatrixXd::Zero(n, n);
  const Eigen::Index k = std::min(n, rows_of_factor.cols());
  R.topRows(k) = qr.matrixQR().topRows(k).triangularView<Eigen::Upper>();
  return R.transpose();
}

Status CovarianceSidecarText(const std::string& path, const CameraModel& camera,
                             double noise_sigma_px, int views, std::string* out,
                             const Eigen::MatrixXd& mean_frames_factor) {
  const Eigen::MatrixXd& L = camera.intrinsics_covariance_factor();
  if (L.size() == 0) return Status::Error(path + ": the camera has no intrinsics covariance");
  const Eigen::Index nm = L.rows() + 6;
  if (mean_frames_factor.size() > 0 &&
      (mean_frames_factor.rows() != nm || mean_frames_factor.cols() != nm ||
       !mean_frames_factor.allFinite()))
    return Status::Error(path + ": mean_frames_factor: expected " + std::to_string(nm) + " x " +
                         std::to_string(nm) + " finite numbers");
  json sigma = json::array();
  for (Eigen::Index i = 0; i < L.rows(); ++i) sigma.push_back(L.row(i).norm());
  const json head = {{"type", kType},
                     {"lensmodel", camera.lensmodel()},
                     {"imagersize", {camera.width(), camera.height()}},
                     {"intrinsics", camera.intrinsics()},
                     {"sigma", sigma},
                     {"noise_sigma_px", noise_sigma_px},
                     {"views", views}};
  // One field per line and one row of the factor per line (nlohmann's indented dump would put
  // every number on a line of its own).
  std::string text = "{\n";
  for (const char* key :
       {"type", "lensmodel", "imagersize", "intrinsics", "sigma", "noise_sigma_px", "views"})
    text += "  \"" + std::string(key) + "\": " + head[key].dump() + ",\n";
  text += "  \"covariance_factor\": " + RowsText(L);
  if (mean_frames_factor.size() > 0)
    text += ",\n  \"mean_frames_factor\": " + RowsText(mean_frames_factor);
  text += "\n}\n";
  *out = std::move(text);
  return Status::Ok();
}

Status WriteCovarianceSidecar(const std::string& path, const CameraModel& camera,
                              double noise_sigma_px, int views,
                              const Eigen::MatrixXd& mean_frames_factor) {
  std::string text;
  if (Status s =
          CovarianceSidecarText(path, camera, noise_sigma_px, views, &text, mean_frames_factor);
      !s)
    return s;
  return WriteFileAtomically(path, text);
}

Status AddCameraWithSidecar(const std::string& path, const CameraModel& camera,
                            double noise_sigma_px, int views, AtomicFileSet* files) {
  std::string model, sidecar;
  const std::string sidecar_path = CovarianceSidecarPath(path);
  if (Status s = camera.ToText(path, &model); !s) return s;
  if (Status s = CovarianceSidecarText(sidecar_path, camera, noise_sigma_px, views, &sidecar); !s)
    return s;
  if (Status s = files->Add(sidecar_path, sidecar); !s) return s;
  return files->Add(path, model);
}

Status WriteCameraWithSidecar(const std::string& path, const CameraModel& camera,
                              double noise_sigma_px, int views) {
  const bool has_covariance = camera.intrinsics_covariance_factor().size() > 0;
  AtomicFileSet files;
  if (has_covariance) {
    if (Status s = AddCameraWithSidecar(path, camera, noise_sigma_px, views, &files); !s) return s;
  } else {
    std::string model;
    if (Status s = camera.ToText(path, &model); !s) return s;
    if (Status s = files.Add(path, model); !s) return s;
  }
  if (Status s = files.Commit(); !s) return s;
  // A sidecar of an earlier calibration would be refused next to the new model anyway; it goes,
  // so that the pair on disk is consistent.
  if (!has_covariance) std::remove(CovarianceSidecarPath(path).c_str());
  return Status::Ok();
}

Status ReadCovarianceSidecar(const std::string& path, CameraModel* camera) {
  std::string text;
  if (Status s = ReadTextFile(path, &text); !s) return s;
  json j;
  std::string error;
  if (!json_fields::ParseText(text, path, &j, &error)) return Status::Error(error);
  const Eigen::Index n = static_cast<Eigen::Index>(camera->intrinsics().size());
  Eigen::MatrixXd L(n, n);
  try {
    using namespace json_fields;
    if (!j.is_object()) Fail("(top level)", "an object of type \"" + std::string(kType) + "\"", j);
    CheckKeys(j, "",
              {"type", "lensmodel", "imagersize", "intrinsics", "sigma", "noise_sigma_px", "views",
               "covariance_factor", "mean_frames_factor"});
    if (String(j, "", "type") != kType) Fail("type", std::string("\"") + kType + "\"", j["type"]);
    const std::string lensmodel = String(j, "", "lensmodel");
    if (lensmodel != camera->lensmodel()) {
      throw FieldError{"lensmodel: written for " + lensmodel + ", but the camera is " +
                       camera->lensmodel() + " (a sidecar of another calibration?)"};
    }
    const json& size = Required(j, "", "imagersize");
    if (!size.is_array() || size.size() != 2 || !size[0].is_number_integer() ||
        !size[1].is_number_integer())
      Fail("imagersize", "an array of 2 integers", size);
    if (size[0].get<long long>() != camera->width() || size[1].get<long long>() != camera->height())
      throw FieldError{"imagersize: written for " + size[0].dump() + "x" + size[1].dump() +
                       ", but the camera is " + std::to_string(camera->width()) + "x" +
                       std::to_string(camera->height())};
    const json& in = Required(j, "", "intrinsics");
    if (!in.is_array() || static_cast<Eigen::Index>(in.size()) != n)
      Fail("intrinsics", "an array of " + std::to_string(n) + " numbers", in);
    for (Eigen::Index i = 0; i < n; ++i) {
      const std::string field = "intrinsics[" + std::to_string(i) + "]";
      if (!in[i].is_number()) Fail(field, "a number", in[i]);
      const double a = in[i].get<double>(), b = camera->intrinsics()[i];
      if (!(std::abs(a - b) <= 1e-9 * std::max(1.0, std::abs(b))))
        throw FieldError{field + ": written for " + in[i].dump() + ", but the camera has " +
                         json(b).dump() + " (a sidecar of another calibration?)"};
    }
    NumberIn(j, "", "noise_sigma_px", 0, 1e3);
    if (Integer(j, "", "views") < 1) Fail("views", "a positive integer", j["views"]);
    ReadSquareRows(j, "covariance_factor", n, &L);
    if (j.contains("mean_frames_factor")) {
      Eigen::MatrixXd m;
      ReadSquareRows(j, "mean_frames_factor", n + 6, &m);
    }
  } catch (const FieldError& e) {
    return Status::Error(path + ": " + e.message);
  }
  // The propagation needs d pixel / d intrinsics: mrcal 2.2 has none for CAHVORE.
  Eigen::Vector2d q;
  Eigen::Matrix<double, 2, Eigen::Dynamic> dq_dintrinsics;
  if (!camera->Project(Eigen::Vector3d(0, 0, 1), &q, nullptr, &dq_dintrinsics))
    return Status::Error(path + ": " + camera->lensmodel() +
                         " gives no intrinsics gradients in mrcal 2.2, so its calibration's "
                         "uncertainty cannot be propagated; remove the sidecar");
  // Finite entries can still overflow: the covariance L L^T and the pixel covariance it gives
  // at the image centre must be finite (L L^T is positive semi-definite by construction).
  const Eigen::MatrixXd C = L * L.transpose();
  const Eigen::Matrix2d pixel_cov = dq_dintrinsics * C * dq_dintrinsics.transpose();
  if (!C.allFinite() || !pixel_cov.allFinite())
    return Status::Error(path +
                         ": covariance_factor: the covariance it implies (L L^T) overflows; "
                         "expected a factor whose products are finite numbers");
  if (Status s = camera->set_intrinsics_covariance_factor(L); !s)
    return Status::Error(path + ": " + s.message());
  return Status::Ok();
}

Status ReadMeanFramesFactor(const std::string& path, const CameraModel& camera,
                            Eigen::MatrixXd* factor) {
  CameraModel checked = camera;
  if (Status s = ReadCovarianceSidecar(path, &checked); !s) return s;
  std::string text, error;
  json j;
  if (Status s = ReadTextFile(path, &text); !s) return s;
  if (!json_fields::ParseText(text, path, &j, &error)) return Status::Error(error);
  Eigen::MatrixXd m;
  if (j.contains("mean_frames_factor")) {
    try {
      ReadSquareRows(j, "mean_frames_factor",
                     static_cast<Eigen::Index>(camera.intrinsics().size()) + 6, &m);
    } catch (const FieldError& e) {
      return Status::Error(path + ": " + e.message);
    }
  }
  *factor = std::move(m);
  return Status::Ok();
}

bool MeanFramesProjectionCovariance(const CameraModel& camera,
                                    const Eigen::MatrixXd& mean_frames_factor,
                                    const Eigen::Vector3d& p_cam, bool at_infinity,
                                    Eigen::Matrix2d* covariance) {
  const Eigen::Index n = static_cast<Eigen::Index>(camera.intrinsics().size());
  if (mean_frames_factor.rows() != n + 6 || mean_frames_factor.cols() != n + 6) return false;
  Eigen::Vector2d q;
  Eigen::Matrix<double, 2, 3> dq_dp;
  Eigen::Matrix<double, 2, Eigen::Dynamic> dq_di;
  if (!camera.Project(p_cam, &q, &dq_dp, &dq_di)) return false;
  Eigen::Matrix3d minus_skew;  // -[p]x: d(psi x p)/d psi
  minus_skew << 0, p_cam.z(), -p_cam.y(), -p_cam.z(), 0, p_cam.x(), p_cam.y(), -p_cam.x(), 0;
  Eigen::MatrixXd G = Eigen::MatrixXd::Zero(2, n + 6);
  G.leftCols(n) = dq_di;
  G.middleCols(n, 3) = dq_dp * minus_skew;
  if (!at_infinity) G.rightCols(3) = dq_dp;
  const Eigen::MatrixXd GM = G * mean_frames_factor;
  const Eigen::Matrix2d c = GM * GM.transpose();
  if (!c.allFinite()) return false;
  *covariance = c;
  return true;
}

}  // namespace svms
