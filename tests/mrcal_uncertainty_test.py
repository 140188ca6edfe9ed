#!/usr/bin/python3
"""svms camera import-uncertainty against mrcal's own projection uncertainty.

Cameras are calibrated by mrcal itself (mrcal.synthesize_board_observations, mrcal.optimize) on
synthetic boards with known corner noise: a single OPENCV8 camera, and the second camera of a
stereo pair (extrinsics in the problem). For each, `svms camera import-uncertainty` writes the
sidecar, and:
  - the projection uncertainty derived from the sidecar (its mean_frames_factor through
    mrcal.project's gradients) matches mrcal.projection_uncertainty on a 5x5 grid of pixels, at
    0.8 m, 3 m and at infinity, within 10 % (worst-direction sigma);
  - svms's own figures (C++: MeanFramesProjectionCovariance, printed at the centre and the corners)
    match mrcal's within 10 %;
  - the covariance_factor (what detect, pose, survey and the C API use) is the intrinsics' block
    of mrcal's state covariance, recomputed here densely from J (within 1e-6);
  - the intrinsics-only propagation is not mrcal's number (the frames matter), so the comparison
    above can fail;
  - the sidecar is read by svms (camera show), the hint is printed when it is missing, and a model
    without optimization_inputs is refused in one line.
Usage: mrcal_uncertainty_test.py SVMS
"""
import json, os, subprocess, sys, tempfile
import numpy as np, numpysane as nps, mrcal

SVMS = sys.argv[1]
failures = []


def check(ok, what):
    print(("ok    " if ok else "FAIL  ") + what)
    if not ok:
        failures.append(what)


def run(*args):
    return subprocess.run([SVMS, *args], capture_output=True, text=True)


def calibrate(models, seed, Nframes=30, sigma=0.3):
    """An mrcal calibration of `models` (the truth) from synthetic boards; returns solved models."""
    np.random.seed(seed)
    Nw, Nh, spacing = 10, 10, 0.06
    q, Rt_ref_board = mrcal.synthesize_board_observations(
        models, object_width_n=Nw, object_height_n=Nh, object_spacing=spacing,
        calobject_warp=None, rt_ref_boardcenter=np.array([0, 0, 0, 0, 0, 1.3]),
        rt_ref_boardcenter__noiseradius=np.array(
            [np.pi / 180 * 30, np.pi / 180 * 30, np.pi / 180 * 20, 0.4, 0.3, 0.5]),
        Nframes=Nframes)
    Ncam = len(models)
    q = q + np.random.randn(*q.shape) * sigma
    obs = nps.glue(q, np.ones(q.shape[:-1] + (1,)), axis=-1)  # (Nframes, Ncam, Nh, Nw, 3)
    obs = nps.clump(obs, n=2)  # frame-major, then camera
    idx = np.array([[f, c, c - 1] for f in range(Nframes) for c in range(Ncam)], dtype=np.int32)
    lensmodel = models[0].intrinsics()[0]
    seed_intr = np.array([m.intrinsics()[1] for m in models])
    seed_intr[:, :4] *= 1 + 0.01 * np.random.randn(Ncam, 4)
    seed_intr[:, 4:] = 0
    extr = np.array([m.extrinsics_rt_fromref() for m in models[1:]]).reshape(-1, 6)
    oi = dict(intrinsics=seed_intr, extrinsics_rt_fromref=extr + 0.001 * np.random.randn(*extr.shape),
              frames_rt_toref=mrcal.rt_from_Rt(Rt_ref_board) + 0.01 * np.random.randn(Nframes, 6),
              points=None, observations_board=obs,
              indices_frame_camintrinsics_camextrinsics=idx,
              observations_point=None, indices_point_camintrinsics_camextrinsics=None,
              lensmodel=lensmodel,
              imagersizes=np.array([m.imagersize() for m in models], dtype=np.int32),
              calobject_warp=None, do_optimize_intrinsics_core=True,
              do_optimize_intrinsics_distortions=True, do_optimize_extrinsics=True,
              do_optimize_frames=True, do_optimize_calobject_warp=False,
              calibration_object_spacing=spacing, do_apply_outlier_rejection=False,
              do_apply_regularization=True, verbose=False)
    # The core first (distortion held), then everything, as mrcal's tools do.
    oi['do_optimize_intrinsics_distortions'] = False
    mrcal.optimize(**oi)
    oi['do_optimize_intrinsics_distortions'] = True
    stats = mrcal.optimize(**oi)
    print(f"mrcal calibration: {Ncam} camera(s), {Nframes} boards, "
          f"RMS {stats['rms_reproj_error__pixels']:.3f} px")
    return [mrcal.cameramodel(optimization_inputs=oi, icam_intrinsics=i) for i in range(Ncam)]


def grid(model, n=5):
    W, H = model.imagersize()
    u, v = np.linspace(0, W - 1, n), np.linspace(0, H - 1, n)
    return np.array([(a, b) for b in v for a in u], float)


def sidecar_projection_sigma(model, M, p_cam, at_infinity):
    """Worst-direction sigma (px) of the projection of p_cam from the sidecar's factor."""
    lensmodel, intr = model.intrinsics()
    _, dq_dp, dq_di = mrcal.project(p_cam, lensmodel, intr, get_gradients=True)
    out = []
    for k, p in enumerate(p_cam):
        minus_skew = np.array([[0, p[2], -p[1]], [-p[2], 0, p[0]], [p[1], -p[0], 0]])
        G = np.hstack([dq_di[k], dq_dp[k] @ minus_skew,
                       np.zeros((2, 3)) if at_infinity else dq_dp[k]])
        out.append(mrcal.worst_direction_stdev(G @ M @ M.T @ G.T))
    return np.array(out)


def dense_intrinsics_covariance(model, sigma):
    """mrcal's Var(intrinsics) recomputed densely: D sigma^2 inv(JtJ) Jo^t Jo inv(JtJ) D."""
    oi = model.optimization_inputs()
    _, _, J, _ = mrcal.optimizer_callback(**oi)
    J = J.toarray()
    D = np.ones(J.shape[1])
    mrcal.unpack_state(D, **oi)
    Jo = J[:mrcal.num_measurements_boards(**oi)]
    JtJinv = np.linalg.inv(J.T @ J)
    V = sigma ** 2 * JtJinv @ Jo.T @ Jo @ JtJinv * np.outer(D, D)
    i0 = mrcal.state_index_intrinsics(model.icam_intrinsics(), **oi)
    N = mrcal.lensmodel_num_params(oi['lensmodel'])
    return V[i0:i0 + N, i0:i0 + N]


def check_model(name, model, d):
    path = os.path.join(d, name + ".cameramodel")
    model.write(path)
    r = run("camera", "import-uncertainty", path)
    check(r.returncode == 0, f"{name}: import-uncertainty exits 0 ({r.stderr.strip()})")
    if r.returncode != 0:
        return
    print(r.stdout.strip())
    side = json.load(open(path + ".covariance.json"))
    N = len(side["intrinsics"])
    M = np.array(side["mean_frames_factor"])
    L = np.array(side["covariance_factor"])
    model = mrcal.cameramodel(path)
    lensmodel, intr = model.intrinsics()
    q = grid(model)
    worst = 0
    for dist in (0.8, 3.0, None):
        p = mrcal.unproject(q, lensmodel, intr, normalize=True) * (dist or 1.0)
        ref = mrcal.projection_uncertainty(p, model, atinfinity=dist is None,
                                           what="worstdirection-stdev")
        ours = sidecar_projection_sigma(model, M, p, dist is None)
        ratio = ours / ref
        worst = max(worst, np.max(np.abs(ratio - 1)))
        where = "infinity" if dist is None else f"{dist} m"
        # The same computation as mrcal's: agreement to rounding, far inside the 10 % the issue
        # asks, so that a wrong frame average or count cannot hide in it.
        check(np.all(np.abs(ratio - 1) < 1e-4),
              f"{name}: sidecar vs mrcal.projection_uncertainty at {where}, 5x5 grid: "
              f"mrcal {ref.min():.3f}-{ref.max():.3f} px, ratio {ratio.min():.6f}-{ratio.max():.6f}")
        # The intrinsics alone (the pose's term) at the same points: larger, not mrcal's number.
        _, _, dq_di = mrcal.project(p, lensmodel, intr, get_gradients=True)
        marg = mrcal.worst_direction_stdev(nps.matmult(dq_di, L @ L.T, nps.transpose(dq_di)))
        check(np.max(marg / ref) > 1.10 and np.all(marg / ref > 0.999),
              f"{name}: intrinsics alone at {where}: {np.min(marg / ref):.2f}-"
              f"{np.max(marg / ref):.2f} x mrcal's (the boards' frames take part of it)")
    # svms's own numbers (C++), printed at infinity: centre and the four corners.
    W, H = model.imagersize()
    corners = np.array([[(W - 1) / 2, (H - 1) / 2], [0, 0], [W - 1, 0], [0, H - 1], [W - 1, H - 1]])
    ref = mrcal.projection_uncertainty(mrcal.unproject(corners, lensmodel, intr, normalize=True),
                                       model, atinfinity=True, what="worstdirection-stdev")
    line = [l for l in r.stdout.splitlines() if "projection uncertainty" in l][0]
    printed = np.array([float(w) for w in line.replace(" px", "").split(":")[1].split()[1::2]])
    check(np.all(np.abs(printed / ref - 1) < 0.10),
          f"{name}: svms's printed sigmas {printed} vs mrcal's {np.round(ref, 3)}")
    # The covariance_factor against a dense recomputation of mrcal's state covariance.
    C = L @ L.T
    Cd = dense_intrinsics_covariance(model, side["noise_sigma_px"])
    rel = np.max(np.abs(C - Cd) / np.sqrt(np.outer(np.diag(Cd), np.diag(Cd))))
    check(rel < 1e-6, f"{name}: covariance_factor = mrcal's Var(intrinsics) (rel. {rel:.1e})")
    check(np.all(np.linalg.eigvalsh(C) > 0), f"{name}: the intrinsics covariance is positive definite")
    show = run("camera", "show", path)
    check(show.returncode == 0 and "used by svms pose" in show.stdout,
          f"{name}: svms camera show reads the sidecar")
    return worst


with tempfile.TemporaryDirectory() as d:
    truth = mrcal.cameramodel(
        intrinsics=("LENSMODEL_OPENCV8",
                    np.array([1000., 1000., 645., 508., -0.2, 0.05, 0.001, -0.0005, 0.01, 0, 0, 0])),
        imagersize=(1280, 1024))
    (single,) = calibrate([truth], seed=3)
    check_model("single", single, d)

    right = mrcal.cameramodel(truth)
    right.extrinsics_rt_fromref(np.array([0.01, -0.05, 0.002, -0.3, 0.01, 0.02]))
    stereo = calibrate([truth, right], seed=5, Nframes=20)
    check_model("stereo1", stereo[1], d)

    # No sidecar, optimization_inputs present: the commands say how to make one.
    hint_model = os.path.join(d, "hint.cameramodel")
    single.write(hint_model)
    r = run("detect", "--camera", hint_model, os.path.join(d, "none.png"))
    check(f"svms camera import-uncertainty {hint_model}" in r.stderr,
          "svms detect names import-uncertainty when the sidecar is missing")
    # A model without optimization_inputs: refused in one line, exit 2.
    bare = os.path.join(d, "bare.cameramodel")
    mrcal.cameramodel(intrinsics=single.intrinsics(), imagersize=single.imagersize()).write(bare)
    r = run("camera", "import-uncertainty", bare)
    check(r.returncode == 2 and "no optimization_inputs" in r.stderr
          and len(r.stderr.strip().splitlines()) == 1 and not os.path.exists(bare + ".covariance.json"),
          f"no optimization_inputs: exit 2, one line ({r.stderr.strip()})")

if failures:
    print(f"{len(failures)} check(s) failed")
    sys.exit(1)
print("all checks passed")
