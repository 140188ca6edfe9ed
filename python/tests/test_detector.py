"""svms.Detector on frames rendered by the simulator: the same numbers as `svms detect` on the
same files, the truth, and images taken from numpy without a copy."""
import glob
import json
import os
import threading
import unittest

import numpy as np

import svms
from svms_test_data import need


def load(path):
    import cv2
    image = cv2.imread(path, cv2.IMREAD_UNCHANGED)
    assert image is not None, path
    return image


class DetectorTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        data = need("SVMS_TEST_DATA")
        cls.dir = os.path.join(data, "range")
        cls.camera = svms.Camera(os.path.join(cls.dir, "true.cameramodel"))
        cls.detector = svms.Detector(cls.camera, os.path.join(cls.dir, "markers.json"))
        cls.images = sorted(glob.glob(os.path.join(cls.dir, "range_*.png")))
        cls.cli = {}
        with open(os.path.join(data, "range_detections.jsonl")) as f:
            for line in f:
                j = json.loads(line)
                cls.cli[os.path.basename(j["image"])] = j.get("detections", [])
        with open(os.path.join(cls.dir, "truth.json")) as f:
            cls.truth = {v["image"]: v for v in json.load(f)["views"]}

    def test_same_numbers_as_svms_detect(self):
        self.assertEqual(len(self.images), 6)
        found = 0
        for path in self.images:
            ours = self.detector.detect(load(path))
            theirs = self.cli[os.path.basename(path)]
            self.assertEqual([d.id for d in ours], [d["id"] for d in theirs], path)
            for d, t in zip(ours, theirs):
                found += 1
                np.testing.assert_array_equal(d.corners, np.array(t["corners"]), path)
                self.assertEqual(d.bit_errors, t["bit_errors"])
                if "corner_sigma" in t:
                    np.testing.assert_array_equal(d.corner_sigma, t["corner_sigma"])
                    # Symmetric, so the JSON's row-major order is the matrix's either way.
                    np.testing.assert_array_equal(d.corner_covariance.ravel(), t["corner_covariance"])
                    np.testing.assert_allclose(np.diag(d.corner_covariance).reshape(4, 2).mean(axis=1),
                                               np.square(d.corner_sigma), rtol=1e-9)
                self.assertEqual(d.tip is None, t["tip"] is None)
                if d.tip is not None:
                    np.testing.assert_array_equal(d.tip, t["tip"])
                self.assertEqual(d.cam_from_marker is None, "cam_from_marker" not in t)
                if d.cam_from_marker is not None:
                    np.testing.assert_array_equal(d.cam_from_marker.rvec, t["cam_from_marker"]["rvec"])
                    np.testing.assert_array_equal(d.cam_from_marker.tvec, t["cam_from_marker"]["tvec"])
                    np.testing.assert_array_equal(d.covariance.ravel(), t["covariance"])
                    self.assertEqual(d.pose_ambiguous, t["pose_ambiguous"])
        self.assertGreaterEqual(found, 6)

    def test_against_the_truth(self):
        checked = 0
        for path in self.images:
            view = self.truth[os.path.basename(path)]
            found = {d.id: d for d in self.detector.detect(load(path))}
            for m in view["markers"]:
                if not m["fully_visible"] or m["side_px"] < 40:
                    continue
                self.assertIn(m["id"], found, f"{path}: marker {m['id']} ({m['side_px']:.0f} px) not found")
                d = found[m["id"]]
                truth = np.array([c["pixel"] for c in m["corners"]])
                self.assertLess(np.abs(d.corners - truth).max(), 0.5, path)
                self.assertEqual(d.corners.shape, (4, 2))
                self.assertEqual(d.covariance.shape, (6, 6))
                t = np.array(m["cam_from_marker"]["tvec"])
                self.assertLess(np.linalg.norm(d.cam_from_marker.tvec - t), 0.01 * np.linalg.norm(t))
                self.assertEqual(d.cam_from_marker.matrix.shape, (4, 4))
                checked += 1
        self.assertGreaterEqual(checked, 4)

    def test_no_copy_of_the_image(self):
        image = load(self.images[1])
        self.assertEqual(svms._svms._image_address(image), image.ctypes.data)
        reference = self.detector.detect(image)
        self.assertTrue(reference)
        # A rectangle of a larger array is used in place (rows 1100 bytes apart): the same
        # detections.
        big = np.zeros((image.shape[0] + 30, image.shape[1] + 76), np.uint8)
        big[10:10 + image.shape[0], 40:40 + image.shape[1]] = image
        view = big[10:10 + image.shape[0], 40:40 + image.shape[1]]
        self.assertFalse(view.flags.c_contiguous)
        self.assertEqual(svms._svms._image_address(view), view.ctypes.data)
        ours = self.detector.detect(view)
        self.assertEqual([d.id for d in ours], [d.id for d in reference])
        for a, b in zip(ours, reference):
            np.testing.assert_array_equal(a.corners, b.corners)
        # A read-only array is fine: the detector only reads.
        image.flags.writeable = False
        self.assertEqual(len(self.detector.detect(image)), len(reference))

    def test_refused_arrays(self):
        image = load(self.images[1])
        plain = svms.Detector()
        for bad, words in [(image.astype(np.float64), "float64"),
                           (image.astype(np.int16), "int16"),
                           (image[:, ::2], "strides"),
                           (image.T, "transposed"),
                           (image[::-1], "flipped"),
                           (image.reshape(-1), "shape"),
                           (np.zeros((4, 4, 2), np.uint8), "(4, 4, 2)"),
                           (image.astype(">u2"), "byte order")]:
            with self.assertRaises(TypeError, msg=words) as e:
                plain.detect(bad)
            self.assertIn(words, str(e.exception))
            self.assertIn("image", str(e.exception))
        with self.assertRaises(ValueError) as e:
            self.detector.detect(image[:100, :100])
        self.assertIn("1024x1024", str(e.exception))

    def test_depths_and_colour(self):
        import cv2
        image = load(self.images[2])
        ids = [d.id for d in self.detector.detect(image)]
        wide = image.astype(np.uint16) * 257
        ours = self.detector.detect(wide)
        self.assertEqual([d.id for d in ours], ids)
        bgr = cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)
        self.assertEqual([d.id for d in self.detector.detect(bgr)], ids)
        # Without a camera: IDs and corners, no poses.
        bare = svms.Detector().detect(image)
        self.assertEqual(sorted(d.id for d in bare), sorted(ids))
        self.assertTrue(all(d.cam_from_marker is None for d in bare))
        # A gamma-encoded copy read back through its response: the same markers.
        encoded = np.round(255 * (image / 255.0) ** (1 / 2.2)).astype(np.uint8)
        gamma = svms.Detector(self.camera, os.path.join(self.dir, "markers.json"), response="gamma:2.2")
        self.assertEqual(sorted(d.id for d in gamma.detect(encoded)), sorted(ids))
        with self.assertRaises(ValueError):
            svms.Detector(response="nosuch")

    def test_threads_share_a_detector(self):
        images = [load(p) for p in self.images[:4]]
        expected = [[d.corners for d in self.detector.detect(im)] for im in images]
        results = [None] * len(images)

        def run(i):
            results[i] = [d.corners for d in self.detector.detect(images[i])]

        threads = [threading.Thread(target=run, args=(i,)) for i in range(len(images))]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        for r, e in zip(results, expected):
            self.assertEqual(len(r), len(e))
            for a, b in zip(r, e):
                np.testing.assert_array_equal(a, b)

    def test_decimate_option(self):
        # Steps 1-4 on 2 x 2 block averages: the range's markers (tens of pixels) found with the
        # same IDs and, from the same full-image corner fit, corners within 0.01 px.
        options = svms.DetectorOptions()
        self.assertEqual(options.decimate, 1)
        for bad in (0, 5):
            with self.assertRaises(ValueError):
                options.decimate = bad
        options.decimate = 2
        coarse = svms.Detector(self.camera, os.path.join(self.dir, "markers.json"), options)
        found = 0
        for path in self.images[:3]:
            image = load(path)
            a = {d.id: d for d in coarse.detect(image)}
            b = {d.id: d for d in self.detector.detect(image)}
            self.assertEqual(sorted(a), sorted(b), path)
            for i in a:
                found += 1
                np.testing.assert_allclose(a[i].corners, b[i].corners, atol=0.01)
        self.assertGreater(found, 0)

    def test_markers_argument(self):
        models = svms.read_markers(os.path.join(self.dir, "markers.json"))
        self.assertTrue(all(isinstance(m, svms.MarkerModel) for m in models))
        image = load(self.images[1])
        a = svms.Detector(self.camera, models).detect(image)
        b = self.detector.detect(image)
        self.assertEqual([d.id for d in a], [d.id for d in b])
        with self.assertRaises(TypeError):
            svms.Detector(self.camera, [1, 2, 3])
        with self.assertRaises(FileNotFoundError):
            svms.Detector(self.camera, "/nonexistent/markers.json")


if __name__ == "__main__":
    unittest.main()
