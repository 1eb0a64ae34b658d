// The residual checks: the fast column tests against refits of the augmented model
// (the project's solver on [J X], a different computation), and diagnose's checks over
// 100 seeds each (gross reading, noise larger than declared, too low a model order,
// an effect at its stated detection limit).
#include "dbbkit/residual_checks.hpp"

#include <gtest/gtest.h>

#include <boost/math/distributions/fisher_f.hpp>
#include <random>

#include "../src/column_tester.hpp"
#include "../src/wls_solver.hpp"
#include "dbbkit/diagnose.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/diagnose_text.hpp"
#include "dbbkit/simulate.hpp"
#include "test_util.hpp"

namespace dbbkit {
namespace {

// A feature no machine or bar can have is marked: a drift of -56.7 um/min over a test of about an
// hour would move the bar 3.4 mm, beyond the +-1 mm the instrument reads; a 1 um/min drift, a
// 5 um step are not; a step of 1.2 mm is.
TEST(ResidualFeatures, WhatNoMachineCanHaveIsMarked) {
  const Design d = test::paper_design('C');
  std::vector<Reading> readings(2);
  readings[0].time_s = 0;
  readings[1].time_s = 3600;
  auto feature = [](FeatureKind k, double value) {
    ResidualFeature f;
    f.kind = k;
    f.value = value;
    return f;
  };
  std::vector<ResidualFeature> fs = {
      feature(FeatureKind::kDrift, -56.71), feature(FeatureKind::kDrift, 1.0),
      feature(FeatureKind::kStep, 5.0), feature(FeatureKind::kStep, 1200.0)};
  mark_implausible(d, readings, fs);
  ASSERT_TRUE(fs[0].beyond_instrument_um);
  EXPECT_NEAR(*fs[0].beyond_instrument_um, 56.71 * 60, 1e-9);
  EXPECT_FALSE(fs[1].beyond_instrument_um);
  EXPECT_FALSE(fs[2].beyond_instrument_um);
  EXPECT_TRUE(fs[3].beyond_instrument_um);
  EXPECT_TRUE(fs[0].beyond_drift_rate_um_per_min);  // and faster than 10 um/min
  EXPECT_FALSE(fs[1].beyond_drift_rate_um_per_min);
}

// A drift faster than the design's max_drift_um_per_min is marked whatever its reach: 20 um/min
// over a 5 min test moves the bar 0.1 mm, within the range, yet no machine drifts that fast;
// 9 um/min does not exceed the 10 um/min default; a design allowing 30 um/min marks neither.
TEST(ResidualFeatures, ADriftFasterThanTheDesignAllowsIsMarked) {
  Design d = test::paper_design('C');
  std::vector<Reading> readings(2);
  readings[0].time_s = 0;
  readings[1].time_s = 300;
  std::vector<ResidualFeature> fs(3);
  fs[0].kind = FeatureKind::kDrift, fs[0].value = -20.0;
  fs[1].kind = FeatureKind::kDrift, fs[1].value = 9.0;
  fs[2].kind = FeatureKind::kStep, fs[2].value = 20.0;
  mark_implausible(d, readings, fs);
  EXPECT_FALSE(fs[0].beyond_instrument_um);
  ASSERT_TRUE(fs[0].beyond_drift_rate_um_per_min);
  EXPECT_EQ(*fs[0].beyond_drift_rate_um_per_min, 20.0);
  EXPECT_TRUE(fs[0].implausible());
  EXPECT_FALSE(fs[1].implausible());
  EXPECT_FALSE(fs[2].implausible());
  d.max_drift_um_per_min = 30;
  for (ResidualFeature& f : fs) f.beyond_drift_rate_um_per_min.reset();
  mark_implausible(d, readings, fs);
  EXPECT_FALSE(fs[0].implausible());
}

// A drift of one installation moves the bar over that installation's readings only: 30 um/min
// over its 5 min is 150 um, an ordinary size; the same rate over the whole 60 min test would be
// 1.8 mm, beyond the +-1 mm range.
TEST(ResidualFeatures, ADriftIsWeighedOverItsOwnReadings) {
  Design d = test::paper_design('C');
  d.max_drift_um_per_min = 100;
  std::vector<Reading> readings(3);
  readings[0].installation = readings[1].installation = d.installations[0].id;
  readings[2].installation = d.installations[1].id;
  readings[0].time_s = 0;
  readings[1].time_s = 300;
  readings[2].time_s = 3600;
  std::vector<ResidualFeature> fs(2);
  fs[0].kind = fs[1].kind = FeatureKind::kDrift;
  fs[0].value = fs[1].value = 30.0;
  fs[0].installation = 0;
  fs[1].installation = -1;  // the whole test
  mark_implausible(d, readings, fs);
  EXPECT_FALSE(fs[0].implausible());
  ASSERT_TRUE(fs[1].beyond_instrument_um);
  EXPECT_NEAR(*fs[1].beyond_instrument_um, 1800.0, 1e-9);
}

struct Problem {
  Eigen::MatrixXd J;
  Eigen::VectorXd sigma, y;
};

Problem random_problem(int n, int p, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01;
  std::uniform_real_distribution<double> u(0.5, 2.0);
  Problem pr;
  pr.J = Eigen::MatrixXd::NullaryExpr(n, p, [&](Eigen::Index, Eigen::Index) { return n01(rng); });
  pr.sigma = Eigen::VectorXd::NullaryExpr(n, [&](Eigen::Index) { return u(rng); });
  pr.y = pr.J * Eigen::VectorXd::NullaryExpr(p, [&](Eigen::Index) { return n01(rng); });
  for (int i = 0; i < n; ++i) pr.y(i) += pr.sigma(i) * n01(rng);
  for (int i = n / 2; i < n; ++i) pr.y(i) += 1.5;  // a step halfway
  return pr;
}

// The F-test by refitting [J X] from scratch.
double refit_F(const Problem& pr, const Eigen::MatrixXd& X, int* dof = nullptr) {
  const Estimate a = WlsSolver(pr.J, pr.sigma).solve(pr.y);
  Eigen::MatrixXd JX(pr.J.rows(), pr.J.cols() + X.cols());
  JX << pr.J, X;
  const Estimate b = WlsSolver(JX, pr.sigma).solve(pr.y);
  const int q = b.rank - a.rank;
  if (dof) *dof = b.dof;
  return ((a.chi2 - b.chi2) / q) / (b.chi2 / b.dof);
}

TEST(ColumnTester, OneAndTwoColumnsAgreeWithARefit) {
  const Problem pr = random_problem(60, 5, 1);
  const WlsSolver solver(pr.J, pr.sigma);
  const Estimate fit = solver.solve(pr.y);
  const ColumnTester tester(solver, fit);
  std::mt19937_64 rng(2);
  std::normal_distribution<double> n01;
  for (int q : {1, 2}) {
    const Eigen::MatrixXd X =
        Eigen::MatrixXd::NullaryExpr(60, q, [&](Eigen::Index, Eigen::Index) { return n01(rng); });
    const ColumnTest t = tester.test(X);
    int dof = 0;
    EXPECT_EQ(t.added_rank, q);
    EXPECT_NEAR(t.F, refit_F(pr, X, &dof), 1e-8 * t.F);
    EXPECT_EQ(t.dof, dof);
    const double p = boost::math::cdf(boost::math::complement(boost::math::fisher_f(q, dof), t.F));
    EXPECT_NEAR(t.p, p, 1e-12);
  }
  // A column the model reproduces adds nothing and is not tested.
  EXPECT_EQ(tester.test(pr.J.col(2) * 3.0 - pr.J.col(0)).added_rank, 0);
}

TEST(ColumnTester, StepScanIsTheBestOfEveryRefit) {
  const int n = 50;
  const Problem pr = random_problem(n, 4, 3);
  const WlsSolver solver(pr.J, pr.sigma);
  const Estimate fit = solver.solve(pr.y);
  std::vector<int> rows(n);
  for (int i = 0; i < n; ++i) rows[i] = i;
  const ScanTest s = ColumnTester(solver, fit).scan_steps(rows, 3);
  double best_F = -1;
  int best_k = -1, tested = 0;
  for (int k = 3; k <= n - 3; ++k) {
    Eigen::MatrixXd x = Eigen::MatrixXd::Zero(n, 1);
    x.bottomRows(n - k).setOnes();
    const double F = refit_F(pr, x);
    ++tested;
    if (F > best_F) best_F = F, best_k = k;
  }
  EXPECT_EQ(s.tested, tested);
  EXPECT_EQ(s.best, best_k);
  EXPECT_EQ(s.best, n / 2);
  EXPECT_NEAR(s.test.F, best_F, 1e-7 * best_F);
  EXPECT_NEAR(s.p_scan, std::min(1.0, tested * s.test.p), 1e-15);
}

TEST(ColumnTester, ReadingScanIsTheExternallyStudentisedResidual) {
  const int n = 40;
  Problem pr = random_problem(n, 3, 5);
  pr.y(17) += 25.0 * pr.sigma(17);
  const WlsSolver solver(pr.J, pr.sigma);
  const Estimate fit = solver.solve(pr.y);
  std::vector<int> rows(n);
  for (int i = 0; i < n; ++i) rows[i] = i;
  const ScanTest s = ColumnTester(solver, fit).scan_readings(rows);
  EXPECT_EQ(s.best, 17);
  Eigen::MatrixXd e = Eigen::MatrixXd::Zero(n, 1);
  e(17, 0) = 1;
  EXPECT_NEAR(s.test.F, refit_F(pr, e), 1e-7 * s.test.F);
  // Sequential flagging finds it and then nothing more at 1 %.
  const std::vector<GrossReading> g = gross_readings(test::sparse(pr.J), pr.sigma, pr.y, 0.01, 5);
  ASSERT_GE(g.size(), 1u);
  EXPECT_EQ(g[0].row, 17);
  EXPECT_NEAR(g[0].value_um, 25.0 * pr.sigma(17), 6 * g[0].std_um);
}

TEST(NoiseScale, IntervalFromChiSquaredQuantiles) {
  const NoiseScale s = noise_scale(400.0, 100);
  EXPECT_DOUBLE_EQ(s.ratio, 2.0);
  EXPECT_LT(s.low, 2.0);
  EXPECT_GT(s.high, 2.0);
  // chi2(100) quantiles 0.025 and 0.975: 74.2219 and 129.561.
  EXPECT_NEAR(s.low, std::sqrt(400.0 / 129.561), 1e-4);
  EXPECT_NEAR(s.high, std::sqrt(400.0 / 74.2219), 1e-4);
}

// ---------------------------------------------------------------------------
// diagnose's checks over 100 seeds on the paper's C installations with a Fourier
// order-2 model (tests/data/c_fourier2_bar150.json), swept ccw, cw, ccw.

using test::fourier_design;
// One reading 30 um off: named (the right reading), nothing of the library added to explain
// it, and the opt-in refit without it consistent with the noise.
TEST(DiagnoseFindsEffect, GrossReadingIsNamedNotExplainedAway) {
  const Design d = fourier_design();
  std::mt19937_64 rng(21);
  const int seeds = 100;
  int named = 0, nothing_added = 0, refit_clean = 0;
  for (int s = 0; s < seeds; ++s) {
    std::vector<Reading> rd = simulate(d, test::random_fourier_truth(d, rng), 11000 + s);
    const int row = static_cast<int>(rng() % rd.size());
    rd[row].reading_um += (s % 2 ? 30.0 : -30.0);
    const DiagnoseResult r = diagnose(d, rd);
    named += !r.gross.empty() && r.gross[0].row == row &&
             io::diagnose_verdict(d, rd, r).find("gross reading") != std::string::npos;
    nothing_added += r.added.empty();
    DiagnoseOptions o;
    o.exclude_gross = true;
    const DiagnoseResult x = diagnose(d, rd, o);
    refit_clean += x.excluded_rows == std::vector<int>{row} && x.after.p_value &&
                   *x.after.p_value > 0.01 &&
                   io::diagnose_verdict(d, rd, x).rfind("Refit without 1 gross reading", 0) == 0;
  }
  EXPECT_GE(named, 95);
  EXPECT_GE(nothing_added, 95);
  EXPECT_GE(refit_clean, 90);
}

// Noise 2.45 times the declared (chi2/dof near 6), spread evenly: said as such, nothing added,
// no feature named as the cause, the interval of the ratio covering 2.45.
TEST(DiagnoseFindsEffect, NoiseLargerThanDeclaredIsSaidSo) {
  const Design d = fourier_design();
  std::mt19937_64 rng(22);
  const int seeds = 100;
  int said = 0, nothing_added = 0, covered = 0;
  for (int s = 0; s < seeds; ++s) {
    Truth t = test::random_fourier_truth(d, rng);
    NoiseModel noisy = d.noise;
    noisy.half_width_um *= 2.45;
    t.noise = noisy;
    const std::vector<Reading> rd = simulate(d, t, 12000 + s);
    const DiagnoseResult r = diagnose(d, rd);
    const std::string verdict = io::diagnose_verdict(d, rd, r);
    said += r.noise_larger_than_declared &&
            verdict.find("more than the declared noise") != std::string::npos;
    nothing_added += r.added.empty();
    covered += r.noise && r.noise->low <= 2.45 && 2.45 <= r.noise->high;
  }
  EXPECT_GE(said, 95);
  EXPECT_GE(nothing_added, 95);
  EXPECT_GE(covered, 90);
}

// A 6-per-turn motion (3 um in dx and dy) under a model of order 2: order 6 suggested and the
// fit with it consistent with the noise; nothing of the library added.
TEST(DiagnoseFindsEffect, ModelOrderTooLowIsSuggested) {
  const Design d = fourier_design();
  std::mt19937_64 rng(23);
  const int seeds = 100;
  int suggested = 0, nothing_added = 0, consistent = 0;
  for (int s = 0; s < seeds; ++s) {
    Truth t = test::random_fourier_truth(d, rng);
    t.model.order = 6;
    for (int k = 0; k < 6; ++k) t.coefficients[k].resize(13, 0.0);
    t.coefficients[0][11] = 3.0;  // dx: cos 6a
    t.coefficients[1][12] = 3.0;  // dy: sin 6a
    const std::vector<Reading> rd = simulate(d, t, 13000 + s);
    const DiagnoseResult r = diagnose(d, rd);
    const std::string verdict = io::diagnose_verdict(d, rd, r);
    suggested += r.order && r.order->suggested == 6 && r.order->p < 0.01 &&
                 verdict.find("Set errors.order to 6") != std::string::npos;
    nothing_added += r.added.empty();
    consistent += r.order && r.order->p_value_with && *r.order->p_value_with > 0.01;
  }
  EXPECT_GE(suggested, 95);
  EXPECT_GE(nothing_added, 95);
  EXPECT_GE(consistent, 90);
}

// The detection limit diagnose states on clean data is what it finds: a length offset of 2r
// at its stated limit is found in about 90 % of seeds (power 0.9), at twice it in at least 95.
TEST(DiagnoseFindsEffect, StatedDetectionLimitHasItsPower) {
  const Design d = fourier_design();
  std::mt19937_64 rng(24);
  const DiagnoseResult clean = diagnose(d, simulate(d, test::random_fourier_truth(d, rng), 14000));
  const auto it =
      std::find_if(clean.detection_limits.begin(), clean.detection_limits.end(),
                   [](const DetectionLimit& l) { return l.label == "length_offset[2r]"; });
  ASSERT_NE(it, clean.detection_limits.end());
  ASSERT_TRUE(it->limit.has_value());
  const double limit = *it->limit;
  const int seeds = 100;
  int at_limit = 0, at_twice = 0;
  // Found: added, or named as an equivalent or a close alternative of the effect added (a drift
  // of the whole test makes a staircase of installation means that can pass for it; diagnose
  // then says the readings cannot tell them apart reliably).
  auto found = [](const DiagnoseResult& r) {
    return std::any_of(r.added.begin(), r.added.end(), [](const AddedEffect& a) {
      auto in = [](const std::vector<std::string>& v) {
        return std::find(v.begin(), v.end(), "length_offset[2r]") != v.end();
      };
      return a.block.label == "length_offset[2r]" || in(a.equivalent_to) ||
             in(a.close_alternatives);
    });
  };
  for (int s = 0; s < seeds; ++s) {
    for (double factor : {1.0, 2.0}) {
      Truth t = test::random_fourier_truth(d, rng);
      TruthEffect e;
      e.effect.kind = EffectKind::kLengthOffset;
      e.installation = "2r";
      e.value = Eigen::VectorXd::Constant(1, factor * limit);
      t.effects = {e};
      const bool f = found(diagnose(d, simulate(d, t, 15000 + s)));
      (factor == 1.0 ? at_limit : at_twice) += f;
    }
  }
  // Binomial(100, 0.9): 80 to 97 holds with probability above 0.99.
  EXPECT_GE(at_limit, 80) << "limit " << limit;
  EXPECT_LE(at_limit, 97) << "limit " << limit;
  // At twice the limit the test always detects it (F near 100); the few misses are a whole-test
  // drift chosen by more than the close-alternative margin (chi2 within 4), which noise allows.
  EXPECT_GE(at_twice, 95);
}

}  // namespace
}  // namespace dbbkit
