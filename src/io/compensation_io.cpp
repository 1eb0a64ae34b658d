#include "dbbkit/io/compensation_io.hpp"

#include <cmath>
#include <cstdio>
#include <sstream>

#include "dbbkit/error.hpp"
#include "dbbkit/io/escape.hpp"
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

// A length written for a controller [mm], within kMaxCompensation_mm; `what` names it.
double written_mm(double mm, const ResultFile& r, const std::string& what) {
  if (!(std::abs(mm) <= kMaxCompensation_mm))
    throw InputError(r.source, what,
                     "would be written as " + g9(mm) + " mm, beyond +-" + g9(kMaxCompensation_mm) +
                         " mm: no machine's location; not written");
  return mm;
}

// Whether a value is worth entering, and why not.
struct Verdict {
  bool enter = false;
  std::string why;  // empty when it is
};
Verdict verdict(const ResultQuantity& q, double k) {
  if (!q.value) return {false, "not determined by the measurement"};
  if (std::abs(*q.value) <= k * *q.std)
    return {false, "too uncertain: |value| <= U, not distinguishable from zero"};
  return {true, ""};
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

std::string isg(const ResultFile& r, const CompensationOptions& o) {
  std::ostringstream s;
  s << provenance(r, "// ");
  s << "// ISG CSV: location errors; offsets in mm, angles in rad; U = k u, " << k_text(o.k)
    << "\n";
  std::string names, values, uncertain, undetermined;
  for (const ResultQuantity& q : r.location) {
    const Verdict v = verdict(q, o.k);
    if (!q.value) {
      undetermined += " " + q.name;
      continue;
    }
    if (q.unit == "um") written_mm(to_si(*q.value, q.unit), r, q.name);
    s << "//   " << q.name << " = " << g9(to_si(*q.value, q.unit)) << " " << si_unit(q.unit)
      << ", U = " << g9(to_si(o.k * *q.std, q.unit)) << " " << si_unit(q.unit)
      << (v.enter ? "" : " (too uncertain to enter: |value| <= U)") << "\n";
    if (!v.enter) uncertain += " " + q.name;
    names += (names.empty() ? "" : " ") + q.name;
    values += (values.empty() ? "" : " ") + g9(to_si(*q.value, q.unit));
  }
  if (!uncertain.empty())
    s << "// too uncertain to enter (written as measured; set them to 0 to leave them out):"
      << uncertain << "\n";
  if (!undetermined.empty())
    s << "// not determined by the measurement, not written:" << undetermined << "\n";
  if (names.empty()) {
    s << "// no location error is determined: nothing to compensate\n";
    return s.str();
  }
  s << names << "\n" << values << "\n";
  // The component errors over the angle, where all six are given and determined (the reader
  // keeps them in ISO 230-1's order: one table, one column a component).
  std::string omitted;
  std::vector<const ResultComponents*> rows;
  for (const ResultComponents& c : r.components) {
    bool all = c.motions.size() == 6;
    for (const ResultQuantity& m : c.motions) {
      all = all && m.value.has_value();
      if (m.value && m.unit == "um")
        written_mm(to_si(*m.value, m.unit), r, m.name + " at " + fmt_num(c.angle_deg, 6) + " deg");
    }
    if (all)
      rows.push_back(&c);
    else
      omitted += " " + fmt_num(c.angle_deg, 6);
  }
  if (!rows.empty()) {
    const std::string letter(1, r.axis.letter());
    s << "#\n// component errors of axis " << letter << " over its angle: " << letter
      << " in rad (the argument)";
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
      s << g9(c->angle_deg * kPi / 180.0);
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

std::string linuxcnc(const ResultFile& r, const CompensationOptions& o) {
  if (!r.axis.table())
    throw InputError(option_name("--format"), "",
                     "LinuxCNC's trt kinematics modules describe tilting rotary tables; axis " +
                         std::string(1, r.axis.letter()) + " of this result carries the head");
  const std::string kins = default_kins(r, o);
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
  s << provenance(r, "# ");
  s << "# LinuxCNC " << kins << "-kins: the rotary axes' positions only, in mm (machine units);"
    << "\n# C turns about (x-rot-point, y-rot-point); "
    << (kins == "xyzac-trt" ? "A about (y-rot-point + y-offset, z-rot-point + z-offset)"
                            : "B about (x-rot-point + x-offset, z-rot-point + z-offset)")
    << ".\n# U = k u, " << k_text(o.k) << ".\n";
  std::map<std::string, double> change;
  std::string not_taken, uncertain;
  for (const ResultQuantity& q : r.location) {
    const std::vector<std::pair<std::string, double>> pins = linuxcnc_pins(kins, q.name);
    const Verdict v = verdict(q, o.k);
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
      const double d = f * written_mm(to_si(*q.value, q.unit), r, q.name);
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
        << g9(written_mm(it->second + d, r, pin + " (--current plus the change)")) << "\n";
    }
  }
  if (change.empty()) s << "# nothing to enter\n";
  return s.str();
}

std::string table(const ResultFile& r, const CompensationOptions& o) {
  std::ostringstream s;
  s << provenance(r, "");
  s << "U: expanded uncertainty, U = k u, " << k_text(o.k) << "\n\n";
  s << "name  value                                   U                     enter\n";
  for (const ResultQuantity& q : r.location) {
    const Verdict v = verdict(q, o.k);
    std::string value, U;
    if (!q.value) {
      value = "--", U = "--";
    } else if (q.unit == "urad") {
      value = fmt_num(to_si(*q.value, q.unit) * 180.0 / kPi, 6) + " deg (" + fmt_num(*q.value, 6) +
              " urad)";
      U = fmt_num(to_si(o.k * *q.std, q.unit) * 180.0 / kPi, 3) + " deg";
    } else {
      value = fmt_num(to_si(*q.value, q.unit), 6) + " mm";
      U = fmt_num(to_si(o.k * *q.std, q.unit), 3) + " mm";
    }
    char line[256];
    std::snprintf(line, sizeof line, "%-5s %-39s %-21s %s\n", q.name.c_str(), value.c_str(),
                  U.c_str(), v.enter ? "yes" : ("no: " + v.why).c_str());
    s << line;
  }
  s << "\nA control that holds the axis' location (Heidenhain's kinematics table, Siemens' "
       "TRAFO5 offset vectors, Fanuc's tool-centre-point parameters) takes each value marked "
       "yes added to the entry that holds that location, in the entry's unit; one that holds "
       "a correction takes it with the opposite sign. Measure again after entering them and "
       "compare the two results (dbbkit compare): the change should be the values entered.\n";
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
  throw InputError(source, "format", quote_value(name) + " (expected isg, linuxcnc or table)");
}

void check_compensation_options(CompensationFormat format, const CompensationOptions& options) {
  if (format == CompensationFormat::kLinuxCnc) return;
  const std::string name = format == CompensationFormat::kIsg ? "isg" : "table";
  const std::string what =
      format == CompensationFormat::kIsg
          ? "writes the location errors themselves, as the ISG kernel adds them"
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
  }
  return "";
}

}  // namespace dbbkit::io
