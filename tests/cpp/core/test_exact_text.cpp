// The outputs' number format (mpm/core/exact_text.hpp): the bytes of printf's "%.17g", and the
// same double read back.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "mpm/core/exact_text.hpp"

namespace pfm {
namespace {

std::string printf_17g(double v) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.17g", v);
  return buffer;
}

TEST(ExactText, TheBytesOfPrintf17gOnRandomAndSpecialDoubles) {
  std::vector<double> values = {0.0,
                                -0.0,
                                1.0,
                                -1.0,
                                0.1,
                                1e-5,
                                1e-4,
                                123456789012345678.0,
                                1e16,
                                1e17,
                                std::numeric_limits<double>::min(),
                                std::numeric_limits<double>::denorm_min(),
                                std::numeric_limits<double>::max(),
                                std::numeric_limits<double>::lowest(),
                                std::numeric_limits<double>::infinity(),
                                -std::numeric_limits<double>::infinity(),
                                std::numeric_limits<double>::quiet_NaN(),
                                -std::numeric_limits<double>::quiet_NaN()};
  // Random bit patterns (every exponent) and random values of the outputs' sizes.
  std::mt19937_64 bits(20261206);
  std::uniform_real_distribution<double> uniform(-1e3, 1e3);
  for (int k = 0; k < 200000; ++k) {
    const std::uint64_t b = bits();
    double v = 0.0;
    std::memcpy(&v, &b, sizeof v);
    values.push_back(v);
    values.push_back(uniform(bits));
  }
  int differing = 0, not_round_trip = 0;
  for (const double v : values) {
    const std::string text = format_exact(v);
    differing += text != printf_17g(v);
    if (std::isfinite(v)) not_round_trip += std::strtod(text.c_str(), nullptr) != v;
  }
  EXPECT_EQ(differing, 0);
  EXPECT_EQ(not_round_trip, 0);
  std::string appended = "a,";
  append_exact(appended, 0.25);
  EXPECT_EQ(appended, "a,0.25");
}

}  // namespace
}  // namespace pfm
