#include "svms/pipelines/mrcal_optimization_inputs.h"

#include <cmath>
#include <nlohmann/json.hpp>

#include "svms/base/file_io.h"
#include "svms/calib/board_grid.h"
#include "svms/camera/camera.h"
#include "svms/pipelines/json_text.h"
#include "svms/pipelines/run_program.h"

namespace svms {
namespace {

// Reads the problem (JSON) on stdin; argv: OUT. Builds mrcal 2.2's optimization_inputs, checks
// that mrcal factors J^T J at the stored optimum and that its board residuals are SVMS's
// (inlier count and weighted RMS), adds the keys mrcal's cameramodel writer writes to SVMS's
// model text, reads that back with mrcal and writes it to OUT. Exits 3 with one line on stderr
// when mrcal cannot take it.
constexpr const char* kScript = R"PY(
import io, json, sys
def fail(msg):
    sys.stderr.write(msg + "\n"); sys.exit(3)
try:
    import numpy as np, mrcal
except ImportError as e:
    fail(f"{sys.executable} has no mrcal ({e}); install python3-mrcal or give --python")
out = sys.argv[1]
d = json.load(sys.stdin)
N, H, W = d["views"], d["height"], d["width"]
obs = np.array(d["observations"], dtype=float).reshape(N, H, W, 3)
oi = dict(intrinsics=np.array([d["intrinsics"]], dtype=float),
          extrinsics_rt_fromref=np.zeros((0, 6)),
          frames_rt_toref=np.array(d["frames_rt_toref"], dtype=float).reshape(N, 6),
          points=None,
          observations_board=obs,
          indices_frame_camintrinsics_camextrinsics=np.array([[k, 0, -1] for k in range(N)],
                                                             dtype=np.int32),
          observations_point=None,
          indices_point_camintrinsics_camextrinsics=None,
          lensmodel=d["lensmodel"],
          imagersizes=np.array([d["imagersize"]], dtype=np.int32),
          calobject_warp=np.array(d["calobject_warp"], dtype=float),
          do_optimize_intrinsics_core=True,
          do_optimize_intrinsics_distortions=True,
          do_optimize_extrinsics=True,
          do_optimize_frames=True,
          do_optimize_calobject_warp=bool(d["do_optimize_calobject_warp"]),
          calibration_object_spacing=float(d["spacing"]),
          do_apply_outlier_rejection=False,
          do_apply_regularization=bool(d["do_apply_regularization"]),
          verbose=False,
          imagepaths=np.array(d["imagepaths"]))
try:
    b, x, J, factorization = mrcal.optimizer_callback(**oi)
except Exception as e:
    fail(f"mrcal refuses the problem: {e}")
if factorization is None:
    fail("mrcal cannot factor the calibration's J^T J")
r = mrcal.residuals_chessboard(oi, residuals=x)
rms = float(np.sqrt(np.mean(np.sum(r * r, axis=-1)))) if len(r) else 0.0
if len(r) != d["inliers"] or not abs(rms - d["weighted_rms"]) <= 1e-6 * d["weighted_rms"] + 1e-9:
    fail(f"mrcal's board residuals are not SVMS's ({len(r)} points, RMS {rms:.9g} px; SVMS: "
         f"{d['inliers']} points, RMS {d['weighted_rms']:.9g} px)")
f = io.StringIO()
mrcal.cameramodel(optimization_inputs=oi, icam_intrinsics=0).write(f)
lines = f.getvalue().splitlines(keepends=True)
start = [k for k, l in enumerate(lines) if l.startswith("    # The optimization inputs")]
key = [k for k, l in enumerate(lines) if l.startswith("    'optimization_inputs':")]
if len(start) != 1 or len(key) != 1 or key[0] < start[0]:
    fail("mrcal's cameramodel writer wrote an unexpected layout")
text = d["model_text"]
end = text.rstrip().rfind("}")
text = text[:end] + "\n    'icam_intrinsics': 0,\n\n" + "".join(lines[start[0]:key[0] + 1]) + "}\n"
with open(out, "w") as g:
    g.write(text)
m = mrcal.cameramodel(out)
back = m.optimization_inputs()
if m.icam_intrinsics() != 0 or back is None or \
   not np.array_equal(back["observations_board"], obs) or \
   not np.array_equal(m.intrinsics()[1], oi["intrinsics"][0]):
    fail("mrcal does not read back what was written")
)PY";

}  // namespace

Status MrcalOptimizationInputsText(const CalibrationResult& r,
                                   const std::vector<ViewObservations>& views,
                                   const std::vector<std::string>& image_names,
                                   const std::string& model_text, const MrcalInputsOptions& o,
                                   std::string* text) {
  const size_t nv = r.views.size();
  if (nv == 0 || r.residuals.size() != nv || r.outlier.size() != nv ||
      r.cam_from_board.size() != nv || image_names.size() != views.size())
    return Status::Error("no calibration to write");
  // The grid every point of every used view lies on (tolerance: 1e-7 m, far below what a
  // projection resolves, far above the round-off of a layout's coordinates).
  constexpr double kTolerance = 1e-7;
  std::vector<Eigen::Vector3d> points;
  for (int v : r.views)
    for (const PointObservation& p : views[v].points) points.push_back(p.point_in_board);
  BoardGrid grid;
  if (Status s = FindBoardGrid(points, kTolerance, o.max_grid_nodes, &grid); !s)
    return Status::Error("the board's points do not fit mrcal's calibration object: " +
                         s.message());
  const size_t nodes = static_cast<size_t>(grid.width) * grid.height;
  std::vector<double> obs(nv * nodes * 3, 0.0);
  for (size_t k = 0; k < nv * nodes; ++k) obs[3 * k + 2] = -1;  // unseen
  double sum_w2 = 0;
  int inliers = 0;
  std::vector<double> frames;
  nlohmann::json names = nlohmann::json::array();
  for (size_t k = 0; k < nv; ++k) {
    const ViewObservations& view = views[r.views[k]];
    if (r.residuals[k].size() != view.points.size() || r.outlier[k].size() != view.points.size())
      return Status::Error("no calibration to write");
    for (size_t i = 0; i < view.points.size(); ++i) {
      const PointObservation& p = view.points[i];
      int row = 0, col = 0;
      grid.Node(p.point_in_board, kTolerance, &row, &col);
      double* node = &obs[3 * (k * nodes + static_cast<size_t>(row) * grid.width + col)];
      if (node[2] != -1)
        return Status::Error(view.name + ": two points on one node of mrcal's calibration object");
      const double weight = r.reference_sigma_px / p.sigma_px;
      // mrcal has no edge bias: it gets the corners the bias accounts for, where SVMS's fit
      // expects them without it (its residuals are then SVMS's).
      const Eigen::Vector2d seen = p.pixel - r.edge_bias_px * p.edge_shift;
      node[0] = seen.x(), node[1] = seen.y();
      if (r.outlier[k][i]) continue;  // stays at weight -1: mrcal's outlier
      node[2] = weight;
      sum_w2 += weight * weight * r.residuals[k][i].squaredNorm();
      ++inliers;
    }
    // mrcal's frame is the board frame translated to the grid's node (0, 0).
    const Pose& cb = r.cam_from_board[k];
    const Eigen::Vector3d t = cb * grid.origin;
    frames.insert(frames.end(), {cb.rvec.x(), cb.rvec.y(), cb.rvec.z(), t.x(), t.y(), t.z()});
    names.push_back(image_names[r.views[k]]);
  }
  const std::string& lensmodel = r.camera.lensmodel();
  nlohmann::json j;
  j["views"] = nv;
  j["width"] = grid.width;
  j["height"] = grid.height;
  j["spacing"] = grid.spacing;
  j["observations"] = obs;
  j["frames_rt_toref"] = frames;
  j["intrinsics"] = r.camera.intrinsics();
  j["imagersize"] = {r.camera.width(), r.camera.height()};
  j["lensmodel"] = lensmodel;
  j["calobject_warp"] = {r.warp.x(), r.warp.y()};
  j["do_optimize_calobject_warp"] = o.board_warp;
  j["do_apply_regularization"] = lensmodel.rfind("LENSMODEL_SPLINED", 0) == 0;
  j["imagepaths"] = names;
  j["inliers"] = inliers;
  j["weighted_rms"] = inliers > 0 ? std::sqrt(sum_w2 / inliers) : 0.0;
  j["model_text"] = model_text;

  ProgramOutputFiles tmp("mrcal-model", "mrcal-err");
  if (tmp.out.empty() || tmp.err.empty())
    return Status::Error("cannot create a temporary file for mrcal's model");
  RunProgramOptions ro;
  ro.stderr_path = tmp.err;
  // mrcal keeps the image paths only to show them: a path that is not UTF-8 goes with U+FFFD
  // for its invalid bytes.
  ro.stdin_text = DumpJson(j);
  const int rc = RunProgram({o.python, "-c", kScript, tmp.out}, ro);
  std::string err;
  ReadTextFile(tmp.err, &err).ok();
  if (rc == 127) return Status::Error("cannot run " + o.python + " (mrcal's Python)");
  if (rc != 0) {
    const std::string line = LastLine(err);
    return Status::Error(line.empty() ? o.python + " exited with " + std::to_string(rc) : line);
  }
  std::string written;
  if (Status s = ReadTextFile(tmp.out, &written); !s) return s;
  // SVMS's own text comes first, unchanged, so every reader of the model sees the same camera.
  const size_t brace = model_text.find_last_of('}');
  if (brace == std::string::npos || written.compare(0, brace, model_text, 0, brace) != 0)
    return Status::Error("mrcal's Python changed the model's own keys");
  CameraModel back;
  if (Status s = CameraModel::Read(tmp.out, &back); !s) return s;
  if (back.lensmodel() != lensmodel || back.intrinsics() != r.camera.intrinsics())
    return Status::Error("the model with optimization_inputs reads back as another camera");
  *text = std::move(written);
  return Status::Ok();
}

}  // namespace svms
