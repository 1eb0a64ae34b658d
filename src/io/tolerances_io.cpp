#include "dbbkit/io/tolerances_io.hpp"

#include <cmath>
#include <iomanip>
#include <sstream>

#include "dbbkit/error.hpp"
#include "dbbkit/io/json_reader.hpp"
#include "dbbkit/io/result_io.hpp"
#include "dbbkit/io/text.hpp"
#include "dbbkit/user_text.hpp"
#include "object_reader.hpp"
#include "result_blocks.hpp"

namespace dbbkit::io {

using nlohmann::json;

namespace {

// A unit of the limits: its dimension ("um" or "urad") and the factor to it.
bool unit_of(const std::string& u, std::string& dimension, double& factor) {
  if (u == "um") {
    dimension = "um", factor = 1.0;
  } else if (u == "mm") {
    dimension = "um", factor = 1000.0;
  } else if (u == "urad") {
    dimension = "urad", factor = 1.0;
  } else if (u == "mrad") {
    dimension = "urad", factor = 1000.0;
  } else if (u == "arcsec") {
    dimension = "urad", factor = M_PI / (180.0 * 3600.0) * 1e6;
  } else {
    return false;
  }
  return true;
}

}  // namespace

// The largest limit a tolerance may have, in um or urad.
constexpr double kMaxToleranceLimit = 1e9;

std::vector<Tolerance> tolerances_from_json(const json& j, const std::string& source) {
  ObjectReader top(j, source, "");
  const std::string format = top.string("format");
  if (format != kTolerancesFormat) {
    top.fail("format",
             "expected \"" + std::string(kTolerancesFormat) + "\", found \"" + format + "\"");
  }
  top.optional_string("description");
  const json& limits = top.required("limits");
  if (!limits.is_array() || limits.empty()) {
    top.fail("limits",
             "expected a non-empty list of {quantity, unit, max_abs | lower and/or upper}");
  }
  std::vector<Tolerance> out;
  for (size_t i = 0; i < limits.size(); ++i) {
    const std::string where = "limits[" + std::to_string(i) + "]";
    ObjectReader r(limits[i], source, where);
    Tolerance t;
    t.quantity = r.string("quantity");
    t.where = where;
    // A location error spelt with the letter O (XOC): ISO 230-1 writes the digit zero (X0C).
    if (t.quantity.size() == 3 && t.quantity[1] == 'O' &&
        std::string("XYZABC").find(t.quantity[0]) != std::string::npos &&
        std::string("ABC").find(t.quantity[2]) != std::string::npos) {
      t.alias = t.quantity;
      t.quantity[1] = '0';
    }
    for (const Tolerance& o : out) {
      if (o.quantity == t.quantity)
        r.fail("quantity", quote_value(t.quantity) + " has a limit already (" + o.where + ")");
    }
    const std::string unit = r.string("unit");
    double factor = 1.0;
    if (!unit_of(unit, t.unit, factor))
      r.fail("unit", "unknown unit " + quote_value(unit) + " (um, mm, urad, mrad or arcsec)");
    const std::optional<double> max_abs = r.optional_number("max_abs");
    const std::optional<double> lower = r.optional_number("lower");
    const std::optional<double> upper = r.optional_number("upper");
    if (max_abs) {
      if (lower || upper) r.fail("max_abs", "give either max_abs or lower/upper, not both");
      if (!(*max_abs > 0)) r.fail("max_abs", "must be > 0");
      t.lower = -*max_abs * factor;
      t.upper = *max_abs * factor;
    } else {
      if (!lower && !upper)
        throw InputError(source, where, "a limit needs max_abs, lower or upper (none is given)");
      if (lower) t.lower = *lower * factor;
      if (upper) t.upper = *upper * factor;
      if (lower && upper && !(*upper > *lower)) r.fail("upper", "must exceed lower");
    }
    // In um or urad: finite, within +-1e9 (a metre, a thousand radians), and a zone that is
    // not empty after the unit's conversion.
    for (const auto& [key, v] : {std::pair{"lower", t.lower}, std::pair{"upper", t.upper}}) {
      if (v && !(std::isfinite(*v) && std::abs(*v) <= kMaxToleranceLimit)) {
        const double given = max_abs ? *max_abs : (std::string(key) == "lower" ? *lower : *upper);
        r.fail(max_abs ? "max_abs" : key, fmt_num(given, 6) + " " + unit + " is beyond +-1e9 " +
                                              t.unit + " (the most a limit may be)");
      }
    }
    if (t.lower && t.upper && !(*t.upper > *t.lower))
      r.fail(max_abs ? "max_abs" : "upper", "the zone is empty in " + t.unit);
    r.finish();
    out.push_back(t);
  }
  top.finish();
  return out;
}

std::vector<Tolerance> read_tolerances_file(const std::string& path) {
  return tolerances_from_json(parse_json(read_json_file(path), path), path);
}

json conformance_to_json(const ConformanceReport& report, const std::string& tolerances_path) {
  json rows = json::array();
  for (const ConformanceResult& r : report.results) {
    json row{{"quantity", r.quantity},
             {"unit", r.unit},
             {"lower", r.lower ? json(r6(*r.lower)) : json(nullptr)},
             {"upper", r.upper ? json(r6(*r.upper)) : json(nullptr)},
             {"decision", decision_name(r.decision)},
             {"basis", conformance_basis(report, r)},
             {"monte_carlo_intervals", r.monte_carlo_intervals},
             {"values", r.values},
             {"conforming", r.conforming},
             {"nonconforming", r.nonconforming},
             {"not_proven", r.not_proven},
             {"undetermined", r.undetermined}};
    if (r.value)
      row["deciding_value"] = {{"value", r6(*r.value)}, {"interval", {r6(*r.low), r6(*r.high)}}};
    if (r.value && r.angle_deg) row["deciding_value"]["angle_deg"] = *r.angle_deg;
    rows.push_back(row);
  }
  json j{{"tolerances", tolerances_path},
         {"errors", report.corrected ? "corrected" : "identified"},
         {"rule", conformance_rule(report)},
         {"coverage_probability", report.coverage_probability},
         {"results", rows},
         {"verdict", report.any_nonconforming() ? "does not conform" : "no nonconformity proven"}};
  j["warnings"] = conformance_warnings(report);
  json notes = json::array();
  if (const std::string n = conformance_alias_note(report); !n.empty()) notes.push_back(n);
  j["notes"] = notes;
  return j;
}

std::string conformance_alias_note(const ConformanceReport& report) {
  if (report.aliases.empty()) return "";
  std::string t = "the tolerance file names";
  for (std::size_t k = 0; k < report.aliases.size(); ++k)
    t += (k ? ", " : " ") + report.aliases[k].first + " (read as " + report.aliases[k].second + ")";
  return t + ": ISO 230-1 writes a location error with the digit zero";
}

std::string conformance_text(const ConformanceReport& report) {
  std::ostringstream s;
  s << "\nconformance" << (report.corrected ? " of the corrected errors" : "") << " ("
    << conformance_rule(report) << "):\n";
  for (const std::string& w : conformance_warnings(report)) s << "  WARNING: " << w << "\n";
  if (const std::string n = conformance_alias_note(report); !n.empty())
    s << "  note: " << n << "\n";
  s << "  " << std::left << std::setw(12) << "quantity" << std::setw(22) << "tolerance zone"
    << std::setw(18) << "decision"
    << "deciding value [interval]\n";
  for (const ConformanceResult& r : report.results) {
    std::ostringstream zone;
    zone << std::setprecision(4);
    if (r.lower && r.upper) {
      zone << "[" << *r.lower << ", " << *r.upper << "]";
    } else if (r.upper) {
      zone << "<= " << *r.upper;
    } else {
      zone << ">= " << *r.lower;
    }
    zone << " " << r.unit;
    s << "  " << std::setw(12) << r.quantity << std::setw(22) << zone.str() << std::setw(18)
      << decision_name(r.decision) << std::right;
    if (r.value) {
      s << std::fixed << std::setprecision(3) << *r.value << " [" << *r.low << ", " << *r.high
        << "]" << std::defaultfloat;
      if (r.angle_deg) s << " at " << *r.angle_deg << " deg";
    } else {
      s << "-- (not determined)";
    }
    if (r.values > 1) {
      s << "  (" << r.values << " values: " << r.conforming << " conform, " << r.nonconforming
        << " do not, " << r.not_proven << " not proven"
        << (r.undetermined ? ", " + std::to_string(r.undetermined) + " undetermined" : "") << ")";
    }
    s << std::left << "\n";
  }
  s << "  verdict: "
    << (report.any_nonconforming() ? "DOES NOT CONFORM (exit code 1)" : "no nonconformity proven")
    << "\n";
  return s.str();
}

std::string conformance_line(const ConformanceReport& report, const std::string& tolerances_path) {
  return std::string("conformance: ") +
         (report.any_nonconforming() ? "does not conform" : "no nonconformity proven") + " (" +
         printable(tolerances_path, 400) + "; the decisions in the JSON)\n";
}

std::string conformance_rule(const ConformanceReport& report) {
  const std::string pct = fmt_num(100 * report.coverage_probability, 4) + " %";
  return "ISO 14253-1:2017 default decision rule: conformity is proven when the interval (value "
         "+- U, coverage probability " +
         pct +
         ") lies inside the tolerance zone, nonconformity when it lies wholly outside; otherwise "
         "neither is proven. A quantity at every measured angle conforms when every value does "
         "and does not conform when one does not; an undetermined value proves nothing";
}

std::vector<std::string> conformance_warnings(const ConformanceReport& report) {
  std::vector<std::string> w;
  if (report.noise_contradiction_p) {
    const double p = *report.noise_contradiction_p;
    w.push_back("the residual contradicts the declared reading noise (chi2 p " +
                (p > 0 ? "= " + fmt_num(p, 2) : std::string("< 1e-300")) +
                "): the intervals rest on an uncertainty the data do not support; state it from "
                "the residual (--type-a) or find what the model lacks (diagnose) before relying "
                "on these decisions");
  }
  if (report.setup_declared_left_out) {
    w.push_back(
        "the corrected errors' intervals leave out the design's set-up tolerances (diagnose "
        "states them as set-up risks): for intervals that include them, identify with the "
        "effects diagnose added (identify --effects) and decide there");
  } else if (report.no_setup_tolerances) {
    w.push_back(
        "the design declares no set-up tolerances (setup_std): the intervals leave out where the "
        "balls were set, and a centring error of the balls moves the location errors (" +
        report.position_names + ") by as much as itself");
  }
  return w;
}

std::string conformance_basis(const ConformanceReport& report, const ConformanceResult& r) {
  const std::string iso =
      "value +- k u, k = " + fmt_num(report.k_iso, 4) +
      (report.type_a_dof
           ? " (Student's t, " + fmt_rounded(*report.type_a_dof, 1) + " degrees of freedom)"
           : std::string(" (normal)"));
  switch (r.basis) {
    case ConformanceResult::Basis::kIsoQuantity:
      return iso;
    case ConformanceResult::Basis::kIsoAtEveryAngle:
      return iso + ", at every measured angle";
    case ConformanceResult::Basis::kMotionValue: {
      std::string t = "[max(0, range - U), range + U], coverage probability at least " +
                      fmt_num(100 * report.coverage_probability, 4) + " % (error motion values)";
      if (!r.motion_values_computed) t += "; not computed";
      if (r.uncomputed_motion)
        t += "; " + iso_motion_reason(*r.uncomputed_motion, r.uncomputed_index);
      return t;
    }
    case ConformanceResult::Basis::kBudget: {
      std::string t =
          "value +- U of the uncertainty budget (k at each value's effective degrees of "
          "freedom), at every measured angle";
      if (r.monte_carlo_intervals > 0) {
        t += "; at " + std::to_string(r.monte_carlo_intervals) +
             " angles the Monte Carlo interval, where the linear one is not validated";
      }
      return t;
    }
    case ConformanceResult::Basis::kCorrectedErrors:
      return "value +- k u of the corrected errors (u with the attributions' share), k = " +
             fmt_num(report.k_iso, 4) + " (normal), at every measured angle";
  }
  return "";
}

}  // namespace dbbkit::io
