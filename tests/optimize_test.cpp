// The design search: the fast worst case against the full evaluation, the
// kit's geometry (block stacks, travel), and the search against exhaustive
// enumeration on small kits whose travel limits bind.

#include "dbbkit/optimize.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <numeric>
#include <random>
#include <set>

#include "../src/setup_solver.hpp"
#include "dbbkit/diagnose.hpp"
#include "dbbkit/error.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/kit_io.hpp"
#include "dbbkit/io/optimize_io.hpp"
#include "dbbkit/io/result_io.hpp"
#include "dbbkit/kinematics.hpp"
#include "dbbkit/user_text.hpp"
#include "test_util.hpp"

namespace dbbkit {
namespace {

Design random_design(std::mt19937& rng, const AxisFrame& axis) {
  std::uniform_real_distribution<double> L(0, 300), D(-80, 80), H(0, 200), unit(-1, 1);
  Design d;
  d.axis = axis;
  d.angles_deg = axis == test::kAxisC ? std::vector<double>{0, 30, 60, 90, 135, 200, 270, 330, 360}
                                      : std::vector<double>{-100, -75, -50, -20, 0};
  d.noise.half_width_um = 1.0 + unit(rng) * 0.5;
  const int n = 6 + static_cast<int>(rng() % 4);
  for (int i = 0; i < n; ++i) {
    Installation in;
    in.id = "i" + std::to_string(i);
    in.L_mm = axis == test::kAxisC ? L(rng) : 50 + L(rng);
    in.D_mm = D(rng);
    in.H_mm = axis == test::kAxisC ? H(rng) : 0.0;
    if (rng() % 2) {
      in.direction = Direction::named(axis, static_cast<Direction::Kind>(rng() % 3));
    } else {
      in.direction =
          Direction::vector(Eigen::Vector3d(unit(rng), unit(rng), unit(rng)).normalized());
    }
    in.sign = rng() % 2 ? 1 : -1;
    if (!table_ball_beyond_tool(axis, in.direction, in.sign))
      in.sign = -in.sign;  // beyond the tool
    d.installations.push_back(in);
  }
  validate_design(d);
  return d;
}

TEST(FastWorstCase, MatchesTheFullEvaluation) {
  std::mt19937 rng(7);
  int fast = 0;
  for (int t = 0; t < 300; ++t) {
    const AxisFrame& axis = t % 2 ? test::kAxisC : test::kAxisB;
    Design d = random_design(rng, axis);
    if (t % 3 == 1) {  // a series model on a third of the designs
      d.errors = {axis == test::kAxisC ? ErrorModel::Kind::kFourier : ErrorModel::Kind::kLegendre,
                  static_cast<int>(rng() % 3)};
    }
    const std::optional<WorstCase> w = fast_worst_case(d, 120.0);
    const Evaluation ev = evaluate_design(d, 120.0);
    if (!w) continue;
    ++fast;
    ASSERT_TRUE(ev.worst.worst_std_um)
        << "the fast path answered for a design the full path finds rank-deficient";
    EXPECT_NEAR(*w->worst_std_um, *ev.worst.worst_std_um, 1e-9 * *ev.worst.worst_std_um);
  }
  EXPECT_GT(fast,
            250);  // random designs with six or more installations are almost always full rank
}

TEST(FastWorstTotal, MatchesTheStackedSetupSolver) {
  // The per-angle Schur path against SetupSolver on the stacked model: random designs with
  // random length offset and centring tolerances, a default and per-installation overrides
  // (some installations without any), both axes, general directions and signs.
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> unit(0, 1);
  int fast = 0;
  double worst_total_rel = 0, worst_noise_rel = 0;
  for (int t = 0; t < 120; ++t) {
    const AxisFrame& axis = t % 2 ? test::kAxisC : test::kAxisB;
    Design d = random_design(rng, axis);
    d.setup_std.length_offset_um = t % 3 == 0 ? 0.0 : 20 * unit(rng);
    d.setup_std.centring_um = t % 3 == 1 ? 0.0 : 10 * unit(rng);
    for (Installation& in : d.installations) {
      if (rng() % 3 == 0) in.setup_std.centring_um = 30 * unit(rng);
      if (rng() % 4 == 0) in.setup_std.length_offset_um = 0.0;
    }
    if (!d.setup_nuisance_declared()) continue;
    const std::optional<TotalWorstCase> f = fast_worst_total(d, 120.0);
    const TotalWorstCase ref = dense_worst_total(d, 120.0);
    if (!f) continue;
    ++fast;
    ASSERT_TRUE(ref.total.worst_std_um)
        << "the fast path answered for a design the stacked path finds rank-deficient";
    // Rounding only;
    // where the worst case is reached is not compared: symmetric designs reach it at
    // several angles, and rounding picks one.
    EXPECT_NEAR(*f->total.worst_std_um, *ref.total.worst_std_um, 1e-9 * *ref.total.worst_std_um)
        << t;
    worst_total_rel =
        std::max(worst_total_rel, std::abs(*f->total.worst_std_um / *ref.total.worst_std_um - 1));
    worst_noise_rel =
        std::max(worst_noise_rel, std::abs(*f->noise->worst_std_um - *ref.noise->worst_std_um) /
                                      *ref.total.worst_std_um);
    EXPECT_NEAR(*f->noise->worst_std_um, *ref.noise->worst_std_um, 1e-9 * *ref.total.worst_std_um)
        << t;
    EXPECT_GT(*f->total.worst_std_um, *f->noise->worst_std_um);  // a declared tolerance adds
  }
  EXPECT_GT(fast, 60);
  std::cout << "fast_worst_total against the stacked path over " << fast
            << " designs: largest relative difference " << worst_total_rel << " (total), "
            << worst_noise_rel << " (noise part, relative to the total)\n";
  // At the limits of a declared tolerance (README, "Limits"): a prior far above what the
  // readings leave (10 mm, the total near the prior) and far below (1 nm, the total near
  // the noise part) give the stacked path's total.
  for (double u : {1e4, 1e-3}) {
    Design e = test::paper_design('C');
    e.setup_std.length_offset_um = e.setup_std.centring_um = u;
    const std::optional<TotalWorstCase> f = fast_worst_total(e, 100.0);
    ASSERT_TRUE(f) << u;
    const TotalWorstCase ref = dense_worst_total(e, 100.0);
    EXPECT_NEAR(*f->total.worst_std_um, *ref.total.worst_std_um, 1e-9 * *ref.total.worst_std_um)
        << u;
  }
  // Without tolerances the total is the noise-only fast worst case; a series model declines.
  Design c = test::paper_design('C');
  ASSERT_TRUE(fast_worst_total(c, 100));
  EXPECT_EQ(*fast_worst_total(c, 100)->total.worst_std_um, *fast_worst_case(c, 100)->worst_std_um);
  c.setup_std.centring_um = 5;
  c.errors = {ErrorModel::Kind::kFourier, 2};
  EXPECT_FALSE(fast_worst_total(c, 100));
  EXPECT_TRUE(design_worst_total(c, 100).total.worst_std_um);
}

TEST(FastSetupInformation, MatchesTheStackedModel) {
  // What the readings keep of each declared set-up effect after the axis errors (r^2, its
  // directions, detectable) in closed form against the SVD of the stacked residual.
  std::mt19937 rng(23);
  std::uniform_real_distribution<double> unit(0, 1);
  int fast = 0, detectable = 0, not_detectable = 0;
  for (int t = 0; t < 80; ++t) {
    const AxisFrame& axis = t % 2 ? test::kAxisC : test::kAxisB;
    Design d = random_design(rng, axis);
    d.setup_std.length_offset_um = t % 3 == 0 ? 0.0 : 1 + 20 * unit(rng);
    d.setup_std.centring_um = t % 3 == 1 ? 0.0 : 1 + 10 * unit(rng);
    for (Installation& in : d.installations) {
      if (rng() % 4 == 0) in.setup_std.length_offset_um = 0.0;
      if (rng() % 5 == 0) {  // the same direction twice: a duplicated reading
        in = d.installations.front();
        in.id = "dup" + std::to_string(rng());
      }
    }
    validate_design(d);
    if (!d.setup_nuisance_declared()) continue;
    const std::optional<SetupInformation> f = fast_setup_information(d);
    if (!f) continue;
    ++fast;
    const SetupInformation ref = dense_setup_information(d);
    EXPECT_EQ(f->n_readings, ref.n_readings);
    EXPECT_EQ(f->rank, ref.rank);
    ASSERT_EQ(f->effects.size(), ref.effects.size()) << t;
    for (size_t k = 0; k < ref.effects.size(); ++k) {
      const SetupEffectInformation &a = f->effects[k], &b = ref.effects[k];
      EXPECT_EQ(a.kind, b.kind);
      EXPECT_EQ(a.installation, b.installation);
      EXPECT_EQ(a.q, b.q) << t << " " << k;
      EXPECT_EQ(a.detectable, b.detectable) << t << " " << k;
      if (a.detectable && b.detectable) {
        EXPECT_NEAR(a.min_information, b.min_information, 1e-9 * b.min_information)
            << t << " " << k;
      }
      (b.detectable ? detectable : not_detectable) += 1;
    }
  }
  std::cout << "fast_setup_information against the stacked model: " << fast << " designs, "
            << detectable << " effects detectable, " << not_detectable << " not\n";
  EXPECT_GT(fast, 40);
  EXPECT_GT(detectable, 50);      // both outcomes are met: six installations leave nothing to
  EXPECT_GT(not_detectable, 20);  // detect, a duplicated reading leaves its pair
  // The paper's C design has 7 installations: one redundancy per angle, between 1r and 2r
  // (the two radial readings at one height); every other effect is taken by the axis errors.
  Design c = test::paper_design('C');
  c.setup_std.length_offset_um = 10;
  c.setup_std.centring_um = 5;
  const SetupInformation info = design_setup_information(c);
  for (const SetupEffectInformation& e : info.effects) {
    const std::string& id = c.installations[e.installation].id;
    EXPECT_EQ(e.detectable, id == "1r" || id == "2r") << id << " " << effect_name(e.kind);
  }
}

TEST(AngleStations, GivenStationsGiveTheSameAnswersAndOthersAreNotUsed) {
  // A search forms the stations of its angles once: the fast paths answer exactly as with
  // their own, and stations of other angles or another axis are passed over.
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> unit(0, 1);
  for (int t = 0; t < 40; ++t) {
    const AxisFrame& axis = t % 2 ? test::kAxisC : test::kAxisB;
    Design d = random_design(rng, axis);
    if (t % 4 < 2) {  // repeated angles and angles a turn apart are one station
      d.angles_deg.push_back(d.angles_deg[1]);
      if (axis == test::kAxisC) d.angles_deg.push_back(d.angles_deg[2] + 360);
    }
    if (t % 3) {
      d.setup_std.length_offset_um = 20 * unit(rng);
      d.setup_std.centring_um = 10 * unit(rng);
    }
    const AngleStations own(axis, d.angles_deg);
    ASSERT_TRUE(own.serves(d));
    EXPECT_EQ(std::accumulate(own.count.begin(), own.count.end(), 0),
              static_cast<int>(d.angles_deg.size()));
    std::vector<double> shifted = d.angles_deg;
    shifted.back() += 1;
    const AngleStations other(axis, shifted);
    const AngleStations turned(axis == test::kAxisC ? test::kAxisB : test::kAxisC, d.angles_deg);
    EXPECT_FALSE(other.serves(d));
    EXPECT_FALSE(turned.serves(d));
    const std::optional<TotalWorstCase> ref = fast_worst_total(d, 100.0);
    for (const AngleStations* s : {&own, &other, &turned}) {
      const std::optional<TotalWorstCase> f = fast_worst_total(d, 100.0, true, s);
      ASSERT_EQ(f.has_value(), ref.has_value()) << t;
      if (!f) continue;
      EXPECT_EQ(f->total.worst_std_um, ref->total.worst_std_um) << t;
      EXPECT_EQ(f->total.at_angle_deg, ref->total.at_angle_deg) << t;
      EXPECT_EQ(f->noise->worst_std_um, ref->noise->worst_std_um) << t;
      const std::optional<SetupInformation> a = fast_setup_information(d),
                                            b = fast_setup_information(d, s);
      ASSERT_EQ(a.has_value(), b.has_value());
      if (!a) continue;
      ASSERT_EQ(a->effects.size(), b->effects.size());
      for (size_t k = 0; k < a->effects.size(); ++k)
        EXPECT_EQ(a->effects[k].min_information, b->effects[k].min_information);
    }
    d.setup_std = {};
    const std::optional<WorstCase> w = fast_worst_case(d, 100.0);
    for (const AngleStations* s : {&own, &other, &turned}) {
      const std::optional<WorstCase> f = fast_worst_case(d, 100.0, s);
      ASSERT_EQ(f.has_value(), w.has_value());
      if (f) EXPECT_EQ(f->worst_std_um, w->worst_std_um);
    }
  }
}

TEST(FastWorstCase, DeclinesRankLossAndAnswersSeries) {
  const Design b = test::paper_design('B');  // both balls on the tool axis: rank 5 at every angle
  EXPECT_FALSE(fast_worst_case(b, 100));
  const WorstCase w = design_worst_case(b, 100);
  EXPECT_FALSE(w.worst_std_um);
  EXPECT_GT(w.n_undetermined, 0);
  Design c = test::paper_design('C');
  ASSERT_TRUE(fast_worst_case(c, 100));
  EXPECT_NEAR(*fast_worst_case(c, 100)->worst_std_um, *evaluate_design(c, 100).worst.worst_std_um,
              1e-12);
  c.errors = {ErrorModel::Kind::kFourier, 2};
  ASSERT_TRUE(fast_worst_case(c, 100));
  EXPECT_NEAR(*fast_worst_case(c, 100)->worst_std_um, *evaluate_design(c, 100).worst.worst_std_um,
              1e-12);
  // Order 9 on 20 deg steps: sin 9g is 0 at every measured angle, so its coefficients are not
  // determined (rank 108 of 114); the fast path declines and the general solver answers.
  c.errors = {ErrorModel::Kind::kFourier, 9};
  EXPECT_FALSE(fast_worst_case(c, 100));
  const Evaluation ev = evaluate_design(c, 100);
  EXPECT_EQ(ev.prior.n_unknowns - ev.prior.rank, 6);
  EXPECT_NEAR(design_worst_case(c, 100).worst_std_um.value_or(-1),
              ev.worst.worst_std_um.value_or(-1), 1e-12);
}

Kit formats_kit() {
  return io::read_kit_file(test::source_path("designs/kits/c-turntable-kit.json"));
}

Kit small_c_kit() { return test::small_c_kit(); }

Kit small_b_kit() { return test::small_b_kit(); }

void expect_no_better_grid_point(const Kit& kit, double grid_mm) {
  const OptimizeResult opt = optimize_kit(kit, {Criterion::kWorst, 2});
  const OptimizeResult grid = exhaustive_search(kit, Criterion::kWorst, grid_mm, 2);
  ASSERT_TRUE(opt.best && grid.best);
  EXPECT_TRUE(opt.best->feasible);
  EXPECT_EQ(opt.best->n_undetermined, grid.best->n_undetermined);
  EXPECT_LE(opt.best->objective, 1.005 * grid.best->objective)
      << "a grid point is more than 0.5% better: " << grid.best->objective << " um vs "
      << opt.best->objective;
  // The travel binds: it is active at the optimum, and relaxing it lets the search do better.
  EXPECT_GT(opt.best->travel_violation_mm, -0.5);
  Kit relaxed = kit;
  relaxed.travel_mm = {Interval{-2000, 2000}, Interval{-2000, 2000}, Interval{-2000, 2000}};
  const OptimizeResult free = optimize_kit(relaxed, {Criterion::kWorst, 2});
  ASSERT_TRUE(free.best);
  EXPECT_LT(free.best->objective, 0.99 * opt.best->objective);
  std::cout << kit.name << ": optimize " << opt.best->objective << " um (" << opt.evaluations
            << " designs), grid " << grid_mm << " mm " << grid.best->objective << " um ("
            << grid.evaluations << " designs), travel relaxed " << free.best->objective << " um\n";
}

TEST(Exhaustive, SmallCKitNoGridPointBeatsTheSearch) {
  expect_no_better_grid_point(small_c_kit(), 2.5);
}

TEST(Exhaustive, SmallBKitNoGridPointBeatsTheSearch) {
  expect_no_better_grid_point(small_b_kit(), 5.0);
}

TEST(Optimize, BKitWithOffsetGivesRankSix) {
  const OptimizeResult r = optimize_kit(small_b_kit(), {Criterion::kWorst, 2});
  ASSERT_TRUE(r.best);
  EXPECT_EQ(r.best->choice.n_optional, 1);
  EXPECT_EQ(r.best_evaluation.prior.rank, r.best_evaluation.prior.n_unknowns);
  EXPECT_TRUE(r.best_evaluation.worst.worst_std_um);
  EXPECT_TRUE(r.best_evaluation.unidentifiable.empty());
  EXPECT_NE(r.best->design.installations.back().D_mm, 0.0);
  EXPECT_EQ(r.rank_five, OptimizeResult::RankFiveCause::kNone);
  // Every installation it writes has its table ball beyond the tool tip, and the design passes
  // validation as read back.
  for (const Installation& in : r.best->design.installations)
    EXPECT_TRUE(table_ball_beyond_tool(r.best->design.axis, in.direction, in.sign)) << in.id;
  EXPECT_NO_THROW(io::design_from_json(io::design_to_json(r.best->design), "optimised"));
}

TEST(Optimize, BKitWithoutOffsetGivesRankFiveAndNamesTheMissingRotation) {
  Kit k = small_b_kit();
  k.D_mm = {0, 0};
  const OptimizeResult r = optimize_kit(k, {Criterion::kWorst, 2});
  ASSERT_TRUE(r.best);
  const int n_angles = static_cast<int>(r.best->design.angles_deg.size());
  EXPECT_EQ(r.best_evaluation.prior.rank, 5 * n_angles);
  EXPECT_EQ(r.best_evaluation.prior.n_unknowns, 6 * n_angles);
  ASSERT_EQ(static_cast<int>(r.best_evaluation.unidentifiable.size()), n_angles);
  for (const Unidentifiable& u : r.best_evaluation.unidentifiable) {
    ASSERT_TRUE(u.motion);
    EXPECT_TRUE(u.motion->tool_axis) << io::unidentifiable_interpretation(u);
  }
  EXPECT_EQ(r.rank_five, OptimizeResult::RankFiveCause::kNoLateralOffset);
  EXPECT_NE(io::rank_five_note(k, r).find("rank 5"), std::string::npos) << io::rank_five_note(k, r);
  EXPECT_FALSE(r.best_evaluation.worst.worst_std_um);
  EXPECT_TRUE(r.best_evaluation.worst.worst_determined_std_um);
}

TEST(Optimize, ResultDoesNotDependOnThreads) {
  const Kit k = small_c_kit();
  const OptimizeResult a = optimize_kit(k, {Criterion::kWorst, 1});
  const OptimizeResult b = optimize_kit(k, {Criterion::kWorst, 3});
  ASSERT_TRUE(a.best && b.best);
  EXPECT_EQ(a.best->x, b.best->x);
  EXPECT_EQ(a.best->objective, b.best->objective);
  EXPECT_EQ(a.evaluations, b.evaluations);
}

TEST(Optimize, EachChoicesBestIsTheCandidateMadeAfreshAtItsPoint) {
  // The search places each point in the storage of an earlier one: the best of every
  // choice is what make_candidate and a fresh score give at its point.
  Kit k = small_c_kit();
  k.angle_steps_deg = {20, 30, 45};
  const OptimizeResult res = optimize_kit(k, {Criterion::kWorst, 1});
  int compared = 0;
  for (const ChoiceResult& cr : res.choices) {
    if (!cr.best) continue;
    Candidate fresh = make_candidate(k, cr.choice, cr.best->x);
    score_candidate(k, Criterion::kWorst, fresh);
    const Design &a = cr.best->design, &b = fresh.design;
    EXPECT_EQ(a.angles_deg, b.angles_deg);
    ASSERT_EQ(a.installations.size(), b.installations.size());
    for (size_t i = 0; i < a.installations.size(); ++i) {
      EXPECT_EQ(a.installations[i].id, b.installations[i].id);
      EXPECT_EQ(a.installations[i].L_mm, b.installations[i].L_mm);
      EXPECT_EQ(a.installations[i].D_mm, b.installations[i].D_mm);
      EXPECT_EQ(a.installations[i].H_mm, b.installations[i].H_mm);
      EXPECT_EQ(a.installations[i].bar_mm, b.installations[i].bar_mm);
      EXPECT_EQ(a.installations[i].sign, b.installations[i].sign);
    }
    EXPECT_EQ(cr.best->travel_violation_mm, fresh.travel_violation_mm);
    EXPECT_EQ(cr.best->separation_violation_mm, fresh.separation_violation_mm);
    // The same two by hand: the travel and the workspace of each installation with its bar
    // (on C the spindle ball at least a cup's height above the table), the separation of each
    // pair of separated positions.
    double travel = -std::numeric_limits<double>::infinity();
    for (const Installation& in : a.installations)
      travel = std::max({travel, travel_violation_mm(k, k.axis, in, a.angles_deg),
                         workspace_violation_mm(k, k.axis, in, a.angles_deg)});
    EXPECT_EQ(cr.best->travel_violation_mm, travel);
    double separation = -std::numeric_limits<double>::infinity();
    std::vector<Eigen::Vector3d> seen;
    std::set<int> positions;
    for (size_t i = 0; i < a.installations.size(); ++i) {
      const int p = cr.best->installation_position[i];
      if (!k.pattern.positions[p].separated || !positions.insert(p).second) continue;
      const Installation& in = a.installations[i];
      const Eigen::Vector3d here(in.L_mm, in.D_mm, in.H_mm);
      for (const Eigen::Vector3d& there : seen)
        separation = std::max(separation, k.min_separation_mm - (here - there).norm());
      seen.push_back(here);
    }
    EXPECT_NEAR(cr.best->separation_violation_mm, separation, 1e-12);
    EXPECT_EQ(cr.best->time_s, fresh.time_s);
    EXPECT_EQ(cr.best->feasible, fresh.feasible);
    EXPECT_EQ(cr.best->objective_defined, fresh.objective_defined);
    EXPECT_EQ(cr.best->n_undetermined, fresh.n_undetermined);
    EXPECT_NEAR(cr.best->objective, fresh.objective, 1e-12 * fresh.objective);
    ++compared;
  }
  EXPECT_EQ(compared, static_cast<int>(res.choices.size()));
  EXPECT_GE(compared, 6);
}

TEST(Optimize, TimeBudgetExcludesChoices) {
  Kit k = small_c_kit();
  k.angle_steps_deg = {10, 30};
  // 7 installations: 37 angles take 7 * 240 + 259 * 3 = 2457 s, 13 angles 1953 s.
  k.time_budget_s = 2000;
  const OptimizeResult r = optimize_kit(k, {Criterion::kWorst, 2});
  ASSERT_TRUE(r.best);
  EXPECT_EQ(r.best->choice.step_deg, 30);
  EXPECT_DOUBLE_EQ(r.best->time_s, 1953);
  int over = 0;
  for (const ChoiceResult& c : r.choices) over += c.state == ChoiceState::kOverTimeBudget;
  EXPECT_EQ(over, 2);  // step 10 for both height orders
}

// A kit's coarsest acceptable step: per-angle errors alone would choose the coarsest step (the
// shortest measurement, each angle known as well); with angles_deg.max_step the coarser steps
// are not tried, and the best is the coarsest of those left.
TEST(Optimize, AnglesMaxStepLeavesCoarserStepsOut) {
  Kit k = small_c_kit();
  k.angle_steps_deg = {10, 20, 30};
  const OptimizeResult free_step = optimize_kit(k, {Criterion::kWorst, 2});
  ASSERT_TRUE(free_step.best);
  EXPECT_EQ(free_step.best->choice.step_deg, 30);
  k.angle_max_step_deg = 20;
  const OptimizeResult capped = optimize_kit(k, {Criterion::kWorst, 2});
  ASSERT_TRUE(capped.best);
  EXPECT_EQ(capped.best->choice.step_deg, 20);
  for (const ChoiceResult& c : capped.choices) EXPECT_LE(c.choice.step_deg, 20);
  EXPECT_EQ(capped.choices.size() * 3, free_step.choices.size() * 2);
}

// No choice fits the budget: one constraint binds the whole kit, with the shortest design's
// time as it adds up (7 installations at 37 angles and at 13).
TEST(Optimize, AKitOverItsTimeBudgetNamesTheShortestDesign) {
  Kit k = small_c_kit();
  k.angle_steps_deg = {10, 30};
  k.time_budget_s = 1900;
  const OptimizeResult r = optimize_kit(k, {Criterion::kWorst, 2});
  ASSERT_FALSE(r.best);
  const std::vector<BindingConstraint> b = binding_constraints(k, r);
  ASSERT_EQ(b.size(), 1u);
  EXPECT_EQ(b[0].state, ChoiceState::kOverTimeBudget);
  EXPECT_EQ(b[0].choices, 4);
  EXPECT_DOUBLE_EQ(b[0].time_s, 1953);  // 7 x 240 + 7 x 13 x 3
  EXPECT_EQ(b[0].installations, 7);
  EXPECT_EQ(b[0].readings, 91);
}

// With more than six continuous variables the rounding tries the nearest multiples and each
// single change of them (at most 2 n + 1 designs), not every combination.
TEST(Optimize, RoundingManyVariablesTriesTheNearestAndSingleChanges) {
  std::string positions;
  for (int i = 1; i <= 7; ++i) {
    positions += std::string(i > 1 ? ", " : "") + R"({"id": ")" + std::to_string(i) +
                 R"(", "L": "L)" + std::to_string(i) + R"(", "H": )" + std::to_string(45 + 40 * i) +
                 R"(, "directions": ["radial", "tangential"]})";
  }
  const Kit k = io::kit_from_text(
      R"({"format": "dbbkit.kit/1", "axis": "C", "reference_length_mm": 100,
    "pattern": {"name": "seven", "positions": [)" +
          positions + R"(,
      {"id": "0", "H": 45, "directions": ["axial"], "separated": false}]},
    "L_mm": {"min": 20, "max": 250}, "H_mm": {"base": 45, "blocks": [], "max_stack": 0}, "bars_mm": [100],
    "resolution_mm": 5,
    "travel_mm": {"x": [-400, 400], "y": [-400, 400], "z": [-50, 600]},
    "angles_deg": {"range": [0, 360], "steps": [90]}, "time_s": {"per_reading": 3, "per_installation": 240}})",
      "seven");
  OptimizeOptions o;
  o.global_evaluations_per_variable = 5;
  o.local_evaluations = 20;
  o.threads = 2;
  const OptimizeResult r = optimize_kit(k, o);
  ASSERT_TRUE(r.best && r.rounding);
  EXPECT_EQ(r.rounding->unrounded.x.size(), 7u);
  EXPECT_TRUE(r.rounding->applied);
  EXPECT_GE(r.rounding->tried, 1);
  EXPECT_LE(r.rounding->tried, 2 * 7 + 1);
  for (const Installation& in : r.best->design.installations)
    EXPECT_NEAR(std::remainder(in.L_mm, 5.0), 0, 1e-9) << in.id;
}

// The runner-ups are the best of each other set of block stacks, worse than (or tied with)
// the best, in order.
TEST(Optimize, RunnerUpsAreTheBestOfEachOtherSetOfStacks) {
  Kit k = formats_kit();
  k.angle_steps_deg = {45};
  const OptimizeResult r = optimize_kit(k, {Criterion::kWorst, 2});
  ASSERT_TRUE(r.best);
  const std::vector<int> runners = runner_up_choices(r, 100);
  std::set<std::vector<int>> seen;
  std::vector<int> best_stacks;
  for (const auto& h : r.best->choice.heights) best_stacks.push_back(h.stack);
  double previous = r.best->objective * (1 - 1e-4);
  for (int i : runners) {
    const Candidate& c = *r.choices[i].best;
    std::vector<int> stacks;
    for (const auto& h : c.choice.heights) stacks.push_back(h.stack);
    EXPECT_NE(stacks, best_stacks);
    EXPECT_TRUE(seen.insert(stacks).second) << "one runner-up per set of stacks";
    EXPECT_GE(c.objective, previous * (1 - 1e-9));  // `better`: ties within 1e-9 go by time
    previous = c.objective;
    // No other choice with these stacks is better: none lower by more than the tie (1e-4
    // relative), and none within the tie that takes less time.
    for (const ChoiceResult& cr : r.choices) {
      std::vector<int> s2;
      for (const auto& h : cr.choice.heights) s2.push_back(h.stack);
      if (s2 != stacks || !cr.best || cr.state != ChoiceState::kSearched) continue;
      const double tie = 1e-4 * std::max(cr.best->objective, c.objective);
      EXPECT_GE(cr.best->objective, c.objective - tie);
      if (std::abs(cr.best->objective - c.objective) <= tie) EXPECT_GE(cr.best->time_s, c.time_s);
    }
  }
  // Every other set of stacks of the kit: pairs of distinct heights of 7 stacks, less the best's.
  EXPECT_EQ(runners.size(), 7u * 6u - 1u);
}

TEST(Optimize, ARunnerUpWithinTheTieIsTheShorterMeasurement) {
  // As for the best: between objectives within 1e-4 of each other the shorter measurement,
  // beyond it the smaller objective.
  auto choice = [](std::vector<int> stacks, double objective, double time_s) {
    ChoiceResult cr;
    for (int st : stacks) cr.choice.heights.push_back({"H", st, 0.0});
    cr.state = ChoiceState::kSearched;
    Candidate c;
    c.choice = cr.choice;
    c.feasible = true;
    c.objective_defined = true;
    c.objective = objective;
    c.time_s = time_s;
    cr.best = c;
    return cr;
  };
  OptimizeResult r;
  r.choices = {choice({2, 3}, 0.9, 100),      // the best
               choice({0, 1}, 1.0, 200),      // same stacks: 5e-5 above, shorter
               choice({0, 1}, 1.00005, 150),  //
               choice({0, 4}, 1.1, 90),       // same stacks: 2e-4 above, shorter
               choice({0, 4}, 1.10022, 60)};
  r.best = r.choices[0].best;
  const std::vector<int> runners = runner_up_choices(r, 10);
  EXPECT_EQ(runners, (std::vector<int>{2, 3}));
}

// With a resolution the best is rounded: every position a multiple of it, checked and scored
// again (the objective is the rounded design's own), within a small change of the optimum.
TEST(Optimize, TheBestIsRoundedToTheKitsResolutionAndScoredAgain) {
  Kit k = small_c_kit();
  const OptimizeResult free = optimize_kit(k, {Criterion::kWorst, 2});
  k.resolution_mm = 5;
  const OptimizeResult r = optimize_kit(k, {Criterion::kWorst, 2});
  ASSERT_TRUE(r.best && r.rounding && free.best);
  EXPECT_TRUE(r.rounding->applied);
  EXPECT_TRUE(r.best->feasible);
  EXPECT_GE(r.rounding->tried, 1);
  EXPECT_EQ(r.rounding->unrounded.x, free.best->x);
  for (const Installation& in : r.best->design.installations) {
    EXPECT_NEAR(std::remainder(in.L_mm, 5.0), 0, 1e-9) << in.id << " L " << in.L_mm;
    EXPECT_NEAR(std::remainder(in.D_mm, 5.0), 0, 1e-9) << in.id;
  }
  const WorstCase w = design_worst_case(r.best->design, k.reference_length_mm);
  EXPECT_NEAR(r.best->objective, *w.worst_std_um, 1e-12 * *w.worst_std_um);
  EXPECT_NEAR(*r.best_evaluation.worst.worst_std_um, *w.worst_std_um, 1e-9);
  EXPECT_GE(r.best->objective, free.best->objective * (1 - 1e-9));  // the search's optimum
  EXPECT_LE(r.best->objective, free.best->objective * 1.05);
}

// A pattern is data: the built-in three_position written out position by position
// searches the same, and optional positions are added in order, each choice the search
// reports, within the time budget.
// The C three_position pattern written out in a kit file, position by position.
Pattern written_out_three_position() {
  const Kit k =
      io::kit_from_text(R"({"format": "dbbkit.kit/1", "axis": "C", "reference_length_mm": 100,
    "pattern": {"name": "written-out", "distinct": [["H1", "H3"]], "positions": [
      {"id": "1", "L": "L1", "D": "D1", "H": "H1", "directions": ["radial", "tangential"]},
      {"id": "1", "H": "H1", "directions": ["axial"], "separated": false},
      {"id": "2", "L": "L2", "D": "D2", "H": "H1", "directions": ["radial", "tangential"]},
      {"id": "3", "L": "L3", "D": "D3", "H": "H3", "directions": ["radial", "tangential"]}]},
    "L_mm": {"min": 20, "max": 250}, "H_mm": {"base": 45, "blocks": [150], "max_stack": 1}, "bars_mm": [100],
    "travel_mm": {"x": [-220, 220], "y": [-220, 220], "z": [-50, 400]},
    "angles_deg": {"range": [0, 360], "steps": [30]}, "time_s": {"per_reading": 3, "per_installation": 240}})",
                        "written-out");
  EXPECT_FALSE(k.pattern.builtin);
  return k.pattern;
}

TEST(Pattern, KitFileExtendsTheBuiltIn) {
  const Kit k = io::read_kit_file(test::source_path("designs/kits/c-turntable-kit-setup.json"));
  EXPECT_EQ(k.pattern.name, "three_position+4");
  EXPECT_FALSE(k.pattern.builtin);
  ASSERT_EQ(k.pattern.positions.size(), 8u);
  EXPECT_EQ(k.pattern.inherited_positions, 4);
  EXPECT_EQ(offered_optional_positions(k), (std::vector<int>{4, 5, 6, 7}));
  EXPECT_EQ(max_installations(k), 13);
  EXPECT_EQ(k.pattern.positions[5].L.variable, "L5");
  EXPECT_EQ(k.pattern.positions[4].H.variable, "H3");
  EXPECT_FALSE(k.pattern.positions[4].separated);
  EXPECT_EQ(k.pattern.distinct, (std::vector<std::vector<std::string>>{{"H1", "H3"}}));
  // 7 heights, H1 != H3, 6 steps, 0 to 4 optional positions.
  EXPECT_EQ(pattern_choices(k).size(), 7u * 6u * 6u * 5u);
  // The B pattern's off-axis position is offered only where D_mm allows an offset.
  const Kit b = io::read_kit_file(test::source_path("designs/kits/b-head-kit-on-axis.json"));
  EXPECT_TRUE(offered_optional_positions(b).empty());
  EXPECT_EQ(offered_optional_positions(
                io::read_kit_file(test::source_path("designs/kits/b-head-kit.json")))
                .size(),
            1u);
}

// A kit's name names the design optimize writes ("<name>-optimized"): the longest kit name
// leaves that design's name within a design's limit, and one byte more is refused.
TEST(Pattern, TheLongestKitNameNamesADesignWithinTheDesignsLimit) {
  Kit k = small_c_kit();
  k.name = std::string(limits::kMaxKitNameBytes, 'k');
  EXPECT_NO_THROW(validate_kit(k));
  Design d = test::paper_design('C');
  d.name = k.name + "-optimized";
  EXPECT_NO_THROW(validate_design(d));
  k.name += "k";
  EXPECT_THROW(validate_kit(k), InputError);
  d.name += "d";
  EXPECT_THROW(validate_design(d), InputError);
}

TEST(Pattern, TheBuiltInWrittenAsDataSearchesTheSame) {
  const Kit builtin = small_c_kit();
  Kit data = builtin;
  data.pattern = written_out_three_position();
  validate_kit(data);
  const OptimizeResult a = optimize_kit(builtin, {Criterion::kWorst, 2});
  const OptimizeResult b = optimize_kit(data, {Criterion::kWorst, 2});
  ASSERT_TRUE(a.best && b.best);
  ASSERT_EQ(a.choices.size(), b.choices.size());
  EXPECT_EQ(a.best->objective, b.best->objective);
  EXPECT_EQ(a.best->x, b.best->x);
  EXPECT_EQ(a.evaluations, b.evaluations);
  ASSERT_EQ(a.best->design.installations.size(), 7u);
  for (size_t i = 0; i < 7; ++i)
    EXPECT_EQ(a.best->design.installations[i].id, b.best->design.installations[i].id);
}

TEST(Pattern, OptionalPositionsAreAddedInOrderAndBuyTotal) {
  Kit k = small_c_kit();
  k.setup_std.length_offset_um = 10;
  k.setup_std.centring_um = 5;
  const OptimizeResult plain = optimize_kit(k, {Criterion::kWorstTotal, 2});
  using K = Direction::Kind;
  const PatternCoordinate zero{};
  k.pattern.positions.push_back({"4", zero, zero, {"H3", 0}, {K::kAxial}, false, true, false});
  k.pattern.positions.push_back(
      {"5", {"L5", 0}, {"D5", 0}, {"H1", 0}, {K::kRadial, K::kTangential}, true, true, false});
  validate_kit(k);
  // Two heights (45, 195 mm) in two orders, one step, 0, 1 or 2 optional positions.
  const std::vector<PatternChoice> choices = pattern_choices(k);
  ASSERT_EQ(choices.size(), 6u);
  for (size_t i = 0; i < choices.size(); ++i)
    EXPECT_EQ(choices[i].n_optional, static_cast<int>(i / 2));
  const OptimizeResult r = optimize_kit(k, {Criterion::kWorstTotal, 2});
  ASSERT_TRUE(plain.best && r.best);
  for (const ChoiceResult& c : r.choices) {
    ASSERT_TRUE(c.best);
    const size_t expected =
        7 + (c.choice.n_optional >= 1 ? 1 : 0) + (c.choice.n_optional >= 2 ? 2 : 0);
    EXPECT_EQ(c.best->design.installations.size(), expected) << c.label;
    if (c.choice.n_optional == 2) EXPECT_EQ(added_installations(k, *c.best), "4a 5r 5t");
  }
  // The same choices without optional positions search exactly as before.
  for (size_t i = 0; i < plain.choices.size(); ++i)
    EXPECT_EQ(plain.choices[i].best->objective, r.choices[i].best->objective);
  // Extra installations buy total uncertainty: the best adds both positions, and its total
  // (recomputed through the stacked model) is below the three_position optimum.
  EXPECT_EQ(r.best->choice.n_optional, 2);
  const TotalWorstCase best = dense_worst_total(r.best->design, k.reference_length_mm);
  EXPECT_NEAR(*best.total.worst_std_um, r.best->objective, 1e-9 * r.best->objective);
  EXPECT_LT(r.best->objective, 0.95 * plain.best->objective);
  // The design written states the total it was chosen by, beside the noise alone, and reads
  // it back.
  const Design written = io::optimized_design(k, r, "kit.json");
  ASSERT_TRUE(written.predicted && written.predicted->worst_total_std_um);
  EXPECT_EQ(written.predicted->criterion, "worst_total_std_um");
  EXPECT_NEAR(*written.predicted->worst_total_std_um, r.best->objective, 1e-9 * r.best->objective);
  EXPECT_LT(*written.predicted->worst_std_um, *written.predicted->worst_total_std_um);
  const Design back = io::design_from_json(io::design_to_json(written), "written");
  ASSERT_TRUE(back.predicted && back.predicted->worst_total_std_um);
  EXPECT_EQ(*back.predicted->worst_total_std_um, *written.predicted->worst_total_std_um);
  std::cout << "small C kit, 10 um / 5 um: three_position " << plain.best->objective
            << " um, with 4a 5r 5t " << r.best->objective << " um\n";
  // The Pareto front: longer measurements only where they buy a smaller total.
  ASSERT_GE(r.pareto.size(), 2u);
  for (size_t i = 1; i < r.pareto.size(); ++i) {
    EXPECT_GT(r.pareto[i].time_s, r.pareto[i - 1].time_s);
    EXPECT_LT(r.pareto[i].objective, r.pareto[i - 1].objective);
  }
  EXPECT_EQ(added_installations(k, r.pareto.front()), "-");
}

TEST(Pattern, RequiredSetupDetectionIsMetByTheDesignFoundAndNamedWhereNoPositionCan) {
  // The kit with set-up tolerances and optional positions at 45 deg steps, cup heights 45 and
  // 195 mm: the best total alone leaves centring[3t] and [6t] below diagnose's reach (limit
  // above the declared 5 um); with require_setup_detection the design found has every
  // declared effect detected at its declared size, as evaluate states it (with the
  // candidates diagnose tests, never more than the search counts).
  Kit k = io::read_kit_file(test::source_path("designs/kits/c-turntable-kit-setup.json"));
  ASSERT_TRUE(k.require_setup_detection);
  k.angle_steps_deg = {45};
  k.blocks_mm = {150};
  k.max_stack = 1;
  auto evaluated_ratio = [&](const Design& d) {
    double ratio = 0;
    const DetectionSettings settings =
        diagnose_detection_settings(effect_detectability(d, nominal_readings(d)));
    for (const SetupEffectCheck& c :
         evaluate_design(d, k.reference_length_mm, {}, settings).setup_checks) {
      ratio =
          std::max(ratio, c.detection_limit_um ? *c.detection_limit_um / c.declared_std_um : 1e300);
    }
    return ratio;
  };
  Kit free = k;
  free.require_setup_detection = false;
  const OptimizeResult unconstrained = optimize_kit(free, {Criterion::kWorstTotal, 2});
  const OptimizeResult r = optimize_kit(k, {Criterion::kWorstTotal, 2});
  ASSERT_TRUE(unconstrained.best && r.best);
  EXPECT_FALSE(unconstrained.best->detection);
  EXPECT_GT(evaluated_ratio(unconstrained.best->design), 1.5);
  ASSERT_TRUE(r.best->detection);
  EXPECT_LE(r.best->detection->ratio, 1.0);
  const double ratio = evaluated_ratio(r.best->design);
  EXPECT_LE(ratio, r.best->detection->ratio * (1 + 1e-9));
  EXPECT_GT(ratio, 0.9);  // the requirement binds
  std::cout << "set-up kit at 45 deg: best total " << unconstrained.best->objective
            << " um (largest detection limit / "
            << "declared " << evaluated_ratio(unconstrained.best->design)
            << "); with the requirement " << r.best->objective << " um (" << ratio << ", "
            << r.best->detection->effect << ")\n";
  // A choice that meets the requirement meets it at its best point; one without enough
  // installations is named with the effects the axis errors take at every position.
  for (const ChoiceResult& c : r.choices) {
    ASSERT_TRUE(c.best && c.best->detection) << c.label;
    if (c.state == ChoiceState::kSearched) EXPECT_LE(c.best->detection->ratio, 1.0) << c.label;
  }
  // The three_position pattern alone: per angle its three tangential readings determine
  // the tangential translation, ez and the tilt about the radius with nothing to spare, so
  // no position of any choice detects their set-up effects.
  Kit plain = io::read_kit_file(test::source_path("designs/kits/c-turntable-kit-tolerances.json"));
  ASSERT_FALSE(plain.require_setup_detection);
  plain.require_setup_detection = true;
  const OptimizeResult none = optimize_kit(plain, {Criterion::kWorstTotal, 2});
  EXPECT_FALSE(none.best);
  for (const ChoiceResult& c : none.choices) {
    EXPECT_EQ(c.state, ChoiceState::kUndetectableEverywhere) << c.label;
    const std::string status = io::choice_status_text(plain, c);
    EXPECT_NE(status.find("length_offset[1t], centring[1t]"), std::string::npos) << status;
    EXPECT_NE(status.find("at every position of this choice"), std::string::npos) << status;
  }
}

TEST(Optimize, OtherCriteriaScoreFullRankDesigns) {
  Kit k = small_c_kit();
  for (Criterion c : {Criterion::kD, Criterion::kA, Criterion::kE, Criterion::kCondition}) {
    OptimizeOptions o;
    o.criterion = c;
    o.threads = 2;
    // A short search: what is checked holds for any design it returns.
    o.global_evaluations_per_variable = 20;
    o.local_evaluations = 50;
    const OptimizeResult r = optimize_kit(k, o);
    ASSERT_TRUE(r.best) << criterion_name(c);
    EXPECT_TRUE(r.best->objective_defined) << criterion_name(c);
    EXPECT_EQ(r.best_evaluation.prior.rank, r.best_evaluation.prior.n_unknowns)
        << criterion_name(c);
    // The search's value is the criterion of the design it returns.
    const Evaluation& ev = r.best_evaluation;
    const double expect = c == Criterion::kD   ? -*ev.criteria.D_logdet
                          : c == Criterion::kA ? *ev.criteria.A_trace
                          : c == Criterion::kE ? -ev.criteria.E_min_eigenvalue
                                               : *ev.prior.condition_number;
    EXPECT_NEAR(r.best->objective, expect, 1e-9 * std::abs(expect)) << criterion_name(c);
  }
}

TEST(Optimize, FormatsKitBeatsThePaperLikeDesign) {
  const Kit k = formats_kit();
  const OptimizeResult r = optimize_kit(k, {Criterion::kWorst, 2});
  ASSERT_TRUE(r.best && r.best_evaluation.worst.worst_std_um);
  const Evaluation paper = evaluate_design(test::paper_design('C'), k.reference_length_mm);
  ASSERT_TRUE(paper.worst.worst_std_um);
  const double ratio = *r.best_evaluation.worst.worst_std_um / *paper.worst.worst_std_um;
  EXPECT_LT(ratio, 1.0);
  std::cout << "formats.md kit: optimised " << *r.best_evaluation.worst.worst_std_um
            << " um, paper-like " << *paper.worst.worst_std_um << " um, ratio " << ratio << "\n";
  // The prediction carried by the search equals the full evaluation of the design it returns.
  EXPECT_NEAR(r.best->objective, *r.best_evaluation.worst.worst_std_um, 1e-9);
}

}  // namespace
}  // namespace dbbkit
