// A calibration board: a rectangular grid of flat SVMS markers printed on one plane. A board is
// just a Layout (layout.h): the board frame is the object frame, origin at the centre of the
// grid, x to the right and y up as printed, z out of the board; every marker lies at z = 0 with
// its own axes parallel to the board's. Any other (surveyed) layout serves as a calibration
// object too; nothing in calib/ requires a grid.
#pragma once

#include <string>

#include "svms/base/status.h"
#include "svms/marker/layout.h"

namespace svms {

struct BoardSpec {
  int rows = 0, cols = 0;  // markers down and across
  double size = 0;         // side of each black square, metres (the whole marker is 2 * size)
  double gap = 0;          // white space between neighbouring markers' outer edges, metres
  int first_id = 0;        // the marker in row r, column c has ID first_id + r * cols + c
  // rows, cols >= 1, size > 0, gap >= 0, every ID in [0, 32768). Errors name the option
  // ("--rows", "--size", ...) and the value.
  Status Validate() const;
  // Centre-to-centre distance of neighbouring markers: 2 * size + gap (metres).
  double pitch() const { return 2 * size + gap; }
};

// The board's layout: row 0 at the top (largest y), column 0 at the left; marker centres at
// ((c - (cols - 1) / 2) * pitch, ((rows - 1) / 2 - r) * pitch, 0). Flat standard markers (no
// post). Named "calibration board COLSxROWS, SIZE m". Requires spec.Validate().
Layout MakeBoardLayout(const BoardSpec& spec);

}  // namespace svms
