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
