#include "dbbkit/user_text.hpp"

#include <atomic>
#include <cstdio>

namespace dbbkit {

namespace internal {

CodePoint decode_utf8(std::string_view s, std::size_t i) {
  const auto byte = [&](std::size_t k) { return static_cast<unsigned char>(s[k]); };
  const unsigned char b0 = byte(i);
  if (b0 < 0x80) return {b0, 1};
  std::size_t n = 0;
  char32_t c = 0, least = 0;
  if ((b0 & 0xE0) == 0xC0) {
    n = 2, c = b0 & 0x1F, least = 0x80;
  } else if ((b0 & 0xF0) == 0xE0) {
    n = 3, c = b0 & 0x0F, least = 0x800;
  } else if ((b0 & 0xF8) == 0xF0) {
    n = 4, c = b0 & 0x07, least = 0x10000;
  } else {
    return {0, 0};
  }
  if (i + n > s.size()) return {0, 0};
  for (std::size_t k = 1; k < n; ++k) {
    if ((byte(i + k) & 0xC0) != 0x80) return {0, 0};
    c = (c << 6) | (byte(i + k) & 0x3F);
  }
  // Overlong forms, UTF-16 surrogates and values beyond Unicode are not UTF-8.
  if (c < least || (c >= 0xD800 && c <= 0xDFFF) || c > 0x10FFFF) return {0, 0};
  return {c, n};
}

bool is_control(char32_t c) {
  return c < 0x20 || (c >= 0x7F && c <= 0x9F) || c == 0x2028 || c == 0x2029 || c == 0x061C ||
         c == 0x200E || c == 0x200F || (c >= 0x202A && c <= 0x202E) || (c >= 0x2066 && c <= 0x2069);
}

}  // namespace internal

namespace {

std::string hex(char32_t c, int digits) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "%0*X", digits, static_cast<unsigned>(c));
  return buf;
}

// One character as an escape: \n, \t, \r, \0, \xNN (a byte), \uNNNN or \UNNNNNNNN (a code point).
std::string escape(char32_t c) {
  switch (c) {
    case '\n':
      return "\\n";
    case '\t':
      return "\\t";
    case '\r':
      return "\\r";
    case 0:
      return "\\0";
    default:
      // Four hex digits within the Basic Multilingual Plane, eight beyond it (as C and Python
      // write them: four digits of U+1F600 would read as U+1F60 and a 0).
      return c < 0x80 ? "\\x" + hex(c, 2) : c <= 0xFFFF ? "\\u" + hex(c, 4) : "\\U" + hex(c, 8);
  }
}

}  // namespace

std::optional<std::string> text_problem(std::string_view text, std::size_t max_bytes) {
  if (text.size() > max_bytes) {
    return "longer than " + std::to_string(max_bytes) + " bytes (" + std::to_string(text.size()) +
           ")";
  }
  std::size_t chars = 0;
  for (std::size_t i = 0; i < text.size();) {
    const internal::CodePoint cp = internal::decode_utf8(text, i);
    ++chars;
    if (cp.length == 0) {
      return "not valid UTF-8 (byte 0x" + hex(static_cast<unsigned char>(text[i]), 2) +
             " at byte " + std::to_string(i + 1) + ")";
    }
    if (internal::is_control(cp.value)) {
      return "a control character U+" + hex(cp.value, 4) + " at character " +
             std::to_string(chars) + " (line breaks, tabs, NUL, escape sequences and " +
             "direction controls are not text dbbkit writes anywhere)";
    }
    i += cp.length;
  }
  return std::nullopt;
}

std::optional<std::string> id_problem(std::string_view id) {
  if (id.empty()) return "empty id";
  if (auto p = text_problem(id, limits::kMaxIdBytes)) return p;
  const auto alnum = [](char c) {
    return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9');
  };
  if (!alnum(id.front())) return "an id starts with a letter or a digit";
  for (std::size_t i = 0; i < id.size();) {
    const char c = id[i];
    if (!alnum(c) && c != '-' && c != '_' && c != '.' && c != '+' && c != ':') {
      // The whole character, not its first byte: text_problem has checked the UTF-8.
      const internal::CodePoint cp = internal::decode_utf8(id, i);
      return std::string("an id holds ASCII letters, digits and - _ . + : only (not '") +
             (cp.value < 0x80 && cp.value >= 0x20 ? std::string(1, c) : escape(cp.value)) + "')";
    }
    ++i;
  }
  return std::nullopt;
}

std::string printable(std::string_view text, std::size_t max_bytes, bool keep_lines) {
  // max_bytes bounds the text read (an escape may make the output longer).
  std::string out;
  std::size_t i = 0;
  for (; i < text.size() && i < max_bytes;) {
    const internal::CodePoint cp = internal::decode_utf8(text, i);
    if (cp.length == 0) {
      out += "\\x" + hex(static_cast<unsigned char>(text[i]), 2);
      ++i;
      continue;
    }
    if (internal::is_control(cp.value) && !(keep_lines && (cp.value == '\n' || cp.value == '\t'))) {
      out += escape(cp.value);
    } else {
      out.append(text.substr(i, cp.length));
    }
    i += cp.length;
  }
  if (i < text.size()) out += "... (" + std::to_string(text.size()) + " bytes)";
  return out;
}

std::string quote_value(std::string_view text, std::size_t max_chars) {
  std::string out = "'";
  std::size_t i = 0, chars = 0;
  for (; i < text.size() && chars < max_chars; ++chars) {
    const internal::CodePoint cp = internal::decode_utf8(text, i);
    if (cp.length == 0) {
      out += "\\x" + hex(static_cast<unsigned char>(text[i]), 2);
      ++i;
      continue;
    }
    if (internal::is_control(cp.value)) {
      out += escape(cp.value);
    } else if (cp.value == '\'' || cp.value == '\\') {
      out += "\\";
      out += static_cast<char>(cp.value);
    } else {
      out.append(text.substr(i, cp.length));
    }
    i += cp.length;
  }
  out += "'";
  if (i < text.size()) out += "... (" + std::to_string(text.size()) + " bytes)";
  return out;
}

namespace {
std::atomic<OptionStyle> g_option_style{OptionStyle::kCommandLine};
}  // namespace

void set_option_style(OptionStyle style) { g_option_style = style; }
OptionStyle option_style() { return g_option_style; }

std::string option_name(std::string_view name) {
  if (g_option_style != OptionStyle::kPython) return std::string(name);
  if (name == "--start") return "start_s";
  if (name == "--trace") return "traces";
  std::string out(name.substr(name.rfind("--", 0) == 0 ? 2 : 0));
  for (char& c : out) c = c == '-' ? '_' : c;
  return out;
}

std::string option_with_value(std::string_view name, std::string_view value) {
  if (g_option_style != OptionStyle::kPython) return std::string(name) + " " + std::string(value);
  return option_name(name) + "=" + quote_value(value);
}

}  // namespace dbbkit
