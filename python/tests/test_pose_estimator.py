"""svms.PoseEstimator on the C API's fixture frame (approach view 11, 2.25 m): the truth, and
the same numbers as `svms pose` on the same pixels; and on its two-object frame (the module and
a fixture plate, approach view 6) with two layouts: one detection, each object's own pose."""
import json
import os
import subprocess
import tempfile
import threading
import unittest

import numpy as np

import svms
from svms_test_data import need


class PoseEstimatorTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.fixture = need("SVMS_CAPI_FIXTURE")
        cls.camera_path = os.path.join(cls.fixture, "true.cameramodel")
        cls.layout_path = os.path.join(cls.fixture, "true_layout.json")
        cls.camera = svms.Camera(cls.camera_path)
        cls.layout = svms.read_layout(cls.layout_path)
        raw = np.fromfile(os.path.join(cls.fixture, "frame_11.raw"), np.uint8)
        cls.frame = raw.reshape(cls.camera.height, cls.camera.width)
        with open(os.path.join(cls.fixture, "frame_11.txt")) as f:
            t = [float(x) for x in f.read().split()]
        cls.truth = svms.Pose(t[:3], t[3:])

    def test_pose_against_the_truth(self):
        e = svms.PoseEstimator(self.camera, self.layout)
        r = e.estimate(self.frame, 1.1)
        p = r.pose
        self.assertTrue(p.valid, p.message)
        self.assertEqual(r.timestamp, 1.1)
        self.assertGreaterEqual(p.markers_used, 2)
        self.assertEqual(p.dof, 2 * p.points_used + p.edge_rows - 6)
        self.assertTrue(r.detections)
        # The C API's limits on this frame (capi_test.c): 0.16 mm and 0.008 degrees.
        self.assertLess(np.linalg.norm(p.cam_from_object.tvec - self.truth.tvec), 0.16e-3)
        R = p.cam_from_object.rotation.T @ self.truth.rotation
        angle = np.arccos(np.clip((np.trace(R) - 1) / 2, -1, 1))
        self.assertLess(np.degrees(angle), 0.008)
        cov = p.covariance
        self.assertEqual(cov.shape, (6, 6))
        np.testing.assert_array_equal(cov, cov.T)
        self.assertTrue(np.all(np.linalg.eigvalsh(cov) > 0))
        self.assertFalse(p.calibration_in_covariance)

    def test_same_numbers_as_svms_pose(self):
        import cv2
        binary = need("SVMS_BINARY")
        r = svms.PoseEstimator.from_files(self.camera_path, self.layout_path).estimate(self.frame, 0)
        with tempfile.TemporaryDirectory() as d:
            png = os.path.join(d, "frame.png")
            cv2.imwrite(png, self.frame)
            out = subprocess.run([binary, "pose", png, "--camera", self.camera_path, "--layout",
                                  self.layout_path, "--response", "linear", "--quiet"],
                                 check=True, capture_output=True, text=True).stdout
        j = json.loads(out.splitlines()[0])
        self.assertTrue(j["valid"])
        np.testing.assert_array_equal(r.pose.cam_from_object.rvec, j["cam_from_object"]["rvec"])
        np.testing.assert_array_equal(r.pose.cam_from_object.tvec, j["cam_from_object"]["tvec"])
        np.testing.assert_array_equal(r.pose.covariance.ravel(), j["covariance"])
        self.assertIsNone(j["covariance_common"])  # no calibration's uncertainty here
        self.assertIsNone(j["bias_factor"])
        self.assertEqual(r.pose.ids_used, j["markers"])

    def test_calibration_covariance_from_the_sidecar(self):
        e = svms.PoseEstimator(os.path.join(self.fixture, "cal.cameramodel"), self.layout_path)
        self.assertEqual(e.camera.intrinsics_covariance_factor.shape[0], len(e.camera.intrinsics))
        p = e.estimate(self.frame).pose
        self.assertTrue(p.valid and p.calibration_in_covariance)
        plain = svms.PoseEstimator(self.camera, self.layout).estimate(self.frame).pose
        # The calibration's error widens the range's variance.
        self.assertGreater(p.covariance[5, 5], plain.covariance[5, 5])
        # By its share common to every frame, one column per component of the intrinsics'
        # error: the same pose, so what remains is the plain covariance.
        B = p.bias_factor
        self.assertEqual(B.shape, (6, e.camera.intrinsics_covariance_factor.shape[1]))
        np.testing.assert_allclose(p.covariance - B @ B.T, plain.covariance,
                                   rtol=0, atol=1e-9 * np.abs(plain.covariance).max())
        self.assertEqual(plain.bias_factor.shape, (6, 0))

    def test_threads_and_bad_input(self):
        e = svms.PoseEstimator(self.camera, self.layout)
        expected = e.estimate(self.frame).pose.cam_from_object.tvec
        results = []
        threads = [threading.Thread(target=lambda: results.append(
            e.estimate(self.frame).pose.cam_from_object.tvec)) for _ in range(3)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        for r in results:
            np.testing.assert_array_equal(r, expected)
        with self.assertRaises(ValueError) as c:
            e.estimate(self.frame[:, :-1].copy())
        self.assertIn("1023x1024", str(c.exception))
        with self.assertRaises(TypeError):
            e.estimate(self.frame.astype(np.float32))
        with self.assertRaises(ValueError):
            e.estimate(self.frame, float("nan"))
        with self.assertRaises(FileNotFoundError):
            svms.PoseEstimator("/nonexistent/cam.cameramodel", self.layout)
        with self.assertRaises(ValueError) as c:
            svms.read_layout(self.camera_path)
        self.assertIn(self.camera_path, str(c.exception))
        with self.assertRaises(ValueError) as c:
            svms.PoseEstimator(self.camera, svms.Layout())
        empty_frame = np.zeros_like(self.frame)
        p = e.estimate(empty_frame).pose
        self.assertFalse(p.valid)
        self.assertTrue(p.message)


class SeveralObjectsTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.fixture = need("SVMS_CAPI_FIXTURE")
        cls.camera_path = os.path.join(cls.fixture, "true.cameramodel")
        cls.module_path = os.path.join(cls.fixture, "true_layout.json")
        cls.fixture_path = os.path.join(cls.fixture, "fixture_layout.json")
        cls.camera = svms.Camera(cls.camera_path)
        raw = np.fromfile(os.path.join(cls.fixture, "pair.raw"), np.uint8)
        cls.frame = raw.reshape(cls.camera.height, cls.camera.width)
        with open(os.path.join(cls.fixture, "pair.txt")) as f:
            rows = [[float(x) for x in line.split()] for line in f.read().splitlines()]
        cls.truths = [svms.Pose(r[:3], r[3:]) for r in rows]

    def test_two_layouts_one_detection_each_its_own_pose(self):
        layouts = [svms.read_layout(self.module_path), svms.read_layout(self.fixture_path)]
        e = svms.PoseEstimator(self.camera, layouts)
        self.assertEqual([l.name for l in e.layouts], ["mockup (true)", "fixture"])
        r = e.estimate(self.frame, 0.5)
        self.assertEqual(r.detection_passes, 1)
        self.assertEqual(len(r.poses), 2)
        self.assertEqual(r.unassigned_ids, [])
        self.assertGreaterEqual(r.latency_ms, r.detect_ms + r.fuse_ms - 1e-6)
        for i, (pose, truth, layout) in enumerate(zip(r.poses, self.truths, layouts)):
            self.assertTrue(pose.valid, pose.message)
            self.assertLess(np.linalg.norm(pose.cam_from_object.tvec - truth.tvec), 1e-3)
            alone = svms.PoseEstimator(self.camera, layout).estimate(self.frame, 0.5).pose
            # Bit for bit the pose of an estimator of this object alone.
            np.testing.assert_array_equal(pose.cam_from_object.rvec, alone.cam_from_object.rvec)
            np.testing.assert_array_equal(pose.cam_from_object.tvec, alone.cam_from_object.tvec)
            np.testing.assert_array_equal(pose.covariance, alone.covariance)
            self.assertEqual(pose.ids_used, alone.ids_used)
        np.testing.assert_array_equal(r.pose.cam_from_object.tvec, r.poses[0].cam_from_object.tvec)
        self.assertTrue(set(r.poses[1].ids_used) <= {30, 31, 32})
        # From files, as svms pose and the C API read them: the same numbers.
        f = svms.PoseEstimator.from_files(self.camera_path, [self.module_path, self.fixture_path])
        rf = f.estimate(self.frame, 0.5)
        for a, b in zip(rf.poses, r.poses):
            np.testing.assert_array_equal(a.cam_from_object.tvec, b.cam_from_object.tvec)

    def test_unassigned_markers_and_bad_layouts(self):
        options = svms.PoseEstimatorOptions()
        options.detector.known_ids_only = False
        r = svms.PoseEstimator(self.camera, self.module_path, options).estimate(self.frame)
        self.assertEqual(sorted(r.unassigned_ids), [30, 31, 32])
        clash = os.path.join(self.fixture, "clash_layout.json")
        with self.assertRaises(ValueError) as c:
            svms.PoseEstimator.from_files(self.camera_path, [self.module_path, clash])
        self.assertIn(clash + ": marker ID 13 is also in " + self.module_path, str(c.exception))
        with self.assertRaises(ValueError) as c:
            svms.PoseEstimator(self.camera, [self.module_path, clash])
        self.assertIn("marker ID 13 is also in layouts[0] 'mockup (true)'", str(c.exception))
        with self.assertRaises(FileNotFoundError) as c:
            svms.PoseEstimator.from_files(self.camera_path, [self.module_path, "/nonexistent.json"])
        self.assertIn("/nonexistent.json", str(c.exception))
        with self.assertRaises(ValueError):
            svms.PoseEstimator(self.camera, [])


if __name__ == "__main__":
    unittest.main()
