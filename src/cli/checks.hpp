#pragma once
// Range checks of command-line values, applied where the option is read: a value
// outside its range is a parse error naming the option (exit status 2). CLI11's own
// Range lets NaN through (every comparison with NaN is false); these do not.

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>

#include "dbbkit/limits.hpp"
#include "dbbkit/parallel.hpp"

namespace dbbkit::cli {

// A finite number in [lo, hi].
inline CLI::Validator finite_in(double lo, double hi) {
  std::ostringstream desc;
  desc << "FINITE in [" << lo << ", " << hi << "]";
  return CLI::Validator(
      [lo, hi](std::string& s) -> std::string {
        double x = 0;
        std::istringstream in(s);
        in >> x;
        if (in.fail() || !in.eof()) return "'" + s + "' is not a number";
        if (!std::isfinite(x) || !(x >= lo && x <= hi)) {
          std::ostringstream m;
          m << "'" << s << "' is outside [" << lo << ", " << hi << "]";
          return m.str();
        }
        return "";
      },
      desc.str());
}

// A whole number in [lo, hi], written in decimal digits (no sign for lo >= 0, no exponent, no hex).
// Leading zeros are decimal ("010" is 10, as an O-number or a tool is written): the value is
// rewritten in its plain form before CLI11 converts it, which would read a leading 0 as octal. An
// option takes it with ->transform, so that the rewritten value is the one converted.
inline CLI::Validator integer_in(long long lo, long long hi) {
  std::ostringstream desc;
  desc << "INT in [" << lo << ", " << hi << "]";
  return CLI::Validator(
      [lo, hi](std::string& s) -> std::string {
        size_t i = (!s.empty() && s[0] == '-') ? 1 : 0;
        if (i == s.size()) return "'" + s + "' is not a whole number";
        for (size_t k = i; k < s.size(); ++k) {
          if (s[k] < '0' || s[k] > '9') return "'" + s + "' is not a whole number";
        }
        errno = 0;
        const long long x = std::strtoll(s.c_str(), nullptr, 10);
        if (errno == ERANGE || x < lo || x > hi) {
          std::ostringstream m;
          m << "'" << s << "' is outside [" << lo << ", " << hi << "]";
          return m.str();
        }
        s = std::to_string(x);
        return "";
      },
      desc.str());
}

// A seed: a whole number in [0, 2^64 - 1], decimal digits only (so "-1" is not taken as 2^64 - 1);
// leading zeros are decimal, rewritten away as integer_in does (->transform).
inline CLI::Validator seed_value() {
  return CLI::Validator(
      [](std::string& s) -> std::string {
        if (s.empty() || s.size() > 64)
          return "'" + s + "' is not a seed (a whole number in [0, 2^64 - 1])";
        for (char c : s) {
          if (c < '0' || c > '9')
            return "'" + s + "' is not a seed (a whole number in [0, 2^64 - 1])";
        }
        const std::size_t first = std::min(s.find_first_not_of('0'), s.size() - 1);
        const std::string digits = s.substr(first);
        if (digits.size() > 20 || (digits.size() == 20 && digits > "18446744073709551615"))
          return "'" + s + "' is beyond 2^64 - 1";
        s = digits;
        return "";
      },
      "SEED in [0, 2^64-1]");
}

// A path to read or write: never empty ("-" is standard output where the option allows it).
inline CLI::Validator path_value() {
  return CLI::Validator(
      [](std::string& s) -> std::string { return s.empty() ? "an empty path" : ""; }, "PATH");
}

// A thread count: 0 (all hardware threads) up to kMaxThreads.
inline CLI::Validator thread_count() { return integer_in(0, kMaxThreads); }

}  // namespace dbbkit::cli
