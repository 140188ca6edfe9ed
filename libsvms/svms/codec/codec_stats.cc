#include "svms/codec/codec_stats.h"

#include <algorithm>
#include <cmath>
#include <thread>
#include <vector>

#include "svms/codec/bch.h"
#include "svms/codec/svms44.h"

namespace svms {
namespace {

uint64_t SplitMix64(uint64_t& state) {
  uint64_t z = (state += 0x9e3779b97f4a7c15ULL);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

double Binomial(int n, int k) {
  double r = 1;
  for (int i = 1; i <= k; ++i) r = r * (n - k + i) / i;
  return r;
}

}  // namespace

CodecStats MeasureCodecStats(int64_t samples, uint64_t seed, int threads) {
  CodecStats s;
  s.bits = Svms44::kBits;
  s.ids = Svms44::kNumIds;
  threads = std::max(1, threads);

  const Bch44& bch = Bch44::Get();
  s.code_min_distance = Bch44::kN;
  for (uint32_t info = 1; info < Bch44::kInfoCount; ++info) {
    s.code_min_distance = std::min(s.code_min_distance, Weight(bch.Encode(info)));
  }

  // Exhaustive pairwise distances: for a < b, the rotation-0 distance and all four rotations;
  // for a == b, the three non-trivial rotations.
  const int n = Svms44::kNumIds;
  std::vector<uint64_t> words(n);
  for (int id = 0; id < n; ++id) words[id] = Svms44::Codeword(id);
  struct Partial {
    int min_plain = 99, min_rot = 99;
    std::array<int64_t, 45> hist{};
  };
  std::vector<Partial> partial(threads);
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) {
    pool.emplace_back([&, t] {
      Partial& p = partial[t];
      for (int a = t; a < n; a += threads) {
        uint64_t rot[4];
        for (int r = 0; r < 4; ++r) rot[r] = Svms44::Rotate(words[a], r);
        for (int r = 1; r < 4; ++r) {
          const int d = Weight(rot[r] ^ words[a]);
          p.min_rot = std::min(p.min_rot, d);
          ++p.hist[d];
        }
        for (int b = a + 1; b < n; ++b) {
          const uint64_t wb = words[b];
          const int d0 = Weight(rot[0] ^ wb);
          p.min_plain = std::min(p.min_plain, d0);
          int m = d0;
          ++p.hist[d0];
          for (int r = 1; r < 4; ++r) {
            const int d = Weight(rot[r] ^ wb);
            m = std::min(m, d);
            ++p.hist[d];
          }
          p.min_rot = std::min(p.min_rot, m);
        }
      }
    });
  }
  for (auto& th : pool) th.join();
  std::array<int64_t, 45> hist{};
  s.min_distance = 99;
  s.rotation_min_distance = 99;
  for (const Partial& p : partial) {
    s.min_distance = std::min(s.min_distance, p.min_plain);
    s.rotation_min_distance = std::min(s.rotation_min_distance, p.min_rot);
    for (int d = 0; d <= 44; ++d) hist[d] += p.hist[d];
  }
  for (int d = 0; d <= std::min(44, s.rotation_min_distance + 2); ++d) {
    if (hist[d]) s.rotation_distance_pairs[d] = hist[d];
  }

  // Monte Carlo false-accept rates: one decode at limit 5 per word tells every limit.
  s.false_accept_samples = samples;
  std::vector<std::array<int64_t, 7>> counts(threads);
  pool.clear();
  for (int t = 0; t < threads; ++t) {
    pool.emplace_back([&, t] {
      uint64_t state = seed + 0x1234567ULL * (t + 1);
      for (int64_t i = t; i < samples; i += threads) {
        const CodeMatch m = Svms44::Decode(SplitMix64(state) & Bch44::kWordMask, 5);
        if (m.accepted()) ++counts[t][m.bit_errors];
        if (m.verdict == CodeMatch::Verdict::kAmbiguous) ++counts[t][6];
      }
    });
  }
  for (auto& th : pool) th.join();
  int64_t cumulative = 0;
  for (int limit = 0; limit <= 5; ++limit) {
    for (int t = 0; t < threads; ++t) cumulative += counts[t][limit];
    s.false_accept_hits[limit] = cumulative;
    s.false_accept[limit] = samples > 0 ? static_cast<double>(cumulative) / samples : 0.0;
  }
  for (int t = 0; t < threads; ++t) s.ambiguous_hits += counts[t][6];

  // Exact values where balls of radius `limit` around the 4n rotated codewords are disjoint.
  double volume = 0;
  for (int limit = 0; limit <= 5; ++limit) {
    volume += Binomial(Bch44::kN, limit);
    s.false_accept_exact[limit] = (2 * limit + 1 <= s.rotation_min_distance)
                                      ? 4.0 * n * volume / std::ldexp(1.0, Bch44::kN)
                                      : -1.0;
  }
  return s;
}

}  // namespace svms
