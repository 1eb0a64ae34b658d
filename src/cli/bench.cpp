#include <filesystem>
#include <iostream>
#include <memory>
#include <set>
#include <sstream>

#include "checks.hpp"
#include "commands.hpp"
#include "dbbkit/error.hpp"
#include "dbbkit/io/bench_io.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/escape.hpp"
#include "dbbkit/io/json_reader.hpp"
#include "dbbkit/io/output.hpp"
#include "dbbkit/observability.hpp"

namespace dbbkit::cli {

namespace {
struct BenchArgs {
  std::vector<std::string> designs;
  std::string baseline, write_baseline, summary, junit;
  std::optional<double> tolerance;
  io::BenchLimits limits;
  bool quiet = false;
};
}  // namespace

Runner add_bench(CLI::App& app) {
  auto args = std::make_shared<BenchArgs>();
  CLI::App* sub = app.add_subcommand(
      "bench", "Evaluate designs and fail (exit 1) when one got worse than its baseline");
  sub->add_option("designs", args->designs, "Design files (dbbkit.design/1)")->required();
  sub->add_option("--baseline", args->baseline, "Baseline file (dbbkit.designs-baseline/1)");
  sub->add_option(
         "--tolerance", args->tolerance,
         "Relative change of worst_std_um allowed (default: the baseline's tolerance_relative)")
      ->check(finite_in(0, limits::kMaxBenchTolerance));
  sub->add_option(
      "--write-baseline", args->write_baseline,
      "Write the present figures as a new baseline file (with --tolerance, default 0.001); the "
      "designs it records need no baseline of their own");
  sub->add_flag("--allow-new", args->limits.allow_new,
                "A design without a baseline passes (it fails otherwise)");
  sub->add_option("--max-worst-std-um", args->limits.max_worst_std_um,
                  "Fail a design whose worst_std_um [um] is above this (or undetermined)")
      ->check(finite_in(1e-12, 1e12));
  sub->add_option("--max-worst-total-std-um", args->limits.max_worst_total_std_um,
                  "Fail a design whose worst_total_std_um [um] (noise and declared set-up) is "
                  "above this, or "
                  "that declares no set-up tolerance")
      ->check(finite_in(1e-12, 1e12));
  sub->add_option(
         "--max-time-s", args->limits.max_time_s,
         "Fail a design whose predicted measurement time [s] is above this, or that states none")
      ->check(finite_in(1e-12, 1e12));
  sub->add_option("--summary", args->summary, "A Markdown summary of the gate (for CI logs)");
  sub->add_option("--junit", args->junit,
                  "JUnit XML: one test case per design and check, for CI systems");
  sub->add_flag("--quiet", args->quiet,
                "No table on the terminal (the exit code and the files asked for tell the result)");
  return [args]() {
    std::vector<io::OutputTarget> targets;
    if (!args->write_baseline.empty())
      targets.push_back({"--write-baseline", args->write_baseline});
    if (!args->summary.empty()) targets.push_back({"--summary", args->summary});
    if (!args->junit.empty()) targets.push_back({"--junit", args->junit});
    io::BenchLimits limits = args->limits;
    if (!args->write_baseline.empty())
      limits.allow_new = true;  // the baseline being written records them
    std::vector<std::string> inputs = args->designs;
    inputs.push_back(args->baseline);
    io::OutputSet outputs(targets, inputs);
    io::Baseline baseline;
    if (!args->baseline.empty()) baseline = io::read_baseline_file(args->baseline);
    double tol =
        args->tolerance.value_or(args->baseline.empty() ? 0.001 : baseline.tolerance_relative);
    if (!(tol >= 0 && tol < 1)) throw InputError("--tolerance", "", "must be a fraction in [0, 1)");
    std::vector<io::BenchRow> rows;
    std::set<std::string> keys;
    for (const std::string& file : args->designs) {
      const Design d = io::read_design_file(file);
      io::BenchRow row;
      row.file = file;
      row.key = std::filesystem::path(file).filename().string();
      if (!keys.insert(row.key).second) {
        throw InputError(file, "",
                         "two designs share the file name '" + row.key + "' (the baseline key)");
      }
      if (!d.reference_length_mm) {
        throw InputError(file, "reference_length_mm",
                         "needed to express angular uncertainty in um");
      }
      const Evaluation ev = evaluate_design(d, *d.reference_length_mm, {}, {}, std::nullopt);
      row.name = d.name;
      row.axis = d.axis.label();
      row.model = d.errors.describe();
      row.now = {ev.prior.rank,         ev.prior.n_unknowns,
                 ev.worst.worst_std_um, ev.worst.worst_determined_std_um,
                 std::nullopt,          std::nullopt};
      if (ev.worst_total) {
        row.now.worst_total_std_um = ev.worst_total->worst_std_um;
        row.now.worst_total_determined_std_um = ev.worst_total->worst_determined_std_um;
      }
      row.condition_number = ev.prior.condition_number;
      if (d.predicted) row.time_s = d.predicted->time_s;
      if (auto it = baseline.designs.find(row.key); it != baseline.designs.end())
        row.baseline = it->second;
      io::judge(row, tol);
      io::check_row(row, limits);
      rows.push_back(row);
    }
    // With an output on standard output ('-'), the table goes to the error stream, so that
    // what a pipe reads is that output alone.
    const bool stdout_taken =
        args->write_baseline == "-" || args->summary == "-" || args->junit == "-";
    std::ostringstream discarded;
    std::ostream& text = args->quiet ? discarded : stdout_taken ? std::cerr : std::cout;
    text << io::bench_table(rows, tol);
    for (const auto& [key, f] : baseline.designs) {
      if (!keys.count(key))
        text << "note: " << io::terminal_text(key) << " is in the baseline but was not given\n";
    }
    int worse = 0, failed = 0;
    for (const io::BenchRow& r : rows)
      worse += r.state == io::BenchState::kWorse, failed += !r.passed();
    if (!args->write_baseline.empty()) {
      io::Baseline out;
      out.tolerance_relative = tol;
      for (const io::BenchRow& r : rows) out.designs[r.key] = r.now;
      outputs.stage("--write-baseline", io::dump_json(io::baseline_to_json(out)) + "\n");
    }
    if (!args->summary.empty()) outputs.stage("--summary", io::bench_markdown(rows, tol, limits));
    if (!args->junit.empty()) outputs.stage("--junit", io::bench_junit(rows));
    outputs.commit();
    text << rows.size() << " designs, " << worse << " worse than the baseline, " << failed
         << " failed\n";
    for (const auto& [option, file] :
         {std::pair{"--write-baseline", args->write_baseline},
          std::pair{"--summary", args->summary}, std::pair{"--junit", args->junit}}) {
      if (!file.empty() && file != "-") text << "wrote " << option << " " << file << "\n";
    }
    return failed ? 1 : 0;
  };
}

}  // namespace dbbkit::cli
