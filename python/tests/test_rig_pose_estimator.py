"""svms.RigPoseEstimator on the C API's fixture frame (approach view 11): a one-camera rig gives
rig_from_cam times the camera's own pose; two cameras that are one (the same model, pose and
frame) halve the covariance; bad rig files raise ValueError naming the file and field."""
import json
import os
import tempfile
import unittest

import numpy as np

import svms
from svms_test_data import need


def rotation(rvec):
    return svms.Pose(rvec, [0, 0, 0]).rotation


class RigPoseEstimatorTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.fixture = need("SVMS_CAPI_FIXTURE")
        cls.camera_path = os.path.join(cls.fixture, "true.cameramodel")
        cls.layout_path = os.path.join(cls.fixture, "true_layout.json")
        camera = svms.Camera(cls.camera_path)
        raw = np.fromfile(os.path.join(cls.fixture, "frame_11.raw"), np.uint8)
        cls.frame = raw.reshape(camera.height, camera.width)
        cls.rig_from_cam = ([0.1, -0.2, 0.05], [0.3, -0.1, 0.2])

    def write_rig(self, directory, cameras):
        path = os.path.join(directory, "test.rig")
        with open(path, "w") as f:
            json.dump({"type": "svms.rig", "cameras": cameras}, f)
        return path

    def camera_entry(self, name):
        rvec, tvec = self.rig_from_cam
        return {"name": name, "cameramodel": self.camera_path,
                "rig_from_cam": {"rvec": rvec, "tvec": tvec}}

    def test_one_camera_rig_is_rig_from_cam_times_the_cameras_pose(self):
        with tempfile.TemporaryDirectory() as d:
            rig = svms.RigPoseEstimator.from_files(
                self.write_rig(d, [self.camera_entry("only")]), self.layout_path)
        self.assertEqual(rig.camera_names, ["only"])
        r = rig.estimate([self.frame], 2.5)
        self.assertEqual(r.timestamp, 2.5)
        self.assertTrue(r.pose.valid, r.pose.message)
        alone = svms.PoseEstimator.from_files(self.camera_path, self.layout_path).estimate(
            self.frame).pose
        R_rc = rotation(self.rig_from_cam[0])
        expected_R = R_rc @ alone.cam_from_object.rotation
        expected_t = R_rc @ alone.cam_from_object.tvec + np.array(self.rig_from_cam[1])
        np.testing.assert_allclose(r.pose.cam_from_object.rotation, expected_R, atol=1e-9)
        np.testing.assert_allclose(r.pose.cam_from_object.tvec, expected_t, atol=1e-9)
        A = np.zeros((6, 6))
        A[:3, :3] = A[3:, 3:] = R_rc
        np.testing.assert_allclose(r.pose.covariance, A @ alone.covariance @ A.T,
                                   rtol=1e-6, atol=1e-15)
        self.assertEqual(set(r.pose.cameras_used), {0})
        self.assertEqual(len(r.cameras), 1)

    def test_two_identical_cameras_halve_the_covariance(self):
        with tempfile.TemporaryDirectory() as d:
            rig = svms.RigPoseEstimator.from_files(
                self.write_rig(d, [self.camera_entry("a"), self.camera_entry("b")]),
                self.layout_path)
        one = rig.estimate([self.frame, None]).pose
        two = rig.estimate([self.frame, self.frame]).pose
        self.assertTrue(one.valid and two.valid)
        np.testing.assert_allclose(two.covariance, one.covariance / 2, rtol=1e-6, atol=1e-15)
        self.assertEqual(sorted(set(two.cameras_used)), [0, 1])
        with self.assertRaisesRegex(ValueError, "one per camera of the rig"):
            rig.estimate([self.frame])

    def test_survey_finds_a_camera_that_is_another_ones_twin(self):
        # Camera b sees exactly what camera a sees, so it sits where a sits; the rig file puts it
        # 0.02 rad and 30 mm away. The survey, with a held fixed, must move it back.
        with tempfile.TemporaryDirectory() as d:
            b = self.camera_entry("b")
            b["rig_from_cam"] = {"rvec": [0.12, -0.2, 0.05], "tvec": [0.33, -0.1, 0.2]}
            rig = svms.RigPoseEstimator.from_files(
                self.write_rig(d, [self.camera_entry("a"), b]), self.layout_path)
        r = rig.survey_extrinsics([(0.0, [self.frame, self.frame])], reference="a")
        a_out, b_out = r["cameras"]
        self.assertTrue(a_out["reference"])
        self.assertFalse(b_out["reference"])
        self.assertEqual(r["frames_used"], 1)
        self.assertGreater(b_out["markers"], 0)
        rvec, tvec = self.rig_from_cam
        np.testing.assert_allclose(a_out["rig_from_cam"].rvec, rvec, atol=1e-12)
        np.testing.assert_allclose(b_out["rig_from_cam"].rotation, rotation(rvec), atol=1e-6)
        np.testing.assert_allclose(b_out["rig_from_cam"].tvec, tvec, atol=1e-6)
        C = b_out["covariance"]
        self.assertEqual(C.shape, (6, 6))
        np.testing.assert_allclose(C, C.T, rtol=1e-9, atol=1e-18)
        self.assertTrue(np.all(np.linalg.eigvalsh(C) > 0))
        self.assertIsNone(a_out["covariance"])  # the reference had none in the rig file
        with self.assertRaisesRegex(ValueError, r"frames\[0\]\[1\]: 1 images, expected one per camera"):
            rig.survey_extrinsics([(0.0, [self.frame])])
        with self.assertRaisesRegex(ValueError, "reference: no camera named 'c'"):
            rig.survey_extrinsics([(0.0, [self.frame, self.frame])], reference="c")
        with self.assertRaisesRegex(ValueError, "at least one time stamp"):
            rig.survey_extrinsics([])
        with self.assertRaisesRegex(ValueError, r"frames\[0\]\[0\]: expected a time stamp"):
            rig.survey_extrinsics([("now", [self.frame, self.frame])])
        with self.assertRaisesRegex(ValueError, "reference: expected a camera's index or name"):
            rig.survey_extrinsics([(0.0, [self.frame, self.frame])], reference=1.5)

        # An image given as an object with __array__ (converted to a new array) stays alive
        # until the frame is used.
        class Wrapped:
            def __init__(self, a):
                self.a = a

            def __array__(self, dtype=None):
                return self.a.copy()

        self.assertTrue(rig.estimate([Wrapped(self.frame), None]).pose.valid)
        # b alone at the only time stamp: nothing ties it to a.
        with self.assertRaises(RuntimeError):
            rig.survey_extrinsics([(0.0, [None, self.frame])], reference=0)

    def test_bad_rig_files_name_the_file_and_field(self):
        with tempfile.TemporaryDirectory() as d:
            entry = self.camera_entry("a")
            entry["covariance"] = [[1e-6 if i == j else 0 for j in range(6)] for i in range(6)]
            entry["covariance"][0][1] = 1e-7
            path = self.write_rig(d, [entry])
            with self.assertRaisesRegex(ValueError,
                                        r"test\.rig: cameras\[0\]\.covariance: expected a "
                                        "symmetric"):
                svms.RigPoseEstimator.from_files(path, self.layout_path)
        with self.assertRaises(FileNotFoundError):
            svms.RigPoseEstimator.from_files("/nonexistent/x.rig", self.layout_path)


if __name__ == "__main__":
    unittest.main()
