#include "dbbkit/selection.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include "column_tester.hpp"
#include "dbbkit/effects.hpp"
#include "dbbkit/instrument.hpp"
#include "dbbkit/residual_checks.hpp"
#include "wls_solver.hpp"

namespace dbbkit {

namespace {

// An exchange replaces an added effect when the model with the other candidate in its place has
// chi2_new < chi2 (1 - kExchangeGain): a fall of rounding size is not a better explanation.
constexpr double kExchangeGain = 1e-9;
// Two candidates explain the data alike (a tie, broken by the latest installation) when their
// chi2 falls d1, d2 satisfy |d1 - d2| <= kTie (1 + |d1|).
constexpr double kTie = 1e-9;
// The golden-section search of a warm-up's time constant stops when its bracket in ln(tau) is
// narrower than kLogTauBracket.
constexpr double kLogTauBracket = 1e-6;

// A scanned effect's position (effects.hpp, EffectPosition): a time among its installation's
// readings, scanned by splitting them (a step), or a time constant on a grid, refined (a warm-up).
bool splits_readings(const EffectCandidate& e) {
  return effect_info(e.kind).position == EffectPosition::kTime;
}
bool has_time_constant(const EffectCandidate& e) {
  return effect_info(e.kind).position == EffectPosition::kTimeConstant;
}

CandidateStatus status(const std::string& label, CandidateState state, CandidateReason reason) {
  CandidateStatus s;
  s.label = label;
  s.state = state;
  s.reason = reason;
  return s;
}

CandidateStatus not_applicable(const std::string& label, const Applicability& why) {
  CandidateStatus s =
      status(label, CandidateState::kNotApplicable, CandidateReason::kNotApplicable);
  s.applicability = why;
  return s;
}

// Of candidates appended to one model, the one whose columns lower chi2 most, raising the rank
// by their number; of candidates that explain the data alike (a tie, kTie: equivalent ones), the
// latest installation's, as in forward().
struct BestAppended {
  std::optional<EffectBlock> block;
  ColumnTest test;
  void consider(const EffectBlock& b, const ColumnTest& t) {
    if (t.added_rank < b.J_reading_effect.cols()) return;
    if (block) {
      const double d = t.delta_chi2 - test.delta_chi2;
      const bool tie = std::abs(d) <= kTie * (1.0 + std::abs(t.delta_chi2));
      if (tie ? b.effect.installation <= block->effect.installation : d < 0) return;
    }
    block = b, test = t;
  }
};

class Selector {
 public:
  Selector(const Jacobian& J, const Eigen::VectorXd& sigma, const Eigen::VectorXd& y,
           const std::vector<EffectBlock>& pool, const SelectionOptions& o,
           const std::vector<ScanFamily>& families = {}, const Design* design = nullptr,
           const std::vector<Reading>* readings = nullptr)
      : J0_(J),
        sigma_(sigma),
        y_(y),
        pool_(pool),
        o_(o),
        used_(pool.size(), false),
        status_(pool.size()),
        families_(families),
        design_(design),
        readings_(readings),
        family_used_(families.size(), false),
        family_status_(families.size()) {
    if (design_) range_um_ = 1e3 * design_->instrument_range_mm;
  }

  Selection run() {
    Selection res;
    J_ = J0_;
    current_ = solve(J_);
    res.before = current_;
    for (std::size_t i = 0; i < pool_.size(); ++i) {
      status_[i].label = pool_[i].label;
      if (!pool_[i].applicability.applicable()) {
        status_[i] = not_applicable(pool_[i].label, pool_[i].applicability);
        used_[i] = true;
      }
    }
    for (std::size_t f = 0; f < families_.size(); ++f) {
      family_status_[f].label = families_[f].label;
      if (!families_[f].applicability.applicable()) {
        family_status_[f] = not_applicable(families_[f].label, families_[f].applicability);
        family_used_[f] = true;
      }
    }
    if (o_.stop_at_model_order && design_ && readings_)
      higher_ = higher_order_columns(*design_, *readings_);
    all_rows_.resize(static_cast<std::size_t>(y_.size()));
    for (std::size_t i = 0; i < all_rows_.size(); ++i) all_rows_[i] = static_cast<int>(i);
    for (bool changed = true; changed;) {
      forward();
      if (stopped_at_reading_ >= 0 || stopped_at_order_) break;
      changed = exchange() || backward() || drop_implausible();
    }
    compare_structures();
    final_alternatives();
    final_substitutions();
    final_evidence();
    res.after = current_;
    res.added = added_;
    res.substitutions = substitutions_;
    res.candidates = status_;
    res.candidates.insert(res.candidates.end(), family_status_.begin(), family_status_.end());
    res.structures = structures_;
    res.J_final = J_;
    res.stopped_at_reading = stopped_at_reading_;
    res.stopped_at_order = stopped_at_order_;
    res.stopped_at_step = stopped_at_step_;
    res.gross = gross_;
    return res;
  }

 private:
  Estimate solve(const Jacobian& J) const { return WlsSolver(J, sigma_, o_.estimate).solve(y_); }

  // Whether `block`, fitted in `fit` (its columns last), is an effect no machine or bar can
  // have (the status that says so): a drift or a warm-up faster than the design's
  // max_drift_um_per_min (drift_rate_um_per_min), or any effect that alone moves the bar beyond
  // the instrument's range in these readings (effect_reach_um).
  std::optional<CandidateStatus> implausible(const EffectBlock& block, const Estimate& fit,
                                             const std::string& label) const {
    const Eigen::Index q = block.J_reading_effect.cols();
    return implausible(block, values_at(fit, fit.n_unknowns - q, q), label);
  }
  // `q` fitted values of `fit` from column `first` on.
  static Eigen::VectorXd values_at(const Estimate& fit, Eigen::Index first, Eigen::Index q) {
    Eigen::VectorXd value(q);
    for (Eigen::Index j = 0; j < q; ++j) {
      Eigen::VectorXd unit = Eigen::VectorXd::Zero(fit.n_unknowns);
      unit(first + j) = 1.0;
      value(j) = fit.evaluate(unit).value;
    }
    return value;
  }
  std::optional<CandidateStatus> implausible(const EffectBlock& block, const Eigen::VectorXd& value,
                                             const std::string& label) const {
    if (!design_) return std::nullopt;
    std::optional<CandidateStatus> c;
    if (const auto rate = drift_rate_um_per_min(block.effect, value);
        rate && !(*rate <= design_->max_drift_um_per_min)) {
      c = status(label, CandidateState::kImplausible, CandidateReason::kBeyondDriftRate);
      c->implied_um_per_min = *rate;
      c->level = design_->max_drift_um_per_min;
    } else if (const double size = effect_reach_um(block.J_reading_effect, value);
               range_um_ > 0 && !(size <= range_um_)) {
      c = status(label, CandidateState::kImplausible, CandidateReason::kBeyondInstrument);
      c->implied_um = size;
      c->level = range_um_;
    }
    if (c) c->step = step_;
    return c;
  }
  int rank_of(const Jacobian& J) const { return WlsSolver(J, sigma_, o_.estimate).a_priori().rank; }

  // [J0, the added effects' columns], leaving out added effect `skip`.
  Jacobian model_without(int skip) const { return model_without(std::vector<int>{skip}); }
  // [J0, the added effects' columns], leaving out the added effects `skip`.
  Jacobian model_without(const std::vector<int>& skip) const {
    Jacobian J = J0_;
    for (std::size_t b = 0; b < added_.size(); ++b) {
      if (std::find(skip.begin(), skip.end(), static_cast<int>(b)) == skip.end())
        J = append_columns(J, added_[b].block.J_reading_effect);
    }
    return J;
  }
  void rebuild() { J_ = model_without(-1); }

  int index_of(const std::string& label) const {
    for (std::size_t i = 0; i < pool_.size(); ++i) {
      if (pool_[i].label == label) return static_cast<int>(i);
    }
    return -1;
  }

  // Candidates equivalent to pool candidate `best` on the model `base` (which does not hold it):
  // each spans the other modulo the model, so only their difference is determined. By the
  // declared convention the latest installation's is chosen; returns it and the others.
  std::pair<int, std::vector<int>> equivalents(int best, const Jacobian& base) const {
    std::vector<int> equivalent;
    const WlsSolver with_best(append_columns(base, pool_[best].J_reading_effect), sigma_,
                              o_.estimate);
    for (std::size_t i = 0; i < pool_.size(); ++i) {
      if (used_[i] || static_cast<int>(i) == best ||
          status_[i].state == CandidateState::kConfounded)
        continue;
      if (pool_[i].J_reading_effect.cols() != pool_[best].J_reading_effect.cols()) continue;
      if (added_rank(with_best, pool_[i].J_reading_effect, o_.estimate) == 0)
        equivalent.push_back(static_cast<int>(i));
    }
    int chosen = best;
    for (int i : equivalent) {
      if (pool_[i].effect.installation > pool_[chosen].effect.installation) chosen = i;
    }
    if (chosen != best) {
      equivalent.erase(std::find(equivalent.begin(), equivalent.end(), chosen));
      equivalent.push_back(best);
    }
    return {chosen, equivalent};
  }

  // Pool candidates `equivalent` to the added effect `a` (pool index `chosen`) leave the pool.
  void mark_equivalent(AddedEffect& a, int chosen, const std::vector<int>& equivalent) {
    a.equivalent_to.clear();
    for (int i : equivalent) {
      a.equivalent_to.push_back(pool_[i].label);
      used_[i] = true;
      status_[i] =
          status(pool_[i].label, CandidateState::kEquivalent, CandidateReason::kEquivalent);
      status_[i].other = pool_[chosen].label;
      // Which of the two carries it: of one installation (a sphere's components), the one found
      // first; else the later sphere of a sphere's effect, or the later row carrier (a ball bar's
      // installation, a probe's channel).
      if (pool_[i].effect.installation == pool_[chosen].effect.installation)
        status_[i].note = "the component found first";
      else if (design_)
        status_[i].note =
            std::string("the later ") + (effect_info(pool_[i].effect.kind).per_sphere
                                             ? "sphere"
                                             : instrument_info(design_->instrument).row_carrier);
    }
  }

  // An added effect leaves the model: the candidates equivalent to it return to the pool.
  void release_equivalents(const AddedEffect& a) {
    for (const std::string& l : a.equivalent_to) {
      const int i = index_of(l);
      if (i < 0) continue;
      used_[i] = false;
      status_[i] = status(l, CandidateState::kNotSignificant, CandidateReason::kReleased);
      status_[i].other = a.block.label;
    }
  }

  void forward() {
    while (static_cast<int>(added_.size()) < o_.max_effects) {
      ++step_;
      int best = -1, tested = 0;
      Estimate best_est;
      std::vector<double> trial_chi2(pool_.size(), -1.0);
      double best_p = 2, best_F = 0;
      // The current model factorised once: every candidate and scan is a column test on it.
      const WlsSolver solver(J_, sigma_, o_.estimate);
      const ColumnTester tester(solver, current_, o_.estimate);
      for (std::size_t i = 0; i < pool_.size(); ++i) {
        if (used_[i]) continue;
        const int q = static_cast<int>(pool_[i].J_reading_effect.cols());
        const ColumnTest trial = tester.test(pool_[i].J_reading_effect);
        if (trial.added_rank < q) {
          status_[i] =
              status(pool_[i].label, CandidateState::kConfounded, CandidateReason::kRankShort);
          status_[i].columns = q;
          status_[i].added_rank = trial.added_rank;
          status_[i].with_added = !added_.empty();
          continue;
        }
        if (trial.dof <= 0) {
          status_[i] =
              status(pool_[i].label, CandidateState::kNotSignificant, CandidateReason::kNoDof);
          continue;
        }
        ++tested;
        trial_chi2[i] = current_.chi2 - trial.delta_chi2;
        status_[i] =
            status(pool_[i].label, CandidateState::kNotSignificant, CandidateReason::kTested);
        status_[i].F = trial.F;
        status_[i].p = trial.p;
        // Ties within kSignificanceTie (the x and z scales of a symmetric design) go to the
        // first in the pool's order, not to rounding.
        if (more_significant(trial.p, trial.F, best_p, best_F))
          best = static_cast<int>(i), best_p = trial.p, best_F = trial.F;
      }
      // Scanned candidates: the best alternative of each, p multiplied by the alternatives tested.
      int best_family = -1, best_alt = -1, best_scanned = 0;
      if (!families_.empty()) {
        for (std::size_t f = 0; f < families_.size(); ++f) {
          if (family_used_[f]) continue;
          const ScanFamily& fam = families_[f];
          ScanTest st;
          if (splits_readings(fam.effect)) {
            st = tester.scan_steps(fam.rows, fam.min_segment);
          } else {
            for (std::size_t k = 0; k < fam.alternatives.size(); ++k) {
              st.consider(static_cast<int>(k), tester.test(fam.alternatives[k].J_reading_effect));
            }
          }
          if (st.best < 0) {
            family_status_[f] =
                status(fam.label, CandidateState::kConfounded, CandidateReason::kScanRankShort);
            continue;
          }
          ++tested;
          CandidateStatus& fs = family_status_[f];
          fs = status(fam.label, CandidateState::kNotSignificant, CandidateReason::kScanTested);
          fs.other = fam.alternative(*design_, *readings_, st.best).label;
          fs.F = st.test.F;
          fs.p = st.test.p;
          fs.scanned = st.tested;
          fs.p_scan = st.p_scan;
          if (st.p_scan < best_p ||
              (best_family >= 0 && more_significant(st.p_scan, st.test.F, best_p, best_F))) {
            best = -1, best_family = static_cast<int>(f), best_alt = st.best, best_p = st.p_scan,
            best_F = st.test.F;
            best_scanned = st.tested;
          }
        }
      }
      if (o_.stop_at_gross_reading) {
        // One reading on its own, counted as one more candidate of the step.
        const ScanTest g = tester.scan_readings(all_rows_);
        if (g.best >= 0) {
          ++tested;
          if (g.p_scan < best_p && g.p_scan < o_.level / tested) {
            stopped_at_reading_ = g.best;
            stopped_at_step_ = step_;
            gross_ = g;
            return;
          }
        }
      }
      if (!higher_.empty()) {
        // A higher order of the error model, counted as one more candidate of the step.
        const std::optional<OrderCheck> order =
            model_order_check(design_->errors.order, higher_, tester, current_);
        if (order) {
          ++tested;
          if (order->p < best_p && order->p < o_.level / tested) {
            stopped_at_order_ = order;
            stopped_at_step_ = step_;
            return;
          }
        }
      }
      if (best_family >= 0) {
        if (!add_scanned(best_family, best_alt, best_p, best_F, best_scanned, tested, trial_chi2))
          return;
        continue;  // added, or left out as implausible: the next step
      }
      if (best < 0) return;
      best_est = solve(append_columns(J_, pool_[best].J_reading_effect));
      const double threshold = o_.level / tested;
      const double dbic = bic(best_est) - bic(current_);
      if (!(best_p < threshold && dbic < 0)) {
        status_[best].missed = StepMiss{step_, threshold, dbic, false};
        return;
      }
      // Equivalent alternatives: each spans the other modulo the current model.
      const auto [chosen, equivalent] = equivalents(best, J_);
      if (chosen != best)
        best_est = solve(append_columns(J_, pool_[chosen].J_reading_effect)), best = chosen;
      if (auto c = implausible(pool_[best], best_est, pool_[best].label)) {
        // Significant at a size no machine or bar has: not a finding; the step again without it.
        status_[best] = *c;
        used_[best] = true;
        --step_;
        continue;
      }
      AddedEffect a;
      a.block = pool_[best];
      for (std::size_t i = 0; i < pool_.size(); ++i) {
        if (static_cast<int>(i) == best || trial_chi2[i] < 0 ||
            pool_[i].J_reading_effect.cols() != pool_[best].J_reading_effect.cols())
          continue;
        if (std::find(equivalent.begin(), equivalent.end(), static_cast<int>(i)) !=
            equivalent.end())
          continue;
        if (fits_almost_as_well(trial_chi2[i], best_est)) {
          a.close_alternatives.push_back(pool_[i].label);
        }
      }
      mark_equivalent(a, best, equivalent);
      a.evidence = {step_,        best_F, static_cast<int>(pool_[best].J_reading_effect.cols()),
                    best_est.dof, best_p, threshold,
                    tested,       dbic,   current_.chi2,
                    best_est.chi2};
      added_.push_back(a);
      used_[best] = true;
      status_[best] = status(pool_[best].label, CandidateState::kAdded, CandidateReason::kAdded);
      status_[best].step = step_;
      status_[best].F = best_F;
      status_[best].p = best_p;
      status_[best].threshold = threshold;
      status_[best].bic_change = dbic;
      J_ = append_columns(J_, pool_[best].J_reading_effect);
      current_ = best_est;
    }
  }

  // Adds alternative k of scanned family f when it passes (p < level / tested and the BIC,
  // with the position counted, falls). True when added, or when it passes at a size no machine
  // or bar has (the family is then left out and the step tried again without it).
  bool add_scanned(int f, int k, double p, double F, int scanned, int tested,
                   const std::vector<double>& trial_chi2) {
    const ScanFamily& fam = families_[f];
    EffectBlock block = fam.alternative(*design_, *readings_, k);
    const Estimate trial = solve(append_columns(J_, block.J_reading_effect));
    const double threshold = o_.level / tested;
    const double dbic =
        bic(trial) - bic(current_) + std::log(static_cast<double>(current_.n_readings));
    if (!(p < threshold && dbic < 0)) {
      family_status_[f].missed = StepMiss{step_, threshold, dbic, true};
      return false;
    }
    // Significant at a size or rate no machine or bar has: the family left out, the step again.
    auto left_out = [&](const Estimate& fit) {
      auto c = implausible(block, fit, fam.label);
      if (c) {
        family_status_[f] = *c;
        family_status_[f].other = block.label;
        family_used_[f] = true;
        --step_;
      }
      return c.has_value();
    };
    if (left_out(trial)) return true;
    AddedEffect a;
    a.evidence = {step_, F, 1, trial.dof, p, threshold, tested, dbic, current_.chi2, trial.chi2};
    a.evidence.scanned = scanned;
    // Library candidates of one column that fit almost as well (as in forward()).
    for (std::size_t i = 0; i < pool_.size(); ++i) {
      if (trial_chi2[i] < 0 || pool_[i].J_reading_effect.cols() != 1) continue;
      if (fits_almost_as_well(trial_chi2[i], trial)) a.close_alternatives.push_back(pool_[i].label);
    }
    Estimate after = trial;
    if (has_time_constant(fam.effect)) {
      block = refine_thermal(fam, k, after);
      // Its time constant refined (below the grid's), the warm-up may start faster than any
      // machine or bar: then it is no finding either.
      if (left_out(after)) return true;
    }
    CandidateStatus& fs = family_status_[f];
    fs = status(fam.label, CandidateState::kAdded, CandidateReason::kScanAdded);
    fs.step = step_;
    fs.other = block.label;
    fs.F = F;
    fs.p = p;
    fs.scanned = scanned;
    fs.threshold = threshold;
    fs.bic_change = dbic;
    a.block = std::move(block);
    added_.push_back(a);
    family_used_[f] = true;
    J_ = append_columns(J_, added_.back().block.J_reading_effect);
    current_ = after;
    return true;
  }

  // The time constant of a warm-up between the grid's neighbours of alternative k, by
  // golden-section search on chi2; then the block linearised there (Gauss-Newton):
  // [f(tau), a df/dtau] with f = 1 - exp(-(t - t0) / tau) and a the plateau, so that the
  // second column's coefficient is a correction to tau (0 at the minimum) whose
  // uncertainty is that of tau, carried into the axis errors. `fit` becomes the fit with it.
  // The time constant of a warm-up between the grid's neighbours of alternative k, by
  // golden-section search on the chi2 of the model `tester` tests against with the warm-up's
  // column appended (residual_checks.hpp: its chi2 less the fall the column brings).
  double refined_tau(const ScanFamily& fam, int k, const ColumnTester& tester) const {
    const std::size_t m = fam.alternatives.size();
    const double lo = fam.alternatives[k > 0 ? k - 1 : 0].effect.tau_min / (k > 0 ? 1.0 : 1.5);
    const double hi = fam.alternatives[std::min<std::size_t>(k + 1, m - 1)].effect.tau_min *
                      (static_cast<std::size_t>(k) + 1 < m ? 1.0 : 1.5);
    auto fall_at = [&](double log_tau) {
      return -tester.test(thermal_block(fam, std::exp(log_tau)).J_reading_effect).delta_chi2;
    };
    const double g = (std::sqrt(5.0) - 1) / 2;
    double a = std::log(lo), b = std::log(hi);
    double c = b - g * (b - a), d = a + g * (b - a), fc = fall_at(c), fd = fall_at(d);
    for (int it = 0; it < 40 && b - a > kLogTauBracket; ++it) {
      if (fc < fd) {
        b = d, d = c, fd = fc, c = b - g * (b - a), fc = fall_at(c);
      } else {
        a = c, c = d, fc = fd, d = a + g * (b - a), fd = fall_at(d);
      }
    }
    return std::exp((a + b) / 2);
  }

  EffectBlock thermal_block(const ScanFamily& fam, double tau) const {
    EffectCandidate c = fam.effect;
    c.tau_min = tau;
    return effect_block(*design_, *readings_, c);
  }

  EffectBlock refine_thermal(const ScanFamily& fam, int k, Estimate& fit) const {
    const WlsSolver solver(J_, sigma_, o_.estimate);
    const ColumnTester tester(solver, current_, o_.estimate);
    const double tau = refined_tau(fam, k, tester);
    EffectBlock f = thermal_block(fam, tau);
    const Estimate one = solve(append_columns(J_, f.J_reading_effect));
    Eigen::VectorXd unit = Eigen::VectorXd::Zero(one.n_unknowns);
    unit(one.n_unknowns - 1) = 1.0;
    const double plateau = one.evaluate(unit).value;
    // df/dtau = -exp(-dt / tau) dt / tau^2 = -(1 - f) dt / tau^2, dt in min.
    Eigen::VectorXd deriv = Eigen::VectorXd::Zero(f.J_reading_effect.rows());
    const double t0 = test_start_time(*readings_);
    for (Eigen::Index i = 0; i < f.J_reading_effect.rows(); ++i) {
      const double dt = (*(*readings_)[static_cast<std::size_t>(i)].time_s - t0) / 60.0;
      deriv(i) = -plateau * (1.0 - f.J_reading_effect(i, 0)) * dt / (tau * tau);
    }
    EffectBlock two = f;
    two.J_reading_effect.conservativeResize(Eigen::NoChange, 2);
    two.J_reading_effect.col(1) = deriv;
    const Estimate with_tau = solve(append_columns(J_, two.J_reading_effect));
    Eigen::VectorXd last = Eigen::VectorXd::Zero(with_tau.n_unknowns);
    last(with_tau.n_unknowns - 1) = 1.0;
    // tau not determined (a plateau of zero), or the linearised correction leaves it at or below
    // 0 (a warm-up quicker than the search's bracket, where the linearisation does not hold):
    // the one-column block at the refined tau.
    if (with_tau.rank - one.rank < 1 || !(tau + with_tau.evaluate(last).value > 0)) {
      fit = one;
      return f;
    }
    two.parameters = {"value", "tau_min"};
    fit = with_tau;
    return two;
  }

  // The scanned family an added block came from, or -1.
  int family_of(const EffectBlock& b) const {
    if (effect_info(b.effect.kind).position == EffectPosition::kNone) return -1;
    for (std::size_t f = 0; f < families_.size(); ++f) {
      if (families_[f].effect.kind == b.effect.kind &&
          families_[f].effect.installation == b.effect.installation) {
        return static_cast<int>(f);
      }
    }
    return -1;
  }

  // chi2 of the model with added effect `a` replaced by each candidate of the pool of as many
  // columns (not in the model, not confounded or equivalent, raising the rank by its columns);
  // -1 where not tried. One factorisation of the model without `a`, then a column test each.
  std::vector<double> swapped_chi2(int a) const {
    std::vector<double> chi2(pool_.size(), -1.0);
    const WlsSolver base(model_without(a), sigma_, o_.estimate);
    const Estimate fit = base.solve(y_);
    const ColumnTester tester(base, fit, o_.estimate);
    for (std::size_t i = 0; i < pool_.size(); ++i) {
      if (used_[i] || status_[i].state == CandidateState::kConfounded ||
          status_[i].state == CandidateState::kEquivalent)
        continue;
      if (pool_[i].J_reading_effect.cols() != added_[a].block.J_reading_effect.cols()) continue;
      const ColumnTest t = tester.test(pool_[i].J_reading_effect);
      if (t.added_rank < pool_[i].J_reading_effect.cols()) continue;
      chi2[i] = fit.chi2 - t.delta_chi2;
    }
    return chi2;
  }

  // Replace an added effect by another candidate when that lowers chi2 (forward
  // selection alone cannot undo an early choice that noise favoured). True when it did.
  bool exchange() {
    double best_chi2 = current_.chi2 * (1 - kExchangeGain);
    int swap_out = -1, swap_in = -1;
    for (std::size_t a = 0; a < added_.size(); ++a) {
      if (family_of(added_[a].block) >= 0)
        continue;  // a scanned effect keeps its place; backward() may drop it
      const std::vector<double> chi2 = swapped_chi2(static_cast<int>(a));
      for (std::size_t i = 0; i < pool_.size(); ++i) {
        if (chi2[i] >= 0 && chi2[i] < best_chi2)
          best_chi2 = chi2[i], swap_out = static_cast<int>(a), swap_in = static_cast<int>(i);
      }
    }
    if (swap_out < 0) return false;
    if (auto c = implausible(
            pool_[swap_in],
            solve(append_columns(model_without(swap_out), pool_[swap_in].J_reading_effect)),
            pool_[swap_in].label)) {
      // In its place it would explain more, at a size no machine or bar has: left out, and the
      // exchange tried again without it.
      status_[swap_in] = *c;
      used_[swap_in] = true;
      return true;
    }
    const int out_idx = index_of(added_[swap_out].block.label);
    release_equivalents(added_[swap_out]);
    const auto [chosen, equivalent] = equivalents(swap_in, model_without(swap_out));
    swap_in = chosen;
    used_[out_idx] = false;
    status_[out_idx] = status(pool_[out_idx].label, CandidateState::kNotSignificant,
                              CandidateReason::kExchangedOut);
    status_[out_idx].other = pool_[swap_in].label;
    used_[swap_in] = true;
    status_[swap_in] =
        status(pool_[swap_in].label, CandidateState::kAdded, CandidateReason::kExchangedIn);
    status_[swap_in].other = pool_[out_idx].label;
    added_[swap_out].block = pool_[swap_in];
    mark_equivalent(added_[swap_out], swap_in, equivalent);
    added_[swap_out].close_alternatives = {pool_[out_idx].label};
    rebuild();
    // Solved again on J_ as rebuilt: `swapped` has the new columns last, J_ has them in the
    // exchanged effect's place, and final_evidence reads the values in J_'s order.
    current_ = solve(J_);
    return true;
  }

  // Drop the added effect least significant in the model as it now stands when its
  // F-test of dropping gives p >= level (an effect added early can be made redundant
  // by later ones). Entry needs p < level / m, so a dropped effect cannot re-enter at
  // once. True when one was dropped.
  // An added effect that, with the effects added after it, the final fit puts at a size no machine
  // or bar has: left out (implausible), and selection goes on without it. True when one was.
  bool drop_implausible() {
    Eigen::Index col = J0_.cols();
    for (std::size_t a = 0; a < added_.size(); ++a) {
      const EffectBlock& b = added_[a].block;
      const Eigen::Index q = b.J_reading_effect.cols();
      const std::optional<CandidateStatus> c = implausible(b, values_at(current_, col, q), b.label);
      col += q;
      if (!c) continue;
      if (const int f = family_of(b); f >= 0) {
        family_status_[f] = *c;
        family_status_[f].label = families_[f].label;
        family_status_[f].other = b.label;
        family_used_[f] = true;
      } else {
        const int idx = index_of(b.label);
        status_[idx] = *c;
        used_[idx] = true;
        release_equivalents(added_[a]);
      }
      added_.erase(added_.begin() + static_cast<std::ptrdiff_t>(a));
      rebuild();
      current_ = solve(J_);
      return true;
    }
    return false;
  }

  bool backward() {
    int worst = -1;
    double worst_p = -1, worst_F = 0;
    for (std::size_t a = 0; a < added_.size(); ++a) {
      const Estimate reduced = solve(model_without(static_cast<int>(a)));
      const int q = static_cast<int>(added_[a].block.J_reading_effect.cols());
      if (current_.dof <= 0) return false;
      const double F = ((reduced.chi2 - current_.chi2) / q) / (current_.chi2 / current_.dof);
      const double p = f_test_p(q, current_.dof, F);
      if (p > worst_p) worst = static_cast<int>(a), worst_p = p, worst_F = F;
    }
    if (worst < 0 || worst_p < o_.level) return false;
    std::string others;
    for (std::size_t a = 0; a < added_.size(); ++a) {
      if (static_cast<int>(a) != worst)
        others += (others.empty() ? "" : ", ") + added_[a].block.label;
    }
    CandidateStatus dropped = status(added_[worst].block.label, CandidateState::kNotSignificant,
                                     CandidateReason::kDropped);
    dropped.other = others;
    dropped.F = worst_F;
    dropped.p = worst_p;
    dropped.level = o_.level;
    if (const int f = family_of(added_[worst].block); f >= 0) {
      family_used_[f] = false;
      family_status_[f] = dropped;
      family_status_[f].label = families_[f].label;
    } else {
      const int idx = index_of(added_[worst].block.label);
      used_[idx] = false;
      status_[idx] = dropped;
      release_equivalents(added_[worst]);
    }
    added_.erase(added_.begin() + worst);
    rebuild();
    current_ = solve(J_);
    return true;
  }

  // One whole-test term against the same effect per installation, for each kind that has both.
  void compare_structures() {
    for (EffectKind kind : effect_kinds()) {
      const EffectInfo& info = effect_info(kind);
      if (!info.whole_test_form || info.whole_test_only) continue;
      int whole = -1;  // pool index of the whole-test candidate
      for (std::size_t i = 0; i < pool_.size(); ++i) {
        if (pool_[i].effect.kind == kind && pool_[i].effect.installation < 0 &&
            pool_[i].applicability.applicable()) {
          whole = static_cast<int>(i);
        }
      }
      if (whole < 0) continue;
      std::vector<int> per_added;  // indices into added_ of per-installation effects of this kind
      int whole_added = -1;
      for (std::size_t a = 0; a < added_.size(); ++a) {
        if (added_[a].block.effect.kind != kind) continue;
        if (added_[a].block.effect.installation < 0) {
          whole_added = static_cast<int>(a);
        } else {
          per_added.push_back(static_cast<int>(a));
        }
      }
      StructureComparison c;
      c.kind = effect_name(kind);
      if (whole_added >= 0) {
        // The rejected alternative: every per-installation term of the kind that the model
        // without the whole-test term can take (rank-raising), in its place.
        Jacobian alt = model_without(whole_added);
        int rank = rank_of(alt);
        for (std::size_t i = 0; i < pool_.size(); ++i) {
          const EffectBlock& b = pool_[i];
          if (b.effect.kind != kind || b.effect.installation < 0 || !b.applicability.applicable() ||
              used_[i])
            continue;
          const Jacobian trial = append_columns(alt, b.J_reading_effect);
          const int r = rank_of(trial);
          if (r - rank < b.J_reading_effect.cols()) continue;
          alt = trial, rank = r;
          c.rejected.push_back(b.label);
        }
        if (c.rejected.size() < 2)
          continue;  // a single term is a nested alternative the F-tests decided
        c.chosen = {added_[whole_added].block.label};
        c.bic_chosen = bic(current_);
        c.bic_rejected = bic(solve(alt));
        structures_.push_back(c);
      } else if (per_added.size() >= 2 && !used_[whole]) {
        Jacobian alt = J0_;
        for (std::size_t a = 0; a < added_.size(); ++a) {
          if (std::find(per_added.begin(), per_added.end(), static_cast<int>(a)) ==
              per_added.end()) {
            alt = append_columns(alt, added_[a].block.J_reading_effect);
          }
        }
        const int base_rank = rank_of(alt);
        alt = append_columns(alt, pool_[whole].J_reading_effect);
        const Estimate alt_est = solve(alt);
        if (alt_est.rank - base_rank < pool_[whole].J_reading_effect.cols())
          continue;  // confounded with what remains
        for (int a : per_added) c.chosen.push_back(added_[a].block.label);
        c.rejected = {pool_[whole].label};
        c.bic_chosen = bic(current_);
        c.bic_rejected = bic(alt_est);
        structures_.push_back(c);
      }
    }
  }

  // Close alternatives in the final model as well as when each effect was added: a candidate
  // that, in an added effect's place, fits almost as well as the final model, with as many
  // columns or not (a centring's two columns against one of a scale); of the pool, or a scanned
  // step or warm-up at its best position (a warm-up against a linear drift). Later effects can
  // make two candidates indistinguishable that were not when the first was chosen. Each added
  // effect's single best replacement is kept on the way (single_: what best_appended would
  // return on the model without it), where final_substitutions starts.
  void final_alternatives() {
    single_.assign(added_.size(), {});
    for (std::size_t a = 0; a < added_.size(); ++a) {
      AddedEffect& effect = added_[a];
      const WlsSolver base(model_without(static_cast<int>(a)), sigma_, o_.estimate);
      const Estimate fit = base.solve(y_);
      const ColumnTester tester(base, fit, o_.estimate);
      single_[a].chi2_without = fit.chi2;
      auto fits = [&](const EffectBlock& b, const ColumnTest& t) {
        return t.added_rank >= b.J_reading_effect.cols() &&
               fits_almost_as_well(fit.chi2 - t.delta_chi2, current_, cost(b) - cost(effect.block));
      };
      auto consider = [&](const EffectBlock& b, const ColumnTest& t) {
        single_[a].best.consider(b, t);
        if (!fits(b, t)) return false;
        std::vector<std::string>& close = effect.close_alternatives;
        if (std::find(close.begin(), close.end(), b.label) == close.end()) close.push_back(b.label);
        effect.close_in_final.push_back(b);
        return true;
      };
      for (std::size_t i = 0; i < pool_.size(); ++i) {
        if (used_[i] || status_[i].state == CandidateState::kConfounded) continue;
        consider(pool_[i], tester.test(pool_[i].J_reading_effect));
      }
      if (!design_ || !readings_) continue;
      for (std::size_t f = 0; f < families_.size(); ++f) {
        if (family_used_[f]) continue;
        const auto b = best_of_family(families_[f], tester);
        if (!b || !consider(b->first, b->second) || !has_time_constant(families_[f].effect))
          continue;
        // A warm-up's time constant is poorly determined where a drift fits almost as well: every
        // time constant of the grid that fits almost as well is an alternative too.
        for (const EffectBlock& alt : families_[f].alternatives) {
          if (alt.label != b->first.label && fits(alt, tester.test(alt.J_reading_effect)))
            effect.close_in_final.push_back(alt);
        }
      }
    }
  }

  // The candidate (of the pool not in the model, or a scanned family not in the model at its
  // best position) whose columns lower chi2 most when appended to the model `tester` tests
  // against, raising the rank by their number; skipping the labels in `skip`. Of candidates that
  // explain the data alike (equivalent), the latest installation's, as in forward().
  BestAppended best_appended(const ColumnTester& tester,
                             const std::vector<EffectBlock>& skip) const {
    BestAppended best;
    auto consider = [&](const EffectBlock& b, const ColumnTest& t) {
      if (std::none_of(skip.begin(), skip.end(),
                       [&](const EffectBlock& s) { return s.label == b.label; })) {
        best.consider(b, t);
      }
    };
    for (std::size_t i = 0; i < pool_.size(); ++i) {
      if (used_[i] || status_[i].state == CandidateState::kConfounded) continue;
      consider(pool_[i], tester.test(pool_[i].J_reading_effect));
    }
    if (!design_ || !readings_) return best;
    for (std::size_t f = 0; f < families_.size(); ++f) {
      if (family_used_[f]) continue;
      if (const auto b = best_of_family(families_[f], tester)) consider(b->first, b->second);
    }
    return best;
  }

  // A scanned family's alternative that lowers chi2 most on the model `tester` tests against:
  // a step at its best reading, a warm-up at its time constant refined between the grid's
  // (refined_tau). None when no alternative raises the rank.
  std::optional<std::pair<EffectBlock, ColumnTest>> best_of_family(
      const ScanFamily& fam, const ColumnTester& tester) const {
    if (splits_readings(fam.effect)) {
      const ScanTest st = tester.scan_steps(fam.rows, fam.min_segment);
      if (st.best < 0) return std::nullopt;
      return std::make_pair(fam.alternative(*design_, *readings_, st.best), st.test);
    }
    int k = -1;
    ColumnTest t;
    for (std::size_t a = 0; a < fam.alternatives.size(); ++a) {
      const ColumnTest ta = tester.test(fam.alternatives[a].J_reading_effect);
      if (ta.added_rank > 0 && (k < 0 || ta.delta_chi2 > t.delta_chi2))
        k = static_cast<int>(a), t = ta;
    }
    if (k < 0) return std::nullopt;
    if (!has_time_constant(fam.effect))
      return std::make_pair(fam.alternative(*design_, *readings_, k), t);
    EffectBlock b = thermal_block(fam, refined_tau(fam, k, tester));
    const ColumnTest tb = tester.test(b.J_reading_effect);
    if (tb.added_rank < 1 || tb.delta_chi2 < t.delta_chi2)
      return std::make_pair(fam.alternative(*design_, *readings_, k), t);
    return std::make_pair(std::move(b), tb);
  }

  // parameter_cost with the alternatives of the effect's scanned family (a step's positions, a
  // warm-up's time constants).
  double cost(const EffectBlock& b) const {
    const int f = family_of(b);
    int m = 0;
    if (f >= 0) {
      const ScanFamily& fam = families_[f];
      m = static_cast<int>(splits_readings(fam.effect) ? fam.rows.size() : fam.alternatives.size());
    }
    return parameter_cost(b, m);
  }

  // Substitutions (selection.hpp): for every added effect and every pair of them, the model
  // without them takes the candidate that lowers chi2 most, then the next (greedy); the first
  // set that fits almost as well as the final model is recorded, unless it is one candidate for
  // one effect (final_alternatives) or its effects are already part of a recorded substitution.
  void final_substitutions() {
    if (current_.dof < 1) return;
    std::vector<std::vector<int>> sets;
    for (std::size_t a = 0; a < added_.size(); ++a) sets.push_back({static_cast<int>(a)});
    for (std::size_t a = 0; a < added_.size(); ++a) {
      for (std::size_t b = a + 1; b < added_.size(); ++b)
        sets.push_back({static_cast<int>(a), static_cast<int>(b)});
    }
    std::vector<bool> in_substitution(added_.size(), false);
    for (const std::vector<int>& out : sets) {
      if (std::any_of(out.begin(), out.end(), [&](int a) { return in_substitution[a]; })) continue;
      Jacobian M = model_without(out);
      std::vector<EffectBlock> by;
      for (int k = 0; k < 2; ++k) {
        BestAppended best;
        double chi2_before = 0;
        if (k == 0 && out.size() == 1) {  // found by final_alternatives on the same model
          best = single_[out[0]].best;
          chi2_before = single_[out[0]].chi2_without;
        } else {
          const WlsSolver base(M, sigma_, o_.estimate);
          const Estimate fit = base.solve(y_);
          best = best_appended(ColumnTester(base, fit, o_.estimate), by);
          chi2_before = fit.chi2;
        }
        if (!best.block) break;
        by.push_back(*best.block);
        M = append_columns(M, best.block->J_reading_effect);
        const double chi2 = chi2_before - best.test.delta_chi2;
        double extra = 0;
        for (const EffectBlock& b : by) extra += cost(b);
        for (int a : out) extra -= cost(added_[a].block);
        if (!fits_almost_as_well(chi2, current_, extra)) continue;
        if (out.size() == 1 && by.size() == 1) break;  // one for one: a close alternative already
        Substitution s;
        for (int a : out) s.replaced.push_back(added_[a].block.label), in_substitution[a] = true;
        s.by = by;
        s.chi2 = chi2;
        substitutions_.push_back(std::move(s));
        break;
      }
    }
  }

  // Evidence of every added effect in the final model: the F-test of dropping it.
  void final_evidence() {
    for (std::size_t a = 0; a < added_.size(); ++a) {
      const Estimate reduced = solve(model_without(static_cast<int>(a)));
      EffectEvidence& e = added_[a].evidence;
      e.q = static_cast<int>(added_[a].block.J_reading_effect.cols());
      e.dof = current_.dof;
      e.chi2_before = reduced.chi2;
      e.chi2_after = current_.chi2;
      e.F = current_.dof > 0
                ? ((reduced.chi2 - current_.chi2) / e.q) / (current_.chi2 / current_.dof)
                : 0.0;
      e.p_value = f_test_p(e.q, current_.dof, e.F);
      e.bic_change = bic(current_) - bic(reduced);
    }
    // The effects' values from the final model.
    int col = static_cast<int>(J0_.cols());
    for (AddedEffect& a : added_) {
      a.values.clear();
      for (int j = 0; j < a.block.J_reading_effect.cols(); ++j, ++col) {
        Eigen::VectorXd c = Eigen::VectorXd::Zero(current_.n_unknowns);
        c(col) = 1.0;
        a.values.push_back(current_.evaluate(c));
        // A warm-up's second column is the correction to the time constant it was linearised at.
        if (a.block.parameters[j] == "tau_min") a.values.back().value += a.block.effect.tau_min;
      }
    }
  }

  const Jacobian& J0_;
  const Eigen::VectorXd& sigma_;
  const Eigen::VectorXd& y_;
  const std::vector<EffectBlock>& pool_;
  const SelectionOptions& o_;
  std::vector<bool> used_;
  std::vector<CandidateStatus> status_;
  const std::vector<ScanFamily>& families_;
  const Design* design_;
  const std::vector<Reading>* readings_;
  std::vector<bool> family_used_;
  std::vector<CandidateStatus> family_status_;
  std::vector<int> all_rows_;
  int stopped_at_reading_ = -1, stopped_at_step_ = 0;
  std::optional<OrderCheck> stopped_at_order_;
  std::vector<std::pair<int, Eigen::MatrixXd>> higher_;
  ScanTest gross_;
  std::vector<AddedEffect> added_;
  std::vector<StructureComparison> structures_;
  std::vector<Substitution> substitutions_;
  // Per added effect (final_alternatives): chi2 of the final model without it, and the candidate
  // that lowers it most there.
  struct Single {
    double chi2_without = 0;
    BestAppended best;
  };
  std::vector<Single> single_;
  Jacobian J_;
  Estimate current_;
  int step_ = 0;
  double range_um_ = 0;  // the instrument's range (0: no design, no bound)
};

}  // namespace

const char* candidate_state_name(CandidateState s) {
  switch (s) {
    case CandidateState::kAdded:
      return "added";
    case CandidateState::kNotSignificant:
      return "not significant";
    case CandidateState::kConfounded:
      return "confounded";
    case CandidateState::kNotApplicable:
      return "not applicable";
    case CandidateState::kEquivalent:
      return "equivalent";
    case CandidateState::kDetectable:
      return "detectable";
    case CandidateState::kSetUp:
      return "declared set-up";
    case CandidateState::kImplausible:
      return "implausible";
  }
  return "unknown";
}

double bic(const Estimate& e) { return bic(static_cast<double>(e.n_readings), e.chi2, e.rank); }

double parameter_cost(const EffectBlock& b, int scanned_alternatives) {
  double cost = 2.0 * static_cast<double>(b.J_reading_effect.cols());
  const bool scanned =
      splits_readings(b.effect) || (has_time_constant(b.effect) && b.J_reading_effect.cols() == 1);
  if (scanned && scanned_alternatives > 1)
    cost += 2.0 * std::log(static_cast<double>(scanned_alternatives));
  return cost;
}

Selection select_effects(const Jacobian& J, const Eigen::VectorXd& sigma_um,
                         const Eigen::VectorXd& y_um, const std::vector<EffectBlock>& pool,
                         const SelectionOptions& options) {
  return Selector(J, sigma_um, y_um, pool, options).run();
}

Selection select_effects(const Jacobian& J, const Eigen::VectorXd& sigma_um,
                         const Eigen::VectorXd& y_um, const std::vector<EffectBlock>& pool,
                         const std::vector<ScanFamily>& families, const Design& design,
                         const std::vector<Reading>& readings, const SelectionOptions& options) {
  return Selector(J, sigma_um, y_um, pool, options, families, &design, &readings).run();
}

}  // namespace dbbkit
