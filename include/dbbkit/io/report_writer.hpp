#pragma once
// One interface for the pages of the reports, with two writers: HTML (self-contained,
// plots inline as SVG, no network) and Markdown (tables only, for CI logs). A command's
// report (reports.hpp) writes its sections once, through this interface.

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "dbbkit/design.hpp"
#include "dbbkit/io/escape.hpp"

namespace dbbkit::io {

enum class ReportFormat { kHtml, kMarkdown };

class ReportWriter {
 public:
  virtual ~ReportWriter() = default;
  virtual void heading(const std::string& text, int level = 2) = 0;
  virtual void paragraph(const std::string& text) = 0;
  virtual void bullets(const std::vector<std::string>& items) = 0;  // escaped
  virtual void preformatted(const std::string& text) = 0;
  virtual void table(const std::vector<std::string>& header,
                     const std::vector<std::vector<std::string>>& rows) = 0;
  // A plot: `svg` is called only by a writer that draws plots (gnuplot runs only then).
  virtual void figure(const std::function<std::string()>& svg, const std::string& caption) = 0;
  // Conditions of the run, a heading and a table written through the two calls above:
  // software version, command, inputs with their SHA-256, noise, error model, assumptions.
  void conditions(const std::string& command, const std::vector<std::string>& inputs,
                  const Design* design);
  virtual std::string str() const = 0;
};

// An HTML page assembled section by section; every plot is a <figure class="plot">, and a
// self-check in the page (id "selfcheck") tells a browser whether every plot was drawn.
class HtmlWriter final : public ReportWriter {
 public:
  explicit HtmlWriter(const std::string& title);
  void heading(const std::string& text, int level = 2) override;
  void paragraph(const std::string& text) override;  // escaped
  void bullets(const std::vector<std::string>& items) override;
  void preformatted(const std::string& text) override;
  void table(const std::vector<std::string>& header,
             const std::vector<std::vector<std::string>>& rows) override;
  void figure(const std::function<std::string()>& svg, const std::string& caption) override;
  std::string str() const override;

 private:
  std::string title_, body_;
};

// The same sections in Markdown; figures are left out (and not drawn).
class MarkdownWriter final : public ReportWriter {
 public:
  explicit MarkdownWriter(const std::string& title);
  void heading(const std::string& text, int level = 2) override;
  void paragraph(const std::string& text) override;
  void bullets(const std::vector<std::string>& items) override;
  void preformatted(const std::string& text) override;
  void table(const std::vector<std::string>& header,
             const std::vector<std::vector<std::string>>& rows) override;
  void figure(const std::function<std::string()>& svg, const std::string& caption) override;
  std::string str() const override { return text_; }

 private:
  std::string text_;
};

std::unique_ptr<ReportWriter> make_report_writer(ReportFormat format, const std::string& title);

}  // namespace dbbkit::io
