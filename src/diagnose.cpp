#include "dbbkit/diagnose.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <algorithm>
#include <boost/math/distributions/chi_squared.hpp>
#include <cmath>
#include <limits>

#include "column_tester.hpp"
#include "dbbkit/kinematics.hpp"
#include "dbbkit/linear_model.hpp"
#include "dbbkit/parameterisation.hpp"
#include "dbbkit/setup.hpp"
#include "dbbkit/warnings.hpp"
#include "number_text.hpp"
#include "setup_solver.hpp"
#include "tolerances.hpp"
#include "wls_solver.hpp"

namespace dbbkit {

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
    if (design.axis.full_turn()) s.harmonic_um = residual_harmonics(readings, rows, r);
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
        (*rd.sweep == Sweep::kCW ? (cw_sum += ri(j), ++ncw) : (ccw_sum += ri(j), ++nccw));
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
                                   const std::vector<ErrorsAtAngle>& after,
                                   const std::vector<std::string>& declared) {
  std::vector<SetupRisk> out;
  const int p_ext = static_cast<int>(solver.J().cols());
  for (const SetupEffect& e : setup_effects(design, model, false)) {
    // A declared one is in the errors' uncertainty (fitted, or through its tolerance).
    if (std::find(declared.begin(), declared.end(), e.label) != declared.end()) continue;
    bool in_model = false;
    for (const AddedEffect& a : added) in_model = in_model || a.block.label == e.label;
    if (in_model ||
        added_rank(solver, e.J_reading_effect, options.estimate) == e.J_reading_effect.cols())
      continue;
    const Eigen::MatrixXd GX = solver.J_theta_reading() * e.J_reading_effect;
    SetupRisk worst;
    bool any = false;
    PlaceOfLargest place;  // of the smallest threshold (the largest b / std), ties to the first
    for (int s = 0; s < param.n_stations(); ++s) {
      const Eigen::SparseMatrix<double> C = error_functions(param, s, p_ext);
      for (int k = 0; k < 6; ++k) {
        const Determined& d = after[s].errors[k];
        if (!d.determined || !(d.std > 0)) continue;
        const double b = (C.col(k).transpose() * GX).norm();
        if (!(b > tol::kSeenValue))
          continue;  // the effect moves this error by nothing but rounding
        const double threshold = d.std / b;
        if (place.offer(b / d.std)) {
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
  std::stable_sort(out.begin(), out.end(), [](const SetupRisk& a, const SetupRisk& b) {
    return a.threshold_um < b.threshold_um;
  });
  return out;
}

// The most significant feature (smallest p), if any.
std::optional<ResidualFeature> most_significant(const std::vector<ResidualFeature>& features) {
  const ResidualFeature* top = nullptr;
  for (const ResidualFeature& f : features) {
    if (f.implausible()) continue;  // no machine or bar has it: not a feature of its own
    if (!top || more_significant(f.p, f.test.F, top->p, top->test.F)) top = &f;
  }
  return top ? std::optional<ResidualFeature>(*top) : std::nullopt;
}

// `solver`: the axis errors' model alone (diagnose's first step).
// `range_um`: the instrument's range (effect_reach_um).
std::vector<DetectionLimit> detection_limits(const WlsSolver& solver,
                                             const std::vector<EffectBlock>& pool, int n_tests,
                                             const DiagnoseOptions& options, double range_um,
                                             double max_drift_um_per_min) {
  std::vector<DetectionLimit> out;
  const Estimate& prior = solver.a_priori();
  DetectionSettings settings;
  settings.level = options.level;
  settings.n_tests = std::max(1, n_tests);
  for (const EffectBlock& b : pool) {
    if (!b.applicability.applicable()) continue;
    const Eigen::MatrixXd R = unexplained(solver, b.J_reading_effect);
    const Eigen::VectorXd norms =
        (solver.sigma_um().cwiseInverse().asDiagonal() * b.J_reading_effect)
            .colwise()
            .norm()
            .transpose();
    const int q = added_rank(R, norms, options.estimate);
    if (q < b.J_reading_effect.cols()) continue;  // confounded: no size would be found
    const double info =
        Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(R.transpose() * R).eigenvalues()(0);
    const int dof = static_cast<int>(solver.J().rows()) - prior.rank - q;
    DetectionLimit d{b.label, b.unit, detection_limit_um(q, true, info, dof, settings), {}, {}};
    if (d.limit) {
      // The smallest reach of an effect of this size: along the direction its limit is set in,
      // bounded below by one column's (exact for one column).
      Eigen::VectorXd v = Eigen::VectorXd::Zero(b.J_reading_effect.cols());
      double reach = std::numeric_limits<double>::infinity();
      for (Eigen::Index c = 0; c < v.size(); ++c) {
        v.setZero();
        v(c) = *d.limit;
        reach = std::min(reach, effect_reach_um(b.J_reading_effect, v));
      }
      if (reach > range_um) d.beyond_instrument_um = reach;
      if (const auto rate = drift_rate_um_per_min(
              b.effect, Eigen::VectorXd::Constant(b.J_reading_effect.cols(), *d.limit));
          rate && *rate > max_drift_um_per_min)
        d.beyond_drift_rate_um_per_min = *rate;
    }
    out.push_back(d);
  }
  return out;
}

using text::joined;

// The attribution uncertainty of the errors after (Attribution). Each added effect's
// alternatives that still fit almost as well in its place in the final model (close_in_final),
// each substitution, and the effects chosen by convention among equivalent ones (all of them
// together: every combination of their equivalents that fits exactly as well) are put in place of
// what they replace, one attribution at a time. The largest change w of each error at each position
// over one attribution's alternatives enters in quadrature. For a substitution or a close
// alternative, which the readings fit less well, as a rectangular half-width: u^2 += w^2 / 3. For
// the convention the readings cannot choose: the value is the chosen one or an alternative up to w
// away, and no distribution over those has a second moment about the chosen value above w^2:
// u^2 += w^2 (a rectangular share left the other choice outside the 95 % interval in 9 % of
// simulated cases).
// The ISO quantities of an estimate as one list (location, constant parts, components), for the
// attribution's share: their values, determined or not.
std::vector<Determined> iso_values(const IsoResult& iso) {
  std::vector<Determined> v;
  for (const IsoQuantity& q : iso.location) v.push_back(q.value);
  for (const IsoQuantity& q : iso.constants) v.push_back(q.value);
  for (const IsoComponentsAtAngle& a : iso.components)
    for (const Determined& m : a.motions) v.push_back(m);
  return v;
}

// Adds the attributions' variance (w2: the sum of their shares' variances) to each.
void add_iso_share(IsoResult& iso, const std::vector<double>& w2) {
  // The location errors' covariance takes the same share on its diagonal, so that it stays the
  // one their std come from.
  for (int k = 0; k < 5; ++k)
    if (iso.location[static_cast<std::size_t>(k)].value.determined)
      iso.location_covariance(k, k) += w2[static_cast<std::size_t>(k)];
  std::size_t i = 0;
  auto add = [&](Determined& d) {
    if (d.determined) d.std = std::sqrt(d.std * d.std + w2[i]);
    ++i;
  };
  for (IsoQuantity& q : iso.location) add(q.value);
  for (IsoQuantity& q : iso.constants) add(q.value);
  bool share = false;
  for (const double w : w2) share = share || w > 0;
  for (IsoComponentsAtAngle& a : iso.components) {
    for (Determined& m : a.motions) add(m);
    // A share on each std is not a covariance of the motions: none is stated.
    if (share) a.motion_covariance.reset(), a.errors_covariance.reset();
  }
}

// With `iso` (the ISO quantities of `after`), each alternative's ISO quantities are computed as
// well and the attribution's share added to theirs as to the errors'.
std::vector<Attribution> attribute(const Design& design, const Parameterisation& param,
                                   const LinearModel& model, const std::vector<AddedEffect>& added,
                                   const std::vector<Substitution>& substitutions,
                                   const std::vector<EffectBlock>& pool, const Estimate& after,
                                   std::vector<ErrorsAtAngle>& errors,
                                   const EstimateOptions& options, IsoResult* iso) {
  std::vector<Attribution> out;
  if (after.dof < 1) return out;
  std::vector<std::array<double, 6>> w2(errors.size(), std::array<double, 6>{});
  const std::vector<Determined> iso_base = iso ? iso_values(*iso) : std::vector<Determined>{};
  std::vector<double> iso_w2(iso_base.size(), 0.0);
  IsoMotionOptions no_motion;
  no_motion.enabled = false;
  no_motion.covariance = false;
  std::vector<Determined> iso_alternative;  // of the last refit
  bool exact = false;                       // refit: only alternatives that fit exactly as well
  // The errors with the added effects `out_labels` replaced by `in`; nullopt when that model
  // does not have the rank the swap should give.
  auto refit =
      [&](const std::vector<std::string>& out_labels,
          const std::vector<const EffectBlock*>& in) -> std::optional<std::vector<ErrorsAtAngle>> {
    std::vector<const Eigen::MatrixXd*> blocks;
    Eigen::Index cols = 0, removed = 0, inserted = 0;
    for (const AddedEffect& a : added) {
      if (std::find(out_labels.begin(), out_labels.end(), a.block.label) != out_labels.end()) {
        removed += a.block.J_reading_effect.cols();
        continue;
      }
      blocks.push_back(&a.block.J_reading_effect);
    }
    for (const EffectBlock* b : in)
      blocks.push_back(&b->J_reading_effect), inserted += b->J_reading_effect.cols();
    for (const Eigen::MatrixXd* X : blocks) cols += X->cols();
    Eigen::MatrixXd X(model.J.rows(), cols);
    Eigen::Index c = 0;
    for (const Eigen::MatrixXd* B : blocks) X.middleCols(c, B->cols()) = *B, c += B->cols();
    const Jacobian A = append_columns(model.J, X);
    const Estimate fit = WlsSolver(A, model.sigma_um, options).solve(model.y_um);
    if (fit.rank != after.rank - removed + inserted) return std::nullopt;
    // An equivalent combination fits exactly as well (to rounding); one that does not is no
    // alternative of the convention.
    if (exact && fit.chi2 > after.chi2 + 1e-6 * std::max(1.0, after.chi2)) return std::nullopt;
    if (iso) iso_alternative = iso_values(iso230_quantities(design, param, fit, 1.0, no_motion));
    return errors_at_stations(param, fit);
  };
  auto attribution = [&](const std::vector<std::string>& out_labels,
                         const std::vector<std::vector<const EffectBlock*>>& alternatives) {
    Attribution at;
    at.effect = joined(out_labels);
    at.convention = exact;
    std::vector<std::array<double, 6>> w(errors.size(), std::array<double, 6>{});
    std::vector<double> iso_w(iso_base.size(), 0.0);
    for (const std::vector<const EffectBlock*>& in : alternatives) {
      const std::optional<std::vector<ErrorsAtAngle>> e = refit(out_labels, in);
      if (!e) continue;
      for (std::size_t i = 0; i < iso_base.size() && i < iso_alternative.size(); ++i) {
        if (iso_base[i].determined && iso_alternative[i].determined)
          iso_w[i] = std::max(iso_w[i], std::abs(iso_alternative[i].value - iso_base[i].value));
      }
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
    at.iso_change = iso_w;
    const double share = exact ? 1.0 : 1.0 / 3.0;  // two-point bound or rectangular
    for (std::size_t s = 0; s < errors.size(); ++s) {
      for (int k = 0; k < 6; ++k) w2[s][k] += share * w[s][k] * w[s][k];
    }
    for (std::size_t i = 0; i < iso_w.size(); ++i) iso_w2[i] += share * iso_w[i] * iso_w[i];
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
  // The effects chosen by convention: each is kept or replaced by one of its equivalents, every
  // combination but the chosen one (at most kMaxCombinations, the first effects' first).
  {
    constexpr std::size_t kMaxCombinations = 256;
    std::vector<std::string> out_labels;
    std::vector<std::vector<const EffectBlock*>> options_of;  // [0]: the chosen effect
    for (const AddedEffect& a : added) {
      if (a.equivalent_to.empty()) continue;
      std::vector<const EffectBlock*> o{&a.block};
      for (const std::string& l : a.equivalent_to) {
        const auto it = std::find_if(pool.begin(), pool.end(),
                                     [&](const EffectBlock& b) { return b.label == l; });
        if (it != pool.end()) o.push_back(&*it);
      }
      if (o.size() < 2) continue;
      out_labels.push_back(a.block.label);
      options_of.push_back(std::move(o));
    }
    std::vector<std::vector<const EffectBlock*>> combinations;
    std::vector<std::size_t> pick(options_of.size(), 0);
    while (!options_of.empty() && combinations.size() < kMaxCombinations) {
      // The next combination (odometer order, the last effect fastest).
      std::size_t k = options_of.size();
      while (k > 0 && ++pick[k - 1] == options_of[k - 1].size()) pick[--k] = 0;
      if (k == 0) break;
      std::vector<const EffectBlock*> in;
      for (std::size_t e = 0; e < options_of.size(); ++e) in.push_back(options_of[e][pick[e]]);
      combinations.push_back(std::move(in));
    }
    if (!combinations.empty()) {
      double total = 1;
      for (const auto& o : options_of) total *= static_cast<double>(o.size());
      exact = true;
      attribution(out_labels, combinations);
      exact = false;
      if (!out.empty() && out.back().convention)
        out.back().untried = static_cast<std::size_t>(
            std::max(0.0, total - 1 - static_cast<double>(combinations.size())));
    }
  }
  for (std::size_t s = 0; s < errors.size(); ++s) {
    for (int k = 0; k < 6; ++k) {
      Determined& d = errors[s].errors[k];
      if (d.determined) d.std = std::sqrt(d.std * d.std + w2[s][k]);
    }
  }
  if (iso) add_iso_share(*iso, iso_w2);
  return out;
}

// The set-up effects with a declared tolerance (setup_effects) that are nuisance, and the base
// model diagnose seeks effects on: the axis errors' model with the columns of those the
// readings tell from it (each raising the rank by its number of columns, in the design's
// order), when what they read agrees with the tolerance: with beta their free estimate, C its
// noise covariance and P the declared variances, beta' (P + C)^-1 beta within chi2(q) at the
// level over the effects tested. One beyond its tolerance is no nuisance: it stays a candidate,
// to be found (a ball knocked, a bar not zeroed). Those the readings cannot tell are carried in
// the errors' uncertainties through their tolerance.
struct DeclaredSetUp {
  std::vector<SetupEffect> effects;  // nuisance: fitted or carried
  std::vector<bool> fitted;          // per effect: a column of the base model
  std::vector<SetupEffect> all;      // every declared one (beyond the tolerance too)
  LinearModel base;
  bool nuisance(const std::string& label) const {
    return std::any_of(effects.begin(), effects.end(),
                       [&](const SetupEffect& e) { return e.label == label; });
  }
  std::vector<std::string> all_labels() const {
    std::vector<std::string> l;
    for (const SetupEffect& e : all) l.push_back(e.label);
    return l;
  }
};

DeclaredSetUp declared_setup_base(const Design& design, const LinearModel& model,
                                  const DiagnoseOptions& options) {
  DeclaredSetUp d;
  d.base = model;
  d.all = setup_effects(design, model, true);
  if (d.all.empty()) return d;
  const double level = options.level / static_cast<double>(d.all.size());
  int base_rank = WlsSolver(d.base.J, d.base.sigma_um, options.estimate).a_priori().rank;
  for (const SetupEffect& e : d.all) {
    const int q = static_cast<int>(e.J_reading_effect.cols());
    const Jacobian with = append_columns(d.base.J, e.J_reading_effect);
    const WlsSolver solver(with, d.base.sigma_um, options.estimate);
    const bool tells = solver.a_priori().rank == base_rank + q;
    if (tells) {
      const Estimate fit = solver.solve(d.base.y_um);
      const Eigen::Index c0 = with.cols() - q;
      Eigen::MatrixXd S = Eigen::MatrixXd::Identity(q, q) * e.std_um * e.std_um;
      for (int a = 0; a < q; ++a)
        for (int b = 0; b < q; ++b) S(a, b) += fit.covariance_at(c0 + a, c0 + b);
      const Eigen::VectorXd beta = fit.theta.tail(q);
      const double T = beta.dot(S.ldlt().solve(beta));
      const boost::math::chi_squared chi2(q);
      if (T > boost::math::quantile(boost::math::complement(chi2, level))) continue;
      d.base.J = with;
      d.base.series = nullptr;
      base_rank += q;
    }
    d.fitted.push_back(tells);
    d.effects.push_back(e);
  }
  return d;
}

DiagnoseResult diagnose_once(const Design& design, const std::vector<Reading>& readings,
                             const DiagnoseOptions& options) {
  DiagnoseResult res;
  res.instrument = design.instrument;
  res.level = options.level;
  const Parameterisation param(design);
  const LinearModel model = build_linear_model(design, param, readings);
  SelectionOptions so;
  so.level = options.level;
  so.max_effects = options.max_effects;
  so.estimate = options.estimate;
  // The set-up effects whose tolerance the design declares are nuisance, as identify carries
  // them, not findings: those the readings tell from the axis errors are fitted with them (the
  // base model's columns), the others carried in the errors' uncertainties; none is a candidate.
  const DeclaredSetUp declared = declared_setup_base(design, model, options);
  const LinearModel& base = declared.base;
  std::vector<EffectBlock> pool;
  for (EffectBlock& b : candidate_effects(design, readings)) {
    if (!declared.nuisance(b.label)) pool.push_back(std::move(b));
  }
  const std::vector<ScanFamily> families = scan_families(design, readings);
  Selection sel =
      select_effects(base.J, base.sigma_um, base.y_um, pool, families, design, readings, so);
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
  res.iso_after = iso230_quantities(design, param, current, 1.0, options.iso_motion);
  const std::vector<ErrorsAtAngle> errors_plain = res.errors_after;
  const IsoResult iso_plain = res.iso_after;
  res.attributions = attribute(design, param, base, res.added, res.substitutions, pool, current,
                               res.errors_after, options.estimate, &res.iso_after);
  if (!declared.all.empty()) {
    // The errors before and after as identify states them (identify --effects with those
    // added): every declared set-up effect not added through its tolerance (SetupSolver), with
    // the attributions' share as the fit with the set-up fitted freely has it.
    auto budgeted = [&](const std::vector<const EffectBlock*>& blocks) {
      Jacobian A = model.J;
      std::vector<SetupEffect> carried;
      for (const SetupEffect& e : declared.all) {
        if (std::none_of(blocks.begin(), blocks.end(),
                         [&](const EffectBlock* b) { return b->label == e.label; }))
          carried.push_back(e);
      }
      for (const EffectBlock* b : blocks) A = append_columns(A, b->J_reading_effect);
      const WlsSolver solver(A, model.sigma_um, options.estimate);
      return SetupSolver(solver, carried).solve(model.y_um);
    };
    res.errors_before = errors_at_stations(param, budgeted({}));
    std::vector<const EffectBlock*> blocks;
    for (const AddedEffect& a : res.added) blocks.push_back(&a.block);
    const Estimate after = budgeted(blocks);
    std::vector<ErrorsAtAngle> errors = errors_at_stations(param, after);
    for (std::size_t st = 0; st < errors.size() && st < errors_plain.size(); ++st) {
      for (int k = 0; k < 6; ++k) {
        Determined& d = errors[st].errors[k];
        const double a = res.errors_after[st].errors[k].std, p = errors_plain[st].errors[k].std;
        if (d.determined) d.std = std::sqrt(d.std * d.std + std::max(0.0, a * a - p * p));
      }
    }
    res.errors_after = std::move(errors);
    IsoResult iso = iso230_quantities(design, param, after, 1.0, options.iso_motion);
    const std::vector<Determined> with_share = iso_values(res.iso_after),
                                  plain = iso_values(iso_plain);
    std::vector<double> w2(with_share.size(), 0.0);
    for (std::size_t i = 0; i < w2.size() && i < plain.size(); ++i)
      w2[i] = std::max(0.0, with_share[i].std * with_share[i].std - plain[i].std * plain[i].std);
    add_iso_share(iso, w2);
    res.iso_after = std::move(iso);
  }
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
  for (std::size_t e = 0; e < declared.effects.size(); ++e) {
    CandidateStatus c;
    c.label = declared.effects[e].label;
    c.state = CandidateState::kSetUp;
    c.reason = declared.fitted[e] ? CandidateReason::kSetUpFitted : CandidateReason::kSetUpCarried;
    c.columns = static_cast<int>(declared.effects[e].J_reading_effect.cols());
    c.note = text::significant(declared.effects[e].std_um, 3);
    res.candidates.push_back(c);
  }

  // The final model [J, added effects], factorised once for the set-up risks and the checks.
  const WlsSolver final_solver(J, model.sigma_um, options.estimate);
  const Estimate final_fit = final_solver.solve(model.y_um);
  res.setup_risks = setup_risks(design, param, model, final_solver, options, res.added,
                                res.errors_after, declared.all_labels());

  // Checks outside the library, each a test at the level.
  res.stopped_at_step =
      sel.stopped_at_reading >= 0 || sel.stopped_at_order ? sel.stopped_at_step : 0;
  res.stopped_because = sel.stopped_at_order          ? SelectionStop::kModelOrder
                        : sel.stopped_at_reading >= 0 ? SelectionStop::kGrossReading
                                                      : SelectionStop::kNone;
  if (res.after.dof > 1) {
    res.gross = gross_readings(J, model.sigma_um, model.y_um, options.level, options.max_gross,
                               options.estimate);
    for (GrossReading& g : res.gross) {
      g.reading = readings[static_cast<std::size_t>(g.row)];
      for (int j : g.indistinguishable)
        g.alternatives.push_back(readings[static_cast<std::size_t>(j)]);
    }
    res.features_after =
        residual_features(design, readings, final_solver, final_fit, options.estimate);
    res.signature_after.dominant = most_significant(res.features_after);
  }
  // The axis errors' model alone, factorised when a check needs it.
  std::optional<WlsSolver> first_solver;
  auto first = [&]() -> const WlsSolver& {
    if (!first_solver) first_solver.emplace(base.J, base.sigma_um, options.estimate);
    return *first_solver;
  };
  if (res.before.dof > 1 && res.significant_before) {
    res.features_before =
        residual_features(design, readings, first(), res.before, options.estimate);
    res.signature_before.dominant = most_significant(res.features_before);
  }
  double feature_p = 1;
  for (const ResidualFeature& f : res.features_after)
    if (!f.implausible()) feature_p = std::min(feature_p, f.p);
  res.features_p_all = std::min(
      1.0, feature_p * static_cast<double>(std::max<std::size_t>(1, res.features_after.size())));
  if (res.significant_after) {
    res.order = model_order_check(design, readings, final_solver, final_fit, options.estimate);
    res.noise = noise_scale(res.after.chi2, res.after.dof);
    const bool order_explains = res.order && res.order->p < options.level;
    res.noise_larger_than_declared =
        !(res.features_p_all < options.level) && !order_explains && res.gross.empty();
  }
  // Detection limits, with the declared noise: only when that noise explains the residual.
  if (res.added.empty() && res.stopped_at_step == 0 && res.after.p_value &&
      !res.significant_after) {
    int tested = 0;
    for (const CandidateStatus& c : res.candidates) {
      tested += c.state != CandidateState::kConfounded &&
                c.state != CandidateState::kNotApplicable && c.state != CandidateState::kSetUp;
    }
    res.detection_limits =
        detection_limits(first(), pool, tested + 1, options, 1e3 * design.instrument_range_mm,
                         design.max_drift_um_per_min);
  }

  if (res.after.dof > 0) res.p_lower_after = chi2_lower_tail(res.after.dof, res.after.chi2);
  for (int k = 0; k < 6; ++k) {
    for (std::size_t s = 0; s < res.errors_after.size(); ++s) {
      const Determined &a = res.errors_after[s].errors[k], &b = res.errors_before[s].errors[k];
      if (a.determined && b.determined) {
        res.largest_change_of_errors[k] =
            std::max(res.largest_change_of_errors[k].value_or(0.0), std::abs(a.value - b.value));
      }
    }
  }
  return res;
}

}  // namespace

DiagnoseResult diagnose(const Design& design, const std::vector<Reading>& readings,
                        const DiagnoseOptions& options) {
  DiagnoseResult res = diagnose_once(design, readings, options);
  res.warnings = diagnose_warnings(res);
  if (!options.exclude_gross || res.gross.empty()) return res;
  // Refit without the gross readings, in passes (one may mask another), as asked.
  std::vector<int> kept(readings.size());
  for (std::size_t j = 0; j < kept.size(); ++j) kept[j] = static_cast<int>(j);
  std::vector<GrossReading> excluded, not_excluded;
  // The rows of g (into the readings fitted) as rows of the readings given.
  auto to_given = [&](GrossReading g) {
    g.row = kept[static_cast<std::size_t>(g.row)];
    for (int& j : g.indistinguishable) j = kept[static_cast<std::size_t>(j)];
    return g;
  };
  while (!res.gross.empty() && static_cast<int>(excluded.size()) < options.max_gross) {
    std::vector<int> drop;
    not_excluded.clear();  // those of the last pass
    for (const GrossReading& g : res.gross) {
      if (static_cast<int>(excluded.size()) >= options.max_gross) break;
      if (!g.indistinguishable.empty()) {  // which reading is gross is not known: none goes
        not_excluded.push_back(to_given(g));
        continue;
      }
      excluded.push_back(to_given(g));
      drop.push_back(g.row);
    }
    if (drop.empty()) break;
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
  res.not_excluded = not_excluded;

  // Rows of the gross readings still found (max_gross reached, or left in) refer to the
  // readings given.
  for (GrossReading& g : res.gross) g = to_given(g);
  auto feature_to_given = [&](ResidualFeature& f) {
    if (f.row >= 0) f.row = kept[static_cast<std::size_t>(f.row)];
    for (int& j : f.indistinguishable) j = kept[static_cast<std::size_t>(j)];
  };
  for (std::vector<ResidualFeature>* fs : {&res.features_before, &res.features_after}) {
    for (ResidualFeature& f : *fs) feature_to_given(f);
  }
  for (ResidualSignature* s : {&res.signature_before, &res.signature_after}) {
    if (s->dominant) feature_to_given(*s->dominant);
  }
  res.warnings = diagnose_warnings(res);
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
    if (!b.applicability.applicable()) {
      CandidateStatus c;
      c.label = b.label;
      c.state = CandidateState::kNotApplicable;
      c.reason = CandidateReason::kNotApplicable;
      c.applicability = b.applicability;
      out.push_back(c);
      continue;
    }
    const int q = static_cast<int>(b.J_reading_effect.cols());
    const int added = added_rank(solver, b.J_reading_effect);
    CandidateStatus c;
    c.label = b.label;
    c.columns = q;
    c.added_rank = added;
    if (added < q) {
      c.state = CandidateState::kConfounded;
      c.reason = CandidateReason::kRankShortOfModel;
      c.note = design.errors.describe();
    } else {
      c.state = CandidateState::kDetectable;
      c.reason = CandidateReason::kFullRank;
    }
    out.push_back(c);
  }
  return out;
}

DesignAssessment assess_design(const Design& design, double reference_length_mm) {
  DesignAssessment a;
  a.effects = effect_detectability(design, nominal_readings(design));
  a.evaluation =
      evaluate_design(design, reference_length_mm, {}, diagnose_detection_settings(a.effects));
  // Without declared tolerances, the figure with typical ones says what the noise-only one
  // leaves out.
  {
    const std::optional<WorstCase> w = typical_setup_worst(design, reference_length_mm);
    if (w) {
      a.evaluation.worst_total_typical = w;
      const std::optional<double>& noise = a.evaluation.worst.worst_determined_std_um;
      for (Warning& warning : a.evaluation.warnings) {
        if (warning.kind != "setup_undeclared") continue;
        warning.text += " With typical tolerances (length offset " +
                        text::significant(kTypicalLengthOffsetStd_um, 3) + " um, centring " +
                        text::significant(kTypicalCentringStd_um, 3) +
                        " um per installation) the worst standard uncertainty would be " +
                        text::significant(*w->worst_determined_std_um, 3) + " um" +
                        (noise ? " instead of " + text::significant(*noise, 3) + " um" : "") + ".";
      }
    }
  }
  return a;
}

}  // namespace dbbkit
