#pragma once
// Options shared by the commands that write reports, and where output goes:
//   JSON goes to --out (a file, or '-' for stdout); with no --out it goes to
//   stdout when stdout is not a terminal (scripts and pipes get JSON, as
//   formats.md promises), while a terminal gets the aligned tables instead.
//   --quiet leaves only the files asked for.

#include <CLI/CLI.hpp>
#include <memory>
#include <string>
#include <unistd.h>

namespace dbbkit::cli {

struct ReportArgs {
  std::string report, summary;
  bool quiet = false;
};

inline void add_report_options(CLI::App* sub, const std::shared_ptr<ReportArgs>& args) {
  sub->add_option("--report", args->report, "A self-contained HTML report with plots (gnuplot)");
  sub->add_option("--summary", args->summary, "A Markdown summary (for CI logs)");
  sub->add_flag("--quiet", args->quiet, "No tables and no progress on the terminal");
}

inline bool stdout_is_terminal() { return ::isatty(STDOUT_FILENO) == 1; }

// The JSON result goes to stdout.
inline bool json_to_stdout(const std::string& out) { return out == "-" || (out.empty() && !stdout_is_terminal()); }

// The human tables go to stdout.
inline bool tables_to_stdout(const std::string& out, bool quiet) {
  return !quiet && out != "-" && (!out.empty() || stdout_is_terminal());
}

// The command line as given, for the conditions of a report.
const std::string& command_line();

}  // namespace dbbkit::cli
