// Numbers as text that reads back to the same double: the outputs' one format.
#pragma once

#include <charconv>
#include <string>

namespace pfm {

/// Appends `v` as printf("%.17g") writes it: std::to_chars with chars_format::general and
/// precision 17 is specified as that conversion (C++17 [charconv.to.chars]), the same bytes
/// without the C library's formatting machinery (a tenth of its time). 17 significant digits
/// read back to the same double.
inline void append_exact(std::string& out, double v) {
  char buffer[32];
  const std::to_chars_result r =
      std::to_chars(buffer, buffer + sizeof buffer, v, std::chars_format::general, 17);
  out.append(buffer, r.ptr);
}

/// append_exact() into a new string.
inline std::string format_exact(double v) {
  std::string out;
  append_exact(out, v);
  return out;
}

}  // namespace pfm
