#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

#include "dbbkit/io/optimize_io.hpp"
#include "dbbkit/io/plots.hpp"
#include "dbbkit/io/report_writer.hpp"
#include "dbbkit/io/reports.hpp"
#include "dbbkit/io/result_io.hpp"
#include "dbbkit/io/setup_sheet_io.hpp"
#include "dbbkit/io/text.hpp"
#include "dbbkit/kinematics.hpp"
#include "report_sections.hpp"

namespace dbbkit::io {

using namespace detail;

std::string optimize_report(ReportFormat f, const RunContext& run, const Kit& kit,
                            const OptimizeResult& res, const std::optional<Reference>& reference,
                            double seconds, const Expansion& expansion, const SetupSheet* sheet) {
  const std::unique_ptr<ReportWriter> page = make_report_writer(
      f, "dbbkit optimize: " + (kit.name.empty() ? std::string("kit") : kit.name));
  ReportWriter& p = *page;
  int feasible = 0;
  for (const ChoiceResult& c : res.choices) feasible += c.state == ChoiceState::kSearched;
  p.heading("Search");
  p.paragraph("Axis " + std::string(axis_name(kit.axis)) + ", pattern " + kit.pattern.name +
              ", criterion " + criterion_name(res.criterion) + "; " +
              std::to_string(res.choices.size()) + " discrete choices, " +
              std::to_string(feasible) + " feasible; " + std::to_string(res.evaluations) +
              " designs scored in " + fmt_num(seconds, 3) + " s." +
              (res.rank_five == OptimizeResult::RankFiveCause::kNone
                   ? ""
                   : " " + rank_five_note(kit, res) + "."));
  if (!res.best) {
    p.paragraph("No design fits the kit: " + binding_text(kit, res) + ".");
    conditions(p, run, nullptr);
    return p.str();
  }
  const Candidate& b = *res.best;
  const Evaluation& ev = res.best_evaluation;
  const double k = expansion.k, coverage = expansion.coverage_probability;
  std::vector<std::vector<std::string>> summary = {
      {"choice", choice_label(kit, b.choice)},
      {"time", fmt_num(b.time_s, 6) + " s" +
                   (kit.time_budget_s ? " of " + fmt_num(*kit.time_budget_s, 6) + " s" : "")},
      {"rank", std::to_string(ev.prior.rank) + " of " + std::to_string(ev.prior.n_unknowns)},
      {"condition number", fmt_opt(ev.prior.condition_number)},
      {"worst_std_um", fmt_opt(ev.worst.worst_std_um) + " um"},
      {"worst determined", fmt_opt(ev.worst.worst_determined_std_um) + " um"}};
  if (ev.worst_total)
    summary.push_back(
        {"worst_total_std_um (noise and set-up)", fmt_opt(ev.worst_total->worst_std_um) + " um"});
  if (b.detection) summary.push_back({"set-up detection", detection_text(*b.detection)});
  if (reference) {
    const ReferenceRatios ratios = reference_ratios(res, *reference);
    summary.push_back(
        {"reference " + reference->file, fmt_opt(reference->worst.worst_std_um) + " um"});
    if (ratios.worst_std_um)
      summary.push_back({"ratio optimised / reference", fmt_num(*ratios.worst_std_um, 3)});
    if (reference->worst_total && ev.worst_total) {
      summary.push_back({"reference worst_total_std_um, same set-up tolerances",
                         fmt_opt(reference->worst_total->worst_std_um) + " um"});
      if (ratios.worst_total_std_um)
        summary.push_back(
            {"total ratio optimised / reference", fmt_num(*ratios.worst_total_std_um, 3)});
    }
  }
  p.table({"best design", ""}, summary);
  const Design d = optimized_design(kit, res, run.inputs.empty() ? "" : run.inputs.front());
  design_section(p, d);
  p.heading("Predicted uncertainty");
  if (ev.setup_included) {
    errors_section(p, expanded_errors(ev.total_errors, k), false,
                   "predicted expanded uncertainty, best design, total (noise and the declared "
                   "set-up tolerances)",
                   coverage);
  } else {
    p.paragraph(as_sentence(evaluation_setup_note(ev)));
    errors_section(p, expanded_errors(ev.errors, k), false,
                   "predicted expanded uncertainty, best design", coverage);
  }
  unidentifiable_section(p, ev.unidentifiable);
  p.heading("Trade-off against time");
  p.figure(
      [&] {
        PlotSeries all, front;
        all.title = "best of each choice";
        all.style = "points";
        front.title = "Pareto front";
        front.style = "linespoints";
        for (const ChoiceResult& c : res.choices) {
          if (c.best && c.best->feasible && c.best->objective_defined &&
              c.best->n_undetermined == b.n_undetermined) {
            all.x.push_back(c.best->time_s);
            all.y.push_back(c.best->objective);
          }
        }
        for (const Candidate& c : res.pareto)
          front.x.push_back(c.time_s), front.y.push_back(c.objective);
        return plot_series(std::string(criterion_name(res.criterion)) + " against measurement time",
                           "time [s]", criterion_name(res.criterion), {all, front});
      },
      "Every discrete choice's best design (points) and the front of those no other beats in both "
      "time and "
      "uncertainty (line).");
  std::vector<std::vector<std::string>> front;
  for (const Candidate& c : res.pareto) {
    front.push_back({fmt_num(c.time_s, 6), std::to_string(c.design.installations.size()),
                     std::to_string(c.design.angles_deg.size()), fmt_num(c.choice.step_deg),
                     fmt_num(c.objective, 5), added_installations(kit, c)});
  }
  p.table({"time [s]", "installations", "angles", "step [deg]", criterion_name(res.criterion),
           "added (optional positions)"},
          front);
  if (sheet) write_setup_sheet(p, *sheet, run.inputs.empty() ? "" : run.inputs.front(), 2);
  conditions(p, run, &d);
  return p.str();
}

}  // namespace dbbkit::io
