#pragma once
// One corpus of hostile strings for every writer (architecture.md, "text is data"): what
// would end a gnuplot string, a part program's comment or record, an HTML, Markdown or XML
// context, or fool a terminal. `admitted` says whether the readers take it as a name or a
// description (user_text.hpp): the others must be refused at the reader, and the writers
// must still make them safe when they come from code.

#include <string>
#include <vector>

namespace dbbkit::test {

struct HostileString {
  std::string label;
  std::string text;
  bool admitted;
};

inline std::vector<HostileString> hostile_strings() {
  using namespace std::string_literals;
  return {
      {"newline then a gnuplot shell command", "x\n! touch PWNED\nset title 'y", false},
      {"carriage return", "a\rb", false},
      {"NUL", "a\0b"s, false},
      {"escape sequence", "a\x1b[31mred\x1b[0m", false},
      {"bell, vertical tab, form feed", "a\x07\x0b\x0c", false},
      {"DEL and a C1 control", "a\x7f\xc2\x85", false},
      {"Ctrl-Z", "a\x1a", false},
      {"tab", "a\tb", false},
      {"line separator U+2028",
       "a\xe2\x80\xa8"
       "b",
       false},
      {"paragraph separator U+2029",
       "a\xe2\x80\xa9"
       "b",
       false},
      {"right-to-left override",
       "a\xe2\x80\xae"
       "b",
       false},
      {"arabic letter mark U+061C",
       "a\xd8\x9c"
       "b",
       false},
      {"invalid UTF-8",
       "a\xff\xfe"
       "b",
       false},
      {"overlong slash",
       "a\xc0\xaf"
       "b",
       false},
      {"UTF-16 surrogate",
       "a\xed\xa0\x80"
       "b",
       false},
      {"single quote", "it's", true},
      {"double quote", "say \"hi\"", true},
      {"gnuplot bang", "! touch PWNED", true},
      {"percent", "100 % done %", true},
      {"parentheses", "(M30) (G00 X0)", true},
      {"semicolon", "a; STOP", true},
      {"raw HTML", "<script>alert(1)</script><img src=x onerror=alert(2)>", true},
      {"markdown link and image", "[x](javascript:alert(1)) ![y](http://h/i.png)", true},
      {"markdown code fence", "```\n", false},
      {"backticks", "``` `code` ```", true},
      {"table pipe", "a | b", true},
      {"ampersand entity", "&lt;script&gt; &amp;", true},
      {"XML CDATA end", "]]> <![CDATA[x]]>", true},
      {"non-ASCII",
       "Drehtisch Gr\xc3\xb6\xc3\x9f"
       "e \xe2\x88\x85",
       true},
      {"U+FFFF",
       "a\xef\xbf\xbf"
       "b",
       true},
      {"1 MB", std::string(1 << 20, 'x'), false},
  };
}

}  // namespace dbbkit::test
