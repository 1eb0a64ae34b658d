#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <sstream>

#include "checks.hpp"
#include "commands.hpp"
#include "dbbkit/error.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/measurement_io.hpp"
#include "dbbkit/io/output.hpp"
#include "dbbkit/io/reports.hpp"
#include "dbbkit/io/text.hpp"
#include "dbbkit/io/trace_io.hpp"
#include "dbbkit/limits.hpp"
#include "dbbkit/measurement.hpp"
#include "dbbkit/trace.hpp"
#include "dbbkit/user_text.hpp"
#include "report_options.hpp"

namespace dbbkit::cli {

namespace {
struct ReadingsArgs {
  std::string design, out, columns, unit, sweeps = "ccw";
  std::vector<std::string> traces, starts;
  double dwell_s = 2.0, min_share = 0.5;
  std::optional<double> sample_rate_hz;
};

}  // namespace

Runner add_readings(CLI::App& app) {
  auto args = std::make_shared<ReadingsArgs>();
  CLI::App* sub = app.add_subcommand(
      "readings",
      "Readings from the instrument's raw traces: the dwells found in each installation's "
      "trace, matched in order to the sweep's angles, written as a measurement file");
  sub->add_option("--design", args->design, "Design file (dbbkit.design/1)")->required();
  sub->add_option("--trace", args->traces,
                  "ID=FILE: the trace of installation ID (repeat for each installation)")
      ->required();
  sub->add_option("--start", args->starts,
                  "ID=SECONDS: when the trace of ID began on the test's clock (one for every "
                  "trace, or none: then each trace keeps its own clock and effects over the "
                  "whole test cannot be formed)");
  sub->add_option("--out", args->out, "Measurement CSV; '-' or absent: stdout");
  sub->add_option("--dwell-s", args->dwell_s, "The program's dwell at each angle [s]")
      ->check(finite_in(limits::kMinTraceDwell_s, limits::kMaxDwell_s))
      ->capture_default_str();
  sub->add_option("--min-share", args->min_share,
                  "A dwell is at least this share of --dwell-s long")
      ->check(finite_in(limits::kMinDwellShare, 1))
      ->capture_default_str();
  sub->add_option("--sweeps", args->sweeps,
                  "The program's sweeps: ccw, cw or both (as program --sweeps), or a list in "
                  "order (ccw,cw,ccw, as a truth's schedule.sweeps)")
      ->capture_default_str();
  sub->add_option("--columns", args->columns,
                  "time=NAME,reading=NAME: the trace's columns when not time_s and "
                  "reading_um/reading_mm");
  sub->add_option("--unit", args->unit, "The unit of --columns reading=NAME: um or mm");
  sub->add_option("--sample-rate-hz", args->sample_rate_hz,
                  "The time is a sample index (the time column) or the row's number, at this rate");
  auto rep = std::make_shared<ReportArgs>();
  add_report_options(sub, rep);
  return [args, rep]() {
    std::vector<std::string> inputs = {args->design};
    std::vector<std::pair<std::string, std::string>> traces;
    for (const std::string& t : args->traces) {
      const std::size_t eq = t.find('=');
      if (eq == std::string::npos || eq == 0 || eq + 1 == t.size())
        throw InputError("--trace", quote_value(t), "expected ID=FILE");
      for (const auto& [id, path] : traces) {
        if (id == t.substr(0, eq))
          throw InputError("--trace", quote_value(id), "two traces of one installation");
        std::error_code ec;
        if (path == t.substr(eq + 1) || std::filesystem::equivalent(path, t.substr(eq + 1), ec)) {
          throw InputError("--trace", quote_value(t.substr(eq + 1)),
                           "one file given for installations " + quote_value(id) + " and " +
                               quote_value(t.substr(0, eq)) +
                               ": each installation is a recording of its own");
        }
      }
      traces.emplace_back(t.substr(0, eq), t.substr(eq + 1));
      inputs.push_back(t.substr(eq + 1));
    }
    // --start: each trace's zero on the test's clock, for every trace or none.
    std::map<std::string, double> start;
    for (const std::string& t : args->starts) {
      const std::size_t eq = t.find('=');
      if (eq == std::string::npos || eq == 0 || eq + 1 == t.size())
        throw InputError("--start", quote_value(t), "expected ID=SECONDS");
      const std::string id = t.substr(0, eq);
      if (std::none_of(traces.begin(), traces.end(), [&](const auto& p) { return p.first == id; }))
        throw InputError("--start", quote_value(id), "no --trace of this installation");
      if (start.count(id)) throw InputError("--start", quote_value(id), "given twice");
      const std::string v = t.substr(eq + 1);
      char* end = nullptr;
      const double s = v.find_first_not_of("0123456789+-.eE") == std::string::npos
                           ? std::strtod(v.c_str(), &end)
                           : std::numeric_limits<double>::quiet_NaN();
      if (end != v.c_str() + v.size() || !std::isfinite(s) ||
          std::abs(s) > limits::kMaxTraceStart_s)
        throw InputError("--start", quote_value(t),
                         "expected a number of seconds (decimal, at most 1e11 in size)");
      start[id] = s;
    }
    io::TraceFormat format;
    if (!args->columns.empty()) io::parse_trace_columns(args->columns, format);
    format.unit = args->unit;
    format.sample_rate_hz = args->sample_rate_hz;
    if (!args->unit.empty() && format.reading_column.empty())
      throw InputError("--unit", "", "--unit goes with --columns reading=NAME");
    const std::vector<Sweep> sweeps = sweeps_by_name(args->sweeps, "--sweeps");
    io::OutputSet outputs(output_targets(args->out.empty() ? "-" : args->out, *rep), inputs);
    const Design design = io::read_design_file(args->design);
    // Every id before any trace is read: an id that is none is the option's fault, not a file's.
    for (const auto& [id, path] : traces) check_trace_installation(design, id);
    DwellOptions options;
    options.dwell_s = args->dwell_s;
    options.min_share = args->min_share;
    std::vector<Reading> readings;
    std::vector<Warning> warnings;
    // The traces are kept for the report only (a reading needs its own dwell's samples alone).
    const bool keep = !rep->report.empty() || !rep->summary.empty();
    std::vector<std::unique_ptr<Trace>> kept_traces;
    std::vector<std::unique_ptr<TraceReadings>> kept_found;
    std::vector<io::TraceRun> runs;
    for (std::size_t k = 0; k < traces.size(); ++k) {
      const auto& [id, path] = traces[k];
      auto trace = std::make_unique<Trace>(io::read_trace_file(path, format));
      auto r = std::make_unique<TraceReadings>(
          readings_from_trace(design, id, *trace, sweeps, options, path));
      {  // its range, before it is counted in (its times once on the test's clock)
        std::vector<Reading> own = r->readings;
        for (Reading& g : own) g.time_s.reset();
        validate_readings(design, own, path);
      }
      readings.insert(readings.end(), r->readings.begin(), r->readings.end());
      warnings.insert(warnings.end(), r->warnings.begin(), r->warnings.end());
      if (!rep->quiet) {
        std::cerr << "readings: " << printable(id, 80) << ": " << r->readings.size()
                  << " readings from " << r->search.plateaus.size() << " dwells of "
                  << printable(path, 400) << " (" << trace->time_s.size()
                  << " samples, sample noise " << io::fmt_num(r->search.noise_um, 3) << " um)\n";
      }
      if (keep) {
        runs.push_back({id, path, trace.get(), r.get()});
        kept_traces.push_back(std::move(trace));
        kept_found.push_back(std::move(r));
      }
    }
    if (auto w = put_on_test_clock(design, readings, start, "--start")) warnings.push_back(*w);
    validate_readings(design, readings, "readings");
    std::ostringstream csv;
    io::write_measurements_csv(csv, readings);
    outputs.stage("--out", csv.str());
    const io::RunContext run{command_line(), inputs};
    if (!rep->report.empty())
      outputs.stage("--report", io::readings_report(io::ReportFormat::kHtml, run, design, runs));
    if (!rep->summary.empty()) {
      outputs.stage("--summary",
                    io::readings_report(io::ReportFormat::kMarkdown, run, design, runs));
    }
    outputs.commit();
    if (!rep->quiet) {
      for (const Warning& w : warnings) std::cerr << "WARNING: " << w.text << "\n";
    }
    return 0;
  };
}

}  // namespace dbbkit::cli
