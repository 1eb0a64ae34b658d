#include "dbbkit/io/report_writer.hpp"

#include <algorithm>
#include <sstream>

#include "dbbkit/io/escape.hpp"
#include "dbbkit/io/hashing.hpp"
#include "dbbkit/io/text.hpp"

namespace dbbkit::io {

namespace {
// The lines of a text, without their line feeds (a last line without one counts).
std::vector<std::string> split_lines(const std::string& text) {
  std::vector<std::string> lines;
  size_t start = 0;
  while (start < text.size()) {
    const size_t end = text.find('\n', start);
    if (end == std::string::npos) {
      lines.push_back(text.substr(start));
      break;
    }
    lines.push_back(text.substr(start, end - start));
    start = end + 1;
  }
  return lines;
}
}  // namespace

HtmlWriter::HtmlWriter(const std::string& title) : title_(title) {}

void HtmlWriter::heading(const std::string& text, int level) {
  body_ += "<h" + std::to_string(level) + ">" + html_escape(text) + "</h" + std::to_string(level) +
           ">\n";
}
void HtmlWriter::paragraph(const std::string& text) {
  body_ += "<p>" + html_escape(text) + "</p>\n";
}
void HtmlWriter::bullets(const std::vector<std::string>& items) {
  body_ += "<ul>\n";
  for (const std::string& i : items) body_ += "<li>" + html_escape(i) + "</li>\n";
  body_ += "</ul>\n";
}
void HtmlWriter::preformatted(const std::string& text) {
  // Line by line: the line feeds are the block's own; every other control character is the
  // escape's to replace.
  std::string body;
  for (const std::string& line : split_lines(text)) body += html_escape(line) + "\n";
  body_ += "<pre>" + body + "</pre>\n";
}
void HtmlWriter::table(const std::vector<std::string>& header,
                       const std::vector<std::vector<std::string>>& rows) {
  std::string t = "<table><thead><tr>";
  for (const std::string& h : header) t += "<th>" + html_escape(h) + "</th>";
  t += "</tr></thead><tbody>\n";
  for (const auto& row : rows) {
    t += "<tr>";
    for (const std::string& c : row) t += "<td>" + html_escape(c) + "</td>";
    t += "</tr>\n";
  }
  body_ += t + "</tbody></table>\n";
}
void HtmlWriter::figure(const std::function<std::string()>& svg, const std::string& caption) {
  body_ += "<figure class=\"plot\">" + svg() + "<figcaption>" + html_escape(caption) +
           "</figcaption></figure>\n";
}

namespace {
std::vector<std::vector<std::string>> condition_rows(const std::string& command,
                                                     const std::vector<std::string>& inputs,
                                                     const Design* design) {
  std::vector<std::vector<std::string>> rows = {
      {"software", std::string("dbbkit ") + DBBKIT_VERSION}, {"command", command}};
  for (const std::string& f : inputs) {
    if (!f.empty()) rows.push_back({"input " + f, "SHA-256 " + sha256_file(f)});
  }
  if (design) {
    rows.push_back({"noise", design->noise.describe()});
    rows.push_back({"error model", design->errors.describe()});
    if (design->reference_length_mm)
      rows.push_back({"reference length", fmt_num(*design->reference_length_mm) + " mm"});
    for (const auto& [k, v] : design->assumed) rows.push_back({"assumed: " + k, v});
  }
  return rows;
}
}  // namespace

std::string HtmlWriter::str() const {
  std::ostringstream h;
  h << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>"
    << html_escape(title_)
    << "</title>\n<style>body{font-family:sans-serif;max-width:72em;margin:2em auto;padding:0 "
       "1em;color:#222}"
       "table{border-collapse:collapse;margin:0.5em 0}td,th{border:1px solid #bbb;padding:2px 8px;"
       "text-align:right;font-variant-numeric:tabular-nums}th{background:#eee}td:first-child{text-"
       "align:left}"
       "figure{margin:1em 0}figure "
       "svg{max-width:100%;height:auto}figcaption{font-size:90%;color:#555}"
       "pre{background:#f6f6f6;padding:0.5em;overflow-x:auto}</style>\n</head><body>\n<h1>"
    << html_escape(title_) << "</h1>\n"
    << body_
    // A self-check a browser runs on load: every plot present, drawn, and holding data (a
    // gnuplot plot's paths, or the balls and bars of a drawing's <g class="data">); no script
    // error; nothing fetched from elsewhere (the file is self-contained). It stays in the DOM
    // for a test to read and is not shown.
    << "<p id=\"selfcheck\" data-status=\"pending\" "
       "style=\"display:none\"></p>\n<script>\n"
       "window.__errors=[];window.addEventListener('error',function(e){window.__errors.push(String("
       "e.message));});\n"
       "window.addEventListener('load',function(){var "
       "figs=document.querySelectorAll('figure.plot');var bad=[];\n"
       "for(var i=0;i<figs.length;i++){var s=figs[i].querySelector('svg');if(!s){bad.push(i+': no "
       "svg');continue;}\n"
       "var b=s.getBoundingClientRect();var data=0;var "
       "gs=s.querySelectorAll('g[id^=\"gnuplot_plot_\"]');\n"
       "for(var j=0;j<gs.length;j++){var ps=gs[j].querySelectorAll('path,image,use');"
       "for(var k=0;k<ps.length;k++){var "
       "d=ps[k].getAttribute('d');if(ps[k].tagName!=='path'||(d&&d.length>20))data++;}}\n"
       "var ds=s.querySelectorAll('g.data circle,g.data line');data+=ds.length;\n"
       "if(b.width<100||b.height<100)bad.push(i+': not drawn');else if(data===0)bad.push(i+': no "
       "data');}\n"
       "var ext=performance.getEntriesByType('resource').length;var "
       "el=document.getElementById('selfcheck');\n"
       "el.setAttribute('data-status',(bad.length||window.__errors.length||ext)?'fail':'ok');\n"
       "el.textContent='self-check: '+figs.length+' plots, '+bad.length+' empty, "
       "'+window.__errors.length+"
       "' script errors, '+ext+' external resources'+(bad.length?' ('+bad.join('; ')+')':'');});\n"
       "</script>\n</body></html>\n";
  return h.str();
}

MarkdownWriter::MarkdownWriter(const std::string& title)
    : text_("# " + markdown_escape(title) + "\n\n") {}
void MarkdownWriter::heading(const std::string& text, int level) {
  text_ += std::string(static_cast<size_t>(level), '#') + " " + markdown_escape(text) + "\n\n";
}
void MarkdownWriter::paragraph(const std::string& text) {
  text_ += markdown_escape(text, true) + "\n\n";
}
void MarkdownWriter::bullets(const std::vector<std::string>& items) {
  for (const std::string& i : items) text_ += "- " + markdown_escape(i, true) + "\n";
  text_ += "\n";
}
void MarkdownWriter::preformatted(const std::string& text) {
  // A fenced block ends at a fence at least as long as its opening one: the fence is longer
  // than any run of backticks in the text. Control characters but the line feed become '?'.
  std::string body;
  size_t run = 0, longest = 0;
  for (char c : text) {
    run = c == '`' ? run + 1 : 0;
    longest = std::max(longest, run);
  }
  for (const std::string& line : split_lines(text)) body += terminal_text(line) + "\n";
  const std::string fence(std::max<size_t>(3, longest + 1), '`');
  text_ += fence + "\n" + body + fence + "\n\n";
}
void MarkdownWriter::table(const std::vector<std::string>& header,
                           const std::vector<std::vector<std::string>>& rows) {
  std::string t = "|";
  for (const std::string& h : header) t += " " + markdown_escape(h) + " |";
  t += "\n|";
  for (size_t i = 0; i < header.size(); ++i) t += i ? "---:|" : "---|";
  t += "\n";
  for (const auto& row : rows) {
    t += "|";
    for (const std::string& c : row) t += " " + markdown_escape(c) + " |";
    t += "\n";
  }
  text_ += t + "\n";
}
void MarkdownWriter::figure(const std::function<std::string()>&, const std::string&) {}

void ReportWriter::conditions(const std::string& command, const std::vector<std::string>& inputs,
                              const Design* design) {
  heading("Conditions");
  table({"item", "value"}, condition_rows(command, inputs, design));
}

std::unique_ptr<ReportWriter> make_report_writer(ReportFormat format, const std::string& title) {
  if (format == ReportFormat::kHtml) return std::make_unique<HtmlWriter>(title);
  return std::make_unique<MarkdownWriter>(title);
}

}  // namespace dbbkit::io
