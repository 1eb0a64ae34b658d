#include "dbbkit/io/verify_io.hpp"

#include <algorithm>
#include <boost/math/distributions/chi_squared.hpp>
#include <boost/math/distributions/normal.hpp>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <map>
#include <sstream>

#include "dbbkit/error.hpp"
#include "dbbkit/io/escape.hpp"
#include "dbbkit/io/predict_io.hpp"
#include "dbbkit/io/result_io.hpp"
#include "dbbkit/io/text.hpp"
#include "dbbkit/iso230.hpp"
#include "dbbkit/limits.hpp"
#include "result_blocks.hpp"

namespace dbbkit::io {

using nlohmann::json;

void check_test_axis(const ResultFile& result, const Design& design,
                     const std::string& design_source) {
  if (const std::string diff = axis_difference(result.axis, design.axis, false); !diff.empty())
    throw InputError(design_source, "axis",
                     "the test is not of the result's axis (" + result.axis.label() + ": " + diff +
                         "): a result predicts the readings of its own axis only");
  if (result.machine.has_value() != design.machine.has_value())
    throw InputError(design_source, "machine",
                     result.machine ? "the result was measured on a machine (" +
                                          terminal_text(result.machine->file) +
                                          ") and the test names none: their frames' origins "
                                          "cannot be matched"
                                    : std::string("the test names a machine and the result "
                                                  "none: their frames' origins cannot be matched"));
  if (result.machine && (result.machine->origin_mm - design.machine->origin_mm()).norm() > 1e-6)
    throw InputError(design_source, "machine",
                     "the axis frame's origin (the axis' nominal point with the other axes "
                     "parked) is not the result's: park the other axes as the result's test did");
}

namespace {

[[noreturn]] void throw_not_determined(const ResultFile& result, const AxisErrors& axis) {
  const std::array<std::string, 5> names = iso230_names(result.axis).location;
  std::string missing;
  for (std::size_t q = 0; q < 5; ++q)
    if (!axis.location[q]) missing += (missing.empty() ? "" : ", ") + names[q];
  throw InputError(
      result.source, "iso230.location",
      "the result does not determine " + missing + ": it cannot predict another test's readings");
}

// Two names of one file: the same text, or, both existing, the same file (a result's inputs.data
// is as identify was given it, relative to where it ran).
bool same_file(const std::string& a, const std::string& b) {
  if (a.empty() || b.empty() || b == "-") return false;
  if (a == b) return true;
  std::error_code ec;
  return std::filesystem::exists(a, ec) && std::filesystem::equivalent(a, b, ec) && !ec;
}

std::vector<std::string> reversed_installations(const Design& design) {
  std::vector<std::string> ids;
  for (const Installation& in : design.installations)
    if (in.reading_sign < 0) ids.push_back(in.id);
  return ids;
}

void check_test_size(std::size_t readings, const std::string& source) {
  if (readings > limits::kMaxVerifyReadings)
    throw InputError(source, "",
                     std::to_string(readings) + " readings: verify and predict take at most " +
                         std::to_string(limits::kMaxVerifyReadings) + " of one test");
}

}  // namespace

VerifyReport verify(const ResultFile& result, const Design& design,
                    const std::vector<Reading>& readings, const std::string& design_source,
                    const std::string& data_source, double coverage_probability,
                    bool location_only) {
  check_test_axis(result, design, design_source);
  check_test_size(readings.size(), data_source);
  const AxisErrors axis = axis_errors_of(result);
  VerifyReport r;
  r.result_source = result.source;
  r.design_source = design_source;
  r.data_source = data_source;
  r.axis_label = result.axis.label();
  r.design_name = design.name;
  r.letter = result.axis.letter();
  r.location_names = iso230_names(result.axis).location;
  for (int q = 0; q < 5; ++q) r.location_units[static_cast<std::size_t>(q)] = q < 2 ? "um" : "urad";
  r.location_only = location_only;
  r.k = boost::math::quantile(boost::math::normal(), 0.5 + coverage_probability / 2);
  r.readings = readings;
  r.warnings = result.warnings;
  r.reversed = reversed_installations(design);
  r.result_dof = axis.dof;
  VerifyOptions o;
  o.coverage_probability = coverage_probability;
  o.location_only = location_only;
  r.v = verify_readings(axis, design, readings, o);
  if (r.v.gap == VerifyGap::kLocationNotDetermined) throw_not_determined(result, axis);
  if (same_file(result.data_source, data_source))
    r.notes.push_back("the test's readings are the result's own (its inputs.data, " +
                      result.data_source +
                      "): a result explains the readings it was fitted to; this is no held-out "
                      "check");
  {  // Readings of the design not given: the check is of those given alone.
    std::map<std::string, int> missing;
    std::map<std::pair<std::string, double>, int> given;
    for (const Reading& x : readings) ++given[{x.installation, x.angle_deg}];
    std::size_t absent = 0;
    const std::vector<Reading> designed = nominal_readings(design);
    for (const Reading& x : designed)
      if (auto it = given.find({x.installation, x.angle_deg});
          it != given.end() && it->second > 0) {
        --it->second;
      } else {
        ++missing[x.installation];
        ++absent;
      }
    if (absent > 0) {
      std::string where;
      for (const auto& [id, count] : missing)
        where += (where.empty() ? "" : ", ") + id + " " + std::to_string(count);
      r.notes.push_back(std::to_string(absent) + " of the design's " +
                        std::to_string(designed.size()) +
                        " readings are not in the data (by installation: " + where +
                        "): the check is of the readings given alone");
    }
  }
  if (r.v.gap == VerifyGap::kNone && r.v.p_value > 0.999)
    r.notes.push_back(
        "chi-squared lies far below its degrees of freedom (p > 0.999; a right "
        "result with right uncertainties gives this once in a thousand tests): the "
        "uncertainties weighed (the result's, the test's reading noise or declared "
        "set-up) may be overstated, and the check is then lenient");
  if (r.v.gap == VerifyGap::kIllConditioned)
    throw InputError(design_source, "",
                     "the residual's covariance (the reading noise beside the declared set-up "
                     "and the result's uncertainty) spans more than double precision can hold: "
                     "check the design's noise and setup_std");
  if (r.v.gap == VerifyGap::kNoRedundancy)
    throw InputError(data_source, "",
                     std::to_string(r.v.readings) + " readings, and the test's constant parts (" +
                         std::to_string(r.v.nuisance) +
                         ", where each reading's zero was taken) take up every one: nothing is "
                         "left to check the result against");
  return r;
}

namespace {

std::string method_text(const VerifyReport& r) {
  std::string s =
      "each reading of the test predicted from the result: the location errors and, at an angle "
      "the result measured, the component error motions, less the constant parts; the test's "
      "own constant parts (where its readings' zero was taken) fitted and taken out; chi-squared "
      "of what is left against its covariance (the test's reading noise, the result's "
      "uncertainty, the test's declared set-up), pass at most its quantile of the coverage "
      "probability";
  if (r.location_only) s += "; --location-only: the location errors alone at every angle";
  return s;
}

}  // namespace

json verification_to_json(const VerifyReport& r) {
  const Verification& v = r.v;
  json worst = json::array();
  for (const std::size_t i : v.worst) {
    const VerifiedReading& c = v.readings_checked[i];
    const Reading& in = r.readings[c.index];
    json j{{"installation", in.installation},  {"angle_deg", in.angle_deg},
           {"read_um", r6(c.read_um)},         {"predicted_um", r6(c.predicted_um)},
           {"residual_um", r6(c.residual_um)}, {"std_um", r6(c.std_um)},
           {"normalized", r6(c.normalized)},   {"basis", basis_key(c.basis)}};
    if (in.line > 0) j["line"] = in.line;
    worst.push_back(j);
  }
  json explanations = json::array();
  for (const VerifyExplanation& x : v.explanations) {
    const auto q = static_cast<std::size_t>(x.location);
    explanations.push_back({{"name", r.location_names[q]},
                            {"unit", r.location_units[q]},
                            {"change", r6(x.change)},
                            {"change_std", r6(x.change_std)},
                            {"change_U", r6(r.k * x.change_std)},
                            {"chi2", r6(x.chi2)},
                            {"passes_with", x.passes_with}});
  }
  json warnings = json::array();
  for (const std::string& w : r.warnings) warnings.push_back(w);
  json out{{"format", kVerifyFormat},
           {"inputs",
            {{"result", r.result_source}, {"design", r.design_source}, {"data", r.data_source}}},
           {"axis", r.axis_label},
           {"method", method_text(r)},
           {"coverage_probability", v.coverage_probability},
           {"location_only", r.location_only},
           {"pass", v.pass},
           {"chi2", r6(v.chi2)},
           {"dof", v.dof},
           {"threshold", r6(v.threshold)},
           {"statistic",
            {{"scale", v.statistic_scale},
             {"dof", v.statistic_dof},
             {"distribution",
              "chi2 / scale is chi-squared with dof degrees of freedom (the design's normal "
              "noise: scale 1, dof the readings less the constant parts; uniform noise: the "
              "scaled chi-squared of the statistic's mean and variance)"}}},
           {"p_value", v.p_value},
           {"readings", v.readings},
           {"constant_parts", v.nuisance},
           {"noise_std_um", r6(v.noise_std_um)},
           {"angles", v.angles},
           {"angles_location_only", v.angles_location_only},
           {"angles_motions_correlated", v.angles_motions_correlated},
           {"angles_without_covariance", v.angles_without_covariance},
           {"notes", r.notes},
           {"worst", worst},
           {"explanations", explanations},
           {"k", r.k},
           {"result_dof", r.result_dof ? json(r6(*r.result_dof)) : json(nullptr)},
           {"result_warnings", warnings}};
  if (!r.result_sha256.empty()) out["inputs"]["result_sha256"] = r.result_sha256;
  return out;
}

std::string verification_text(const VerifyReport& r) {
  const Verification& v = r.v;
  std::ostringstream s;
  s << "verify: " << v.readings << " readings of " << terminal_text(r.data_source) << " ("
    << terminal_text(r.design_name) << ") against " << terminal_text(r.result_source) << ", the "
    << r.axis_label << " axis\n";
  for (const std::string& w : r.warnings)
    s << "Warning (the result's; its uncertainties may be too small): " << terminal_text(w) << "\n";
  if (r.location_only)
    s << "the location errors alone at every angle (--location-only): the component error motions "
         "are in the residual\n";
  else if (const int not_measured =
               v.angles_location_only - v.angles_motions_correlated - v.angles_without_covariance;
           not_measured > 0)
    s << "at " << not_measured << " of the test's " << v.angles
      << " angles the result measured no motions: the location errors alone predict those "
         "readings, and the component motions there are in the residual (a fail may come from "
         "them)\n";
  if (!r.location_only && v.angles_without_covariance > 0)
    s << "at " << v.angles_without_covariance << " of the test's " << v.angles
      << " angles the result states its motions without their covariance (an earlier version, "
         "or diagnose's shares of equivalent effects): the location errors alone predict them, "
         "the component motions are in the residual\n";
  if (!r.location_only && v.angles_motions_correlated > 0)
    s << "at " << v.angles_motions_correlated << " angles the result measured, its motions' "
      << "estimates are correlated between angles (a series model or a set-up effect shared by "
         "them) and no such covariance is stated: the location errors alone predict them, the "
         "component motions are in the residual\n";
  if (r.result_dof)
    s << "the result's uncertainties are Type A (" << fmt_num(*r.result_dof, 3)
      << " degrees of freedom) and are taken as known here\n";
  s << "the test's constant parts (" << v.nuisance
    << ", where its readings' zero was taken) fitted to it; reading noise "
    << fmt_num(v.noise_std_um, 3) << " um (the test's design)\n";
  s << "chi-squared " << fmt_num(v.chi2, 4) << " with " << v.dof << " degrees of freedom; its "
    << fmt_num(100 * v.coverage_probability, 4) << " % quantile " << fmt_num(v.threshold, 4);
  if (v.statistic_scale != 1 || v.statistic_dof != v.dof)
    s << " for the design's uniform noise ("
      << fmt_num(boost::math::quantile(boost::math::chi_squared(v.dof), v.coverage_probability), 4)
      << " were it normal)";
  s << " (p = " << fmt_num(v.p_value, 2) << ")\n";
  for (const std::string& n : r.notes) s << "Note: " << terminal_text(n) << "\n";
  if (v.pass)
    s << "PASS: the result explains this test within its uncertainty\n";
  else
    s << "FAIL: the result does not explain this test: do not enter its values before the cause "
         "is found\n";
  if (!v.worst.empty()) {
    s << "largest residuals after the constant parts (um; std: of the residual when the result "
         "is right):\n";
    for (const std::size_t i : v.worst) {
      const VerifiedReading& c = v.readings_checked[i];
      const Reading& in = r.readings[c.index];
      s << "  " << terminal_text(in.installation) << " at " << r.letter << " "
        << angle_text(in.angle_deg) << " deg";
      if (in.line > 0) s << " (line " << in.line << ")";
      if (std::find(r.reversed.begin(), r.reversed.end(), in.installation) != r.reversed.end())
        s << " (reversed count)";
      s << ": read " << fmt_rounded(c.read_um, 2) << ", predicted "
        << fmt_rounded(c.predicted_um, 2) << ", residual " << fmt_rounded(c.residual_um, 2)
        << ", std " << fmt_rounded(c.std_um, 2) << " (" << fmt_rounded(c.normalized, 1)
        << " std)\n";
    }
  }
  if (!v.pass && !v.explanations.empty()) {
    const VerifyExplanation& x = v.explanations.front();
    const auto q = static_cast<std::size_t>(x.location);
    s << (x.passes_with ? "What explains it: " : "No one location error explains it; the most: ")
      << r.location_names[q] << " changed by " << (x.change >= 0 ? "+" : "")
      << fmt_rounded(x.change, 2) << " " << r.location_units[q] << " (U "
      << fmt_rounded(r.k * x.change_std, 2) << ", k = " << fmt_num(r.k, 3)
      << ") leaves chi-squared " << fmt_num(x.chi2, 4)
      << (x.passes_with ? ": the test passes with it" : ": still a fail with it") << "\n";
  }
  return s.str();
}

TestPrediction predict_test(const ResultFile& result, const Design& design,
                            const std::string& design_source, double coverage_probability,
                            bool location_only) {
  check_test_axis(result, design, design_source);
  check_test_size(nominal_readings(design).size(), design_source);
  const AxisErrors axis = axis_errors_of(result);
  TestPrediction t;
  t.result_source = result.source;
  t.design_source = design_source;
  t.axis_label = result.axis.label();
  t.design_name = design.name;
  t.letter = result.axis.letter();
  t.location_only = location_only;
  t.k = boost::math::quantile(boost::math::normal(), 0.5 + coverage_probability / 2);
  t.result_dof = axis.dof;
  t.warnings = result.warnings;
  t.reversed = reversed_installations(design);
  VerifyOptions o;
  o.coverage_probability = coverage_probability;
  o.location_only = location_only;
  t.p = predict_test_readings(axis, design, o);
  if (t.p.gap == VerifyGap::kLocationNotDetermined) throw_not_determined(result, axis);
  return t;
}

namespace {

const char* const kTestPredictionMethod =
    "each reading of the test predicted from the result before it is run, the test run on the "
    "result's preset (the motions' constant parts, where the readings' zero was taken, the "
    "result's; verify fits them to what is read): at an angle the result measured the six "
    "motions it found there, elsewhere the location errors' part and the constant parts (the "
    "component motions there unknown: not in the prediction nor in U); the test's cups as its "
    "design has them; std: of the reading about the prediction when the result is right (the "
    "test's reading noise, the result's uncertainty, the test's declared set-up); U = k std";

}  // namespace

json test_prediction_to_json(const TestPrediction& t) {
  const PredictedTest& p = t.p;
  json readings = json::array();
  for (const PredictedReading& r : p.readings)
    readings.push_back({{"installation", r.reading.installation},
                        {"angle_deg", r.reading.angle_deg},
                        {"return", r.is_return},
                        {"predicted_um", r6(r.predicted_um)},
                        {"std_um", r6(r.std_um)},
                        {"U_um", r6(t.k * r.std_um)},
                        {"basis", basis_key(r.basis)}});
  json warnings = json::array();
  for (const std::string& w : t.warnings) warnings.push_back(w);
  json out{{"format", kPredictFormat},
           {"inputs", {{"result", t.result_source}, {"design", t.design_source}}},
           {"axis", t.axis_label},
           {"test", t.design_name},
           {"method", kTestPredictionMethod},
           {"coverage_probability", p.coverage_probability},
           {"k", t.k},
           {"location_only", t.location_only},
           {"noise_std_um", r6(p.noise_std_um)},
           {"angles", p.angles},
           {"angles_location_only", p.angles_location_only},
           {"angles_motions_correlated", p.angles_motions_correlated},
           {"angles_without_covariance", p.angles_without_covariance},
           {"readings", readings},
           {"result_dof", t.result_dof ? json(r6(*t.result_dof)) : json(nullptr)},
           {"result_warnings", warnings}};
  if (!t.result_sha256.empty()) out["inputs"]["result_sha256"] = t.result_sha256;
  return out;
}

std::string test_prediction_text(const TestPrediction& t) {
  const PredictedTest& p = t.p;
  std::ostringstream s;
  s << "predict: the " << p.readings.size() << " readings of " << terminal_text(t.design_name)
    << " (" << terminal_text(t.design_source) << ") before it is run, from "
    << terminal_text(t.result_source) << ", the " << t.axis_label << " axis\n";
  for (const std::string& w : t.warnings)
    s << "Warning (the result's; its uncertainties may be too small): " << terminal_text(w) << "\n";
  // Before the run a measured angle's motions need no independence between angles: none is
  // counted as correlated (predict_test_readings).
  const int location_only = p.angles_location_only - p.angles_without_covariance;
  if (t.location_only)
    s << "the location errors alone at every angle (--location-only): the component error "
         "motions are not in U\n";
  else if (location_only > 0)
    s << "at " << location_only << " of the test's " << p.angles
      << " angles the result measured no motions (marked *): the location errors and the "
         "constant parts alone predict those readings (their estimates taken as independent), "
         "and the component motions there are not in the prediction nor in U\n";
  if (!t.location_only && p.angles_without_covariance > 0)
    s << "at " << p.angles_without_covariance << " of the test's " << p.angles
      << " angles (marked *) the result states its motions, or their covariance, not in full (an "
         "earlier version, or diagnose's shares of equivalent effects): the location errors and "
         "the constant parts alone predict them, the component motions are not in U\n";
  s << "the test run on the result's preset (the motions' constant parts the result's: verify "
       "fits them to what is read), its cups as its design has them; U at "
    << fmt_num(100 * p.coverage_probability, 4) << " % (k = " << fmt_num(t.k, 3)
    << "): the test's reading noise (" << fmt_num(p.noise_std_um, 3)
    << " um), the result's uncertainty and the test's declared set-up";
  if (t.result_dof) s << " (the result's Type A uncertainties taken as known)";
  s << "\n";
  std::string installation;
  for (const PredictedReading& r : p.readings) {
    if (r.reading.installation != installation) {
      installation = r.reading.installation;
      s << "installation " << terminal_text(installation)
        << (std::find(t.reversed.begin(), t.reversed.end(), installation) != t.reversed.end()
                ? " (um, in the instrument's reversed count: reading_sign -1)"
                : " (um)")
        << ":\n";
    }
    const std::string value = fmt_rounded(r.predicted_um, 2);
    s << "  " << t.letter << " " << angle_text(r.reading.angle_deg) << " deg"
      << (r.is_return ? " (return)" : "") << ": " << (value[0] != '-' && value != "0" ? "+" : "")
      << value << " +- " << fmt_rounded(t.k * r.std_um, 2)
      << (r.basis == PredictionBasis::kLocationOnly && !t.location_only ? " *" : "") << "\n";
  }
  return s.str();
}

}  // namespace dbbkit::io
