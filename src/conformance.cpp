#include "dbbkit/conformance.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <sstream>

#include "dbbkit/error.hpp"
#include "dbbkit/kinematics.hpp"
#include "dbbkit/user_text.hpp"

namespace dbbkit {

namespace {

// One value's interval against the zone: its decision and its margin (the smallest
// distance of the interval inside the zone; negative when it reaches outside).
struct Judged {
  Decision decision = Decision::kNotProven;
  double margin = 0;
};

Judged judge(double low, double high, const std::optional<double>& lower,
             const std::optional<double>& upper) {
  Judged j;
  j.margin = std::numeric_limits<double>::infinity();
  if (lower) j.margin = std::min(j.margin, low - *lower);
  if (upper) j.margin = std::min(j.margin, *upper - high);
  const bool outside = (lower && high < *lower) || (upper && low > *upper);
  if (outside) {
    j.decision = Decision::kDoesNotConform;
  } else if (j.margin >= 0) {
    j.decision = Decision::kConforms;
  }
  return j;
}

// Collects the values of one quantity and decides the set.
class SetDecision {
 public:
  explicit SetDecision(ConformanceResult& r) : r_(r) {}
  void undetermined() { ++r_.undetermined, ++r_.values; }
  void add(double value, double low, double high, std::optional<double> angle) {
    if (!std::isfinite(value) || !std::isfinite(low) || !std::isfinite(high)) {
      undetermined();  // no decision rests on a number that is not one
      return;
    }
    const Judged j = judge(low, high, r_.lower, r_.upper);
    ++r_.values;
    (j.decision == Decision::kConforms         ? r_.conforming
     : j.decision == Decision::kDoesNotConform ? r_.nonconforming
                                               : r_.not_proven)++;
    // The deciding value: of the worst decision so far, the smallest margin.
    const int rank = j.decision == Decision::kDoesNotConform ? 2
                     : j.decision == Decision::kNotProven    ? 1
                                                             : 0;
    if (!r_.value || rank > rank_ || (rank == rank_ && j.margin < margin_)) {
      rank_ = rank;
      margin_ = j.margin;
      r_.value = value;
      r_.low = low;
      r_.high = high;
      r_.angle_deg = angle;
    }
  }
  void finish() {
    if (r_.nonconforming > 0) {
      r_.decision = Decision::kDoesNotConform;
    } else if (r_.not_proven > 0 || r_.undetermined > 0 || r_.conforming == 0) {
      r_.decision = Decision::kNotProven;
    } else {
      r_.decision = Decision::kConforms;
    }
  }

 private:
  ConformanceResult& r_;
  int rank_ = -1;
  double margin_ = 0;
};

}  // namespace

const char* decision_name(Decision d) {
  switch (d) {
    case Decision::kConforms:
      return "conforms";
    case Decision::kDoesNotConform:
      return "does not conform";
    case Decision::kNotProven:
      return "not proven";
  }
  return "";
}

bool ConformanceReport::any_nonconforming() const {
  return std::any_of(results.begin(), results.end(), [](const ConformanceResult& r) {
    return r.decision == Decision::kDoesNotConform;
  });
}

std::vector<std::string> tolerance_quantities(const AxisFrame& axis) {
  const IsoNames names = iso230_names(axis);
  std::vector<std::string> q(names.location.begin(), names.location.end());
  for (const std::string& c : names.components) q.push_back(c);
  for (const std::string& c : names.components) q.push_back(c + " range");
  for (const char* e : kErrorNames) q.push_back(e);
  return q;
}

namespace {

// The index of t's quantity among q (tolerance_quantities(axis)) and its unit, checked
// against the limits' unit; throws as tolerance_unit.
int quantity_index(const AxisFrame& axis, const std::vector<std::string>& q, const Tolerance& t,
                   const std::string& source, std::string& unit) {
  const auto it = std::find(q.begin(), q.end(), t.quantity);
  if (it == q.end()) {
    std::string list;
    for (const std::string& n : q) list += (list.empty() ? "" : ", ") + n;
    throw InputError(source, t.where + ".quantity",
                     quote_value(t.quantity) + " is not a quantity of axis " + axis.label() +
                         "; a tolerance names one of: " + list);
  }
  const int i = static_cast<int>(it - q.begin());
  // Location: XO., YO./ZO. in um, the rest in urad; components and ranges: X, Y, Z in um;
  // errors: dx, dy, dz in um.
  bool length = false;
  if (i < 5) {
    length = i < 2;
  } else if (i < 17) {
    length = (i - 5) % 6 < 3;
  } else {
    length = i - 17 < 3;
  }
  unit = length ? "um" : "urad";
  // An error motion value is a range (a peak-to-valley): never negative.
  if (i >= 11 && i < 17 && t.upper && !(*t.upper > 0)) {
    throw InputError(source, t.where + ".upper",
                     t.quantity + " is a range, never negative: its upper limit must be > 0");
  }
  if (!t.unit.empty() && t.unit != unit) {
    throw InputError(source, t.where + ".unit",
                     t.quantity + " is " + (length ? "a length (um)" : "an angle (urad)") +
                         "; its limits are " + (length ? "an angle" : "a length"));
  }
  return i;
}

}  // namespace

std::string tolerance_unit(const AxisFrame& axis, const Tolerance& t, const std::string& source) {
  std::string unit;
  quantity_index(axis, tolerance_quantities(axis), t, source, unit);
  return unit;
}

void check_tolerances(const AxisFrame& axis, const std::vector<Tolerance>& tolerances,
                      const std::string& source) {
  for (const Tolerance& t : tolerances) tolerance_unit(axis, t, source);
}

namespace {

// One identified error's interval at one position: its value and the ends, and whether they
// are a Monte Carlo run's.
struct ErrorInterval {
  double value = 0, low = 0, high = 0;
  bool monte_carlo = false;
};

// What the decisions are made on: the ISO 230 quantities with their standard uncertainties,
// and the six errors' intervals at each station (station-major; absent where undetermined).
struct DecisionInputs {
  const IsoResult* iso = nullptr;
  std::vector<double> station_angle_deg;
  std::vector<std::optional<ErrorInterval>> errors;  // 6 per station
  ConformanceResult::Basis error_basis = ConformanceResult::Basis::kBudget;
};

void decide(const Design& design, const DecisionInputs& in,
            const std::vector<Tolerance>& tolerances, const std::string& source,
            ConformanceReport& rep) {
  {
    const IsoNames names = iso230_names(design.axis);
    rep.position_names = names.location[0] + ", " + names.location[1];
  }
  const double k_iso = rep.k_iso;
  const IsoResult& iso = *in.iso;
  const std::vector<std::string> q = tolerance_quantities(design.axis);
  for (const Tolerance& t : tolerances) {
    ConformanceResult r;
    r.quantity = t.quantity;
    if (!t.alias.empty()) rep.aliases.emplace_back(t.alias, t.quantity);
    const int i = quantity_index(design.axis, q, t, source, r.unit);
    r.lower = t.lower;
    r.upper = t.upper;
    SetDecision set(r);
    if (i < 5) {  // a location error
      const Determined& d = iso.location[i].value;
      r.basis = ConformanceResult::Basis::kIsoQuantity;
      if (d.determined) {
        set.add(d.value, d.value - k_iso * d.std, d.value + k_iso * d.std, std::nullopt);
      } else {
        set.undetermined();
      }
    } else if (i < 11) {  // a component error motion at every angle
      r.basis = ConformanceResult::Basis::kIsoAtEveryAngle;
      for (const IsoComponentsAtAngle& a : iso.components) {
        const Determined& d = a.motions[i - 5];
        if (d.determined) {
          set.add(d.value, d.value - k_iso * d.std, d.value + k_iso * d.std, a.angle_deg);
        } else {
          set.undetermined();
        }
      }
    } else if (i < 17) {  // an error motion value
      const IsoMotionValues& mv = iso.motion_values;
      r.basis = ConformanceResult::Basis::kMotionValue;
      if (mv.values.empty()) {
        set.undetermined();
        r.motion_values_computed = false;
      } else {
        const IsoMotionValue& v = mv.values[i - 11];
        if (v.computed) {
          set.add(v.value, v.low, v.high, std::nullopt);
        } else {
          set.undetermined();
          r.uncomputed_motion = v;
          r.uncomputed_index = i - 11;
        }
      }
    } else {  // an identified error at every angle
      const int e = i - 17;
      r.basis = in.error_basis;
      for (std::size_t s = 0; s < in.station_angle_deg.size(); ++s) {
        const std::optional<ErrorInterval>& v = in.errors[6 * s + e];
        if (v) {
          set.add(v->value, v->low, v->high, in.station_angle_deg[s]);
          r.monte_carlo_intervals += v->monte_carlo;
        } else {
          set.undetermined();
        }
      }
    }
    set.finish();
    rep.results.push_back(r);
  }
}

}  // namespace

ConformanceReport decide_conformance(const Design& design, const IdentifyResult& result,
                                     const std::vector<Tolerance>& tolerances,
                                     const std::string& source, const MonteCarloResult* mc) {
  ConformanceReport rep;
  const double p = result.budget.coverage_probability;
  rep.coverage_probability = p;
  const Estimate& est = result.estimate;
  const bool type_a = result.budget.type_a_scale.has_value();
  // k of the ISO quantities: Student's t at the degrees of freedom of their Type A part (the
  // residual's, or the least effective of the readings' own); Type B: infinite.
  rep.type_a_dof = iso_degrees_of_freedom(result.budget);
  rep.k_iso = coverage_factor(rep.type_a_dof, p);
  if (!type_a && est.p_value && *est.p_value < kNoiseContradiction)
    rep.noise_contradiction_p = *est.p_value;
  rep.no_setup_tolerances = !result.setup_included;
  DecisionInputs in;
  in.iso = &result.iso;
  for (const ErrorsAtAngle& a : result.errors) in.station_angle_deg.push_back(a.angle_deg);
  in.errors.resize(6 * result.errors.size());
  // The budget's value of each determined error (station-major), on the interval the result
  // reports: Monte Carlo's (in the budget's order) where the linear one is not validated.
  const bool with_mc = mc && mc->values.size() == result.budget.values.size();
  for (std::size_t k = 0; k < result.budget.values.size(); ++k) {
    const ValueBudget& v = result.budget.values[k];
    const MonteCarloValue* m = with_mc ? &mc->values[k] : nullptr;
    ErrorInterval x{v.value, v.value - v.U, v.value + v.U, false};
    if (m && !m->validated) x = {v.value, m->interval_low(), m->interval_high(), true};
    in.errors[6 * static_cast<std::size_t>(v.station) + static_cast<std::size_t>(v.error)] = x;
  }
  decide(design, in, tolerances, source, rep);
  return rep;
}

ConformanceReport decide_conformance(const Design& design, const DiagnoseResult& result,
                                     const std::vector<Tolerance>& tolerances,
                                     const std::string& source, double coverage_probability) {
  if (!(coverage_probability > 0 && coverage_probability < 1))
    throw InputError("options", "coverage_probability", "must lie strictly between 0 and 1");
  ConformanceReport rep;
  rep.coverage_probability = coverage_probability;
  rep.corrected = true;
  // The corrected errors' uncertainties are Type B (the declared noise, the attributions'
  // share): the normal quantile.
  rep.k_iso = coverage_factor(std::nullopt, coverage_probability);
  const Estimate& est = result.after;
  if (est.p_value && *est.p_value < kNoiseContradiction) rep.noise_contradiction_p = *est.p_value;
  for (int i = 0; i < static_cast<int>(design.installations.size()); ++i)
    rep.setup_declared_left_out = rep.setup_declared_left_out || design.setup_of(i).any();
  rep.no_setup_tolerances = !rep.setup_declared_left_out;
  DecisionInputs in;
  in.iso = &result.iso_after;
  in.error_basis = ConformanceResult::Basis::kCorrectedErrors;
  in.errors.resize(6 * result.errors_after.size());
  for (std::size_t s = 0; s < result.errors_after.size(); ++s) {
    const ErrorsAtAngle& a = result.errors_after[s];
    in.station_angle_deg.push_back(a.angle_deg);
    for (int e = 0; e < 6; ++e) {
      const Determined& d = a.errors[e];
      if (d.determined)
        in.errors[6 * s + e] =
            ErrorInterval{d.value, d.value - rep.k_iso * d.std, d.value + rep.k_iso * d.std};
    }
  }
  decide(design, in, tolerances, source, rep);
  return rep;
}

}  // namespace dbbkit
