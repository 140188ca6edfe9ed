"""svms.Camera from and to the other libraries' camera models: mrcal.cameramodel and OpenCV's
camera matrix K with its distortion coefficients."""
import numpy as np

from ._svms import Camera, Pose

# OpenCV's distortion vector (k1, k2, p1, p2[, k3[, k4, k5, k6[, s1, s2, s3, s4]]]) is mrcal's
# LENSMODEL_OPENCVn parameters in the same order, after fx, fy, cx, cy.
_OPENCV_MODELS = {4: "LENSMODEL_OPENCV4", 5: "LENSMODEL_OPENCV5", 8: "LENSMODEL_OPENCV8",
                  12: "LENSMODEL_OPENCV12"}


def from_mrcal(model):
    """A Camera from an mrcal.cameramodel (its lens model, intrinsics, image size and
    extrinsics, rt_cam_ref). The uncertainty mrcal keeps in 'optimization_inputs' is not
    carried over (set intrinsics_covariance_factor for that, or run `svms camera
    import-uncertainty` on the file and read it with its sidecar)."""
    lensmodel, intrinsics = model.intrinsics()
    width, height = (int(x) for x in model.imagersize())
    camera = Camera(lensmodel, np.asarray(intrinsics, dtype=float).tolist(), (width, height))
    rt = np.asarray(model.extrinsics_rt_fromref(), dtype=float)
    camera.cam_from_ref = Pose(rt[:3], rt[3:])
    return camera


def to_mrcal(camera):
    """The mrcal.cameramodel of this camera (needs mrcal's Python module)."""
    import mrcal
    rt = np.concatenate([camera.cam_from_ref.rvec, camera.cam_from_ref.tvec])
    return mrcal.cameramodel(intrinsics=(camera.lensmodel, camera.intrinsics),
                             imagersize=np.array(camera.imagersize), extrinsics_rt_fromref=rt)


def from_opencv(K, dist, imagersize):
    """A Camera from OpenCV's 3 x 3 camera matrix K, its distortion coefficients `dist` (0, 4, 5,
    8 or 12 of them, OpenCV's order; 14 when the last two, the tilt, are zero) and imagersize
    (width, height) in pixels. The lens model is mrcal's LENSMODEL_PINHOLE (no coefficients, or
    all zero) or LENSMODEL_OPENCV4/5/8/12, the same projection as cv2.projectPoints. OpenCV and
    mrcal both put pixel (0, 0) at the centre of the top-left pixel."""
    K = np.asarray(K, dtype=float)
    if K.shape != (3, 3):
        raise ValueError(f"K: expected a 3 x 3 camera matrix, got shape {K.shape}")
    if not np.all(np.isfinite(K)) or K[0, 1] != 0 or np.any(K[2] != [0, 0, 1]) or K[1, 0] != 0:
        raise ValueError("K: expected [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] (finite, no skew: "
                         f"mrcal's models have none), got {K.tolist()}")
    d = np.zeros(0) if dist is None else np.asarray(dist, dtype=float).ravel()
    if d.size == 14:
        if np.any(d[12:] != 0):
            raise ValueError("dist: the tilted-sensor terms (tauX, tauY = dist[12:14]) have no "
                             f"mrcal model; expected them zero, got {d[12:].tolist()}")
        d = d[:12]
    try:
        width, height = (int(x) for x in imagersize)
    except (TypeError, ValueError):
        raise ValueError(f"imagersize: expected (width, height) in pixels, got {imagersize!r}")
    core = [K[0, 0], K[1, 1], K[0, 2], K[1, 2]]
    if d.size == 0 or not np.any(d):
        return Camera("LENSMODEL_PINHOLE", core, (width, height))
    if d.size not in _OPENCV_MODELS:
        raise ValueError(f"dist: expected 0, 4, 5, 8, 12 or 14 coefficients (OpenCV's order), got {d.size}")
    return Camera(_OPENCV_MODELS[d.size], core + d.tolist(), (width, height))
