// How the svms44 family's IDs are chosen from the 2^17 codewords of the shortened BCH code.
//
// A marker can be seen in any of four 90-degree rotations, and rotating a marker shifts its
// 44-bit word cyclically by 11 bits. Rotated codewords are generally not codewords, and can lie
// close to other codewords, so IDs are a subset chosen so that every pair (a, b) of IDs and
// every rotation r (except a == b, r == 0) satisfies Hamming(rotate(a, r), b) >= D.
//
// The selection is greedy in order of information word, in phases of decreasing D
// (11, then 10, then 9) until the requested count is reached: the lowest IDs are the ones
// farthest apart, so a user who needs few markers gets the strongest ones. Candidates are
// skipped when they look too much like a plain frame: weight below 11 or above 33 (close to
// the all-black and all-white rings of plain squares in clutter), a side with fewer than 2
// white or 2 black cells, or a run of more than 8 equal cells around the ring.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

namespace svms {

struct IdSelectionOptions {
  int count = 32768;                            // IDs wanted
  std::vector<int> phase_distances{11, 10, 9};  // D of each greedy phase, decreasing
  int min_weight = 11;                          // skip codewords lighter than this
  int max_weight = 33;                          // or heavier than this
  int min_side_each = 2;                        // white and black cells each side must have
  int max_run = 8;                              // longest cyclic run of equal cells
};

// Longest run of equal bits around the 44-bit ring (cyclic).
int LongestRun(uint64_t word);

struct IdSelection {
  std::vector<uint32_t> infos;      // information word of ID i, i in [0, count)
  std::vector<int> phase_first_id;  // first ID selected in each phase
};

// Runs the greedy selection; deterministic. `progress` (may be empty) is called now and then
// with (phase, ids selected so far). Returns fewer IDs than asked if the phases run out.
IdSelection SelectSvms44Ids(const IdSelectionOptions& options,
                            const std::function<void(int, int)>& progress = {});

// Cyclic rotation of a 44-bit word by whole sides: bit i of the result is bit
// (i + 11 * quarter_turns) mod 44 of `word`.
uint64_t RotateWord(uint64_t word, int quarter_turns);

}  // namespace svms
