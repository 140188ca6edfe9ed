// A short, dumb fuzz run for `make test` (gcc, no libFuzzer): each seed of a target's corpus,
// then `mutations` mutated copies of it (bits flipped, bytes overwritten with 0, 0xff or noise,
// cut short, bytes inserted), drawn from a fixed seed so that a failure repeats. A target
// checks its own invariants and aborts on a violation; a crash or an abort fails the test.
// The coverage-guided runs are libFuzzer's (`make test-sanitize`, docs/reliability.md).
//
// Usage: fuzz_X_replay CORPUS_DIR [MUTATIONS_PER_SEED]
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size);

namespace {

std::vector<uint8_t> Mutate(std::vector<uint8_t> b, std::mt19937_64& rng) {
  auto pick = [&](size_t n) { return static_cast<size_t>(rng() % std::max<size_t>(n, 1)); };
  const int edits = 1 + static_cast<int>(rng() % 4);
  for (int e = 0; e < edits; ++e) {
    switch (rng() % 5) {
      case 0:
        if (!b.empty()) b[pick(b.size())] ^= static_cast<uint8_t>(1u << (rng() % 8));
        break;
      case 1: {
        static const uint8_t kSpecial[] = {0, 0xff, 0x7f, 0x80, '9', '"', '{', '-'};
        if (!b.empty()) b[pick(b.size())] = kSpecial[rng() % sizeof(kSpecial)];
        break;
      }
      case 2:
        if (!b.empty()) b[pick(b.size())] = static_cast<uint8_t>(rng());
        break;
      case 3:
        b.resize(pick(b.size() + 1));
        break;
      default: {
        const size_t at = pick(b.size() + 1), n = 1 + rng() % 8;
        std::vector<uint8_t> ins(n);
        for (auto& x : ins) x = static_cast<uint8_t>(rng());
        b.insert(b.begin() + static_cast<std::ptrdiff_t>(at), ins.begin(), ins.end());
      }
    }
  }
  return b;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s CORPUS_DIR [MUTATIONS_PER_SEED]\n", argv[0]);
    return 2;
  }
  const int mutations = argc > 2 ? std::atoi(argv[2]) : 50;
  std::vector<std::filesystem::path> seeds;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(argv[1], ec))
    if (e.is_regular_file()) seeds.push_back(e.path());
  if (ec || seeds.empty()) {
    std::fprintf(stderr, "%s: %s: no seed files (expected a corpus directory)\n", argv[0], argv[1]);
    return 2;
  }
  std::sort(seeds.begin(), seeds.end());
  std::mt19937_64 rng(20261128);
  long runs = 0;
  for (const auto& path : seeds) {
    std::ifstream in(path, std::ios::binary);
    const std::vector<uint8_t> seed((std::istreambuf_iterator<char>(in)),
                                    std::istreambuf_iterator<char>());
    LLVMFuzzerTestOneInput(seed.data(), seed.size());
    ++runs;
    for (int m = 0; m < mutations; ++m, ++runs) {
      const std::vector<uint8_t> b = Mutate(seed, rng);
      LLVMFuzzerTestOneInput(b.data(), b.size());
    }
  }
  std::printf("%s: %ld inputs from %zu seeds, no crash\n", argv[0], runs, seeds.size());
  return 0;
}
