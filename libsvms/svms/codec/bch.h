// The binary BCH code behind the svms44 marker family.
//
// BCH(63,36) with designed distance 11 (corrects t = 5 bit errors), over GF(2^6) with the
// primitive polynomial x^6 + x + 1, shortened to 44 bits: 17 information bits and 27 parity
// bits. Its minimum distance is exactly 11 (see bch_test.cc).
//
// Word layout: bit i of a uint64_t is the coefficient of x^i, i in [0, 44). The code is
// systematic: the 17 information bits are bits 27..43, the 27 parity bits are bits 0..26.
// Bits 44..63 of every word passed in must be zero.
#pragma once

#include <array>
#include <cstdint>

namespace svms {

class Bch44 {
 public:
  static constexpr int kN = 44;       // code length in bits
  static constexpr int kK = 17;       // information bits
  static constexpr int kParity = 27;  // degree of the generator polynomial
  static constexpr int kT = 5;        // guaranteed correctable errors
  static constexpr uint64_t kWordMask = (uint64_t{1} << kN) - 1;
  static constexpr uint32_t kInfoCount = uint32_t{1} << kK;

  // The one instance (tables are built once, thread-safe).
  static const Bch44& Get();

  // The generator polynomial g(x), bit i = coefficient of x^i (degree 27).
  uint64_t generator() const { return generator_; }

  // The codeword whose information bits are `info` (info < 2^17).
  uint64_t Encode(uint32_t info) const;

  // The information bits of a codeword.
  static uint32_t Info(uint64_t codeword) { return static_cast<uint32_t>(codeword >> kParity); }

  // The five independent syndromes S1, S3, S5, S7, S9 of `word`, 6 bits each, packed into
  // bits 0..29. Zero if and only if `word` is a codeword.
  uint32_t Syndrome(uint64_t word) const;

  // Bounded-distance decoding: if a codeword lies within 5 bit flips of `word` (there is at
  // most one), stores it in *codeword and returns the number of flips (0..5). Otherwise
  // returns -1 and leaves *codeword alone. About 0.1 microsecond.
  int Decode(uint64_t word, uint64_t* codeword) const;

 private:
  Bch44();
  uint64_t generator_ = 0;
  std::array<uint8_t, 128> exp_{};         // exp_[i] = alpha^i, i in [0, 126)
  std::array<uint8_t, 64> log_{};          // log_[x] for x != 0
  uint8_t mul_[64][64] = {};               // GF(64) products
  uint8_t chien_powers_[kN][kT + 1] = {};  // alpha^(-i p) for position p, power i
  std::array<std::array<uint32_t, 256>, 6> syndrome_table_{};  // per byte of the word
};

// Number of set bits; the Hamming weight of a word.
inline int Weight(uint64_t word) { return __builtin_popcountll(word); }

}  // namespace svms
