#include "svms/codec/id_selection.h"

#include "svms/codec/bch.h"

namespace svms {

uint64_t RotateWord(uint64_t word, int quarter_turns) {
  const int shift = 11 * (((quarter_turns % 4) + 4) % 4);
  if (shift == 0) return word & Bch44::kWordMask;
  word &= Bch44::kWordMask;
  return ((word >> shift) | (word << (Bch44::kN - shift))) & Bch44::kWordMask;
}

int LongestRun(uint64_t word) {
  const uint64_t w = word & Bch44::kWordMask;
  if (w == 0 || w == Bch44::kWordMask) return Bch44::kN;
  // Rotate so that bit 0 starts a run, then scan once.
  int start = 0;
  while (((w >> start) & 1) == ((w >> ((start + Bch44::kN - 1) % Bch44::kN)) & 1)) ++start;
  int best = 0, run = 0;
  uint64_t prev = 2;
  for (int k = 0; k < Bch44::kN; ++k) {
    const uint64_t b = (w >> ((start + k) % Bch44::kN)) & 1;
    run = (b == prev) ? run + 1 : 1;
    prev = b;
    if (run > best) best = run;
  }
  return best;
}

namespace {

bool LooksLikeAPlainFrame(uint64_t c, const IdSelectionOptions& o) {
  const int w = Weight(c);
  if (w < o.min_weight || w > o.max_weight) return true;
  for (int side = 0; side < 4; ++side) {
    const int ones = Weight((c >> (11 * side)) & 0x7ff);
    if (ones < o.min_side_each || 11 - ones < o.min_side_each) return true;
  }
  return LongestRun(c) > o.max_run;
}

}  // namespace

IdSelection SelectSvms44Ids(const IdSelectionOptions& options,
                            const std::function<void(int, int)>& progress) {
  const Bch44& bch = Bch44::Get();
  IdSelection out;
  std::vector<uint8_t> taken(Bch44::kInfoCount, 0);
  // All four rotations of every selected codeword: d(rot_r(c), a) = d(c, rot_-r(a)), so
  // comparing a candidate against these covers every rotation.
  std::vector<uint64_t> rotations;
  rotations.reserve(4 * static_cast<size_t>(options.count));

  for (size_t phase = 0; phase < options.phase_distances.size(); ++phase) {
    const int D = options.phase_distances[phase];
    out.phase_first_id.push_back(static_cast<int>(out.infos.size()));
    for (uint32_t info = 0; info < Bch44::kInfoCount; ++info) {
      if (static_cast<int>(out.infos.size()) >= options.count) break;
      if (taken[info]) continue;
      const uint64_t c = bch.Encode(info);
      if (LooksLikeAPlainFrame(c, options)) continue;
      bool ok = true;
      for (int r = 1; r < 4 && ok; ++r) ok = Weight(RotateWord(c, r) ^ c) >= D;
      for (size_t i = 0; i < rotations.size() && ok; ++i) ok = Weight(rotations[i] ^ c) >= D;
      if (!ok) continue;
      taken[info] = 1;
      out.infos.push_back(info);
      for (int r = 0; r < 4; ++r) rotations.push_back(RotateWord(c, r));
      if (progress && out.infos.size() % 1024 == 0) {
        progress(static_cast<int>(phase), static_cast<int>(out.infos.size()));
      }
    }
  }
  return out;
}

}  // namespace svms
