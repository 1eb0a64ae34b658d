#include "dbbkit/diagnose.hpp"
#include "dbbkit/setup.hpp"

#include <Eigen/QR>
#include <boost/math/distributions/chi_squared.hpp>
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "dbbkit/kinematics.hpp"
#include "dbbkit/linear_model.hpp"
#include "dbbkit/parameterisation.hpp"

namespace dbbkit {

namespace {

std::string fmt(double x, int digits = 3) {
  std::ostringstream s;
  s << std::setprecision(digits) << x;
  return s.str();
}

}  // namespace

ResidualSignature residual_signature(const Design& design, const std::vector<Reading>& readings,
                                     const Eigen::VectorXd& r) {
  ResidualSignature sig;
  double best = -1;
  for (std::size_t i = 0; i < design.installations.size(); ++i) {
    ResidualSignature::Installation s;
    s.id = design.installations[i].id;
    s.L_mm = design.installations[i].L_mm;
    s.D_mm = design.installations[i].D_mm;
    s.H_mm = design.installations[i].H_mm;
    std::vector<int> rows;
    for (std::size_t j = 0; j < readings.size(); ++j) {
      if (readings[j].installation == s.id) rows.push_back(static_cast<int>(j));
    }
    s.n = static_cast<int>(rows.size());
    if (s.n == 0) continue;
    Eigen::VectorXd ri(s.n);
    for (int j = 0; j < s.n; ++j) ri(j) = r(rows[j]);
    s.mean_um = ri.mean();
    s.rms_um = std::sqrt(ri.squaredNorm() / s.n);
    auto consider = [&](double size, const std::string& what) {
      if (size > best) {
        best = size;
        sig.dominant = what;
      }
    };
    consider(std::abs(s.mean_um), "a mean residual of " + fmt(s.mean_um) + " um in installation " + s.id);
    if (design.axis == Axis::C) {
      // Distinct positions bound the harmonics that can be told apart: 2K + 1 <= positions.
      std::vector<double> positions;
      for (int j : rows) {
        const double a = readings[j].angle_deg;
        bool seen = false;
        for (double p : positions) seen = seen || same_position(Axis::C, p, a);
        if (!seen) positions.push_back(a);
      }
      const int K = std::min(4, (static_cast<int>(positions.size()) - 1) / 2);
      if (K >= 1) {
        Eigen::MatrixXd A(s.n, 2 * K + 1);
        for (int j = 0; j < s.n; ++j) A.row(j) = fourier_basis(K, readings[rows[j]].angle_deg).transpose();
        const Eigen::VectorXd coef = A.colPivHouseholderQr().solve(ri);
        for (int k = 1; k <= K; ++k) {
          s.harmonic_um.push_back(std::hypot(coef(2 * k - 1), coef(2 * k)));
          consider(s.harmonic_um.back(), "a " + std::to_string(k) + "-per-turn term of amplitude " +
                                             fmt(s.harmonic_um.back()) + " um in installation " + s.id);
        }
      }
    }
    double t_sum = 0, t2 = 0, tr = 0, t_min = 1e300, t_max = -1e300;
    int nt = 0;
    double cw_sum = 0, ccw_sum = 0;
    int ncw = 0, nccw = 0;
    for (int j = 0; j < s.n; ++j) {
      const Reading& rd = readings[rows[j]];
      if (rd.time_s) {
        const double t = *rd.time_s / 60.0;
        t_sum += t, t2 += t * t, tr += t * ri(j), ++nt;
        t_min = std::min(t_min, t), t_max = std::max(t_max, t);
      }
      if (rd.sweep) (*rd.sweep == Sweep::CW ? (cw_sum += ri(j), ++ncw) : (ccw_sum += ri(j), ++nccw));
    }
    if (nt == s.n && nt > 2 && t_max > t_min) {
      const double tm = t_sum / nt;
      s.slope_um_per_min = (tr - tm * ri.sum()) / (t2 - nt * tm * tm);
      consider(std::abs(*s.slope_um_per_min) * (t_max - t_min),
               "a drift of " + fmt(*s.slope_um_per_min) + " um/min in installation " + s.id);
    }
    if (ncw > 0 && nccw > 0) {
      s.cw_minus_ccw_um = cw_sum / ncw - ccw_sum / nccw;
      consider(std::abs(*s.cw_minus_ccw_um),
               "a difference cw - ccw of " + fmt(*s.cw_minus_ccw_um) + " um in installation " + s.id);
    }
    sig.installations.push_back(s);
  }
  return sig;
}

namespace {

// The set-up effects the final model [J, added effects] cannot detect (added_rank
// below their columns) and the bias each causes in the errors after, relative to
// their stated uncertainty.
std::vector<SetupRisk> setup_risks(const Design& design, const Parameterisation& param, const LinearModel& model,
                                   const Eigen::MatrixXd& J_final, const DiagnoseOptions& options,
                                   const std::vector<AddedEffect>& added, const std::vector<ErrorsAtAngle>& after) {
  std::vector<SetupRisk> out;
  const WlsSolver solver(J_final, model.sigma_um, options.estimate);
  const int p_ext = static_cast<int>(J_final.cols());
  for (const SetupEffect& e : setup_effects(design, model, false)) {
    bool in_model = false;
    for (const AddedEffect& a : added) in_model = in_model || a.block.label == e.label;
    if (in_model || added_rank(solver, e.X, options.estimate) == e.X.cols()) continue;
    const Eigen::MatrixXd GX = solver.gain() * e.X;
    SetupRisk worst;
    bool any = false;
    for (int s = 0; s < param.n_stations(); ++s) {
      const Eigen::MatrixXd C = error_functions(param, s, p_ext);
      for (int k = 0; k < 6; ++k) {
        const Determined& d = after[s].errors[k];
        if (!d.determined || !(d.std > 0)) continue;
        const double b = (C.col(k).transpose() * GX).norm();
        if (!(b > 1e-12)) continue;
        const double threshold = d.std / b;
        if (!any || threshold < worst.threshold_um) {
          any = true;
          worst.error = k;
          worst.angle_deg = after[s].angle_deg;
          worst.bias_per_um = b;
          worst.stated_std = d.std;
          worst.threshold_um = threshold;
        }
      }
    }
    if (!any) continue;
    worst.label = e.label;
    worst.declared_std_um = e.std_um;
    if (e.std_um > 0) {
      worst.at_declared = e.std_um * worst.bias_per_um;
      worst.exceeds = *worst.at_declared > worst.stated_std;
    }
    out.push_back(worst);
  }
  std::sort(out.begin(), out.end(), [](const SetupRisk& a, const SetupRisk& b) { return a.threshold_um < b.threshold_um; });
  return out;
}

std::string setup_risk_text(const Design& design, const std::vector<SetupRisk>& risks) {
  std::ostringstream v;
  const bool declared = design.setup_nuisance_declared();
  v << "But " << risks.size() << " set-up effect(s) cannot be detected by this design, and they move the errors "
    << "without leaving a residual";
  if (!declared) v << " (no set-up tolerance is declared: the stated uncertainties assume a perfect set-up)";
  v << ". The most dangerous:";
  const std::size_t shown = std::min<std::size_t>(3, risks.size());
  for (std::size_t i = 0; i < shown; ++i) {
    const SetupRisk& r = risks[i];
    v << (i ? ";" : "") << " " << r.label << " of " << fmt(r.threshold_um, 3) << " um moves " << kErrorNames[r.error]
      << " at " << fmt(r.angle_deg) << " deg by its standard uncertainty " << fmt(r.stated_std, 3) << " "
      << kErrorUnits[r.error] << " (" << fmt(r.bias_per_um, 3) << " " << kErrorUnits[r.error] << " per um)";
    if (r.at_declared) {
      v << ", at its declared " << fmt(r.declared_std_um, 3) << " um by " << fmt(*r.at_declared, 3) << " "
        << kErrorUnits[r.error];
    }
  }
  if (declared) {
    v << ". The errors here are stated for the readings' noise; identify and evaluate carry the declared set-up "
         "tolerances in their total uncertainties. Installations that make these effects detectable remove the "
         "doubt (evaluate lists them).";
  } else {
    v << ". Declare set-up tolerances (setup_std) to carry them in the uncertainties, or measure installations that "
         "make them detectable (evaluate lists them).";
  }
  return v.str();
}

}  // namespace

DiagnoseResult diagnose(const Design& design, const std::vector<Reading>& readings, const DiagnoseOptions& options) {
  DiagnoseResult res;
  res.level = options.level;
  const Parameterisation param(design);
  const LinearModel model = build_linear_model(design, param, readings);
  SelectionOptions so;
  so.level = options.level;
  so.max_effects = options.max_effects;
  so.estimate = options.estimate;
  Selection sel = select_effects(model.J, model.sigma_um, model.y_um, candidate_effects(design, readings), so);
  res.before = sel.before;
  res.errors_before = errors_at_stations(param, res.before);
  res.signature_before = residual_signature(design, readings, res.before.residual_um);
  res.significant_before = res.before.p_value && *res.before.p_value < options.level;
  const Estimate& current = sel.after;
  const Eigen::MatrixXd& J = sel.J_final;
  res.added = std::move(sel.added);
  res.structures = std::move(sel.structures);
  res.after = current;
  res.errors_after = errors_at_stations(param, current);
  {
    // Null space of the final model over the axis-error unknowns (effects are all determined when added).
    Estimate axis_only = current;
    const int p = param.n_parameters();
    axis_only.null_space_scaled = current.null_space_scaled.topRows(p);
    axis_only.column_scale = current.column_scale.head(p);
    axis_only.n_unknowns = p;
    res.unidentifiable_after = describe_null_space(design, param, axis_only);
  }
  res.signature_after = residual_signature(design, readings, current.residual_um);
  res.significant_after = current.p_value && *current.p_value < options.level;
  res.candidates = std::move(sel.candidates);

  res.setup_risks = setup_risks(design, param, model, J, options, res.added, res.errors_after);

  std::ostringstream v;
  auto chi = [](const Estimate& e) {
    std::ostringstream s;
    s << "chi2 " << fmt(e.chi2, 4) << " on " << e.dof << " dof, p ";
    if (e.p_value && *e.p_value < 1e-300) {
      s << "< 1e-300";
    } else if (e.p_value) {
      s << "= " << fmt(*e.p_value);
    } else {
      s << "undefined";
    }
    return s.str();
  };
  if (!res.before.p_value) {
    v << "The design leaves no redundant reading: nothing can be tested.";
  } else if (!res.significant_before && res.added.empty()) {
    v << "The residual is consistent with the declared noise (" << chi(res.before) << "): nothing to explain"
      << (res.setup_risks.empty() ? "." : " in the residual.");
  } else {
    v << "Before: " << chi(res.before) << ". ";
    if (res.added.empty()) {
      v << "No effect of the library is justified. ";
    } else {
      v << "Added:";
      for (const AddedEffect& a : res.added) v << " " << a.block.label;
      v << ". After: " << chi(res.after) << ". ";
      for (const AddedEffect& a : res.added) {
        if (!a.close_alternatives.empty()) {
          v << a.block.label << " was chosen over";
          for (const std::string& l : a.close_alternatives) v << " " << l;
          v << ", which fit almost as well: these readings cannot tell them apart reliably. ";
        }
        if (a.equivalent_to.empty()) continue;
        v << a.block.label << " is equivalent to";
        for (const std::string& l : a.equivalent_to) v << " " << l;
        v << ": the data determine only their difference, so it is attributed by convention to the later "
             "installation, and the errors after are conditional on that choice. ";
      }
    }
    for (const StructureComparison& c : res.structures) {
      auto list = [](const std::vector<std::string>& labels) {
        std::string out;
        for (const std::string& l : labels) out += (out.empty() ? "" : " ") + l;
        return out;
      };
      v << (c.chosen.size() == 1 ? "One " + c.kind + " for the whole test (" + list(c.chosen) + ")"
                                 : "A " + c.kind + " per installation (" + list(c.chosen) + ")")
        << " was preferred to "
        << (c.rejected.size() == 1 ? "one for the whole test (" + list(c.rejected) + ")"
                                   : "one per installation (" + list(c.rejected) + ")")
        << ": BIC " << fmt(c.bic_chosen, 6) << " against " << fmt(c.bic_rejected, 6) << ". ";
    }
    if (res.significant_after) {
      v << "A significant residual remains that no effect of the library explains; its largest feature is "
        << res.signature_after.dominant << ".";
    } else {
      v << "No significant residual remains.";
    }
  }
  if (res.after.dof > 0) {
    // The lower tail: a residual far smaller than the declared noise predicts.
    const double lower = boost::math::cdf(boost::math::chi_squared(res.after.dof), res.after.chi2);
    res.p_lower_after = lower;
    if (lower < options.level) {
      v << " The residual is smaller than the declared noise predicts (P(chi2 <= " << fmt(res.after.chi2, 4)
        << ") = " << fmt(lower) << "): the declared instrument accuracy overstates the scatter of these readings "
        << "(averaged readings?); the uncertainties stated from it are conservative, and a Type A evaluation "
        << "(identify --type-a) would state them from the data.";
    }
  }
  if (!res.setup_risks.empty()) v << " " << setup_risk_text(design, res.setup_risks);
  res.verdict = v.str();
  return res;
}

DetectionSettings diagnose_detection_settings(const std::vector<CandidateStatus>& candidates,
                                              const DiagnoseOptions& options) {
  DetectionSettings detection;
  detection.level = options.level;
  detection.n_tests = 0;
  for (const CandidateStatus& c : candidates) detection.n_tests += c.state == CandidateState::kDetectable;
  detection.n_tests = std::max(1, detection.n_tests);
  return detection;
}

std::vector<CandidateStatus> effect_detectability(const Design& design, const std::vector<Reading>& readings) {
  const Parameterisation param(design);
  const LinearModel model = build_linear_model(design, param, readings);
  const WlsSolver solver(model.J, model.sigma_um);
  std::vector<CandidateStatus> out;
  for (const EffectBlock& b : candidate_effects(design, readings)) {
    if (!b.not_applicable.empty()) {
      out.push_back({b.label, CandidateState::kNotApplicable, b.not_applicable});
      continue;
    }
    const int q = static_cast<int>(b.X.cols());
    const int added = added_rank(solver, b.X);
    if (added < q) {
      out.push_back({b.label, CandidateState::kConfounded,
                     "raises the rank by " + std::to_string(added) + " of " + std::to_string(q) +
                         ": indistinguishable from the axis errors of the " + design.errors.describe() + " model"});
    } else {
      out.push_back({b.label, CandidateState::kDetectable, ""});
    }
  }
  return out;
}

DesignAssessment assess_design(const Design& design, double reference_length_mm) {
  DesignAssessment a;
  a.effects = effect_detectability(design, nominal_readings(design));
  a.evaluation = evaluate_design(design, reference_length_mm, {}, diagnose_detection_settings(a.effects));
  return a;
}

}  // namespace dbbkit
