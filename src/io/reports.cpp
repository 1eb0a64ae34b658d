#include "dbbkit/io/reports.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <memory>

#include "dbbkit/io/diagnose_io.hpp"
#include "dbbkit/io/optimize_io.hpp"
#include "dbbkit/io/report.hpp"
#include "dbbkit/io/result_io.hpp"
#include "dbbkit/kinematics.hpp"
#include "dbbkit/uncertainty.hpp"

namespace dbbkit::io {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// One page, written as HTML or as Markdown; figures exist only in HTML and are
// drawn only then.
class Page {
 public:
  Page(ReportFormat f, const std::string& title) {
    if (f == ReportFormat::Html) {
      html_ = std::make_unique<HtmlReport>(title);
    } else {
      md_ = std::make_unique<MarkdownSummary>(title);
    }
  }
  void heading(const std::string& t, int level = 2) {
    html_ ? html_->heading(t, level) : md_->heading(t, level);
  }
  void paragraph(const std::string& t) { html_ ? html_->paragraph(t) : md_->paragraph(t); }
  void preformatted(const std::string& t) { html_ ? html_->preformatted(t) : md_->preformatted(t); }
  void table(const std::vector<std::string>& h, const std::vector<std::vector<std::string>>& rows) {
    html_ ? html_->table(h, rows) : md_->table(h, rows);
  }
  void figure(const std::function<std::string()>& svg, const std::string& caption) {
    if (html_) html_->figure(svg(), caption);
  }
  void conditions(const RunContext& run, const Design* design) {
    html_ ? html_->conditions(run.command, run.inputs, design)
          : md_->conditions(run.command, run.inputs, design);
  }
  std::string str() const { return html_ ? html_->str() : md_->str(); }

 private:
  std::unique_ptr<HtmlReport> html_;
  std::unique_ptr<MarkdownSummary> md_;
};

std::vector<std::vector<std::string>> installation_rows(const Design& d) {
  std::vector<std::vector<std::string>> rows;
  for (const Installation& in : d.installations) {
    rows.push_back({in.id, fmt_num(in.L_mm, 6), fmt_num(in.D_mm, 6),
                    d.axis == Axis::C ? fmt_num(in.H_mm, 6) : "--", in.direction.label(),
                    std::to_string(in.sign), in.bar_mm ? fmt_num(*in.bar_mm, 6) : "--",
                    in.description});
  }
  return rows;
}

void design_section(Page& p, const Design& d) {
  p.heading("Design");
  p.paragraph(d.name + ": axis " + axis_name(d.axis) + ", " + std::to_string(d.angles_deg.size()) +
              " angles from " +
              fmt_num(*std::min_element(d.angles_deg.begin(), d.angles_deg.end()), 6) + " to " +
              fmt_num(*std::max_element(d.angles_deg.begin(), d.angles_deg.end()), 6) + " deg, " +
              std::to_string(d.installations.size()) + " installations, errors " +
              d.errors.describe() + ".");
  if (!d.description.empty()) p.paragraph(d.description);
  p.figure([&] { return plot_design(d); },
           "Ball positions (red) and bars to the following ball (blue), labelled "
           "with the installations that use them; dashed: the axis of rotation.");
  p.table({"id", "L [mm]", "D [mm]", "H [mm]", "direction", "sign", "bar [mm]", "set-up"},
          installation_rows(d));
}

// Residual against angle, one line per installation.
std::vector<PlotSeries> residual_series(const Design& d, const std::vector<Reading>& readings,
                                        const Eigen::VectorXd& residual) {
  std::vector<PlotSeries> out;
  for (const Installation& in : d.installations) {
    std::vector<std::pair<double, double>> pts;
    for (size_t i = 0; i < readings.size(); ++i) {
      if (readings[i].installation == in.id)
        pts.push_back({readings[i].angle_deg, residual(static_cast<long>(i))});
    }
    if (pts.empty()) continue;
    std::stable_sort(pts.begin(), pts.end(), [](auto& a, auto& b) { return a.first < b.first; });
    PlotSeries s;
    s.title = in.id;
    for (auto& [a, r] : pts) s.x.push_back(a), s.y.push_back(r);
    out.push_back(s);
  }
  return out;
}

void unidentifiable_section(Page& p, const std::vector<Unidentifiable>& list) {
  if (list.empty()) return;
  p.heading("Not determined");
  p.paragraph(std::to_string(list.size()) +
              " combination(s) of the errors no reading sees; their values are reported as '--', "
              "never as numbers.");
  std::vector<std::vector<std::string>> rows;
  for (const Unidentifiable& u : list) {
    rows.push_back(
        {u.angle_deg ? fmt_num(*u.angle_deg, 6) : "all", u.expression, u.interpretation});
  }
  p.table({"angle [deg]", "combination", "meaning"}, rows);
}

// Errors with U = k u per value (k from the budget when there is one).
std::vector<ErrorsAtAngle> with_expanded(const std::vector<ErrorsAtAngle>& errors,
                                         const Budget* budget, double k) {
  std::vector<ErrorsAtAngle> out = errors;
  std::map<std::pair<int, int>, double> U;
  if (budget) {
    for (const ValueBudget& v : budget->values) U[{v.station, v.error}] = v.U;
  }
  for (ErrorsAtAngle& ea : out) {
    for (int e = 0; e < 6; ++e) {
      if (!ea.errors[e].determined) continue;
      auto it = U.find({ea.station, e});
      ea.errors[e].std = it != U.end() ? it->second : k * ea.errors[e].std;
    }
  }
  return out;
}

// `coverage`: the coverage probability of U.
void errors_section(Page& p, const std::vector<ErrorsAtAngle>& expanded, bool values,
                    const std::string& what, double coverage) {
  const std::string at = "U (" + fmt_num(100 * coverage) + " %)";
  p.figure([&] { return plot_errors(expanded, values, 1.0, what); },
           values ? "The six errors against angle; the band is the expanded uncertainty " + at + "."
                  : "Expanded uncertainty " + at +
                        " of each error at each angle, before any reading is taken.");
  p.table(errors_header(values), errors_rows(expanded, values, 1.0));
}

}  // namespace

namespace {
// A clause as a sentence: capital first letter, full stop.
std::string as_sentence(std::string text) {
  if (!text.empty()) text[0] = static_cast<char>(std::toupper(static_cast<unsigned char>(text[0])));
  return text + ".";
}

// The ISO 230-7 quantities (iso230.hpp): location errors and constant parts with u (k = 1),
// then the component error motions.
void iso230_section(Page& p, const IdentifyResult& r) {
  const IsoResult& iso = r.iso;
  p.heading("In ISO 230-7 terms");
  p.paragraph(
      "First order. Location errors of the axis average line and the constant parts, fitted by "
      "least squares "
      "to the determined values; the component error motions are what remains. " +
      as_sentence(r.iso_note));
  std::vector<std::vector<std::string>> rows;
  for (const auto* list : {&iso.location, &iso.constants}) {
    for (const IsoQuantity& q : *list) {
      rows.push_back({q.name, q.value.determined ? fmt_num(q.value.value) : "--",
                      q.value.determined ? fmt_num(q.value.std) : "--", q.unit});
    }
  }
  p.table({"quantity", "value", "u (k = 1)", "unit"}, rows);
  std::vector<std::string> header = {"angle [deg]"};
  for (int e = 0; e < 6; ++e)
    header.push_back(iso.component_names[e] + (e < 3 ? " [um]" : " [urad]"));
  std::vector<std::vector<std::string>> comp;
  for (const IsoComponentsAtAngle& a : iso.components) {
    std::vector<std::string> row = {fmt_num(a.angle_deg)};
    for (const Determined& m : a.motions)
      row.push_back(m.determined ? fmt_num(m.value) + " ± " + fmt_num(m.std) : "--");
    comp.push_back(row);
  }
  p.table(header, comp);
  const IsoMotionValues& mv = iso.motion_values;
  if (!mv.values.empty()) {
    std::vector<std::vector<std::string>> vals;
    for (const IsoMotionValue& v : mv.values) {
      if (v.computed) {
        vals.push_back({v.name, v.component, fmt_num(v.value), fmt_num(v.U),
                        "[" + fmt_num(v.low) + ", " + fmt_num(v.high) + "]", v.unit});
      } else {
        vals.push_back({v.name, v.component, "--", "--", v.reason, v.unit});
      }
    }
    p.paragraph("Error motion values (ISO 230-7, fixed sensitive direction). " +
                as_sentence(mv.note));
    p.table({"quantity", "component", "value", "U",
             "interval (at least " + fmt_num(100 * mv.coverage_probability) + " %)", "unit"},
            vals);
  }
  if (!iso.note.empty()) p.paragraph(as_sentence(iso.note));
}

// The conformance decisions (conformance.hpp): the rule, then one row per tolerance.
void conformance_section(Page& p, const ConformanceReport& c) {
  p.heading("Conformance");
  p.paragraph(
      std::string("Verdict: ") +
      (c.any_nonconforming() ? "DOES NOT CONFORM (exit code 1)." : "no nonconformity proven.") +
      " " + as_sentence(c.rule));
  for (const std::string& w : c.warnings) p.paragraph("Warning: " + as_sentence(w));
  bool sets = false;  // a quantity at every angle: its counts get a column
  for (const ConformanceResult& r : c.results) sets = sets || r.values > 1;
  std::vector<std::vector<std::string>> rows;
  for (const ConformanceResult& r : c.results) {
    std::string zone = r.lower && r.upper ? "[" + fmt_num(*r.lower) + ", " + fmt_num(*r.upper) + "]"
                       : r.upper          ? "≤ " + fmt_num(*r.upper)
                                          : "≥ " + fmt_num(*r.lower);
    std::string deciding = "--";
    if (r.value) {
      deciding = fmt_num(*r.value) + " [" + fmt_num(*r.low) + ", " + fmt_num(*r.high) + "]";
      if (r.angle_deg) deciding += " at " + fmt_num(*r.angle_deg) + "°";
    }
    std::vector<std::string> row = {r.quantity, zone + " " + r.unit, decision_name(r.decision),
                                    deciding};
    if (sets) {
      row.push_back(r.values > 1
                        ? std::to_string(r.conforming) + " / " + std::to_string(r.nonconforming) +
                              " / " + std::to_string(r.not_proven + r.undetermined)
                        : "");
    }
    row.push_back(r.basis);
    rows.push_back(row);
  }
  std::vector<std::string> header = {"quantity", "tolerance zone", "decision",
                                     "deciding value [interval]"};
  if (sets) header.push_back("conform / do not / not proven");
  header.push_back("interval");
  p.table(header, rows);
}

}  // namespace

std::string identify_report(ReportFormat f, const RunContext& run, const Design& design,
                            const std::vector<Reading>& readings, const IdentifyResult& r,
                            const MonteCarloResult* mc, const ConformanceReport* conformance) {
  Page p(f, "dbbkit identify: " + design.name);
  const Estimate& est = r.estimate;
  p.heading("Result");
  p.paragraph(std::to_string(est.n_readings) + " readings, " + std::to_string(est.n_unknowns) +
              " unknowns, rank " + std::to_string(est.rank) +
              (est.rank == est.n_unknowns ? " (full rank)" : " (rank-deficient)") + "; residual " +
              residual_text(est) + ". Reading noise: " + r.budget.noise_evaluation +
              "; expanded uncertainty U = k u_c at " +
              fmt_num(100 * r.budget.coverage_probability) +
              " % coverage (k from Student's t at the effective degrees of freedom).");
  design_section(p, design);
  p.heading("Errors");
  errors_section(p, with_expanded(r.errors, &r.budget, 0), true,
                 "identified errors of " + design.name, r.budget.coverage_probability);
  unidentifiable_section(p, r.unidentifiable);
  iso230_section(p, r);
  if (conformance) conformance_section(p, *conformance);
  p.heading("Residuals");
  p.figure(
      [&] {
        return plot_series("residual per installation", "angle [deg]", "reading - model [um]",
                           residual_series(design, readings, est.residual_um));
      },
      "Residual of every reading against the fitted model, per installation.");
  // The budget of the value with the largest U of each error (JCGM 100).
  p.heading("Uncertainty budget (JCGM 100)");
  p.paragraph(
      "For each error, the value with the largest expanded uncertainty; every value's budget is in "
      "the "
      "JSON result (budget).");
  std::vector<std::vector<std::string>> rows;
  for (int e = 0; e < 6; ++e) {
    const ValueBudget* worst = nullptr;
    for (const ValueBudget& v : r.budget.values) {
      if (v.error == e && (!worst || v.U > worst->U)) worst = &v;
    }
    if (!worst) continue;
    const std::string q = std::string(kErrorNames[e]) + " at " + fmt_num(worst->angle_deg, 6) +
                          " deg [" + kErrorUnits[e] + "]";
    for (const BudgetComponent& c : worst->components) {
      rows.push_back(
          {q, c.name, c.type, fmt_num(c.u), c.dof ? fmt_num(*c.dof) : "inf", "", "", ""});
    }
    rows.push_back({q, "combined", "", fmt_num(worst->u_c),
                    worst->nu_eff ? fmt_num(*worst->nu_eff) : "inf", fmt_num(worst->k),
                    fmt_num(worst->U), fmt_num(worst->value)});
  }
  p.table({"quantity", "source", "type", "u", "degrees of freedom", "k", "U", "value"}, rows);
  if (mc) {
    p.heading("Monte Carlo check (JCGM 101)");
    p.paragraph(std::to_string(mc->trials) + " trials; " + std::to_string(mc->n_validated) +
                " of " + std::to_string(mc->values.size()) +
                " linear intervals validated; where not validated the Monte Carlo interval is the "
                "one to report.");
    std::vector<std::vector<std::string>> mrows;
    for (const MonteCarloValue& v : mc->values) {
      if (v.validated) continue;
      mrows.push_back({fmt_num(v.angle_deg, 6), kErrorNames[v.error],
                       "[" + fmt_num(v.linear_value - v.linear_U) + ", " +
                           fmt_num(v.linear_value + v.linear_U) + "]",
                       "[" + fmt_num(v.low) + ", " + fmt_num(v.high) + "]", fmt_num(v.d_low, 3),
                       fmt_num(v.d_high, 3), fmt_num(v.delta, 3)});
    }
    if (!mrows.empty()) {
      p.table({"angle [deg]", "error", "linear interval", "Monte Carlo interval", "d_low", "d_high",
               "delta"},
              mrows);
    }
  }
  p.conditions(run, &design);
  return p.str();
}

// Every set-up effect: declared size, detectable, detection limit, largest bias per um.
void setup_checks_section(Page& p, const Evaluation& ev) {
  if (ev.setup_checks.empty()) return;
  p.heading("Set-up effects");
  p.paragraph(
      "Detection limit: the smallest size the nested F test of diagnose finds at level " +
      fmt_num(ev.detection.level) +
      (ev.detection.n_tests > 1 ? " / " + std::to_string(ev.detection.n_tests) : "") +
      " with power " + fmt_num(ev.detection.power) +
      " (least favourable direction). Bias: the largest change of an error per um of the effect.");
  std::vector<std::vector<std::string>> rows;
  for (const SetupEffectCheck& c : ev.setup_checks) {
    std::string bias = "none";
    if (c.bias_per_um) {
      bias = fmt_num(*c.bias_per_um) + " " + kErrorUnits[c.bias_error] + " per um (" +
             kErrorNames[c.bias_error] + " at " + fmt_num(c.bias_angle_deg, 6) + " deg)";
    }
    rows.push_back({c.label, c.declared_std_um > 0 ? fmt_num(c.declared_std_um) : "not declared",
                    c.detectable ? "yes" : "NO", fmt_opt(c.detection_limit_um), bias});
  }
  p.table({"effect", "declared std [um]", "detectable", "detection limit [um]", "largest bias"},
          rows);
}

std::string evaluate_report(ReportFormat f, const RunContext& run, const Design& design,
                            const Evaluation& ev, const std::vector<SweepVariable>& variables,
                            const std::vector<SweepPoint>& map, const MonteCarloResult* mc,
                            const Expansion& expansion) {
  Page p(f, "dbbkit evaluate: " + design.name);
  const Estimate& est = ev.prior;
  const double k = expansion.k, coverage = expansion.coverage_probability;
  p.heading("What the design can identify");
  std::string s = std::to_string(est.n_readings) + " readings (one per installation and angle), " +
                  std::to_string(est.n_unknowns) + " unknowns, rank " + std::to_string(est.rank) +
                  ". ";
  if (est.condition_number)
    s += "Condition number " + fmt_num(*est.condition_number) + " (equilibrated). ";
  if (ev.worst.worst_std_um) {
    s += "worst_std_um " + fmt_num(*ev.worst.worst_std_um) + " um (" +
         kErrorNames[ev.worst.at_error] + " at " + fmt_num(ev.worst.at_angle_deg, 6) +
         " deg; angular errors at " + fmt_num(ev.reference_length_mm) + " mm).";
  } else {
    s += "worst_std_um: none, " + std::to_string(ev.worst.n_undetermined) +
         " errors at angles are not determined.";
  }
  if (ev.worst_total && ev.worst_total->worst_std_um) {
    s += " With the declared set-up tolerances, worst_total_std_um " +
         fmt_num(*ev.worst_total->worst_std_um) + " um (" + kErrorNames[ev.worst_total->at_error] +
         " at " + fmt_num(ev.worst_total->at_angle_deg, 6) + " deg).";
  }
  p.paragraph(s);
  p.table({"O1", "O2", "O3", "O4", "O5", "D = log det M", "A = trace M^-1", "E = min eig M",
           "G = max leverage"},
          {{fmt_num(ev.indices.O1), fmt_num(ev.indices.O2), fmt_num(ev.indices.O3),
            fmt_num(ev.indices.O4), fmt_num(ev.indices.O5), fmt_opt(ev.criteria.D_logdet),
            fmt_opt(ev.criteria.A_trace), fmt_num(ev.criteria.E_min_eigenvalue),
            fmt_num(ev.criteria.G_max_leverage)}});
  design_section(p, design);
  p.heading("Uncertainty before measuring");
  p.paragraph("Reading noise Type B: " + design.noise.describe() + "; U = " + fmt_num(k) + " u (" +
              fmt_num(100 * coverage) + " %, infinite degrees of freedom).");
  if (ev.setup_included) {
    p.paragraph("Set-up: " + ev.setup_note +
                ". The plot and table show the total (noise and set-up).");
    errors_section(p, with_expanded(ev.total_errors, nullptr, k), false,
                   "a-priori expanded total uncertainty of " + design.name, coverage);
  } else {
    p.paragraph(as_sentence(ev.setup_note));
    errors_section(p, with_expanded(ev.errors, nullptr, k), false,
                   "a-priori expanded uncertainty of " + design.name, coverage);
  }
  unidentifiable_section(p, ev.unidentifiable);
  setup_checks_section(p, ev);
  if (mc) {
    p.heading("Monte Carlo check (JCGM 101)");
    p.paragraph(std::to_string(mc->trials) + " trials; " + std::to_string(mc->n_validated) +
                " of " + std::to_string(mc->values.size()) + " linear intervals validated.");
  }
  if (!variables.empty()) {
    p.heading("Design map");
    std::vector<std::string> header;
    for (const SweepVariable& v : variables) header.push_back(v.name + " [mm]");
    header.insert(header.end(), {"rank", "condition number", "worst_std_um"});
    std::vector<std::vector<std::string>> rows;
    for (const SweepPoint& pt : map) {
      std::vector<std::string> r;
      for (double v : pt.values) r.push_back(fmt_num(v, 6));
      r.insert(r.end(), {std::to_string(pt.rank) + "/" + std::to_string(pt.n_unknowns),
                         fmt_opt(pt.condition_number), fmt_opt(pt.worst_std_um)});
      rows.push_back(r);
    }
    if (variables.size() == 2) {
      p.figure(
          [&] {
            std::vector<double> z;
            // sweep_design varies the last variable fastest: x = the second variable.
            for (const SweepPoint& pt : map) z.push_back(pt.worst_std_um.value_or(kNaN));
            return plot_heatmap("worst_std_um [um] over the design map",
                                variables[1].name + " [mm]", variables[0].name + " [mm]",
                                "worst_std_um [um]", variables[1].values, variables[0].values, z);
          },
          "worst_std_um at each point of the map; blank where not every error is determined.");
    } else if (variables.size() == 1) {
      p.figure(
          [&] {
            PlotSeries sr;
            sr.title = "worst_std_um";
            for (const SweepPoint& pt : map)
              sr.x.push_back(pt.values[0]), sr.y.push_back(pt.worst_std_um.value_or(kNaN));
            return plot_series("worst_std_um over the design map", variables[0].name + " [mm]",
                               "worst_std_um [um]", {sr});
          },
          "worst_std_um at each point of the map; gaps where not every error is determined.");
    }
    p.table(header, rows);
  }
  p.conditions(run, &design);
  return p.str();
}

std::string optimize_report(ReportFormat f, const RunContext& run, const Kit& kit,
                            const OptimizeResult& res, const std::optional<Reference>& reference,
                            double seconds, const Expansion& expansion) {
  Page p(f, "dbbkit optimize: " + (kit.name.empty() ? std::string("kit") : kit.name));
  int feasible = 0;
  for (const ChoiceResult& c : res.choices) feasible += c.state == ChoiceState::kSearched;
  p.heading("Search");
  p.paragraph("Axis " + std::string(axis_name(kit.axis)) + ", pattern " + kit.pattern.name +
              ", criterion " + criterion_name(res.criterion) + "; " +
              std::to_string(res.choices.size()) + " discrete choices, " +
              std::to_string(feasible) + " feasible; " + std::to_string(res.evaluations) +
              " designs scored in " + fmt_num(seconds, 3) + " s." +
              (res.note.empty() ? "" : " " + res.note + "."));
  if (!res.best) {
    p.paragraph("No design fits the kit.");
    std::vector<std::vector<std::string>> rows;
    for (const ChoiceResult& c : res.choices) rows.push_back({c.label, choice_status_text(kit, c)});
    p.table({"choice", "status"}, rows);
    p.conditions(run, nullptr);
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
    summary.push_back(
        {"reference " + reference->file, fmt_opt(reference->worst.worst_std_um) + " um"});
    if (ev.worst.worst_std_um && reference->worst.worst_std_um) {
      summary.push_back({"ratio optimised / reference",
                         fmt_num(*ev.worst.worst_std_um / *reference->worst.worst_std_um, 3)});
    }
    if (reference->worst_total && ev.worst_total) {
      summary.push_back({"reference worst_total_std_um, same set-up tolerances",
                         fmt_opt(reference->worst_total->worst_std_um) + " um"});
      if (ev.worst_total->worst_std_um && reference->worst_total->worst_std_um) {
        summary.push_back(
            {"total ratio optimised / reference",
             fmt_num(*ev.worst_total->worst_std_um / *reference->worst_total->worst_std_um, 3)});
      }
    }
  }
  p.table({"best design", ""}, summary);
  const Design d = optimized_design(kit, res, run.inputs.empty() ? "" : run.inputs.front());
  design_section(p, d);
  p.heading("Predicted uncertainty");
  if (ev.setup_included) {
    errors_section(p, with_expanded(ev.total_errors, nullptr, k), false,
                   "predicted expanded uncertainty, best design, total (noise and the declared "
                   "set-up tolerances)",
                   coverage);
  } else {
    p.paragraph(as_sentence(ev.setup_note));
    errors_section(p, with_expanded(ev.errors, nullptr, k), false,
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
  p.conditions(run, &d);
  return p.str();
}

std::string diagnose_report(ReportFormat f, const RunContext& run, const Design& design,
                            const std::vector<Reading>& given, const DiagnoseResult& r,
                            const Expansion& expansion) {
  // The readings fitted: those given, less any the user asked to exclude (--exclude-gross).
  std::vector<Reading> readings;
  for (std::size_t j = 0; j < given.size(); ++j) {
    if (!std::binary_search(r.excluded_rows.begin(), r.excluded_rows.end(), static_cast<int>(j)))
      readings.push_back(given[j]);
  }
  Page p(f, "dbbkit diagnose: " + design.name);
  p.heading("Verdict");
  p.paragraph(r.verdict);
  p.table({"", "rms [um]", "chi2", "dof", "p"},
          {{"before", fmt_num(r.before.rms_um), fmt_num(r.before.chi2),
            std::to_string(r.before.dof), fmt_opt(r.before.p_value, 3)},
           {"after", fmt_num(r.after.rms_um), fmt_num(r.after.chi2), std::to_string(r.after.dof),
            fmt_opt(r.after.p_value, 3)}});
  p.heading("Effects added");
  if (r.added.empty() && r.stopped_at_step > 0) {
    p.paragraph(
        "None: selection stopped at step " + std::to_string(r.stopped_at_step) +
        (r.stopped_because == SelectionStop::kModelOrder
             ? ", where a higher order of the error model was the best candidate (see the verdict)."
             : ", where one reading alone was the best candidate (see the verdict and the checks "
               "below)."));
  } else if (r.added.empty()) {
    p.paragraph("None: no effect of the library explains the residual significantly better.");
  } else {
    std::vector<std::vector<std::string>> rows;
    for (const AddedEffect& a : r.added) {
      for (size_t i = 0; i < a.values.size(); ++i) {
        const Determined& v = a.values[i];
        rows.push_back({a.block.label, a.block.parameters[i],
                        v.determined ? fmt_num(v.value) : "--",
                        v.determined ? fmt_num(v.std) : "--", a.block.unit,
                        fmt_num(a.evidence.p_value, 3), fmt_num(a.evidence.bic_change, 4)});
      }
    }
    p.table({"effect", "parameter", "value", "u", "unit", "p (F-test)", "BIC change"}, rows);
  }
  p.heading("Checks of the residual");
  {
    std::vector<std::vector<std::string>> rows;
    std::vector<const ResidualFeature*> sorted;
    for (const ResidualFeature& x : r.features_after) sorted.push_back(&x);
    std::sort(sorted.begin(), sorted.end(),
              [](const ResidualFeature* a, const ResidualFeature* b) { return a->p < b->p; });
    for (std::size_t i = 0; i < std::min<std::size_t>(5, sorted.size()); ++i) {
      rows.push_back({describe_feature(design, readings, *sorted[i]), fmt_num(sorted[i]->p, 3)});
    }
    if (rows.empty()) {
      p.paragraph("No residual degrees of freedom left to test features of the residual.");
    } else {
      p.paragraph(
          "The five most significant features of the residual after, each tested against the "
          "residual's own "
          "scatter (F-test of appending it to the final model; a scan's p times the positions "
          "scanned), at "
          "the level " +
          fmt_num(r.level, 3) + ". Every feature is in the JSON (residual_checks).");
      p.table({"feature", "p"}, rows);
    }
  }
  design_section(p, design);
  p.heading("Residuals before and after");
  auto residual_figure = [&](const char* title, const Eigen::VectorXd& residual,
                             const char* caption) {
    p.figure(
        [&] {
          return plot_series(title, "angle [deg]", "reading - model [um]",
                             residual_series(design, readings, residual));
        },
        caption);
  };
  residual_figure("residual before (axis errors only)", r.before.residual_um,
                  "Residual per installation with the six error motions alone.");
  residual_figure("residual after (with the effects added)", r.after.residual_um,
                  "Residual per installation with the effects added.");
  p.heading("Errors after");
  errors_section(p, with_expanded(r.errors_after, nullptr, expansion.k), true,
                 "errors with the effects added, " + design.name, expansion.coverage_probability);
  unidentifiable_section(p, r.unidentifiable_after);
  p.heading("Details");
  p.preformatted(diagnose_summary(design, r));
  std::vector<std::vector<std::string>> cand;
  for (const CandidateStatus& c : r.candidates)
    cand.push_back({c.label, candidate_state_name(c.state), c.detail});
  p.table({"candidate", "status", "why"}, cand);
  p.conditions(run, &design);
  return p.str();
}

}  // namespace dbbkit::io
