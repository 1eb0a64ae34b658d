#pragma once
// Conformance decisions after ISO 14253-1:2017 (its default rule, simple acceptance
// and rejection with the expanded uncertainty as guard band): for a tolerance zone
// [lower, upper] and a measured value y with the interval [y - U, y + U],
//   conforms            lower <= y - U and y + U <= upper   (conformity proven)
//   does not conform    y + U < lower  or  y - U > upper     (nonconformity proven)
//   not proven          otherwise (the interval straddles a limit)
// A quantity with a value at every measured angle (dx, EXC, ...) conforms when every
// value conforms and does not conform when one does not; a value the data do not
// determine cannot prove conformity (not proven, said so).
//
// The quantities and their intervals:
//   ISO location errors (X0C ...) and component error motions (EXC ... at every angle):
//     y +- k u, u from iso230.hpp, k the coverage factor at the budget's coverage
//     probability (normal, or Student's t at the residual's degrees of freedom with
//     a Type A budget);
//   error motion values ("EXC range" ...): [max(0, range - U), range + U] of iso230.hpp
//     (coverage probability at least p);
//   the identified errors dx ... ez at every angle: y +- U of the budget (uncertainty.hpp,
//     which also carries the ball placement L, D, H).

#include <optional>
#include <string>
#include <vector>

#include "dbbkit/diagnose.hpp"
#include "dbbkit/identify.hpp"
#include "dbbkit/monte_carlo.hpp"

namespace dbbkit {

// One tolerance zone, in the quantity's unit (um or urad); at least one limit.
struct Tolerance {
  std::string quantity;  // "X0C", "EXC", "EZC range", "dx", ...
  // The spelling the file used when it was the alias of the letter O ("XOC" for X0C, as an
  // earlier sketch of ISO 230-1's names wrote them); empty otherwise.
  std::string alias;
  std::optional<double> lower, upper;
  std::string unit;   // the limits' unit, "um" or "urad"; it must be the quantity's
  std::string where;  // where it was declared (e.g. "limits.XOC"), for messages
};

enum class Decision { kConforms, kDoesNotConform, kNotProven };

// "conforms", "does not conform", "not proven".
const char* decision_name(Decision d);

struct ConformanceResult {
  std::string quantity;
  std::string unit;
  std::optional<double> lower, upper;
  Decision decision = Decision::kNotProven;
  int values = 0;  // values decided (1, or the measured angles)
  int conforming = 0, nonconforming = 0, not_proven = 0, undetermined = 0;
  // The deciding value: the one farthest outside (does not conform), nearest the limit
  // (conforms) or straddling it (not proven); absent when no value is determined.
  std::optional<double> value, low, high;
  std::optional<double> angle_deg;  // where, for a quantity at every angle
  // What the intervals are: a location error's value +- k_iso u, the same at every measured
  // angle (component error motions), an error motion value's interval, or an identified
  // error's value +- U of its budget at every measured angle.
  // kCorrectedErrors: diagnose's corrected errors, value +- k u with the attributions' share in u.
  enum class Basis { kIsoQuantity, kIsoAtEveryAngle, kMotionValue, kBudget, kCorrectedErrors };
  Basis basis = Basis::kIsoQuantity;
  bool motion_values_computed = true;  // kMotionValue: false when none was asked for
  // An error motion value that was not computed, and its index in the order of the component
  // names (io says why after the basis).
  std::optional<IsoMotionValue> uncomputed_motion;
  int uncomputed_index = -1;
  // kBudget with a Monte Carlo run: the values decided on its interval (the one to report
  // where the linear interval is not validated); the others on the linear interval.
  int monte_carlo_intervals = 0;
};

struct ConformanceReport {
  double coverage_probability = 0.95;
  // k of the ISO 230-7 quantities' intervals: Student's t at type_a_dof degrees of freedom
  // (Type A), else the normal quantile.
  double k_iso = 0;
  std::optional<double> type_a_dof;
  std::vector<ConformanceResult> results;  // in the order of the tolerances
  // What the decisions rest on that the data or the design put in doubt: the residual
  // contradicting the declared noise (its chi2 p-value below kNoiseContradiction, Type B
  // only); no declared set-up tolerances.
  std::optional<double> noise_contradiction_p;
  bool no_setup_tolerances = false;
  // Decisions on diagnose's corrected errors (decide_conformance of a DiagnoseResult), whose
  // uncertainties leave out the design's declared set-up tolerances when it has any
  // (setup_declared_left_out: diagnose states them as set-up risks instead).
  bool corrected = false;
  bool setup_declared_left_out = false;
  // The names of the axis' two position errors (location errors of the axis average line that
  // a ball's centring moves), for the words that go with the decisions.
  std::string position_names;
  // Quantities the tolerance file named by the alias with the letter O ("XOC"): read as the
  // ISO 230-1 spelling with the digit zero ("X0C"), said once.
  std::vector<std::pair<std::string, std::string>> aliases;  // (as given, as read)
  bool any_nonconforming() const;
};

// The residual contradicts the declared noise when its chi2 p-value < kNoiseContradiction.
inline constexpr double kNoiseContradiction = 0.01;

// The quantities a tolerance can name for `axis`, for messages and documentation.
std::vector<std::string> tolerance_quantities(const AxisFrame& axis);

// The unit of a quantity ("um" or "urad"); throws InputError(source, t.where) when the
// quantity is not one of tolerance_quantities(axis) or its limits are in the other unit.
std::string tolerance_unit(const AxisFrame& axis, const Tolerance& t, const std::string& source);

// tolerance_unit of every tolerance: the quantities and units checked before any work.
void check_tolerances(const AxisFrame& axis, const std::vector<Tolerance>& tolerances,
                      const std::string& source);

// Decides every tolerance against an identification. Throws InputError as tolerance_unit.
// With `mc` (a Monte Carlo run of the same result), an identified error's value is decided on
// the interval that run reports (MonteCarloValue::interval_low/high): its own where the
// linear interval is not validated. A value, or an end of its interval, that is not finite
// counts as undetermined, never as conforming.
ConformanceReport decide_conformance(const Design& design, const IdentifyResult& result,
                                     const std::vector<Tolerance>& tolerances,
                                     const std::string& source,
                                     const MonteCarloResult* mc = nullptr);

// Decides every tolerance against diagnose's corrected errors (DiagnoseResult::errors_after
// and iso_after, the attributions' share in their standard uncertainties): value +- k u, k the
// normal quantile at the coverage probability (the corrected errors' uncertainties are Type B).
// Their intervals leave out the design's declared set-up tolerances (the report says so).
ConformanceReport decide_conformance(const Design& design, const DiagnoseResult& result,
                                     const std::vector<Tolerance>& tolerances,
                                     const std::string& source, double coverage_probability = 0.95);

}  // namespace dbbkit
