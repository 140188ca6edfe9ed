// Codec micro-benchmarks. Target: decoding one word over all four rotations in at most 1
// microsecond. Run: build/bin/svms_bench_codec --benchmark_repetitions=9
#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include "svms/codec/bch.h"
#include "svms/codec/svms44.h"

namespace {

// Random 44-bit words: what a detector sees on quadrilaterals that are not markers.
void BM_DecodeRandomWord(benchmark::State& state) {
  std::mt19937_64 rng(1);
  std::vector<uint64_t> words(1 << 16);
  for (auto& w : words) w = rng() & svms::Bch44::kWordMask;
  size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(svms::Svms44::Decode(words[i++ & 0xffff], 5));
  }
}
BENCHMARK(BM_DecodeRandomWord);

// Rotated markers with `flips` bit errors.
void BM_DecodeMarker(benchmark::State& state) {
  const int flips = static_cast<int>(state.range(0));
  std::mt19937_64 rng(2);
  std::vector<uint64_t> words(1 << 16);
  for (auto& w : words) {
    const int turns = static_cast<int>(rng() % 4);  // drawn first, GCC's order: same words
    w = svms::Svms44::Rotate(svms::Svms44::Codeword(rng() % svms::Svms44::kNumIds), turns);
    uint64_t e = 0;
    while (svms::Weight(e) < flips) e |= uint64_t{1} << (rng() % 44);
    w ^= e;
  }
  size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(svms::Svms44::Decode(words[i++ & 0xffff], 5));
  }
}
BENCHMARK(BM_DecodeMarker)->Arg(0)->Arg(2)->Arg(5);

void BM_BchDecodeOneRotation(benchmark::State& state) {
  std::mt19937_64 rng(3);
  std::vector<uint64_t> words(1 << 16);
  for (auto& w : words) w = rng() & svms::Bch44::kWordMask;
  const svms::Bch44& bch = svms::Bch44::Get();
  size_t i = 0;
  uint64_t out;
  for (auto _ : state) benchmark::DoNotOptimize(bch.Decode(words[i++ & 0xffff], &out));
}
BENCHMARK(BM_BchDecodeOneRotation);

}  // namespace

BENCHMARK_MAIN();
