#include "dbbkit/diagnose.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <algorithm>
#include <boost/math/distributions/chi_squared.hpp>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "dbbkit/kinematics.hpp"
#include "dbbkit/linear_model.hpp"
#include "dbbkit/parameterisation.hpp"
#include "dbbkit/setup.hpp"
#include "tolerances.hpp"

namespace dbbkit {

namespace {

std::string fmt(double x, int digits = 3) {
  std::ostringstream s;
  s << std::setprecision(digits) << x;
  return s.str();
}

}  // namespace

const char* selection_stop_name(SelectionStop s) {
  switch (s) {
    case SelectionStop::kNone:
      return "none";
    case SelectionStop::kGrossReading:
      return "gross reading";
    case SelectionStop::kModelOrder:
      return "model order";
  }
  return "unknown";
}

ResidualSignature residual_signature(const Design& design, const std::vector<Reading>& readings,
                                     const Eigen::VectorXd& r) {
  ResidualSignature sig;
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
    if (design.axis == Axis::C) s.harmonic_um = residual_harmonics(readings, rows, r);
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
      if (rd.sweep)
        (*rd.sweep == Sweep::CW ? (cw_sum += ri(j), ++ncw) : (ccw_sum += ri(j), ++nccw));
    }
    if (nt == s.n && nt > 2 && t_max > t_min) {
      const double tm = t_sum / nt;
      s.slope_um_per_min = (tr - tm * ri.sum()) / (t2 - nt * tm * tm);
    }
    if (ncw > 0 && nccw > 0) {
      s.cw_minus_ccw_um = cw_sum / ncw - ccw_sum / nccw;
    }
    sig.installations.push_back(s);
  }
  return sig;
}

namespace {

// The set-up effects the final model [J, added effects] cannot detect (added_rank
// below their columns) and the bias each causes in the errors after, relative to
// their stated uncertainty.
std::vector<SetupRisk> setup_risks(const Design& design, const Parameterisation& param,
                                   const LinearModel& model, const WlsSolver& solver,
                                   const DiagnoseOptions& options,
                                   const std::vector<AddedEffect>& added,
                                   const std::vector<ErrorsAtAngle>& after) {
  std::vector<SetupRisk> out;
  const int p_ext = static_cast<int>(solver.J().cols());
  for (const SetupEffect& e : setup_effects(design, model, false)) {
    bool in_model = false;
    for (const AddedEffect& a : added) in_model = in_model || a.block.label == e.label;
    if (in_model || added_rank(solver, e.X, options.estimate) == e.X.cols()) continue;
    const Eigen::MatrixXd GX = solver.gain() * e.X;
    SetupRisk worst;
    bool any = false;
    for (int s = 0; s < param.n_stations(); ++s) {
      const Eigen::SparseMatrix<double> C = error_functions(param, s, p_ext);
      for (int k = 0; k < 6; ++k) {
        const Determined& d = after[s].errors[k];
        if (!d.determined || !(d.std > 0)) continue;
        const double b = (C.col(k).transpose() * GX).norm();
        if (!(b > tol::kSeenValue))
          continue;  // the effect moves this error by nothing but rounding
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
  std::sort(out.begin(), out.end(),
            [](const SetupRisk& a, const SetupRisk& b) { return a.threshold_um < b.threshold_um; });
  return out;
}

std::string setup_risk_text(const Design& design, const std::vector<SetupRisk>& risks) {
  std::ostringstream v;
  const bool declared = design.setup_nuisance_declared();
  v << "But " << risks.size()
    << " set-up effect(s) cannot be detected by this design, and they move the errors "
    << "without leaving a residual";
  if (!declared)
    v << " (no set-up tolerance is declared: the stated uncertainties assume a perfect set-up)";
  v << ". The most dangerous:";
  const std::size_t shown = std::min<std::size_t>(3, risks.size());
  for (std::size_t i = 0; i < shown; ++i) {
    const SetupRisk& r = risks[i];
    v << (i ? ";" : "") << " " << r.label << " of " << fmt(r.threshold_um, 3) << " um moves "
      << kErrorNames[r.error] << " at " << fmt(r.angle_deg) << " deg by its standard uncertainty "
      << fmt(r.stated_std, 3) << " " << kErrorUnits[r.error] << " (" << fmt(r.bias_per_um, 3) << " "
      << kErrorUnits[r.error] << " per um)";
    if (r.at_declared) {
      v << ", at its declared " << fmt(r.declared_std_um, 3) << " um by " << fmt(*r.at_declared, 3)
        << " " << kErrorUnits[r.error];
    }
  }
  if (declared) {
    v << ". The errors here are stated for the readings' noise; identify and evaluate carry the "
         "declared set-up "
         "tolerances in their total uncertainties. Installations that make these effects "
         "detectable remove the "
         "doubt (evaluate lists them).";
  } else {
    v << ". Declare set-up tolerances (setup_std) to carry them in the uncertainties, or measure "
         "installations that "
         "make them detectable (evaluate lists them).";
  }
  return v.str();
}

}  // namespace

namespace {

// The most significant feature (smallest p) in words, or empty.
std::string most_significant(const Design& design, const std::vector<Reading>& readings,
                             const std::vector<ResidualFeature>& features) {
  const ResidualFeature* top = nullptr;
  for (const ResidualFeature& f : features) {
    if (!top || more_significant(f.p, f.test.F, top->p, top->test.F)) top = &f;
  }
  return top ? describe_feature(design, readings, *top) : std::string();
}

std::string p_text(double p) { return p < 1e-300 ? "< 1e-300" : "= " + fmt(p); }

std::string reading_text(const Reading& r) {
  std::string s = "installation " + r.installation + " at " + fmt(r.angle_deg, 6) + " deg";
  if (r.sweep) s += *r.sweep == Sweep::CW ? " cw" : " ccw";
  if (r.time_s) s += ", t = " + fmt(*r.time_s, 6) + " s";
  if (r.line > 0) s += ", line " + std::to_string(r.line);
  return s;
}

// `solver`: the axis errors' model alone (diagnose's first step).
std::vector<DetectionLimit> detection_limits(const WlsSolver& solver,
                                             const std::vector<EffectBlock>& pool, int n_tests,
                                             const DiagnoseOptions& options) {
  std::vector<DetectionLimit> out;
  const Estimate& prior = solver.a_priori();
  DetectionSettings settings;
  settings.level = options.level;
  settings.n_tests = std::max(1, n_tests);
  for (const EffectBlock& b : pool) {
    if (!b.not_applicable.empty()) continue;
    const Eigen::MatrixXd R = unexplained(solver, b.X);
    const Eigen::VectorXd norms =
        (solver.sigma_um().cwiseInverse().asDiagonal() * b.X).colwise().norm().transpose();
    const int q = added_rank(R, norms, options.estimate);
    if (q < b.X.cols()) continue;  // confounded: no size would be found
    const double info =
        Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(R.transpose() * R).eigenvalues()(0);
    const int dof = static_cast<int>(solver.J().rows()) - prior.rank - q;
    out.push_back({b.label, b.unit, detection_limit_um(q, true, info, dof, settings)});
  }
  return out;
}

// "a + b" for a set of effects.
std::string joined(const std::vector<std::string>& labels) {
  std::string out;
  for (const std::string& l : labels) out += (out.empty() ? "" : " + ") + l;
  return out;
}

// The attribution uncertainty of the errors after (Attribution). Each added effect's
// alternatives that still fit almost as well in its place in the final model (close_in_final),
// and each substitution, are put in place of what they replace, one at a time. The largest change
// of each error at each position over one effect's (or substitution's) alternatives is its
// half-width; the half-widths combine in quadrature, u^2 += w^2 / 3.
std::vector<Attribution> attribute(const Parameterisation& param, const LinearModel& model,
                                   const std::vector<AddedEffect>& added,
                                   const std::vector<Substitution>& substitutions,
                                   const Estimate& after, std::vector<ErrorsAtAngle>& errors,
                                   const EstimateOptions& options) {
  std::vector<Attribution> out;
  if (after.dof < 1) return out;
  std::vector<std::array<double, 6>> w2(errors.size(), std::array<double, 6>{});
  // The errors with the added effects `out_labels` replaced by `in`; nullopt when that model
  // does not have the rank the swap should give.
  auto refit =
      [&](const std::vector<std::string>& out_labels,
          const std::vector<const EffectBlock*>& in) -> std::optional<std::vector<ErrorsAtAngle>> {
    std::vector<const Eigen::MatrixXd*> blocks;
    Eigen::Index cols = 0, removed = 0, inserted = 0;
    for (const AddedEffect& a : added) {
      if (std::find(out_labels.begin(), out_labels.end(), a.block.label) != out_labels.end()) {
        removed += a.block.X.cols();
        continue;
      }
      blocks.push_back(&a.block.X);
    }
    for (const EffectBlock* b : in) blocks.push_back(&b->X), inserted += b->X.cols();
    for (const Eigen::MatrixXd* X : blocks) cols += X->cols();
    Eigen::MatrixXd X(model.J.rows(), cols);
    Eigen::Index c = 0;
    for (const Eigen::MatrixXd* B : blocks) X.middleCols(c, B->cols()) = *B, c += B->cols();
    const Jacobian A = append_columns(model.J, X);
    const Estimate fit = WlsSolver(A, model.sigma_um, options).solve(model.y_um);
    if (fit.rank != after.rank - removed + inserted) return std::nullopt;
    return errors_at_stations(param, fit);
  };
  auto attribution = [&](const std::vector<std::string>& out_labels,
                         const std::vector<std::vector<const EffectBlock*>>& alternatives) {
    Attribution at;
    at.effect = joined(out_labels);
    std::vector<std::array<double, 6>> w(errors.size(), std::array<double, 6>{});
    for (const std::vector<const EffectBlock*>& in : alternatives) {
      const std::optional<std::vector<ErrorsAtAngle>> e = refit(out_labels, in);
      if (!e) continue;
      for (std::size_t s = 0; s < errors.size() && s < e->size(); ++s) {
        for (int k = 0; k < 6; ++k) {
          if (!errors[s].errors[k].determined || !(*e)[s].errors[k].determined) continue;
          const double d = std::abs((*e)[s].errors[k].value - errors[s].errors[k].value);
          w[s][k] = std::max(w[s][k], d);
          at.largest_change[k] = std::max(at.largest_change[k], d);
        }
      }
      std::vector<std::string> labels;
      for (const EffectBlock* b : in) labels.push_back(b->label);
      at.alternatives.push_back(joined(labels));
    }
    if (at.alternatives.empty()) return;
    for (std::size_t s = 0; s < errors.size(); ++s) {
      for (int k = 0; k < 6; ++k) w2[s][k] += w[s][k] * w[s][k];
    }
    out.push_back(std::move(at));
  };
  for (const AddedEffect& a : added) {
    std::vector<std::vector<const EffectBlock*>> alternatives;
    for (const EffectBlock& b : a.close_in_final) alternatives.push_back({&b});
    if (!alternatives.empty()) attribution({a.block.label}, alternatives);
  }
  for (const Substitution& s : substitutions) {
    std::vector<const EffectBlock*> in;
    for (const EffectBlock& b : s.by) in.push_back(&b);
    attribution(s.replaced, {in});
  }
  for (std::size_t s = 0; s < errors.size(); ++s) {
    for (int k = 0; k < 6; ++k) {
      Determined& d = errors[s].errors[k];
      if (d.determined) d.std = std::sqrt(d.std * d.std + w2[s][k] / 3.0);
    }
  }
  return out;
}

DiagnoseResult diagnose_once(const Design& design, const std::vector<Reading>& readings,
                             const DiagnoseOptions& options) {
  DiagnoseResult res;
  res.level = options.level;
  const Parameterisation param(design);
  const LinearModel model = build_linear_model(design, param, readings);
  SelectionOptions so;
  so.level = options.level;
  so.max_effects = options.max_effects;
  so.estimate = options.estimate;
  const std::vector<EffectBlock> pool = candidate_effects(design, readings);
  const std::vector<ScanFamily> families = scan_families(design, readings);
  Selection sel =
      select_effects(model.J, model.sigma_um, model.y_um, pool, families, design, readings, so);
  res.before = sel.before;
  res.errors_before = errors_at_stations(param, res.before);
  res.signature_before = residual_signature(design, readings, res.before.residual_um);
  res.significant_before = res.before.p_value && *res.before.p_value < options.level;
  const Estimate& current = sel.after;
  const Jacobian& J = sel.J_final;
  res.added = std::move(sel.added);
  res.structures = std::move(sel.structures);
  res.after = current;
  res.errors_after = errors_at_stations(param, current);
  res.substitutions = std::move(sel.substitutions);
  res.attributions = attribute(param, model, res.added, res.substitutions, current,
                               res.errors_after, options.estimate);
  {
    // Null space of the final model over the axis-error unknowns (effects are all determined when
    // added).
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

  // The final model [J, added effects], factorised once for the set-up risks and the checks.
  const WlsSolver final_solver(J, model.sigma_um, options.estimate);
  const Estimate final_fit = final_solver.solve(model.y_um);
  res.setup_risks =
      setup_risks(design, param, model, final_solver, options, res.added, res.errors_after);

  // Checks outside the library, each a test at the level.
  res.stopped_at_step =
      sel.stopped_at_reading >= 0 || sel.stopped_at_order ? sel.stopped_at_step : 0;
  res.stopped_because = sel.stopped_at_order          ? SelectionStop::kModelOrder
                        : sel.stopped_at_reading >= 0 ? SelectionStop::kGrossReading
                                                      : SelectionStop::kNone;
  const bool stopped_at_order = res.stopped_because == SelectionStop::kModelOrder;
  if (res.after.dof > 1) {
    res.gross = gross_readings(J, model.sigma_um, model.y_um, options.level, options.max_gross,
                               options.estimate);
    for (GrossReading& g : res.gross) g.reading = readings[static_cast<std::size_t>(g.row)];
    res.features_after =
        residual_features(design, readings, final_solver, final_fit, options.estimate);
    res.signature_after.dominant = most_significant(design, readings, res.features_after);
  }
  // The axis errors' model alone, factorised when a check needs it.
  std::optional<WlsSolver> first_solver;
  auto first = [&]() -> const WlsSolver& {
    if (!first_solver) first_solver.emplace(model.J, model.sigma_um, options.estimate);
    return *first_solver;
  };
  if (res.before.dof > 1 && res.significant_before) {
    res.features_before =
        residual_features(design, readings, first(), res.before, options.estimate);
    res.signature_before.dominant = most_significant(design, readings, res.features_before);
  }
  double feature_p = 1;
  for (const ResidualFeature& f : res.features_after) feature_p = std::min(feature_p, f.p);
  const double feature_p_all = std::min(
      1.0, feature_p * static_cast<double>(std::max<std::size_t>(1, res.features_after.size())));
  if (res.significant_after) {
    res.order = model_order_check(design, readings, final_solver, final_fit, options.estimate);
    res.noise = noise_scale(res.after.chi2, res.after.dof);
    const bool order_explains = res.order && res.order->p < options.level;
    res.noise_larger_than_declared =
        !(feature_p_all < options.level) && !order_explains && res.gross.empty();
  }
  // Detection limits, with the declared noise: only when that noise explains the residual.
  if (res.added.empty() && res.stopped_at_step == 0 && res.after.p_value &&
      !res.significant_after) {
    int tested = 0;
    for (const CandidateStatus& c : res.candidates) {
      tested += c.state != CandidateState::kConfounded && c.state != CandidateState::kNotApplicable;
    }
    res.detection_limits = detection_limits(first(), pool, tested + 1, options);
  }

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
    v << "The residual is consistent with the declared noise (" << chi(res.before)
      << "): nothing to explain" << (res.setup_risks.empty() ? "." : " in the residual.");
  } else {
    v << "Before: " << chi(res.before) << ". ";
    if (res.added.empty() && res.stopped_at_step > 0) {
      v << "No effect of the library was added before selection stopped. ";
    } else if (res.added.empty()) {
      v << "No effect of the library is justified. ";
    } else {
      // The change of the errors should the alternatives of `effect` be the true ones.
      auto attribution_sentence = [&](const std::string& effect) {
        for (const Attribution& at : res.attributions) {
          if (at.effect != effect) continue;
          const double um =
              *std::max_element(at.largest_change.begin(), at.largest_change.begin() + 3);
          const double urad =
              *std::max_element(at.largest_change.begin() + 3, at.largest_change.end());
          v << "The errors after carry the change should";
          for (std::size_t i = 0; i < at.alternatives.size(); ++i)
            v << (i ? " or " : " ") << at.alternatives[i];
          v << " be the true one (up to " << fmt(um) << " um, " << fmt(urad)
            << " urad) in their uncertainties (rectangular). ";
        }
      };
      v << "Added:";
      for (const AddedEffect& a : res.added) v << " " << a.block.label;
      v << ". After: " << chi(res.after) << ". ";
      for (const AddedEffect& a : res.added) {
        if (!a.close_alternatives.empty()) {
          v << a.block.label << " was chosen over";
          for (std::size_t i = 0; i < a.close_alternatives.size(); ++i)
            v << (i ? " or " : " ") << a.close_alternatives[i];
          v << ", which fit almost as well: these readings cannot tell them apart reliably. ";
          attribution_sentence(a.block.label);
        }
        if (a.equivalent_to.empty()) continue;
        v << a.block.label << " is equivalent to";
        for (const std::string& l : a.equivalent_to) v << " " << l;
        v << ": the data determine only their difference, so it is attributed by convention to the "
             "later "
             "installation, and the errors after are conditional on that choice. ";
      }
      for (const Substitution& sub : res.substitutions) {
        std::vector<std::string> by;
        for (const EffectBlock& b : sub.by) by.push_back(b.label);
        v << joined(by) << " in place of " << joined(sub.replaced) << " fit"
          << (by.size() == 1 ? "s" : "")
          << " almost as well: these readings cannot tell the two explanations apart reliably. ";
        attribution_sentence(joined(sub.replaced));
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
    if (res.stopped_at_step > 0 && stopped_at_order) {
      v << "Selection stopped at step " << res.stopped_at_step
        << ", where a higher order of the error model was the best candidate: no effect is added "
           "to explain part "
           "of a motion the model's order cannot follow. ";
    }
    if (res.stopped_at_step > 0 && !stopped_at_order && !res.gross.empty()) {
      v << "Selection stopped at step " << res.stopped_at_step
        << ", where one reading alone was the best candidate: no effect is added to explain part "
           "of it away. ";
    }
    if (!res.gross.empty()) {
      v << res.gross.size()
        << " gross reading(s), each tested alone against the rest (externally studentised "
        << "residual, Bonferroni over the readings):";
      for (std::size_t g = 0; g < res.gross.size(); ++g) {
        const GrossReading& gr = res.gross[g];
        v << (g ? ";" : "") << " " << reading_text(readings[gr.row]) << ", off by "
          << fmt(gr.value_um, 4) << " +- " << fmt(gr.std_um, 2) << " um (t = " << fmt(gr.t, 4)
          << ", p " << p_text(gr.p_scan) << " over " << gr.tested << " readings)";
      }
      v << ". Check them at the machine; dbbkit diagnose --exclude-gross refits without them and "
           "says so. ";
    }
    if (res.significant_after) {
      v << "A significant residual remains that no effect of the library explains";
      if (feature_p_all < options.level) {
        v << "; its most significant feature is " << res.signature_after.dominant << ". ";
      } else {
        v << ". ";
      }
      if (res.order && res.order->p < options.level) {
        const OrderCheck& o = *res.order;
        v << "The error model's order looks too low: order " << o.suggested << " instead of "
          << o.order << " explains " << fmt(o.test.delta_chi2, 4)
          << " of chi2 (F = " << fmt(o.test.F, 4) << ", p " << p_text(o.p) << " over " << o.tried
          << " orders); with it chi2 " << fmt(o.chi2_with, 4) << " on " << o.dof_with << " dof"
          << (o.p_value_with ? ", p " + p_text(*o.p_value_with) : std::string())
          << ". Set errors.order to " << o.suggested << " in the design. ";
      }
      if (res.noise_larger_than_declared && res.noise) {
        const NoiseScale& ns = *res.noise;
        v << "No feature of the residual stands out against its own scatter (the most significant, "
          << res.signature_after.dominant << ", has p " << p_text(feature_p_all) << " over "
          << res.features_after.size() << " features): the readings scatter " << fmt(ns.ratio, 3)
          << " times (95 % interval " << fmt(ns.low, 3) << " to " << fmt(ns.high, 3)
          << ") more than the declared noise, evenly. The declared accuracy looks too "
          << "small; identify --type-a states the uncertainties from the data's own scatter. ";
      }
    } else {
      v << "No significant residual remains.";
    }
  }
  if (res.after.dof > 0) {
    // The lower tail: a residual far smaller than the declared noise predicts.
    const double lower = chi2_lower_tail(res.after.dof, res.after.chi2);
    res.p_lower_after = lower;
    if (lower < options.level) {
      v << " The residual is smaller than the declared noise predicts (P(chi2 <= "
        << fmt(res.after.chi2, 4) << ") = " << fmt(lower)
        << "): the declared instrument accuracy overstates the scatter of these readings "
        << "(averaged readings?); the uncertainties stated from it are conservative, and a Type A "
           "evaluation "
        << "(identify --type-a) would state them from the data.";
    }
  }
  if (!res.setup_risks.empty()) {
    if (v.str().empty() || v.str().back() != ' ') v << " ";
    v << setup_risk_text(design, res.setup_risks);
  }
  if (!res.detection_limits.empty()) {
    // Per kind, the range over its candidates of the size found with power 0.9.
    v << " Nothing was added; with the declared noise, these would have been found with power 0.9 "
         "at this level:";
    std::vector<std::string> kinds;
    for (const DetectionLimit& d : res.detection_limits) {
      const std::string k = d.label.substr(0, d.label.find('['));
      if (std::find(kinds.begin(), kinds.end(), k) == kinds.end()) kinds.push_back(k);
    }
    bool first = true;
    for (const std::string& k : kinds) {
      double lo = 1e300, hi = 0;
      std::string lo_label, unit;
      for (const DetectionLimit& d : res.detection_limits) {
        if (d.label.substr(0, d.label.find('[')) != k || !d.limit) continue;
        if (*d.limit < lo) lo = *d.limit, lo_label = d.label;
        hi = std::max(hi, *d.limit), unit = d.unit;
      }
      if (lo_label.empty()) continue;
      v << (first ? " " : "; ") << k << " of " << fmt(lo, 2) << " " << unit
        << (hi > lo * 1.005 ? " (" + lo_label + ") to " + fmt(hi, 2) + " " + unit : std::string())
        << " or more";
      first = false;
    }
    v << " (every candidate in the JSON).";
  }
  res.verdict = v.str();
  return res;
}

}  // namespace

std::string describe_feature(const Design& design, const std::vector<Reading>& readings,
                             const ResidualFeature& f) {
  std::ostringstream s;
  const std::string inst =
      f.installation >= 0 ? design.installations[f.installation].id : std::string("all");
  auto pm = [&](const char* unit) { return fmt(f.value, 4) + " +- " + fmt(f.std, 2) + " " + unit; };
  switch (f.kind) {
    case FeatureKind::kMean:
      s << "a mean residual of " << pm("um") << " in installation " << inst;
      break;
    case FeatureKind::kHarmonic:
      s << "a " << f.harmonic << "-per-turn term of amplitude " << fmt(f.value, 4)
        << " um in installation " << inst;
      break;
    case FeatureKind::kDrift:
      s << "a drift of " << pm("um/min") << " in installation " << inst;
      break;
    case FeatureKind::kReversal:
      s << "a difference cw - ccw of " << pm("um") << " in installation " << inst;
      break;
    case FeatureKind::kStep:
      s << "a step of " << pm("um") << " in installation " << inst << " from the reading "
        << reading_text(readings[f.row]);
      break;
    case FeatureKind::kReading:
      s << "one reading off by " << pm("um") << ": " << reading_text(readings[f.row]);
      break;
  }
  s << " (F = " << fmt(f.test.F, 4) << ", p " << p_text(f.test.p);
  if (f.tested > 1)
    s << ", times " << f.tested
      << " positions scanned: " << p_text(f.p).substr(f.p < 1e-300 ? 0 : 2);
  s << ")";
  if (!f.difference_with.empty()) {
    s << "; only its difference from installation";
    for (int j : f.difference_with) s << " " << design.installations[j].id;
    s << " is determined";
  }
  return s.str();
}

DiagnoseResult diagnose(const Design& design, const std::vector<Reading>& readings,
                        const DiagnoseOptions& options) {
  DiagnoseResult res = diagnose_once(design, readings, options);
  if (!options.exclude_gross || res.gross.empty()) return res;
  // Refit without the gross readings, in passes (one may mask another), as asked.
  std::vector<int> kept(readings.size());
  for (std::size_t j = 0; j < kept.size(); ++j) kept[j] = static_cast<int>(j);
  std::vector<GrossReading> excluded;
  while (!res.gross.empty() && static_cast<int>(excluded.size()) < options.max_gross) {
    std::vector<int> drop;
    for (const GrossReading& g : res.gross) {
      if (static_cast<int>(excluded.size()) >= options.max_gross) break;
      GrossReading e = g;
      e.row = kept[static_cast<std::size_t>(g.row)];
      excluded.push_back(e);
      drop.push_back(g.row);
    }
    std::sort(drop.rbegin(), drop.rend());
    for (int r : drop) kept.erase(kept.begin() + r);
    std::vector<Reading> subset;
    for (int r : kept) subset.push_back(readings[static_cast<std::size_t>(r)]);
    res = diagnose_once(design, subset, options);
  }
  std::vector<int> rows;
  for (const GrossReading& g : excluded) rows.push_back(g.row);
  std::sort(rows.begin(), rows.end());
  res.excluded_rows = rows;
  res.excluded = excluded;
  std::ostringstream v;
  v << "Refit without " << excluded.size() << " gross reading(s), as asked (--exclude-gross):";
  for (std::size_t g = 0; g < excluded.size(); ++g) {
    v << (g ? ";" : "") << " " << reading_text(readings[static_cast<std::size_t>(excluded[g].row)])
      << ", off by " << fmt(excluded[g].value_um, 4) << " +- " << fmt(excluded[g].std_um, 2)
      << " um (t = " << fmt(excluded[g].t, 4) << ")";
  }
  v << ". " << res.verdict;
  res.verdict = v.str();
  // Rows of the gross readings still found (max_gross reached) refer to the readings given.
  for (GrossReading& g : res.gross) g.row = kept[static_cast<std::size_t>(g.row)];
  for (std::vector<ResidualFeature>* fs : {&res.features_before, &res.features_after}) {
    for (ResidualFeature& f : *fs) {
      if (f.row >= 0) f.row = kept[static_cast<std::size_t>(f.row)];
    }
  }
  return res;
}

DetectionSettings diagnose_detection_settings(const std::vector<CandidateStatus>& candidates,
                                              const DiagnoseOptions& options) {
  DetectionSettings detection;
  detection.level = options.level;
  detection.n_tests = 0;
  for (const CandidateStatus& c : candidates)
    detection.n_tests += c.state == CandidateState::kDetectable;
  detection.n_tests = std::max(1, detection.n_tests);
  return detection;
}

std::vector<CandidateStatus> effect_detectability(const Design& design,
                                                  const std::vector<Reading>& readings) {
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
                         ": indistinguishable from the axis errors of the " +
                         design.errors.describe() + " model"});
    } else {
      out.push_back({b.label, CandidateState::kDetectable, ""});
    }
  }
  return out;
}

DesignAssessment assess_design(const Design& design, double reference_length_mm) {
  DesignAssessment a;
  a.effects = effect_detectability(design, nominal_readings(design));
  a.evaluation =
      evaluate_design(design, reference_length_mm, {}, diagnose_detection_settings(a.effects));
  return a;
}

}  // namespace dbbkit
