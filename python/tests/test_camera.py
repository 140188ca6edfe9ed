"""svms.Camera against mrcal's own Python and OpenCV's projectPoints."""
import io
import os
import tempfile
import unittest

import numpy as np

import svms

OPENCV8 = ("LENSMODEL_OPENCV8",
           [1100.0, 1090.0, 639.3, 481.7, -0.21, 0.08, 1e-3, -5e-4, -0.01, 0.02, -5e-3, 1e-3])


def grid(n=9, z=2.0, half=0.8):
    """Points in front of the camera: an n x n grid at depth z and another at 3 z (metres)."""
    u = np.linspace(-half, half, n)
    x, y = np.meshgrid(u, u)
    near = np.stack([x.ravel() * z, y.ravel() * z, np.full(x.size, z)], axis=1)
    return np.concatenate([near, near * 3])


class CameraTest(unittest.TestCase):
    def test_projection_matches_mrcal(self):
        import mrcal
        for lensmodel, intrinsics in [
                OPENCV8,
                ("LENSMODEL_PINHOLE", [800.0, 810.0, 319.5, 239.5]),
                ("LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=8_Ny=6_fov_x_deg=100",
                 [700.0, 700.0, 639.5, 479.5] +
                 list(np.random.default_rng(1).normal(0, 0.05, 2 * 8 * 6)))]:
            cam = svms.Camera(lensmodel, intrinsics, (1280, 960))
            p = grid()
            ours = cam.project(p)
            theirs = mrcal.project(p, lensmodel, np.array(intrinsics))
            np.testing.assert_allclose(ours, theirs, rtol=0, atol=1e-9, err_msg=lensmodel)
            q, dq_dp, dq_di = cam.project(p, gradients=True)
            _, their_dp, their_di = mrcal.project(p, lensmodel, np.array(intrinsics),
                                                   get_gradients=True)
            np.testing.assert_allclose(q, ours, rtol=0, atol=0)
            np.testing.assert_allclose(dq_dp, their_dp, rtol=1e-9, atol=1e-9, err_msg=lensmodel)
            np.testing.assert_allclose(dq_di, their_di, rtol=1e-9, atol=1e-9, err_msg=lensmodel)
            # One point in, one pixel out; unprojection is the inverse.
            self.assertEqual(cam.project(p[0]).shape, (2,))
            d = cam.unproject(ours)
            np.testing.assert_allclose(d, p / np.linalg.norm(p, axis=1)[:, None], atol=1e-9)

    def test_behind_the_camera_is_nan(self):
        cam = svms.Camera(*OPENCV8, (1280, 960))
        q = cam.project(np.array([[0, 0, -1.0], [0.1, 0, 1.0]]))
        self.assertTrue(np.all(np.isnan(q[0])))
        self.assertTrue(np.all(np.isfinite(q[1])))

    def test_file_round_trip_and_mrcal_objects(self):
        import mrcal
        cam = svms.Camera(*OPENCV8, (1280, 960))
        cam.cam_from_ref = svms.Pose([0.1, -0.2, 0.3], [1.0, 2.0, 3.0])
        with tempfile.TemporaryDirectory() as d:
            path = os.path.join(d, "cam.cameramodel")
            cam.write(path)
            back = svms.Camera(path)
            np.testing.assert_array_equal(back.intrinsics, cam.intrinsics)
            self.assertEqual(back.imagersize, (1280, 960))
            np.testing.assert_array_equal(back.cam_from_ref.tvec, [1.0, 2.0, 3.0])
            m = mrcal.cameramodel(path)
            self.assertEqual(m.intrinsics()[0], "LENSMODEL_OPENCV8")
        # From an mrcal.cameramodel object, and back.
        m = mrcal.cameramodel(io.StringIO(cam.to_text()))
        from_m = svms.Camera.from_mrcal(m)
        np.testing.assert_array_equal(from_m.intrinsics, cam.intrinsics)
        np.testing.assert_allclose(from_m.cam_from_ref.rvec, [0.1, -0.2, 0.3], atol=1e-15)
        m2 = cam.to_mrcal()
        np.testing.assert_array_equal(m2.intrinsics()[1], cam.intrinsics)
        np.testing.assert_array_equal(m2.imagersize(), [1280, 960])

    def test_from_opencv_matches_project_points(self):
        import cv2
        K = np.array([[900.0, 0, 512.3], [0, 905.0, 383.9], [0, 0, 1]])
        full = np.array([-0.25, 0.1, 1e-3, -2e-3, -0.02, 0.01, -4e-3, 2e-3, 1e-3, -1e-3, 5e-4, 2e-4])
        p = grid(z=1.5, half=0.5)
        for n in (0, 4, 5, 8, 12, 14):
            dist = np.concatenate([full, [0, 0]])[:n]
            cam = svms.Camera.from_opencv(K, dist, (1024, 768))
            self.assertEqual(cam.lensmodel, "LENSMODEL_PINHOLE" if n == 0 else
                             f"LENSMODEL_OPENCV{min(n, 12)}")
            ref, _ = cv2.projectPoints(p, np.zeros(3), np.zeros(3), K,
                                       dist if n else np.zeros(4))
            np.testing.assert_allclose(cam.project(p), ref.reshape(-1, 2), rtol=0, atol=1e-6,
                                       err_msg=f"{n} coefficients")

    def test_bad_input(self):
        with self.assertRaises(FileNotFoundError) as e:
            svms.Camera("/nonexistent/cam.cameramodel")
        self.assertIn("/nonexistent/cam.cameramodel", str(e.exception))
        with self.assertRaises(ValueError) as e:
            svms.Camera("LENSMODEL_NOSUCH", [1, 1, 1, 1], (10, 10))
        self.assertIn("lensmodel", str(e.exception))
        with self.assertRaises(ValueError) as e:
            svms.Camera("LENSMODEL_OPENCV4", [1, 1, 1, 1], (10, 10))
        self.assertIn("intrinsics", str(e.exception))
        with self.assertRaises(ValueError) as e:
            svms.Camera.from_opencv([[900, 1, 500], [0, 900, 400], [0, 0, 1]], None, (1000, 800))
        self.assertIn("skew", str(e.exception))
        with self.assertRaises(ValueError):
            svms.Camera.from_opencv(np.eye(3), [0.1, 0.2, 0.3], (10, 10))
        cam = svms.Camera(*OPENCV8, (1280, 960))
        with self.assertRaises(ValueError) as e:
            cam.project(np.zeros((4, 2)))
        self.assertIn("(4, 2)", str(e.exception))
        with self.assertRaises(ValueError):
            cam.intrinsics_covariance_factor = np.eye(3)
        with tempfile.TemporaryDirectory() as d:
            bad = os.path.join(d, "bad.cameramodel")
            with open(bad, "w") as f:
                f.write("{ 'lensmodel': 'LENSMODEL_PINHOLE', 'intrinsics': [1, 2] }\n")
            with self.assertRaises(ValueError) as e:
                svms.Camera(bad)
            self.assertIn(bad, str(e.exception))


class PoseTest(unittest.TestCase):
    def test_matrix_inverse_composition(self):
        a = svms.Pose([0.1, 0.2, -0.3], [1, 2, 3])
        b = svms.Pose([-0.4, 0.0, 0.25], [0.5, -1, 2])
        np.testing.assert_allclose((a * b).matrix, a.matrix @ b.matrix, atol=1e-12)
        np.testing.assert_allclose((a * a.inverse()).matrix, np.eye(4), atol=1e-12)
        np.testing.assert_allclose(svms.Pose.from_matrix(a.matrix).rvec, a.rvec, atol=1e-12)
        p = np.array([[0.1, 0.2, 0.3], [1, 1, 1]])
        np.testing.assert_allclose(a.transform(p), (a.matrix[:3, :3] @ p.T).T + a.tvec, atol=1e-12)
        with self.assertRaises(ValueError):
            svms.Pose.from_matrix(np.ones((4, 4)))


if __name__ == "__main__":
    unittest.main()
