// The renderer's randomness, all of it derived from the scene's seed: a 64-bit mixing hash
// (one SplitMix64 step) that turns a seed, a view and a pixel into an independent seed, and the
// small generator each pixel draws its jitter, motion-blur times and sun-disc points from. The
// procedural patterns and earth hash their lattice cells with Mix, and the sensor's noise
// generator is seeded by it; so a scene renders the same bytes on every machine, in any order
// and with any number of threads. Internal to sim (not installed).
#pragma once

#include <cstdint>

namespace svms::render {

// A bijective mix of the 64 bits of x (SplitMix64's increment and finaliser): nearby inputs give
// unrelated outputs.
inline uint64_t Mix(uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

// A small deterministic generator for per-pixel jitter: seeded by hashing the pixel, then
// xorshift64* steps (cheap: the sampler draws several numbers per ray).
struct Rng {
  uint64_t s = 1;
  Rng() = default;
  explicit Rng(uint64_t seed) : s(Mix(seed) | 1) {}
  double Uniform() {
    s ^= s >> 12;
    s ^= s << 25;
    s ^= s >> 27;
    // (53 bits: converting them as signed is the same value, without the unsigned fix-up)
    return static_cast<double>(static_cast<int64_t>((s * 0x2545f4914f6cdd1dULL) >> 11)) * 0x1.0p-53;
  }
};

}  // namespace svms::render
