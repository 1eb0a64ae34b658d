#pragma once
// Numbers as text, the one implementation behind io's formatters (io/text.hpp) and the
// labels and notes the library still writes (effect labels, choice labels, the meaning of
// an undetermined combination); and the one join of a set of effects' labels. Internal to
// the library.

#include <cmath>
#include <iomanip>
#include <sstream>
#include <string>
#include <vector>

namespace dbbkit::text {

// x with `digits` significant digits (std::setprecision, shortest form).
inline std::string significant(double x, int digits) {
  std::ostringstream s;
  s << std::setprecision(digits) << x;
  return s.str();
}

// x rounded to `decimals` decimal places, in its shortest form ("100", "0.125").
inline std::string rounded(double x, int decimals) {
  const double p = std::pow(10.0, decimals);
  std::ostringstream s;
  s << std::round(x * p) / p + 0.0;  // + 0.0: a value rounding to zero prints 0, never -0
  return s.str();
}

// "a + b" for a set of effects.
inline std::string joined(const std::vector<std::string>& labels) {
  std::string out;
  for (const std::string& l : labels) out += (out.empty() ? "" : " + ") + l;
  return out;
}

}  // namespace dbbkit::text
