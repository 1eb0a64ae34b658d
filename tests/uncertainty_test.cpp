#include "dbbkit/uncertainty.hpp"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <random>

#include "../src/factorised.hpp"
#include "../src/setup_solver.hpp"
#include "../src/wls_solver.hpp"
#include "dbbkit/error.hpp"
#include "dbbkit/identify.hpp"
#include "dbbkit/monte_carlo.hpp"
#include "dbbkit/setup.hpp"
#include "dbbkit/simulate.hpp"
#include "test_util.hpp"

namespace dbbkit {
namespace {

Truth constant_truth(const Design& d, const Vector6d& e) {
  Truth t;
  t.model.kind = ErrorModel::Kind::kPerAngle;
  for (double a : d.angles_deg) test::add_truth_value(t, d.axis, a, e);
  return t;
}

// Readings of the constant errors e with installation i's ball moved by dL [mm] along L (no
// ball moved for i < 0), from the exact two-ball geometry (Truth::exact, the following ball on
// its programmed path): the part odd in e, (r(e) - r(-e)) / 2, so that neither the reading the
// moved ball gives by itself (a constant the zeroing of the bar absorbs, or second order) nor
// terms of second order in e remain. Independent of the first-order model.
std::vector<Reading> exact_readings_moved(const Design& d, const Vector6d& e, int i, double dL) {
  auto run = [&](const Vector6d& x) {
    Truth t = constant_truth(d, x);
    t.noiseless = true;
    t.exact = true;
    if (i >= 0) {
      SetupError moved;
      moved.ball_mm = {dL, 0, 0};
      t.setup_given = {{d.installations[static_cast<std::size_t>(i)].id, moved}};
    }
    return simulate(d, t, 0);
  };
  std::vector<Reading> plus = run(e);
  const std::vector<Reading> minus = run(-e);
  for (std::size_t k = 0; k < plus.size(); ++k)
    plus[k].reading_um = 0.5 * (plus[k].reading_um - minus[k].reading_um);
  return plus;
}

// Per installation, the derivative of every budget value with respect to its ball's L: central
// differences of identify on the exact readings (the third-order error, (dL / bar)^2 / 6 of
// the value, is about 2e-6 of it here).
std::vector<Eigen::VectorXd> value_shifts_per_L(const Design& d, const Vector6d& e) {
  const double dL = 0.5;
  std::vector<Eigen::VectorXd> shift;
  for (std::size_t i = 0; i < d.installations.size(); ++i) {
    const IdentifyResult plus = identify(d, exact_readings_moved(d, e, static_cast<int>(i), dL));
    const IdentifyResult minus = identify(d, exact_readings_moved(d, e, static_cast<int>(i), -dL));
    Eigen::VectorXd sh(static_cast<Eigen::Index>(plus.budget.values.size()));
    for (std::size_t v = 0; v < plus.budget.values.size(); ++v)
      sh(static_cast<Eigen::Index>(v)) =
          (plus.budget.values[v].value - minus.budget.values[v].value) / (2 * dL);
    shift.push_back(sh);
  }
  return shift;
}

TEST(Budget, CoverageFactorsFromTables) {
  EXPECT_NEAR(coverage_factor(std::nullopt, 0.95), 1.959964, 1e-6);
  EXPECT_NEAR(coverage_factor(10.0, 0.95), 2.228139, 1e-6);  // Student t, 10 dof, two-sided 95%
  EXPECT_NEAR(coverage_factor(3.0, 0.9545), 3.307, 2e-3);    // JCGM 100 Table G.2
}

TEST(Budget, WelchSatterthwaiteByHand) {
  // u1 = 1 with 4 dof, u2 = 1 Type B: nu_eff = (1 + 1)^2 / (1^4 / 4) = 16.
  const std::vector<BudgetComponent> c = {{"a", "A", 1.0, 4.0}, {"b", "B", 1.0, std::nullopt}};
  ASSERT_TRUE(welch_satterthwaite(c).has_value());
  EXPECT_DOUBLE_EQ(*welch_satterthwaite(c), 16.0);
  EXPECT_FALSE(welch_satterthwaite({{"b", "B", 1.0, std::nullopt}}).has_value());
}

TEST(Budget, TypeAScalesByTheObservedNoise) {
  Design d = test::paper_design('C');
  Truth t = constant_truth(d, Vector6d::Constant(3.0));
  NoiseModel heavy;
  heavy.distribution = NoiseModel::Distribution::kNormal;
  heavy.std_um = 2.0 * d.noise.sigma_um();  // the machine is twice as noisy as declared
  t.noise = heavy;
  t.repeats = 3;  // 399 readings, 108 unknowns: 291 dof
  const std::vector<Reading> readings = simulate(d, t, 21);
  IdentifyOptions opt;
  const IdentifyResult b = identify(d, readings, opt);
  opt.budget.type_a = true;
  const IdentifyResult a = identify(d, readings, opt);
  ASSERT_TRUE(a.budget.type_a_scale.has_value());
  EXPECT_NEAR(*a.budget.type_a_scale, 2.0, 0.25);  // sqrt(chi2/nu), nu = 291
  ASSERT_EQ(a.budget.values.size(), b.budget.values.size());
  for (size_t i = 0; i < a.budget.values.size(); ++i) {
    EXPECT_NEAR(a.budget.values[i].u_c, *a.budget.type_a_scale * b.budget.values[i].u_c, 1e-9);
    ASSERT_TRUE(a.budget.values[i].nu_eff.has_value());
    EXPECT_DOUBLE_EQ(*a.budget.values[i].nu_eff, 291.0);
    EXPECT_NEAR(a.budget.values[i].k, coverage_factor(291.0, 0.95), 1e-12);
    EXPECT_NEAR(b.budget.values[i].k, 1.959964, 1e-6);
  }
}

TEST(Budget, TypeAWithoutRedundancyIsRefused) {
  Design d = test::paper_design('C');
  d.angles_deg = {0, 20};
  d.installations.erase(d.installations.begin() +
                        3);  // without 2r: 6 readings per angle, rank 6, no residual
  std::vector<Reading> readings = simulate(d, constant_truth(d, Vector6d::Ones()), 1);
  IdentifyOptions opt;
  opt.budget.type_a = true;
  EXPECT_THROW(identify(d, readings, opt), InputError);
}

// The set-up component against finite differences of the exact geometry: readings taken with
// a ball moved along L (following ball on its programmed path), identified with the nominal
// design, shift the values by dvalue; with independent inputs
// u_setup^2 = sum_i (dvalue_i/dL)^2 u_L^2 over the installations i.
TEST(Budget, SetupUncertaintyMatchesFiniteDifference) {
  Design d = test::paper_design('C');
  d.setup_std.L_mm = 0.2;
  Vector6d e;
  e << 5, -4, 3, 40, -30, 60;
  const IdentifyResult nominal = identify(d, exact_readings_moved(d, e, -1, 0.0));
  const std::vector<Eigen::VectorXd> shift = value_shifts_per_L(d, e);
  int checked = 0;
  for (size_t v = 0; v < nominal.budget.values.size(); ++v) {
    double expected2 = 0;
    for (const auto& s : shift) expected2 += std::pow(s(v) * 0.2, 2);
    double got = 0;
    for (const BudgetComponent& c : nominal.budget.values[v].components) {
      if (c.name == "set-up L") got = c.u;
    }
    EXPECT_NEAR(got, std::sqrt(expected2), 1e-7 + 1e-4 * std::sqrt(expected2)) << v;
    checked += expected2 > 1e-6;
  }
  EXPECT_GT(checked, 30);  // the set-up matters for many values, not a vacuous check
}

// The joint covariance of the values. Its L part against finite differences of the
// identification (the exact geometry moved by dL per installation), off the diagonal too:
// with independent inputs Cov_L(v, w) = sum_i (dv/dL_i)(dw/dL_i) u_L^2.
TEST(BudgetCovariance, PlacementPartMatchesFiniteDifferences) {
  Design d = test::paper_design('C');
  Vector6d e;
  e << 5, -4, 3, 40, -30, 60;
  const std::vector<Reading> readings = exact_readings_moved(d, e, -1, 0.0);
  const IdentifyResult plain = identify(d, readings);
  const double uL = 0.2;
  Design with = d;
  with.setup_std.L_mm = uL;
  const IdentifyResult placed = identify(with, readings);
  ASSERT_EQ(plain.budget.values.size(), placed.budget.values.size());
  const Eigen::Index m = static_cast<Eigen::Index>(plain.budget.values.size());
  Eigen::MatrixXd expected = Eigen::MatrixXd::Zero(m, m);
  for (const Eigen::VectorXd& sh : value_shifts_per_L(d, e))
    expected += sh * sh.transpose() * uL * uL;
  const Eigen::MatrixXd got = budget_covariance(with, placed) - budget_covariance(d, plain);
  EXPECT_GT(expected.cwiseAbs().maxCoeff(),
            0.01);  // (um^2, urad^2) the placement matters: not a vacuous check
  EXPECT_TRUE(test::near(got, expected, 1e-4 * expected.cwiseAbs().maxCoeff()));
}

// The noise part against the gain (theta_hat = G y, so Cov = C G diag(sigma^2) G' C', a formula
// other than the pseudo-inverse covariance), scaled by the Type A factor; the diagonal is u_c^2.
TEST(BudgetCovariance, NoisePartIsThatOfTheGainAndScalesWithTypeA) {
  const Design d = test::paper_design('C');
  Truth t = constant_truth(d, Vector6d::Constant(2.0));
  t.repeats = 2;
  const std::vector<Reading> readings = simulate(d, t, 5);
  for (bool type_a : {false, true}) {
    IdentifyOptions opt;
    opt.budget.type_a = type_a;
    const IdentifyResult r = identify(d, readings, opt);
    const Eigen::MatrixXd C = budget_functions(r.param, r.budget);
    const Eigen::MatrixXd CG = C * r.solver->J_theta_reading().sparse();
    const double s2 = type_a ? *r.budget.type_a_scale * *r.budget.type_a_scale : 1.0;
    const Eigen::MatrixXd expected =
        s2 * CG * r.solver->sigma_um().cwiseAbs2().asDiagonal() * CG.transpose();
    const Eigen::MatrixXd cov = budget_covariance(d, r);
    EXPECT_TRUE(test::near(cov, expected, 1e-9 * expected.cwiseAbs().maxCoeff())) << type_a;
    for (size_t v = 0; v < r.budget.values.size(); ++v) {
      EXPECT_NEAR(std::sqrt(cov(v, v)), r.budget.values[v].u_c, 1e-9 * r.budget.values[v].u_c) << v;
    }
  }
}

// With declared length offset and centring tolerances (and L, D, H): the diagonal is u_c^2, and
// every pair agrees with the variance of the sum, Var(a + b) = Var(a) + Var(b) + 2 Cov(a, b),
// where Var(a + b) comes from the per-function form (SetupSolver::parts and the budget's
// sensitivities) of the function c_a + c_b.
TEST(BudgetCovariance, SetupPartAgreesWithTheVarianceOfSums) {
  Design d = test::paper_design('C');
  d.setup_std.length_offset_um = 10;
  d.setup_std.centring_um = 5;
  d.setup_std.D_mm = 0.1;
  Truth t = constant_truth(d, Vector6d::Constant(2.0));
  const std::vector<Reading> readings = simulate(d, t, 9);
  const IdentifyResult r = identify(d, readings);
  ASSERT_TRUE(r.setup_included);
  const Eigen::MatrixXd cov = budget_covariance(d, r);
  const Eigen::Index m = cov.rows();
  ASSERT_EQ(m, static_cast<Eigen::Index>(r.budget.values.size()));
  for (Eigen::Index v = 0; v < m; ++v)
    EXPECT_NEAR(std::sqrt(cov(v, v)), r.budget.values[v].u_c, 1e-9 * r.budget.values[v].u_c);
  const SetupSolver setup(*r.solver, setup_effects(d, r.model, true));
  const std::vector<SetupInput> inputs = setup_inputs(d);
  const Eigen::MatrixXd GD =
      setup.gain_times(J_reading_setup(d, r.param, r.model, inputs, r.estimate.theta));
  const Eigen::MatrixXd C = budget_functions(r.param, r.budget);
  std::mt19937 rng(3);
  std::uniform_int_distribution<Eigen::Index> pick(0, m - 1);
  double largest_correlation = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const Eigen::Index a = pick(rng), b = pick(rng);
    const Eigen::VectorXd c = (C.row(a) + C.row(b)).transpose();
    const SetupSolver::Parts parts = setup.parts(c);
    double var = parts.noise + parts.setup;
    const Eigen::VectorXd sens = GD.transpose() * c;
    for (size_t j = 0; j < inputs.size(); ++j) var += std::pow(sens(j) * inputs[j].std_mm, 2);
    const double sum = cov(a, a) + cov(b, b) + 2 * cov(a, b);
    EXPECT_NEAR(sum, var, 1e-9 * var) << a << " " << b;
    if (a != b)
      largest_correlation =
          std::max(largest_correlation, std::abs(cov(a, b)) / std::sqrt(cov(a, a) * cov(b, b)));
  }
  EXPECT_GT(largest_correlation, 0.3);  // the off-diagonal terms matter
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(cov);
  EXPECT_GT(eig.eigenvalues().minCoeff(), -1e-9 * eig.eigenvalues().maxCoeff());  // a covariance
}

struct CoverageCase {
  const char* name;
  bool fourier;
  bool normal;
};

class Coverage95 : public ::testing::TestWithParam<CoverageCase> {};

TEST_P(Coverage95, IntervalsContainTheTruth) {
  const CoverageCase& c = GetParam();
  Design d = test::paper_design('C');
  if (c.fourier) d.errors = {ErrorModel::Kind::kFourier, 3};
  if (c.normal) {
    d.noise.distribution = NoiseModel::Distribution::kNormal;
    d.noise.std_um = 0.6;
  }
  MonteCarloOptions o;
  o.adaptive = false;
  o.max_trials = 100000;
  o.threads = 2;
  const MonteCarloResult mc =
      monte_carlo_a_priori(d, 0.95, o);  // offsets of the value from the truth
  std::mt19937_64 rng(5);
  std::normal_distribution<double> n01;
  // 1,000 machines: a value's share within 4.5 standard errors (+-3.1 %) of 95 %.
  const int sets = 1000;
  std::vector<int> inside(mc.values.size(), 0);
  const Parameterisation param(d);
  for (int s = 0; s < sets; ++s) {
    Truth t;
    t.model = d.errors;
    if (c.fourier) {
      for (int k = 0; k < 6; ++k) {
        for (int j = 0; j < 7; ++j) t.coefficients[k].push_back(10 * n01(rng));
      }
    } else {
      for (double a : d.angles_deg) {
        Vector6d e;
        for (int k = 0; k < 6; ++k) e(k) = 20 * n01(rng);
        test::add_truth_value(t, d.axis, a, e);
      }
    }
    const IdentifyResult r = identify(d, simulate(d, t, 1000 + s));
    ASSERT_EQ(r.budget.values.size(), mc.values.size());
    for (size_t v = 0; v < mc.values.size(); ++v) {
      const ValueBudget& b = r.budget.values[v];
      const MonteCarloValue& m = mc.values[v];
      const double lo = m.validated ? b.value - b.U : b.value + m.low;
      const double hi = m.validated ? b.value + b.U : b.value + m.high;
      const double truth = truth_errors(t, d.axis, b.angle_deg)(b.error);
      inside[v] += lo <= truth && truth <= hi;
    }
  }
  double pooled = 0;
  for (size_t v = 0; v < inside.size(); ++v) {
    EXPECT_TRUE(test::within_binomial(inside[v], sets, 0.95, 4.5))
        << c.name << " value " << v << ": " << inside[v];
    pooled += inside[v];
  }
  pooled /= static_cast<double>(inside.size());
  // The pooled share is a mean of correlated shares: its spread is at most that of one value.
  EXPECT_TRUE(test::within_binomial(pooled, sets, 0.95, 4.0))
      << c.name << " pooled " << pooled / sets;
}

INSTANTIATE_TEST_SUITE_P(Models, Coverage95,
                         ::testing::Values(CoverageCase{"per_angle_normal", false, true},
                                           CoverageCase{"per_angle_rectangular", false, false},
                                           CoverageCase{"fourier_normal", true, true},
                                           CoverageCase{"fourier_rectangular", true, false}),
                         [](const auto& info) { return std::string(info.param.name); });

}  // namespace
}  // namespace dbbkit
