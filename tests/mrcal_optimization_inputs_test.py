#!/usr/bin/python3
"""`svms calibrate`'s models carry mrcal's optimization_inputs, and mrcal's own tools agree with
SVMS on them.

On the quick calibration benchmark's rendered board views (12 images, 6 x 5 markers):
  - the model has optimization_inputs; the board's corners sit on mrcal's grid (0.015 m spacing,
    50 x 41 nodes, 4 corners a marker);
  - mrcal.projection_uncertainty agrees with SVMS's own (the report's uncertainty.dat, 32 x 32
    pixels at the median board range) within 10 % at every pixel within 50 px of an observed
    corner (where OPENCV8 is not extrapolated: far outside, the model folds and the two
    unprojections of one pixel can be different rays);
  - the intrinsics' covariance that `svms camera import-uncertainty` recomputes from the stored
    problem with mrcal's Python equals SVMS's sidecar (sigmas within 10 %);
  - mrcal-show-projection-uncertainty and mrcal-show-residuals-board-observation run and write
    their pictures;
  - mrcal's residuals of the stored observations from the stored frames are SVMS's
    (residuals.dat, point by point, and the RMS of summary.json);
  - the model's own keys are those of a model written without optimization_inputs, byte for
    byte, and svms detect measures the same poses with both;
  - with --warp, mrcal's warp is SVMS's and the uncertainties still agree;
  - the fallbacks: without mrcal's Python, and with a board whose corners lie on no grid mrcal
    can hold, the model is written without optimization_inputs, with its sidecar and a note.
Usage: mrcal_optimization_inputs_test.py SVMS BOARD_IMAGES_DIR
"""
import glob, json, os, shutil, subprocess, sys, tempfile
import numpy as np, mrcal

SVMS, IMAGES = sys.argv[1], sys.argv[2]
failures = []


def check(ok, what):
    print(("ok    " if ok else "FAIL  ") + what)
    if not ok:
        failures.append(what)


def run(*args):
    return subprocess.run([*args], capture_output=True, text=True)


def tool(name, *args):
    # mrcal's tools under Debian's Python (the PATH's python3 may be another one).
    return run("/usr/bin/python3", shutil.which(name) or "/usr/bin/" + name, *args)


tmp = tempfile.mkdtemp()
images = sorted(glob.glob(os.path.join(IMAGES, "*.png")))
check(len(images) >= 10, f"{len(images)} board images in {IMAGES}")
r = run(SVMS, "dataset", "calibration", "--quick", "--no-render", "--out", f"{tmp}/cal", "--quiet")
board = f"{tmp}/cal/board_layout.json"


def calibrate(name, *options, board=board):
    out = f"{tmp}/{name}.cameramodel"
    r = run(SVMS, "calibrate", *images, "--board", board, "--out", out, "--report",
            f"{tmp}/{name}_report", "--quiet", "--threads", "2", *options)
    check(r.returncode == 0, f"svms calibrate {name} exits 0 (got {r.returncode}: {r.stderr.strip()})")
    return out, f"{tmp}/{name}_report", r


def uncertainty_agreement(model_path, report, label):
    """mrcal.projection_uncertainty against the report's grid, near the observations."""
    m = mrcal.cameramodel(model_path)
    summary = json.load(open(report + "/summary.json"))
    R = summary["uncertainty"]["range_m"]
    u = np.loadtxt(report + "/uncertainty.dat")
    q, svms = u[:, :2], u[:, 2]  # svms: sqrt(trace(Var(q))) in pixels
    p = mrcal.unproject(q, *m.intrinsics(), normalize=True) * R
    C = mrcal.projection_uncertainty(p, m, what="covariance")
    ours = np.sqrt(C[..., 0, 0] + C[..., 1, 1])
    oi = m.optimization_inputs()
    obs = oi["observations_board"].reshape(-1, 3)
    obs = obs[obs[:, 2] > 0, :2]
    dmin = np.min(np.linalg.norm(q[:, None, :] - obs[None, :, :], axis=-1), axis=-1)
    near = dmin < 50
    ratio = ours[near] / svms[near]
    check(near.sum() > 300, f"{label}: {near.sum()} of {len(q)} grid pixels near the observations")
    check(np.all(np.abs(ratio - 1) < 0.10),
          f"{label}: mrcal / svms projection uncertainty at {R:.2f} m over those pixels: "
          f"{ratio.min():.4f} .. {ratio.max():.4f} (median {np.median(ratio):.4f}; "
          f"svms {svms[near].min():.4f} .. {svms[near].max():.4f} px)")
    return m, oi, summary


# The default calibration, and the same without optimization_inputs.
model, report, _ = calibrate("cam")
plain, _, _ = calibrate("plain", "--no-optimization-inputs")
text, plain_text = open(model).read(), open(plain).read()
check("'optimization_inputs':" in text and "'optimization_inputs':" not in plain_text,
      "the model has optimization_inputs; with --no-optimization-inputs it has none")
check(text.startswith(plain_text[:plain_text.rindex("}")]),
      "the model's own keys are byte for byte those of the model without optimization_inputs")
check(open(model + ".covariance.json").read() == open(plain + ".covariance.json").read(),
      "the covariance sidecar is unchanged")

m, oi, summary = uncertainty_agreement(model, report, "OPENCV8")
check(oi["observations_board"].shape == (len(images), 41, 50, 3)
      and abs(oi["calibration_object_spacing"] - 0.015) < 1e-12,
      f"the board is mrcal's 50 x 41 grid at 0.015 m (got {oi['observations_board'].shape}, "
      f"{oi['calibration_object_spacing']})")
check(np.sum(oi["observations_board"][..., 2] > 0) == summary["points"]["inliers"],
      "every inlier corner is one observed grid node")

# mrcal's residuals of the stored observations at the stored optimum are SVMS's.
b, x, J, factorization = mrcal.optimizer_callback(**oi)
res = mrcal.residuals_chessboard(oi, residuals=x)
rms = np.sqrt(np.mean(np.sum(res * res, axis=-1)))
svms_rms = summary["residuals_px"]["rms"]
check(abs(rms / svms_rms - 1) < 0.01, f"residual RMS: mrcal {rms:.6f} px, svms {svms_rms:.6f} px")
obs = oi["observations_board"]
seen = obs[..., 2] > 0
seen_px, seen_res = obs[seen][:, :2], res
worst, matched = 0.0, 0
for row in np.loadtxt(report + "/residuals.dat"):  # observed x, y, residual x, y (6 digits)
    k = np.argmin(np.sum((seen_px - row[:2]) ** 2, axis=-1))
    if np.max(np.abs(seen_px[k] - row[:2])) < 0.01:
        matched += 1
        worst = max(worst, float(np.max(np.abs(seen_res[k] - row[2:4]))))
check(matched == len(res) and worst < 1e-4,
      f"residuals point by point: {matched} of {len(res)} matched, largest difference {worst:.2g} px")

# The intrinsics' covariance mrcal recomputes from the stored problem is SVMS's sidecar's.
shutil.copy(model, f"{tmp}/imported.cameramodel")
r = run(SVMS, "camera", "import-uncertainty", f"{tmp}/imported.cameramodel")
check(r.returncode == 0, f"svms camera import-uncertainty on it exits 0 ({r.stderr.strip()})")
if r.returncode == 0:
    def sigmas(path):
        F = np.array(json.load(open(path))["covariance_factor"])
        return np.sqrt(np.diag(F @ F.T))
    ratio = sigmas(f"{tmp}/imported.cameramodel.covariance.json") / sigmas(model + ".covariance.json")
    check(np.all(np.abs(ratio - 1) < 0.10),
          f"intrinsics' sigmas, mrcal / svms: {ratio.min():.4f} .. {ratio.max():.4f}")

# mrcal's tools.
r = tool("mrcal-show-projection-uncertainty", "--cbmax", "1", "--gridn", "8", "6", "--hardcopy",
         f"{tmp}/uncertainty.png", model)
check(r.returncode == 0 and os.path.getsize(f"{tmp}/uncertainty.png") > 1000,
      f"mrcal-show-projection-uncertainty exits 0 and draws ({r.stderr.strip()[-200:]})")
r = tool("mrcal-show-residuals-board-observation", "--hardcopy", f"{tmp}/residuals.png", model, "0")
check(r.returncode == 0 and os.path.getsize(f"{tmp}/residuals.png") > 1000,
      f"mrcal-show-residuals-board-observation exits 0 and draws ({r.stderr.strip()[-200:]})")

# svms measures with the model as before.
def poses(cam):
    r = run(SVMS, "detect", images[0], "--camera", cam, "--markers", board, "--quiet")
    return [(d["id"], d.get("cam_from_marker")) for line in r.stdout.splitlines()
            for d in json.loads(line)["detections"]]
a, p = poses(model), poses(plain)
check(len(a) > 10 and a == p, f"svms detect: the same {len(a)} poses with and without optimization_inputs")

# With the warp estimated: mrcal's warp is SVMS's, optimised, and the uncertainties agree.
warped, wreport, _ = calibrate("warp", "--warp")
mw, oiw, sw = uncertainty_agreement(warped, wreport, "OPENCV8 --warp")
check(bool(oiw["do_optimize_calobject_warp"]) and np.any(oiw["calobject_warp"] != 0),
      f"--warp: mrcal's calobject_warp {oiw['calobject_warp']} is optimised")

# Fallbacks: the model and its sidecar without optimization_inputs, and a note saying why.
nopy, _, r = calibrate("nopy", "--python", f"{tmp}/no-such-python")
check("'optimization_inputs':" not in open(nopy).read() and os.path.exists(nopy + ".covariance.json")
      and "without mrcal's optimization_inputs" in r.stderr and "no-such-python" in r.stderr,
      f"without mrcal's Python: model and sidecar, no optimization_inputs, a note ({r.stderr.strip()})")
layout = json.load(open(board))
layout["markers"][7]["object_from_marker"]["tvec"][0] += 0.0007  # 0.7 mm: the grid would be 0.1 mm
json.dump(layout, open(f"{tmp}/moved.json", "w"))
moved, _, r = calibrate("moved", board=f"{tmp}/moved.json")
check("'optimization_inputs':" not in open(moved).read() and os.path.exists(moved + ".covariance.json")
      and "no regular grid" in r.stderr,
      f"a board off any grid mrcal can hold: model and sidecar, no optimization_inputs, a note "
      f"({r.stderr.strip()})")
try:
    mrcal.projection_uncertainty(np.array((0., 0., 1.)), mrcal.cameramodel(moved))
    check(False, "mrcal refuses the uncertainty of a model without optimization_inputs")
except Exception as e:
    check("optimization_inputs" in str(e), f"mrcal's uncertainty refuses it: {e}")

shutil.rmtree(tmp)
if failures:
    sys.exit(f"{len(failures)} checks failed")
print("mrcal_optimization_inputs: ok")
