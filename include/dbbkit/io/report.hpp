#pragma once
// Reports people read: one self-contained HTML file per run (plots inline as
// SVG drawn by gnuplot, no network), and a Markdown summary for CI logs. The
// pieces here are shared by every command's report.

#include <optional>
#include <string>
#include <vector>

#include "dbbkit/design.hpp"
#include "dbbkit/identify.hpp"

namespace dbbkit::io {

// SHA-256 of a file's bytes, as 64 hex digits (FIPS 180-4).
std::string sha256_hex(const std::string& bytes);
std::string sha256_file(const std::string& path);

// Runs gnuplot on a script (its terminal and output are set here: SVG, white
// background) and returns the SVG. Throws InputError naming "--report" when
// gnuplot is not installed or fails.
std::string gnuplot_svg(const std::string& script, int width_px = 760, int height_px = 380);

// One line of a line plot; lo/hi (same length as x, or empty) draw a band.
// NaN values are gaps (a value the data cannot determine).
struct PlotSeries {
  std::string title;
  std::vector<double> x, y, lo, hi;
  std::string style = "linespoints";  // gnuplot style of the line: linespoints, lines, points
};
std::string plot_series(const std::string& title, const std::string& xlabel,
                        const std::string& ylabel, const std::vector<PlotSeries>& series,
                        int width_px = 760, int height_px = 380);

// The design drawn in its body frame (the machine frame at angle 0): a top
// view (x, y) and a side view (x, z) with every ball position, its id, and the
// bar to the following ball (or the reading direction, 40 mm, when no bar is given).
std::string plot_design(const Design& design);

// The six errors against angle, translations and rotations in two panels: the
// value (or 0 for an a-priori evaluation) with a band of +-U, U = k u.
std::string plot_errors(const std::vector<ErrorsAtAngle>& errors, bool values, double k,
                        const std::string& title);

// A heat map of z over a grid (x fastest); NaN cells are left blank.
std::string plot_heatmap(const std::string& title, const std::string& xlabel,
                         const std::string& ylabel, const std::string& zlabel,
                         const std::vector<double>& x, const std::vector<double>& y,
                         const std::vector<double>& z);

std::string html_escape(const std::string& s);

// An HTML page assembled section by section; every plot is a <figure class="plot">.
class HtmlReport {
 public:
  explicit HtmlReport(const std::string& title);
  void heading(const std::string& text, int level = 2);
  void paragraph(const std::string& text);  // escaped
  void preformatted(const std::string& text);
  void table(const std::vector<std::string>& header,
             const std::vector<std::vector<std::string>>& rows);
  void figure(const std::string& svg, const std::string& caption);
  // Conditions of the run: software version, command, inputs with their SHA-256, noise,
  // assumptions.
  void conditions(const std::string& command, const std::vector<std::string>& inputs,
                  const Design* design);
  std::string str() const;
  int n_figures() const { return figures_; }

 private:
  std::string title_, body_;
  int figures_ = 0;
};

// The same sections in Markdown (no plots): headings, paragraphs, tables.
class MarkdownSummary {
 public:
  explicit MarkdownSummary(const std::string& title);
  void heading(const std::string& text, int level = 2);
  void paragraph(const std::string& text);
  void preformatted(const std::string& text);
  void table(const std::vector<std::string>& header,
             const std::vector<std::vector<std::string>>& rows);
  void conditions(const std::string& command, const std::vector<std::string>& inputs,
                  const Design* design);
  std::string str() const { return text_; }

 private:
  std::string text_;
};

// The errors as table rows: angle, then value +- U (or U alone) per error; "--" where not
// determined.
std::vector<std::vector<std::string>> errors_rows(const std::vector<ErrorsAtAngle>& errors,
                                                  bool values, double k);
std::vector<std::string> errors_header(bool values);

// Formats a number with `digits` significant digits; fmt_opt gives "--" when absent.
std::string fmt_num(double x, int digits = 4);
std::string fmt_opt(const std::optional<double>& x, int digits = 4);

}  // namespace dbbkit::io
