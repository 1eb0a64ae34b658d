#include "dbbkit/io/compensation_io.hpp"

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <optional>
#include <sstream>

#include "dbbkit/error.hpp"
#include "dbbkit/io/escape.hpp"
#include "dbbkit/io/predict_io.hpp"
#include "dbbkit/io/text.hpp"
#include "dbbkit/user_text.hpp"

namespace dbbkit::io {

namespace {

constexpr double kPi = 3.14159265358979323846;

// A value in the target's unit: um -> mm, urad -> rad.
double to_si(double v, const std::string& unit) { return unit == "urad" ? v * 1e-6 : v * 1e-3; }
std::string si_unit(const std::string& unit) { return unit == "urad" ? "rad" : "mm"; }

// "k = 2 (about 95.4 % for a normal distribution)".
std::string k_text(double k) {
  const double p = std::erf(k / std::sqrt(2.0));
  return "k = " + fmt_num(k, 6) + " (about " + fmt_num(100 * p, 3) +
         " % for a normal distribution)";
}

std::string g9(double v) {
  char b[40];
  std::snprintf(b, sizeof b, "%.9g", v == 0 ? 0.0 : v);
  return b;
}

// A number as a controller reads it: fixed point, 9 decimals at most, no exponent, no "-0".
std::string fixed(double v) {
  char b[64];
  std::snprintf(b, sizeof b, "%.9f", v);
  std::string t = b;
  while (!t.empty() && t.back() == '0') t.pop_back();
  if (!t.empty() && t.back() == '.') t.pop_back();
  if (t == "-0" || t.empty()) t = "0";
  return t;
}

// A length written for a controller [mm], within kMaxCompensation_mm; `what` names it.
double written_mm(double mm, const std::string& source, const std::string& what) {
  if (!(std::abs(mm) <= kMaxCompensation_mm))
    throw InputError(source, what,
                     "would be written as " + g9(mm) + " mm, beyond +-" + g9(kMaxCompensation_mm) +
                         " mm: no machine's location; not written");
  return mm;
}

// Whether a value is worth entering, and why not.
struct Verdict {
  bool enter = false;
  std::string why;        // empty when it is
  bool envelope = false;  // left out by the envelope's judgement, not for its own U
};
Verdict verdict(const ResultQuantity& q, double k) {
  if (!q.value) return {false, "not determined by the measurement"};
  if (std::abs(*q.value) <= k * *q.std)
    return {false, "too uncertain: |value| <= U, not distinguishable from zero"};
  return {true, ""};
}

std::vector<Verdict> per_value(const std::vector<ResultQuantity>& location, double k) {
  std::vector<Verdict> out;
  for (const ResultQuantity& q : location) out.push_back(verdict(q, k));
  return out;
}

std::string um_text(double x) { return fmt_rounded(x, 2) + " um"; }

// A coverage in percent with the digits that tell it from 100 % (95.45, 99.9999943).
std::string coverage_text(double p) {
  const int digits = 4 + std::max(0, static_cast<int>(std::ceil(-std::log10(1 - p))) - 2);
  return fmt_num(100 * p, digits);
}

// Each location error's verdict over an envelope judged (determined; five location errors): a
// value worth entering alone but not in the set entered says why.
std::vector<Verdict> entering(const ResultFile& r, const EnvelopeJudgement& j, double k) {
  std::vector<Verdict> out = per_value(r.location, k);
  const bool none = std::none_of(j.enter.begin(), j.enter.end(), [](bool b) { return b; });
  for (std::size_t q = 0; q < 5; ++q) {
    if (!j.candidate[q] || j.enter[q]) continue;
    out[q].enter = false;
    out[q].envelope = true;
    out[q].why = none ? "over the envelope entering leaves up to " + um_text(j.best_bound_um) +
                            " at best, of any set of the values (the error left plus its U), "
                            "not below the largest error today (" +
                            um_text(j.today_um) + ")"
                 : j.bound_with[q] <= j.after_bound_um + 0.005
                     ? "over the envelope entered or not it leaves the same, up to " +
                           um_text(j.after_bound_um) + ": not needed there"
                     : "over the envelope the values marked yes leave up to " +
                           um_text(j.after_bound_um) + "; with it as well, up to " +
                           um_text(j.bound_with[q]);
  }
  return out;
}

std::string list_text(const std::vector<double>& v) {
  std::string out;
  for (const double x : v) out += (out.empty() ? "" : ", ") + fmt_num(x, 12);
  return out;
}

std::string where_text(char letter, const Pose& at) {
  return "at " + std::string(1, letter) + " " + fmt_num(at.angle_deg, 12) + " deg, point (" +
         fmt_rounded(at.point_mm.x(), 1) + ", " + fmt_rounded(at.point_mm.y(), 1) + ", " +
         fmt_rounded(at.point_mm.z(), 1) + ") mm";
}

// The verdicts of one axis' location errors, and, over the envelope where one is given, the
// lines that say what they rest on (each begun by `prefix`).
// `takes`: the values the target can hold (the others are never in a set entered).
std::vector<Verdict> single_axis_verdicts(const ResultFile& r, const CompensationOptions& o,
                                          std::ostream& s, const std::string& prefix,
                                          const std::array<bool, 5>& takes = {true, true, true,
                                                                              true, true}) {
  if (!o.envelope) return per_value(r.location, o.k);
  const EnvelopeGrid& g = *o.envelope;
  const EnvelopeJudgement j = judge_envelope(r, g, o.k, takes);
  if (prefix.empty()) s << "\n";
  s << prefix << "Over the envelope (" << j.points << " points: radii " << list_text(g.radii_mm)
    << " mm from the axis line, heights " << list_text(g.heights_mm) << " mm along it, " << g.around
    << " around, " << g.angles_deg.size() << " angles from "
    << fmt_num(*std::min_element(g.angles_deg.begin(), g.angles_deg.end()), 12) << " to "
    << fmt_num(*std::max_element(g.angles_deg.begin(), g.angles_deg.end()), 12)
    << " deg), the error of the body's point from the location errors (predict --location-only; "
       "the component error motions are not corrected by them and are left out):\n";
  if (!j.determined) {
    s << prefix
      << "  not judged: a location error is not determined; each value is judged on its own\n";
    return per_value(r.location, o.k);
  }
  const bool none = std::none_of(j.enter.begin(), j.enter.end(), [](bool b) { return b; });
  s << prefix << "  today: up to " << um_text(j.today_um) << " (U " << um_text(j.today_U_um) << ") "
    << where_text(r.axis.letter(), j.today_at) << "\n";
  if (!none) {
    std::string names;
    for (std::size_t q = 0; q < 5; ++q)
      if (j.enter[q]) names += (names.empty() ? "" : ", ") + r.location[q].name;
    s << prefix << "  entering " << names << ": at most " << um_text(j.after_bound_um)
      << " left (the error left plus its U, " << coverage_text(j.coverage_probability)
      << " % at each point) " << where_text(r.axis.letter(), j.after_at) << "\n";
  } else if (std::isfinite(j.best_bound_um)) {
    s << prefix << "  entering: none; the best set of values would leave up to "
      << um_text(j.best_bound_um) << " (the error left plus its U), not below today's "
      << um_text(j.today_um) << "\n";
  } else {
    s << prefix << "  entering: none; no value is larger than its U\n";
  }
  return entering(r, j, o.k);
}

// The header's lines: what, from where, units, k.
// The result's warnings, one comment line each: what makes its values unreliable reaches
// whoever enters them.
std::string result_warnings(const ResultFile& r, const std::string& prefix) {
  std::string out;
  for (const std::string& w : r.warnings)
    out += prefix + "WARNING (from the result): " + program_comment(w, 1000) + "\n";
  return out;
}

std::string provenance(const ResultFile& r, const std::string& prefix) {
  return prefix + "dbbkit compensation of axis " + std::string(1, r.axis.letter()) + " (design " +
         program_comment(r.design_name, 120) + ", " + r.format + ", " +
         program_comment(r.source, 200) + ")\n" + prefix +
         "each value is the location error as measured: the axis' actual location minus its "
         "nominal (ISO 230-1), in the work frame the measurement was taught in\n" +
         result_warnings(r, prefix);
}

// The location errors' block of the ISG CSV: each value with its U as a comment, then the row
// of names and the row of values; false when none is determined.
bool isg_location(std::ostream& s, const std::vector<ResultQuantity>& location,
                  const std::vector<Verdict>& verdicts, const std::string& source,
                  const CompensationOptions& o) {
  s << "// ISG CSV: location errors; offsets in mm, angles in rad; U = k u, " << k_text(o.k)
    << "\n";
  std::string names, values, uncertain, undetermined;
  bool envelope = false;  // a value left out by the envelope, not for its U
  for (std::size_t i = 0; i < location.size(); ++i) {
    const ResultQuantity& q = location[i];
    const Verdict& v = verdicts[i];
    if (!q.value) {
      undetermined += " " + q.name;
      continue;
    }
    if (q.unit == "um") written_mm(to_si(*q.value, q.unit), source, q.name);
    s << "//   " << q.name << " = " << g9(to_si(*q.value, q.unit)) << " " << si_unit(q.unit)
      << ", U = " << g9(to_si(o.k * *q.std, q.unit)) << " " << si_unit(q.unit)
      << (v.enter      ? ""
          : v.envelope ? " (not to enter: " + v.why + ")"
                       : std::string(" (too uncertain to enter: |value| <= U)"))
      << "\n";
    if (!v.enter) uncertain += " " + q.name;
    envelope = envelope || v.envelope;
    names += (names.empty() ? "" : " ") + q.name;
    values += (values.empty() ? "" : " ") + g9(to_si(*q.value, q.unit));
  }
  if (!uncertain.empty())
    s << (envelope ? "// not to enter" : "// too uncertain to enter")
      << " (written as measured; set them to 0 to leave them out):" << uncertain << "\n";
  if (!undetermined.empty())
    s << "// not determined by the measurement, not written:" << undetermined << "\n";
  if (names.empty()) {
    s << "// no location error is determined: nothing to compensate\n";
    return false;
  }
  s << names << "\n" << values << "\n";
  return true;
}

std::string isg(const ResultFile& r, const CompensationOptions& o) {
  std::ostringstream s;
  s << provenance(r, "// ");
  if (!isg_location(s, r.location, single_axis_verdicts(r, o, s, "// "), r.source, o))
    return s.str();
  // The component errors over the angle, where all six are given and determined (the reader
  // keeps them in ISO 230-1's order: one table, one column a component).
  std::string omitted;
  std::vector<const ResultComponents*> rows;
  for (const ResultComponents& c : r.components) {
    bool all = c.motions.size() == 6;
    for (const ResultQuantity& m : c.motions) {
      all = all && m.value.has_value();
      if (m.value && m.unit == "um")
        written_mm(to_si(*m.value, m.unit), r.source,
                   m.name + " at " + fmt_num(c.angle_deg, 6) + " deg");
    }
    if (all)
      rows.push_back(&c);
    else
      omitted += " " + fmt_num(c.angle_deg, 6);
  }
  if (!rows.empty()) {
    const std::string letter(1, r.axis.letter());
    s << "#\n// component errors of axis " << letter << " over its angle: " << letter
      << " in deg (the argument: the kernel takes a rotary axis' value in degrees, every error "
         "value in mm or rad)";
    for (const ResultQuantity& m : rows.front()->motions)
      s << ", " << m.name << " in " << si_unit(m.unit);
    s << "\n";
    double largest_u = 0;
    for (const ResultComponents* c : rows) {
      for (const ResultQuantity& m : c->motions) {
        if (m.unit == "um" && o.k * *m.std > largest_u) largest_u = o.k * *m.std;
      }
    }
    s << "// they carry the measurement's uncertainty (U up to " << g9(largest_u * 1e-3)
      << " mm for the translations): a value below its U is noise, not an error to compensate\n";
    if (!omitted.empty())
      s << "// angles where a component is not determined, left out (deg):" << omitted << "\n";
    s << letter;
    for (const ResultQuantity& m : rows.front()->motions) s << " " << m.name;
    s << "\n";
    for (const ResultComponents* c : rows) {
      s << g9(c->angle_deg);
      for (const ResultQuantity& m : c->motions) s << " " << g9(to_si(*m.value, m.unit));
      s << "\n";
    }
  } else {
    s << "// no angle with every component error determined: no component table\n";
  }
  return s.str();
}

std::string default_kins(const ResultFile& r, const CompensationOptions& o) {
  if (!o.linuxcnc_kins.empty()) {
    if (o.linuxcnc_kins != "xyzac-trt" && o.linuxcnc_kins != "xyzbc-trt")
      throw InputError(
          option_name("--kins"), "",
          quote_value(o.linuxcnc_kins) + " is not a module written for (xyzac-trt, xyzbc-trt)");
    const char second = o.linuxcnc_kins == "xyzac-trt" ? 'A' : 'B';
    if (r.axis.letter() != 'C' && r.axis.letter() != second)
      throw InputError(
          option_name("--kins"), "",
          o.linuxcnc_kins + "-kins has no " + std::string(1, r.axis.letter()) + " axis");
    return o.linuxcnc_kins;
  }
  if (r.axis.letter() == 'A') return "xyzac-trt";
  if (r.axis.letter() == 'B') return "xyzbc-trt";
  throw InputError(option_name("--kins"), "",
                   "a C table is in both xyzac-trt-kins and xyzbc-trt-kins: say which (" +
                       option_with_value("--kins", "xyzac-trt") + " or " +
                       option_with_value("--kins", "xyzbc-trt") + ")");
}

// The setp lines of a trt module for the location errors given (one axis' or a machine's),
// after `header` (the provenance, '#' comments).
std::string linuxcnc_text(const std::string& header, const std::vector<ResultQuantity>& location,
                          const std::vector<Verdict>& verdicts, const std::string& kins,
                          const std::string& source, const CompensationOptions& o) {
  for (const auto& [pin, value] : o.current_mm) {
    static const char* kPins[] = {"x-rot-point", "y-rot-point", "z-rot-point",
                                  "x-offset",    "y-offset",    "z-offset"};
    bool known = false;
    for (const char* p : kPins) known = known || pin == p;
    if (!known)
      throw InputError(option_name("--current"), "",
                       quote_value(pin) + " is not a position pin of " + kins +
                           "-kins (x-rot-point, y-rot-point, z-rot-point, "
                           "x-offset, y-offset, z-offset)");
    (void)value;
  }
  std::ostringstream s;
  s << header;
  s << "# LinuxCNC " << kins << "-kins: the rotary axes' positions only, in mm (machine units);"
    << "\n# C turns about (x-rot-point, y-rot-point); "
    << (kins == "xyzac-trt" ? "A about (y-rot-point + y-offset, z-rot-point + z-offset)"
                            : "B about (x-rot-point + x-offset, z-rot-point + z-offset)")
    << ".\n# U = k u, " << k_text(o.k) << ".\n";
  std::map<std::string, double> change;
  std::string not_taken, uncertain;
  for (std::size_t i = 0; i < location.size(); ++i) {
    const ResultQuantity& q = location[i];
    const std::vector<std::pair<std::string, double>> pins = linuxcnc_pins(kins, q.name);
    const Verdict& v = verdicts[i];
    if (pins.empty()) {
      not_taken += " " + q.name;
      continue;
    }
    if (!v.enter) {
      uncertain += " " + q.name + " (" + v.why + ")";
      continue;
    }
    s << "# " << q.name << " = " << g9(to_si(*q.value, q.unit))
      << " mm, U = " << g9(to_si(o.k * *q.std, q.unit)) << " mm:";
    for (const auto& [pin, f] : pins) {
      const double d = f * written_mm(to_si(*q.value, q.unit), source, q.name);
      change[pin] += d;
      s << " " << pin << (d >= 0 ? " += " : " -= ") << g9(std::abs(d));
    }
    s << "\n";
  }
  if (!uncertain.empty()) s << "# not entered:" << uncertain << "\n";
  if (!not_taken.empty())
    s << "# the module takes no tilt and no zero: not compensated here:" << not_taken
      << " (a zero error is the home offset of the axis' joint)\n";
  // Pins that move together (the other rotary axis kept in place) are written together or not
  // at all: half of a coupled change would move that axis.
  {
    std::size_t given = 0;
    for (const auto& [pin, d] : change) given += o.current_mm.count(pin);
    if (given > 0 && given < change.size()) {
      std::string all;
      for (const auto& [pin, d] : change) all += (all.empty() ? "" : ", ") + pin;
      throw InputError(option_name("--current"), "",
                       "give the current value of every pin the change moves (" + all +
                           "): some of them move together, and half of the change would move "
                           "the other rotary axis");
    }
    for (const auto& [pin, v] : o.current_mm) {
      if (!change.count(pin))
        s << "# " << pin << ": not changed by this measurement (stays " << g9(v) << ")\n";
    }
  }
  for (const auto& [pin, d] : change) {
    const auto it = o.current_mm.find(pin);
    if (it == o.current_mm.end()) {
      s << "# setp " << kins << "-kins." << pin << " <current value " << (d >= 0 ? "+ " : "- ")
        << g9(std::abs(d)) << ">   (give --current " << pin << "=VALUE to write it)\n";
    } else {
      s << "setp " << kins << "-kins." << pin << " "
        << fixed(written_mm(it->second + d, source, pin + " (--current plus the change)")) << "\n";
    }
  }
  if (change.empty()) s << "# nothing to enter\n";
  return s.str();
}

std::string linuxcnc(const ResultFile& r, const CompensationOptions& o) {
  if (!r.axis.table())
    throw InputError(option_name("--format"), "",
                     "LinuxCNC's trt kinematics modules describe tilting rotary tables; axis " +
                         std::string(1, r.axis.letter()) + " of this result carries the head");
  // The module takes positions only: the envelope weighs the values it can take.
  const std::string kins = default_kins(r, o);
  std::array<bool, 5> takes{};
  for (std::size_t q = 0; q < 5 && q < r.location.size(); ++q)
    takes[q] = !linuxcnc_pins(kins, r.location[q].name).empty();
  std::ostringstream envelope;
  const std::vector<Verdict> verdicts = single_axis_verdicts(r, o, envelope, "# ", takes);
  return linuxcnc_text(provenance(r, "# ") + envelope.str(), r.location, verdicts, kins, r.source,
                       o);
}

// One row a quantity: its value (angles also in degrees), U and whether to enter it.
// Each location error: its value and U, whether to enter it, the error today (|value| - U to
// |value| + U, or at most |value| + U where U reaches zero) against the error expected after
// entering it (within +-U, either sign: what is entered is the measured value, not the true
// one). An entered value whose U is more than half of it may leave an error of either sign up
// to U: a second measurement confirms it. True when any value needs it.
bool table_rows(std::ostream& s, const std::vector<ResultQuantity>& location,
                const std::vector<Verdict>& verdicts, const CompensationOptions& o) {
  bool confirm_any = false;
  s << "name  value                                   U                     enter\n";
  std::ostringstream after;
  for (std::size_t i = 0; i < location.size(); ++i) {
    const ResultQuantity& q = location[i];
    const Verdict& v = verdicts[i];
    std::string value, U;
    // In the table's unit: mm, or deg (urad beside).
    auto in_unit = [&](double x, int digits) {
      return q.unit == "urad" ? fmt_num(to_si(x, q.unit) * 180.0 / kPi, digits) + " deg"
                              : fmt_num(to_si(x, q.unit), digits) + " mm";
    };
    if (!q.value) {
      value = "--", U = "--";
    } else if (q.unit == "urad") {
      value = in_unit(*q.value, 6) + " (" + fmt_num(*q.value, 6) + " urad)";
      U = in_unit(o.k * *q.std, 3);
    } else {
      value = in_unit(*q.value, 6);
      U = in_unit(o.k * *q.std, 3);
    }
    const bool confirm = v.enter && 2 * o.k * *q.std > std::abs(*q.value);
    confirm_any = confirm_any || confirm;
    char line[1024];
    std::snprintf(line, sizeof line, "%-5s %-39s %-21s %s\n", q.name.c_str(), value.c_str(),
                  U.c_str(),
                  v.enter ? (confirm ? "yes, then measure again to confirm" : "yes")
                          : ("no: " + v.why).c_str());
    s << line;
    if (!q.value) continue;
    const double a = std::abs(*q.value), u = o.k * *q.std;
    const std::string today =
        a > u ? in_unit(a - u, 3) + " to " + in_unit(a + u, 3) : "at most " + in_unit(a + u, 3);
    std::snprintf(line, sizeof line, "%-5s %-39s %s\n", q.name.c_str(), today.c_str(),
                  v.enter ? ("within +-" + in_unit(u, 3) + ", either sign").c_str()
                          : "as today (not entered)");
    after << line;
  }
  s << "\nThe size of each error today, and after entering the values marked yes (U as above):\n"
    << "name  today                                   after entering\n"
    << after.str();
  if (confirm_any)
    s << "A value marked 'measure again to confirm' has U above half its size: after entering "
         "it, the error left may be of either sign and up to U, as large as the measurement "
         "can tell; a second measurement tells whether entering it helped.\n";
  return confirm_any;
}

std::string table(const ResultFile& r, const CompensationOptions& o) {
  std::ostringstream s;
  s << provenance(r, "");
  s << "U: expanded uncertainty, U = k u, " << k_text(o.k) << "\n\n";
  std::ostringstream envelope;
  const std::vector<Verdict> verdicts = single_axis_verdicts(r, o, envelope, "");
  table_rows(s, r.location, verdicts, o);
  s << envelope.str();
  s << "\nA control that holds the axis' location (Heidenhain's kinematics table, Siemens' "
       "TRAFO5 offset vectors, Fanuc's tool-centre-point parameters) takes each value marked "
       "yes added to the entry that holds that location, in the entry's unit; one that holds "
       "a correction takes it with the opposite sign. Measure again after entering them and "
       "compare the two results (dbbkit compare, this result as A): each change should be "
       "minus the value entered (the error after it less the error before), within the "
       "change's U.\n";
  return s.str();
}

// ---- A machine result (dbbkit chain): the corrected lines of every axis ----

std::string machine_provenance(const ChainFile& m, const std::string& prefix) {
  std::string out = prefix + "dbbkit compensation of machine " +
                    program_comment(m.machine_name, 120) + " (controller " +
                    program_comment(m.controller, 20) + ", " + kChainFormat + ", " +
                    program_comment(m.source, 200) + ")\n" + prefix +
                    "each value is a location error as measured: the axis' actual line minus the "
                    "machine file's (its controller's), in its carrier's body (the machine frame "
                    "with every axis at zero), ISO 230-1 names\n";
  for (const std::string& w : m.warnings)
    out += prefix + "WARNING (from the machine result): " + program_comment(w, 1000) + "\n";
  return out;
}

std::vector<ResultQuantity> all_location(const ChainFile& m) {
  std::vector<ResultQuantity> all;
  for (const ChainFileAxis& a : m.axes) all.insert(all.end(), a.location.begin(), a.location.end());
  return all;
}

// An axis' line corrected by its location errors worth entering (the others left at the
// machine file's), with the derivatives of every component by every location error (mm per
// um, per urad): the corrected value's uncertainty includes the errors not entered.
struct CorrectedLine {
  Eigen::Vector3d point, direction;
  Eigen::MatrixXd dpoint, ddirection;  // 3 x 5n
};

CorrectedLine corrected_line(const ChainFile& m, std::size_t i, double k) {
  const ChainFileAxis& a = m.axes[i];
  const Eigen::Index n = static_cast<Eigen::Index>(5 * m.axes.size());
  CorrectedLine c;
  c.point = a.point_mm;
  c.direction = a.direction;
  c.dpoint = Eigen::MatrixXd::Zero(3, n);
  c.ddirection = Eigen::MatrixXd::Zero(3, n);
  for (int e = 0; e < 4; ++e) {
    const ResultQuantity& q = a.location[static_cast<std::size_t>(e)];
    const Eigen::Index col = static_cast<Eigen::Index>(5 * i) + e;
    const Eigen::Vector3d& v = a.vector[static_cast<std::size_t>(e)];
    if (e < 2) {
      c.dpoint.col(col) = 1e-3 * v;
      if (verdict(q, k).enter) c.point += 1e-3 * *q.value * v;
    } else {
      c.ddirection.col(col) = 1e-6 * v.cross(a.direction);
      if (verdict(q, k).enter) c.direction += 1e-6 * *q.value * v.cross(a.direction);
    }
  }
  c.direction.normalize();
  return c;
}

// U of a value whose derivatives by the location errors are `row`; absent when it depends on
// one that is not determined.
std::optional<double> expanded(const ChainFile& m, const Eigen::RowVectorXd& row, double k) {
  for (Eigen::Index c = 0; c < row.size(); ++c)
    if (row(c) != 0 && !m.axes[static_cast<std::size_t>(c) / 5].location[c % 5].value)
      return std::nullopt;
  return k * std::sqrt(std::max(0.0, (row * m.covariance * row.transpose())(0, 0)));
}

// The zero errors: no kinematics table of a chain holds them; said with the value and U.
std::string zero_errors(const ChainFile& m, const std::string& prefix, double k) {
  std::string out;
  for (const ChainFileAxis& a : m.axes) {
    const ResultQuantity& q = a.location[4];
    out += prefix + q.name + " (the zero of axis " + std::string(1, a.letter) + "): ";
    if (!q.value) {
      out += "not determined\n";
      continue;
    }
    out += fmt_num(*q.value, 6) + " urad (" + fmt_num(*q.value * 1e-6 * 180 / kPi, 4) +
           " deg), U = " + fmt_num(k * *q.std, 3) +
           " urad: the axis stands that far beyond its command (about its direction); not part "
           "of the kinematics written here: " +
           (verdict(q, k).enter ? "correct it at the axis' zero (its reference point offset)"
                                : "too uncertain to enter") +
           "\n";
  }
  return out;
}

// Two table axes, the second carried by the first: their indices in the file, or refused.
std::pair<std::size_t, std::size_t> table_pair(const ChainFile& m, const std::string& what) {
  std::string sides;
  for (const ChainFileAxis& a : m.axes)
    sides +=
        (sides.empty() ? "" : ", ") + std::string(1, a.letter) + " " + (a.table ? "table" : "head");
  if (m.axes.size() == 2 && m.axes[0].table && m.axes[1].table) {
    if (m.axes[1].on == m.axes[0].letter) return {0, 1};
    if (m.axes[0].on == m.axes[1].letter) return {1, 0};
  }
  throw InputError(option_name("--format"), "",
                   what +
                       " takes a machine of two table axes, one carried by the other; this "
                       "machine result holds " +
                       sides + ": " + option_with_value("--format", "table") +
                       " lists the corrected lines of any machine");
}

// The swivel data record's kinematic type and its two rotary axes (v1, v2) as the Sinumerik
// commissioning manual orders them: two tables (P: v1 the one that carries the other), two heads
// (T: v1 the one nearer the machine's frame, that carries the other), a head and a table (M: v1
// the head). Refused otherwise.
struct SiemensAxes {
  char type = 'P';
  std::size_t first = 0, second = 1;
};

SiemensAxes siemens_axes(const ChainFile& m) {
  std::string sides;
  for (const ChainFileAxis& a : m.axes)
    sides +=
        (sides.empty() ? "" : ", ") + std::string(1, a.letter) + " " + (a.table ? "table" : "head");
  if (m.axes.size() == 2) {
    const ChainFileAxis &a = m.axes[0], &b = m.axes[1];
    if (a.table == b.table) {
      const char type = a.table ? 'P' : 'T';
      if (b.on == a.letter) return {type, 0, 1};
      if (a.on == b.letter) return {type, 1, 0};
    } else if (!a.on && !b.on) {
      return a.table ? SiemensAxes{'M', 1, 0} : SiemensAxes{'M', 0, 1};
    }
  }
  throw InputError(option_name("--format"), "",
                   option_with_value("--format", "siemens") +
                       " takes a machine of two rotary axes: two tables or two heads, one "
                       "carried by the other, or a head and a table; this machine result holds " +
                       sides + ": " + option_with_value("--format", "table") +
                       " lists the corrected lines of any machine");
}

std::string siemens(const ChainFile& m, const CompensationOptions& o) {
  if (o.record <= 0)
    throw InputError(option_name("--record"), "",
                     "required with " + option_with_value("--format", "siemens") +
                         ": the number n of the swivel data record ($TC_CARR..[n]) that holds "
                         "this machine's kinematics");
  const SiemensAxes axes = siemens_axes(m);
  const std::size_t first = axes.first, second = axes.second;
  const bool head = axes.type != 'P';
  if (head && !o.tool_reference_mm)
    throw InputError(option_name("--tool-reference-mm"), "",
                     "required with " + option_with_value("--format", "siemens") +
                         " on a machine with a head axis: the tool adapter's reference point "
                         "(where the tool's length is measured from) with every axis at zero, in "
                         "the machine file's frame (where its point_mm are given, not the "
                         "control's machine coordinates), mm, e.g. 0,0,100: the record's head "
                         "vectors start there");
  if (!head && o.tool_reference_mm)
    throw InputError(option_name("--tool-reference-mm"), "",
                     "a machine of two table axes (kinematic type P) has no vector from the tool "
                     "adapter: leave it out");
  const ChainFileAxis &a1 = m.axes[first], &a2 = m.axes[second];
  const CorrectedLine c1 = corrected_line(m, first, o.k), c2 = corrected_line(m, second, o.k);
  const std::string n = std::to_string(o.record);
  const Eigen::Vector3d t = o.tool_reference_mm.value_or(Eigen::Vector3d::Zero());
  const std::string from_tool = "the tool adapter's reference point (--tool-reference-mm " +
                                fmt_num(t.x(), 12) + "," + fmt_num(t.y(), 12) + "," +
                                fmt_num(t.z(), 12) + ")";
  std::ostringstream s;
  s << machine_provenance(m, "; ");
  s << "; Sinumerik swivel data record " << n << " (--record " << n << "), kinematic type "
    << axes.type
    << (axes.type == 'P'   ? " (swivel table)"
        : axes.type == 'T' ? " (swivel head)"
                           : " (swivel head and swivel table)")
    << ": the offset vectors in mm and the rotary axis vectors as unit vectors, in the machine "
       "frame with every axis at zero:\n";
  if (axes.type == 'P')
    s << ";   l2 = the point of " << a1.letter
      << " (from the machine's reference point, the machine file's origin),\n"
      << ";   l3 = from it to the point of " << a2.letter << ", l4 = -(l2 + l3) (the chain closed)";
  else if (axes.type == 'T')
    s << ";   l3 = from " << from_tool << " to the point of " << a2.letter << ",\n"
      << ";   l2 = from it to the point of " << a1.letter << ", l1 = -(l2 + l3) (the chain closed)";
  else
    s << ";   l2 = from " << from_tool << " to the point of the head axis " << a1.letter
      << ", l1 = -l2,\n"
      << ";   l3 = the point of the table axis " << a2.letter
      << " (from the machine's reference point, the machine file's origin), l4 = -l3 (the "
         "chains closed)";
  s << ", v1 = the direction of " << a1.letter << ", v2 = that of " << a2.letter << "\n"
    << "; the values replace the record's: check before running that it holds the machine "
       "file's nominal values (each line says them) and is of kinematic type "
    << axes.type << ", and keep a copy of the record\n";
  if (head)
    s << "; the points are in the machine file's frame (where its point_mm are given), not the "
         "control's machine coordinates; the head vectors' 'was' values use the tool adapter's "
         "point given: where the record's differ, that point is not the record's: do not run\n";
  s << "; the record's fine offsets ($TC_CARR41 to $TC_CARR60) add to these values: check that "
       "they are zero, or subtract them from what is written\n"
    << "; v1 and v2 in the machine file's sense (the axis turns right-handed about it): where "
       "the record holds an axis' vector reversed, reverse the written one\n"
    << "; U = k u, " << k_text(o.k) << "\n";
  s << "; the location errors:\n";
  for (const ChainFileAxis& a : m.axes) {
    for (int e = 0; e < 4; ++e) {
      const ResultQuantity& q = a.location[static_cast<std::size_t>(e)];
      const Verdict v = verdict(q, o.k);
      s << ";   " << q.name << " = "
        << (q.value ? fmt_num(*q.value, 6) + " " + q.unit + ", U = " + fmt_num(o.k * *q.std, 3) +
                          " " + q.unit
                    : std::string("--"))
        << (v.enter ? ": entered" : ": not entered (" + v.why + ")") << "\n";
    }
  }
  s << zero_errors(m, ";   ", o.k);
  struct Assignment {
    int first_index;
    std::string what;
    Eigen::Vector3d value, nominal;
    Eigen::MatrixXd d;  // 3 x 5n
  };
  const Eigen::Vector3d &p1 = c1.point, &p2 = c2.point, &n1 = a1.point_mm, &n2 = a2.point_mm;
  const Eigen::MatrixXd &d1 = c1.dpoint, &d2 = c2.dpoint;
  std::vector<Assignment> out;
  if (axes.type == 'P')
    out = {{4, "l2", p1, n1, d1}, {15, "l3", p2 - p1, n2 - n1, d2 - d1}, {18, "l4", -p2, -n2, -d2}};
  else if (axes.type == 'T')
    out = {{1, "l1", t - p1, t - n1, -d1},
           {4, "l2", p1 - p2, n1 - n2, d1 - d2},
           {15, "l3", p2 - t, n2 - t, d2}};
  else
    out = {{1, "l1", t - p1, t - n1, -d1},
           {4, "l2", p1 - t, n1 - t, d1},
           {15, "l3", p2, n2, d2},
           {18, "l4", -p2, -n2, -d2}};
  out.push_back({7, "v1", c1.direction, a1.direction, c1.ddirection});
  out.push_back({10, "v2", c2.direction, a2.direction, c2.ddirection});
  for (const Assignment& x : out) {
    const bool length = x.what[0] == 'l';
    for (int c = 0; c < 3; ++c) {
      if (length) written_mm(x.value(c), m.source, x.what);
      const std::optional<double> U = expanded(m, x.d.row(c), o.k);
      std::string u = "not stated (a location error it needs is not determined)";
      if (U && *U == 0 && length)
        u = "0 (along the axis: any point of the line serves)";
      else if (U && *U == 0)
        u = "0";
      else if (U)
        u = fmt_num(*U, 3) + (length ? " mm" : "");
      s << "$TC_CARR" << x.first_index + c << "[" << n << "]=" << fixed(x.value(c)) << " ; "
        << x.what << " "
        << "xyz"[c] << ", was " << fixed(x.nominal(c)) << ", U = " << u << "\n";
    }
  }
  s << "M30\n";
  return s.str();
}

std::string machine_linuxcnc(const ChainFile& m, const CompensationOptions& o) {
  const auto [first, second] = table_pair(m, option_with_value("--format", "linuxcnc"));
  const char tilt = m.axes[first].letter, turn = m.axes[second].letter;
  std::string kins;
  if (turn == 'C' && tilt == 'A') kins = "xyzac-trt";
  if (turn == 'C' && tilt == 'B') kins = "xyzbc-trt";
  if (kins.empty())
    throw InputError(option_name("--format"), "",
                     std::string("LinuxCNC's trt modules take an A or B table carrying a C "
                                 "table; this machine has ") +
                         turn + " on " + tilt);
  if (!o.linuxcnc_kins.empty() && o.linuxcnc_kins != kins)
    throw InputError(option_name("--kins"), "",
                     quote_value(o.linuxcnc_kins) + ": this machine's axes are " + kins +
                         "-kins' (" + std::string(1, tilt) + " carrying " + turn + ")");
  std::string header = machine_provenance(m, "# ");
  const std::string zero = zero_errors(m, "# ", o.k);
  return linuxcnc_text(header + zero, all_location(m), per_value(all_location(m), o.k), kins,
                       m.source, o);
}

std::string machine_isg(const ChainFile& m, const CompensationOptions& o) {
  std::ostringstream s;
  s << machine_provenance(m, "// ");
  isg_location(s, all_location(m), per_value(all_location(m), o.k), m.source, o);
  s << "// the machine result holds no component errors: compensation of each axis' result "
       "writes its table\n";
  return s.str();
}

std::string vector_text(const Eigen::Vector3d& v) {
  return "(" + fixed(v.x()) + ", " + fixed(v.y()) + ", " + fixed(v.z()) + ")";
}

std::string machine_table(const ChainFile& m, const CompensationOptions& o) {
  std::ostringstream s;
  s << machine_provenance(m, "");
  s << "U: expanded uncertainty, U = k u, " << k_text(o.k) << "\n";
  for (std::size_t i = 0; i < m.axes.size(); ++i) {
    const ChainFileAxis& a = m.axes[i];
    s << "\naxis " << a.letter << " (" << (a.table ? "table" : "head")
      << (a.on ? std::string(", on ") + a.on : std::string()) << "; "
      << program_comment(a.result, 200) << "):\n";
    table_rows(s, a.location, per_value(a.location, o.k), o);
    const CorrectedLine c = corrected_line(m, i, o.k);
    for (int k = 0; k < 3; ++k)
      written_mm(c.point(k), m.source, std::string("the corrected point of axis ") + a.letter);
    s << "  its line as the controller should hold it (the values marked yes entered):\n";
    auto U_text = [&](const Eigen::MatrixXd& d) {
      std::string t;
      for (int k = 0; k < 3; ++k) {
        const std::optional<double> U = expanded(m, d.row(k), o.k);
        t += (k ? ", " : "") + (U ? fmt_num(*U, 3) : std::string("--"));
      }
      return "(" + t + ")";
    };
    s << "    point     " << vector_text(a.point_mm) << " mm -> " << vector_text(c.point)
      << " mm, U = " << U_text(c.dpoint) << " mm\n";
    s << "    direction " << vector_text(a.direction) << " -> " << vector_text(c.direction)
      << ", U = " << U_text(c.ddirection) << "\n";
  }
  s << "\nthe chain (the real relation minus the nominal one):\n";
  for (const ChainFileTerm& t : m.terms) {
    s << "  " << program_comment(t.text, 300) << ": ";
    if (!t.q.value)
      s << "not determined\n";
    else
      s << fmt_num(*t.q.value, 4) << " " << t.q.unit << ", U = " << fmt_num(o.k * *t.q.std, 3)
        << " " << t.q.unit << "\n";
  }
  s << "\n" << zero_errors(m, "", o.k);
  s << "\nA control that holds the axes' lines takes the corrected points and directions: "
       "Heidenhain's kinematics table (the transformations to each axis), Siemens' swivel data "
       "record (--format siemens writes it), LinuxCNC's trt pins (--format linuxcnc)";
  bool tables = m.axes.size() == 2 && m.axes[0].table && m.axes[1].table;
  if (tables && m.controller == "fanuc") {
    try {
      const auto [first, second] = table_pair(m, "");
      const CorrectedLine c1 = corrected_line(m, first, o.k), c2 = corrected_line(m, second, o.k);
      s << "; Fanuc's tool centre point control of a table rotation type (parameter 19680 = 12): "
           "the rotary table position, a point on the first axis ("
        << m.axes[first].letter << "), in 19700-19702 = " << vector_text(c1.point)
        << " mm, and the intersection offset vector from it to the second axis ("
        << m.axes[second].letter << ") in 19703-19705 = " << vector_text(c2.point - c1.point)
        << " mm (both from the machine file's origin: the machine's zero there)";
    } catch (const InputError&) {
    }
  }
  s << ". Measure again after entering them and run chain on the new results: what remains "
       "should lie within U.\n";
  return s.str();
}

}  // namespace

std::vector<std::pair<std::string, double>> linuxcnc_pins(const std::string& kins,
                                                          const std::string& n) {
  if (kins == "xyzac-trt") {
    if (n == "X0C") return {{"x-rot-point", 1}};
    if (n == "Y0C") return {{"y-rot-point", 1}, {"y-offset", -1}};  // A stays where it is
    if (n == "Y0A") return {{"y-offset", 1}};
    if (n == "Z0A") return {{"z-offset", 1}};
  } else if (kins == "xyzbc-trt") {
    if (n == "X0C") return {{"x-rot-point", 1}, {"x-offset", -1}};  // B stays where it is
    if (n == "Y0C") return {{"y-rot-point", 1}};
    if (n == "X0B") return {{"x-offset", 1}};
    if (n == "Z0B") return {{"z-offset", 1}};
  }
  return {};
}

CompensationFormat compensation_format(const std::string& name, const std::string& source) {
  if (name == "isg") return CompensationFormat::kIsg;
  if (name == "linuxcnc") return CompensationFormat::kLinuxCnc;
  if (name == "table") return CompensationFormat::kTable;
  if (name == "siemens") return CompensationFormat::kSiemens;
  throw InputError(source, "format",
                   quote_value(name) + " (expected isg, linuxcnc, siemens or table)");
}

Eigen::Vector3d parse_tool_reference(const std::string& text, const std::string& key) {
  const std::vector<double> x = parse_number_list(text, key);
  if (x.size() != 3)
    throw InputError(
        key, "", "expected the point x,y,z in mm (three numbers), got " + std::to_string(x.size()));
  for (std::size_t k = 0; k < 3; ++k)
    if (!(std::abs(x[k]) <= kMaxCompensation_mm))
      throw InputError(
          key, "item " + std::to_string(k + 1),
          fmt_num(x[k], 12) + " mm is beyond +-" + fmt_num(kMaxCompensation_mm, 6) + " mm");
  return {x[0], x[1], x[2]};
}

void check_compensation_options(CompensationFormat format, const CompensationOptions& options) {
  if (options.record != 0 && format != CompensationFormat::kSiemens)
    throw InputError(option_name("--record"), "",
                     "numbers Siemens' swivel data record (" +
                         option_with_value("--format", "siemens") + "); this format has none");
  if (options.tool_reference_mm && format != CompensationFormat::kSiemens)
    throw InputError(option_name("--tool-reference-mm"), "",
                     "places the tool adapter for Siemens' swivel data record (" +
                         option_with_value("--format", "siemens") + "); this format has none");
  if (format == CompensationFormat::kLinuxCnc) return;
  const std::string name = format == CompensationFormat::kIsg       ? "isg"
                           : format == CompensationFormat::kSiemens ? "siemens"
                                                                    : "table";
  const std::string what =
      format == CompensationFormat::kIsg
          ? "writes the location errors themselves, as the ISG kernel adds them"
      : format == CompensationFormat::kSiemens
          ? "writes the swivel data record's vectors themselves"
          : "is a table of the location errors to enter by hand";
  if (!options.current_mm.empty()) {
    throw InputError(option_name("--current"), "",
                     option_with_value("--format", name) + " " + what +
                         ": it takes no current values; " + option_name("--current") +
                         " gives the current values of LinuxCNC's position pins (" +
                         option_with_value("--format", "linuxcnc") + ")");
  }
  if (!options.linuxcnc_kins.empty()) {
    throw InputError(option_name("--kins"), "",
                     option_with_value("--format", name) + " " + what + ": it takes no module; " +
                         option_name("--kins") + " names LinuxCNC's kinematics module (" +
                         option_with_value("--format", "linuxcnc") + ")");
  }
}

EnvelopeJudgement judge_envelope(const ResultFile& result, const EnvelopeGrid& grid, double k,
                                 const std::array<bool, 5>& takes) {
  EnvelopeJudgement j;
  if (!(k <= kMaxEnvelopeK))
    throw InputError(option_name("--k"), "",
                     "with an envelope, k up to " + fmt_num(kMaxEnvelopeK, 3) +
                         " (a coverage of 1 - 2e-9): beyond it the coverage is 1 in double "
                         "precision and U has no quantile");
  const AxisErrors axis = axis_errors_of(result);
  const std::vector<Pose> poses = envelope_poses(result.axis, grid);
  j.points = poses.size();
  j.coverage_probability = std::erf(k / std::sqrt(2.0));
  const PredictionCoverage coverage = prediction_coverage(j.coverage_probability, axis.dof);
  for (std::size_t q = 0; q < 5; ++q)
    j.candidate[q] = takes[q] && verdict(result.location[q], k).enter;
  if (std::any_of(axis.location.begin(), axis.location.end(),
                  [](const std::optional<double>& v) { return !v.has_value(); }))
    return j;
  j.determined = true;
  static_cast<EnteringJudgement&>(j) = judge_entering(axis, poses, j.candidate, coverage);
  return j;
}

std::string compensation_text(const ResultFile& result, CompensationFormat format,
                              const CompensationOptions& options) {
  check_compensation_options(format, options);
  switch (format) {
    case CompensationFormat::kIsg:
      return isg(result, options);
    case CompensationFormat::kLinuxCnc:
      return linuxcnc(result, options);
    case CompensationFormat::kTable:
      return table(result, options);
    case CompensationFormat::kSiemens:
      throw InputError(option_name("--format"), "",
                       "siemens writes a swivel data record, which holds two rotary axes: give "
                       "a machine result (dbbkit chain --out) of the machine's axes");
  }
  return "";
}

std::string machine_compensation_text(const ChainFile& machine, CompensationFormat format,
                                      const CompensationOptions& options) {
  check_compensation_options(format, options);
  switch (format) {
    case CompensationFormat::kIsg:
      return machine_isg(machine, options);
    case CompensationFormat::kLinuxCnc:
      return machine_linuxcnc(machine, options);
    case CompensationFormat::kTable:
      return machine_table(machine, options);
    case CompensationFormat::kSiemens:
      return siemens(machine, options);
  }
  return "";
}

}  // namespace dbbkit::io
