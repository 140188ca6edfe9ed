// Random draws for tests that must see the same images under every compiler.
#pragma once

#include <Eigen/Core>
#include <random>

namespace svms_testing {

// Two draws of `d`, x first. Written as Vector2d(d(rng), d(rng)) the order of the two draws is
// the compiler's (GCC and Clang differ), and the sanitizer build would test other images than
// `make test`.
inline Eigen::Vector2d Draw2(std::uniform_real_distribution<double>& d, std::mt19937& rng) {
  const double x = d(rng);
  const double y = d(rng);
  return Eigen::Vector2d(x, y);
}

}  // namespace svms_testing
