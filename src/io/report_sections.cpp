#include "report_sections.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <iomanip>
#include <sstream>
#include <utility>

#include "dbbkit/instrument.hpp"
#include "dbbkit/io/plots.hpp"
#include "dbbkit/io/result_io.hpp"
#include "dbbkit/io/text.hpp"
#include "dbbkit/io/tolerances_io.hpp"
#include "dbbkit/kinematics.hpp"

namespace dbbkit::io::detail {

namespace {

struct DesignTable {
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
};

// A ball bar's installations: id, L, D, H, direction, sign, bar, set-up.
DesignTable installation_table(const Design& d) {
  DesignTable t;
  t.header = {"id", "L [mm]", "D [mm]", "H [mm]", "direction", "sign", "bar [mm]", "set-up"};
  for (const Installation& in : d.installations) {
    t.rows.push_back({in.id, fmt_num(in.L_mm, 6), fmt_num(in.D_mm, 6),
                      d.axis.has_H() ? fmt_num(in.H_mm, 6) : "--", in.direction.label(),
                      std::to_string(in.sign), in.bar_mm ? fmt_num(*in.bar_mm, 6) : "--",
                      in.description});
  }
  return t;
}

// A probe's spheres, not its channels: id, L, D, H, set-up.
DesignTable sphere_table(const Design& d) {
  DesignTable t;
  t.header = {"sphere", "L [mm]", "D [mm]", "H [mm]", "set-up"};
  for (const Sphere& sp : d.spheres)
    t.rows.push_back({sp.id, fmt_num(sp.L_mm, 6), fmt_num(sp.D_mm, 6),
                      d.axis.has_H() ? fmt_num(sp.H_mm, 6) : "--", sp.description});
  return t;
}

// What the design section lists, one per instrument in the order of InstrumentKind.
struct InstrumentTable {
  InstrumentKind kind;
  DesignTable (*table)(const Design& d);
};
constexpr std::array<InstrumentTable, 2> kDesignTables = {{
    {InstrumentKind::kBallbar, installation_table},
    {InstrumentKind::kProbe, sphere_table},
}};
static_assert(kDesignTables[0].kind == InstrumentKind::kBallbar &&
                  kDesignTables[1].kind == InstrumentKind::kProbe,
              "kDesignTables is indexed by InstrumentKind");

}  // namespace

void design_section(ReportWriter& p, const Design& d) {
  p.heading("Design");
  const std::string measured = measured_phrase(d);
  p.paragraph(d.name + ": axis " + d.axis.label() + ", " + std::to_string(d.angles_deg.size()) +
              " angles from " +
              fmt_num(*std::min_element(d.angles_deg.begin(), d.angles_deg.end()), 6) + " to " +
              fmt_num(*std::max_element(d.angles_deg.begin(), d.angles_deg.end()), 6) + " deg, " +
              measured + ", errors " + d.errors.describe() + ".");
  if (!d.description.empty()) p.paragraph(d.description);
  p.figure([&] { return plot_design(d); }, instrument_info(d.instrument).design_caption);
  const DesignTable t = kDesignTables[static_cast<std::size_t>(d.instrument)].table(d);
  p.table(t.header, t.rows);
}

// Residual against angle, one line per installation.
std::vector<ResidualPanel> residual_panels(const Design& d, const std::vector<Reading>& readings,
                                           const Eigen::VectorXd& residual) {
  std::vector<ResidualPanel> out;
  for (const Installation& in : d.installations) {
    ResidualPanel panel;
    panel.installation = in.id;
    // Readings of one sweep and repeat form a line; lines in the order first read.
    std::vector<std::pair<std::string, std::vector<std::pair<double, double>>>> lines;
    for (size_t i = 0; i < readings.size(); ++i) {
      const Reading& r = readings[i];
      if (r.installation != in.id) continue;
      std::string key = r.sweep ? sweep_name(*r.sweep) : "sweep not recorded";
      if (r.repeat) key += " #" + std::to_string(*r.repeat);
      auto it = std::find_if(lines.begin(), lines.end(), [&](auto& l) { return l.first == key; });
      if (it == lines.end()) {
        lines.push_back({key, {}});
        it = lines.end() - 1;
      }
      it->second.push_back({r.angle_deg, residual(static_cast<long>(i))});
    }
    for (auto& [key, pts] : lines) {
      std::stable_sort(pts.begin(), pts.end(), [](auto& a, auto& b) { return a.first < b.first; });
      ResidualLine l;
      l.sweep = key;
      for (auto& [a, r] : pts) l.angle_deg.push_back(a), l.residual_um.push_back(r);
      panel.lines.push_back(std::move(l));
    }
    if (!panel.lines.empty()) out.push_back(std::move(panel));
  }
  return out;
}

void iso230_section(ReportWriter& p, const IsoResult& iso, const std::string& note) {
  p.heading("In ISO 230-7 terms");
  p.paragraph(
      "First order. Location errors of the axis average line and the constant parts, fitted by "
      "least squares "
      "to the determined values; the component error motions are what remains. " +
      as_sentence(note));
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
    for (std::size_t e = 0; e < mv.values.size(); ++e) {
      const IsoMotionValue& v = mv.values[e];
      if (v.computed) {
        vals.push_back({v.name, v.component, fmt_num(v.value), fmt_num(v.U),
                        "[" + fmt_num(v.low) + ", " + fmt_num(v.high) + "]", v.unit});
      } else {
        vals.push_back(
            {v.name, v.component, "--", "--", iso_motion_reason(v, static_cast<int>(e)), v.unit});
      }
    }
    p.paragraph("Error motion values (ISO 230-7, fixed sensitive direction). " +
                as_sentence(iso_motion_note(mv)));
    p.table({"quantity", "component", "value", "U",
             "interval (at least " + fmt_num(100 * mv.coverage_probability) + " %)", "unit"},
            vals);
  }
  if (!iso.gaps.empty() || !iso.not_in_model.empty()) p.paragraph(as_sentence(iso_gaps_note(iso)));
}

// The conformance decisions (conformance.hpp): the rule, then one row per tolerance.
void summary_section(ReportWriter& p, const std::vector<BriefItem>& brief) {
  if (brief.empty()) return;
  p.heading("Summary");
  std::vector<std::string> items;
  for (const BriefItem& b : brief) items.push_back(b.text);
  p.bullets(items);
}

void warnings_section(ReportWriter& p, const std::vector<Warning>& warnings) {
  if (warnings.empty()) return;
  p.heading("Warnings");
  for (const Warning& w : warnings) p.paragraph("WARNING: " + w.text);
}

void unidentifiable_section(ReportWriter& p, const std::vector<Unidentifiable>& list) {
  if (list.empty()) return;
  p.heading("Not determined");
  p.paragraph(std::to_string(list.size()) +
              " combination(s) of the errors no reading sees; their values are reported as '--', "
              "never as numbers.");
  std::vector<std::vector<std::string>> rows;
  for (const Unidentifiable& u : list) {
    rows.push_back({u.angle_deg ? fmt_num(*u.angle_deg, 6) : "all", unidentifiable_expression(u),
                    unidentifiable_interpretation(u)});
  }
  p.table({"angle [deg]", "combination", "meaning"}, rows);
}

// Errors with U = k u per value (k from the budget when there is one).
// `coverage`: the coverage probability of U.
void errors_section(ReportWriter& p, const std::vector<ExpandedErrorsAtAngle>& expanded,
                    bool values, const std::string& what, double coverage) {
  const std::string at = "U (" + fmt_num(100 * coverage) + " %)";
  p.figure([&] { return plot_errors(expanded, values, what); },
           values ? "The six errors against angle; the band is the expanded uncertainty " + at + "."
                  : "Expanded uncertainty " + at +
                        " of each error at each angle, before any reading is taken.");
  p.table(errors_header(values), errors_rows(expanded, values));
}

// A clause as a sentence: capital first letter, full stop.
std::string as_sentence(std::string text) {
  if (!text.empty()) text[0] = static_cast<char>(std::toupper(static_cast<unsigned char>(text[0])));
  return text + ".";
}

std::vector<std::string> errors_header(bool values) {
  std::vector<std::string> h = {"angle [deg]"};
  for (int e = 0; e < 6; ++e) {
    h.push_back(std::string(kErrorNames[e]) + (values ? " ± U" : " U") + " [" + kErrorUnits[e] +
                "]");
  }
  return h;
}

std::vector<std::vector<std::string>> errors_rows(const std::vector<ExpandedErrorsAtAngle>& errors,
                                                  bool values) {
  std::vector<std::vector<std::string>> rows;
  for (const ExpandedErrorsAtAngle& ea : errors) {
    std::vector<std::string> r = {fmt_num(ea.angle_deg, 6)};
    for (int e = 0; e < 6; ++e) {
      const ExpandedValue& d = ea.errors[e];
      std::ostringstream c;
      c << std::fixed << std::setprecision(2);
      if (!d.determined) {
        c << "--";
      } else if (values) {
        c << d.value << " ± " << d.U;
      } else {
        c << d.U;
      }
      r.push_back(c.str());
    }
    rows.push_back(r);
  }
  return rows;
}

void conditions(ReportWriter& p, const RunContext& run, const Design* design) {
  p.conditions(run.command, run.inputs, design);
}

void conformance_section(ReportWriter& p, const ConformanceReport& c) {
  p.heading(c.corrected ? "Conformance of the corrected errors" : "Conformance");
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

}  // namespace dbbkit::io::detail
