#include "dbbkit/io/diagnose_io.hpp"

#include <cmath>
#include <iomanip>
#include <sstream>

#include "dbbkit/instrument.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/diagnose_text.hpp"
#include "dbbkit/io/result_io.hpp"
#include "dbbkit/kinematics.hpp"
#include "result_blocks.hpp"

namespace dbbkit::io {

using nlohmann::json;

namespace {

json signature_to_json(const ResidualSignature& s, const Design& design,
                       const std::vector<Reading>& readings) {
  json list = json::array();
  for (const auto& i : s.installations) {
    json e = {{"installation", i.id},
              {"ball_mm", {{"L", i.L_mm}, {"D", i.D_mm}, {"H", i.H_mm}}},
              {"n", i.n},
              {"mean_um", r6(i.mean_um)},
              {"rms_um", r6(i.rms_um)}};
    json h = json::array();
    for (double a : i.harmonic_um) h.push_back(r6(a));
    e["harmonic_amplitude_um"] = h;
    e["slope_um_per_min"] = i.slope_um_per_min ? json(r6(*i.slope_um_per_min)) : json(nullptr);
    e["cw_minus_ccw_um"] = i.cw_minus_ccw_um ? json(r6(*i.cw_minus_ccw_um)) : json(nullptr);
    list.push_back(e);
  }
  return {
      {"installations", list},
      {"dominant", s.dominant ? describe_feature(design, readings, *s.dominant) : std::string()}};
}

json reading_to_json(const Reading& r) {
  json j = {{"installation", r.installation},
            {"angle_deg", r.angle_deg},
            {"reading_um", r6(r.reading_um)}};
  j["time_s"] = r.time_s ? json(*r.time_s) : json(nullptr);
  j["sweep"] = r.sweep ? json(sweep_name(*r.sweep)) : json(nullptr);
  j["line"] = r.line > 0 ? json(r.line) : json(nullptr);
  return j;
}

json column_test_to_json(const ColumnTest& t) {
  return {{"columns", t.q},
          {"added_rank", t.added_rank},
          {"delta_chi2", r6(t.delta_chi2)},
          {"F", r6(t.F)},
          {"dof", t.dof},
          {"p_value", t.p}};
}

json features_to_json(const Design& d, const std::vector<ResidualFeature>& fs) {
  json out = json::array();
  for (const ResidualFeature& f : fs) {
    json j = {{"kind", feature_kind_name(f.kind)},
              {"installation",
               f.installation >= 0 ? json(d.installations[f.installation].id) : json(nullptr)},
              {"test", column_test_to_json(f.test)},
              {"alternatives_scanned", f.tested},
              {"p_value", f.p}};
    if (f.kind == FeatureKind::kHarmonic) {
      j["harmonic"] = f.harmonic;
      j["amplitude_um"] = r6(f.value);
    } else {
      j["value"] = r6(f.value);
      j["std"] = r6(f.std);
      j["unit"] = f.kind == FeatureKind::kDrift ? "um/min" : "um";
    }
    if (f.reading) j["reading"] = reading_to_json(*f.reading);
    json diff = json::array();
    for (int i : f.difference_with) diff.push_back(d.installations[i].id);
    j["only_difference_determined_with"] = diff;
    j["beyond_instrument_range_um"] =
        f.beyond_instrument_um ? json(r6(*f.beyond_instrument_um)) : json(nullptr);
    j["beyond_max_drift_um_per_min"] =
        f.beyond_drift_rate_um_per_min ? json(r6(*f.beyond_drift_rate_um_per_min)) : json(nullptr);
    out.push_back(j);
  }
  return out;
}

json gross_to_json(const std::vector<GrossReading>& gs) {
  json out = json::array();
  for (const GrossReading& g : gs) {
    json j = {{"residual_um", r6(g.residual_um)},
              {"offset_um", r6(g.value_um)},
              {"offset_std_um", r6(g.std_um)},
              {"studentised", r6(g.t)},
              {"p_value", g.p},
              {"p_value_over_readings", g.p_scan},
              {"readings_tested", g.tested}};
    if (g.reading) j["reading"] = reading_to_json(*g.reading);
    // Readings the data cannot tell from it: any one of them may be the gross one.
    json alt = json::array();
    for (std::size_t k = 0; k < g.alternatives.size(); ++k) {
      json a = reading_to_json(g.alternatives[k]);
      if (k < g.alternative_values_um.size()) a["offset_um"] = r6(g.alternative_values_um[k]);
      alt.push_back(a);
    }
    j["indistinguishable_from"] = alt;
    out.push_back(j);
  }
  return out;
}

std::vector<std::string> installations_of(const Design& d, const EffectCandidate& e) {
  std::vector<std::string> ids;
  for (std::size_t i = 0; i < d.installations.size(); ++i) {
    if (e.installation < 0 || e.installation == static_cast<int>(i))
      ids.push_back(d.installations[i].id);
  }
  return ids;
}

// x as printed to `decimals` places without a sign when it rounds to zero: a residual mean of
// -1e-17 um is 0.00, not -0.00.
double unsigned_zero(double x, int decimals) {
  return std::abs(x) < 0.5 * std::pow(10.0, -decimals) ? 0.0 : x;
}

std::string signature_text(const ResidualSignature& s, const Design& design,
                           const std::vector<Reading>& readings) {
  const AxisFrame& axis = design.axis;
  // The place of each row's point: L, and D where the axis has no H or a point lies off the
  // plane through the axis (a probe's spheres, an offset head's balls), H where the axis has it.
  bool off_plane = false;
  for (const auto& i : s.installations) off_plane = off_plane || i.D_mm != 0;
  const bool show_d = !axis.has_H() || off_plane;
  std::ostringstream o;
  o << std::setw(8) << instrument_info(design.instrument).row_column << std::setw(8) << "L_mm";
  if (show_d) o << std::setw(8) << "D_mm";
  if (axis.has_H()) o << std::setw(8) << "H_mm";
  o << std::setw(5) << "n" << std::setw(10) << "mean" << std::setw(10) << "rms";
  if (axis.full_turn())
    o << std::setw(9) << "1/turn" << std::setw(9) << "2/turn" << std::setw(9) << "3/turn"
      << std::setw(9) << "4/turn";
  o << std::setw(12) << "um/min" << std::setw(10) << "cw-ccw"
    << "\n";
  for (const auto& i : s.installations) {
    o << std::setw(8) << i.id << std::fixed << std::setprecision(1) << std::setw(8) << i.L_mm;
    if (show_d) o << std::setw(8) << i.D_mm;
    if (axis.has_H()) o << std::setw(8) << i.H_mm;
    o << std::setw(5) << i.n << std::fixed << std::setprecision(2) << std::setw(10)
      << unsigned_zero(i.mean_um, 2) << std::setw(10) << i.rms_um;
    if (axis.full_turn()) {
      for (int k = 0; k < 4; ++k) {
        if (k < static_cast<int>(i.harmonic_um.size())) {
          o << std::setw(9) << i.harmonic_um[k];
        } else {
          o << std::setw(9) << "--";
        }
      }
    }
    o << std::setw(12);
    if (i.slope_um_per_min)
      o << std::setprecision(3) << unsigned_zero(*i.slope_um_per_min, 3);
    else
      o << "--";
    o << std::setw(10);
    if (i.cw_minus_ccw_um)
      o << std::setprecision(2) << unsigned_zero(*i.cw_minus_ccw_um, 2);
    else
      o << "--";
    o << std::defaultfloat << "\n";
  }
  o << "most significant feature (+- standard uncertainty, k = 1): "
    << (s.dominant ? describe_feature(design, readings, *s.dominant) : "(not tested)") << "\n";
  return o.str();
}

}  // namespace

std::string diagnose_iso_note(const DiagnoseResult& r) {
  return "of the corrected errors: standard uncertainty (k = 1) from the final model's covariance "
         "(the declared reading noise)" +
         std::string(
             r.attributions.empty()
                 ? ""
                 : " and the share of the alternatives that fit almost as well or "
                   "equally (as the errors carry it: rectangular for those that fit almost as "
                   "well, the whole change for those that fit equally; the error motion "
                   "values without it)");
}

json diagnose_to_json(const Design& design, const std::vector<Reading>& readings,
                      const DiagnoseResult& r, const InputFiles& inputs) {
  json j = result_header("dbbkit.diagnose/1", design, inputs);
  j["method"] =
      "forward selection; a candidate is added when its nested F-test p-value is below level / "
      "(candidates tested "
      "at that step) and the BIC decreases; a candidate that does not raise the rank by its number "
      "of columns is "
      "confounded and never added";
  j["level"] = r.level;
  j["warnings"] = warnings_to_json(r.warnings);
  j["summary"] = brief_to_json(diagnose_brief(design, r));
  j["iso230"] = iso230_to_json(r.iso_after, diagnose_iso_note(r));
  j["before"] = residual_to_json(r.before);
  j["after"] = residual_to_json(r.after);
  j["residual"] = j["after"];
  j["significant_residual_before"] = r.significant_before;
  j["significant_residual_after"] = r.significant_after;
  j["after_lower_tail_p"] = r.p_lower_after ? json(*r.p_lower_after) : json(nullptr);
  j["verdict"] = diagnose_verdict(design, readings, r);
  json added = json::array();
  for (const AddedEffect& a : r.added) {
    json value = json::object(), std = json::object();
    for (std::size_t k = 0; k < a.values.size(); ++k) {
      const std::string& p = a.block.parameters[k];
      value[p] = a.values[k].determined ? json(r6(a.values[k].value)) : json(nullptr);
      std[p] = a.values[k].determined ? json(r6(a.values[k].std)) : json(nullptr);
    }
    const EffectEvidence& e = a.evidence;
    added.push_back({{"name", effect_name(a.block.effect.kind)},
                     {"label", a.block.label},
                     {"installations", installations_of(design, a.block.effect)},
                     {"value", value},
                     {"std", std},
                     {"unit", a.block.unit},
                     {"equivalent_to", a.equivalent_to},
                     {"close_alternatives", a.close_alternatives},
                     {"evidence",
                      {{"step", e.step},
                       {"F", e.F},
                       {"q", e.q},
                       {"dof", e.dof},
                       {"p_value", e.p_value},
                       {"p_threshold", e.p_threshold},
                       {"candidates_tested", e.n_tested},
                       {"alternatives_scanned", e.scanned > 0 ? json(e.scanned) : json(nullptr)},
                       {"bic_change", e.bic_change},
                       {"chi2_before", e.chi2_before},
                       {"chi2_after", e.chi2_after}}}});
  }
  j["added_effects"] = added;
  json structures = json::array();
  for (const StructureComparison& c : r.structures) {
    structures.push_back({{"effect", c.kind},
                          {"chosen", c.chosen},
                          {"rejected", c.rejected},
                          {"bic_chosen", c.bic_chosen},
                          {"bic_rejected", c.bic_rejected}});
  }
  j["structures"] = structures;
  json substitutions = json::array();
  for (const Substitution& sub : r.substitutions) {
    std::vector<std::string> by;
    for (const EffectBlock& b : sub.by) by.push_back(b.label);
    substitutions.push_back({{"replaced", sub.replaced}, {"by", by}, {"chi2", sub.chi2}});
  }
  j["substitutions"] = substitutions;
  json attributions = json::array();
  for (const Attribution& at : r.attributions) {
    json change = json::object();
    for (int k = 0; k < 6; ++k) change[kErrorNames[k]] = r6(at.largest_change[k]);
    attributions.push_back(
        {{"effect", at.effect},
         {"kind", at.convention ? "equivalent" : "fits almost as well"},
         {"untried_combinations", at.untried},
         {"alternatives", at.alternatives},
         {"largest_change", change},
         {"distribution", at.convention
                              ? "two-point bound: the change enters the errors' std whole"
                              : "rectangular, half-width the change, in the errors' std"}});
  }
  j["attributions"] = attributions;
  json cands = json::array();
  for (const CandidateStatus& c : r.candidates)
    cands.push_back({{"label", c.label},
                     {"status", candidate_state_name(c.state)},
                     {"detail", candidate_detail(c)}});
  j["candidates"] = cands;
  json risks = json::array();
  for (const SetupRisk& k : r.setup_risks) {
    risks.push_back(
        {{"effect", k.label},
         {"error", kErrorNames[k.error]},
         {"angle_deg", k.angle_deg},
         {"bias_per_um", r6(k.bias_per_um)},
         {"unit", std::string(kErrorUnits[k.error]) + " per um"},
         {"stated_std", r6(k.stated_std)},
         {"threshold_um", r6(k.threshold_um)},
         {"declared_std_um", k.declared_std_um > 0 ? json(k.declared_std_um) : json(nullptr)},
         {"bias_at_declared", k.at_declared ? json(r6(*k.at_declared)) : json(nullptr)},
         {"exceeds_stated_std", k.exceeds}});
  }
  j["undetectable_setup_effects"] = risks;
  j["errors"] = errors_to_json(r.errors_after, true);
  j["errors_before"] = errors_to_json(r.errors_before, true);
  json change = json::object();
  for (int k = 0; k < 6; ++k) {
    const std::optional<double>& m = r.largest_change_of_errors[k];
    change[kErrorNames[k]] = m ? json(r6(*m)) : json(nullptr);
  }
  j["largest_change_of_errors"] = change;
  j["units"] = {{"dx", "um"},   {"dy", "um"},   {"dz", "um"},
                {"ex", "urad"}, {"ey", "urad"}, {"ez", "urad"}};
  j["unidentifiable"] = unidentifiable_to_json(r.unidentifiable_after);
  json checks = {
      {"level", r.level},
      {"method",
       "each feature is the F-test of appending its columns to the final model (scale-free: "
       "referred to "
       "the residual's own scatter); a scan (a step at any reading of an installation, one reading "
       "alone) "
       "takes its best position, its p times the positions scanned (Bonferroni)"},
      {"features_after", features_to_json(design, r.features_after)},
      {"features_before", features_to_json(design, r.features_before)},
      {"gross_readings", gross_to_json(r.gross)},
      {"selection_stopped_at_gross_reading_step",
       r.stopped_because == SelectionStop::kGrossReading ? json(r.stopped_at_step) : json(nullptr)},
      {"selection_stopped_at_model_order_step",
       r.stopped_because == SelectionStop::kModelOrder ? json(r.stopped_at_step) : json(nullptr)},
      {"excluded_readings", gross_to_json(r.excluded)},
      {"gross_readings_not_excluded", gross_to_json(r.not_excluded)},
      {"noise_larger_than_declared", r.noise_larger_than_declared}};
  if (r.noise) {
    checks["noise_scale"] = {{"ratio", r6(r.noise->ratio)},
                             {"low_95", r6(r.noise->low)},
                             {"high_95", r6(r.noise->high)}};
  } else {
    checks["noise_scale"] = nullptr;
  }
  if (r.order) {
    checks["model_order"] = {
        {"order", r.order->order},
        {"suggested", r.order->suggested},
        {"orders_tried", r.order->tried},
        {"test", column_test_to_json(r.order->test)},
        {"p_value_over_orders", r.order->p},
        {"chi2_with", r6(r.order->chi2_with)},
        {"dof_with", r.order->dof_with},
        {"p_value_with", r.order->p_value_with ? json(*r.order->p_value_with) : json(nullptr)}};
  } else {
    checks["model_order"] = nullptr;
  }
  json limits = json::array();
  for (const DetectionLimit& d : r.detection_limits) {
    limits.push_back({{"effect", d.label},
                      {"unit", d.unit},
                      {"size_found_with_power_0_9", d.limit ? json(r6(*d.limit)) : json(nullptr)},
                      {"beyond_instrument_range_um",
                       d.beyond_instrument_um ? json(r6(*d.beyond_instrument_um)) : json(nullptr)},
                      {"beyond_max_drift_um_per_min",
                       d.beyond_drift_rate_um_per_min ? json(r6(*d.beyond_drift_rate_um_per_min))
                                                      : json(nullptr)}});
  }
  checks["detection_limits"] = limits;
  j["residual_checks"] = checks;
  j["signature_before"] = signature_to_json(r.signature_before, design, readings);
  j["signature_after"] = signature_to_json(r.signature_after, design, readings);
  return j;
}

std::string diagnose_summary(const Design& design, const std::vector<Reading>& readings,
                             const DiagnoseResult& r) {
  std::ostringstream s;
  s << brief_text(diagnose_brief(design, r)) << warnings_text(r.warnings);
  s << "design: " << (design.name.empty() ? "(unnamed)" : design.name) << "  axis "
    << design.axis.label() << "  errors " << design.errors.describe() << "\n";
  s << "noise: " << design.noise.describe() << "\n";
  s << "before: " << residual_text(r.before) << "\n";
  s << "after:  " << residual_text(r.after) << "\n\n";
  s << diagnose_verdict(design, readings, r) << "\n\n";
  if (!r.added.empty()) {
    s << "added effects (value +- standard uncertainty, k = 1):\n";
    for (const AddedEffect& a : r.added) {
      s << "  " << std::left << std::setw(22) << a.block.label << std::right;
      for (std::size_t k = 0; k < a.values.size(); ++k) {
        s << " " << a.block.parameters[k] << " = " << std::fixed << std::setprecision(3)
          << a.values[k].value << " +- " << a.values[k].std << std::defaultfloat;
      }
      s << " " << a.block.unit << "   (F = " << std::setprecision(4) << a.evidence.F
        << ", p = " << std::setprecision(3) << a.evidence.p_value << ")\n";
    }
    s << "\n";
  }
  int confounded = 0, na = 0, setup = 0;
  std::vector<const CandidateStatus*> implausible;
  for (const CandidateStatus& c : r.candidates) {
    confounded += c.state == CandidateState::kConfounded;
    na += c.state == CandidateState::kNotApplicable;
    setup += c.state == CandidateState::kSetUp;
    if (c.state == CandidateState::kImplausible) implausible.push_back(&c);
  }
  s << "candidates: " << r.candidates.size() << " (" << confounded << " confounded with the model, "
    << na << " not applicable to these readings"
    << (setup > 0 ? ", " + std::to_string(setup) +
                        " declared set-up effects carried as identify carries them, not sought"
                  : std::string())
    << "; see the JSON)\n";
  for (const CandidateStatus* c : implausible)
    s << "  left out: " << c->label << ": " << candidate_detail(*c) << "\n";
  if (!r.setup_risks.empty()) {
    s << "\nset-up effects this design cannot detect (size that moves the error by its standard "
         "uncertainty; "
         "bias per um; at the declared size):\n";
    for (const SetupRisk& k : r.setup_risks) {
      s << "  " << std::left << std::setw(22) << k.label << std::right << std::setprecision(3)
        << std::setw(8) << k.threshold_um << " um  " << kErrorNames[k.error] << " at "
        << k.angle_deg << " deg, u = " << k.stated_std << " " << kErrorUnits[k.error] << ", "
        << k.bias_per_um << " " << kErrorUnits[k.error] << " per um";
      if (k.at_declared)
        s << ", " << *k.at_declared << " " << kErrorUnits[k.error]
          << (k.exceeds ? " (exceeds u)" : "");
      s << "\n";
    }
  }
  s << "\nresidual signature before [um]:\n"
    << signature_text(r.signature_before, design, readings);
  s << "\nresidual signature after [um]:\n" << signature_text(r.signature_after, design, readings);
  s << "\nerrors after (value +- standard uncertainty, k = 1); '--' = not determined\n";
  s << errors_table(r.errors_after, true);
  s << unidentifiable_text(r.unidentifiable_after);
  s << iso230_text(design, r.iso_after, diagnose_iso_note(r));
  return s.str();
}

}  // namespace dbbkit::io
