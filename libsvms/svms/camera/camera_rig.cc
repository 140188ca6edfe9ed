#include "svms/camera/camera_rig.h"

#include <algorithm>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <set>

#include "svms/base/file_io.h"
#include "svms/base/json_fields.h"
#include "svms/camera/camera_covariance.h"
#include "svms/geometry/pose_matrix.h"

namespace svms {
namespace {
using json_fields::FieldError;
using nlohmann::json;
constexpr const char* kType = "svms.rig";

// A 6x6 covariance: 6 rows of 6 finite numbers, symmetric (to 1e-9 of its largest entry) and
// positive definite.
PoseCovariance ParseCovariance(const json& obj, const std::string& path) {
  using namespace json_fields;
  const std::string where = Join(path, "covariance");
  const json& rows = Required(obj, path, "covariance");
  if (!rows.is_array() || rows.size() != 6)
    Fail(where, "6 rows of 6 numbers ([rotation, translation], rig axes)", rows);
  PoseCovariance C;
  for (int i = 0; i < 6; ++i) {
    const json& row = rows[i];
    const std::string row_path = where + "[" + std::to_string(i) + "]";
    if (!row.is_array() || row.size() != 6) Fail(row_path, "a row of 6 numbers", row);
    for (int k = 0; k < 6; ++k) {
      if (!row[k].is_number() || !std::isfinite(row[k].get<double>()))
        Fail(row_path + "[" + std::to_string(k) + "]", "a finite number", row[k]);
      C(i, k) = row[k].get<double>();
    }
  }
  const double scale = std::max(1e-300, C.cwiseAbs().maxCoeff());
  if ((C - C.transpose()).cwiseAbs().maxCoeff() > 1e-9 * scale)
    throw FieldError{where + ": expected a symmetric 6x6 matrix"};
  const double min_eig = SymmetricEigenvalues(C)(0);
  if (!(min_eig > 0))
    throw FieldError{where + ": expected a positive definite matrix, its smallest eigenvalue is " +
                     std::to_string(min_eig)};
  return C;
}
}  // namespace

Status ParseRig(const std::string& text, const std::string& source, const std::string& base_dir,
                CameraRig* rig) {
  json j;
  std::string error;
  if (!json_fields::ParseText(text, source, &j, &error)) return Status::Error(error);
  CameraRig out;
  try {
    using namespace json_fields;
    if (!j.is_object()) Fail("(top level)", "an object of type \"" + std::string(kType) + "\"", j);
    CheckKeys(j, "", {"type", "name", "cameras"});
    if (String(j, "", "type") != kType) Fail("type", std::string("\"") + kType + "\"", j["type"]);
    if (j.contains("name")) out.name = String(j, "", "name");
    const json& cameras = Required(j, "", "cameras");
    if (!cameras.is_array() || cameras.empty())
      Fail("cameras", "a non-empty array of cameras", cameras);
    std::set<std::string> names;
    for (size_t i = 0; i < cameras.size(); ++i) {
      const std::string path = "cameras[" + std::to_string(i) + "]";
      const json& c = cameras[i];
      CheckKeys(c, path, {"name", "cameramodel", "rig_from_cam", "covariance"});
      RigCamera camera;
      camera.name = String(c, path, "name");
      if (camera.name.empty()) throw FieldError{path + ".name: expected a non-empty name"};
      if (!names.insert(camera.name).second)
        throw FieldError{path + ".name: '" + camera.name +
                         "' appears twice; expected unique camera names"};
      const std::string model = String(c, path, "cameramodel");
      if (model.empty()) throw FieldError{path + ".cameramodel: expected a file name"};
      const std::filesystem::path model_path(model);
      camera.cameramodel_absolute = model_path.is_absolute();
      camera.cameramodel_path = model_path.is_absolute()
                                    ? model
                                    : (std::filesystem::path(base_dir) / model_path).string();
      camera.rig_from_cam = ParsePose(c, path, "rig_from_cam");
      if (c.contains("covariance")) camera.rig_from_cam_covariance = ParseCovariance(c, path);
      out.cameras.push_back(std::move(camera));
    }
  } catch (const FieldError& e) {
    return Status::Error(source + ": " + e.message);
  }
  *rig = std::move(out);
  return Status::Ok();
}

Status ReadRigFile(const std::string& path, CameraRig* rig) {
  std::string text;
  if (Status s = ReadTextFile(path, &text); !s) return s;
  CameraRig out;
  const std::string base_dir = std::filesystem::path(path).parent_path().string();
  if (Status s = ParseRig(text, path, base_dir, &out); !s) return s;
  for (size_t i = 0; i < out.cameras.size(); ++i) {
    RigCamera& c = out.cameras[i];
    if (Status s = ReadCameraWithSidecar(c.cameramodel_path, &c.camera); !s)
      return Status::Error(path + ": cameras[" + std::to_string(i) +
                           "].cameramodel: " + s.message());
  }
  *rig = std::move(out);
  return Status::Ok();
}

namespace {
std::string Number(double v) { return json(v).dump(); }
std::string Vector3(const Eigen::Vector3d& v) {
  return "[" + Number(v(0)) + ", " + Number(v(1)) + ", " + Number(v(2)) + "]";
}
}  // namespace

std::string RigToJson(const CameraRig& rig, const std::string& dir) {
  namespace fs = std::filesystem;
  std::string out = "{\"type\": \"" + std::string(kType) +
                    "\", \"name\": " + json(rig.name).dump() + ",\n \"cameras\": [\n";
  for (size_t i = 0; i < rig.cameras.size(); ++i) {
    const RigCamera& c = rig.cameras[i];
    const fs::path model(c.cameramodel_path);
    const std::string path =
        c.cameramodel_absolute
            ? c.cameramodel_path
            : fs::absolute(model)
                  .lexically_normal()
                  .lexically_relative(
                      fs::absolute(dir.empty() ? fs::path(".") : fs::path(dir)).lexically_normal())
                  .string();
    out += "   {\"name\": " + json(c.name).dump() + ", \"cameramodel\": " + json(path).dump() +
           ",\n    \"rig_from_cam\": {\"rvec\": " + Vector3(c.rig_from_cam.rvec) +
           ", \"tvec\": " + Vector3(c.rig_from_cam.tvec) + "}";
    if (c.rig_from_cam_covariance) {
      out += ",\n    \"covariance\": [";
      for (int r = 0; r < 6; ++r) {
        out += r ? ",\n                   [" : "[";
        for (int k = 0; k < 6; ++k)
          out += (k ? ", " : "") + Number((*c.rig_from_cam_covariance)(r, k));
        out += "]";
      }
      out += "]";
    }
    out += i + 1 < rig.cameras.size() ? "},\n" : "}]}\n";
  }
  return out;
}

Status WriteRigFile(const std::string& path, const CameraRig& rig) {
  return WriteTextFile(path, RigToJson(rig, std::filesystem::path(path).parent_path().string()));
}

Status FindRigCamera(const CameraRig& rig, const std::string& name, const std::string& rig_label,
                     int* index) {
  std::string names;
  for (size_t c = 0; c < rig.cameras.size(); ++c) {
    if (rig.cameras[c].name == name) {
      *index = static_cast<int>(c);
      return Status::Ok();
    }
    names += (c ? ", " : "") + rig.cameras[c].name;
  }
  return Status::Error("no camera named '" + name + "' in " + rig_label + " (it has " + names +
                       ")");
}

}  // namespace svms
