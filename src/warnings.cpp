#include "dbbkit/warnings.hpp"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>

#include "dbbkit/diagnose.hpp"
#include "dbbkit/instrument.hpp"
#include "dbbkit/kinematics.hpp"
#include "factorised.hpp"
#include "number_text.hpp"
#include "setup_solver.hpp"
#include "wls_solver.hpp"

namespace dbbkit {

namespace {

std::string chi2_text(const Estimate& est) {
  std::string t =
      "chi2 " + text::significant(est.chi2, 4) + " on " + std::to_string(est.dof) + " dof, p ";
  if (*est.p_value < 1e-300) return t + "< 1e-300";
  return t + "= " + text::significant(*est.p_value, 2);
}

}  // namespace

std::optional<Warning> residual_warning(const Estimate& est, bool type_a) {
  if (!est.p_value || *est.p_value >= kWarningLevel) return std::nullopt;
  const double ratio = est.dof > 0 ? std::sqrt(est.chi2 / est.dof) : 0.0;
  if (type_a) {
    return Warning{"residual",
                   "The residual is " + text::significant(ratio, 2) +
                       " times the declared noise (" + chi2_text(est) +
                       "): the uncertainties are stated from the scatter (--type-a), but an "
                       "effect the model lacks still biases the values. Run dbbkit diagnose to "
                       "find it."};
  }
  return Warning{"residual",
                 "The residual contradicts the declared noise (" + chi2_text(est) + ", " +
                     text::significant(ratio, 2) +
                     " times the noise): the stated uncertainties hold only for a model that "
                     "explains the readings. Run dbbkit diagnose to find the effect, or identify "
                     "--type-a to state the uncertainty from the scatter."};
}

std::optional<Warning> first_order_warning(const FirstOrderCheck& f) {
  if (!f.computed || !f.warn || !f.bias_bound_std || *f.bias_bound_std < 1) return std::nullopt;
  return Warning{
      "first_order",
      "The first-order reading model is not adequate for this set-up: the term it neglects "
      "reaches " +
          text::significant(f.largest_term_um, 3) + " um (" + f.installation + " at " +
          text::significant(f.angle_deg, 6) + " deg) and can bias an error by up to " +
          text::significant(*f.bias_bound_std, 2) + " standard uncertainties (" +
          kErrorNames[f.bias_error] + " at " + text::significant(f.bias_angle_deg, 6) +
          " deg), which the stated uncertainty does not cover. Correct the largest errors and "
          "measure again, or use longer bars."};
}

std::vector<HiddenSetupEffect> hidden_setup_effects(const Design& design,
                                                    const Parameterisation& param,
                                                    const LinearModel& model,
                                                    const WlsSolver& solver,
                                                    double reference_length_mm) {
  std::vector<SetupEffect> undeclared;
  for (SetupEffect& e : setup_effects(design, model, false)) {
    if (!(e.std_um > 0)) undeclared.push_back(std::move(e));
  }
  return hidden_setup_effects(param, solver, undeclared, effect_columns(solver, undeclared),
                              determined_functions(param, solver.a_priori()), reference_length_mm);
}

std::vector<HiddenSetupEffect> hidden_setup_effects(
    const Parameterisation& param, const WlsSolver& solver, const std::vector<SetupEffect>& effects,
    const EffectColumns& columns, const DeterminedFunctions& fns, double reference_length_mm) {
  std::vector<HiddenSetupEffect> out;
  const Eigen::VectorXd& sigma = solver.sigma_um();
  Eigen::Index first = 0;  // the effect's first column
  for (const SetupEffect& e : effects) {
    const Eigen::Index q = e.J_reading_effect.cols();
    const Eigen::Index c0 = first;
    first += q;
    if (e.std_um > 0) continue;
    double scale = 0;  // the largest whitened column
    for (Eigen::Index c = 0; c < q; ++c)
      scale = std::max(scale, columns.X.col(c0 + c).cwiseQuotient(sigma).norm());
    if (scale <= 0) continue;
    // The singular values and directions of the unexplained part, from its q x q triangle.
    const Eigen::JacobiSVD<Eigen::MatrixXd> svd(
        triangular_factor(Eigen::MatrixXd(columns.R.middleCols(c0, q))), Eigen::ComputeFullV);
    const Eigen::VectorXd& sv = svd.singularValues();
    std::vector<Eigen::Index> hidden_dirs;
    for (Eigen::Index k = 0; k < q; ++k) {
      if ((k < sv.size() ? sv(k) : 0.0) <= 1e-8 * scale) hidden_dirs.push_back(k);
    }
    if (hidden_dirs.empty()) continue;              // every direction shows in the residual
    const auto GX = columns.G0X.middleCols(c0, q);  // the errors' estimate per um of each column
    HiddenSetupEffect h{e.label, 0, 0, 0, static_cast<int>(e.parameters.size())};
    for (const DeterminedFunctions::Function& f : fns.functions) {
      double norm2 = 0;  // |c'G X_e V_null|^2
      for (Eigen::Index d : hidden_dirs) {
        double along = 0;
        for (Eigen::Index c = 0; c < q; ++c) along += fns.dot(f, GX, c) * svd.matrixV()(c, d);
        norm2 += along * along;
      }
      const double b = std::sqrt(norm2) * (f.error < 3 ? 1.0 : 1e-3 * reference_length_mm);
      if (b > h.bias_um_per_um) {
        h.bias_um_per_um = b;
        h.error = f.error;
        h.angle_deg = param.station_angle_deg(f.station);
      }
    }
    if (h.bias_um_per_um > 1e-9) out.push_back(h);
  }
  // Most biasing first; biases equal to single precision (the same motion of two effects,
  // apart in the last digits by the order of the sums) keep the design's order.
  std::stable_sort(
      out.begin(), out.end(), [](const HiddenSetupEffect& a, const HiddenSetupEffect& b) {
        return static_cast<float>(a.bias_um_per_um) > static_cast<float>(b.bias_um_per_um);
      });
  return out;
}

std::optional<Warning> setup_undeclared_warning(const std::vector<HiddenSetupEffect>& hidden,
                                                double reference_length_mm,
                                                InstrumentKind instrument) {
  if (hidden.empty()) return std::nullopt;
  const HiddenSetupEffect& worst = hidden.front();
  std::string names;
  const size_t shown = std::min<size_t>(hidden.size(), 3);
  for (size_t i = 0; i < shown; ++i) names += (i ? ", " : "") + hidden[i].label;
  if (hidden.size() > shown) names += " and " + std::to_string(hidden.size() - shown) + " more";
  const bool angular = worst.error >= 3;
  return Warning{
      "setup_undeclared",
      std::to_string(hidden.size()) + " set-up effect" + (hidden.size() > 1 ? "s" : "") + " (" +
          names +
          ") cannot be told from the axis errors and leave no trace in the residual: each um of " +
          worst.label + (worst.parameters > 1 ? " along the direction no reading sees" : "") +
          " moves " + kErrorNames[worst.error] + " at " + text::significant(worst.angle_deg, 6) +
          " deg by " + text::significant(worst.bias_um_per_um, 3) + " um" +
          (angular ? " at " + text::significant(reference_length_mm, 6) + " mm" : "") +
          ". The stated uncertainties assume a perfect set-up: declare setup_std (" +
          instrument_info(instrument).setup_tolerance_keys +
          ") in the design for intervals that include it."};
}

namespace {

std::vector<Warning> residual_after_warnings(const DiagnoseResult& r) {
  std::vector<Warning> out;
  if (!r.significant_after || !r.after.p_value) return out;
  const double ratio = r.after.dof > 0 ? std::sqrt(r.after.chi2 / r.after.dof) : 0.0;
  if (r.noise_larger_than_declared) {
    out.push_back({"noise_scale",
                   "After the effects found, the residual is still " + text::significant(ratio, 2) +
                       " times the declared noise (" + chi2_text(r.after) +
                       ") and no check explains it: the noise may be larger than declared. The "
                       "corrected errors' uncertainties assume the declared noise; identify "
                       "--type-a states them from the scatter."});
  } else {
    out.push_back({"residual",
                   "After the effects found, the residual still contradicts the declared noise (" +
                       chi2_text(r.after) +
                       "): something outside the library remains (see the checks of the "
                       "residual), and the corrected errors' uncertainties do not cover it."});
  }
  return out;
}

// Set-up effects diagnose cannot detect that move an error by its stated uncertainty at a size
// below their threshold, without a declared tolerance (setup_risks, most dangerous first).
std::optional<Warning> setup_risk_warning(const std::vector<SetupRisk>& risks,
                                          InstrumentKind instrument) {
  std::vector<const SetupRisk*> undeclared;
  for (const SetupRisk& r : risks)
    if (r.declared_std_um <= 0) undeclared.push_back(&r);
  if (undeclared.empty()) return std::nullopt;
  const SetupRisk& r = *undeclared.front();
  const std::string unit = r.error < 3 ? " um" : " urad";
  return Warning{
      "setup_undeclared",
      std::to_string(undeclared.size()) + " set-up effect" + (undeclared.size() > 1 ? "s" : "") +
          " this design cannot detect move the corrected errors without a trace in the "
          "residual: " +
          r.label + " of " + text::significant(r.threshold_um, 3) + " um already moves " +
          kErrorNames[r.error] + " at " + text::significant(r.angle_deg, 6) +
          " deg by its stated uncertainty (" + text::significant(r.stated_std, 3) + unit +
          "). Declare setup_std (" + instrument_info(instrument).setup_tolerance_keys +
          ") in the design for intervals that include them."};
}

}  // namespace

std::vector<Warning> diagnose_warnings(const DiagnoseResult& r) {
  std::vector<Warning> out = residual_after_warnings(r);
  // Effects chosen by convention among equivalent ones: the readings fit each the same, and the
  // corrected errors differ between them; the attribution carries the difference when the
  // combinations could be refitted.
  const Attribution* convention = nullptr;
  for (const Attribution& at : r.attributions) {
    if (at.convention) convention = &at;
  }
  std::string chosen;  // "a (or b, c) and d (or e)"
  int n_chosen = 0;
  for (const AddedEffect& a : r.added) {
    if (a.equivalent_to.empty()) continue;
    std::string others;
    for (const std::string& e : a.equivalent_to) others += (others.empty() ? "" : ", ") + e;
    chosen += (n_chosen++ ? " and " : "") + a.block.label + " (or " + others + ")";
  }
  if (n_chosen > 0) {
    std::string consequence;
    if (convention) {
      const double um = *std::max_element(convention->largest_change.begin(),
                                          convention->largest_change.begin() + 3);
      const double urad = *std::max_element(convention->largest_change.begin() + 3,
                                            convention->largest_change.end());
      consequence =
          "the corrected errors and their ISO terms carry the difference in their uncertainties "
          "(the whole change as a standard uncertainty, up to " +
          // Changes below 1e-6 (rounding of an exact equivalence) are zero.
          text::significant(um < 1e-6 ? 0.0 : um, 3) + " um, " +
          text::significant(urad < 1e-6 ? 0.0 : urad, 3) + " urad" +
          (convention->untried > 0
               ? ", over the first 256 combinations; " + std::to_string(convention->untried) +
                     " more were not tried and may move them further"
               : std::string()) +
          "), so they may be too uncertain to enter or to decide. To remove it, measure " +
          instrument_info(r.instrument).item +
          " that tells them apart; dbbkit identify --effects fits each choice.";
    } else {
      consequence =
          "the corrected errors and their ISO terms depend on the choice, and their "
          "uncertainties leave the difference out. Before deciding conformance or entering a "
          "compensation, fit each with dbbkit identify --effects to see the difference, or "
          "measure " +
          std::string(instrument_info(r.instrument).item) + " that tells them apart.";
    }
    out.push_back({"equivalent_effects", chosen + (n_chosen == 1 ? " was" : " were") +
                                             " chosen by convention among effects the readings "
                                             "cannot tell apart: " +
                                             consequence});
  }
  if (auto w = setup_risk_warning(r.setup_risks, r.instrument)) out.push_back(*w);
  return out;
}

std::vector<Warning> identify_warnings(const Design& design, const IdentifyResult& result) {
  std::vector<Warning> out;
  if (auto w = residual_warning(result.estimate, result.budget.type_a_scale.has_value()))
    out.push_back(*w);
  if (auto w = first_order_warning(result.first_order)) out.push_back(*w);
  // Fitted effects the readings cannot tell from others of the library: the values hold for
  // the model as given, not for the effect the machine has.
  std::string chosen;
  int n_chosen = 0;
  std::array<double, 6> change{};
  for (const FittedEffect& f : result.effects) {
    if (f.equivalent_to.empty()) continue;
    std::string others;
    for (const std::string& e : f.equivalent_to) others += (others.empty() ? "" : ", ") + e;
    chosen += (n_chosen++ ? " and " : "") + f.label + " (or " + others + ")";
    for (int k = 0; k < 6; ++k) change[k] = std::max(change[k], f.largest_change[k]);
  }
  if (n_chosen > 0) {
    const double um = *std::max_element(change.begin(), change.begin() + 3);
    const double urad = *std::max_element(change.begin() + 3, change.end());
    out.push_back(
        {"equivalent_effects",
         "The readings fit " + chosen + " exactly as well: the errors and their uncertainties " +
             "hold for the effects as given, and move by up to " + text::significant(um, 3) +
             " um, " + text::significant(urad, 3) +
             " urad should one of the others take an effect's place (more should several). "
             "dbbkit diagnose carries the difference of every combination in its uncertainties; "
             "measure " +
             instrument_info(design.instrument).item + " that tells them apart to remove it."});
  }
  const double L = design.reference_length_mm.value_or(100.0);
  if (auto w = setup_undeclared_warning(
          hidden_setup_effects(design, result.param, result.model, *result.solver, L), L,
          design.instrument))
    out.push_back(*w);
  return out;
}

}  // namespace dbbkit
