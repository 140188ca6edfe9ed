#include "svms/codec/bch.h"

#include <gtest/gtest.h>

#include <random>

namespace svms {
namespace {

TEST(Bch44, GeneratorIsTheTabulatedOne) {
  // Lin & Costello, Error Control Coding, Appendix C: (63,36,t=5) generator 1033500423 (octal)
  // for the primitive polynomial 103 (octal) = x^6 + x + 1.
  EXPECT_EQ(Bch44::Get().generator(), 01033500423ULL);
}

TEST(Bch44, GeneratorDividesXToThe63MinusOne) {
  // x^63 + 1 mod g(x) == 0: the code is cyclic of length 63.
  uint64_t a = (uint64_t{1} << 63) | 1;
  const uint64_t g = Bch44::Get().generator();
  for (int d = 63; d >= 27; --d) {
    if ((a >> d) & 1) a ^= g << (d - 27);
  }
  EXPECT_EQ(a, 0u);
}

TEST(Bch44, EveryCodewordIsSystematicWithZeroSyndrome_AndMinDistanceIsExactly11) {
  const Bch44& bch = Bch44::Get();
  int min_weight = 99;
  for (uint32_t info = 0; info < Bch44::kInfoCount; ++info) {
    const uint64_t c = bch.Encode(info);
    ASSERT_EQ(c & ~Bch44::kWordMask, 0u);
    ASSERT_EQ(Bch44::Info(c), info);
    ASSERT_EQ(bch.Syndrome(c), 0u) << info;
    if (info) min_weight = std::min(min_weight, Weight(c));
  }
  EXPECT_EQ(min_weight, 11);
}

TEST(Bch44, SyndromeIsNonzeroForEveryWordOfWeightOneAndTwo) {
  // A necessary part of d >= 11 (the full check is the minimum weight above).
  const Bch44& bch = Bch44::Get();
  for (int i = 0; i < 44; ++i) {
    EXPECT_NE(bch.Syndrome(uint64_t{1} << i), 0u);
    for (int j = i + 1; j < 44; ++j)
      EXPECT_NE(bch.Syndrome((uint64_t{1} << i) | (uint64_t{1} << j)), 0u);
  }
}

// Every error pattern of weight 0..5 on one codeword: 1,235,994 decodes.
TEST(Bch44, CorrectsEveryPatternOfUpTo5FlipsExhaustively) {
  const Bch44& bch = Bch44::Get();
  const uint64_t c = bch.Encode(0x1a2b3);
  int64_t checked = 0;
  auto check = [&](uint64_t e, int w) {
    uint64_t out = 0;
    ASSERT_EQ(bch.Decode(c ^ e, &out), w);
    ASSERT_EQ(out, c);
    ++checked;
  };
  check(0, 0);
  for (int a = 0; a < 44; ++a) {
    const uint64_t ea = uint64_t{1} << a;
    check(ea, 1);
    for (int b = a + 1; b < 44; ++b) {
      const uint64_t eb = ea | (uint64_t{1} << b);
      check(eb, 2);
      for (int d = b + 1; d < 44; ++d) {
        const uint64_t ed = eb | (uint64_t{1} << d);
        check(ed, 3);
        for (int f = d + 1; f < 44; ++f) {
          const uint64_t ef = ed | (uint64_t{1} << f);
          check(ef, 4);
          for (int g = f + 1; g < 44; ++g) check(ef | (uint64_t{1} << g), 5);
        }
      }
    }
  }
  EXPECT_EQ(checked, 1235994);
}

TEST(Bch44, BeyondFiveFlipsItRejectsOrFindsATrulyCloseCodeword) {
  const Bch44& bch = Bch44::Get();
  std::mt19937_64 rng(7);
  int rejected = 0;
  for (int trial = 0; trial < 200000; ++trial) {
    const uint64_t c = bch.Encode(rng() & (Bch44::kInfoCount - 1));
    uint64_t e = 0;
    const int flips = 6 + trial % 10;
    while (Weight(e) < flips) e |= uint64_t{1} << (rng() % 44);
    uint64_t out = 0;
    const int n = bch.Decode(c ^ e, &out);
    if (n < 0) {
      ++rejected;
      continue;
    }
    // A claimed decode is always a real codeword at the claimed distance, never the original.
    ASSERT_EQ(bch.Syndrome(out), 0u);
    ASSERT_EQ(Weight(out ^ c ^ e), n);
    ASSERT_LE(n, 5);
    ASSERT_NE(out, c);
  }
  EXPECT_GT(rejected, 150000);
}

}  // namespace
}  // namespace svms
