#include "dbbkit/optimize.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <map>
#include <mutex>
#include <nlopt.hpp>
#include <sstream>

#include "dbbkit/diagnose.hpp"
#include "dbbkit/effects.hpp"
#include "dbbkit/error.hpp"
#include "dbbkit/instrument.hpp"
#include "dbbkit/limits.hpp"
#include "dbbkit/parallel.hpp"
#include "dbbkit/program.hpp"
#include "dbbkit/user_text.hpp"
#include "number_text.hpp"
#include "tolerances.hpp"

namespace dbbkit {

namespace {

constexpr double kPenalty = 1e12;  // objective of a point the criterion cannot score
// A geometric constraint holds when its violation v [mm] (travel excursion, separation shortfall)
// satisfies v <= kGeometryTolerance_mm; NLopt's constraint tolerance is the same.
constexpr double kGeometryTolerance_mm = 1e-9;
// The geometric violation a point the machine's program refuses counts as [mm] (the refusal
// states no distance): infeasible, ranked as one a millimetre outside the travel.
constexpr double kMachineClash_mm = 1.0;
// Within one choice, two feasible candidates tie when |f_a - f_b| <= kCandidateTie max(|f_a|,
// |f_b|) (the shorter measurement is then better).
constexpr double kCandidateTie = 1e-9;
constexpr int kNearRankLoss = 1 << 20;  // n_undetermined of a point the fast path declined
// A reference design declares the kit's instrument when |sigma_ref - sigma_kit| <=
// kSameNoiseRelative sigma_kit (the same noise written in another form).
constexpr double kSameNoiseRelative = 1e-12;
// Local starts: two points are apart when max_k |x_k - y_k| / max(ub_k - lb_k, kMinRange_mm)
// > kStartsApart; COBYLA stops when a step changes every coordinate by at most kLocalXtol of it.
constexpr double kMinRange_mm = 1e-12;
constexpr double kStartsApart = 0.05;
constexpr double kLocalXtol = 1e-10;

std::string mm(double x) { return text::rounded(x, 3); }

Candidate candidate_skeleton(const Kit& kit, const PatternChoice& choice);
void place_candidate(const Kit& kit, Candidate& c, const std::vector<double>& x);

std::string kit_stack_text(const Kit& kit, const Stack& s) {
  // A ball bar's cup, a probe's sphere on its stand.
  const std::string holder = kit.instrument == InstrumentKind::kProbe ? "stand" : "cup";
  std::string t = mm(s.height_mm) + " mm (";
  if (s.blocks_mm.empty()) return t + holder + " on the table)";
  t += holder + " of " + mm(kit.H_base_mm) + " mm on block";
  if (s.blocks_mm.size() > 1) t += "s";
  for (size_t i = 0; i < s.blocks_mm.size(); ++i) t += (i ? " + " : " ") + mm(s.blocks_mm[i]);
  return t + " mm)";
}

// The positions of a choice: the required ones and the first n_optional offered, in pattern order.
std::vector<int> included_positions(const Kit& kit, int n_optional) {
  const std::vector<int> offered = offered_optional_positions(kit);
  std::vector<int> out;
  for (int i = 0; i < static_cast<int>(kit.pattern.positions.size()); ++i) {
    const bool optional = kit.pattern.positions[i].optional;
    const auto it = std::find(offered.begin(), offered.end(), i);
    if (!optional || (it != offered.end() && it - offered.begin() < n_optional)) out.push_back(i);
  }
  return out;
}

// A position off the B tool axis: D a variable over a range that allows an offset, or fixed != 0.
bool off_axis(const Kit& kit, const PatternPosition& p) {
  const auto off = [](const PatternCoordinate& c, const Interval& range) {
    return c.is_variable() ? range.min < 0 || range.max > 0 : c.value != 0;
  };
  return off(p.D, kit.D_mm) || (kit.axis.head() && kit.axis.has_H() && off(p.H, kit.axial_mm));
}

// The kit's requirement that diagnose detect every declared set-up effect at its declared
// size, for the designs of one choice. The test: diagnose's level over every candidate
// effect applicable to the choice's readings (Bonferroni; diagnose tests the detectable
// ones, never more), power 0.9. The noncentrality depends only on (q, dof), so it is
// formed once per pair.
class DetectionRequirement {
 public:
  DetectionRequirement(const Kit& kit, const Design& probe) : kit_(&kit) {
    settings_.level = DiagnoseOptions{}.level;
    settings_.n_tests = 0;
    for (const EffectBlock& b : candidate_effects(probe, nominal_readings(probe)))
      settings_.n_tests += b.applicability.applicable();
    settings_.n_tests = std::max(1, settings_.n_tests);
  }

  // fast_only: a choice scored on the fast path alone, where a point it declines (near rank
  // loss, penalised) is not scored either.
  void score(Candidate& c, bool fast_only, const AngleStations* stations = nullptr) {
    Candidate::Detection d;
    d.settings = settings_;
    d.ratio = -std::numeric_limits<double>::infinity();
    std::optional<SetupInformation> fast;
    if (!kit_->require_setup_detection) {
      d.ratio = 0;
    } else if (fast_only) {
      fast = fast_setup_information(c.design, stations);
      if (!fast) {
        d.ratio = std::numeric_limits<double>::infinity();
        d.effect = "near rank loss, not scored";
        c.feasible = false;
        c.detection = std::move(d);
        return;
      }
    }
    const SetupInformation info = !kit_->require_setup_detection ? SetupInformation{}
                                  : fast                         ? std::move(*fast)
                                         : design_setup_information(c.design);
    for (const SetupEffectInformation& e : info.effects) {
      const int dof = info.n_readings - info.rank - e.q;
      std::optional<double> limit;
      if (e.detectable && dof > 0 && e.min_information > 0)
        limit = std::sqrt(lambda(e.q, dof) / e.min_information);
      const double ratio =
          limit ? *limit / e.declared_std_um : std::numeric_limits<double>::infinity();
      if (!limit) d.undetectable.push_back(EffectCandidate{e.kind, e.installation}.label(c.design));
      if (ratio > d.ratio) {
        d.ratio = ratio;
        d.effect = EffectCandidate{e.kind, e.installation}.label(c.design);
        d.limit_um = limit;
        d.declared_std_um = e.declared_std_um;
      }
    }
    if (info.effects.empty()) d.ratio = 0;
    // As a drift's (below): a design that leaves errors undetermined meets no set-up detection,
    // for the axis errors it fails to measure would take less of an effect, which would then
    // seem detectable (finite: the generic point of a choice may lose rank where its optimum
    // does not).
    if (kit_->require_setup_detection && !info.effects.empty() && c.n_undetermined > 0) {
      d.ratio = std::max(d.ratio, 1e6);
      d.effect = "every set-up effect (not every error determined)";
      d.limit_um.reset();
    }
    if (kit_->require_drift_detection_um) {
      // The drift over the whole test on the kit's clock (design_drift_checks).
      const TestClock clock{kit_->time_per_reading_s, kit_->time_per_installation_s};
      const DriftChecks drift =
          design_drift_checks(c.design, kit_->reference_length_mm, settings_, clock);
      for (const DriftCheck& e : drift.effects) {
        if (e.kind != EffectKind::kDrift) continue;
        const double ratio = e.detection_limit_um
                                 ? *e.detection_limit_um / *kit_->require_drift_detection_um
                                 : std::numeric_limits<double>::infinity();
        if (!e.detection_limit_um) d.undetectable.push_back(e.label);
        if (ratio > d.ratio) {
          d.ratio = ratio;
          d.effect = e.label;
          d.limit_um = e.detection_limit_um;
          d.declared_std_um = *kit_->require_drift_detection_um;
        }
      }
      // Only a design that determines every error meets it: at or near rank loss the axis
      // errors take less of a drift, which would then seem detectable for what the design
      // fails to measure.
      // Finite: the generic point of a choice may lose rank where its optimum does not.
      if (c.n_undetermined > 0 || drift.rank < drift.n_unknowns) {
        d.ratio = std::max(d.ratio, 1e6);
        d.effect = "drift[all] (not every error determined)";
        d.limit_um.reset();
      }
      if (drift.effects.empty()) {  // one time only: nothing tells a drift
        d.ratio = std::numeric_limits<double>::infinity();
        d.effect = "drift[all]";
        d.undetectable.push_back(d.effect);
      }
    }
    c.feasible = c.feasible && d.ratio <= 1.0;
    c.detection = std::move(d);
  }

 private:
  double lambda(int q, int dof) {
    const auto key = std::make_pair(q, dof);
    const auto it = cache_.find(key);
    if (it != cache_.end()) return it->second;
    const double alpha = settings_.level / settings_.n_tests;
    return cache_[key] = noncentrality_for_power(q, dof, alpha, settings_.power);
  }

  const Kit* kit_;
  DetectionSettings settings_;
  std::map<std::pair<int, int>, double> cache_;
};

// The constraint NLopt sees: ratio - 1 <= 0 (finite where the axis errors take an effect).
double detection_violation(const Candidate& c) {
  return c.detection ? std::min(c.detection->ratio, 1e6) - 1.0 : -1.0;
}

// The search over one choice: DIRECT-L (a point outside the constraints scored as
// unscorable), then COBYLA under the constraints from the best point found, from the
// global stage's next best points apart from it and from the centre. Every scored point is
// kept if it is the best so far.
class ChoiceSearch {
 public:
  ChoiceSearch(const Kit& kit, const PatternChoice& choice, Criterion criterion)
      : kit_(kit),
        choice_(choice),
        criterion_(criterion),
        space_(choice.space),
        stations_(kit.axis, kit_angles(kit, choice.step_deg)) {
    for (size_t i = 0; i < space_.names.size(); ++i) {
      if (space_.upper[i] > space_.lower[i]) free_.push_back(static_cast<int>(i));
    }
    // The determination a generic point of this choice reaches: points that reach less are
    // penalised. The centre may be degenerate (e.g. L1 = L2): a generic point is taken a third of
    // the way in.
    std::vector<double> generic = space_.lower;
    for (int i : free_) generic[i] += (space_.upper[i] - space_.lower[i]) * (0.29 + 0.07 * i);
    Candidate probe = make_candidate(kit_, choice_, generic);
    score_candidate(kit_, criterion_, probe);
    generic_undetermined_ = probe.n_undetermined;
    fast_only_ = generic_undetermined_ == 0 && fast_score(probe);
    if (kit_.require_setup_detection || kit_.require_drift_detection_um) {
      // An effect the axis errors take at a generic point is taken at every point of the
      // choice (a special point can only lose rank): the choice is not searched.
      detection_.emplace(kit_, probe.design);
      detection_->score(probe, false);
      if (std::isinf(probe.detection->ratio)) generic_probe_ = generic;
    }
  }

  long evaluations() const { return evaluations_; }
  void set_max_evaluations(long n) { max_evaluations_ = n; }
  bool budget_exhausted() const { return budget_exhausted_; }
  // A declared set-up effect no position of the choice detects (not searched; best() is the
  // generic point that shows it).
  bool undetectable_everywhere() const { return generic_probe_.has_value(); }
  const std::optional<Candidate>& best() const { return best_; }
  int n_free() const { return static_cast<int>(free_.size()); }

  std::vector<double> centre_free() const {
    std::vector<double> x;
    for (int i : free_) x.push_back(0.5 * (space_.lower[i] + space_.upper[i]));
    return x;
  }
  std::vector<double> full(const std::vector<double>& xf) const {
    std::vector<double> x = space_.lower;
    for (size_t k = 0; k < free_.size(); ++k) x[free_[k]] = xf[k];
    return x;
  }
  std::vector<double> free_part(const std::vector<double>& x) const {
    std::vector<double> xf;
    for (int i : free_) xf.push_back(x[i]);
    return xf;
  }

  // Scores the point (cached for the constraint calls at the same point).
  const Candidate& at(const std::vector<double>& x) {
    if (last_ && last_->x == x) return *last_;
    if (max_evaluations_ > 0 && evaluations_ >= max_evaluations_) {
      budget_exhausted_ = true;
      throw nlopt::forced_stop();  // caught by the stage that is running: its best point is kept
    }
    // The point's candidate in the storage of the one before last (its structure is the
    // choice's): place_candidate builds it as make_candidate would.
    if (!spare_) spare_ = candidate_skeleton(kit_, choice_);
    Candidate& c = *spare_;
    place_candidate(kit_, c, x);
    if (fast_only_) {
      // A choice whose generic point is full rank: a point the fast path declines is within
      // a factor 1e4 of rank loss (or at it, e.g. two balls at one position) and is penalised
      // instead of being evaluated in full; such a point is never the best.
      if (!fast_score(c)) {
        c.objective_defined = false;
        c.n_undetermined = kNearRankLoss;
      }
    } else {
      score_candidate(kit_, criterion_, c);
    }
    if (detection_) detection_->score(c, fast_only_, &stations_);
    ++evaluations_;
    if (global_stage_ && c.feasible && c.objective_defined &&
        c.n_undetermined <= generic_undetermined_) {
      global_points_.emplace_back(c.objective, x);
    }
    if (!best_ || better(c, *best_)) best_ = c;
    last_.swap(spare_);
    return *last_;
  }

  // The worst case (noise only, or the total) without the stacked model, when the fast path
  // applies (observability.hpp); false for the other criteria and where it declines.
  bool fast_score(Candidate& c) const {
    if (criterion_ == Criterion::kWorst) {
      const std::optional<WorstCase> w =
          fast_worst_case(c.design, kit_.reference_length_mm, &stations_);
      if (!w) return false;
      c.worst = *w;
      c.objective = *w->worst_std_um;
    } else if (criterion_ == Criterion::kWorstTotal) {
      // The total alone (one triangular solve); the noise part of each choice's best is
      // formed once the choice is searched (search_all).
      const std::optional<TotalWorstCase> t =
          fast_worst_total(c.design, kit_.reference_length_mm, false, &stations_);
      if (!t) return false;
      c.worst = WorstCase{};
      c.objective = *t->total.worst_std_um;
    } else {
      return false;
    }
    c.n_undetermined = 0;
    c.objective_defined = true;
    return true;
  }

  double objective(const std::vector<double>& xf) {
    const Candidate& c = at(full(xf));
    if (!c.objective_defined || c.n_undetermined > generic_undetermined_) return kPenalty;
    // The global stage scores a point outside the constraints as one it cannot score: NLopt's
    // DIRECT, told of constraints, rescans every infeasible point against every feasible one
    // at each iteration (quadratic in the points; a third of the formats kit's search). The local
    // stage keeps the constraints, so a best on a constraint's boundary is reached there.
    if (global_stage_ &&
        (c.travel_violation_mm > kGeometryTolerance_mm ||
         c.separation_violation_mm > kGeometryTolerance_mm || detection_violation(c) > 0))
      return kPenalty;
    return c.objective;
  }

  void run(const OptimizeOptions& options) {
    const int n = n_free();
    max_evaluations_ = options.max_evaluations_per_choice;
    if (generic_probe_) {  // a set-up effect no position of the choice detects
      at(*generic_probe_);
      return;
    }
    if (n == 0) {
      at(full({}));
      return;
    }
    std::vector<double> lb, ub;
    for (int i : free_) lb.push_back(space_.lower[i]), ub.push_back(space_.upper[i]);
    auto f = [](const std::vector<double>& x, std::vector<double>&, void* self) {
      return static_cast<ChoiceSearch*>(self)->objective(x);
    };
    auto travel = [](const std::vector<double>& x, std::vector<double>&, void* self) {
      auto* s = static_cast<ChoiceSearch*>(self);
      return s->at(s->full(x)).travel_violation_mm;
    };
    auto separation = [](const std::vector<double>& x, std::vector<double>&, void* self) {
      auto* s = static_cast<ChoiceSearch*>(self);
      return s->at(s->full(x)).separation_violation_mm;
    };
    auto detection = [](const std::vector<double>& x, std::vector<double>&, void* self) {
      auto* s = static_cast<ChoiceSearch*>(self);
      return detection_violation(s->at(s->full(x)));
    };
    auto setup = [&](nlopt::opt& o) {
      o.set_lower_bounds(lb);
      o.set_upper_bounds(ub);
      o.set_min_objective(f, this);
      if (!global_stage_) {  // the global stage: objective()
        o.add_inequality_constraint(travel, this, kGeometryTolerance_mm);
        o.add_inequality_constraint(separation, this, kGeometryTolerance_mm);
        if (detection_) o.add_inequality_constraint(detection, this, 0.0);
      }
    };
    // Global stage.
    {
      global_stage_ = true;
      nlopt::opt o(nlopt::GN_ORIG_DIRECT_L, n);
      setup(o);
      o.set_maxeval(options.global_evaluations_per_variable * (n + 1));
      std::vector<double> x = centre_free();
      double fx = 0;
      try {
        o.optimize(x, fx);
      } catch (const std::exception&) {
        // A stage that stops early (round-off, forced stop) leaves its best point in best_.
      }
    }
    global_stage_ = false;
    // Local polish from the best point so far, from the next best points of the global stage
    // that lie apart from it (another basin: a flat criterion such as a set-up floor has
    // several), and from the centre.
    std::vector<std::vector<double>> starts;
    if (best_) starts.push_back(free_part(best_->x));
    std::stable_sort(global_points_.begin(), global_points_.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    for (const auto& [objective, x] : global_points_) {
      if (starts.size() >= 1 + kExtraLocalStarts) break;
      const std::vector<double> xf = free_part(x);
      bool apart = true;
      for (const std::vector<double>& y : starts) {
        double d = 0;
        for (int k = 0; k < n; ++k)
          d = std::max(d, std::abs(xf[k] - y[k]) / std::max(ub[k] - lb[k], kMinRange_mm));
        apart = apart && d > kStartsApart;
      }
      if (apart) starts.push_back(xf);
    }
    global_points_.clear();
    starts.push_back(centre_free());
    for (std::vector<double> x : starts) {
      nlopt::opt o(nlopt::LN_COBYLA, n);
      setup(o);
      std::vector<double> step;
      for (int k = 0; k < n; ++k) step.push_back(0.1 * (ub[k] - lb[k]));
      o.set_initial_step(step);
      o.set_xtol_rel(kLocalXtol);
      o.set_maxeval(options.local_evaluations);
      double fx = 0;
      try {
        o.optimize(x, fx);
      } catch (const std::exception&) {
      }
    }
  }

  void grid(double h) {
    const int n = n_free();
    std::vector<std::vector<double>> axes(n);
    for (int k = 0; k < n; ++k) {
      const double lo = space_.lower[free_[k]], hi = space_.upper[free_[k]];
      const long m = static_cast<long>(std::ceil((hi - lo) / h - tol::kWholeSteps));
      for (long i = 0; i <= m; ++i)
        axes[k].push_back(i == m ? hi : lo + static_cast<double>(i) * h);
    }
    std::vector<size_t> idx(n, 0);
    std::vector<double> xf(n);
    while (true) {
      for (int k = 0; k < n; ++k) xf[k] = axes[k][idx[k]];
      at(full(xf));
      int k = n - 1;
      while (k >= 0 && ++idx[k] == axes[k].size()) idx[k--] = 0;
      if (k < 0) break;
    }
  }

 private:
  const Kit& kit_;
  PatternChoice choice_;
  Criterion criterion_;
  PatternSpace space_;
  AngleStations stations_;  // every candidate's (make_candidate's angles)
  std::vector<int> free_;
  int generic_undetermined_ = 0;
  bool fast_only_ = false;
  std::optional<DetectionRequirement> detection_;     // kit.require_setup_/drift_detection
  std::optional<std::vector<double>> generic_probe_;  // set when no position meets it
  long evaluations_ = 0;
  long max_evaluations_ = 0;
  bool budget_exhausted_ = false;
  std::optional<Candidate> best_, last_, spare_;
  // The points of the global stage (objective, x), for the extra starts of the local stage.
  static constexpr size_t kExtraLocalStarts = 4;
  bool global_stage_ = false;
  std::vector<std::pair<double, std::vector<double>>> global_points_;
};

// Between discrete choices (different measurements), objectives closer than this (relative:
// below the fourth significant digit the outputs print) are equal, and the shorter
// measurement is the better; the Pareto front takes a longer one only beyond it.
constexpr double kObjectiveTie = 1e-4;

bool better_choice(const Candidate& a, const Candidate& b) {
  if (a.feasible && b.feasible && a.n_undetermined == b.n_undetermined && a.objective_defined &&
      b.objective_defined &&
      std::abs(a.objective - b.objective) <=
          kObjectiveTie * std::max(std::abs(a.objective), std::abs(b.objective)) &&
      a.time_s != b.time_s) {
    return a.time_s < b.time_s;
  }
  return better(a, b);
}

// The best design with its continuous positions rounded to multiples of the kit's
// resolution: every combination of the multiple below and above each variable (inside its
// bounds) is made, checked and scored again, and the best feasible one replaces the best.
// Every combination of the multiples below and above is tried for at most this many
// continuous variables (2^6 = 64 designs); beyond, the nearest multiples and each single
// change of them (2 n + 1 designs at most).
constexpr size_t kMaxExhaustiveRounding = 6;

void round_best(const Kit& kit, Criterion criterion, OptimizeResult& res) {
  if (!kit.resolution_mm || !res.best) return;
  const double r = *kit.resolution_mm;
  const Candidate& unrounded = *res.best;
  const PatternSpace& space = unrounded.choice.space;
  std::vector<std::vector<double>> options(unrounded.x.size());
  for (size_t i = 0; i < unrounded.x.size(); ++i) {
    const double x = unrounded.x[i];
    for (double m : {std::floor(x / r) * r, std::ceil(x / r) * r}) {
      // A multiple closer than kAssemblyTolerance_mm to a bound is the bound itself.
      m = std::clamp(m, space.lower[i], space.upper[i]);
      if (std::abs(m / r - std::round(m / r)) * r <= kAssemblyTolerance_mm &&
          (options[i].empty() || options[i].back() != m))
        options[i].push_back(m);
    }
  }
  OptimizeResult::Rounding rd;
  rd.resolution_mm = r;
  rd.unrounded = unrounded;
  // A range with no multiple of the resolution inside: nothing rounded, and said so.
  for (const std::vector<double>& o : options) {
    if (o.empty()) {
      res.rounding = std::move(rd);
      return;
    }
  }
  std::optional<DetectionRequirement> detection;
  if (kit.require_setup_detection || kit.require_drift_detection_um)
    detection.emplace(kit, unrounded.design);
  std::optional<Candidate> best;
  auto score = [&](const std::vector<double>& x) {
    Candidate c = make_candidate(kit, unrounded.choice, x);
    score_candidate(kit, criterion, c);
    if (detection) detection->score(c, false);
    ++rd.tried;
    if (c.feasible && c.n_undetermined <= unrounded.n_undetermined && c.objective_defined &&
        (!best || better(c, *best)))
      best = std::move(c);
  };
  if (options.size() <= kMaxExhaustiveRounding) {
    std::vector<size_t> pick(options.size(), 0);
    for (;;) {
      std::vector<double> x(options.size());
      for (size_t i = 0; i < options.size(); ++i) x[i] = options[i][pick[i]];
      score(x);
      size_t i = 0;
      while (i < pick.size() && ++pick[i] == options[i].size()) pick[i++] = 0;
      if (i == pick.size()) break;
    }
  } else {
    // Many variables: the nearest multiples, and that point with one variable the other way.
    std::vector<double> nearest(options.size());
    for (size_t i = 0; i < options.size(); ++i) {
      nearest[i] = options[i].front();
      for (double m : options[i])
        if (std::abs(m - unrounded.x[i]) < std::abs(nearest[i] - unrounded.x[i])) nearest[i] = m;
    }
    score(nearest);
    for (size_t i = 0; i < options.size(); ++i) {
      for (double m : options[i]) {
        if (m == nearest[i]) continue;
        std::vector<double> x = nearest;
        x[i] = m;
        score(x);
      }
    }
  }
  if (best) {
    if (criterion == Criterion::kWorstTotal)
      best->worst = *design_worst_total(best->design, kit.reference_length_mm).noise;
    describe_installations(kit, *best);
    res.best = std::move(best);
    rd.applied = true;
  }
  res.rounding = std::move(rd);
}

// Runs `search_one` over every choice in parallel and assembles the result.
template <typename SearchOne>
OptimizeResult search_all(const Kit& kit, Criterion criterion, int threads, SearchOne&& search_one,
                          const std::function<void(int, int, const Candidate*)>& progress) {
  OptimizeResult res;
  res.criterion = criterion;
  const std::vector<PatternChoice> choices = pattern_choices(kit);
  res.choices.resize(choices.size());
  std::atomic<long> evaluations{0};
  std::mutex mutex;
  int done = 0;
  std::optional<Candidate> best_so_far;
  parallel_for(static_cast<long>(choices.size()), std::max(1, threads), [&](long i) {
    ChoiceResult& cr = res.choices[i];
    cr.choice = choices[i];
    cr.label = choice_label(kit, choices[i]);
    const Candidate probe = make_candidate(kit, choices[i], choices[i].space.lower);
    cr.time_s = probe.time_s;
    if (kit.time_budget_s && probe.time_s > *kit.time_budget_s) {
      cr.state = ChoiceState::kOverTimeBudget;
    } else {
      ChoiceSearch s(kit, choices[i], criterion);
      search_one(s);
      evaluations += s.evaluations();
      cr.best = s.best();
      if (cr.best && criterion == Criterion::kWorstTotal) {
        cr.best->worst = *design_worst_total(cr.best->design, kit.reference_length_mm).noise;
      }
      cr.budget_exhausted = s.budget_exhausted();
      if (cr.best) describe_installations(kit, *cr.best);
      if (s.undetectable_everywhere()) {
        cr.state = ChoiceState::kUndetectableEverywhere;
      } else if (cr.best && cr.best->feasible) {
        cr.state = ChoiceState::kSearched;
      } else if (cr.best && cr.best->travel_violation_mm > kGeometryTolerance_mm) {
        cr.state = ChoiceState::kOutsideTravel;
      } else if (cr.best && cr.best->separation_violation_mm > kGeometryTolerance_mm) {
        cr.state = ChoiceState::kTooClose;
      } else if (cr.best && cr.best->detection) {
        cr.state = ChoiceState::kSetupNotDetected;
      } else {
        cr.state = ChoiceState::kNoFeasiblePosition;
      }
    }
    std::lock_guard<std::mutex> lock(mutex);
    ++done;
    if (cr.best && cr.best->feasible && (!best_so_far || better_choice(*cr.best, *best_so_far)))
      best_so_far = cr.best;
    if (progress)
      progress(done, static_cast<int>(choices.size()), best_so_far ? &*best_so_far : nullptr);
  });
  res.evaluations = evaluations;
  for (const ChoiceResult& cr : res.choices) {
    if (cr.best && cr.best->feasible && (!res.best || better_choice(*cr.best, *res.best)))
      res.best = cr.best;
  }
  round_best(kit, criterion, res);
  if (res.best) {
    // The drift on the kit's clock (the summary's drift line).
    res.best_evaluation =
        evaluate_design(res.best->design, kit.reference_length_mm, {}, {},
                        DriftOptions{{kit.time_per_reading_s, kit.time_per_installation_s}, false});
    res.best_evaluation.worst_total_typical =
        typical_setup_worst(res.best->design, kit.reference_length_mm);
    // Pareto front of (time, objective) among the choices that determine as much as the best.
    std::vector<Candidate> pool;
    for (const ChoiceResult& cr : res.choices) {
      if (cr.best && cr.best->feasible && cr.best->objective_defined &&
          cr.best->n_undetermined == res.best->n_undetermined) {
        pool.push_back(*cr.best);
      }
    }
    std::stable_sort(pool.begin(), pool.end(), [](const Candidate& a, const Candidate& b) {
      return a.time_s < b.time_s || (a.time_s == b.time_s && a.objective < b.objective);
    });
    double running = std::numeric_limits<double>::infinity();
    for (const Candidate& c : pool) {
      if (c.objective < running * (1 - kObjectiveTie)) {
        if (!res.pareto.empty() && res.pareto.back().time_s == c.time_s) res.pareto.pop_back();
        res.pareto.push_back(c);
        running = c.objective;
      }
    }
  }
  bool can_be_off_axis = false;
  for (const PatternPosition& p : kit.pattern.positions)
    can_be_off_axis = can_be_off_axis || off_axis(kit, p);
  bool best_off_axis = false;
  if (res.best) {
    for (int i : res.best->installation_position)
      best_off_axis = best_off_axis || off_axis(kit, kit.pattern.positions[i]);
  }
  if (kit.axis.head()) {
    if (!can_be_off_axis) {
      res.rank_five = OptimizeResult::RankFiveCause::kNoLateralOffset;
    } else if (!res.best || !best_off_axis) {
      res.rank_five = OptimizeResult::RankFiveCause::kNoOffAxisDesignFits;
    }
  }
  return res;
}

}  // namespace

Criterion criterion_from_name(const std::string& name, const std::string& source) {
  if (name == "worst") return Criterion::kWorst;
  if (name == "D") return Criterion::kD;
  if (name == "A") return Criterion::kA;
  if (name == "E") return Criterion::kE;
  if (name == "condition") return Criterion::kCondition;
  if (name == "worst_total") return Criterion::kWorstTotal;
  throw InputError(source, "",
                   "unknown criterion " + quote_value(name) +
                       " (expected worst, worst_total, D, A, E or condition)");
}

Criterion search_criterion(Kit& kit, const std::optional<std::string>& name,
                           bool require_setup_detection, const std::string& kit_source,
                           const std::string& criterion_option,
                           const std::string& detection_option) {
  const bool declared = kit.setup_std.nuisance();
  const auto needs = [&](const std::string& what) {
    return InputError(kit_source, "setup_std",
                      what + " needs " + instrument_info(kit.instrument).setup_tolerance_phrase +
                          " declared in the kit");
  };
  if (require_setup_detection) {
    if (!declared) throw needs(detection_option);
    kit.require_setup_detection = true;
  }
  const Criterion c = criterion_from_name(name       ? *name
                                          : declared ? "worst_total"
                                                     : "worst",
                                          criterion_option);
  if (c == Criterion::kWorstTotal && !declared) throw needs(criterion_option + " worst_total");
  return c;
}

const char* criterion_name(Criterion c) {
  switch (c) {
    case Criterion::kWorst:
      return "worst_std_um";
    case Criterion::kD:
      return "D";
    case Criterion::kA:
      return "A";
    case Criterion::kE:
      return "E";
    case Criterion::kCondition:
      return "condition";
    case Criterion::kWorstTotal:
      return "worst_total_std_um";
  }
  return "?";
}

namespace {

// Fills the choice's placements and continuous space from the pattern (PatternChoice).
void resolve(const Kit& kit, PatternChoice& c) {
  const std::vector<int> included = included_positions(kit, c.n_optional);
  auto variable = [&](const PatternCoordinate& co, const Interval& range) {
    if (!co.is_variable()) return -1;
    const auto it = std::find(c.space.names.begin(), c.space.names.end(), co.variable);
    if (it != c.space.names.end()) return static_cast<int>(it - c.space.names.begin());
    c.space.names.push_back(co.variable);
    c.space.lower.push_back(range.min);
    c.space.upper.push_back(range.max);
    return static_cast<int>(c.space.names.size()) - 1;
  };
  // The continuous coordinates (all but a table's heights), in the order L, D, H.
  const int hc = height_coordinate(kit);
  auto continuous = [&](const PatternPosition& p, int coordinate) {
    return coordinate == hc || (coordinate == 2 && !kit.axis.has_H())
               ? -1
               : variable(coordinate_of(p, coordinate), coordinate_range(kit, coordinate));
  };
  for (int i : included) {
    PatternChoice::Placement pl;
    pl.position = i;
    pl.L = continuous(kit.pattern.positions[i], 0);
    c.placements.push_back(pl);
  }
  for (PatternChoice::Placement& pl : c.placements)
    pl.D = continuous(kit.pattern.positions[pl.position], 1);
  for (PatternChoice::Placement& pl : c.placements)
    pl.H = continuous(kit.pattern.positions[pl.position], 2);
  if (hc < 0) return;
  for (PatternChoice::Placement& pl : c.placements) {
    const PatternCoordinate& height = height_of(kit, kit.pattern.positions[pl.position]);
    double h = height.value;
    for (const PatternChoice::Height& ch : c.heights) {
      if (height.is_variable() && ch.variable == height.variable) h = ch.height_mm;
    }
    pl.height = height_to_coordinate(kit, h);
  }
}

}  // namespace

std::vector<PatternChoice> pattern_choices(const Kit& kit) {
  std::vector<PatternChoice> out;
  const std::vector<Stack> stacks = kit.axis.table() ? block_stacks(kit) : std::vector<Stack>{};
  const int n_offered = static_cast<int>(offered_optional_positions(kit).size());
  for (int n_opt = 0; n_opt <= n_offered; ++n_opt) {
    // The height variables of the positions included, in the order they first appear.
    std::vector<std::string> vars;
    for (int i : included_positions(kit, n_opt)) {
      if (!kit.axis.table()) break;
      const PatternCoordinate& h = height_of(kit, kit.pattern.positions[i]);
      if (h.is_variable() && std::find(vars.begin(), vars.end(), h.variable) == vars.end())
        vars.push_back(h.variable);
    }
    // Every assignment of a stack to each variable (the first variable outermost), less
    // those that give two variables of a distinct group the same height.
    std::vector<int> idx(vars.size(), 0);
    while (true) {
      bool ok = true;
      // Interchangeable positions: one labelling of each set of heights (ascending).
      if (kit.pattern.interchangeable) ok = std::is_sorted(idx.begin(), idx.end());
      for (const std::vector<std::string>& group : kit.pattern.distinct) {
        for (size_t a = 0; a < group.size() && ok; ++a) {
          for (size_t b = 0; b < a && ok; ++b) {
            const auto ia = std::find(vars.begin(), vars.end(), group[a]),
                       ib = std::find(vars.begin(), vars.end(), group[b]);
            if (ia != vars.end() && ib != vars.end() &&
                idx[ia - vars.begin()] == idx[ib - vars.begin()])
              ok = false;
          }
        }
      }
      if (ok) {
        PatternChoice c;
        c.n_optional = n_opt;
        for (size_t v = 0; v < vars.size(); ++v)
          c.heights.push_back({vars[v], idx[v], stacks[idx[v]].height_mm});
        resolve(kit, c);
        for (double step : kit.angle_steps_deg) {
          if (kit.angle_max_step_deg && step > *kit.angle_max_step_deg + kAngleTolerance_deg)
            continue;  // coarser than the user accepts
          c.step_deg = step;
          out.push_back(c);
        }
      }
      int k = static_cast<int>(vars.size()) - 1;
      while (k >= 0 && ++idx[k] == static_cast<int>(stacks.size())) idx[k--] = 0;
      if (k < 0) break;
    }
  }
  return out;
}

std::string choice_label(const Kit& kit, const PatternChoice& c) {
  std::string t;
  if (kit.axis.table()) {
    const std::vector<Stack> stacks = block_stacks(kit);
    for (const PatternChoice::Height& h : c.heights)
      t += h.variable + " = " + kit_stack_text(kit, stacks[h.stack]) + ", ";
  }
  t += "step " + mm(c.step_deg) + " deg";
  const std::vector<int> offered = offered_optional_positions(kit);
  if (c.n_optional > 0) {
    t += ", adds";
    if (kit.instrument == InstrumentKind::kProbe) t += c.n_optional == 1 ? " sphere" : " spheres";
    for (int k = 0; k < c.n_optional; ++k) {
      const PatternPosition& p = kit.pattern.positions[offered[k]];
      if (kit.instrument == InstrumentKind::kProbe) t += " " + p.id;
      for (Direction::Kind d : p.directions) t += " " + installation_id(p, d);
    }
  }
  return t;
}

namespace {

// What make_candidate builds independently of the point: the choice, the design's
// description, angles and installations (positions, bars and scores are place_candidate's).
Candidate candidate_skeleton(const Kit& kit, const PatternChoice& choice) {
  Candidate c;
  c.choice = choice;
  Design& d = c.design;
  d.axis = kit.axis;
  d.machine = kit.machine;
  d.name = kit.name.empty() ? "optimized" : kit.name + std::string(limits::kOptimizedSuffix);
  d.angles_deg = kit_angles(kit, choice.step_deg);
  d.noise = kit.noise;
  d.errors = kit.errors;
  d.reference_length_mm = kit.reference_length_mm;
  d.setup_std = kit.setup_std;
  d.return_reading = kit.return_reading;
  d.instrument = kit.instrument;
  if (kit.instrument == InstrumentKind::kProbe) {
    // A position is a sphere; its channels are the design's installations (placed with it).
    for (const PatternChoice::Placement& pl : choice.placements) {
      d.spheres.push_back(Sphere{kit.pattern.positions[pl.position].id, 0, 0, 0, {}});
      for (int k = 0; k < 3; ++k) c.installation_position.push_back(pl.position);
    }
    d.installations = probe_channels(d.axis, d.spheres);
    return c;
  }
  for (const PatternChoice::Placement& pl : choice.placements) {
    const PatternPosition& p = kit.pattern.positions[pl.position];
    for (Direction::Kind kind : p.directions) {
      Installation in;
      in.id = installation_id(p, kind);
      in.direction = Direction::named(kit.axis, kind);
      d.installations.push_back(std::move(in));
      c.installation_position.push_back(pl.position);
    }
  }
  return c;
}

// The candidate c (candidate_skeleton's for its choice, or a candidate placed before) at the
// point x: positions, bars and signs fitted to the travel, violations, time; its scores as a
// new candidate's (unscored). The point's storage is reused.
void place_candidate(const Kit& kit, Candidate& c, const std::vector<double>& x) {
  c.x = x;
  Design& d = c.design;
  c.separation_violation_mm = -std::numeric_limits<double>::infinity();
  struct Placed {
    double L, D, H;
  };
  // A placement's ball at x: its variables, or the position's fixed values.
  const int hc = height_coordinate(kit);
  const auto placed = [&](const PatternChoice::Placement& pl) {
    const PatternPosition& p = kit.pattern.positions[pl.position];
    double at[3] = {pl.L >= 0 ? x[pl.L] : p.L.value, pl.D >= 0 ? x[pl.D] : p.D.value,
                    pl.H >= 0 ? x[pl.H] : p.H.value};
    if (hc >= 0) at[hc] = pl.height;
    return Placed{at[0], at[1], at[2]};
  };
  size_t k = 0;
  const bool probe = kit.instrument == InstrumentKind::kProbe;
  const std::vector<PatternChoice::Placement>& placements = c.choice.placements;
  for (size_t i = 0; i < placements.size(); ++i) {
    const PatternPosition& p = kit.pattern.positions[placements[i].position];
    const Placed at = placed(placements[i]);
    if (p.separated) {
      // Against the separated positions before it, in order.
      for (size_t j = 0; j < i; ++j) {
        if (!kit.pattern.positions[placements[j].position].separated) continue;
        const Placed b = placed(placements[j]);
        // Two spheres' stands stand side by side on the table: apart in its plane (the height
        // coordinate left out); two balls anywhere.
        const double dL = probe && hc == 0 ? 0.0 : at.L - b.L,
                     dH = probe && hc == 2 ? 0.0 : at.H - b.H;
        const double dist = std::hypot(dL, at.D - b.D, dH);
        c.separation_violation_mm =
            std::max(c.separation_violation_mm, kit.min_separation_mm - dist);
      }
    }
    if (probe) {
      Sphere& sp = d.spheres[i];
      sp.L_mm = at.L;
      sp.D_mm = at.D;
      sp.H_mm = at.H;
    }
    const size_t n_installations = probe ? 3 : p.directions.size();
    for (size_t n = 0; n < n_installations; ++n, ++k) {
      Installation& in = d.installations[k];
      in.L_mm = at.L;
      in.D_mm = at.D;
      in.H_mm = at.H;
    }
  }
  c.travel_violation_mm = probe ? fit_spheres(kit, d) : fit_bars(kit, d);
  c.machine_clash.clear();
  if (kit.machine && c.travel_violation_mm <= kGeometryTolerance_mm) {
    // What the program on the machine refuses (its linear travel, the table, the solids such as
    // a cradle's cheeks), the search does not offer: such a point lies outside by a millimetre.
    try {
      ProgramOptions o;
      o.path_tolerance_mm = limits::kMaxPathTolerance_mm;
      measurement_program(d, o);
    } catch (const InputError& e) {
      c.machine_clash = e.detail();
      c.travel_violation_mm = std::max(c.travel_violation_mm, kMachineClash_mm);
    }
  }
  c.time_s = design_time_s(kit, d);
  c.feasible = c.travel_violation_mm <= kGeometryTolerance_mm &&
               c.separation_violation_mm <= kGeometryTolerance_mm &&
               (!kit.time_budget_s || c.time_s <= *kit.time_budget_s);
  c.worst = WorstCase{};
  c.n_undetermined = 0;
  c.objective = 0;
  c.objective_defined = false;
  c.detection.reset();
}

}  // namespace

Candidate make_candidate(const Kit& kit, const PatternChoice& choice,
                         const std::vector<double>& x) {
  Candidate c = candidate_skeleton(kit, choice);
  place_candidate(kit, c, x);
  return c;
}

void describe_installations(const Kit& kit, Candidate& c) {
  std::vector<Stack> stacks;
  if (kit.axis.table()) stacks = block_stacks(kit);
  if (kit.instrument == InstrumentKind::kProbe) {
    // A sphere's stand: its height variable's stack (no bar, no cup).
    for (size_t i = 0; i < c.design.spheres.size(); ++i) {
      const PatternPosition& p = kit.pattern.positions[c.choice.placements[i].position];
      const PatternCoordinate& height = height_of(kit, p);
      std::string t = "the sphere's stand at " + mm(height.value) + " mm (fixed by the pattern)";
      for (const PatternChoice::Height& h : c.choice.heights)
        if (height.is_variable() && h.variable == height.variable)
          t = h.variable + " = " + kit_stack_text(kit, stacks[h.stack]);
      c.design.spheres[i].description = t;
    }
    return;
  }
  for (size_t k = 0; k < c.design.installations.size(); ++k) {
    Installation& in = c.design.installations[k];
    const PatternPosition& p = kit.pattern.positions[c.installation_position[k]];
    std::string t;
    in.cup_mm.reset();
    in.blocks_mm.clear();
    if (kit.axis.table()) {
      // A design states its cup and blocks (stack_mm) where its H is their height; on another
      // table the stack is said in words.
      const bool stack_mm = stack_is_H(kit);
      const PatternCoordinate& height = height_of(kit, p);
      if (height.is_variable()) {
        for (const PatternChoice::Height& h : c.choice.heights) {
          if (h.variable != height.variable) continue;
          t = h.variable + " = " + kit_stack_text(kit, stacks[h.stack]);
          if (!stack_mm) continue;
          in.cup_mm = kit.H_base_mm;
          in.blocks_mm = stacks[h.stack].blocks_mm;
        }
      } else {
        // The pattern's height is the cup's above the table: the design's H only on the "C"
        // shorthand (elsewhere H or L also holds the surface, and its sign the normal's).
        t = std::string(stack_mm ? "H" : "the height above the table") + " = " + mm(height.value) +
            " mm (fixed by the pattern)";
        if (const std::optional<Stack> st = stack_of_height(stacks, height.value); st && stack_mm) {
          in.cup_mm = kit.H_base_mm;
          in.blocks_mm = st->blocks_mm;
        }
      }
      if (height_coordinate(kit) == 2 && !p.L.is_variable() && !p.D.is_variable() &&
          p.L.value == 0 && p.D.value == 0)
        t += ", on the axis";
    } else {
      t = off_axis(kit, p) ? "off the tool axis" : "on the tool axis";
    }
    in.bar_parts_mm = bar_parts(kit, *in.bar_mm);
    t += ", bar " + mm(*in.bar_mm) + " mm";
    if (in.bar_parts_mm.size() > 1) {
      t += " (";
      for (size_t i = 0; i < in.bar_parts_mm.size(); ++i)
        t += (i ? " + " : "") + mm(in.bar_parts_mm[i]);
      t += ")";
    }
    in.description = t;
  }
}

std::string added_installations(const Kit& kit, const Candidate& c) {
  std::string t;
  if (kit.instrument == InstrumentKind::kProbe) {
    for (const PatternChoice::Placement& pl : c.choice.placements)
      if (kit.pattern.positions[pl.position].optional)
        t += (t.empty() ? "" : " ") + kit.pattern.positions[pl.position].id;
    return t.empty() ? "-" : t;
  }
  for (size_t k = 0; k < c.design.installations.size(); ++k) {
    if (kit.pattern.positions[c.installation_position[k]].optional)
      t += (t.empty() ? "" : " ") + c.design.installations[k].id;
  }
  return t.empty() ? "-" : t;
}

void score_candidate(const Kit& kit, Criterion criterion, Candidate& c) {
  if (criterion == Criterion::kWorst) {
    c.worst = design_worst_case(c.design, kit.reference_length_mm);
    c.n_undetermined = c.worst.n_undetermined;
    const std::optional<double> v =
        c.worst.worst_std_um ? c.worst.worst_std_um : c.worst.worst_determined_std_um;
    c.objective_defined = v.has_value();
    c.objective = v.value_or(0.0);
    return;
  }
  if (criterion == Criterion::kWorstTotal) {
    const TotalWorstCase t = design_worst_total(c.design, kit.reference_length_mm);
    c.worst = *t.noise;
    c.n_undetermined = t.total.n_undetermined;
    const std::optional<double> v =
        t.total.worst_std_um ? t.total.worst_std_um : t.total.worst_determined_std_um;
    c.objective_defined = v.has_value();
    c.objective = v.value_or(0.0);
    return;
  }
  const Evaluation ev = evaluate_design(c.design, kit.reference_length_mm, {}, {}, std::nullopt);
  c.worst = ev.worst;
  c.n_undetermined = ev.worst.n_undetermined;
  std::optional<double> v;
  switch (criterion) {
    case Criterion::kD:
      if (ev.criteria.D_logdet) v = -*ev.criteria.D_logdet;
      break;
    case Criterion::kA:
      v = ev.criteria.A_trace;
      break;
    case Criterion::kE:
      if (ev.prior.rank == ev.prior.n_unknowns) v = -ev.criteria.E_min_eigenvalue;
      break;
    case Criterion::kCondition:
      if (ev.prior.rank == ev.prior.n_unknowns) v = ev.prior.condition_number;
      break;
    case Criterion::kWorst:
    case Criterion::kWorstTotal:
      break;
  }
  c.objective_defined = v.has_value();
  c.objective = v.value_or(0.0);
}

bool better(const Candidate& a, const Candidate& b) {
  if (a.feasible != b.feasible) return a.feasible;
  if (!a.feasible) {  // the less infeasible: in geometry (mm), then in detection
    const double ga = std::max({a.travel_violation_mm, a.separation_violation_mm, 0.0});
    const double gb = std::max({b.travel_violation_mm, b.separation_violation_mm, 0.0});
    if (ga != gb) return ga < gb;
    return detection_violation(a) < detection_violation(b);
  }
  if (a.n_undetermined != b.n_undetermined) return a.n_undetermined < b.n_undetermined;
  if (a.objective_defined != b.objective_defined) return a.objective_defined;
  // Objectives that tie (kCandidateTie): the shorter measurement is better.
  if (std::abs(a.objective - b.objective) >
      kCandidateTie * std::max(std::abs(a.objective), std::abs(b.objective))) {
    return a.objective < b.objective;
  }
  return a.time_s < b.time_s;
}

const char* choice_state_name(ChoiceState s) {
  switch (s) {
    case ChoiceState::kSearched:
      return "searched";
    case ChoiceState::kOverTimeBudget:
      return "over time budget";
    case ChoiceState::kUndetectableEverywhere:
      return "undetectable everywhere";
    case ChoiceState::kOutsideTravel:
      return "outside travel";
    case ChoiceState::kTooClose:
      return "too close";
    case ChoiceState::kSetupNotDetected:
      return "set-up not detected";
    case ChoiceState::kNoFeasiblePosition:
      return "no feasible position";
  }
  return "unknown";
}

OptimizeResult optimize_kit(const Kit& kit, const OptimizeOptions& options) {
  return search_all(
      kit, options.criterion, options.threads, [&](ChoiceSearch& s) { s.run(options); },
      options.progress);
}

OptimizeResult exhaustive_search(const Kit& kit, Criterion criterion, double grid_mm, int threads) {
  return search_all(kit, criterion, threads, [&](ChoiceSearch& s) { s.grid(grid_mm); }, {});
}

Reference make_reference(const Kit& kit, Design design, const std::string& file) {
  if (design.instrument != kit.instrument)
    throw InputError(file, "instrument.kind",
                     std::string("the reference is a ") + instrument_info(design.instrument).name +
                         " design, the kit a " + instrument_info(kit.instrument).name +
                         " kit: the ratio would compare instruments, not designs");
  Reference r;
  r.file = file;
  r.design = std::move(design);
  if (!r.design.axis.same_as(kit.axis)) {
    throw InputError(file, "axis",
                     "the reference is for axis " + std::string(r.design.axis.label()) +
                         ", the kit for axis " + kit.axis.label());
  }
  if (std::abs(r.design.noise.sigma_um() - kit.noise.sigma_um()) >
      kSameNoiseRelative * kit.noise.sigma_um()) {
    throw InputError(file, "noise",
                     "declares " + r.design.noise.describe() + ", the kit " + kit.noise.describe() +
                         ": the ratio would compare instruments, not designs");
  }
  if (r.design.errors.kind != kit.errors.kind || r.design.errors.order != kit.errors.order) {
    throw InputError(
        file, "errors",
        "the reference uses " + r.design.errors.describe() + ", the kit " + kit.errors.describe());
  }
  const Evaluation ev = evaluate_design(r.design, kit.reference_length_mm, {}, {}, std::nullopt);
  r.worst = ev.worst;
  if (kit.setup_std.nuisance()) {
    Design with = r.design;
    if (!with.setup_nuisance_declared()) with.setup_std = kit.setup_std;
    r.worst_total = design_worst_total(with, kit.reference_length_mm).total;
  }
  r.rank = ev.prior.rank;
  r.n_unknowns = ev.prior.n_unknowns;
  return r;
}

ReferenceRatios reference_ratios(const OptimizeResult& res, const Reference& reference) {
  ReferenceRatios r;
  if (!res.best) return r;
  const Evaluation& ev = res.best_evaluation;
  if (ev.worst.worst_std_um && reference.worst.worst_std_um)
    r.worst_std_um = *ev.worst.worst_std_um / *reference.worst.worst_std_um;
  if (ev.worst_total && ev.worst_total->worst_std_um && reference.worst_total &&
      reference.worst_total->worst_std_um)
    r.worst_total_std_um = *ev.worst_total->worst_std_um / *reference.worst_total->worst_std_um;
  return r;
}

std::vector<BindingConstraint> binding_constraints(const Kit& kit, const OptimizeResult& res) {
  std::vector<BindingConstraint> out;
  // How near a choice is to fitting, in the measure of its state (smaller is nearer).
  auto distance = [](const ChoiceResult& cr) {
    switch (cr.state) {
      case ChoiceState::kOverTimeBudget:
        return cr.time_s;
      case ChoiceState::kOutsideTravel:
        return cr.best ? cr.best->travel_violation_mm : 0.0;
      case ChoiceState::kTooClose:
        return cr.best ? cr.best->separation_violation_mm : 0.0;
      case ChoiceState::kSetupNotDetected:
        return cr.best && cr.best->detection ? cr.best->detection->ratio : 0.0;
      default:
        return 0.0;
    }
  };
  for (int i = 0; i < static_cast<int>(res.choices.size()); ++i) {
    const ChoiceResult& cr = res.choices[i];
    if (cr.state == ChoiceState::kSearched) continue;
    auto it = std::find_if(out.begin(), out.end(),
                           [&](const BindingConstraint& b) { return b.state == cr.state; });
    if (it == out.end()) {
      out.push_back({cr.state, 0, i});
      it = out.end() - 1;
    }
    ++it->choices;
    if (distance(cr) < distance(res.choices[it->closest])) it->closest = i;
  }
  for (BindingConstraint& b : out) {
    if (b.state != ChoiceState::kOverTimeBudget) continue;
    const ChoiceResult& cr = res.choices[b.closest];
    const Candidate probe = make_candidate(kit, cr.choice, cr.choice.space.lower);
    const TimeEstimate t = design_time(kit, probe.design);
    b.time_s = probe.time_s;
    b.positions = t.positions;
    b.installations = t.installations;
    b.readings = t.readings;
  }
  std::stable_sort(
      out.begin(), out.end(),
      [](const BindingConstraint& a, const BindingConstraint& b) { return a.choices > b.choices; });
  return out;
}

std::vector<int> runner_up_choices(const OptimizeResult& res, int n) {
  std::vector<int> out;
  if (!res.best) return out;
  // What a person changes at the machine: the block stacks (C), else the step and the
  // optional positions.
  auto key = [](const PatternChoice& c) {
    std::vector<double> k;
    for (const PatternChoice::Height& h : c.heights) k.push_back(h.stack);
    if (k.empty()) k = {c.step_deg, static_cast<double>(c.n_optional)};
    return k;
  };
  const std::vector<double> best_key = key(res.best->choice);
  std::map<std::vector<double>, int> best_of;
  for (int i = 0; i < static_cast<int>(res.choices.size()); ++i) {
    const ChoiceResult& cr = res.choices[i];
    if (cr.state != ChoiceState::kSearched || !cr.best || !cr.best->objective_defined ||
        cr.best->n_undetermined != res.best->n_undetermined)
      continue;
    const std::vector<double> k = key(cr.choice);
    if (k == best_key) continue;
    auto it = best_of.find(k);
    // As for the best: between objectives within kObjectiveTie the shorter measurement.
    if (it == best_of.end() || better_choice(*cr.best, *res.choices[it->second].best))
      best_of[k] = i;
  }
  for (const auto& [k, i] : best_of) out.push_back(i);
  std::stable_sort(out.begin(), out.end(), [&](int a, int c) {
    return better(*res.choices[a].best, *res.choices[c].best);
  });
  if (static_cast<int>(out.size()) > n) out.resize(n);
  return out;
}

}  // namespace dbbkit
