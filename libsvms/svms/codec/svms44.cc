#include "svms/codec/svms44.h"

#include <vector>

#include "svms/codec/bch.h"
#include "svms/codec/id_selection.h"

namespace svms {
namespace {

// info word -> ID, or -1; built once from the generated table.
const std::vector<int32_t>& InfoToId() {
  static const std::vector<int32_t> table = [] {
    std::vector<int32_t> t(Bch44::kInfoCount, -1);
    for (int id = 0; id < Svms44::kNumIds; ++id) t[kSvms44Info[id]] = id;
    return t;
  }();
  return table;
}

}  // namespace

uint64_t Svms44::Codeword(int id) { return Bch44::Get().Encode(kSvms44Info[id]); }

uint64_t Svms44::Rotate(uint64_t word, int quarter_turns) {
  return RotateWord(word, quarter_turns);
}

int Svms44::IdOfInfo(uint32_t info) { return info < Bch44::kInfoCount ? InfoToId()[info] : -1; }

int Svms44::StrongIdCount() { return kSvms44PhaseFirstId[1]; }

CodeMatch Svms44::Decode(uint64_t word, int max_corrections, int id_count) {
  const Bch44& bch = Bch44::Get();
  const auto& info_to_id = InfoToId();
  CodeMatch best;
  int best_errors = 99, second_errors = 99, ties = 0;
  for (int r = 0; r < 4; ++r) {
    uint64_t codeword;
    const int errors = bch.Decode(RotateWord(word, 4 - r), &codeword);
    if (errors < 0) continue;
    const int id = info_to_id[Bch44::Info(codeword)];
    if (id < 0 || id >= id_count) continue;
    if (errors < best_errors) {
      second_errors = best_errors;
      best_errors = errors;
      ties = 0;
      best.id = id;
      best.rotation = r;
    } else if (errors == best_errors) {
      ++ties;
      second_errors = errors;
    } else if (errors < second_errors) {
      second_errors = errors;
    }
  }
  best.runner_up_errors = second_errors <= Bch44::kT ? second_errors : -1;
  if (best_errors > Bch44::kT || best_errors > max_corrections) {
    return CodeMatch{CodeMatch::Verdict::kNoCodeword, -1, 0, -1, best.runner_up_errors};
  }
  if (ties > 0) {
    return CodeMatch{CodeMatch::Verdict::kAmbiguous, -1, 0, best_errors, second_errors};
  }
  best.verdict = CodeMatch::Verdict::kAccepted;
  best.bit_errors = best_errors;
  return best;
}

std::string Svms44::ToBitString(uint64_t word) {
  std::string s(kBits, '0');
  for (int i = 0; i < kBits; ++i) s[i] = ((word >> i) & 1) ? '1' : '0';
  return s;
}

bool Svms44::FromBitString(const std::string& bits, uint64_t* word) {
  if (bits.size() != static_cast<size_t>(kBits)) return false;
  uint64_t w = 0;
  for (int i = 0; i < kBits; ++i) {
    if (bits[i] == '1') {
      w |= uint64_t{1} << i;
    } else if (bits[i] != '0') {
      return false;
    }
  }
  *word = w;
  return true;
}

}  // namespace svms
