// Reading the 44 data bits of a marker from an image, given where its plane maps to.
//
// Thresholds are local: each bit cell is compared with the white stripe and the black square
// right next to it (inward, at the same place along the side), so a shadow edge across the
// marker moves both references with the cell. Used by the detector and by the artwork check.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <opencv2/core.hpp>

#include "svms/marker/marker_model.h"

namespace svms {

struct BitReading {
  uint64_t word = 0;  // bit i = 1 where cell i reads white, in the order of svms/codec/svms44.h
  // Per cell: (value - threshold) / (white - black), in about [-0.5, 0.5]; near 0 is unsure.
  std::array<float, 44> margin{};
  double black = 0, white = 0;  // mean levels of the square and the stripe references
  int samples_outside = 0;      // sample points that fell outside the image
  // Cells whose own stripe reference is brighter than their own square reference by at least
  // half of (white - black): 44 on a marker, even with its corners tenths of a pixel off (the
  // references sit mid-stripe and mid-square); fewer on a texture's chance quadrilateral.
  int separated_refs = 0;
  // The smallest |margin| over the cells: how close the weakest bit came to flipping.
  float weakest() const;
};

// `pixel_from_plane` maps marker-plane points (x, y in metres, z = 0) to pixel coordinates
// (pixel (0, 0) is the centre of the top-left pixel): p ~ H [x y 1]^T. `image` is CV_8UC1 or
// CV_16UC1. Each cell, reference and threshold is the mean of 5 bilinear samples.
BitReading SampleBits(const cv::Mat& image, const Eigen::Matrix3d& pixel_from_plane,
                      const MarkerModel& model);

}  // namespace svms
