// The svms44 marker family: 32,768 IDs, each a codeword of the shortened BCH(44,17) code.
//
// Bit order on the marker (docs/markers.md): bit i sits on side i / 11 (0 top, 1 right,
// 2 bottom, 3 left, as printed) at place i % 11, clockwise from the top-left corner. White is 1.
// Turning the marker by a quarter turn shifts the word by 11 bits, so every ID is chosen to
// stay at least 9 bits from every rotation of every other ID and of itself
// (svms/codec/id_selection.h): with minimum-distance decoding over the four rotations, every
// pattern of up to 4 flipped bits resolves ID and rotation; 5 flips are always corrected in the
// true orientation, and are reported as ambiguous where another (ID, rotation) is just as close.
#pragma once

#include <cstdint>
#include <string>

namespace svms {

// What the decoder concluded about one 44-bit word.
struct CodeMatch {
  enum class Verdict {
    kAccepted,    // id, rotation, bit_errors are valid
    kNoCodeword,  // no (ID, rotation) within max_corrections flips
    kAmbiguous,   // two (ID, rotation) pairs are equally close: never guessed
  };
  Verdict verdict = Verdict::kNoCodeword;
  int id = -1;
  // The word was read starting at marker corner `rotation` (0 top-left, 1 top-right,
  // 2 bottom-right, 3 bottom-left, as printed) and going clockwise: read = Rotate(code, rotation).
  int rotation = 0;
  int bit_errors = -1;        // flipped bits corrected, 0..5
  int runner_up_errors = -1;  // flips to the next-closest (ID, rotation), or -1 if none within 5
  bool accepted() const { return verdict == Verdict::kAccepted; }
};

class Svms44 {
 public:
  static constexpr const char* kFamily = "svms44";
  static constexpr int kBits = 44;
  static constexpr int kBitsPerSide = 11;
  static constexpr int kNumIds = 32768;
  static constexpr int kRotationDistance = 9;  // guaranteed by the table (tested)
  static constexpr int kMaxCorrections = 5;

  // The 44-bit word of `id` in the printed orientation (read from the top-left corner).
  // Requires 0 <= id < kNumIds.
  static uint64_t Codeword(int id);

  // Bit i of the result is bit (i + 11 * quarter_turns) mod 44 of `word`.
  static uint64_t Rotate(uint64_t word, int quarter_turns);

  // Minimum-distance decoding over the IDs [0, id_count) and the four rotations, accepting at
  // most `max_corrections` (0..5) flipped bits. Never guesses between equally close answers.
  // With id_count <= StrongIdCount() the IDs are 11 apart across rotations, and every pattern
  // of up to 5 flips resolves ID and rotation. Thread-safe; about 0.6 microsecond.
  static CodeMatch Decode(uint64_t word, int max_corrections = kMaxCorrections,
                          int id_count = kNumIds);

  // The number of leading IDs chosen at rotation-aware distance 11 (the strong subset).
  static int StrongIdCount();

  // The ID whose codeword has these information bits, or -1.
  static int IdOfInfo(uint32_t info);

  // The 44 bits as a string of '0'/'1', bit 0 first; and back (false on a malformed string).
  static std::string ToBitString(uint64_t word);
  static bool FromBitString(const std::string& bits, uint64_t* word);
};

// The generated table (svms44_table.cc).
extern const uint32_t kSvms44Info[Svms44::kNumIds];
extern const int kSvms44PhaseCount;
extern const int kSvms44PhaseDistance[];
extern const int kSvms44PhaseFirstId[];

}  // namespace svms
