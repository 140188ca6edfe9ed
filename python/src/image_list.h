// A list of images from Python for the functions that take many (the survey, the calibration):
// each a numpy array used in place (image_array.h), detected with the GIL released.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "svms/detect/detector.h"

namespace svms::python {

namespace py = pybind11;

// The images of `images` (any iterable) as Mat headers over their arrays; `keep` holds the
// arrays for as long as the headers are used. TypeError names the item ("images[3]: ...").
std::vector<cv::Mat> MatsFromList(const py::handle& images, std::vector<py::array>* keep);

// Each item's name: names[i] when given (then as many as the images, ValueError otherwise),
// else "image i".
std::vector<std::string> ImageNames(const std::optional<std::vector<std::string>>& names,
                                    size_t count);

// Every image's detections, the GIL released, on up to `threads` threads.
std::vector<std::vector<Detection>> DetectAll(const Detector& detector,
                                              const std::vector<cv::Mat>& images, int threads);

}  // namespace svms::python
