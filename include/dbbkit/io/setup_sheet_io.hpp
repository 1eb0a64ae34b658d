#pragma once
// The set-up sheet in words and drawings: a page of its own (`dbbkit setup-sheet`, HTML with a
// drawing per installation, or Markdown), a section of the optimize report, and a summary for
// the terminal.

#include <string>

#include "dbbkit/io/report_writer.hpp"
#include "dbbkit/io/reports.hpp"
#include "dbbkit/setup_sheet.hpp"

namespace dbbkit::io {

// The sheet's sections, from a heading at `level`.
void write_setup_sheet(ReportWriter& w, const SetupSheet& sheet, const std::string& kit_file,
                       int level = 2);

// The sheet as a page: the conditions of the run, then the sheet.
std::string setup_sheet_report(ReportFormat format, const RunContext& run, const SetupSheet& sheet,
                               const std::string& kit_file);

// The order and the steps in a few lines.
std::string setup_sheet_summary(const SetupSheet& sheet);

// One installation drawn to scale (SVG): C, the table from above and the plane of the ball
// through the axis from the side (cup, blocks, both balls, the bar); B, the head in the swing
// plane (pivot, tool axis, ball, the table's ball, the bar). At the first angle of the program.
std::string installation_drawing(const SetupSheet& sheet, int step);

}  // namespace dbbkit::io
