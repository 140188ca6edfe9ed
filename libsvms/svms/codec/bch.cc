#include "svms/codec/bch.h"

#include <cstddef>
#include <vector>

namespace svms {
namespace {

constexpr int kFieldOrder = 63;            // multiplicative order of GF(64)
constexpr unsigned kPrimitivePoly = 0x43;  // x^6 + x + 1

// Carry-less product of two binary polynomials (bit i = coefficient of x^i).
uint64_t ClMul(uint64_t a, uint64_t b) {
  uint64_t r = 0;
  for (int i = 0; b >> i; ++i) {
    if ((b >> i) & 1) r ^= a << i;
  }
  return r;
}

int Degree(uint64_t p) { return 63 - __builtin_clzll(p); }

// Remainder of a(x) divided by m(x) over GF(2).
uint64_t PolyMod(uint64_t a, uint64_t m) {
  const int dm = Degree(m);
  while (a && Degree(a) >= dm) a ^= m << (Degree(a) - dm);
  return a;
}

}  // namespace

const Bch44& Bch44::Get() {
  static const Bch44 instance;
  return instance;
}

Bch44::Bch44() {
  // GF(64) tables.
  unsigned x = 1;
  for (int i = 0; i < kFieldOrder; ++i) {
    exp_[i] = static_cast<uint8_t>(x);
    log_[x] = static_cast<uint8_t>(i);
    x <<= 1;
    if (x & 0x40) x ^= kPrimitivePoly;
  }
  for (int i = kFieldOrder; i < 128; ++i) exp_[i] = exp_[i - kFieldOrder];

  auto mul = [&](unsigned a, unsigned b) -> unsigned {
    return (a && b) ? exp_[log_[a] + log_[b]] : 0;
  };

  for (int a = 0; a < 64; ++a)
    for (int c = 0; c < 64; ++c) mul_[a][c] = static_cast<uint8_t>(mul(a, c));

  for (int p = 0; p < kN; ++p)
    for (int i = 0; i <= kT; ++i)
      chien_powers_[p][i] = exp_[(kFieldOrder * kT - i * p) % kFieldOrder];

  // g(x) = lcm of the minimal polynomials of alpha^1 .. alpha^10, i.e. the product of the
  // minimal polynomials of the cyclotomic cosets of 1, 3, 5, 7, 9.
  generator_ = 1;
  for (int root : {1, 3, 5, 7, 9}) {
    std::vector<int> coset;
    int e = root;
    do {
      coset.push_back(e);
      e = (2 * e) % kFieldOrder;
    } while (e != root);
    // m(x) = prod (x - alpha^e), coefficients in GF(64); they come out binary.
    std::vector<unsigned> m{1};
    for (int c : coset) {
      std::vector<unsigned> next(m.size() + 1, 0);
      for (size_t i = 0; i < m.size(); ++i) {
        next[i + 1] ^= m[i];
        next[i] ^= mul(m[i], exp_[c]);
      }
      m = next;
    }
    uint64_t binary = 0;
    for (size_t i = 0; i < m.size(); ++i) {
      if (m[i] > 1) __builtin_trap();  // cannot happen for a minimal polynomial
      binary |= uint64_t{m[i]} << i;
    }
    generator_ = ClMul(generator_, binary);
  }

  // Syndrome tables: the contribution of each byte value at each byte position.
  static constexpr int kRoots[5] = {1, 3, 5, 7, 9};
  for (int byte = 0; byte < 6; ++byte) {
    for (int v = 0; v < 256; ++v) {
      uint32_t packed = 0;
      for (int j = 0; j < 5; ++j) {
        unsigned s = 0;
        for (int bit = 0; bit < 8; ++bit) {
          const int pos = 8 * byte + bit;
          if (pos < kN && ((v >> bit) & 1)) s ^= exp_[(pos * kRoots[j]) % kFieldOrder];
        }
        packed |= uint32_t{s} << (6 * j);
      }
      syndrome_table_[byte][v] = packed;
    }
  }
}

uint64_t Bch44::Encode(uint32_t info) const {
  const uint64_t shifted = (uint64_t{info} & (kInfoCount - 1)) << kParity;
  return shifted | PolyMod(shifted, generator_);
}

uint32_t Bch44::Syndrome(uint64_t word) const {
  uint32_t s = 0;
  for (int byte = 0; byte < 6; ++byte) s ^= syndrome_table_[byte][(word >> (8 * byte)) & 0xff];
  return s;
}

int Bch44::Decode(uint64_t word, uint64_t* codeword) const {
  word &= kWordMask;
  const uint32_t packed = Syndrome(word);
  if (packed == 0) {
    *codeword = word;
    return 0;
  }
  const auto& mul = mul_;
  // S[1..10]; the even ones are squares of earlier ones in a binary code.
  uint8_t S[11];
  for (int j = 0; j < 5; ++j) S[2 * j + 1] = (packed >> (6 * j)) & 0x3f;
  for (int j = 2; j <= 10; j += 2) S[j] = mul[S[j / 2]][S[j / 2]];

  // Berlekamp-Massey for a binary code: the discrepancy of every odd step is zero, so only the
  // even steps are computed. C(x) is the error-locator polynomial, of degree L.
  uint8_t C[8] = {1}, B[8] = {1};
  int L = 0, m = 1;
  unsigned b = 1;
  for (int n = 0; n < 2 * kT; n += 2) {
    unsigned d = S[n + 1];
    for (int i = 1; i <= L; ++i) d ^= mul[C[i]][S[n + 1 - i]];
    if (d != 0) {
      const unsigned coef = exp_[log_[d] + kFieldOrder - log_[b]];
      uint8_t T[8];
      for (int i = 0; i < 8; ++i) T[i] = C[i];
      for (int i = 0; i + m <= kT + 1; ++i) C[i + m] ^= mul[coef][B[i]];
      if (2 * L <= n) {
        L = n + 1 - L;
        for (int i = 0; i < 8; ++i) B[i] = T[i];
        b = d;
        m = 0;
      }
    }
    m += 2;  // this step and the skipped odd one
  }
  if (L > kT) return -1;

  // C(x) must split into L distinct linear factors over GF(64), i.e. x^64 = x (mod C(x)).
  // Cheap (6 squarings), and it rejects nearly every locator of an undecodable word before the
  // Chien search.
  if (L >= 2) {
    const unsigned inv_lead = exp_[kFieldOrder - log_[C[L]]];
    uint8_t monic[8] = {};  // monic[i] = coefficient of x^i of C(x) / C_L
    for (int i = 0; i <= L; ++i) monic[i] = mul[C[i]][inv_lead];
    // R[k] = x^k mod C(x) for k in [L, 2L - 2], as coefficient vectors of degree < L.
    uint8_t R[9][5] = {};
    for (int i = 0; i < L; ++i) R[L][i] = monic[i];  // x^L = sum monic[i] x^i (char 2)
    for (int k = L + 1; k <= 2 * L - 2; ++k) {
      const uint8_t top = R[k - 1][L - 1];
      R[k][0] = mul[top][monic[0]];
      for (int i = 1; i < L; ++i) R[k][i] = R[k - 1][i - 1] ^ mul[top][monic[i]];
    }
    // Squaring is additive in characteristic 2: (sum r_i x^i)^2 = sum r_i^2 x^(2i).
    uint8_t r[5] = {0, 1};  // r(x) = x
    for (int k = 0; k < 6; ++k) {
      uint8_t sq[5] = {};
      for (int i = 0; i < L; ++i) {
        const uint8_t a = mul[r[i]][r[i]];
        if (!a) continue;
        if (2 * i < L) {
          sq[2 * i] ^= a;
        } else {
          const uint8_t* ma = mul[a];
          for (int j = 0; j < L; ++j) sq[j] ^= ma[R[2 * i][j]];
        }
      }
      for (int i = 0; i < L; ++i) r[i] = sq[i];
    }
    if (r[1] != 1 || r[0] != 0) return -1;
    for (int i = 2; i < L; ++i)
      if (r[i]) return -1;
  }

  // Chien search over the 44 positions of the shortened code: position p is in error iff
  // C(alpha^-p) = 0. A root outside [0, 44) means the word is not decodable.
  uint64_t error = 0;
  int roots = 0;
  for (int p = 0; p < kN; ++p) {
    const uint8_t* x = chien_powers_[p];  // x[i] = alpha^(-i p)
    const unsigned v =
        1 ^ mul[C[1]][x[1]] ^ mul[C[2]][x[2]] ^ mul[C[3]][x[3]] ^ mul[C[4]][x[4]] ^ mul[C[5]][x[5]];
    if (v == 0) {
      error |= uint64_t{1} << p;
      if (++roots == L) break;
    }
  }
  if (roots != L) return -1;
  const uint64_t corrected = word ^ error;
  if (Syndrome(corrected) != 0) return -1;
  *codeword = corrected;
  return L;
}

}  // namespace svms
