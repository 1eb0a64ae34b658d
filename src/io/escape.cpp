#include "dbbkit/io/escape.hpp"

#include <cctype>

#include "dbbkit/user_text.hpp"

namespace dbbkit::io {

namespace {

constexpr std::string_view kReplacement = "\xEF\xBF\xBD";  // U+FFFD

// Calls f(code point, its bytes) for each valid character that is not a control, and
// bad() for each invalid byte or control character.
template <typename Good, typename Bad>
void for_each_char(std::string_view s, Good good, Bad bad) {
  for (std::size_t i = 0; i < s.size();) {
    const internal::CodePoint cp = internal::decode_utf8(s, i);
    if (cp.length == 0) {
      bad();
      ++i;
      continue;
    }
    if (internal::is_control(cp.value)) {
      bad();
    } else {
      good(cp.value, s.substr(i, cp.length));
    }
    i += cp.length;
  }
}

// Printable ASCII, each other character (or invalid byte) as '?'.
std::string ascii(std::string_view s) {
  std::string out;
  for_each_char(
      s, [&](char32_t c, std::string_view) { out += c < 0x7F ? static_cast<char>(c) : '?'; },
      [&]() { out += '?'; });
  return out;
}

}  // namespace

std::string html_escape(std::string_view s) {
  std::string out;
  out.reserve(s.size());
  for_each_char(
      s,
      [&](char32_t c, std::string_view bytes) {
        switch (c) {
          case '&':
            out += "&amp;";
            break;
          case '<':
            out += "&lt;";
            break;
          case '>':
            out += "&gt;";
            break;
          case '"':
            out += "&quot;";
            break;
          case '\'':
            out += "&#39;";
            break;
          default:
            out += bytes;
        }
      },
      [&]() { out += kReplacement; });
  return out;
}

std::string xml_escape(std::string_view s) {
  // html_escape already keeps only characters XML 1.0 allows but U+FFFE and U+FFFF.
  std::string out;
  const std::string html = html_escape(s);
  for_each_char(
      html,
      [&](char32_t c, std::string_view bytes) {
        if (c == 0xFFFE || c == 0xFFFF) {
          out += kReplacement;
        } else {
          out += bytes;
        }
      },
      [&]() { out += kReplacement; });
  return out;
}

std::string markdown_escape(std::string_view s, bool line_start) {
  std::string out;
  out.reserve(s.size());
  char before = 0;  // the previous character (0 at the start)
  // Where the text may open a block (a heading, a quote, a list, a rule, a fence, a setext
  // line): its first non-blank character, and an ordered list's '.' or ')' after digits.
  bool opening = line_start, digits = false;
  for_each_char(
      s,
      [&](char32_t c, std::string_view bytes) {
        const std::size_t at = static_cast<std::size_t>(bytes.data() - s.data());
        const char next = at + 1 < s.size() ? s[at + 1] : 0;
        const bool tag_start = (next >= 'A' && next <= 'Z') || (next >= 'a' && next <= 'z') ||
                               next == '/' || next == '!' || next == '?';
        bool escape = false;
        if (opening && c == ' ') {
          out += "&#32;";  // four blanks would open a code block
          before = ' ';
          return;
        }
        if (opening && c < 128 &&
            std::string_view("#>-+*=_~").find(static_cast<char>(c)) != std::string_view::npos)
          escape = true;
        if (digits && (c == '.' || c == ')')) escape = true;
        digits = (opening || digits) && c >= '0' && c <= '9';
        opening = false;
        switch (c) {
          case '\\':
          case '`':
          case '|':
            escape = true;
            break;
          case '<':  // raw HTML, a comment or an autolink
            escape = tag_start;
            break;
          case '[':  // a link's or an image's second part, or a definition at the start
            escape = before == 0 || before == ']';
            break;
          case '(':  // an inline link's destination
            escape = before == ']';
            break;
          default:
            break;
        }
        if (escape) out += '\\';
        out += bytes;
        before = bytes.size() == 1 ? bytes[0] : 'x';
      },
      [&]() {
        out += ' ';
        before = ' ';
      });
  return out;
}

std::string gnuplot_quote(std::string_view s) {
  // gnuplot 5.4 ends a single-quoted string at four quotes in a row however they pair, and runs
  // a backquoted command inside a double-quoted one: every character but a letter, a digit and
  // " _.,:/+-=" is written as its octal escape, so that no quote, backquote, @, $ or backslash
  // of the text reaches the parser as itself; a digit after an escape is escaped too (gnuplot
  // reads an octal escape on as long as digits follow).
  std::string out = "\"";
  bool escaped = false;  // the last character was escaped: gnuplot would read a digit on into it
  for (char c : ascii(s)) {
    const bool digit = c >= '0' && c <= '9';
    if (!(digit && escaped) && (std::isalnum(static_cast<unsigned char>(c)) ||
                                std::string_view(" _.,:/+-=").find(c) != std::string_view::npos)) {
      out += c;
      escaped = false;
    } else {
      escaped = true;
      const auto u = static_cast<unsigned char>(c);
      out += {'\\', static_cast<char>('0' + (u >> 6)), static_cast<char>('0' + ((u >> 3) & 7)),
              static_cast<char>('0' + (u & 7))};
    }
  }
  return out + "\"";
}

std::string gnuplot_label(std::string_view s) {
  std::string out = ascii(s);
  for (char& c : out) {
    if (c == '"') c = '\'';
  }
  return out;
}

std::string program_comment(std::string_view s, std::size_t max_chars) {
  std::string out;
  for (char c : ascii(s)) {
    if (c == '(') {
      out += '[';
    } else if (c == ')') {
      out += ']';
    } else if (c == '%') {
      out += "pct";
    } else if (c == ';') {
      out += ',';
    } else {
      out += c;
    }
  }
  if (out.size() > max_chars) out = out.substr(0, max_chars > 3 ? max_chars - 3 : 0) + "...";
  return out;
}

std::string terminal_text(std::string_view s) { return printable(s, s.size()); }

}  // namespace dbbkit::io
