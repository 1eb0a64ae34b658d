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

void add_brief_item(std::vector<BriefItem>& brief, const std::string& topic,
                    const std::string& text) {
  if (brief.size() >= kBriefMaxItems || text.empty()) return;
  std::string t = text;
  if (t.size() > kBriefItemMaxChars) {
    const std::size_t cut = t.rfind(' ', kBriefItemMaxChars - 4);
    t = t.substr(0, cut == std::string::npos ? kBriefItemMaxChars - 4 : cut) + " ...";
  }
  brief.push_back({topic, t});
}

std::string brief_text(const std::vector<BriefItem>& brief) {
  if (brief.empty()) return "";
  std::string s = "summary:\n";
  for (const BriefItem& b : brief) s += "  - " + b.text + "\n";
  return s + "\n";
}

}  // namespace dbbkit::io
