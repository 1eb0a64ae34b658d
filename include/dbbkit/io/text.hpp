#pragma once
// Numbers as text, for the words io builds (terminal summaries, reports, verdicts).

#include <optional>
#include <string>

namespace dbbkit::io {

// A number with `digits` significant digits (std::setprecision); fmt_opt gives "--" when
// absent.
std::string fmt_num(double x, int digits = 4);
std::string fmt_opt(const std::optional<double>& x, int digits = 4);
// x rounded to `decimals` decimal places, in its shortest form ("100", "0.125").
std::string fmt_rounded(double x, int decimals);

}  // namespace dbbkit::io
