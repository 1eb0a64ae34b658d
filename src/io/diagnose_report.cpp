#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

#include "dbbkit/instrument.hpp"
#include "dbbkit/io/diagnose_io.hpp"
#include "dbbkit/io/diagnose_text.hpp"
#include "dbbkit/io/plots.hpp"
#include "dbbkit/io/report_writer.hpp"
#include "dbbkit/io/reports.hpp"
#include "dbbkit/io/text.hpp"
#include "dbbkit/kinematics.hpp"
#include "report_sections.hpp"

namespace dbbkit::io {

using namespace detail;

std::string diagnose_report(ReportFormat f, const RunContext& run, const Design& design,
                            const std::vector<Reading>& given, const DiagnoseResult& r,
                            const Expansion& expansion, const ConformanceReport* conformance) {
  // The readings fitted: those given, less any the user asked to exclude (--exclude-gross).
  std::vector<Reading> readings;
  for (std::size_t j = 0; j < given.size(); ++j) {
    if (!std::binary_search(r.excluded_rows.begin(), r.excluded_rows.end(), static_cast<int>(j)))
      readings.push_back(given[j]);
  }
  const std::unique_ptr<ReportWriter> page =
      make_report_writer(f, "dbbkit diagnose: " + design.name);
  ReportWriter& p = *page;
  summary_section(p, diagnose_brief(design, r));
  warnings_section(p, r.warnings);
  p.heading("Verdict");
  p.paragraph(diagnose_verdict(design, given, r));
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
      rows.push_back({describe_feature(design, given, *sorted[i]), fmt_num(sorted[i]->p, 3)});
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
  const InstrumentInfo& info = instrument_info(design.instrument);
  auto residual_figure = [&](const char* title, const Eigen::VectorXd& residual,
                             const std::string& caption) {
    p.figure(
        [&] {
          return plot_residual_panels(std::string(title) + " [um]",
                                      residual_panels(design, readings, residual));
        },
        caption);
  };
  residual_figure("residual before (axis errors only)", r.before.residual_um,
                  "Residual with the six error motions alone: a panel per " +
                      std::string(info.row_carrier) +
                      " on one scale, each sweep a line in angle order.");
  residual_figure("residual after (with the effects added)", r.after.residual_um,
                  "Residual per " + std::string(info.row_carrier) + " with the effects added.");
  p.figure(
      [&] {
        return plot_residual_polar("residual before, around the turn",
                                   residual_panels(design, readings, r.before.residual_um));
      },
      "The residual before as " + std::string(info.polar_plot) +
          ": each trace leaves the dashed circle outwards where " + info.polar_reading + ".");
  p.heading("Change of the errors");
  {
    std::vector<std::vector<std::string>> largest;
    for (int e = 0; e < 6; ++e) {
      largest.push_back({kErrorNames[e],
                         r.largest_change_of_errors[e]
                             ? fmt_rounded(*r.largest_change_of_errors[e], 3) + " " + kErrorUnits[e]
                             : "not determined before and after"});
    }
    p.paragraph(
        "What adding the effects changed: the errors after minus the errors before, at "
        "each position where both are determined ('--' elsewhere), to 0.001 um or urad; the "
        "largest change of each error first.");
    p.table({"error", "largest |after - before|"}, largest);
    std::vector<std::vector<std::string>> rows;
    for (size_t a = 0; a < r.errors_before.size() && a < r.errors_after.size(); ++a) {
      std::vector<std::string> row = {fmt_num(r.errors_before[a].angle_deg, 6)};
      for (int e = 0; e < 6; ++e) {
        const Determined &b = r.errors_before[a].errors[e], &f = r.errors_after[a].errors[e];
        row.push_back(b.determined && f.determined ? fmt_rounded(f.value - b.value, 3) : "--");
      }
      rows.push_back(row);
    }
    p.table({"angle [deg]", "dx [um]", "dy [um]", "dz [um]", "ex [urad]", "ey [urad]", "ez [urad]"},
            rows);
  }
  p.heading("Errors after");
  errors_section(p, expanded_errors(r.errors_after, expansion.k), true,
                 "errors with the effects added, " + design.name, expansion.coverage_probability);
  unidentifiable_section(p, r.unidentifiable_after);
  iso230_section(p, r.iso_after, diagnose_iso_note(r));
  if (conformance) conformance_section(p, *conformance);
  p.heading("Details");
  p.preformatted(diagnose_summary(design, given, r));
  std::vector<std::vector<std::string>> cand;
  for (const CandidateStatus& c : r.candidates)
    cand.push_back({c.label, candidate_state_name(c.state), candidate_detail(c)});
  p.table({"candidate", "status", "why"}, cand);
  conditions(p, run, &design);
  return p.str();
}

}  // namespace dbbkit::io
