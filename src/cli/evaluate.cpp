#include <iostream>
#include <memory>
#include <optional>
#include <vector>

#include "checks.hpp"
#include "commands.hpp"
#include "dbbkit/diagnose.hpp"
#include "dbbkit/error.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/json_reader.hpp"
#include "dbbkit/io/output.hpp"
#include "dbbkit/io/reports.hpp"
#include "dbbkit/io/result_io.hpp"
#include "dbbkit/io/sweep_io.hpp"
#include "dbbkit/io/text.hpp"
#include "dbbkit/limits.hpp"
#include "dbbkit/linear_model.hpp"
#include "dbbkit/observability.hpp"
#include "report_options.hpp"
#include "uncertainty_options.hpp"

namespace dbbkit::cli {

namespace {
struct EvaluateArgs {
  std::string design, out, map_csv;
  std::optional<double> reference_length_mm;
  std::vector<std::string> sweeps;
};
}  // namespace

Runner add_evaluate(CLI::App& app) {
  auto args = std::make_shared<EvaluateArgs>();
  CLI::App* sub =
      app.add_subcommand("evaluate", "What a design can identify, and how well, before measuring");
  sub->add_option("--design", args->design, "Design file (dbbkit.design/1)")->required();
  sub->add_option("--reference-length-mm", args->reference_length_mm,
                  "Lever arm converting angular uncertainty to um (default: the design's "
                  "reference_length_mm)")
      ->check(finite_in(limits::kMinReferenceLength_mm, limits::kMaxLength_mm));
  sub->add_option(
      "--out", args->out,
      "Result JSON (dbbkit.evaluate/1); '-': stdout. The summary goes to stdout otherwise");
  sub->add_option(
      "--sweep", args->sweeps,
      "Design map: NAME=start:stop:step with NAME = L|D|H and an installation-id prefix (L2: L of "
      "installations 2*) or L|D|H@id,id; repeat for a grid");
  sub->add_option("--map-csv", args->map_csv, "Write the design map as CSV (with --sweep)");
  auto unc = std::make_shared<UncertaintyArgs>();
  add_uncertainty_options(sub, unc);
  auto rep = std::make_shared<ReportArgs>();
  add_report_options(sub, rep);
  return [args, unc, rep]() {
    io::OutputSet outputs(output_targets(args->out, *rep, {{"--map-csv", args->map_csv}}),
                          {args->design});
    const Design design = io::read_design_file(args->design);
    const std::optional<double> ref =
        args->reference_length_mm ? args->reference_length_mm : design.reference_length_mm;
    if (!ref || !(*ref > 0)) {
      throw InputError(
          args->design, "reference_length_mm",
          "needed to express angular uncertainty in um (or give --reference-length-mm)");
    }
    if (!args->map_csv.empty() && args->sweeps.empty()) {
      throw InputError("--map-csv", "", "a design map needs at least one --sweep");
    }
    std::vector<SweepVariable> variables;
    double points = 1;
    for (const std::string& spec : args->sweeps) {
      variables.push_back(io::parse_sweep(design, spec));
      // The map evaluates the design at every combination: their number is bounded, not only
      // each sweep's.
      points *= static_cast<double>(variables.back().values.size());
      if (points > io::kMaxSweepPoints) {
        throw InputError("--sweep", spec,
                         "the sweeps give more than " +
                             std::to_string(static_cast<long>(io::kMaxSweepPoints)) +
                             " design points together (" + io::fmt_num(points, 6) +
                             "): coarser steps or fewer sweeps");
      }
    }
    const DesignAssessment assessed = assess_design(design, *ref);
    const Evaluation& ev = assessed.evaluation;
    const std::vector<CandidateStatus>& effects = assessed.effects;
    std::vector<SweepPoint> map;
    if (!variables.empty()) map = sweep_design(design, variables, *ref);
    std::optional<MonteCarloResult> mc;
    if (unc->monte_carlo) {
      report_progress(unc->mc, rep->quiet);
      mc = monte_carlo_a_priori(design, unc->coverage, unc->mc);
    }
    if (!args->out.empty()) {
      nlohmann::json j = io::evaluate_to_json(design, ev, args->design, mc ? &*mc : nullptr);
      if (!variables.empty()) j["sweep"] = io::sweep_to_json(variables, map);
      j["effects"] = io::effects_to_json(effects);
      outputs.stage("--out", io::dump_json(j) + "\n");
    }
    if (!args->map_csv.empty()) outputs.stage("--map-csv", io::sweep_csv(variables, map));
    const io::RunContext run{command_line(), {args->design}};
    for (const auto& [option, file, format] :
         {std::tuple{"--report", rep->report, io::ReportFormat::kHtml},
          std::tuple{"--summary", rep->summary, io::ReportFormat::kMarkdown}}) {
      if (!file.empty()) {
        outputs.stage(option, io::evaluate_report(format, run, design, ev, variables, map,
                                                  mc ? &*mc : nullptr,
                                                  a_priori_expansion(unc->coverage), &effects));
      }
    }
    outputs.commit();
    if (args->out != "-" && !rep->quiet) {
      std::cout << io::evaluate_summary(design, ev);
      std::cout << io::effects_summary(design, effects);
      if (mc) std::cout << io::monte_carlo_summary(*mc);
      if (!variables.empty()) std::cout << io::sweep_summary(variables, map);
    }
    return 0;
  };
}

}  // namespace dbbkit::cli
