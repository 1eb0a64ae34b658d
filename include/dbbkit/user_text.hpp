#pragma once
// Text from a user's file is data (architecture.md, "text is data"). The rule has two
// halves: what a reader admits (here), and one escaping function per target that every
// writer calls (io/escape.hpp). What the readers admit:
//   - valid UTF-8 (no overlong forms, no surrogates, nothing above U+10FFFF);
//   - no control character: C0 (U+0000..U+001F, so no NUL, tab, line feed or ESC), DEL,
//     C1 (U+0080..U+009F), the line and paragraph separators U+2028, U+2029, and the
//     bidirectional controls U+061C, U+200E, U+200F, U+202A..U+202E, U+2066..U+2069 (they
//     reorder what a reader sees without changing the bytes);
//   - at most a stated number of bytes (limits below);
//   - an installation id besides: ASCII letters, digits and - _ . + : , starting with a
//     letter or a digit (it names columns, comments of part programs and spreadsheet
//     cells, where a leading = + - @ is a formula).

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>

namespace dbbkit {

namespace limits {
// Bytes of an installation id, of a name (design, kit, pattern), of a free text
// (a description, an assumption, any other string of an input file).
constexpr std::size_t kMaxIdBytes = 64;
constexpr std::size_t kMaxNameBytes = 200;
// A kit's name: the design optimize writes is named after it with kOptimizedSuffix, within
// kMaxNameBytes.
constexpr std::string_view kOptimizedSuffix = "-optimized";
constexpr std::size_t kMaxKitNameBytes = kMaxNameBytes - kOptimizedSuffix.size();
constexpr std::size_t kMaxTextBytes = 4000;
}  // namespace limits

// What is wrong with `text` under the rule above ("a control character U+000A at
// character 3", "longer than 200 bytes (1048576)"), or nullopt when it is admitted.
std::optional<std::string> text_problem(std::string_view text, std::size_t max_bytes);

// The same for an installation id (the stricter character set).
std::optional<std::string> id_problem(std::string_view id);

// A value as a message may quote it: in single quotes, at most `max_chars` characters
// (then "... (N bytes)"), every control character, invalid byte and quote-breaking
// character written as an escape (\n, \t, \0, \xNN, \u2028). Safe on any terminal.
std::string quote_value(std::string_view text, std::size_t max_chars = 60);

// `text` with every control character and invalid byte written as an escape (but line
// feeds and tabs when `keep_lines`), and cut after `max_bytes` of the text ("... (N bytes)"): a
// message's own safety net (InputError passes its parts through it).
std::string printable(std::string_view text, std::size_t max_bytes, bool keep_lines = false);

// How a message names an option of the caller: as the command line spells it ("--dwell-s"),
// or, once the Python module has said so when it is imported (its caller passes keyword
// arguments), as that keyword ("dwell_s"). The library's messages name options through these.
enum class OptionStyle { kCommandLine, kPython };
void set_option_style(OptionStyle style);
OptionStyle option_style();
// "--dwell-s" as the caller knows it: "--dwell-s", or "dwell_s" (--start: start_s, --trace:
// traces, as the Python module names them).
std::string option_name(std::string_view command_line_name);
// An option with one of the values dbbkit knows for it (not the caller's text): "--format isg",
// or "format='isg'".
std::string option_with_value(std::string_view command_line_name, std::string_view value);

namespace internal {
// One UTF-8 sequence at text[i]: its code point and length, or a length of 0 when the
// bytes there are not a valid sequence.
struct CodePoint {
  char32_t value = 0;
  std::size_t length = 0;
};
CodePoint decode_utf8(std::string_view text, std::size_t i);
// A character the rule refuses (a control, a separator, a bidirectional control).
bool is_control(char32_t c);
}  // namespace internal

}  // namespace dbbkit
