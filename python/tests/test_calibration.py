"""svms.calibrate on the calibration benchmark's quick board views: the camera `svms calibrate`
writes from the same images, and the truth."""
import glob
import os
import subprocess
import tempfile
import unittest

import numpy as np

import svms
from svms_test_data import need


class CalibrationTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        import cv2
        cls.board_dir = need("SVMS_BOARD_IMAGES")
        cls.binary = need("SVMS_BINARY")
        cls.tmp = tempfile.TemporaryDirectory()
        # The board's layout and the true camera, as the dataset writes them (no rendering).
        subprocess.run([cls.binary, "dataset", "calibration", "--quick", "--no-render", "--out",
                        os.path.join(cls.tmp.name, "cal"), "--quiet"], check=True,
                       capture_output=True)
        cls.board = os.path.join(cls.tmp.name, "cal", "board_layout.json")
        cls.truth = svms.Camera(os.path.join(cls.tmp.name, "cal", "true.cameramodel"))
        cls.files = sorted(glob.glob(os.path.join(cls.board_dir, "*.png")))
        cls.images = [cv2.imread(f, cv2.IMREAD_UNCHANGED) for f in cls.files]
        cls.result = svms.calibrate(cls.images, cls.board, names=cls.files)

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_same_camera_as_svms_calibrate(self):
        out = os.path.join(self.tmp.name, "cam.cameramodel")
        subprocess.run([self.binary, "calibrate", *self.files, "--board", self.board, "--out", out,
                        "--threads", "1", "--quiet"], check=True, capture_output=True)
        cli = svms.Camera(out)  # with its covariance sidecar
        cam = self.result.camera
        self.assertEqual(cam.lensmodel, cli.lensmodel)
        # The same solve (equal to the last bit here; the limits leave room for sums whose
        # order follows the heap's layout, docs/architecture.md).
        np.testing.assert_allclose(cam.intrinsics, cli.intrinsics, rtol=1e-9, atol=0)
        L = cli.intrinsics_covariance_factor
        np.testing.assert_allclose(cam.intrinsics_covariance_factor, L, rtol=1e-6,
                                   atol=1e-6 * np.abs(L).max())

    def test_against_the_truth(self):
        r = self.result
        self.assertGreaterEqual(len(r.views), 3)
        self.assertLess(r.rms_px, 0.5)
        e, t = r.camera.intrinsics, self.truth.intrinsics
        # cli_success_test.sh's limits: focal lengths within 0.1 %, centre within 1 px.
        self.assertLess(np.max(np.abs(e[:2] / t[:2] - 1)), 1e-3)
        self.assertLess(np.max(np.abs(e[2:4] - t[2:4])), 1.0)
        n = len(e)
        m = n + 6 * len(r.views)  # [intrinsics, cam_from_board per view]
        self.assertEqual(r.covariance.shape, (m, m))
        L = r.camera.intrinsics_covariance_factor
        np.testing.assert_allclose(L @ L.T, r.covariance[:n, :n], rtol=1e-6,
                                   atol=1e-9 * np.abs(r.covariance[:n, :n]).max())
        self.assertEqual(len(r.cam_from_board), len(r.views))

    def test_edge_bias(self):
        # On linear renders there is no bias to find: zero within its sigma, one more state.
        r = svms.calibrate(self.images, self.board, edge_bias=True, redetect=False)
        self.assertGreater(r.edge_bias_sigma_px, 0)
        self.assertLess(abs(r.edge_bias_px), 4 * r.edge_bias_sigma_px)
        n = len(r.camera.intrinsics)
        self.assertEqual(r.covariance.shape[0], n + 6 * len(r.views) + 1)
        self.assertEqual(self.result.edge_bias_sigma_px, 0)

    def test_estimated_response(self):
        """The board through a gamma-2.2 camera with 0.7 px of defocus: the linear renders blurred
        in linear light, then encoded, as real_cameras_test.sh renders it for the CLI."""
        import cv2
        top = 255.0 if self.images[0].dtype == np.uint8 else 65535.0
        encoded = []
        for img in self.images:
            linear = cv2.GaussianBlur(img.astype(np.float64) / top, (0, 0), 0.7)
            encoded.append(np.round(255 * np.clip(linear, 0, 1) ** (1 / 2.2)).astype(np.uint8))
        est = svms.estimate_response(encoded, self.board)
        self.assertGreater(est.patches, 100)
        self.assertGreater(est.sigma, 0)
        self.assertLess(abs(est.gamma - 2.2), max(0.15, 4 * est.sigma), est)
        self.assertEqual(est.response, "gamma:%g" % est.gamma)
        # The same estimate as svms calibrate's from the same pixels in files (8-bit PNGs that
        # declare nothing: read as sRGB for the first pass, as here).
        d = os.path.join(self.tmp.name, "gamma22")
        os.makedirs(d, exist_ok=True)
        for f, img in zip(self.files, encoded):
            cv2.imwrite(os.path.join(d, os.path.basename(f)), img)
        cli = subprocess.run([self.binary, "calibrate", d, "--board", self.board, "--response",
                              "estimate", "--out", os.path.join(d, "cam.cameramodel"),
                              "--threads", "1"], check=True, capture_output=True, text=True)
        line = [l for l in cli.stderr.splitlines() if "response estimated from" in l]
        self.assertEqual(len(line), 1, cli.stderr)
        self.assertIn("from %d edge patches: gamma %.3f +- %.3f" % (est.patches, est.gamma,
                                                                    est.sigma), line[0])
        # calibrate(response="estimate") uses that curve, fits the edge bias with it, and
        # calibrates as well as on the linear images (the focal lengths within 0.3 %, as
        # real_cameras_test.sh asks of the CLI).
        r = svms.calibrate(encoded, self.board, response="estimate")
        self.assertEqual(r.response.gamma, est.gamma)
        self.assertGreater(r.edge_bias_sigma_px, 0)
        f, f0 = r.camera.intrinsics[:2], self.result.camera.intrinsics[:2]
        self.assertLess(np.max(np.abs(f / f0 - 1)), 3e-3)
        self.assertIsNone(self.result.response)
        # ... and the camera svms calibrate --response estimate wrote (its edge bias fitted too;
        # the curve it refines from that bias afterwards changes no intrinsics).
        cli_camera = svms.Camera(os.path.join(d, "cam.cameramodel"))
        np.testing.assert_allclose(r.camera.intrinsics, cli_camera.intrinsics, rtol=1e-9, atol=0)
        # Linear images read as such; an image without markers: nothing to read, no curve.
        lin = svms.estimate_response(self.images, self.board)
        self.assertGreater(lin.patches, 100)
        self.assertLess(abs(lin.gamma - 1), max(0.15, 4 * lin.sigma), lin)
        blank = [np.full_like(encoded[0], 128)]
        self.assertEqual(svms.estimate_response(blank, self.board).patches, 0)
        self.assertIsNone(svms.estimate_response(blank, self.board).response)
        with self.assertRaises(ValueError) as e:
            svms.calibrate(blank * 3, self.board, response="estimate")
        self.assertIn("0 edge patches", str(e.exception))
        with self.assertRaises(ValueError) as e:
            svms.calibrate([], self.board)
        self.assertIn("at least one image", str(e.exception))

    def test_bad_input(self):
        with self.assertRaises(ValueError) as e:
            svms.calibrate(self.images, self.board, lensmodel="LENSMODEL_NOSUCH")
        self.assertIn("lensmodel", str(e.exception))
        with self.assertRaises(ValueError) as e:
            svms.calibrate([self.images[0], self.images[1][:-1]], self.board)
        self.assertIn("images[1]", str(e.exception))
        with self.assertRaises(ValueError):
            svms.calibrate(self.images, self.board, names=["one"])


if __name__ == "__main__":
    unittest.main()
