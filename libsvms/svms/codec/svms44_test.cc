#include "svms/codec/svms44.h"

#include <gtest/gtest.h>

#include <random>

#include "svms/codec/bch.h"
#include "svms/codec/codec_stats.h"
#include "svms/codec/id_selection.h"

namespace svms {
namespace {

std::vector<uint64_t> FlipPatterns(int max_flips) {
  std::vector<uint64_t> out{0};
  for (int a = 0; a < 44 && max_flips >= 1; ++a) {
    const uint64_t ea = uint64_t{1} << a;
    out.push_back(ea);
    for (int b = a + 1; b < 44 && max_flips >= 2; ++b) {
      const uint64_t eb = ea | uint64_t{1} << b;
      out.push_back(eb);
      for (int c = b + 1; c < 44 && max_flips >= 3; ++c) {
        const uint64_t ec = eb | uint64_t{1} << c;
        out.push_back(ec);
        for (int d = c + 1; d < 44 && max_flips >= 4; ++d) out.push_back(ec | uint64_t{1} << d);
      }
    }
  }
  return out;
}

TEST(Svms44, RotationIsACyclicShiftBySides) {
  const uint64_t w = 0x123456789abULL;
  EXPECT_EQ(Svms44::Rotate(w, 0), w);
  EXPECT_EQ(Svms44::Rotate(Svms44::Rotate(w, 1), 3), w);
  EXPECT_EQ(Svms44::Rotate(w, 4), w);
  // Bit 11 (first bit of the right side) becomes bit 0 after one quarter turn.
  EXPECT_EQ(Svms44::Rotate(uint64_t{1} << 11, 1), 1u);
  EXPECT_EQ(Svms44::Rotate(1, 1), uint64_t{1} << 33);
}

TEST(Svms44, BitStringRoundTripsAndRejectsJunk) {
  const uint64_t w = Svms44::Codeword(12345);
  uint64_t back = 0;
  ASSERT_TRUE(Svms44::FromBitString(Svms44::ToBitString(w), &back));
  EXPECT_EQ(back, w);
  EXPECT_FALSE(Svms44::FromBitString("0101", &back));
  EXPECT_FALSE(Svms44::FromBitString(std::string(43, '0') + "2", &back));
}

TEST(Svms44, IdsAreDistinctCodewordsWithTheTabulatedInfo) {
  std::vector<uint8_t> seen(Bch44::kInfoCount, 0);
  for (int id = 0; id < Svms44::kNumIds; ++id) {
    ASSERT_LT(kSvms44Info[id], Bch44::kInfoCount);
    ASSERT_FALSE(seen[kSvms44Info[id]]) << "duplicate info at ID " << id;
    seen[kSvms44Info[id]] = 1;
    ASSERT_EQ(Svms44::IdOfInfo(kSvms44Info[id]), id);
    ASSERT_EQ(Bch44::Get().Syndrome(Svms44::Codeword(id)), 0u);
  }
}

TEST(Svms44, EveryIdRoundTripsInAllFourRotations) {
  for (int id = 0; id < Svms44::kNumIds; ++id) {
    for (int r = 0; r < 4; ++r) {
      const CodeMatch m = Svms44::Decode(Svms44::Rotate(Svms44::Codeword(id), r), 0);
      ASSERT_TRUE(m.accepted()) << id << " r" << r;
      ASSERT_EQ(m.id, id);
      ASSERT_EQ(m.rotation, r);
      ASSERT_EQ(m.bit_errors, 0);
    }
  }
}

// Every ID, every pattern of up to 2 flips, in one rotation per test (4 tests, run in parallel
// by ctest): 32,768 x 991 decodes each.
class EveryIdTwoFlips : public ::testing::TestWithParam<int> {};
TEST_P(EveryIdTwoFlips, DecodesRight) {
  const int r = GetParam();
  const std::vector<uint64_t> patterns = FlipPatterns(2);
  ASSERT_EQ(patterns.size(), 991u);
  for (int id = 0; id < Svms44::kNumIds; ++id) {
    const uint64_t read = Svms44::Rotate(Svms44::Codeword(id), r);
    for (uint64_t e : patterns) {
      const CodeMatch m = Svms44::Decode(read ^ e, 2);
      ASSERT_TRUE(m.accepted() && m.id == id && m.rotation == r && m.bit_errors == Weight(e))
          << "id " << id << " rotation " << r << " flips " << Svms44::ToBitString(e);
    }
  }
}
INSTANTIATE_TEST_SUITE_P(Rotations, EveryIdTwoFlips, ::testing::Values(0, 1, 2, 3));

// 100 IDs spread over the table, every pattern of up to (D - 1) / 2 = 4 flips, all rotations.
class SampleFourFlips : public ::testing::TestWithParam<int> {};
TEST_P(SampleFourFlips, DecodesRight) {
  constexpr int kGuaranteed = (Svms44::kRotationDistance - 1) / 2;
  static_assert(kGuaranteed == 4);
  const std::vector<uint64_t> patterns = FlipPatterns(kGuaranteed);
  ASSERT_EQ(patterns.size(), 149986u);
  const int r = GetParam();
  for (int k = 0; k < 100; ++k) {
    const int id = (k * 2654435761u) % Svms44::kNumIds;
    const uint64_t read = Svms44::Rotate(Svms44::Codeword(id), r);
    for (uint64_t e : patterns) {
      const CodeMatch m = Svms44::Decode(read ^ e, kGuaranteed);
      ASSERT_TRUE(m.accepted() && m.id == id && m.rotation == r)
          << "id " << id << " rotation " << r << " flips " << Svms44::ToBitString(e);
    }
  }
}
INSTANTIATE_TEST_SUITE_P(Rotations, SampleFourFlips, ::testing::Values(0, 1, 2, 3));

TEST(Svms44, CorrectionLimitIsHonoured) {
  const uint64_t c = Svms44::Codeword(77);
  const uint64_t three = c ^ 0b10101ULL << 20;
  EXPECT_EQ(Svms44::Decode(three, 3).bit_errors, 3);
  EXPECT_FALSE(Svms44::Decode(three, 2).accepted());
  EXPECT_EQ(Svms44::Decode(three, 2).verdict, CodeMatch::Verdict::kNoCodeword);
  EXPECT_FALSE(Svms44::Decode(c ^ 1, 0).accepted());
}

// 5 flips in the true orientation: the BCH distance (11) always corrects them within one
// rotation, but another (ID, rotation) may be as close (D = 9 across rotations). Over the
// strong subset (the first IDs, chosen at D >= 11) no wrong answer is possible; over the full
// family the wrong-answer rate is measured and bounded.
TEST(Svms44, FiveFlipsWrongAnswerRate) {
  std::mt19937_64 rng(2026);
  const int kTrials = 200000;
  int right = 0, wrong = 0, ambiguous = 0, strong_wrong = 0, strong_trials = 0;
  for (int t = 0; t < kTrials; ++t) {
    const int id = rng() % Svms44::kNumIds;
    const int r = rng() % 4;
    uint64_t e = 0;
    while (Weight(e) < 5) e |= uint64_t{1} << (rng() % 44);
    const CodeMatch m = Svms44::Decode(Svms44::Rotate(Svms44::Codeword(id), r) ^ e, 5);
    if (m.accepted() && m.id == id && m.rotation == r) {
      ++right;
    } else if (m.accepted()) {
      ++wrong;
    } else {
      ASSERT_EQ(m.verdict, CodeMatch::Verdict::kAmbiguous);
      ++ambiguous;
    }
    if (id < kSvms44PhaseFirstId[1]) {
      ++strong_trials;
      if (m.accepted() && m.id != id) {
        // Only an ID outside the strong subset may be closer; decoding over the subset only
        // would never be wrong (checked in StrongSubsetHasDistance11).
        ASSERT_GE(m.id, kSvms44PhaseFirstId[1]);
        ++strong_wrong;
      }
    }
  }
  const double wrong_rate = static_cast<double>(wrong) / kTrials;
  RecordProperty("five_flip_wrong_rate", std::to_string(wrong_rate));
  RecordProperty("five_flip_ambiguous_rate", std::to_string(double(ambiguous) / kTrials));
  std::printf("5 flips: right %d, wrong %d (%.2e), ambiguous %d of %d\n", right, wrong, wrong_rate,
              ambiguous, kTrials);
  EXPECT_GT(right, kTrials * 0.99);
  EXPECT_LT(wrong_rate, 2e-3);
  EXPECT_GT(strong_trials, 0);
}

// Within the strong subset, decoding over the subset only: every 5-flip pattern (all
// C(44,5) = 1,086,008 of them) of three IDs, in a rotation each, resolves right.
TEST(Svms44, StrongSubsetCorrectsEveryFiveFlipPattern) {
  const int strong = Svms44::StrongIdCount();
  ASSERT_GT(strong, 7000);
  int64_t checked = 0;
  for (int k = 0; k < 3; ++k) {
    const int id = (k * 3001 + 5) % strong, r = k + 1;
    const uint64_t read = Svms44::Rotate(Svms44::Codeword(id), r);
    for (int a = 0; a < 44; ++a)
      for (int b = a + 1; b < 44; ++b)
        for (int c = b + 1; c < 44; ++c)
          for (int d = c + 1; d < 44; ++d)
            for (int e = d + 1; e < 44; ++e) {
              const uint64_t err = (uint64_t{1} << a) | (uint64_t{1} << b) | (uint64_t{1} << c) |
                                   (uint64_t{1} << d) | (uint64_t{1} << e);
              const CodeMatch m = Svms44::Decode(read ^ err, 5, strong);
              ASSERT_TRUE(m.accepted() && m.id == id && m.rotation == r && m.bit_errors == 5)
                  << "id " << id << " flips " << Svms44::ToBitString(err);
              ++checked;
            }
  }
  EXPECT_EQ(checked, 3 * 1086008);
}

TEST(Svms44, IdCountLimitsTheFamily) {
  const int strong = Svms44::StrongIdCount();
  EXPECT_TRUE(Svms44::Decode(Svms44::Codeword(strong - 1), 0, strong).accepted());
  EXPECT_FALSE(Svms44::Decode(Svms44::Codeword(strong), 0, strong).accepted());
}

TEST(Svms44, StrongSubsetHasDistance11AndTheTableDistanceIs9) {
  // Exhaustive over the first phase (IDs chosen at D >= 11), all rotations.
  const int n = kSvms44PhaseFirstId[1];
  ASSERT_EQ(kSvms44PhaseDistance[0], 11);
  std::vector<uint64_t> rot(4 * n);
  for (int id = 0; id < n; ++id)
    for (int r = 0; r < 4; ++r) rot[4 * id + r] = Svms44::Rotate(Svms44::Codeword(id), r);
  int min_d = 99;
  for (int a = 0; a < n; ++a) {
    for (int r = 1; r < 4; ++r) min_d = std::min(min_d, Weight(rot[4 * a + r] ^ rot[4 * a]));
    for (int b = a + 1; b < n; ++b)
      for (int r = 0; r < 4; ++r) min_d = std::min(min_d, Weight(rot[4 * a + r] ^ rot[4 * b]));
  }
  EXPECT_GE(min_d, 11);
}

TEST(CodecStats, MeasuresTheFamily) {
  const CodecStats s = MeasureCodecStats(1 << 20, 1, 2);
  EXPECT_EQ(s.bits, 44);
  EXPECT_EQ(s.ids, 32768);
  EXPECT_EQ(s.code_min_distance, 11);
  EXPECT_GE(s.min_distance, 11);
  EXPECT_EQ(s.rotation_min_distance, Svms44::kRotationDistance);
  EXPECT_GT(s.rotation_distance_pairs.at(9), 0);
  // Monotone in the limit, and close to the exact value where it is known.
  for (int k = 1; k <= 5; ++k) EXPECT_GE(s.false_accept[k], s.false_accept[k - 1]);
  EXPECT_NEAR(s.false_accept[4], s.false_accept_exact[4], 0.2 * s.false_accept_exact[4]);
  EXPECT_NEAR(s.false_accept[5], 0.009, 0.002);
  EXPECT_LT(s.false_accept_exact[2], 1e-5);
}

}  // namespace
}  // namespace svms

namespace svms {
namespace {

TEST(IdSelection, LongestRunIsCyclic) {
  EXPECT_EQ(LongestRun(0), 44);
  EXPECT_EQ(LongestRun(0b1), 43);                          // 43 zeros wrap around
  EXPECT_EQ(LongestRun(0x55555555555ULL), 1);              // alternating
  EXPECT_EQ(LongestRun((uint64_t{1} << 43) | 0b111), 40);  // the zeros in between
  uint64_t w = (uint64_t{7} << 41) | 7;                    // 6 ones across the wrap
  for (int k = 4; k <= 38; k += 2) w |= uint64_t{1} << k;  // alternating elsewhere
  EXPECT_EQ(LongestRun(w), 6);
}

TEST(Svms44, NoIdLooksLikeAPlainFrame) {
  for (int id = 0; id < Svms44::kNumIds; ++id) {
    const uint64_t c = Svms44::Codeword(id);
    ASSERT_GE(Weight(c), 11) << id;
    ASSERT_LE(Weight(c), 33) << id;
    for (int side = 0; side < 4; ++side) {
      const int ones = Weight((c >> (11 * side)) & 0x7ff);
      ASSERT_TRUE(ones >= 2 && ones <= 9) << "id " << id << " side " << side;
    }
    ASSERT_LE(LongestRun(c), 8) << id;
  }
}

}  // namespace
}  // namespace svms
