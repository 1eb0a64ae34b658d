#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

#include "dbbkit/instrument.hpp"
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

namespace {

// What differs between two choices, in words: the angle step, the heights, the optional
// positions added.
std::string choice_change_text(const Kit& kit, const Candidate& from, const Candidate& to) {
  std::vector<std::string> parts;
  if (from.choice.step_deg != to.choice.step_deg)
    parts.push_back("step " + fmt_num(from.choice.step_deg) + " -> " + fmt_num(to.choice.step_deg) +
                    " deg");
  for (size_t h = 0; h < to.choice.heights.size() && h < from.choice.heights.size(); ++h) {
    if (from.choice.heights[h].stack != to.choice.heights[h].stack)
      parts.push_back(to.choice.heights[h].variable + " " +
                      fmt_num(from.choice.heights[h].height_mm) + " -> " +
                      fmt_num(to.choice.heights[h].height_mm) + " mm");
  }
  if (from.choice.n_optional != to.choice.n_optional)
    parts.push_back("added " + added_installations(kit, from) + " -> " +
                    added_installations(kit, to));
  if (parts.empty()) return "the positions only";
  std::string t;
  for (const std::string& p : parts) t += (t.empty() ? "" : ", ") + p;
  return t;
}

// "+3.5 %"; within 0.05 % a tie, which the shorter measurement wins.
std::string percent_worse(double x, double best) {
  const double pct = 100.0 * (x / best - 1.0);
  if (std::abs(pct) < 0.05) return "a tie (within 0.05 %)";
  std::string t(pct > 0 ? "+" : "-");
  return t.append(fmt_rounded(std::abs(pct), 1)).append(" %");
}

}  // namespace

std::string optimize_report(ReportFormat f, const RunContext& run, const Kit& kit,
                            const OptimizeResult& res, const std::optional<Reference>& reference,
                            double seconds, const Expansion& expansion, const SetupSheet* sheet) {
  const std::unique_ptr<ReportWriter> page = make_report_writer(
      f, "dbbkit optimize: " + (kit.name.empty() ? std::string("kit") : kit.name));
  ReportWriter& p = *page;
  summary_section(p, optimize_brief(kit, res, reference));
  int feasible = 0;
  for (const ChoiceResult& c : res.choices) feasible += c.state == ChoiceState::kSearched;
  p.heading("Search");
  p.paragraph("Axis " + std::string(kit.axis.label()) + ", pattern " + kit.pattern.name +
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
  summary.push_back({"drift", drift_text(ev.drift, kit.instrument)});
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
  const bool scored =
      std::any_of(res.choices.begin(), res.choices.end(), [&](const ChoiceResult& c) {
        return c.best && c.best->feasible && c.best->objective_defined &&
               c.best->n_undetermined == b.n_undetermined;
      });
  if (!scored)
    p.paragraph(
        "No choice's best design scores on the criterion (each leaves errors "
        "undetermined): nothing to plot against time.");
  if (scored)
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
          for (size_t i = 0; i < res.pareto.size(); ++i) {
            const Candidate& c = res.pareto[i];
            front.x.push_back(c.time_s), front.y.push_back(c.objective);
            front.labels.push_back(fmt_num(c.time_s, 6) + " s, " + fmt_num(c.objective, 4) +
                                   (i ? "; " + choice_change_text(kit, res.pareto[i - 1], c) : ""));
          }
          // The interesting range: up to 2.5 times the front's largest value.
          double top = 0;
          for (double v : front.y) top = std::max(top, v);
          return plot_series(
              std::string(criterion_name(res.criterion)) + " against measurement time", "time [s]",
              criterion_name(res.criterion), {all, front}, 760, 420, 2.5 * top);
        },
        "Every discrete choice's best design (points) and the front of those no other beats in "
        "both "
        "time and uncertainty (line), each point of the front labelled with its time, its "
        "uncertainty and what changes from the point before; the axis ends at 2.5 times the "
        "front's largest value (worse choices are off the plot, and in the result JSON).");
  std::vector<std::vector<std::string>> front;
  for (size_t i = 0; i < res.pareto.size(); ++i) {
    const Candidate& c = res.pareto[i];
    front.push_back({fmt_num(c.time_s, 6), std::to_string(measured_count(c.design)),
                     std::to_string(c.design.angles_deg.size()), fmt_num(c.choice.step_deg),
                     fmt_num(c.objective, 5), added_installations(kit, c),
                     i == 0 ? "the shortest" : choice_change_text(kit, res.pareto[i - 1], c)});
  }
  p.table({"time [s]", instrument_info(kit.instrument).items, "angles", "step [deg]",
           criterion_name(res.criterion), "added (optional positions)",
           "what changes from the point before"},
          front);
  const std::vector<int> runners = runner_up_choices(res, 5);
  if (!runners.empty()) {
    p.heading("Runner-up designs");
    p.paragraph("The best design with each other " +
                std::string(kit.axis.table() ? "set of block stacks"
                                             : "angle step and set of optional positions") +
                " (as searched, not rounded), and how much worse each is than the best (" +
                fmt_num(b.objective, 5) +
                "): one within a few per cent may be the easier to set up.");
    std::vector<std::vector<std::string>> rows;
    for (int i : runners) {
      const Candidate& c = *res.choices[i].best;
      rows.push_back({res.choices[i].label, fmt_num(c.time_s, 6), fmt_num(c.objective, 5),
                      percent_worse(c.objective, b.objective), choice_change_text(kit, b, c)});
    }
    p.table({"choice", "time [s]", criterion_name(res.criterion), "worse than the best",
             "what differs from the best"},
            rows);
  }
  if (sheet) write_setup_sheet(p, *sheet, run.inputs.empty() ? "" : run.inputs.front(), 2);
  conditions(p, run, &d);
  return p.str();
}

}  // namespace dbbkit::io
