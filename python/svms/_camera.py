"""svms.Camera from and to the other libraries' camera models: mrcal.cameramodel and OpenCV's
camera matrix K with its distortion coefficients."""
import numpy as np

from ._svms import Camera, Pose

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
    mrcal both put pixel (0, 0) at the centre of the top-left pixel. The mapping and its checks
    are those of `svms camera import` (ValueError naming the field)."""
    K = np.asarray(K, dtype=float)
    if K.shape != (3, 3):
        raise ValueError(f"K: expected a 3 x 3 camera matrix, got shape {K.shape}")
    d = np.zeros(0) if dist is None else np.asarray(dist, dtype=float).ravel()
    try:
        width, height = (int(x) for x in imagersize)
    except (TypeError, ValueError):
        raise ValueError(f"imagersize: expected (width, height) in pixels, got {imagersize!r}")
    return Camera._from_opencv(K, d.tolist(), (width, height))