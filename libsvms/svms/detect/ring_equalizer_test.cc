#include "svms/detect/ring_equalizer.h"

#include <gtest/gtest.h>

#include <limits>
#include <random>

#include "svms/codec/bch.h"
#include "svms/codec/svms44.h"

namespace svms {
namespace {

// Bit i of a ring's word, i taken modulo 44. (The test's own, like SumOfSquares below: the
// model is checked against code other than the one that fits it.)
int Bit(uint64_t word, int i) {
  return static_cast<int>((word >> ((i + Svms44::kBits) % Svms44::kBits)) & 1);
}
bool IsCorner(int i) { return i % Svms44::kBitsPerSide == 0; }

// A ring's margins under the equaliser's model (RingEqualization's fields) plus Gaussian noise.
struct RingModel {
  double offset = 0, gain = 0, leak = 0, corner_offset = 0, corner_gain = 0;
};

// A reading of `word` whose margins follow `model` plus Gaussian noise; the plain word is what a
// threshold at 0 reads.
BitReading LeakyReading(uint64_t word, const RingModel& model, double noise, std::mt19937* rng) {
  std::normal_distribution<double> g(0, noise);
  BitReading r;
  for (int i = 0; i < Svms44::kBits; ++i) {
    double v = model.offset + model.gain * Bit(word, i) +
               model.leak * (Bit(word, i - 1) + Bit(word, i + 1)) + g(*rng);
    if (IsCorner(i)) v += model.corner_offset + model.corner_gain * Bit(word, i);
    r.margin[i] = static_cast<float>(v);
    if (r.margin[i] > 0) r.word |= uint64_t{1} << i;
  }
  return r;
}

double SumOfSquares(const BitReading& r, uint64_t word, const RingEqualization& m) {
  double ss = 0;
  for (int i = 0; i < Svms44::kBits; ++i) {
    double e = r.margin[i] - m.offset - m.gain * Bit(word, i) -
               m.leak * (Bit(word, i - 1) + Bit(word, i + 1));
    if (IsCorner(i)) e -= m.corner_offset + m.corner_gain * Bit(word, i);
    ss += e * e;
  }
  return ss;
}

// The model's numbers near those measured on 8-10 px markers behind 0.7 px of blur and JPEG
// (mean margins by a cell's bit and its white neighbours: black -0.40 / -0.28 / -0.12, white
// -0.06 / 0.10 / 0.28): the whole ring reads dark, and a white cell between black ones reads
// below the threshold. The corner cells are given terms of their own. A threshold at 0 flips
// several bits of most rings; the equalised reading is the codeword, and the model is found.
TEST(EqualizeRing, ReadsARingWhoseCellsTakeFromTheirNeighbours) {
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> id(0, Svms44::kNumIds - 1);
  RingModel truth;
  truth.offset = -0.40, truth.gain = 0.34, truth.leak = 0.14;
  truth.corner_offset = 0.08, truth.corner_gain = -0.06;
  int plain_over_two = 0, equalised_right = 0, settled = 0;
  const int trials = 400;
  for (int t = 0; t < trials; ++t) {
    const uint64_t code = Svms44::Codeword(id(rng));
    const BitReading r = LeakyReading(code, truth, 0.03, &rng);
    plain_over_two += Weight(r.word ^ code) > 2;
    const RingEqualization eq = EqualizeRing(r);
    ASSERT_TRUE(eq.ok) << "trial " << t;
    equalised_right += eq.word == code;
    if (eq.word == code) {
      settled += eq.settled;  // else found in the last round allowed, not searched again
      EXPECT_NEAR(eq.gain, truth.gain, 0.05);
      EXPECT_NEAR(eq.leak, truth.leak, 0.03);
      EXPECT_NEAR(eq.offset, truth.offset, 0.05);
      // The corner terms rest on four cells each (standard error about 0.03-0.04 here).
      EXPECT_NEAR(eq.corner_offset, truth.corner_offset, 0.15);
      EXPECT_NEAR(eq.corner_gain, truth.corner_gain, 0.2);
      EXPECT_NEAR(eq.residual_rms, 0.03, 0.012);
      EXPECT_NEAR(eq.sum_of_squares, SumOfSquares(r, eq.word, eq), 1e-9);
    }
  }
  RecordProperty("plain_over_two", plain_over_two);
  RecordProperty("equalised_right", equalised_right);
  EXPECT_GT(plain_over_two, trials / 2);  // the scene shows what the equaliser is for
  EXPECT_GE(equalised_right, trials - 4);
  EXPECT_GE(settled, equalised_right * 9 / 10);
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
    RingModel model;
    model.offset = -0.1, model.gain = 0.4, model.leak = 0.12;
    const BitReading r = LeakyReading(code, model, 0.12, &rng);
    const RingEqualization eq = EqualizeRing(r, options);
    if (!eq.ok) continue;
    // Converged: one more search under the reported model gives the same word.
    RingEqualizerOptions once = options;
    once.rounds = 1;
    once.quantile_starts = 0;
    BitReading again = r;
    again.word = eq.word;
    if (!eq.settled) continue;
    EXPECT_EQ(EqualizeRing(again, once).word, eq.word);
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
// is as random as the plain one. Each decodes (within 5 corrections, any ID and rotation) about
// as often as a random word does (1.24e6 words within 5 flips of each of 131,072: 0.9 %), and
// the detector's risk, that either reading decodes, at most about twice that.
TEST(EqualizeRing, NoiseReadsAsNoMoreLikeACodewordThanItsPlainReading) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-0.5, 0.5);
  int ok = 0, plain = 0, equalised = 0, either = 0, plain_close = 0, either_close = 0;
  const int trials = 20000;
  for (int t = 0; t < trials; ++t) {
    BitReading r;
    for (int i = 0; i < Svms44::kBits; ++i) {
      r.margin[i] = static_cast<float>(u(rng));
      if (r.margin[i] > 0) r.word |= uint64_t{1} << i;
    }
    const CodeMatch p = Svms44::Decode(r.word);
    const RingEqualization eq = EqualizeRing(r);
    ok += eq.ok;
    const CodeMatch e = eq.ok ? Svms44::Decode(eq.word) : CodeMatch{};
    plain += p.accepted();
    equalised += e.accepted();
    either += p.accepted() || e.accepted();
    plain_close += p.accepted() && p.bit_errors <= 4;
    either_close += (p.accepted() && p.bit_errors <= 4) || (e.accepted() && e.bit_errors <= 4);
  }
  RecordProperty("plain_decodes", plain);
  RecordProperty("equalised_decodes", equalised);
  EXPECT_GT(ok, trials * 9 / 10);  // the equaliser reads noise too: the test is not vacuous
  EXPECT_GT(plain, 60);            // about 180 expected
  EXPECT_LT(plain, 400);
  EXPECT_LT(equalised, 1.3 * plain + 20);
  EXPECT_LT(either, 2.3 * plain + 20);
  EXPECT_LT(either_close, 2.3 * plain_close + 10);
}

TEST(EqualizeRing, AUniformRingHasNoModel) {
  BitReading white;
  white.margin.fill(0.3f);
  white.word = (uint64_t{1} << 44) - 1;
  EXPECT_FALSE(EqualizeRing(white).ok);
  BitReading black;
  black.margin.fill(-0.3f);
  EXPECT_FALSE(EqualizeRing(black).ok);
  // Period 4 (0011...): every cell has one white neighbour, and the leak cannot be told from
  // the offset.
  BitReading periodic;
  for (int i = 0; i < Svms44::kBits; ++i) {
    const bool white = (i / 2) % 2 == 1;
    periodic.margin[i] = white ? 0.3f : -0.3f;
    if (white) periodic.word |= uint64_t{1} << i;
  }
  EXPECT_FALSE(EqualizeRing(periodic).ok);
  BitReading nan;
  nan.margin.fill(std::numeric_limits<float>::quiet_NaN());
  EXPECT_FALSE(EqualizeRing(nan).ok);
}

}  // namespace
}  // namespace svms
