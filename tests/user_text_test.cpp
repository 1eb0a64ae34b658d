// Text is data (architecture.md): the readers' rule (user_text.hpp) and one escaping
// function per target (io/escape.hpp), each checked against the one corpus of hostile
// strings (hostile_strings.hpp) for the property its target needs.

#include "dbbkit/user_text.hpp"

#include <gtest/gtest.h>
#include <stdlib.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "dbbkit/error.hpp"
#include "dbbkit/instrument.hpp"
#include "dbbkit/io/escape.hpp"
#include "hostile_strings.hpp"

namespace dbbkit {
namespace {

using test::hostile_strings;

// Every byte is printable ASCII.
bool printable_ascii(const std::string& s) {
  for (char c : s) {
    if (c < 0x20 || c > 0x7E) return false;
  }
  return true;
}

// Valid UTF-8 with no character the rule calls a control.
bool clean_text(const std::string& s) { return !text_problem(s, s.size()).has_value(); }

TEST(UserText, TheReadersRuleAdmitsExactlyTheAdmittedStrings) {
  for (const auto& h : hostile_strings()) {
    EXPECT_EQ(!text_problem(h.text, limits::kMaxTextBytes).has_value(), h.admitted) << h.label;
  }
  EXPECT_FALSE(text_problem("", limits::kMaxNameBytes).has_value());
  EXPECT_NE(text_problem(std::string(201, 'a'), limits::kMaxNameBytes)->find("longer than 200"),
            std::string::npos);
  EXPECT_NE(text_problem("a\nb", 10)->find("U+000A at character 2"), std::string::npos);
  EXPECT_NE(text_problem("ab\xff", 10)->find("byte 0xFF at byte 3"), std::string::npos);
}

TEST(UserText, AnIdIsAsciiLettersDigitsAndAFewMarks) {
  for (const char* ok : {"1r", "2t", "a", "pos_3.r", "B+1", "x:y", "A-2"})
    EXPECT_FALSE(id_problem(ok).has_value()) << ok;
  for (const char* bad : {"", "-1", "+x", "=cmd", "@x", "1 r", "1,r", "1(r", "1%", "1\"", "1'",
                          "1;", "\xc3\xa4", "a/b"})
    EXPECT_TRUE(id_problem(bad).has_value()) << bad;
  EXPECT_TRUE(id_problem(std::string("a\0b", 3)).has_value());
  EXPECT_TRUE(id_problem(std::string(65, 'a')).has_value());
  EXPECT_FALSE(id_problem(std::string(64, 'a')).has_value());
  // A character outside ASCII is named whole (U+00E4), not by its first byte (0xC3).
  const std::string umlaut = *id_problem("a\xc3\xa4");
  EXPECT_NE(umlaut.find("\\u00E4"), std::string::npos) << umlaut;
  EXPECT_EQ(umlaut.find("\\xC3"), std::string::npos) << umlaut;
  EXPECT_NE(id_problem("a\xf0\x9f\x98\x80")->find("'\\U0001F600'"), std::string::npos)
      << *id_problem("a\xf0\x9f\x98\x80");
}

TEST(UserText, ASpheresIdTooLongIsToldSoAtAnyLength) {
  // A sphere's channels add ":x", so its id has two bytes less than an id: one message for
  // every length beyond it, not one up to an id's limit and another past it.
  for (std::size_t n :
       {limits::kMaxIdBytes - 1, limits::kMaxIdBytes, limits::kMaxIdBytes + 1, std::size_t{300}}) {
    const auto p = sphere_id_problem(std::string(n, 's'));
    ASSERT_TRUE(p.has_value()) << n;
    EXPECT_NE(p->find("a sphere's id is at most " + std::to_string(limits::kMaxIdBytes - 2)),
              std::string::npos)
        << *p;
    EXPECT_NE(p->find("this one has " + std::to_string(n)), std::string::npos) << *p;
  }
  EXPECT_FALSE(sphere_id_problem(std::string(limits::kMaxIdBytes - 2, 's')).has_value());
}

TEST(UserText, AQuotedValueIsShortAndPrintable) {
  for (const auto& h : hostile_strings()) {
    const std::string q = quote_value(h.text);
    EXPECT_TRUE(clean_text(q)) << h.label << ": " << q;
    EXPECT_LE(q.size(), 60u * 6 + 40) << h.label;  // 60 characters of at most \uXXXX each
  }
  EXPECT_EQ(quote_value("a\nb"), "'a\\nb'");
  EXPECT_EQ(quote_value(std::string("a\0b", 3)), "'a\\0b'");
  EXPECT_EQ(quote_value("it's"), "'it\\'s'");
  EXPECT_EQ(quote_value(std::string(100, 'x'), 5), "'xxxxx'... (100 bytes)");
}

TEST(UserText, AnInputErrorCarriesNoControlCharacterAndNoMegabytes) {
  const InputError e(std::string("f\0ile", 5), std::string(1 << 20, 'k'),
                     "bad \x1b[2J value " + std::string(1 << 20, 'v'));
  const std::string what = e.what();
  EXPECT_EQ(what.find('\x1b'), std::string::npos);
  EXPECT_EQ(what.find('\0'), std::string::npos);
  EXPECT_NE(what.find("f\\0ile"), std::string::npos);
  EXPECT_LT(what.size(), 4000u);
  EXPECT_NE(what.find("(1048576 bytes)"), std::string::npos);
  // Line breaks of a multi-line detail (gnuplot's messages) stay.
  EXPECT_NE(InputError("f", "", "a\nb").detail().find('\n'), std::string::npos);
}

TEST(Escape, HtmlLeavesNoMarkupAndValidUtf8) {
  for (const auto& h : hostile_strings()) {
    const std::string e = io::html_escape(h.text);
    EXPECT_EQ(e.find_first_of("<>\"'"), std::string::npos) << h.label;
    EXPECT_TRUE(clean_text(e)) << h.label;
    // Every & starts an entity this function wrote.
    for (size_t at = e.find('&'); at != std::string::npos; at = e.find('&', at + 1)) {
      const std::string rest = e.substr(at, 6);
      EXPECT_TRUE(rest.rfind("&amp;", 0) == 0 || rest.rfind("&lt;", 0) == 0 ||
                  rest.rfind("&gt;", 0) == 0 || rest.rfind("&quot;", 0) == 0 ||
                  rest.rfind("&#39;", 0) == 0)
          << h.label;
    }
  }
  EXPECT_EQ(io::html_escape("<a href='x'>&"), "&lt;a href=&#39;x&#39;&gt;&amp;");
}

TEST(Escape, XmlHoldsOnlyCharactersXml10Allows) {
  for (const auto& h : hostile_strings()) {
    const std::string e = io::xml_escape(h.text);
    EXPECT_TRUE(clean_text(e)) << h.label;
    EXPECT_EQ(e.find("\xef\xbf\xbf"), std::string::npos) << h.label;  // U+FFFF
    EXPECT_EQ(e.find_first_of("<>"), std::string::npos) << h.label;
  }
}

TEST(Escape, MarkdownStartsNoHtmlLinkOrCodeAndStaysOneLine) {
  for (const auto& h : hostile_strings()) {
    const std::string e = io::markdown_escape(h.text);
    EXPECT_EQ(e.find('\n'), std::string::npos) << h.label;
    EXPECT_TRUE(clean_text(e)) << h.label;
    for (size_t i = 0; i < e.size(); ++i) {
      // Count the backslashes before i: an odd number escapes the character.
      size_t k = 0;
      while (k < i && e[i - 1 - k] == '\\') ++k;
      const bool escaped = k % 2 == 1;
      const char c = e[i], next = i + 1 < e.size() ? e[i + 1] : 0;
      if (c == '<' && (std::isalpha(static_cast<unsigned char>(next)) || next == '/' ||
                       next == '!' || next == '?'))
        EXPECT_TRUE(escaped) << h.label << ": " << e;
      if (c == '`' || c == '|') EXPECT_TRUE(escaped) << h.label << ": " << e;
      if (c == '(' && i > 0 && e[i - 1] == ']') EXPECT_TRUE(escaped) << h.label << ": " << e;
    }
  }
  EXPECT_EQ(io::markdown_escape("<b>x</b> p < 1"), "\\<b>x\\</b> p < 1");
  EXPECT_EQ(io::markdown_escape("[x](y) length_offset[1r]"), "\\[x]\\(y) length_offset[1r]");
  // A name that would open a block where it starts a line: a heading, a quote, a list, a rule,
  // an ordered list, a code block.
  EXPECT_EQ(io::markdown_escape("# C table", true), "\\# C table");
  EXPECT_EQ(io::markdown_escape("> quoted", true), "\\> quoted");
  EXPECT_EQ(io::markdown_escape("- item", true), "\\- item");
  EXPECT_EQ(io::markdown_escape("***", true), "\\***");
  EXPECT_EQ(io::markdown_escape("12. run", true), "12\\. run");
  EXPECT_EQ(io::markdown_escape("3) run", true), "3\\) run");
  EXPECT_EQ(io::markdown_escape("    code", true), "&#32;&#32;&#32;&#32;code");
  EXPECT_EQ(io::markdown_escape("run 12. x - y", true), "run 12. x - y");
  // Within a line (a table's cell, a heading's text) a number stays as it is.
  EXPECT_EQ(io::markdown_escape("-1.25"), "-1.25");
}

TEST(Escape, GnuplotStringsHaveNoLineBreakAndCloseWhereTheyShould) {
  for (const auto& h : hostile_strings()) {
    const std::string q = io::gnuplot_quote(h.text);
    ASSERT_GE(q.size(), 2u);
    EXPECT_TRUE(printable_ascii(q)) << h.label;
    EXPECT_EQ(q.front(), '"') << h.label;
    EXPECT_EQ(q.back(), '"') << h.label;
    // Inside the quotes no quote, backquote, macro sign or dollar; a backslash only as an octal
    // escape of three digits: the literal ends only at the last character.
    const std::string inner = q.substr(1, q.size() - 2);
    EXPECT_EQ(inner.find_first_of("\"'`@$"), std::string::npos) << h.label << ": " << q;
    for (size_t i = 0; i < inner.size(); ++i) {
      if (inner[i] == '\\') {
        ASSERT_LT(i + 3, inner.size() + 0) << h.label;
        for (int k = 1; k <= 3; ++k) EXPECT_TRUE(inner[i + k] >= '0' && inner[i + k] <= '7');
        i += 3;
      }
    }
    const std::string l = io::gnuplot_label(h.text);
    EXPECT_TRUE(printable_ascii(l)) << h.label;
    EXPECT_EQ(l.find('"'), std::string::npos) << h.label;
  }
}

TEST(Escape, ProgramCommentsAreShortPrintableAsciiWithoutStructure) {
  for (const auto& h : hostile_strings()) {
    const std::string c = io::program_comment(h.text, 200);
    EXPECT_TRUE(printable_ascii(c)) << h.label;
    EXPECT_EQ(c.find_first_of("()%;"), std::string::npos) << h.label;
    EXPECT_LE(c.size(), 200u) << h.label;
  }
  EXPECT_EQ(io::program_comment("(M30) 5 %", 100), "[M30] 5 pct");
  EXPECT_EQ(io::program_comment(std::string(300, 'a'), 10), "aaaaaaa...");
}

TEST(Escape, TerminalTextHasNoControlCharacter) {
  for (const auto& h : hostile_strings()) {
    EXPECT_TRUE(clean_text(io::terminal_text(h.text))) << h.label;
  }
}

// gnuplot itself (the version setup.sh installs) reads every quoted name back as the text's
// printable ASCII: two apostrophes ("12'' rotary table"), four, quotes of both kinds, a
// backquoted command, a macro sign, a backslash and the hostile strings.
TEST(Escape, GnuplotReadsEveryQuotedNameBackAsWritten) {
  std::vector<std::string> names = {
      "12'' rotary table", "''''", "a''''b", "\"x\"'y'", "`touch /tmp/dbbkit-gnuplot-backquote`",
      "@x $y \\n \\047"};
  for (const auto& h : hostile_strings()) names.push_back(h.text);
  char dir[] = "/tmp/dbbkit-gnuplot-XXXXXX";
  ASSERT_NE(mkdtemp(dir), nullptr);
  const std::string script = std::string(dir) + "/names.gp", out = std::string(dir) + "/out.txt";
  {
    std::ofstream s(script);
    s << "set print " << io::gnuplot_quote(out) << "\n";
    for (const std::string& n : names) s << "print " << io::gnuplot_quote(n) << "\n";
  }
  ASSERT_EQ(std::system(("gnuplot " + script + " 2>" + dir + "/err.txt").c_str()), 0);
  std::ifstream in(out);
  std::string line;
  for (const std::string& n : names) {
    ASSERT_TRUE(std::getline(in, line)) << n;
    // What gnuplot prints is what the quoting kept: the text as printable ASCII.
    std::string expected = io::gnuplot_quote(n);
    std::string decoded;
    for (std::size_t i = 1; i + 1 < expected.size(); ++i) {
      if (expected[i] == '\\') {
        decoded += static_cast<char>((expected[i + 1] - '0') * 64 + (expected[i + 2] - '0') * 8 +
                                     (expected[i + 3] - '0'));
        i += 3;
      } else {
        decoded += expected[i];
      }
    }
    EXPECT_EQ(line, decoded) << n;
    if (n == names[0]) EXPECT_EQ(line, "12'' rotary table");
    if (n == names[1]) EXPECT_EQ(line, "''''");
  }
  EXPECT_FALSE(std::ifstream("/tmp/dbbkit-gnuplot-backquote").good());
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace dbbkit
