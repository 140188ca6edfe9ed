// Encodes and decodes through an installed libsvms; exits 0 only if the round trip is right.
#include <cstdio>

#include "svms/marker_model.h"
#include "svms/svms44.h"

int main() {
  const svms::CodeMatch m =
      svms::Svms44::Decode(svms::Svms44::Rotate(svms::Svms44::Codeword(4242), 3) ^ 0b101, 2);
  const svms::MarkerModel model = svms::MarkerModel::Standard(4242, 0.1, 0.02);
  const bool ok =
      m.accepted() && m.id == 4242 && m.rotation == 3 && m.bit_errors == 2 && model.Validate().ok();
  std::printf("downstream: id %d rotation %d bit_errors %d -> %s\n", m.id, m.rotation, m.bit_errors,
              ok ? "ok" : "WRONG");
  return ok ? 0 : 1;
}
