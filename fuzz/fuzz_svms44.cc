// libFuzzer target: the svms44 decoder. Input: 8 bytes of a 64-bit word (any bits, also above
// bit 43), then a byte of max_corrections and two of id_count, all unchecked values. Then the
// guarantee of svms44.h is checked: a codeword turned by any rotation with up to 4 flipped bits
// (taken from the remaining bytes) decodes to its ID and rotation.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "svms/codec/svms44.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 11) return 0;
  uint64_t word;
  std::memcpy(&word, data, 8);
  const int max_corrections = static_cast<int8_t>(data[8]);
  const int id_count = static_cast<int16_t>(data[9] | (data[10] << 8));
  const svms::CodeMatch m = svms::Svms44::Decode(word, max_corrections, id_count);
  if (m.accepted() && (m.id < 0 || m.id >= id_count || m.bit_errors > max_corrections)) {
    std::fprintf(stderr, "accepted an ID or a correction outside the request\n");
    std::abort();
  }
  (void)svms::Svms44::ToBitString(word);
  // The guarantee: ID from the word's low 15 bits, rotation, up to 4 flips.
  const int id = static_cast<int>(word & 0x7fff);
  const int rotation = static_cast<int>((word >> 15) & 3);
  uint64_t read = svms::Svms44::Rotate(svms::Svms44::Codeword(id), rotation);
  for (size_t i = 11; i < size && i < 15; ++i) read ^= uint64_t{1} << (data[i] % 44);
  const svms::CodeMatch r = svms::Svms44::Decode(read);
  if (!r.accepted() || r.id != id || r.rotation != rotation) {
    std::fprintf(stderr, "ID %d rotation %d with up to 4 flips decoded as %d rotation %d\n", id,
                 rotation, r.id, r.rotation);
    std::abort();
  }
  return 0;
}
