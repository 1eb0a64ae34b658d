#pragma once
// Numbers as text, for the words io builds (terminal summaries, reports, verdicts).

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "dbbkit/design.hpp"

namespace dbbkit::io {

// A number with `digits` significant digits (std::setprecision); fmt_opt gives "--" when
// absent.
std::string fmt_num(double x, int digits = 4);
std::string fmt_opt(const std::optional<double>& x, int digits = 4);
// x rounded to `decimals` decimal places, in its shortest form ("100", "0.125").
std::string fmt_rounded(double x, int decimals);

// The other axes of a machine's design as they stand while it is measured: "A at 0 deg, C at 90
// deg" (angles to `decimals` places), empty when it has none.
std::string parked_text(const DesignMachine& machine, int decimals);

// One sentence of a result's first screen (JSON "summary"): `topic` says what it is about
// ("found", "evidence", "changes", "uncertainty", "next", "residual", "determined", "worst",
// "location", "setup").
struct BriefItem {
  std::string topic;
  std::string text;
};
// The longest sentence a summary item may be, in bytes; a summary has at most six.
inline constexpr std::size_t kBriefItemMaxChars = 239;
inline constexpr std::size_t kBriefMaxItems = 6;
// Appends an item (none beyond kBriefMaxItems, none empty); a text over kBriefItemMaxChars (a
// long name from a user's file) is cut at a space with " ...".
void add_brief_item(std::vector<BriefItem>& brief, const std::string& topic,
                    const std::string& text);
// Appends what to do next, in order, as "Next: a; b." items (topic "next"): each sentence within
// kBriefItemMaxChars, the next one beginning "Then: "; the last item the summary has room for
// takes the rest (cut with " ..." when too long). Nothing for no steps.
void add_next_items(std::vector<BriefItem>& brief, const std::vector<std::string>& steps);
// The summary as the terminal's first lines ("summary:" and one "  - " line per item).
std::string brief_text(const std::vector<BriefItem>& brief);

}  // namespace dbbkit::io
