"""svms.marker_image: the artwork `svms generate marker` prints, as an array, that the detector
reads back."""
import os
import subprocess
import tempfile
import unittest

import numpy as np

import svms
from svms_test_data import need


class ArtworkTest(unittest.TestCase):
    def test_same_as_the_png_of_svms_generate(self):
        import cv2
        binary = need("SVMS_BINARY")
        with tempfile.TemporaryDirectory() as d:
            subprocess.run([binary, "generate", "marker", "--id", "17", "--size", "0.2",
                            "--post-height", "0.05", "--dpi", "100", "--out", f"{d}/m"],
                           check=True, capture_output=True)
            png = cv2.imread(f"{d}/m.png", cv2.IMREAD_GRAYSCALE)
            model = svms.read_markers(f"{d}/m.json")[0]
        image = svms.marker_image(model, dpi=100)
        self.assertEqual(image.dtype, np.uint8)
        self.assertEqual(image.shape, png.shape)
        # The marker and its quiet zone are the same pixels. (The label's glyphs may differ in
        # their antialiasing: cairo's glyph cache, warmed by the PDF the command draws first.)
        h, w = image.shape
        half = int(np.ceil((model.half_extent + model.cell_size) * 100 / 0.0254)) + 2
        cy, cx = (h - 1) // 2, (w - 1) // 2
        np.testing.assert_array_equal(image[cy - half:cy + half, cx - half:cx + half],
                                      png[cy - half:cy + half, cx - half:cx + half])

    def test_the_detector_reads_it_back(self):
        for model in [svms.MarkerModel.standard(17, 0.2, 0.05), self.dual()]:
            image = svms.marker_image(model, dpi=60, label=False)
            h, w = image.shape
            found = {d.id: d for d in svms.Detector().detect(image)}
            self.assertIn(model.id, found)
            H = svms.artwork_pixel_from_plane(w, h, 60)
            corners = model.corners[:, :2]
            p = (H @ np.c_[corners, np.ones(4)].T).T
            expected = p[:, :2] / p[:, 2:]
            self.assertLess(np.abs(found[model.id].corners - expected).max(), 0.5)
            if model.inner is not None:
                self.assertIn(model.inner.id, found)

    def dual(self):
        m = svms.MarkerModel.standard(3, 0.432, 0.1)
        m.add_inner(4, 0.108)
        return m

    def test_bad_model(self):
        m = svms.MarkerModel.standard(17, 0.2, 0.05)
        m.size = -1
        with self.assertRaises(ValueError) as e:
            svms.marker_image(m)
        self.assertIn("size", str(e.exception))
        with self.assertRaises(ValueError):
            svms.marker_image(svms.MarkerModel.standard(17, 0.2, 0.05), dpi=0)


if __name__ == "__main__":
    unittest.main()
