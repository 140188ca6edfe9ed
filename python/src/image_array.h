// Images from numpy without copying: a cv::Mat header over the array's own pixels.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <opencv2/core.hpp>

namespace svms::python {

namespace py = pybind11;

// A cv::Mat that shares `image`'s memory (no copy): CV_8UC1 / CV_16UC1 for a 2-D uint8 / uint16
// array of H x W pixels, CV_8UC3 / CV_16UC3 for H x W x 3 (BGR, OpenCV's order). The pixels of a
// row must be adjacent in memory (a C-contiguous array, or a view of one that takes whole rows
// or a rectangle of it: rows may be any whole number of elements apart); anything else (a
// transposed or column-strided view, another dtype or shape, a non-native byte order) raises
// TypeError naming `what`, its dtype, shape and strides. The Mat is valid while `image` lives;
// the caller keeps a reference to it for as long as the Mat is used.
cv::Mat MatFromArray(const py::array& image, const char* what = "image");

}  // namespace svms::python
