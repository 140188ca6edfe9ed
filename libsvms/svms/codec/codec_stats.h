// Measured properties of the svms44 family, printed by `svms codec stats --json`.
#pragma once

#include <array>
#include <cstdint>
#include <map>

namespace svms {

struct CodecStats {
  int bits = 0;
  int ids = 0;
  int code_min_distance = 0;      // minimum weight of a nonzero codeword of the BCH code
  int min_distance = 0;           // minimum Hamming distance between two IDs, same orientation
  int rotation_min_distance = 0;  // minimum over ID pairs and rotations (incl. an ID with itself)
  std::map<int, int64_t> rotation_distance_pairs;  // count of (a, b, r) at distances <= D + 2
  // Measured probability that a uniformly random 44-bit word is accepted with correction
  // limit 0..5, from `false_accept_samples` words; and the exact value where the decoding
  // balls are disjoint (limit <= (D - 1) / 2), else -1.
  std::array<double, 6> false_accept{};
  std::array<int64_t, 6> false_accept_hits{};
  std::array<double, 6> false_accept_exact{};
  int64_t false_accept_samples = 0;
  int64_t ambiguous_hits = 0;  // random words rejected as ambiguous (limit 5)
};

// Measures everything above: exhaustive over ID pairs (about 2e9 word comparisons, split over
// `threads`), Monte Carlo over `samples` random words from `seed`.
CodecStats MeasureCodecStats(int64_t samples, uint64_t seed, int threads);

}  // namespace svms
