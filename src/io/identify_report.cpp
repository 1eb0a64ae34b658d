#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

#include "dbbkit/instrument.hpp"
#include "dbbkit/io/plots.hpp"
#include "dbbkit/io/report_writer.hpp"
#include "dbbkit/io/reports.hpp"
#include "dbbkit/io/result_io.hpp"
#include "dbbkit/io/text.hpp"
#include "dbbkit/kinematics.hpp"
#include "report_sections.hpp"

namespace dbbkit::io {

using namespace detail;

std::string identify_report(ReportFormat f, const RunContext& run, const Design& design,
                            const std::vector<Reading>& readings, const IdentifyResult& r,
                            const MonteCarloResult* mc, const ConformanceReport* conformance) {
  const std::unique_ptr<ReportWriter> page =
      make_report_writer(f, "dbbkit identify: " + design.name);
  ReportWriter& p = *page;
  const Estimate& est = r.estimate;
  summary_section(p, identify_brief(design, r));
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
  if (!r.effects.empty()) {
    p.heading("Effects fitted with the errors");
    std::vector<std::vector<std::string>> rows;
    for (const FittedEffect& f : r.effects) {
      for (std::size_t k = 0; k < f.values.size(); ++k) {
        const Determined& v = f.values[k];
        rows.push_back({f.label, f.parameters[k], v.determined ? fmt_num(v.value) : "--",
                        v.determined ? fmt_num(v.std) : "--", f.unit});
      }
    }
    p.table({"effect", "parameter", "value", "u", "unit"}, rows);
  }
  iso230_section(p, r.iso, iso_uncertainty_note(r));
  if (conformance) conformance_section(p, *conformance);
  p.heading("Residuals");
  const InstrumentInfo& info = instrument_info(design.instrument);
  p.figure(
      [&] {
        return plot_residual_panels("residual per " + std::string(info.row_carrier) + " [um]",
                                    residual_panels(design, readings, est.residual_um));
      },
      "Residual of every reading against the fitted model: a panel per " +
          std::string(info.row_carrier) + " on one scale, each sweep a line in angle order.");
  p.figure(
      [&] {
        return plot_residual_polar("residual around the turn",
                                   residual_panels(design, readings, est.residual_um));
      },
      "The same residuals as " + std::string(info.polar_plot) +
          ": each trace leaves the dashed circle outwards where " + info.polar_reading +
          " (not to scale with the machine).");
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
