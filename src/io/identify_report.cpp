#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

#include "dbbkit/io/plots.hpp"
#include "dbbkit/io/report_writer.hpp"
#include "dbbkit/io/reports.hpp"
#include "dbbkit/io/result_io.hpp"
#include "dbbkit/io/text.hpp"
#include "dbbkit/io/tolerances_io.hpp"
#include "dbbkit/kinematics.hpp"
#include "report_sections.hpp"

namespace dbbkit::io {

using namespace detail;

namespace {

// The ISO 230-7 quantities (iso230.hpp): location errors and constant parts with u (k = 1),
// then the component error motions.
void conformance_section(ReportWriter& p, const ConformanceReport& c) {
  p.heading("Conformance");
  p.paragraph(
      std::string("Verdict: ") +
      (c.any_nonconforming() ? "DOES NOT CONFORM (exit code 1)." : "no nonconformity proven.") +
      " " + as_sentence(conformance_rule(c)));
  for (const std::string& w : conformance_warnings(c)) p.paragraph("Warning: " + as_sentence(w));
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
    row.push_back(conformance_basis(c, r));
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
  const std::unique_ptr<ReportWriter> page =
      make_report_writer(f, "dbbkit identify: " + design.name);
  ReportWriter& p = *page;
  const Estimate& est = r.estimate;
  warnings_section(p, r.warnings);
  p.heading("Result");
  p.paragraph(std::to_string(est.n_readings) + " readings, " + std::to_string(est.n_unknowns) +
              " unknowns, rank " + std::to_string(est.rank) +
              (est.rank == est.n_unknowns ? " (full rank)" : " (rank-deficient)") + "; residual " +
              residual_text(est) + ". Reading noise: " + noise_evaluation_text(r.budget) +
              "; expanded uncertainty U = k u_c at " +
              fmt_num(100 * r.budget.coverage_probability) +
              " % coverage (k from Student's t at the effective degrees of freedom).");
  design_section(p, design);
  p.heading("Errors");
  errors_section(p, expanded_errors(r.errors, r.budget), true,
                 "identified errors of " + design.name, r.budget.coverage_probability);
  unidentifiable_section(p, r.unidentifiable);
  iso230_section(p, r.iso, iso_uncertainty_note(r));
  if (conformance) conformance_section(p, *conformance);
  p.heading("Residuals");
  p.figure(
      [&] {
        return plot_residual_panels("residual per installation [um]",
                                    residual_panels(design, readings, est.residual_um));
      },
      "Residual of every reading against the fitted model: a panel per installation on one "
      "scale, each sweep a line in angle order.");
  p.figure(
      [&] {
        return plot_residual_polar("residual around the turn",
                                   residual_panels(design, readings, est.residual_um));
      },
      "The same residuals as a ballbar plot: each trace leaves the dashed circle outwards where "
      "the bar read longer than the model, inwards where shorter (not to scale with the "
      "machine).");
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
  conditions(p, run, &design);
  return p.str();
}

}  // namespace dbbkit::io
