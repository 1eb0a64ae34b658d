#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

#include "dbbkit/instrument.hpp"
#include "dbbkit/io/diagnose_text.hpp"
#include "dbbkit/io/plots.hpp"
#include "dbbkit/io/report_writer.hpp"
#include "dbbkit/io/reports.hpp"
#include "dbbkit/io/result_io.hpp"
#include "dbbkit/io/text.hpp"
#include "dbbkit/kinematics.hpp"
#include "report_sections.hpp"

namespace dbbkit::io {

using namespace detail;

namespace {

// The effects of diagnose's library this design cannot detect: those the axis errors take
// (confounded), and those its readings cannot carry (not applicable: no times, one sweep).
void effects_section(ReportWriter& p, const Design& design,
                     const std::vector<CandidateStatus>& effects) {
  p.heading("Effects this design cannot detect");
  std::vector<std::vector<std::string>> rows;
  int detectable = 0;
  for (const CandidateStatus& c : effects) {
    if (c.state == CandidateState::kDetectable) ++detectable;
    if (c.state == CandidateState::kConfounded)
      rows.push_back({c.label, "taken by the axis errors", candidate_detail(c)});
    if (c.state == CandidateState::kNotApplicable)
      rows.push_back(
          {c.label, "not applicable to these readings", not_applicable_text(c.applicability)});
  }
  p.paragraph(std::to_string(detectable) + " of the " + std::to_string(effects.size()) +
              " effects diagnose can add are detectable with this design (" +
              design.errors.describe() + "). " +
              (rows.empty() ? std::string("It can detect every one.")
                            : "The others: an effect the axis errors take leaves no residual and "
                              "moves the errors instead; an effect not applicable needs what the "
                              "design's nominal readings lack (times, both sweeps): measured with "
                              "times and both sweeps (program --sweeps both), diagnose tests it."));
  if (!rows.empty()) p.table({"effect", "why not", "detail"}, rows);
}

// Every set-up effect: declared size, detectable, detection limit, largest bias per um.
void setup_checks_section(ReportWriter& p, const Evaluation& ev) {
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
                    c.detectable ? "yes" : "NO" + hidden_directions_text(c),
                    fmt_opt(c.detection_limit_um), bias});
  }
  p.table({"effect", "declared std [um]", "detectable", "detection limit [um]", "largest bias"},
          rows);
}

}  // namespace

std::string evaluate_report(ReportFormat f, const RunContext& run, const Design& design,
                            const Evaluation& ev, const std::vector<SweepVariable>& variables,
                            const std::vector<SweepPoint>& map, const MonteCarloResult* mc,
                            const Expansion& expansion,
                            const std::vector<CandidateStatus>* effects) {
  const std::unique_ptr<ReportWriter> page =
      make_report_writer(f, "dbbkit evaluate: " + design.name);
  ReportWriter& p = *page;
  const Estimate& est = ev.prior;
  const double k = expansion.k, coverage = expansion.coverage_probability;
  summary_section(p, evaluate_brief(design, ev));
  warnings_section(p, ev.warnings);
  p.heading("What the design can identify");
  std::string s = std::to_string(est.n_readings) + " readings (one per " +
                  instrument_info(design.instrument).row_carrier + " and angle), " +
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
    p.paragraph("Set-up: " + evaluation_setup_note(ev) +
                ". The plot and table show the total (noise and set-up).");
    errors_section(p, expanded_errors(ev.total_errors, k), false,
                   "a-priori expanded total uncertainty of " + design.name, coverage);
  } else {
    p.paragraph(as_sentence(evaluation_setup_note(ev)));
    errors_section(p, expanded_errors(ev.errors, k), false,
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
    const bool any_determined = std::any_of(
        map.begin(), map.end(), [](const SweepPoint& pt) { return pt.worst_std_um.has_value(); });
    if (!any_determined) {
      p.paragraph(
          "No point of the map determines every error: worst_std_um is undetermined "
          "everywhere (rank below the unknowns), so there is nothing to plot.");
    } else if (variables.size() == 2) {
      p.figure(
          [&] {
            std::vector<double> z;
            // sweep_design varies the last variable fastest: x = the second variable.
            for (const SweepPoint& pt : map) z.push_back(pt.worst_std_um.value_or(kNaN));
            // The design's own point and the best of the map, marked.
            std::vector<HeatmapMark> marks;
            auto coordinate = [&](const SweepVariable& v) {
              const Installation& in = design.installations[v.installations.front()];
              return v.coord == 0 ? in.L_mm : v.coord == 1 ? in.D_mm : in.H_mm;
            };
            marks.push_back({coordinate(variables[1]), coordinate(variables[0]), "this design"});
            const int best = best_sweep_point(map);
            std::optional<double> z_max;
            if (best >= 0) {
              marks.push_back({map[best].values[1], map[best].values[0], "best"});
              z_max = 2 * *map[best].worst_std_um;
            }
            return plot_heatmap("worst_std_um [um] over the design map",
                                variables[1].name + " [mm]", variables[0].name + " [mm]",
                                "worst_std_um [um]", variables[1].values, variables[0].values, z,
                                z_max, marks);
          },
          "worst_std_um at each point of the map (viridis; the scale runs from the best point to "
          "twice its value, larger values take the top colour); the design evaluated and the "
          "map's best point marked; blank where not every error is determined.");
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
  if (effects) effects_section(p, design, *effects);
  conditions(p, run, &design);
  return p.str();
}

}  // namespace dbbkit::io
