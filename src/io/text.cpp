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

void add_next_items(std::vector<BriefItem>& brief, const std::vector<std::string>& steps) {
  std::vector<std::string> sentences;
  std::string sentence;
  for (const std::string& a : steps) {
    const std::string candidate = sentence.empty() ? "Next: " + a : sentence + "; " + a;
    if (candidate.size() + 1 > kBriefItemMaxChars && !sentence.empty()) {
      sentences.push_back(sentence + ".");
      sentence = "Then: " + a;
    } else {
      sentence = candidate;
    }
  }
  if (!sentence.empty()) sentences.push_back(sentence + ".");
  const std::size_t room = kBriefMaxItems > brief.size() ? kBriefMaxItems - brief.size() : 0;
  for (std::size_t i = 0; i < sentences.size() && i < room; ++i) {
    if (i + 1 == room && i + 1 < sentences.size()) {
      std::string rest = sentences[i];
      for (std::size_t j = i + 1; j < sentences.size(); ++j) rest += " " + sentences[j];
      add_brief_item(brief, "next", rest);
      break;
    }
    add_brief_item(brief, "next", sentences[i]);
  }
}

std::string brief_text(const std::vector<BriefItem>& brief) {
  if (brief.empty()) return "";
  std::string s = "summary:\n";
  for (const BriefItem& b : brief) s += "  - " + b.text + "\n";
  return s + "\n";
}

std::string parked_text(const DesignMachine& machine, int decimals) {
  std::string t;
  for (const DesignMachine::AxisAngle& a : machine.others())
    t += (t.empty() ? "" : ", ") + std::string(1, a.letter) + " at " +
         fmt_rounded(a.angle_deg, decimals) + " deg";
  return t;
}

}  // namespace dbbkit::io
