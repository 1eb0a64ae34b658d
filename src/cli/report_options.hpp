#pragma once
// Options shared by the commands that write reports, and where output goes:
//   JSON goes to --out (a file, or '-' for stdout); with no --out it goes to
//   stdout when stdout is not a terminal (scripts and pipes get JSON, as
//   formats.md promises), while a terminal gets the aligned tables instead.
//   --quiet leaves only the files asked for.

#include <unistd.h>

#include <CLI/CLI.hpp>
#include <memory>
#include <string>
#include <vector>

#include "dbbkit/io/output.hpp"

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
inline bool json_to_stdout(const std::string& out) {
  return out == "-" || (out.empty() && !stdout_is_terminal());
}

// The human tables go to stdout.
inline bool tables_to_stdout(const std::string& out, bool quiet) {
  return !quiet && out != "-" && (!out.empty() || stdout_is_terminal());
}

// The outputs of a command: --out when JSON goes to a file or to stdout (json_out:
// the --out value, "-" when it is stdout by default), --report and --summary when
// given, and the command's own others. Checked before any work is done (output.hpp).
inline std::vector<io::OutputTarget> output_targets(const std::string& json_out,
                                                    const ReportArgs& rep,
                                                    std::vector<io::OutputTarget> others = {}) {
  std::vector<io::OutputTarget> t;
  if (!json_out.empty()) t.push_back({"--out", json_out});
  if (!rep.report.empty()) t.push_back({"--report", rep.report});
  if (!rep.summary.empty()) t.push_back({"--summary", rep.summary});
  for (io::OutputTarget& o : others) {
    if (!o.path.empty()) t.push_back(std::move(o));
  }
  return t;
}

// The command line as given, for the conditions of a report.
const std::string& command_line();

}  // namespace dbbkit::cli
