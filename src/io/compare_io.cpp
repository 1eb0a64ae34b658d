#include "dbbkit/io/compare_io.hpp"

#include <algorithm>
#include <boost/math/distributions/normal.hpp>
#include <cmath>
#include <iomanip>
#include <map>
#include <sstream>

#include "dbbkit/error.hpp"
#include "dbbkit/io/plots.hpp"
#include "dbbkit/io/text.hpp"
#include "dbbkit/kinematics.hpp"
#include "report_sections.hpp"

namespace dbbkit::io {

using nlohmann::json;

namespace {

double gaussian_factor(double two_sided_level) {
  const boost::math::normal n01;
  return boost::math::quantile(boost::math::complement(n01, two_sided_level / 2));
}

ComparedQuantity compared(const std::string& kind, const std::string& name, const std::string& unit,
                          std::optional<double> a, std::optional<double> ua,
                          std::optional<double> b, std::optional<double> ub) {
  ComparedQuantity q{kind, name, unit, a, b, std::nullopt, std::nullopt, false};
  if (a && b && ua && ub) {
    q.change = *b - *a;
    q.u = std::hypot(*ua, *ub);
  }
  return q;
}

// What the significance of a change assumes and the inputs' warnings contradict: each
// result's uncertainty holding as stated (warnings.hpp names the kinds).
std::optional<std::string> caveat(const std::vector<InputWarning>& warnings) {
  if (warnings.empty()) return std::nullopt;
  // One reason per kind, with the results that give it ("in A", "in A and B").
  std::vector<std::pair<std::string, std::string>> reasons;  // what, who
  for (const InputWarning& w : warnings) {
    const std::string what =
        w.kind == "residual" || w.kind == "noise_scale" ? "residual contradicts the declared noise"
        : w.kind == "setup_undeclared"
            ? "design declares no set-up tolerances for effects the readings cannot see (a ball "
              "re-seated or a cup re-centred between the measurements moves the errors unseen)"
        : w.kind == "first_order" ? "errors may be biased by the neglected second-order term"
                                  : "uncertainties may not hold (the warning)";
    auto r = std::find_if(reasons.begin(), reasons.end(),
                          [&](const auto& x) { return x.first == what; });
    if (r == reasons.end()) r = reasons.insert(reasons.end(), {what, ""});
    const std::string who(1, w.result);
    if (r->second.find(who) == std::string::npos)
      r->second += (r->second.empty() ? "in " : " and ") + who;
  }
  std::string s = "each change's significance assumes both results' uncertainties hold as stated; ";
  for (std::size_t i = 0; i < reasons.size(); ++i)
    s += (i == 0 ? "" : "; ") + reasons[i].second + " the " + reasons[i].first;
  s += ": a change called significant here may be the measurements', not the machine's. Declare "
       "setup_std in both designs and identify again (or diagnose the residual) before reading a "
       "change as the machine's";
  return s;
}

}  // namespace

int Comparison::significant() const {
  int n = 0;
  for (const ComparedQuantity& q : quantities) n += q.significant;
  return n;
}

Comparison compare_results(const ResultFile& a, const ResultFile& b, double level) {
  if (!a.axis.same_axis(b.axis)) {
    throw InputError(b.source, "design.axis",
                     "this result is of axis " + b.axis.label() + ", " + a.source + " of axis " +
                         a.axis.label() + " (" + axis_difference(b.axis, a.axis) +
                         "): only two measurements of one axis compare");
  }
  if (!(level > 0 && level < 1)) throw InputError("--level", "", "must be in (0, 1)");
  Comparison c;
  c.a = a;
  c.b = b;
  c.level = level;
  if (!a.data_source.empty() && a.data_source == b.data_source)
    c.notes.push_back("both come from the same readings (" + a.data_source +
                      "): they are not independent, and a change is the models', not the "
                      "machine's");
  if (a.design_name != b.design_name)
    c.notes.push_back("the designs differ (" + a.design_name + ", " + b.design_name +
                      "): the same axis, measured otherwise");
  if (a.errors_model != b.errors_model)
    c.notes.push_back("the error models differ (" + a.errors_model + ", " + b.errors_model + ")");
  if (a.setup_included != b.setup_included)
    c.notes.push_back(std::string("the set-up tolerances are in the uncertainty of ") +
                      (a.setup_included ? "A" : "B") + " only");
  for (const auto& [kind, la, lb] : {std::tuple{"location", &a.location, &b.location},
                                     std::tuple{"constant part", &a.constants, &b.constants}}) {
    // Every quantity of either, in A's order and then B's own: one given in only one of them
    // has no change, and is said to be missing from the other.
    for (const ResultQuantity& qa : *la) {
      const auto qb = std::find_if(lb->begin(), lb->end(),
                                   [&](const ResultQuantity& q) { return q.name == qa.name; });
      if (qb == lb->end()) {
        c.quantities.push_back(compared(kind, qa.name, qa.unit, qa.value, qa.std, {}, {}));
        c.notes.push_back(qa.name + " is not in B");
      } else {
        c.quantities.push_back(
            compared(kind, qa.name, qa.unit, qa.value, qa.std, qb->value, qb->std));
      }
    }
    for (const ResultQuantity& qb : *lb) {
      if (std::none_of(la->begin(), la->end(),
                       [&](const ResultQuantity& q) { return q.name == qb.name; })) {
        c.quantities.push_back(compared(kind, qb.name, qb.unit, {}, {}, qb.value, qb.std));
        c.notes.push_back(qb.name + " is not in A");
      }
    }
  }
  for (const ResultMotionValue& ma : a.motion_values) {
    for (const ResultMotionValue& mb : b.motion_values) {
      if (ma.component != mb.component) continue;
      const double fa = gaussian_factor(1 - a.motion_coverage),
                   fb = gaussian_factor(1 - b.motion_coverage);
      c.quantities.push_back(
          compared("error motion value", ma.name + " (" + ma.component + ")", ma.unit, ma.value,
                   ma.U ? std::optional<double>(*ma.U / fa) : std::nullopt, mb.value,
                   mb.U ? std::optional<double>(*mb.U / fb) : std::nullopt));
    }
  }
  for (const ComparedQuantity& q : c.quantities) c.tested += q.change.has_value();
  c.z = c.tested > 0 ? gaussian_factor(level / c.tested) : 0.0;
  // A change of no uncertainty is significant when it is not zero.
  for (ComparedQuantity& q : c.quantities)
    q.significant = q.change && std::abs(*q.change) > c.z * *q.u;
  // The angles of both, matched within 1e-9 deg through B's angles in order (linear in the
  // angles after the sort, whatever their number).
  std::multimap<double, const ResultErrors*> b_at;
  for (const ResultErrors& eb : b.errors) b_at.emplace(eb.angle_deg, &eb);
  for (const ResultErrors& ea : a.errors) {
    for (auto it = b_at.lower_bound(ea.angle_deg - 1e-9);
         it != b_at.end() && it->first <= ea.angle_deg + 1e-9; ++it) {
      const ResultErrors& eb = *it->second;
      ComparedErrors e;
      e.angle_deg = ea.angle_deg;
      for (int k = 0; k < 6; ++k) {
        if (ea.value[k] && eb.value[k]) {
          e.change[k] = *eb.value[k] - *ea.value[k];
          e.u[k] = std::hypot(*ea.std[k], *eb.std[k]);
        }
      }
      c.errors.push_back(e);
    }
  }
  if (c.errors.empty())
    c.notes.push_back("no angle is measured in both: the error curves are not compared");
  for (const auto& [who, r] : {std::pair{'A', &a}, std::pair{'B', &b}}) {
    for (std::size_t k = 0; k < r->warnings.size(); ++k)
      c.input_warnings.push_back(
          {who, k < r->warning_kinds.size() ? r->warning_kinds[k] : std::string(), r->warnings[k]});
  }
  c.caveat = caveat(c.input_warnings);
  return c;
}

json comparison_to_json(const Comparison& c) {
  json j;
  j["format"] = "dbbkit.compare/1";
  j["dbbkit_version"] = DBBKIT_VERSION;
  j["inputs"] = {{"a", c.a.source}, {"b", c.b.source}};
  j["axis"] = c.a.axis.label();
  j["method"] =
      "change = B - A; u = sqrt(u_A^2 + u_B^2), the two results independent (what they share "
      "cancels in the change and is in neither budget); significant: |change| > z u, z the "
      "two-sided Gaussian factor at level / m (Bonferroni over the m quantities with a change); an "
      "error motion value's u is its U over the Gaussian factor of its coverage";
  j["level"] = c.level;
  j["tested"] = c.tested;
  j["z"] = c.z;
  j["significant_changes"] = c.significant();
  j["notes"] = c.notes;
  json warnings = json::array();
  for (const InputWarning& w : c.input_warnings)
    warnings.push_back({{"result", std::string(1, w.result)}, {"kind", w.kind}, {"text", w.text}});
  j["input_warnings"] = warnings;
  j["caveat"] = c.caveat ? json(*c.caveat) : json(nullptr);
  json list = json::array();
  for (const ComparedQuantity& q : c.quantities) {
    auto opt = [](const std::optional<double>& x) { return x ? json(*x) : json(nullptr); };
    list.push_back({{"kind", q.kind},
                    {"name", q.name},
                    {"unit", q.unit},
                    {"a", opt(q.a)},
                    {"b", opt(q.b)},
                    {"change", opt(q.change)},
                    {"u", opt(q.u)},
                    {"U", q.u ? json(c.z * *q.u) : json(nullptr)},
                    {"significant", q.significant}});
  }
  j["quantities"] = list;
  json errors = json::array();
  for (const ComparedErrors& e : c.errors) {
    json change, u;
    for (int k = 0; k < 6; ++k) {
      change[kErrorNames[k]] = e.change[k] ? json(*e.change[k]) : json(nullptr);
      u[kErrorNames[k]] = e.u[k] ? json(*e.u[k]) : json(nullptr);
    }
    errors.push_back({{"angle_deg", e.angle_deg}, {"change", change}, {"u", u}});
  }
  j["errors_at_common_angles"] = errors;
  return j;
}

namespace {

std::vector<std::vector<std::string>> quantity_rows(const Comparison& c) {
  std::vector<std::vector<std::string>> rows;
  auto num = [](const std::optional<double>& x) { return x ? fmt_num(*x, 4) : std::string("--"); };
  for (const ComparedQuantity& q : c.quantities) {
    rows.push_back({q.name, q.unit, num(q.a), num(q.b), num(q.change), num(q.u),
                    q.u ? fmt_num(c.z * *q.u, 3) : "--",
                    !q.change       ? "not determined in both"
                    : q.significant ? "YES"
                                    : "no"});
  }
  return rows;
}

const std::vector<std::string> kHeader = {"quantity",     "unit",      "A",   "B",
                                          "change B - A", "u (k = 1)", "z u", "significant"};

std::string verdict(const Comparison& c) {
  std::ostringstream s;
  s << c.significant() << " of " << c.tested
    << " quantities changed significantly (family-wise level " << fmt_num(c.level)
    << ", each at |change| > " << fmt_num(c.z, 3) << " u)";
  std::string names;
  for (const ComparedQuantity& q : c.quantities)
    if (q.significant) names += (names.empty() ? "" : ", ") + q.name;
  if (!names.empty()) s << ": " << names;
  s << (c.caveat ? " (if both results' uncertainties hold: see the caveat)." : ".");
  return s.str();
}

}  // namespace

std::string comparison_summary(const Comparison& c) {
  std::ostringstream s;
  s << "compare axis " << c.a.axis.label() << ": A " << terminal_text(c.a.source) << " ("
    << terminal_text(c.a.design_name) << "), B " << terminal_text(c.b.source) << " ("
    << terminal_text(c.b.design_name) << ")\n";
  for (const InputWarning& w : c.input_warnings)
    s << "WARNING (from " << w.result << "): " << terminal_text(w.text) << "\n";
  if (c.caveat) s << "CAVEAT: " << terminal_text(*c.caveat) << ".\n";
  s << verdict(c) << "\n";
  for (const std::string& n : c.notes) s << "note: " << terminal_text(n) << "\n";
  s << "\n"
    << std::left << std::setw(52) << "quantity" << std::right << std::setw(6) << "unit"
    << std::setw(12) << "A" << std::setw(12) << "B" << std::setw(12) << "change" << std::setw(10)
    << "u"
    << "  significant\n";
  for (const std::vector<std::string>& r : quantity_rows(c)) {
    s << std::left << std::setw(52) << r[0] << std::right << std::setw(6) << r[1] << std::setw(12)
      << r[2] << std::setw(12) << r[3] << std::setw(12) << r[4] << std::setw(10) << r[5] << "  "
      << r[7] << "\n";
  }
  return s.str();
}

std::string comparison_report(ReportFormat format, const RunContext& run, const Comparison& c) {
  const std::unique_ptr<ReportWriter> page =
      make_report_writer(format, "dbbkit compare: axis " + c.a.axis.label());
  ReportWriter& p = *page;
  if (!c.input_warnings.empty()) {
    p.heading("Warnings");
    for (const InputWarning& w : c.input_warnings)
      p.paragraph(std::string("From ") + w.result + ": " + w.text);
    p.paragraph("Caveat: " + *c.caveat + ".");
  }
  p.heading("Verdict");
  p.paragraph(verdict(c) + " A: " + c.a.source + " (" + c.a.design_name + "); B: " + c.b.source +
              " (" + c.b.design_name + ").");
  for (const std::string& n : c.notes) p.paragraph("Note: " + n + ".");
  p.paragraph(
      "The change is B - A with u = sqrt(u_A^2 + u_B^2): the two results are taken as "
      "independent, each budget with its own reading noise and set-up; what they share (the "
      "bar's calibration, a set-up left in place) cancels in the change and is in neither "
      "budget. Significant: |change| > z u with z at the family-wise level over the " +
      std::to_string(c.tested) + " quantities (Bonferroni).");
  p.heading("Location errors, constant parts and error motion values");
  p.table(kHeader, quantity_rows(c));
  if (!c.errors.empty()) {
    p.heading("The errors of both, with their bands");
    for (int k = 0; k < 6; ++k) {
      p.figure(
          [&c, k] {
            std::vector<PlotSeries> series;
            for (const auto& [label, r] : {std::pair{"A", &c.a}, std::pair{"B", &c.b}}) {
              PlotSeries s;
              s.title = std::string(label);
              for (const ResultErrors& e : r->errors) {
                if (!e.value[k]) continue;
                s.x.push_back(e.angle_deg);
                s.y.push_back(*e.value[k]);
                s.lo.push_back(*e.value[k] - 2 * *e.std[k]);
                s.hi.push_back(*e.value[k] + 2 * *e.std[k]);
              }
              series.push_back(s);
            }
            return plot_series(std::string(kErrorNames[k]) + " of A and B", "angle [deg]",
                               std::string(kErrorNames[k]) + " [" + kErrorUnits[k] + "]", series);
          },
          std::string(kErrorNames[k]) +
              " of both results against the angle, each with its band "
              "of +-2 u (u: its combined standard uncertainty).");
    }
  }
  detail::conditions(p, run, nullptr);
  return p.str();
}

}  // namespace dbbkit::io
