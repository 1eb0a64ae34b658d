#include "dbbkit/io/result_io.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include "dbbkit/instrument.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/diagnose_text.hpp"
#include "dbbkit/io/text.hpp"
#include "dbbkit/kinematics.hpp"
#include "dbbkit/linear_model.hpp"
#include "result_blocks.hpp"

namespace dbbkit::io {

using nlohmann::json;

namespace {

const char* kConditionScaling =
    "singular values of Sigma^-1/2 J S, S scaling every column to unit Euclidean norm";

}  // namespace

json optional_number(const std::optional<double>& x) { return x ? json(*x) : json(nullptr); }

json errors_to_json(const std::vector<ErrorsAtAngle>& list, bool values) {
  json errors = json::array();
  for (const ErrorsAtAngle& ea : list) {
    json value, std;
    for (int k = 0; k < 6; ++k) {
      const Determined& d = ea.errors[k];
      value[kErrorNames[k]] = d.determined ? json(r6(d.value)) : json(nullptr);
      std[kErrorNames[k]] = d.determined ? json(r6(d.std)) : json(nullptr);
    }
    json entry = {{"angle_deg", ea.angle_deg}};
    if (values) entry["value"] = value;
    entry["std"] = std;
    errors.push_back(entry);
  }
  return errors;
}

json unidentifiable_to_json(const std::vector<Unidentifiable>& list) {
  json unid = json::array();
  for (const Unidentifiable& u : list) {
    json coeffs = json::object();
    for (const auto& [name, c] : u.terms) coeffs[name] = r6(c);
    json entry = {{"combination", coeffs}, {"expression", unidentifiable_expression(u)}};
    if (u.angle_deg) entry["angle_deg"] = *u.angle_deg;
    if (u.motion) entry["interpretation"] = unidentifiable_interpretation(u);
    unid.push_back(entry);
  }
  return unid;
}

json residual_to_json(const Estimate& est) {
  return {{"rms_um", r6(est.rms_um)},
          {"chi2", est.chi2},
          {"dof", est.dof},
          {"p_value", optional_number(est.p_value)}};
}

json warnings_to_json(const std::vector<Warning>& warnings) {
  json list = json::array();
  for (const Warning& w : warnings) list.push_back({{"kind", w.kind}, {"text", w.text}});
  return list;
}

std::string warnings_text(const std::vector<Warning>& warnings) {
  std::string t;
  for (const Warning& w : warnings) t += "WARNING: " + w.text + "\n";
  return t;
}

json result_header(const std::string& format, const Design& design, const InputFiles& inputs) {
  json j;
  j["format"] = format;
  j["dbbkit_version"] = DBBKIT_VERSION;
  j["inputs"] = {{"design", inputs.design}, {"data", inputs.data}};
  j["design"] = {{"name", design.name},
                 {"axis", design.axis.label()},
                 {"errors_model", design.errors.describe()}};
  // The axis as the design gave it (shorthand or general form), for compare and compensation.
  j["design"]["axis_definition"] = axis_to_json(design.axis);
  if (!design.assumed.empty()) j["design"]["assumed"] = design.assumed;
  if (design.machine) {
    // The machine the axis belongs to and where the others stood (formats.md, "Machine file"):
    // what `chain` combines results by.
    const DesignMachine& dm = *design.machine;
    json park = json::object();
    const std::vector<double> a = dm.park_angles();
    for (std::size_t k = 0; k < a.size(); ++k)
      if (static_cast<int>(k) != dm.axis) park[std::string(1, dm.machine->rotary[k].letter)] = a[k];
    const Eigen::Vector3d o = dm.origin_mm();
    j["design"]["machine"] = {{"name", dm.machine->name},
                              {"file", dm.file},
                              {"controller", controller_name(dm.machine->controller)},
                              {"axis", std::string(1, dm.letter())},
                              {"park_deg", park},
                              {"origin_mm", {o.x(), o.y(), o.z()}}};
  }
  j["noise"] = noise_to_json(design.noise);
  j["noise"]["sigma_um"] = design.noise.sigma_um();
  return j;
}

void add_rank_block(json& j, const Estimate& est) {
  j["status"] = status_name(est.status);
  j["message"] = estimate_message(est);
  j["n_readings"] = est.n_readings;
  j["n_unknowns"] = est.n_unknowns;
  j["rank"] = est.rank;
  j["condition_number"] = optional_number(est.condition_number);
  j["condition_scaling"] = kConditionScaling;
}

std::string residual_text(const Estimate& est) {
  std::ostringstream s;
  s << "rms " << std::setprecision(4) << est.rms_um << " um, chi2 " << est.chi2 << " on " << est.dof
    << " dof";
  if (est.p_value && *est.p_value < 1e-300) {
    s << ", p < 1e-300";
  } else if (est.p_value) {
    s << ", p = " << std::setprecision(3) << *est.p_value;
  } else {
    s << ", p undefined (no redundant reading)";
  }
  return s.str();
}

json budget_to_json(const Design& design, const Budget& budget) {
  json b;
  b["standard"] =
      "JCGM 100: u_c^2 = sum of the components' u^2, nu_eff by Welch-Satterthwaite, U = k u_c";
  b["coverage_probability"] = budget.coverage_probability;
  b["noise_evaluation"] = noise_evaluation_text(budget);
  if (budget.type_a_scale) b["type_a_scale"] = *budget.type_a_scale;
  if (design.instrument == InstrumentKind::kProbe) {
    b["setup_std_um"] = {{"trigger_offset", design.setup_std.trigger_offset_um},
                         {"placement", design.setup_std.placement_um}};
  } else {
    b["setup_std_mm"] = {
        {"L", design.setup_std.L_mm}, {"D", design.setup_std.D_mm}, {"H", design.setup_std.H_mm}};
  }
  json values = json::array();
  for (const ValueBudget& v : budget.values) {
    json comps = json::array();
    for (const BudgetComponent& c : v.components) {
      comps.push_back(
          {{"name", c.name}, {"type", c.type}, {"u", r6(c.u)}, {"dof", optional_number(c.dof)}});
    }
    values.push_back({{"angle_deg", v.angle_deg},
                      {"error", kErrorNames[v.error]},
                      {"unit", kErrorUnits[v.error]},
                      {"value", r6(v.value)},
                      {"components", comps},
                      {"u_c", r6(v.u_c)},
                      {"nu_eff", optional_number(v.nu_eff)},
                      {"k", v.k},
                      {"U", r6(v.U)}});
  }
  b["values"] = values;
  return b;
}

json monte_carlo_to_json(const MonteCarloResult& mc) {
  json m;
  m["standard"] =
      "JCGM 101: adaptive Monte Carlo, probabilistically symmetric coverage intervals, validation "
      "of the linear result";
  m["trials"] = mc.trials;
  m["converged"] = mc.converged;
  m["threads"] = mc.threads;
  m["seed"] = mc.seed;
  m["coverage_probability"] = mc.coverage_probability;
  m["significant_digits"] = mc.significant_digits;
  m["n_validated"] = mc.n_validated;
  m["message"] = monte_carlo_message(mc);
  json values = json::array();
  for (const MonteCarloValue& v : mc.values) {
    values.push_back({{"angle_deg", v.angle_deg},
                      {"error", kErrorNames[v.error]},
                      {"mean", r6(v.mean)},
                      {"std", r6(v.std)},
                      {"low", r6(v.low)},
                      {"high", r6(v.high)},
                      {"linear_low", r6(v.linear_value - v.linear_U)},
                      {"linear_high", r6(v.linear_value + v.linear_U)},
                      {"delta", v.delta},
                      {"d_low", r6(v.d_low)},
                      {"d_high", r6(v.d_high)},
                      {"validated", v.validated},
                      {"interval", {r6(v.interval_low()), r6(v.interval_high())}},
                      {"interval_method", v.validated ? "linear (validated)" : "Monte Carlo"}});
  }
  m["values"] = values;
  return m;
}

std::string monte_carlo_summary(const MonteCarloResult& mc) {
  std::ostringstream s;
  s << "\nMonte Carlo (JCGM 101): " << mc.trials << " trials, " << mc.threads << " thread(s), seed "
    << mc.seed << (mc.converged ? ", converged" : ", NOT converged") << "\n  "
    << monte_carlo_message(mc) << "\n";
  int shown = 0;
  for (const MonteCarloValue& v : mc.values) {
    if (v.validated) continue;
    if (shown++ == 0) {
      s << "  not validated (the " << 100 * mc.coverage_probability
        << "% interval reported is the Monte Carlo one):\n";
      s << std::setw(13) << "angle_deg" << std::setw(6) << "error" << std::setw(24)
        << "linear interval" << std::setw(24) << "Monte Carlo interval" << std::setw(10) << "d_low"
        << std::setw(10) << "d_high" << std::setw(10) << "delta"
        << "\n";
    }
    if (shown > 12) continue;
    std::ostringstream lin, m;
    lin << std::fixed << std::setprecision(3) << "[" << v.linear_value - v.linear_U << ", "
        << v.linear_value + v.linear_U << "]";
    m << std::fixed << std::setprecision(3) << "[" << v.low << ", " << v.high << "]";
    s << std::setw(13) << v.angle_deg << std::setw(6) << kErrorNames[v.error] << std::setw(24)
      << lin.str() << std::setw(24) << m.str() << std::setw(10) << std::setprecision(3) << v.d_low
      << std::setw(10) << v.d_high << std::setw(10) << v.delta << "\n";
  }
  if (shown > 12) s << "  ... and " << shown - 12 << " more (see the JSON)\n";
  return s.str();
}

json first_order_to_json(const FirstOrderCheck& f) {
  if (!f.computed) return {{"computed", false}, {"reason", first_order_reason(f)}};
  json j = {{"computed", true},
            {"largest_term_um", r6(f.largest_term_um)},
            {"at", {{"installation", f.installation}, {"angle_deg", f.angle_deg}}},
            {"threshold_um", r6(f.threshold_um)},
            {"warning", f.warn},
            {"term", instrument_info(f.instrument).first_order_term}};
  j["bias_bound_std"] = optional_number(f.bias_bound_std);
  if (f.bias_error >= 0)
    j["bias_bound_at"] = {{"error", kErrorNames[f.bias_error]}, {"angle_deg", f.bias_angle_deg}};
  return j;
}

std::string first_order_text(const FirstOrderCheck& f) {
  std::ostringstream s;
  s << "first-order check: ";
  if (!f.computed) return s.str() + "not computed: " + first_order_reason(f) + "\n";
  s << std::setprecision(3) << "largest second-order term " << f.largest_term_um << " um ("
    << f.installation << " at " << f.angle_deg << " deg), " << (f.warn ? "ABOVE" : "below")
    << " 0.25 sigma = " << f.threshold_um << " um";
  if (f.bias_bound_std) {
    s << "; it can bias an error by at most " << *f.bias_bound_std << " standard uncertainties ("
      << kErrorNames[f.bias_error] << " at " << f.bias_angle_deg << " deg)";
  }
  if (f.warn && f.bias_bound_std && *f.bias_bound_std >= 1) {
    s << ": more than the stated uncertainty, the first-order reading model is not adequate for "
         "this set-up";
  }
  return s.str() + "\n";
}

json identify_setup_to_json(const Design& design, const IdentifyResult& result) {
  json setup = {{"included", result.setup_included},
                {"note", identify_setup_note(result)},
                {"tolerances", setup_tolerances_to_json(design)}};
  json est = json::array();
  for (const SetupEstimate& e : result.setup_estimates) {
    est.push_back({{"effect", e.label},
                   {"parameter", e.parameter},
                   {"value_um", r6(e.value_um)},
                   {"std_um", r6(e.std_um)},
                   {"declared_std_um", e.declared_std_um}});
  }
  setup["estimates"] = est;
  setup["first_order_check"] = first_order_to_json(result.first_order);
  return setup;
}

json identify_to_json(const Design& design, const std::vector<Reading>& readings,
                      const IdentifyResult& result, const InputFiles& inputs,
                      const MonteCarloResult* mc, bool with_readings) {
  const Estimate& est = result.estimate;
  json j = result_header("dbbkit.identify/1", design, inputs);
  j["uncertainty"] =
      "std: combined standard uncertainty u_c (k = 1); U: expanded uncertainty k u_c (see budget)";
  add_rank_block(j, est);
  j["warnings"] = warnings_to_json(result.warnings);
  j["summary"] = brief_to_json(identify_brief(design, result));

  j["errors"] = errors_to_json(result.errors, true);
  for (json& e : j["errors"]) {
    e["U"] = {{"dx", nullptr}, {"dy", nullptr}, {"dz", nullptr},
              {"ex", nullptr}, {"ey", nullptr}, {"ez", nullptr}};
  }
  for (const ValueBudget& v : result.budget.values)
    j["errors"][v.station]["U"][kErrorNames[v.error]] = r6(v.U);
  j["budget"] = budget_to_json(design, result.budget);
  j["iso230"] = iso230_to_json(result);
  if (mc) j["monte_carlo"] = monte_carlo_to_json(*mc);
  j["units"] = {{"dx", "um"},   {"dy", "um"},   {"dz", "um"},
                {"ex", "urad"}, {"ey", "urad"}, {"ez", "urad"}};
  j["unidentifiable"] = unidentifiable_to_json(result.unidentifiable);
  j["residual"] = residual_to_json(est);
  j["setup"] = identify_setup_to_json(design, result);
  j["effects"] = fitted_effects_to_json(result.effects);

  if (design.errors.kind != ErrorModel::Kind::kPerAngle) {
    const Parameterisation param(design);
    json params = json::array();
    for (int p = 0; p < param.n_parameters(); ++p) {
      Eigen::VectorXd c = Eigen::VectorXd::Zero(est.n_unknowns);
      c(p) = 1.0;
      const Determined d = est.evaluate(c);
      params.push_back({{"name", param.parameter_name(p)},
                        {"unit", kErrorUnits[param.parameter_error(p)]},
                        {"value", d.determined ? json(r6(d.value)) : json(nullptr)},
                        {"std", d.determined ? json(r6(d.std)) : json(nullptr)}});
    }
    j["parameters"] = params;
  }

  if (with_readings) {
    json rows = json::array();
    for (std::size_t i = 0;
         i < readings.size() && i < static_cast<std::size_t>(est.residual_um.size()); ++i) {
      rows.push_back(identify_reading_row(design, readings, est, i));
    }
    j["readings"] = rows;
  }
  return j;
}

json fitted_effects_to_json(const std::vector<FittedEffect>& effects) {
  json out = json::array();
  for (const FittedEffect& f : effects) {
    json value = json::object(), std = json::object();
    for (std::size_t k = 0; k < f.values.size(); ++k) {
      const Determined& d = f.values[k];
      value[f.parameters[k]] = d.determined ? json(r6(d.value)) : json(nullptr);
      std[f.parameters[k]] = d.determined ? json(r6(d.std)) : json(nullptr);
    }
    json change = json::object();
    for (int k = 0; k < 6; ++k) change[kErrorNames[k]] = r6(f.largest_change[k]);
    out.push_back({{"label", f.label},
                   {"value", value},
                   {"std", std},
                   {"unit", f.unit},
                   {"equivalent_to", f.equivalent_to},
                   {"largest_change", f.equivalent_to.empty() ? json(nullptr) : change}});
  }
  return out;
}

std::string fitted_effects_text(const std::vector<FittedEffect>& effects) {
  if (effects.empty()) return "";
  std::ostringstream s;
  s << "\neffects fitted with the errors (value +- standard uncertainty):\n";
  for (const FittedEffect& f : effects) {
    for (std::size_t k = 0; k < f.values.size(); ++k) {
      const Determined& d = f.values[k];
      s << "  " << std::left << std::setw(28)
        << (f.values.size() > 1 ? f.label + "." + f.parameters[k] : f.label) << std::right;
      if (d.determined) {
        s << std::setw(10) << fmt_num(d.value, 4) << " +- " << fmt_num(d.std, 3);
      } else {
        s << std::setw(10) << "--"
          << " (not determined by the data)";
      }
      s << " " << f.unit << "\n";
    }
  }
  return s.str();
}

json identify_reading_row(const Design& design, const std::vector<Reading>& readings,
                          const Estimate& est, std::size_t i) {
  const Reading& r = readings[i];
  const Eigen::Index k = static_cast<Eigen::Index>(i);
  const int at = design.find_installation(r.installation);
  const double count =
      at < 0 ? 1.0 : design.installations[static_cast<std::size_t>(at)].reading_sign;
  const double residual = count == 1 ? est.residual_um(k) : count * est.residual_um(k);
  return {{"installation", r.installation},
          {"angle_deg", r.angle_deg},
          {"reading_um", r6(r.reading_um)},
          {"fitted_um", r6(r.reading_um - residual)},
          {"residual_um", r6(residual)}};
}

std::string json_text(const json& j, const std::string& key, std::size_t count,
                      const std::function<json(std::size_t)>& row) {
  if (j.contains(key))
    throw std::logic_error("json_text: the document holds \"" + key + "\" already");
  // A placeholder no value of the document can spell (a control character is escaped in a
  // dumped string), replaced by the array written row by row at the indent of a top-level key.
  json doc = j;
  const std::string mark = "\\u0001rows\\u0001";
  doc[key] = "\x01rows\x01";
  const std::string text = dump_json(doc);
  const std::string slot = "\"" + mark + "\"";
  const std::size_t at = text.find(slot);
  if (at == std::string::npos) throw std::logic_error("json_text: placeholder not found");
  std::string out = text.substr(0, at);
  if (count == 0) {
    out += "[]";
  } else {
    out += "[\n";
    for (std::size_t i = 0; i < count; ++i) {
      const std::string r = dump_json(row(i));
      out += "    ";
      for (char c : r) {
        out += c;
        if (c == '\n') out += "    ";
      }
      out += i + 1 < count ? ",\n" : "\n";
    }
    out += "  ]";
  }
  out.append(text, at + slot.size(), std::string::npos);
  return out;
}

// "2.06 um (dy at 180 deg; angular errors x 100 mm)".
std::string worst_phrase(const WorstCase& w, double reference_length_mm) {
  if (!w.worst_determined_std_um || w.at_error < 0) return "";
  return fmt_num(*w.worst_determined_std_um, 3) + " um (" + kErrorNames[w.at_error] + " at " +
         fmt_num(w.at_angle_deg, 6) + " deg" +
         (w.at_error >= 3 ? "; angular errors x " + fmt_num(reference_length_mm, 6) + " mm"
                          : std::string()) +
         ")";
}

nlohmann::json brief_to_json(const std::vector<BriefItem>& brief) {
  nlohmann::json a = nlohmann::json::array();
  for (const BriefItem& b : brief) a.push_back({{"topic", b.topic}, {"text", b.text}});
  return a;
}

namespace {

// "every error at every angle is determined (108 unknowns from 133 readings)", or how many
// combinations are not.
std::string determined_sentence(const Estimate& est, std::size_t n_unidentifiable) {
  if (est.status == EstimateStatus::kNoReadings) return "No readings: nothing is determined.";
  if (est.status == EstimateStatus::kFullRank)
    return "Determined: every error at every angle (" + std::to_string(est.n_unknowns) +
           " unknowns from " + std::to_string(est.n_readings) + " readings).";
  return "Not determined: " + std::to_string(est.n_unknowns - est.rank) +
         " combination(s) of the errors (" + std::to_string(n_unidentifiable) +
         " listed under 'not determined', never printed as numbers); the rest is determined.";
}

bool has_warning(const std::vector<Warning>& warnings, const std::string& kind) {
  for (const Warning& w : warnings)
    if (w.kind == kind) return true;
  return false;
}

}  // namespace

std::vector<BriefItem> evaluate_brief(const Design& design, const Evaluation& ev) {
  std::vector<BriefItem> out;
  add_brief_item(out, "determined", determined_sentence(ev.prior, ev.unidentifiable.size()));
  const std::string noise = worst_phrase(ev.worst, ev.reference_length_mm);
  const std::string lead = ev.prior.rank < ev.prior.n_unknowns
                               ? "Worst standard uncertainty of the determined errors (k = 1): "
                               : "Worst standard uncertainty (k = 1): ";
  if (ev.worst_total) {
    const std::string total = worst_phrase(*ev.worst_total, ev.reference_length_mm);
    add_brief_item(out, "worst",
                   lead + total + " with the declared set-up tolerances; " + noise +
                       " from the reading noise.");
  } else if (!noise.empty()) {
    add_brief_item(out, "worst", lead + noise + ", from the reading noise alone.");
  }
  if (ev.worst_total_typical && ev.worst_total_typical->worst_determined_std_um) {
    add_brief_item(out, "setup",
                   "No length offset or centring tolerance is declared: with typical ones "
                   "(length offset " +
                       fmt_num(kTypicalLengthOffsetStd_um, 3) + " um, centring " +
                       fmt_num(kTypicalCentringStd_um, 3) + " um) the worst would be " +
                       worst_phrase(*ev.worst_total_typical, ev.reference_length_mm) + ".");
  }
  std::vector<std::string> next;
  if (ev.prior.status == EstimateStatus::kRankDeficient)
    next.push_back(instrument_info(design.instrument).evaluate_add_next);
  if (!design.setup_nuisance_declared())
    next.push_back(std::string("declare ") + instrument_info(design.instrument).setup_effect_nouns +
                   " tolerances (setup_std) in the design");
  if (next.empty()) next.push_back(instrument_info(design.instrument).measure_next);
  add_next_items(out, next);
  return out;
}

std::vector<BriefItem> identify_brief(const Design& design, const IdentifyResult& result) {
  std::vector<BriefItem> out;
  const Estimate& est = result.estimate;
  add_brief_item(out, "determined", determined_sentence(est, result.unidentifiable.size()));
  std::string loc;
  for (const IsoQuantity& q : result.iso.location) {
    if (!q.value.determined) continue;
    loc += (loc.empty() ? "" : ", ") + q.name + " " + fmt_num(q.value.value, 3) + " +- " +
           fmt_num(q.value.std, 2) + " " + q.unit;
  }
  if (!loc.empty())
    add_brief_item(out, "location",
                   "Location errors (value +- standard uncertainty, k = 1): " + loc + ".");
  if (design.reference_length_mm) {
    const std::string w = worst_phrase(worst_case(result.errors, *design.reference_length_mm),
                                       *design.reference_length_mm);
    if (!w.empty()) add_brief_item(out, "worst", "Worst standard uncertainty (k = 1): " + w + ".");
  }
  const bool residual = has_warning(result.warnings, "residual");
  const bool type_a = result.budget.type_a_dof.has_value();
  const std::string chi =
      "chi2 " + fmt_num(est.chi2, 4) + " on " + std::to_string(est.dof) + " dof";
  if (est.p_value) {
    std::string r;
    if (type_a)
      r = "The uncertainties are stated from the residual's own scatter (Type A, " + chi + ")" +
          (residual ? ", which the declared noise does not explain." : ".");
    else if (residual)
      r = "The residual contradicts the declared noise (" + chi +
          "): these uncertainties do not hold.";
    else
      r = "The residual agrees with the declared noise (" + chi +
          ", p = " + fmt_num(*est.p_value, 3) + ").";
    add_brief_item(out, "residual", r);
  }
  std::vector<std::string> next;
  if (residual)
    next.push_back(type_a ? "dbbkit diagnose to find what the model lacks"
                          : "dbbkit diagnose to find the effect, or --type-a to state the "
                            "uncertainty from the scatter");
  if (has_warning(result.warnings, "first_order"))
    next.push_back("smaller errors or a shorter bar (the first-order model is strained)");
  if (has_warning(result.warnings, "setup_undeclared"))
    next.push_back("declare set-up tolerances (setup_std) in the design");
  if (est.status == EstimateStatus::kRankDeficient)
    next.push_back(instrument_info(result.instrument).identify_add_next);
  if (next.empty())
    next.push_back("decide on the errors (--tolerances) or enter them (compensation)");
  add_next_items(out, next);
  return out;
}

std::string identify_summary(const Design& design, const IdentifyResult& result) {
  const Estimate& est = result.estimate;
  std::ostringstream s;
  s << brief_text(identify_brief(design, result));
  s << warnings_text(result.warnings);
  s << "design: " << (design.name.empty() ? "(unnamed)" : design.name) << "  axis "
    << design.axis.label() << "  errors " << design.errors.describe() << "\n";
  s << "noise: " << design.noise.describe() << "\n";
  s << estimate_message(est) << "\n";
  if (est.condition_number) {
    s << "condition number " << std::setprecision(4) << *est.condition_number << " ("
      << kConditionScaling << ")\n";
  }
  s << "residual: " << residual_text(est);
  const Budget& b = result.budget;
  s << "\nuncertainty: reading noise " << noise_evaluation_text(b);
  if (design.setup_std.placement()) {
    s << "; set-up L, D, H +- " << design.setup_std.L_mm << ", " << design.setup_std.D_mm << ", "
      << design.setup_std.H_mm << " mm (standard)";
  }
  s << "\nset-up: " << identify_setup_note(result);
  if (!b.values.empty()) {
    double kmin = b.values[0].k, kmax = kmin;
    for (const ValueBudget& v : b.values) kmin = std::min(kmin, v.k), kmax = std::max(kmax, v.k);
    s << "\nexpanded uncertainty U = k u_c for " << 100 * b.coverage_probability
      << "% coverage, k = " << std::setprecision(4) << kmin;
    if (kmax > kmin) s << " .. " << kmax;
  }
  s << "\n\nvalue +- combined standard uncertainty u_c (k = 1); '--' = not determined by the "
       "data\n";
  s << errors_table(result.errors, true);
  s << unidentifiable_text(result.unidentifiable);
  s << fitted_effects_text(result.effects);
  if (!result.setup_estimates.empty()) {
    s << "\nset-up effects estimated with their prior (value +- posterior standard uncertainty; "
         "declared):\n";
    for (const SetupEstimate& e : result.setup_estimates) {
      s << "  " << std::left << std::setw(22)
        << (e.label + (e.parameter == "value" ? "" : "." + e.parameter)) << std::right << std::fixed
        << std::setprecision(2) << std::setw(9) << e.value_um << " +- " << e.std_um
        << " um  (declared " << e.declared_std_um << ")" << std::defaultfloat << "\n";
    }
  }
  s << iso230_text(design, result);
  s << "\n" << first_order_text(result.first_order);
  return s.str();
}

nlohmann::json iso230_to_json(const IdentifyResult& result) {
  return iso230_to_json(result.iso, iso_uncertainty_note(result));
}

nlohmann::json iso230_to_json(const IsoResult& iso, const std::string& uncertainty_note) {
  auto quantity = [](const IsoQuantity& q) {
    return json{{"name", q.name},
                {"unit", q.unit},
                {"value", q.value.determined ? json(r6(q.value.value)) : json(nullptr)},
                {"std", q.value.determined ? json(r6(q.value.std)) : json(nullptr)}};
  };
  json j;
  j["standard"] =
      "ISO 230-1 / ISO 230-7, first order: location errors of the axis average line (least squares "
      "over the "
      "determined values), constant parts, component error motions";
  j["uncertainty"] = uncertainty_note;
  json loc = json::array(), con = json::array(), comp = json::array();
  for (const IsoQuantity& q : iso.location) loc.push_back(quantity(q));
  for (const IsoQuantity& q : iso.constants) con.push_back(quantity(q));
  for (const IsoComponentsAtAngle& a : iso.components) {
    json row{{"angle_deg", a.angle_deg}};
    for (int e = 0; e < 6; ++e) {
      const Determined& m = a.motions[e];
      row[iso.component_names[e]] = {{"value", m.determined ? json(r6(m.value)) : json(nullptr)},
                                     {"std", m.determined ? json(r6(m.std)) : json(nullptr)},
                                     {"unit", e < 3 ? "um" : "urad"}};
    }
    comp.push_back(row);
  }
  j["location"] = loc;
  {
    // The joint covariance of the location errors (what `chain` combines them by); null where
    // one is not determined.
    json rows = json::array();
    for (int r = 0; r < 5; ++r) {
      json row = json::array();
      for (int c = 0; c < 5; ++c) {
        const bool d = iso.location[r].value.determined && iso.location[c].value.determined;
        row.push_back(d ? json(iso.location_covariance(r, c)) : json(nullptr));
      }
      rows.push_back(row);
    }
    json names = json::array();
    for (const IsoQuantity& q : iso.location) names.push_back(q.name);
    j["location_covariance"] = {{"names", names},
                                {"matrix", rows},
                                {"unit", "the product of the two quantities' units (um, urad)"}};
  }
  j["constant_parts"] = con;
  j["components"] = comp;
  {
    // Each angle's six motions less their constant parts (the location errors' part plus the
    // component): what predict propagates to a point of the body.
    json at = json::array();
    auto matrix = [](const Eigen::Matrix<double, 6, 6>& m) {
      json rows = json::array();
      for (int r = 0; r < 6; ++r) {
        json row = json::array();
        for (int c = 0; c < 6; ++c) row.push_back(m(r, c));
        rows.push_back(row);
      }
      return rows;
    };
    for (const IsoComponentsAtAngle& a : iso.components) {
      if (!a.motion_covariance) continue;
      json entry{{"angle_deg", a.angle_deg}, {"matrix", matrix(*a.motion_covariance)}};
      if (a.errors_covariance) entry["errors_matrix"] = matrix(*a.errors_covariance);
      at.push_back(entry);
    }
    if (!at.empty()) {
      json names = json::array();
      for (int e = 0; e < 6; ++e) names.push_back(kErrorNames[e]);
      j["motion_covariance"] = {
          {"quantity",
           "the error motions at each angle less their constant parts: the location errors' part "
           "plus the component error motion (machine frame)"},
          {"names", names},
          {"unit", "the product of the two quantities' units (um, urad)"},
          {"errors_quantity",
           "errors_matrix: the error motions themselves at the angle, their constant parts "
           "included"},
          {"independent_between_angles", iso.independent_between_angles},
          {"at", at}};
    }
  }
  const IsoMotionValues& mv = iso.motion_values;
  if (!mv.values.empty()) {
    json vals = json::array();
    for (std::size_t e = 0; e < mv.values.size(); ++e) {
      const IsoMotionValue& v = mv.values[e];
      json row{
          {"name", v.name}, {"component", v.component}, {"unit", v.unit}, {"angles", v.angles}};
      if (v.computed) {
        row["value"] = r6(v.value);
        row["U"] = r6(v.U);
        row["interval"] = {r6(v.low), r6(v.high)};
      } else {
        row["value"] = nullptr;
        row["reason"] = iso_motion_reason(v, static_cast<int>(e));
      }
      vals.push_back(row);
    }
    j["error_motion_values"] = {
        {"values", vals},      {"coverage_probability", mv.coverage_probability},
        {"trials", mv.trials}, {"converged", mv.converged},
        {"seed", mv.seed},     {"method", iso_motion_note(mv)}};
  }
  if (!iso.gaps.empty() || !iso.not_in_model.empty()) j["note"] = iso_gaps_note(iso);
  return j;
}

std::string iso230_text(const Design& design, const IdentifyResult& result) {
  return iso230_text(design, result.iso, iso_uncertainty_note(result));
}

std::string iso230_text(const Design& design, const IsoResult& iso, const std::string& note) {
  std::ostringstream s;
  s << "\nISO 230-7 (first order; " << note << "):\n";
  s << "  location errors of the axis average line (value +- u, k = 1):\n";
  auto line = [&](const IsoQuantity& q) {
    s << "    " << std::left << std::setw(22) << q.name << std::right;
    if (q.value.determined) {
      s << std::fixed << std::setprecision(3) << std::setw(10) << q.value.value << " +- "
        << q.value.std << " " << q.unit << std::defaultfloat << "\n";
    } else {
      s << "        -- (not determined)\n";
    }
  };
  for (const IsoQuantity& q : iso.location) line(q);
  s << "  constant parts (where the readings' zero was taken; not location errors):\n";
  for (const IsoQuantity& q : iso.constants) line(q);
  s << "  component error motions (value; the location errors and constant parts removed):\n";
  s << "    " << std::setw(9) << "angle_deg";
  for (const std::string& n : iso.component_names)
    s << std::setw(12) << (n + (n[1] == 'X' || n[1] == 'Y' || n[1] == 'Z' ? " [um]" : " [urad]"));
  s << "\n";
  for (const IsoComponentsAtAngle& a : iso.components) {
    s << "    " << std::setw(9) << a.angle_deg;
    for (const Determined& m : a.motions) {
      if (m.determined) {
        s << std::fixed << std::setprecision(3) << std::setw(12) << m.value << std::defaultfloat;
      } else {
        s << std::setw(12) << "--";
      }
    }
    s << "\n";
  }
  const IsoMotionValues& mv = iso.motion_values;
  if (!mv.values.empty()) {
    s << "  error motion values (range over the measured angles; interval value +- U of coverage "
         "probability at least "
      << 100 * mv.coverage_probability << " %, U by Monte Carlo, " << mv.trials << " trials"
      << (mv.converged ? "" : ", not converged") << "):\n";
    for (std::size_t e = 0; e < mv.values.size(); ++e) {
      const IsoMotionValue& v = mv.values[e];
      s << "    " << std::left << std::setw(48) << (v.name + " (" + v.component + ")")
        << std::right;
      if (v.computed) {
        s << std::fixed << std::setprecision(3) << std::setw(9) << v.value << " " << std::setw(4)
          << v.unit << "  U " << v.U << "  [" << v.low << ", " << v.high << "]" << std::defaultfloat
          << "\n";
      } else {
        s << "  -- (" << iso_motion_reason(v, static_cast<int>(e)) << ")\n";
      }
    }
  }
  if (!iso.gaps.empty() || !iso.not_in_model.empty()) s << "  " << iso_gaps_note(iso) << "\n";
  (void)design;
  return s.str();
}

json effects_to_json(const std::vector<CandidateStatus>& effects) {
  json e = json::array();
  for (const CandidateStatus& c : effects)
    e.push_back({{"label", c.label},
                 {"status", candidate_state_name(c.state)},
                 {"detail", candidate_detail(c)}});
  return e;
}

std::string evaluate_summary(const Design& design, const Evaluation& ev) {
  const Estimate& est = ev.prior;
  std::ostringstream s;
  s << brief_text(evaluate_brief(design, ev));
  s << warnings_text(ev.warnings);
  s << "design: " << (design.name.empty() ? "(unnamed)" : design.name) << "  axis "
    << design.axis.label() << "  errors " << design.errors.describe() << "  " << est.n_readings
    << " readings\n";
  s << "noise: " << design.noise.describe() << "\n";
  s << estimate_message(est) << "\n";
  if (est.condition_number) {
    s << "condition number " << std::setprecision(4) << *est.condition_number << " ("
      << kConditionScaling << ")\n";
  }
  const ObservabilityIndices& o = ev.indices;
  s << std::setprecision(4) << "observability: O1 " << o.O1 << "  O2 " << o.O2 << "  O3 " << o.O3
    << "  O4 " << o.O4 << "  O5 " << o.O5 << "\n";
  const DesignCriteria& c = ev.criteria;
  s << "criteria on J'WJ (um, urad): D = log det ";
  if (c.D_logdet)
    s << *c.D_logdet;
  else
    s << "(singular)";
  s << ", A = trace inv ";
  if (c.A_trace)
    s << *c.A_trace;
  else
    s << "(singular)";
  s << ", E = min eig " << c.E_min_eigenvalue << ", G = max leverage " << c.G_max_leverage << "\n";
  const WorstCase& w = ev.worst;
  s << "worst standard uncertainty (k = 1; angular errors x " << ev.reference_length_mm << " mm): ";
  if (w.worst_std_um) {
    s << *w.worst_std_um << " um (" << kErrorNames[w.at_error] << " at " << w.at_angle_deg
      << " deg)\n";
  } else {
    s << "undefined: " << w.n_undetermined << " error value(s) not determined";
    if (w.worst_determined_std_um) {
      s << "; over the determined ones " << *w.worst_determined_std_um << " um ("
        << kErrorNames[w.at_error] << " at " << w.at_angle_deg << " deg)";
    }
    s << "\n";
  }
  if (ev.worst_total) {
    const WorstCase& t = *ev.worst_total;
    s << "worst total standard uncertainty (noise and set-up): ";
    if (t.worst_std_um) {
      s << *t.worst_std_um << " um (" << kErrorNames[t.at_error] << " at " << t.at_angle_deg
        << " deg)\n";
    } else if (t.worst_determined_std_um) {
      s << "over the determined errors " << *t.worst_determined_std_um << " um ("
        << kErrorNames[t.at_error] << " at " << t.at_angle_deg << " deg)\n";
    } else {
      s << "undefined\n";
    }
  }
  s << "set-up: " << evaluation_setup_note(ev) << "\n";
  if (ev.setup_included) {
    s << "\na-priori standard uncertainty (k = 1), reading-noise part; '--' = not determined by "
         "the design\n";
    s << errors_table(ev.errors, false);
    s << "\nset-up part (declared " << instrument_info(ev.instrument).setup_effect_nouns
      << " tolerances)\n";
    s << errors_table(ev.setup_errors, false);
    s << "\ntotal\n";
    s << errors_table(ev.total_errors, false);
  } else {
    s << "\na-priori standard uncertainty (k = 1); '--' = not determined by the design\n";
    s << errors_table(ev.errors, false);
  }
  s << unidentifiable_text(ev.unidentifiable);
  s << setup_checks_text(ev.setup_checks, ev.detection);
  s << drift_checks_text(ev);
  return s.str();
}

std::string errors_table(const std::vector<ErrorsAtAngle>& errors, bool values) {
  std::ostringstream s;
  s << std::setw(9) << "angle_deg";
  for (int k = 0; k < 6; ++k) {
    s << std::setw(20) << (std::string(kErrorNames[k]) + " [" + kErrorUnits[k] + "]");
  }
  s << "\n";
  for (const ErrorsAtAngle& ea : errors) {
    s << std::setw(9) << std::setprecision(6) << ea.angle_deg;
    for (int k = 0; k < 6; ++k) {
      std::ostringstream cell;
      if (!ea.errors[k].determined) {
        cell << "--";
      } else if (values) {
        cell << std::fixed << std::setprecision(2) << ea.errors[k].value << " +- "
             << ea.errors[k].std;
      } else {
        cell << std::fixed << std::setprecision(3) << ea.errors[k].std;
      }
      s << std::setw(20) << cell.str();
    }
    s << "\n";
  }
  return s.str();
}

std::string unidentifiable_text(const std::vector<Unidentifiable>& list) {
  std::ostringstream s;
  if (list.empty()) return "";
  s << "\nnot determined (" << list.size() << " combination(s)):\n";
  for (const Unidentifiable& u : list) {
    s << "  ";
    if (u.angle_deg) s << "at " << *u.angle_deg << " deg: ";
    s << unidentifiable_expression(u);
    if (u.motion) s << "\n      = " << unidentifiable_interpretation(u);
    s << "\n";
  }
  return s.str();
}

json setup_tolerances_to_json(const Design& design) {
  json list = json::array();
  if (design.instrument == InstrumentKind::kProbe) {  // a probe's: the design's, per sphere
    for (const Sphere& s : design.spheres)
      list.push_back({{"sphere", s.id},
                      {"trigger_offset_um", design.setup_std.trigger_offset_um},
                      {"placement_um", design.setup_std.placement_um}});
    return list;
  }
  for (int i = 0; i < static_cast<int>(design.installations.size()); ++i) {
    const SetupUncertainty u = design.setup_of(i);
    json e = {{"installation", design.installations[i].id},
              {"length_offset_um", u.length_offset_um},
              {"centring_um", u.centring_um},
              {"L_mm", u.L_mm},
              {"D_mm", u.D_mm}};
    if (design.axis.has_H()) e["H_mm"] = u.H_mm;
    list.push_back(e);
  }
  return list;
}

namespace {
// An effect's largest bias per um (null when it moves no determined error).
json bias_json(const std::optional<double>& bias, const std::optional<double>& bias_um, int error,
               double angle_deg, const std::string& per, double reference_length_mm) {
  if (!bias) return nullptr;
  return {{"error", kErrorNames[error]},
          {"angle_deg", angle_deg},
          {"value", r6(*bias)},
          {"unit", std::string(kErrorUnits[error]) + per},
          {"um_per_um_at_reference_length", r6(*bias_um)},
          {"reference_length_mm", reference_length_mm}};
}
}  // namespace

json setup_checks_to_json(const std::vector<SetupEffectCheck>& checks, double reference_length_mm) {
  json list = json::array();
  for (const SetupEffectCheck& c : checks) {
    json e = {{"effect", c.label},
              {"declared_std_um", c.declared_std_um > 0 ? json(c.declared_std_um) : json(nullptr)},
              {"detectable", c.detectable},
              {"detection_limit_um", optional_number(c.detection_limit_um)}};
    // Not detectable as a whole: the directions of its parameters the axis errors take.
    json hidden = json::array();
    for (const std::vector<double>& v : c.hidden_directions) {
      json d = json::object();
      for (std::size_t k = 0; k < v.size(); ++k) d[c.parameters[k]] = r6(v[k]);
      hidden.push_back(d);
    }
    e["hidden_directions"] = hidden;
    e["largest_bias_per_um"] = bias_json(c.bias_per_um, c.bias_um_per_um, c.bias_error,
                                         c.bias_angle_deg, " per um", reference_length_mm);
    list.push_back(e);
  }
  return list;
}

// " as a whole: the axis errors take (dL, dD, dH) = (0.13, -0.42, 0.9)" for an effect of several
// parameters that is not detectable as a whole; "" otherwise.
std::string hidden_directions_text(const SetupEffectCheck& c) {
  if (c.hidden_directions.empty()) return {};
  std::string names;
  for (const std::string& p : c.parameters) names += (names.empty() ? "" : ", ") + p;
  std::string t = " as a whole: the axis errors take (" + names + ") = ";
  for (std::size_t k = 0; k < c.hidden_directions.size(); ++k) {
    std::string v;
    for (double x : c.hidden_directions[k]) v += (v.empty() ? "" : ", ") + fmt_rounded(x, 2);
    t += (k == 0 ? "(" : " and (") + v + ")";
  }
  return t;
}

namespace {
// "detectable, limit 2.35 um; 1 um moves dy at -100 deg by 0.762 um" (per: " um" or
// " um over the test").
std::string detection_and_bias(bool detectable, const std::optional<double>& limit,
                               const std::optional<double>& bias, int error, double angle_deg,
                               const std::string& per, const std::string& hidden = "") {
  std::ostringstream line;
  if (detectable) {
    line << " detectable";
    if (limit) line << ", limit " << std::setprecision(3) << *limit << per;
  } else {
    line << " NOT detectable" << hidden;
  }
  if (bias) {
    line << "; 1" << per << " moves " << kErrorNames[error] << " at " << angle_deg << " deg by "
         << std::setprecision(3) << *bias << " " << kErrorUnits[error];
  }
  return line.str();
}
}  // namespace

std::string setup_checks_text(const std::vector<SetupEffectCheck>& checks,
                              const DetectionSettings& detection) {
  std::ostringstream s;
  s << "\nset-up effects (detection limit: smallest size the nested F test finds at level "
    << detection.level;
  if (detection.n_tests > 1) s << " / " << detection.n_tests << " candidates";
  s << " with power " << detection.power
    << "; bias: the largest change of an error per um of the effect):\n";
  for (const SetupEffectCheck& c : checks) {
    std::ostringstream line;
    line << "  " << std::left << std::setw(22) << c.label << std::right;
    if (c.declared_std_um > 0)
      line << " declared " << std::setprecision(3) << c.declared_std_um << " um;";
    line << detection_and_bias(c.detectable, c.detection_limit_um, c.bias_per_um, c.bias_error,
                               c.bias_angle_deg, " um", hidden_directions_text(c));
    s << line.str() << "\n";
  }
  return s.str();
}

namespace {
std::string drift_check_line(const DriftCheck& c) {
  std::ostringstream line;
  line << "  " << std::left << std::setw(26) << c.label << std::right
       << detection_and_bias(c.detectable, c.detection_limit_um, c.bias_per_um, c.bias_error,
                             c.bias_angle_deg, " um over the test");
  if (!c.bias_per_um) line << "; moves no determined error";
  return line.str();
}
}  // namespace

std::string drift_checks_text(const Evaluation& ev) {
  if (ev.drift.effects.empty()) return {};
  std::ostringstream s;
  const TestClock& k = ev.drift.clock;
  s << "\ndrift and warm-up over the whole test (undetected, per um the bar reads more from the "
       "first reading to the last; the test's clock: installations in the program's order, one "
       "increasing sweep each, "
    << k.per_reading_s << " s a reading, " << k.per_installation_s
    << " s between installations: " << std::setprecision(3) << ev.drift.test_min << " min):\n";
  for (const DriftCheck& c : ev.drift.effects) s << drift_check_line(c) << "\n";
  if (ev.drift_with_return) {
    const DriftCheck* before = nullptr;
    const DriftCheck* after = nullptr;
    for (const DriftCheck& c : ev.drift.effects)
      if (c.kind == EffectKind::kDrift) before = &c;
    for (const DriftCheck& c : ev.drift_with_return->effects)
      if (c.kind == EffectKind::kDrift) after = &c;
    if (before && after && after->detectable &&
        (!before->detectable || (after->detection_limit_um && before->detection_limit_um &&
                                 *after->detection_limit_um < 0.8 * *before->detection_limit_um))) {
      s << "  a return reading (design key return_reading: each sweep reads its first angle "
           "again at its end) would make the drift detectable";
      if (after->detection_limit_um)
        s << ", limit " << std::setprecision(3) << *after->detection_limit_um
          << " um over the test";
      s << " (the test then " << std::setprecision(3) << ev.drift_with_return->test_min
        << " min)\n";
    }
  }
  return s.str();
}

nlohmann::json drift_checks_to_json(const DriftChecks& d, double reference_length_mm) {
  json list = json::array();
  for (const DriftCheck& c : d.effects) {
    json e = {{"effect", c.label},
              {"per", "um over the test"},
              {"detectable", c.detectable},
              {"detection_limit_um", optional_number(c.detection_limit_um)}};
    if (c.kind == EffectKind::kThermal) e["tau_min"] = r6(c.tau_min);
    e["largest_bias_per_um"] =
        bias_json(c.bias_per_um, c.bias_um_per_um, c.bias_error, c.bias_angle_deg,
                  " per um over the test", reference_length_mm);
    list.push_back(e);
  }
  return {
      {"clock",
       {{"per_reading_s", d.clock.per_reading_s},
        {"per_installation_s", d.clock.per_installation_s},
        {"order",
         "installations in the program's order (its set-up order), one increasing sweep each"}}},
      {"test_min", r6(d.test_min)},
      {"effects", list}};
}

json evaluate_to_json(const Design& design, const Evaluation& ev, const std::string& design_file,
                      const MonteCarloResult* mc) {
  const Estimate& est = ev.prior;
  json j = result_header("dbbkit.evaluate/1", design, {design_file, ""});
  j["inputs"].erase("data");
  add_rank_block(j, est);
  j["warnings"] = warnings_to_json(ev.warnings);
  j["singular_values"] = std::vector<double>(
      est.singular_values.data(), est.singular_values.data() + est.singular_values.size());
  const ObservabilityIndices& o = ev.indices;
  j["observability"] = {
      {"O1", o.O1}, {"O2", o.O2}, {"O3", o.O3},
      {"O4", o.O4}, {"O5", o.O5}, {"on", "singular values of the equilibrated whitened Jacobian"}};
  const DesignCriteria& c = ev.criteria;
  j["criteria"] = {{"D_logdet", optional_number(c.D_logdet)},
                   {"A_trace", optional_number(c.A_trace)},
                   {"E_min_eigenvalue", c.E_min_eigenvalue},
                   {"G_max_leverage", c.G_max_leverage},
                   {"on", "M = J' Sigma^-1 J in the units of theta (um, urad)"}};
  j["reference_length_mm"] = ev.reference_length_mm;
  const WorstCase& w = ev.worst;
  j["worst_std_um"] = optional_number(w.worst_std_um);
  j["worst_determined_std_um"] = optional_number(w.worst_determined_std_um);
  j["n_undetermined"] = w.n_undetermined;
  if (w.at_error >= 0)
    j["worst_at"] = {{"angle_deg", w.at_angle_deg}, {"error", kErrorNames[w.at_error]}};
  j["worst_total_std_um"] =
      ev.worst_total ? optional_number(ev.worst_total->worst_std_um) : json(nullptr);
  j["worst_total_std_um_typical_setup"] =
      ev.worst_total_typical ? optional_number(ev.worst_total_typical->worst_std_um)
                             : json(nullptr);
  j["summary"] = brief_to_json(evaluate_brief(design, ev));
  j["errors"] = errors_to_json(ev.errors, false);
  if (ev.setup_included) {
    const json setup_part = errors_to_json(ev.setup_errors, false),
               total = errors_to_json(ev.total_errors, false);
    for (std::size_t i = 0; i < ev.errors.size(); ++i) {
      j["errors"][i]["setup_std"] = setup_part[i]["std"];
      j["errors"][i]["total_std"] = total[i]["std"];
    }
  }
  json setup = {{"included", ev.setup_included},
                {"note", evaluation_setup_note(ev)},
                {"tolerances", setup_tolerances_to_json(design)}};
  if (ev.worst_total) {
    const WorstCase& t = *ev.worst_total;
    setup["worst_total_std_um"] = optional_number(t.worst_std_um);
    setup["worst_total_determined_std_um"] = optional_number(t.worst_determined_std_um);
    if (t.at_error >= 0)
      setup["worst_total_at"] = {{"angle_deg", t.at_angle_deg}, {"error", kErrorNames[t.at_error]}};
  }
  setup["detection"] = {{"level", ev.detection.level},
                        {"n_tests", ev.detection.n_tests},
                        {"power", ev.detection.power},
                        {"test", "nested F test of the effect against the axis errors (diagnose)"}};
  setup["effects"] = setup_checks_to_json(ev.setup_checks, ev.reference_length_mm);
  j["setup"] = setup;
  if (!ev.drift.effects.empty()) {
    j["drift"] = drift_checks_to_json(ev.drift, ev.reference_length_mm);
    j["drift"]["return_reading"] = design.return_reading;
    if (ev.drift_with_return)
      j["drift"]["with_return_reading"] =
          drift_checks_to_json(*ev.drift_with_return, ev.reference_length_mm);
  }
  j["unidentifiable"] = unidentifiable_to_json(ev.unidentifiable);
  if (mc) j["monte_carlo"] = monte_carlo_to_json(*mc);
  return j;
}

std::string effects_summary(const Design& design, const std::vector<CandidateStatus>& effects) {
  std::ostringstream s;
  s << "\neffects this design can tell from the axis errors (" << design.errors.describe()
    << "):\n";
  for (CandidateState st :
       {CandidateState::kDetectable, CandidateState::kConfounded, CandidateState::kNotApplicable}) {
    s << "  " << candidate_state_name(st) << ":";
    for (const CandidateStatus& c : effects) {
      if (c.state == st) s << " " << c.label;
    }
    s << "\n";
  }
  return s.str();
}

std::string estimate_message(const Estimate& est) {
  const int p = est.n_unknowns, n = est.n_readings;
  switch (est.status) {
    case EstimateStatus::kNoReadings:
      return "no readings: nothing can be estimated";
    case EstimateStatus::kFullRank:
      return "full rank: " + std::to_string(p) + " unknowns from " + std::to_string(n) +
             " readings";
    case EstimateStatus::kRankDeficient:
      return "rank " + std::to_string(est.rank) + " of " + std::to_string(p) + ": " +
             std::to_string(p - est.rank) +
             " combination(s) of the unknowns are not determined by the data";
  }
  return "";
}

std::string monte_carlo_message(const MonteCarloResult& mc) {
  if (mc.values.empty()) return "no determined value to propagate";
  std::string t = std::to_string(mc.n_validated) + " of " + std::to_string(mc.values.size()) +
                  " values: the linear (GUM) interval is validated by Monte Carlo within its "
                  "numerical tolerance";
  if (mc.adaptive && !mc.converged)
    t += "; the adaptive procedure stopped at max_trials before its tolerance was met";
  if (mc.unplaced_endpoints > 0) {
    t += "; " + std::to_string(mc.unplaced_endpoints) +
         " interval endpoint(s) could not be placed within a tenth of the numerical tolerance "
         "(not validated)";
  }
  return t;
}

std::string identify_setup_note(const IdentifyResult& r) {
  const InstrumentInfo& info = instrument_info(r.instrument);
  return r.setup_included
             ? std::string("the errors' uncertainties include the declared ") +
                   info.setup_effect_nouns +
                   " tolerances: the set-up effects are estimated with their prior (what the "
                   "readings see is estimated, the rest is propagated at its declared size)"
             : std::string("set-up uncertainty of the ") + info.setup_effects_plural +
                   " is not included: the design declares no such tolerance (setup_std)";
}

std::string evaluation_setup_note(const Evaluation& ev) {
  const InstrumentInfo& info = instrument_info(ev.instrument);
  return ev.setup_included
             ? std::string("the uncertainties include the declared ") + info.setup_effect_nouns +
                   " tolerances (total = noise and set-up)" + info.setup_included_more
             : std::string("set-up uncertainty is not included: the design declares no ") +
                   info.setup_tolerance_none + " (setup_std)";
}

std::string iso_uncertainty_note(const IdentifyResult& r) {
  return std::string(
             "standard uncertainty (k = 1) from the estimate's covariance: reading noise (") +
         noise_evaluation_text(r.budget) + ")" +
         (r.setup_included ? std::string(" and the declared ") +
                                 instrument_info(r.instrument).setup_effect_nouns + " tolerances"
                           : std::string()) +
         (r.placement_declared ? "; the ball placement (L, D, H) is not propagated into them" : "");
}

std::string iso_motion_reason(const IsoMotionValue& v, int index) {
  switch (v.gap) {
    case IsoMotionGap::kNone:
      return "";
    case IsoMotionGap::kLocationNotDetermined:
      return std::string("the ") + (index < 3 ? "translations" : "rotations") +
             " do not determine the location errors";
    case IsoMotionGap::kNotEveryAngle:
      return std::to_string(v.angles) + " of the " + std::to_string(v.measured) +
             " measured angles determine " + v.component +
             ": its range over the measured angles is not known";
    case IsoMotionGap::kTooManyAngles:
      return std::to_string(v.angles) + " angles: more than the " + std::to_string(v.max_angles) +
             " whose joint covariance is drawn";
  }
  return "";
}

std::string iso_motion_note(const IsoMotionValues& mv) {
  const std::string pct =
      std::to_string(static_cast<int>(std::lround(100 * mv.coverage_probability)));
  return "range (peak-to-valley) of each component error motion over the measured angles (fixed "
         "sensitive direction); the range of estimated values is biased upward, so the interval "
         "is value +- U with U the " +
         pct +
         " % quantile of the range of the estimation errors (|range(estimate) - range(true)| <= "
         "range(errors): coverage probability at least " +
         pct + " %), U by Monte Carlo (JCGM 101) from the joint " +
         (mv.dof ? "t distribution (" + fmt_rounded(*mv.dof, 1) + " degrees of freedom)"
                 : std::string("Gaussian")) +
         " of the component values: " + std::to_string(mv.trials) + " trials, seed " +
         std::to_string(mv.seed) + (mv.converged ? "" : ", not converged");
}

std::string iso_gaps_note(const IsoResult& iso) {
  std::string t;
  if (!iso.not_in_model.empty()) {
    for (const std::string& n : iso.not_in_model) t += (t.empty() ? "" : ", ") + n;
    t += ": not in the error model (a model constant over the angle holds no offset or tilt of "
         "the axis line; a series of order 1 or more does)";
  }
  for (const IsoBlockGap& g : iso.gaps) {
    t += (t.empty() ? "" : "; ") + std::string(g.block == 0 ? "translations" : "rotations") +
         ": the determined values (" + std::to_string(g.values) +
         ") do not determine the location errors and constant parts (rank " +
         std::to_string(g.rank) + " of 5)";
  }
  return t;
}

std::string first_order_reason(const FirstOrderCheck& f) {
  return f.computed
             ? std::string()
             : "needs bar_mm on every installation (installation " + f.without_bar + " has none)";
}

namespace {
std::string vec_text(const Eigen::Vector3d& v) {
  auto clean = [](double x) { return std::abs(x) < 5e-13 ? 0.0 : x; };
  return "(" + fmt_num(clean(v.x()), 4) + ", " + fmt_num(clean(v.y()), 4) + ", " +
         fmt_num(clean(v.z()), 4) + ")";
}
}  // namespace

std::string unidentifiable_expression(const Unidentifiable& u) {
  std::string s;
  for (std::size_t i = 0; i < u.terms.size(); ++i) {
    const double c = u.terms[i].second;
    s += i == 0 ? (c < 0 ? "-" : "") : (c < 0 ? " - " : " + ");
    s += fmt_num(std::abs(c), 4) + " " + u.terms[i].first;
  }
  return s;
}

std::string rigid_motion_text(const RigidMotion& m) {
  if (m.kind == RigidMotion::Kind::kTranslation) {
    return "a translation of the moving body along " + vec_text(m.direction) +
           " (machine frame): it changes no reading";
  }
  std::string s =
      std::string(m.kind == RigidMotion::Kind::kRotation ? "a rotation" : "a screw motion") +
      " about the line through " + vec_text(m.point_mm) + " mm along " + vec_text(m.direction) +
      " (machine frame)";
  if (m.tool_axis) s += ", the tool axis";
  const InstrumentInfo& info = instrument_info(m.instrument);
  s += std::string("; ") +
       (m.on_all_balls ? info.motion_on_all_points : info.motion_across_readings);
  return s;
}

std::string unidentifiable_interpretation(const Unidentifiable& u) {
  return u.motion ? rigid_motion_text(*u.motion) : std::string();
}

std::string noise_evaluation_text(const Budget& b) {
  return b.type_a_dof
             ? "Type A (residual, " + std::to_string(*b.type_a_dof) + " degrees of freedom)"
             : "Type B (declared instrument: " + b.declared_noise.describe() + ")" +
                   (b.reading_type_a ? " and each reading's repeatability, Type A (its dwell's "
                                       "0.1 s batch means: u_a_um, u_a_dof of the measurement "
                                       "file; component 'reading repeatability')"
                                     : "");
}

}  // namespace dbbkit::io
