#include "dbbkit/identify.hpp"

#include <iostream>
#include <memory>
#include <optional>

#include "commands.hpp"
#include "dbbkit/conformance.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/measurement_io.hpp"
#include "dbbkit/io/output.hpp"
#include "dbbkit/io/reports.hpp"
#include "dbbkit/io/result_io.hpp"
#include "dbbkit/io/tolerances_io.hpp"
#include "dbbkit/setup.hpp"
#include "report_options.hpp"
#include "uncertainty_options.hpp"

namespace dbbkit::cli {

namespace {
struct IdentifyArgs {
  std::string design, data, out, tolerances, effects;
  bool type_a = false, type_a_readings = false;
};
}  // namespace

Runner add_identify(CLI::App& app) {
  auto args = std::make_shared<IdentifyArgs>();
  CLI::App* sub =
      app.add_subcommand("identify", "Identify the six errors of the axis from DBB readings");
  sub->add_option("--design", args->design, "Design file (dbbkit.design/1)")->required();
  sub->add_option("--data", args->data, "Measurement file (CSV)")->required();
  sub->add_option("--out", args->out,
                  "Result JSON (dbbkit.identify/1); '-': stdout. Absent: JSON on stdout when it is "
                  "not a terminal, "
                  "else the tables");
  sub->add_flag(
      "--type-a", args->type_a,
      "Evaluate the reading noise from the residual (Type A, n - rank degrees of freedom) "
      "instead of the declared instrument accuracy");
  sub->add_flag("--type-a-readings", args->type_a_readings,
                "Add each reading's own Type A (the measurement file's u_a_um and u_a_dof, from "
                "its dwell's repeatability: dbbkit readings) to the declared instrument accuracy");
  sub->add_option("--tolerances", args->tolerances,
                  "Tolerance file (dbbkit.tolerances/1): decide conformance after ISO 14253-1; "
                  "exit code 1 when a "
                  "quantity does not conform");
  sub->add_option("--effects", args->effects,
                  "Effects fitted with the errors, as diagnose names them, comma-separated (e.g. "
                  "length_offset[2r],drift[all]): a model fixed once");
  auto unc = std::make_shared<UncertaintyArgs>();
  add_uncertainty_options(sub, unc);
  auto rep = std::make_shared<ReportArgs>();
  add_report_options(sub, rep);
  return [args, unc, rep]() {
    std::vector<std::string> inputs = {args->design, args->data};
    if (!args->tolerances.empty()) inputs.push_back(args->tolerances);
    const std::string json_out = json_to_stdout(args->out) ? "-" : args->out;
    io::OutputSet outputs(output_targets(json_out, *rep), inputs);
    const Design design = io::read_design_file(args->design);
    const std::vector<Reading> readings = io::read_measurement_file(args->data, design);
    std::vector<Tolerance> tolerances;
    if (!args->tolerances.empty()) {
      tolerances = io::read_tolerances_file(args->tolerances);
      check_tolerances(design.axis, tolerances, args->tolerances);  // before the work
    }
    IdentifyOptions options;
    options.effects = effects_from_list(design, args->effects, "--effects");  // before the work
    options.budget.type_a = args->type_a;
    options.budget.coverage_probability = unc->coverage;
    if (args->type_a_readings) {
      if (unc->monte_carlo)
        throw InputError("--type-a-readings", "",
                         "Monte Carlo draws the declared noise only: leave out --monte-carlo");
      options.budget =
          with_reading_type_a(options.budget, readings, args->data, "--type-a-readings");
    }
    options.iso_motion.seed = unc->mc.seed;
    const IdentifyResult result = identify(design, readings, options);
    std::optional<MonteCarloResult> mc;
    if (unc->monte_carlo) {
      report_progress(unc->mc, rep->quiet);
      mc = monte_carlo(design, result, unc->mc);
    }
    // On the intervals the result reports: Monte Carlo's where the linear one is not validated.
    std::optional<ConformanceReport> conformance;
    if (!tolerances.empty()) {
      conformance =
          decide_conformance(design, result, tolerances, args->tolerances, mc ? &*mc : nullptr);
    }
    nlohmann::json j = io::identify_to_json(design, readings, result, {args->design, args->data},
                                            mc ? &*mc : nullptr, false);
    if (conformance) j["conformance"] = io::conformance_to_json(*conformance, args->tolerances);
    const io::RunContext run{command_line(), inputs};
    if (!rep->report.empty()) {
      outputs.stage("--report", io::identify_report(io::ReportFormat::kHtml, run, design, readings,
                                                    result, mc ? &*mc : nullptr,
                                                    conformance ? &*conformance : nullptr));
    }
    if (!rep->summary.empty()) {
      outputs.stage("--summary", io::identify_report(io::ReportFormat::kMarkdown, run, design,
                                                     readings, result, mc ? &*mc : nullptr,
                                                     conformance ? &*conformance : nullptr));
    }
    if (!json_out.empty()) {
      const std::size_t rows =
          std::min(readings.size(), static_cast<std::size_t>(result.estimate.residual_um.size()));
      outputs.stage("--out", io::json_text(j, "readings", rows, [&](std::size_t i) {
                               return io::identify_reading_row(design, readings, result.estimate,
                                                               i);
                             }) + "\n");
    }
    outputs.commit();
    if (tables_to_stdout(args->out, rep->quiet)) {
      std::cout << io::identify_summary(design, result);
      if (mc) std::cout << io::monte_carlo_summary(*mc);
      if (conformance) std::cout << io::conformance_text(*conformance);
    } else if (conformance && !rep->quiet) {
      std::cerr << io::conformance_line(*conformance, args->tolerances);
    }
    return conformance && conformance->any_nonconforming() ? 1 : 0;
  };
}

}  // namespace dbbkit::cli
