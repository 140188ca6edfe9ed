#include "svms/pipelines/mrcal_uncertainty.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "svms/base/file_io.h"
#include "svms/camera/camera_covariance.h"
#include "svms/camera/camera_info.h"
#include "svms/pipelines/run_program.h"

namespace svms {
namespace {

// argv: MODEL OUT_JSON SIGMA ("" = from the residuals). Writes to OUT_JSON the model's lens
// model, image size and intrinsics as mrcal reads them, the sigma, the board views of its camera
// and "joint_factor": a lower-triangular factor of Cov([intrinsics, psi, kappa]). Exits 3 with
// one line on stderr when the model cannot give it.
constexpr const char* kScript = R"PY(
import json, sys
def fail(msg):
    sys.stderr.write(msg + "\n"); sys.exit(3)
try:
    import numpy as np, numpysane as nps, mrcal
except ImportError as e:
    fail(f"{sys.executable} has no mrcal ({e}); install python3-mrcal or give --python")
path, out, sigma_arg = sys.argv[1], sys.argv[2], sys.argv[3]
try:
    m = mrcal.cameramodel(path)
except Exception as e:
    fail(f"mrcal cannot read it: {e}")
oi = m.optimization_inputs()
if oi is None:
    fail("it has no optimization_inputs (only mrcal's calibration tools write them)")
if not oi.get('do_optimize_extrinsics'):
    fail("its calibration held the extrinsics fixed; mrcal 2.2 computes no uncertainty then")
lensmodel, intrinsics = m.intrinsics()
icam = m.icam_intrinsics()
solved = oi['intrinsics'][icam]
if np.max(np.abs(solved - intrinsics) / np.maximum(1., np.abs(solved))) > 1e-6:
    fail("its intrinsics are not those of its optimization_inputs (edited after the solve?)")
b, x, J, factorization = mrcal.optimizer_callback(**oi)
if factorization is None:
    fail("mrcal could not factor the calibration's J^T J")
Nstate = J.shape[1]
icam_e = mrcal.corresponding_icam_extrinsics(icam, **oi)
N = mrcal.lensmodel_num_params(lensmodel)
# Rows of S: d(quantity)/d(state) for the intrinsics (the optimised ones; the others have no
# uncertainty) and psi, kappa.
S = np.zeros((N + 6, Nstate))
if oi.get('do_optimize_intrinsics_core') or oi.get('do_optimize_intrinsics_distortions'):
    ii = mrcal.state_index_intrinsics(icam, **oi)
    Ncore = 4 if mrcal.lensmodel_metadata_and_config(lensmodel)['has_core'] else 0
    i0 = 0 if oi.get('do_optimize_intrinsics_core') else Ncore
    i1 = N if oi.get('do_optimize_intrinsics_distortions') else Ncore
    for k in range(i0, i1):
        S[k, ii + k - i0] = 1.0
rt_e = oi['extrinsics_rt_fromref'][icam_e] if icam_e >= 0 else None
frames = oi.get('frames_rt_toref') if oi.get('do_optimize_frames') else None
def dpcam_dstate(p_cam):
    # d p_cam / d state (3 x Nstate) of a point fixed in every board's frame, mapped to the
    # reference by each board's pose, averaged, and into the camera: mrcal 2.2's
    # _projection_uncertainty() up to its projection.
    G = np.zeros((3, Nstate))
    p_ref = p_cam if rt_e is None else mrcal.transform_point_rt(mrcal.invert_rt(rt_e), p_cam)
    dpcam_dpref = np.eye(3)
    if rt_e is not None:
        _, dpcam_drt, dpcam_dpref = mrcal.transform_point_rt(rt_e, p_ref, get_gradients=True)
        ie = mrcal.state_index_extrinsics(icam_e, **oi)
        G[:, ie:ie + 6] = dpcam_drt
    if frames is not None:
        Nf = len(frames)
        p_frames = mrcal.transform_point_rt(mrcal.invert_rt(frames), nps.dummy(p_ref, -2))
        _, dp_dframes, _ = mrcal.transform_point_rt(frames, p_frames, get_gradients=True)
        i_f = mrcal.state_index_frames(0, **oi)
        G[:, i_f:i_f + 6 * Nf] = dpcam_dpref @ (nps.clump(nps.mv(dp_dframes, -3, -2), n=-2) / Nf)
    return G
# d p_cam = psi x p_cam + kappa, linear in the state: kappa's rows at p = 0, psi's from the unit
# vectors (psi x e_x = (0, psi_z, -psi_y), psi x e_y = (-psi_z, 0, psi_x), psi x e_z =
# (psi_y, -psi_x, 0)).
G0 = dpcam_dstate(np.zeros(3))
Ge = [dpcam_dstate(np.eye(3)[k]) - G0 for k in range(3)]
S[N + 0], S[N + 1], S[N + 2] = Ge[1][2], Ge[2][0], Ge[0][1]
S[N + 3:N + 6] = G0
p = np.array([0.3, -0.2, 1.7])
Gp = dpcam_dstate(p)
if np.max(np.abs(G0 + np.cross(S[N:N + 3].T, p).T - Gp)) > 1e-9 * max(1e-300, np.max(np.abs(Gp))):
    fail("its boards' poses do not move points rigidly (not mrcal 2.2's problem?)")
Nobs = mrcal.num_measurements_boards(**oi)
sigma = float(sigma_arg) if sigma_arg else \
    float(np.std(mrcal.residuals_chessboard(oi, residuals=x).ravel()))
# mrcal's _propagate_calibration_uncertainty, kept as a factor: the rows
# F = sigma S D inv(J*^T J*) J*obs^T give Cov(S b) = F F^T; its R factor makes it square.
Sp = S.copy()
mrcal.unpack_state(Sp, **oi)
A = factorization.solve_xt_JtJ_bt(Sp)
F = sigma * (J[:Nobs] @ A.T).T
L = np.linalg.qr(F.T, mode='r').T
L = L * np.where(np.diag(L) < 0, -1.0, 1.0)[None, :] + 0.0
json.dump({"lensmodel": lensmodel, "intrinsics": [float(v) for v in intrinsics],
           "imagersize": [int(v) for v in m.imagersize()], "noise_sigma_px": sigma,
           "views": int(np.sum(oi['indices_frame_camintrinsics_camextrinsics'][:, 1] == icam)),
           "joint_factor": [[float(v) for v in row] for row in L]}, open(out, "w"))
)PY";

}  // namespace

Status ImportMrcalUncertainty(const MrcalUncertaintyOptions& o, MrcalUncertaintyResult* result) {
  const std::string& path = o.camera;
  CameraModel cam;
  if (Status s = CameraModel::Read(path, &cam); !s) return s;
  if (std::string why = cam.UnusableReason(); !why.empty()) return Status::Error(path + ": " + why);
  std::string text;
  if (Status s = ReadTextFile(path, &text); !s) return s;
  if (!HasOptimizationInputs(text))
    return Status::Error(path +
                         ": has no optimization_inputs (mrcal's calibration tools write them); "
                         "without them there is no uncertainty to import");
  if (!(o.observed_pixel_uncertainty >= 0) || !std::isfinite(o.observed_pixel_uncertainty))
    return Status::Error("observed pixel uncertainty: expected a positive number of pixels");
  ProgramOutputFiles tmp("mrcal-out", "mrcal-err");
  if (tmp.out.empty() || tmp.err.empty())
    return Status::Error(path + ": cannot create a temporary file for mrcal's result");
  RunProgramOptions ro;
  ro.stderr_path = tmp.err;
  const std::string sigma =
      o.observed_pixel_uncertainty > 0 ? nlohmann::json(o.observed_pixel_uncertainty).dump() : "";
  const int rc = RunProgram({o.python, "-c", kScript, path, tmp.out, sigma}, ro);
  std::string err;
  ReadTextFile(tmp.err, &err).ok();
  if (rc == 127) return Status::Error(path + ": cannot run " + o.python + " (mrcal's Python)");
  if (rc != 0) {
    const std::string line = LastLine(err);
    return Status::Error(path + ": " +
                         (line.empty() ? o.python + " exited with " + std::to_string(rc) : line));
  }
  std::string out;
  nlohmann::json j;
  if (Status s = ReadTextFile(tmp.out, &out); !s) return s;
  try {
    j = nlohmann::json::parse(out);
    const auto intrinsics = j.at("intrinsics").get<std::vector<double>>();
    const auto size = j.at("imagersize").get<std::vector<int>>();
    const auto rows = j.at("joint_factor").get<std::vector<std::vector<double>>>();
    const size_t n = cam.intrinsics().size();
    if (j.at("lensmodel").get<std::string>() != cam.lensmodel() || size.size() != 2 ||
        size[0] != cam.width() || size[1] != cam.height() || intrinsics.size() != n)
      return Status::Error(path + ": mrcal's Python read another model than mrcal's C library");
    for (size_t i = 0; i < n; ++i)
      if (!(std::abs(intrinsics[i] - cam.intrinsics()[i]) <=
            1e-9 * std::max(1.0, std::abs(cam.intrinsics()[i]))))
        return Status::Error(path + ": mrcal's Python read intrinsics[" + std::to_string(i) +
                             "] differently from mrcal's C library");
    if (rows.size() != n + 6) return Status::Error(path + ": mrcal's result has the wrong shape");
    Eigen::MatrixXd M(n + 6, n + 6);
    for (size_t i = 0; i < n + 6; ++i) {
      if (rows[i].size() != n + 6)
        return Status::Error(path + ": mrcal's result has the wrong shape");
      for (size_t k = 0; k < n + 6; ++k) M(i, k) = rows[i][k];
    }
    if (!M.allFinite()) return Status::Error(path + ": mrcal's covariance is not finite");
    result->noise_sigma_px = j.at("noise_sigma_px").get<double>();
    result->views = j.at("views").get<int>();
    result->mean_frames_factor = M;
  } catch (const nlohmann::json::exception& e) {
    return Status::Error(path + ": cannot read mrcal's result: " + e.what());
  }
  // The intrinsics' block of Cov([intrinsics, psi, kappa]) = M M^T: the rows of M that belong to
  // the intrinsics, compacted (M is lower triangular, so this is its top-left block up to signs).
  const Eigen::Index n = static_cast<Eigen::Index>(cam.intrinsics().size());
  if (Status s = cam.set_intrinsics_covariance_factor(
          CompactFactor(result->mean_frames_factor.topRows(n)));
      !s)
    return Status::Error(path + ": " + s.message());
  result->sidecar = CovarianceSidecarPath(path);
  if (Status s = WriteCovarianceSidecar(result->sidecar, cam, result->noise_sigma_px, result->views,
                                        result->mean_frames_factor);
      !s)
    return s;
  result->camera = std::move(cam);
  return Status::Ok();
}

std::string MissingUncertaintyHint(const std::string& camera_path) {
  const std::string sidecar = CovarianceSidecarPath(camera_path);
  std::error_code ec;
  if (std::filesystem::exists(sidecar, ec)) return "";
  std::string text;
  if (!ReadTextFile(camera_path, &text).ok() || !HasOptimizationInputs(text)) return "";
  return camera_path + " has mrcal's optimization_inputs but no " + sidecar +
         ": `svms camera import-uncertainty " + camera_path + "` writes it";
}

}  // namespace svms
