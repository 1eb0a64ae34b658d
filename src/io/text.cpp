#include "dbbkit/io/text.hpp"

#include <iomanip>
#include <sstream>

#include "../number_text.hpp"

namespace dbbkit::io {

std::string fmt_num(double x, int digits) { return text::significant(x, digits); }

std::string fmt_rounded(double x, int decimals) { return text::rounded(x, decimals); }

std::string fmt_opt(const std::optional<double>& x, int digits) {
  return x ? fmt_num(*x, digits) : "--";
}

}  // namespace dbbkit::io

namespace dbbkit::io {

std::string brief_text(const std::vector<BriefItem>& brief) {
  if (brief.empty()) return "";
  std::string s = "summary:\n";
  for (const BriefItem& b : brief) s += "  - " + b.text + "\n";
  return s + "\n";
}

}  // namespace dbbkit::io
