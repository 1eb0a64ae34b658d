// libFuzzer target: text is data (architecture.md). The input, as any bytes, goes through
// every escaping function (io/escape.hpp), and as a design's name, description and an
// installation's id and description through the reader's rule and, where it is admitted,
// through every writer that takes it: the part program in both dialects, the HTML and
// Markdown writers, the design's JSON. Each output must keep its target's structure; a
// violation traps.
#include <cstdint>
#include <string>

#include "dbbkit/error.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/escape.hpp"
#include "dbbkit/io/program_io.hpp"
#include "dbbkit/io/report_writer.hpp"
#include "dbbkit/program.hpp"
#include "dbbkit/user_text.hpp"

namespace {

using dbbkit::internal::decode_utf8;
using dbbkit::internal::is_control;

void require(bool ok) {
  if (!ok) __builtin_trap();
}

bool printable_ascii(const std::string& s) {
  for (char c : s) {
    if (c < 0x20 || c > 0x7E) return false;
  }
  return true;
}

// Valid UTF-8 without any character the rule calls a control, but line feeds when allowed.
bool clean(const std::string& s, bool line_feeds) {
  for (std::size_t i = 0; i < s.size();) {
    const dbbkit::internal::CodePoint cp = decode_utf8(s, i);
    if (cp.length == 0) return false;
    if (is_control(cp.value) && !(line_feeds && cp.value == '\n')) return false;
    i += cp.length;
  }
  return true;
}

// A small C design with bars, built in code (the writers need a valid one).
dbbkit::Design base_design() {
  dbbkit::Design d;
  d.name = "fuzz";
  d.axis = dbbkit::AxisFrame::c_turntable();
  d.angles_deg = {0, 90, 180, 270};
  d.reference_length_mm = 100;
  for (int k = 0; k < 3; ++k) {
    dbbkit::Installation in;
    in.id = std::string(1, static_cast<char>('a' + k));
    in.L_mm = 100 + 50 * k;
    in.H_mm = 60;
    in.direction = dbbkit::Direction::named(dbbkit::AxisFrame::c_turntable(),
                                            dbbkit::Direction::Kind::kRadial);
    in.bar_mm = 150;
    d.installations.push_back(in);
  }
  return d;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size > 8192) return 0;
  const std::string s(reinterpret_cast<const char*>(data), size);
  using namespace dbbkit::io;

  // The escaping functions, whatever the bytes.
  const std::string h = html_escape(s);
  require(clean(h, false) && h.find_first_of("<>\"'") == std::string::npos);
  const std::string x = xml_escape(s);
  require(clean(x, false) && x.find("\xef\xbf\xbf") == std::string::npos &&
          x.find("\xef\xbf\xbe") == std::string::npos);
  const std::string m = markdown_escape(s);
  require(clean(m, false));
  const std::string q = gnuplot_quote(s);
  require(printable_ascii(q) && q.size() >= 2 && q.front() == '"' && q.back() == '"');
  for (std::size_t i = 1; i + 1 < q.size(); ++i) {
    require(std::string_view("\"'`@$").find(q[i]) == std::string_view::npos);
    if (q[i] == '\\') {
      require(i + 4 < q.size());
      for (int k = 1; k <= 3; ++k) require(q[i + k] >= '0' && q[i + k] <= '7');
      i += 3;
    }
  }
  const std::string l = gnuplot_label(s);
  require(printable_ascii(l) && l.find('"') == std::string::npos);
  const std::string c = program_comment(s, 100);
  require(printable_ascii(c) && c.size() <= 100 && c.find_first_of("()%;") == std::string::npos);
  require(clean(terminal_text(s), false));
  require(clean(dbbkit::quote_value(s), false));

  // The same bytes as a design's texts: refused at the rule, or carried by every writer.
  static const dbbkit::Design base = base_design();
  dbbkit::Design d = base;
  d.name = s.substr(0, 200);
  d.description = s;
  d.installations[0].description = s;
  d.installations[1].id = s.substr(0, 64);
  try {
    dbbkit::validate_design(d, "fuzz");
  } catch (const dbbkit::InputError& e) {
    require(clean(e.what(), true));
    return 0;
  }
  require(!dbbkit::text_problem(d.name, dbbkit::limits::kMaxNameBytes).has_value());
  require(!dbbkit::id_problem(d.installations[1].id).has_value());
  const std::string json = design_to_json(d).dump();  // throws on invalid UTF-8
  require(!json.empty());
  const dbbkit::MeasurementProgram program = dbbkit::measurement_program(d, {});
  for (const Dialect dialect : {Dialect::kIso, Dialect::kHeidenhain}) {
    const std::string text = program_text(d, program, dialect, 1);
    std::size_t start = 0;
    while (start < text.size()) {
      const std::size_t end = text.find('\n', start);
      const std::string line = text.substr(start, end - start);
      require(printable_ascii(line) && line.size() <= kProgramLine);
      require(line == "%" || line.find('%') == std::string::npos);
      if (dialect == Dialect::kIso && line.find('(') != std::string::npos)
        require(line.find('(', line.find('(') + 1) == std::string::npos && line.back() == ')');
      start = end == std::string::npos ? text.size() : end + 1;
    }
  }
  HtmlWriter html(d.name);
  html.paragraph(d.description);
  html.table({d.installations[1].id}, {{d.description}});
  const std::string page = html.str();
  std::size_t scripts = 0;
  for (std::size_t at = page.find("<script"); at != std::string::npos;
       at = page.find("<script", at + 1))
    ++scripts;
  require(scripts == 1 && clean(page, true));
  MarkdownWriter md(d.name);
  md.paragraph(d.description);
  md.preformatted(d.description);
  require(clean(md.str(), true));
  return 0;
}
