#include "svms/detect/ring_equalizer.h"

#include <gtest/gtest.h>

#include <limits>
#include <random>

#include "svms/codec/svms44.h"

namespace svms {
namespace {

int Bit(uint64_t word, int i) { return static_cast<int>((word >> ((i + 44) % 44)) & 1); }

// A reading of `word` whose margins follow the equaliser's model plus Gaussian noise; the plain
// word is what a threshold at 0 reads.
BitReading LeakyReading(uint64_t word, double offset, double gain, double leak, double noise,
                        std::mt19937* rng) {
  std::normal_distribution<double> g(0, noise);
  BitReading r;
  for (int i = 0; i < 44; ++i) {
    r.margin[i] = static_cast<float>(offset + gain * Bit(word, i) +
                                     leak * (Bit(word, i - 1) + Bit(word, i + 1)) + g(*rng));
    if (r.margin[i] > 0) r.word |= uint64_t{1} << i;
  }
  return r;
}

double SumOfSquares(const BitReading& r, uint64_t word, const RingEqualization& m) {
  double ss = 0;
  for (int i = 0; i < 44; ++i) {
    double e = r.margin[i] - m.offset - m.gain * Bit(word, i) -
               m.leak * (Bit(word, i - 1) + Bit(word, i + 1));
    if (i % 11 == 0) e -= m.corner_offset + m.corner_gain * Bit(word, i);
    ss += e * e;
  }
  return ss;
}

// The model's numbers as measured on 8-10 px markers behind 0.7 px of blur and JPEG (gain 0.41,
// leak / gain 0.34, the ring darker than the threshold): a threshold at the middle flips
// several bits of most rings; the equalised reading is the codeword, and the model is found.
TEST(EqualizeRing, ReadsARingWhoseCellsTakeFromTheirNeighbours) {
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> id(0, Svms44::kNumIds - 1);
  int plain_flipped = 0, plain_over_two = 0, equalised_right = 0;
  const int trials = 400;
  for (int t = 0; t < trials; ++t) {
    const uint64_t code = Svms44::Codeword(id(rng));
    const BitReading r = LeakyReading(code, -0.25, 0.41, 0.14, 0.03, &rng);
    const int flips = __builtin_popcountll(r.word ^ code);
    plain_flipped += flips > 0;
    plain_over_two += flips > 2;
    const RingEqualization eq = EqualizeRing(r);
    ASSERT_TRUE(eq.ok) << "trial " << t;
    equalised_right += eq.word == code;
    if (eq.word == code) {
      EXPECT_NEAR(eq.gain, 0.41, 0.05);
      EXPECT_NEAR(eq.leak, 0.14, 0.03);
      EXPECT_NEAR(eq.offset, -0.25, 0.05);
      // The corner terms rest on four cells each (standard error about 0.03-0.04 here).
      EXPECT_NEAR(eq.corner_offset, 0, 0.15);
      EXPECT_NEAR(eq.corner_gain, 0, 0.2);
      EXPECT_NEAR(eq.residual_rms, 0.03, 0.012);
      EXPECT_NEAR(eq.sum_of_squares, SumOfSquares(r, eq.word, eq), 1e-9);
    }
  }
  RecordProperty("plain_flipped", plain_flipped);
  RecordProperty("plain_over_two", plain_over_two);
  RecordProperty("equalised_right", equalised_right);
  EXPECT_GT(plain_over_two, trials / 2);  // the scene shows what the equaliser is for
  EXPECT_GE(equalised_right, trials - 4);
}

// Where it has converged, the reading is the least-squares ring under the model it reports:
// no word one or two flips away, nor the codeword the margins were drawn from, fits better.
TEST(EqualizeRing, NoNearbyRingFitsTheMarginsBetter) {
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> id(0, Svms44::kNumIds - 1);
  RingEqualizerOptions options;
  options.rounds = 20;
  int checked = 0;
  for (int t = 0; t < 60; ++t) {
    const uint64_t code = Svms44::Codeword(id(rng));
    const BitReading r = LeakyReading(code, -0.1, 0.4, 0.12, 0.12, &rng);
    const RingEqualization eq = EqualizeRing(r, options);
    if (!eq.ok) continue;
    // Converged: one more search under the reported model gives the same word.
    RingEqualizerOptions once = options;
    once.rounds = 1;
    once.quantile_starts = 0;
    BitReading again = r;
    again.word = eq.word;
    if (EqualizeRing(again, once).word != eq.word) continue;
    ++checked;
    const double best = SumOfSquares(r, eq.word, eq);
    EXPECT_LE(best, SumOfSquares(r, code, eq) + 1e-9);
    for (int i = 0; i < 44; ++i) {
      for (int j = i; j < 44; ++j) {
        const uint64_t other = eq.word ^ (uint64_t{1} << i) ^ (j == i ? 0 : uint64_t{1} << j);
        EXPECT_LE(best, SumOfSquares(r, other, eq) + 1e-9) << "flips " << i << ", " << j;
      }
    }
  }
  EXPECT_GE(checked, 40);
}

// A quadrilateral of texture: its cells are no ring of bits, and the equalised reading of them
// is as random as the plain one. Both decode (within 5 corrections, any ID and rotation) about
// as often as a random word does (1.24e6 words within 5 flips of each of 131,072: 0.9 %).
TEST(EqualizeRing, NoiseReadsAsNoMoreLikeACodewordThanItsPlainReading) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-0.5, 0.5);
  int plain = 0, equalised = 0, equalised_close = 0, plain_close = 0;
  const int trials = 20000;
  for (int t = 0; t < trials; ++t) {
    BitReading r;
    for (int i = 0; i < 44; ++i) {
      r.margin[i] = static_cast<float>(u(rng));
      if (r.margin[i] > 0) r.word |= uint64_t{1} << i;
    }
    const CodeMatch p = Svms44::Decode(r.word);
    plain += p.accepted();
    plain_close += p.accepted() && p.bit_errors <= 4;
    const RingEqualization eq = EqualizeRing(r);
    if (!eq.ok) continue;
    const CodeMatch e = Svms44::Decode(eq.word);
    equalised += e.accepted();
    equalised_close += e.accepted() && e.bit_errors <= 4;
  }
  RecordProperty("plain_decodes", plain);
  RecordProperty("equalised_decodes", equalised);
  EXPECT_GT(plain, 60);  // about 180 expected
  EXPECT_LT(plain, 400);
  EXPECT_LT(equalised, 1.3 * plain + 20);
  EXPECT_LT(equalised_close, 1.3 * plain_close + 10);
}

TEST(EqualizeRing, AUniformRingHasNoModel) {
  BitReading white;
  white.margin.fill(0.3f);
  white.word = (uint64_t{1} << 44) - 1;
  EXPECT_FALSE(EqualizeRing(white).ok);
  BitReading black;
  black.margin.fill(-0.3f);
  EXPECT_FALSE(EqualizeRing(black).ok);
  BitReading nan;
  nan.margin.fill(std::numeric_limits<float>::quiet_NaN());
  EXPECT_FALSE(EqualizeRing(nan).ok);
}

}  // namespace
}  // namespace svms
