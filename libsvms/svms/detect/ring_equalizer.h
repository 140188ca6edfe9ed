// Reading a small marker's bit ring through a blur (detector step 7c).
//
// The 44 bit cells of a marker's ring (svms/codec/svms44.h: bit i + 1 is the next cell
// clockwise, and bit 43 is next to bit 0) are read by SampleBits against a threshold half-way
// between the white stripe and the black square beside each cell. On a marker of 8-12 px a cell
// is 1.3-2 px wide, and the pixels' own area and any lens blur mix each cell with its two
// neighbours along the ring: a white cell between two black ones reads darker than the
// threshold, a black one between two whites lighter (inter-symbol interference). The ring as a
// whole also reads darker or lighter than the threshold says, where the blur reaches the
// background beyond the one-cell quiet zone. Read at their true corners, the small set's 8-12 px
// markers behind 0.7 px of blur and JPEG (`svms dataset small --profile jpeg_srgb`, seed 1: 209
// markers) are 132 within two flips of their codeword and 77 three or more flips away;
// equalised as below, 205 and 4. (These counts, and the ones below, come from a scratch probe that
// samples SampleBits at the truth's corners; no command in the repository prints them. What
// `svms bench profiles` prints is the detector's: docs/benchmarks.md.)
//
// The reading is therefore modelled per marker, from its own 44 cells: each cell's margin
// (BitReading::margin) is offset + gain s_i + leak (s_{i-1} + s_{i+1}) plus noise, s in
// {0, 1}, and the four corner cells (bits 0, 11, 22, 33), which have the quiet zone on two
// sides, get an offset and a gain of their own. The model is fitted by least squares on a
// reading, and the reading is then the ring's most likely sequence under it (a Viterbi search
// over pairs of neighbouring bits, once for each pair the cycle starts from), until it settles.
// A reading far from the model (the plain threshold on a ring that reads mostly dark) can
// settle on a wrong fit, so this is started from the plain reading and from thresholds at five
// quantiles of the margins, and the settled reading with the least squared residuals is kept.
// Nothing is fitted to a dataset: the numbers come from the marker's cells each time. With a
// single start the 8-9 px markers among those (53, at their true corners) are 24 within two
// flips; with the five quantiles, 50. The reading depends on where the corners are: on
// corners 3 % too small, 42 of the 53 are within two flips.
//
// The equalised reading is a second reading of the quad, not a test that it is a marker: a
// texture's quadrilateral gives a word as random as its plain reading (tested), so a second
// reading at most doubles the chance that a texture's quad decodes (7e-6 per reading within
// two corrections: 131,072 words of ID and rotation, 991 words within two flips of each, among
// 2^44). The detector reads a quad again this way only where its plain reading is weak and it
// has been read again on refined corners (step 7b; DetectorOptions::equalize_rings).
#pragma once

#include <cstdint>

#include "svms/detect/bit_sampler.h"

namespace svms {

struct RingEqualizerOptions {
  static constexpr int kMaxStarts = 8;
  // Searches after the first fit, each followed by a fit to the reading it gives; fewer where
  // the reading settles (RingEqualization::settled).
  int rounds = 4;
  // Starting readings besides the plain one: thresholds at this many quantiles of the margins
  // (capped at kMaxStarts), evenly from 0.3 to 0.7.
  int quantile_starts = 5;
};

struct RingEqualization {
  uint64_t word = 0;  // the equalised reading, bit order of BitReading::word
  // The model, in BitReading::margin units: offset + gain s_i + leak (s_{i-1} + s_{i+1}), plus
  // corner_offset + corner_gain s_i on the corner cells (corner_gain 0 where all four corners
  // read alike).
  double offset = 0, gain = 0, leak = 0, corner_offset = 0, corner_gain = 0;
  double sum_of_squares = 0;  // of the margins about the model
  double residual_rms = 0;    // the same per degree of freedom, square-rooted
  // The model could be fitted and has white reading whiter than black, on the corners too:
  // word is meaningful.
  bool ok = false;
  // The search under the model gives `word` back (false: `rounds` ran out, or the next reading's
  // fit failed; word is the last reading the model was fitted to).
  bool settled = false;
};

// The ring of `reading` read with its inter-symbol interference modelled (see above). Where no
// starting reading gives a model that can be fitted (all cells alike, collinear regressors) and
// gives white more light than black, ok is false. Some tens of microseconds.
RingEqualization EqualizeRing(const BitReading& reading, const RingEqualizerOptions& options = {});

}  // namespace svms
