#include "dbbkit/diagnose.hpp"

#include <iostream>
#include <memory>
#include <optional>

#include "checks.hpp"
#include "commands.hpp"
#include "dbbkit/error.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/diagnose_io.hpp"
#include "dbbkit/io/json_reader.hpp"
#include "dbbkit/io/measurement_io.hpp"
#include "dbbkit/io/output.hpp"
#include "dbbkit/io/reports.hpp"
#include "dbbkit/io/tolerances_io.hpp"
#include "dbbkit/limits.hpp"
#include "report_options.hpp"

namespace dbbkit::cli {

namespace {
struct DiagnoseArgs {
  std::string design, data, out, tolerances;
  double level = 0.01;
  int max_effects = 12;
  bool exclude_gross = false;
};
}  // namespace

Runner add_diagnose(CLI::App& app) {
  auto args = std::make_shared<DiagnoseArgs>();
  CLI::App* sub = app.add_subcommand("diagnose",
                                     "Find what the model does not explain, add the effects that "
                                     "explain it, report before and after");
  sub->add_option("--design", args->design, "Design file (dbbkit.design/1)")->required();
  sub->add_option("--data", args->data, "Measurement file (CSV)")->required();
  sub->add_option("--out", args->out,
                  "Result JSON (dbbkit.diagnose/1); '-': stdout. Absent: JSON on stdout when it is "
                  "not a terminal, "
                  "else the tables");
  auto rep = std::make_shared<ReportArgs>();
  add_report_options(sub, rep);
  sub->add_option("--level", args->level, "Family-wise significance level of each selection step")
      ->check(finite_in(limits::kMinLevel, limits::kMaxLevel))
      ->capture_default_str();
  sub->add_option("--max-effects", args->max_effects, "Most effects added")
      ->transform(integer_in(0, limits::kMaxEffects))
      ->capture_default_str();
  sub->add_flag("--exclude-gross", args->exclude_gross,
                "Refit without the gross readings found (at most 10), and say so in the verdict "
                "and the JSON");
  sub->add_option("--tolerances", args->tolerances,
                  "Tolerance file (dbbkit.tolerances/1): decide the conformance of the corrected "
                  "errors after ISO 14253-1; exit code 1 when a quantity does not conform");
  return [args, rep]() {
    std::vector<std::string> in = {args->design, args->data};
    if (!args->tolerances.empty()) in.push_back(args->tolerances);
    const std::string json_out = json_to_stdout(args->out) ? "-" : args->out;
    io::OutputSet outputs(output_targets(json_out, *rep), in);
    const Design design = io::read_design_file(args->design);
    const std::vector<Reading> readings = io::read_measurement_file(args->data, design);
    std::vector<Tolerance> tolerances;
    if (!args->tolerances.empty()) {
      tolerances = io::read_tolerances_file(args->tolerances);
      check_tolerances(design.axis, tolerances, args->tolerances);  // before the work
    }
    DiagnoseOptions options;
    options.level = args->level;
    options.max_effects = args->max_effects;
    options.exclude_gross = args->exclude_gross;
    const DiagnoseResult result = diagnose(design, readings, options);
    std::optional<ConformanceReport> conformance;
    if (!tolerances.empty())
      conformance = decide_conformance(design, result, tolerances, args->tolerances);
    const ConformanceReport* c = conformance ? &*conformance : nullptr;
    const io::InputFiles inputs{args->design, args->data};
    const io::RunContext run{command_line(), in};
    if (!rep->report.empty()) {
      outputs.stage("--report", io::diagnose_report(io::ReportFormat::kHtml, run, design, readings,
                                                    result, a_priori_expansion(), c));
    }
    if (!rep->summary.empty()) {
      outputs.stage("--summary", io::diagnose_report(io::ReportFormat::kMarkdown, run, design,
                                                     readings, result, a_priori_expansion(), c));
    }
    if (!json_out.empty()) {
      nlohmann::json j = io::diagnose_to_json(design, readings, result, inputs);
      if (c) j["conformance"] = io::conformance_to_json(*c, args->tolerances);
      outputs.stage("--out", io::dump_json(j) + "\n");
    }
    outputs.commit();
    if (tables_to_stdout(args->out, rep->quiet)) {
      std::cout << io::diagnose_summary(design, readings, result);
      if (c) std::cout << io::conformance_text(*c);
    } else if (c && !rep->quiet) {
      std::cerr << io::conformance_line(*c, args->tolerances);
    }
    return c && c->any_nonconforming() ? 1 : 0;
  };
}

}  // namespace dbbkit::cli
