#include "dbbkit/uncertainty.hpp"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <random>

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
  t.model.kind = ErrorModel::Kind::PerAngle;
  for (double a : d.angles_deg) test::add_truth_value(t, d.axis, a, e);
  return t;
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
  heavy.distribution = NoiseModel::Distribution::Normal;
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

// The set-up component against a finite difference: readings taken with every ball
// moved by dL, identified with the nominal design, shift the values by dvalue; with
// independent inputs u_setup^2 = sum_i (dvalue_i/dL)^2 u_L^2 over the installations i.
TEST(Budget, SetupUncertaintyMatchesFiniteDifference) {
  Design d = test::paper_design('C');
  d.setup_std.L_mm = 0.2;
  Vector6d e;
  e << 5, -4, 3, 40, -30, 60;
  Truth t = constant_truth(d, e);
  t.noiseless = true;
  const IdentifyResult nominal = identify(d, simulate(d, t, 0));
  std::vector<Eigen::VectorXd> shift;  // per installation, dvalue/dL over the budget's values
  const double dL = 0.5;
  for (size_t i = 0; i < d.installations.size(); ++i) {
    Design moved = d;
    moved.installations[i].L_mm += dL;
    std::vector<Reading> readings = simulate(moved, t, 0);
    const IdentifyResult r = identify(d, readings);
    Eigen::VectorXd s(nominal.budget.values.size());
    for (size_t v = 0; v < nominal.budget.values.size(); ++v) {
      s(v) = (r.budget.values[v].value - nominal.budget.values[v].value) / dL;
    }
    shift.push_back(s);
  }
  int checked = 0;
  for (size_t v = 0; v < nominal.budget.values.size(); ++v) {
    double expected2 = 0;
    for (const auto& s : shift) expected2 += std::pow(s(v) * 0.2, 2);
    double got = 0;
    for (const BudgetComponent& c : nominal.budget.values[v].components) {
      if (c.name == "set-up L") got = c.u;
    }
    EXPECT_NEAR(got, std::sqrt(expected2), 1e-9 + 1e-6 * std::sqrt(expected2)) << v;
    checked += expected2 > 1e-6;
  }
  EXPECT_GT(checked, 30);  // the set-up matters for many values, not a vacuous check
}

// The joint covariance of the values. Its L part against finite differences of the
// identification (the exact simulator moved by dL per installation), off the diagonal too:
// with independent inputs Cov_L(v, w) = sum_i (dv/dL_i)(dw/dL_i) u_L^2.
TEST(BudgetCovariance, PlacementPartMatchesFiniteDifferences) {
  Design d = test::paper_design('C');
  Vector6d e;
  e << 5, -4, 3, 40, -30, 60;
  Truth t = constant_truth(d, e);
  t.noiseless = true;
  const std::vector<Reading> readings = simulate(d, t, 0);
  const IdentifyResult plain = identify(d, readings);
  const double uL = 0.2;
  Design with = d;
  with.setup_std.L_mm = uL;
  const IdentifyResult placed = identify(with, readings);
  ASSERT_EQ(plain.budget.values.size(), placed.budget.values.size());
  const Eigen::Index m = static_cast<Eigen::Index>(plain.budget.values.size());
  Eigen::MatrixXd expected = Eigen::MatrixXd::Zero(m, m);
  const double dL = 0.5;
  for (size_t i = 0; i < d.installations.size(); ++i) {
    Design moved = d;
    moved.installations[i].L_mm += dL;
    const IdentifyResult r = identify(d, simulate(moved, t, 0));
    Eigen::VectorXd s(m);
    for (Eigen::Index v = 0; v < m; ++v)
      s(v) = (r.budget.values[v].value - plain.budget.values[v].value) / dL;
    expected += s * s.transpose() * uL * uL;
  }
  const Eigen::MatrixXd got = budget_covariance(with, placed) - budget_covariance(d, plain);
  EXPECT_GT(expected.cwiseAbs().maxCoeff(),
            0.01);  // (um^2, urad^2) the placement matters: not a vacuous check
  EXPECT_TRUE(test::near(got, expected, 1e-6 * expected.cwiseAbs().maxCoeff()));
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
    const Eigen::MatrixXd CG = C * r.solver.gain().sparse();
    const double s2 = type_a ? *r.budget.type_a_scale * *r.budget.type_a_scale : 1.0;
    const Eigen::MatrixXd expected =
        s2 * CG * r.solver.sigma_um().cwiseAbs2().asDiagonal() * CG.transpose();
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
  const SetupSolver setup(r.solver, setup_effects(d, r.model, true));
  const std::vector<SetupInput> inputs = setup_inputs(d);
  const Eigen::MatrixXd GD =
      setup.gain_times(setup_sensitivity(d, r.param, r.model, inputs, r.estimate.theta));
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

TEST(MonteCarlo, AgreesWithTheLinearResultForNormalNoise) {
  Design d = test::paper_design('C');
  d.noise.distribution = NoiseModel::Distribution::Normal;
  d.noise.std_um = 0.7;
  MonteCarloOptions o;
  o.significant_digits = 1;
  o.threads = 2;
  const MonteCarloResult mc = monte_carlo_a_priori(d, 0.95, o);
  EXPECT_TRUE(mc.converged);
  EXPECT_EQ(mc.n_validated, 108) << mc.message;
}

// The comparison can fail: with rectangular noise, dz at every angle but 0 is one
// rectangular reading, whose 95% interval is +-0.95 a, not +-1.96 a/sqrt(3).
TEST(MonteCarlo, DetectsANonGaussianOutput) {
  const Design d = test::paper_design('C');
  MonteCarloOptions o;
  o.significant_digits = 1;
  const MonteCarloResult mc = monte_carlo_a_priori(d, 0.95, o);
  int dz_checked = 0;
  for (const MonteCarloValue& v : mc.values) {
    if (v.error != 2 || v.angle_deg == 0.0) continue;
    EXPECT_FALSE(v.validated) << v.angle_deg;
    EXPECT_NEAR(v.high, 0.95 * 1.25, 0.01);
    EXPECT_NEAR(v.linear_U, 1.959964 * 1.25 / std::sqrt(3.0), 1e-6);
    ++dz_checked;
  }
  EXPECT_EQ(dz_checked, 17);
}

// With set-up tolerances, the map from readings to values formed (values x readings) and
// applied as a product (large designs, MonteCarloOptions::max_dense_gain_bytes) give the same
// trials to rounding: the same intervals to far below their numerical tolerance.
TEST(MonteCarlo, FactoredSetupGainAgreesWithTheFormedOne) {
  Design d = test::paper_design('C');
  d.setup_std.length_offset_um = 3;
  d.setup_std.centring_um = 2;
  MonteCarloOptions o;
  o.adaptive = false;
  o.max_trials = 20000;
  o.seed = 11;
  const MonteCarloResult formed = monte_carlo_a_priori(d, 0.95, o);
  o.max_dense_gain_bytes = 0;
  const MonteCarloResult product = monte_carlo_a_priori(d, 0.95, o);
  ASSERT_EQ(formed.values.size(), product.values.size());
  ASSERT_FALSE(formed.values.empty());
  double largest_setup_share = 0;
  for (size_t i = 0; i < formed.values.size(); ++i) {
    const MonteCarloValue& a = formed.values[i];
    const MonteCarloValue& b = product.values[i];
    const double tol = 1e-5 * a.std;
    EXPECT_NEAR(a.std, b.std, tol) << i;
    EXPECT_NEAR(a.low, b.low, tol) << i;
    EXPECT_NEAR(a.high, b.high, tol) << i;
    largest_setup_share = std::max(largest_setup_share, a.linear_u / (1.25 / std::sqrt(3.0)));
  }
  // The set-up part is present: u exceeds that of one reading's noise somewhere.
  EXPECT_GT(largest_setup_share, 1.0);
}

TEST(MonteCarlo, ReproducibleForASeedWhateverTheThreads) {
  const Design d = test::paper_design('B');
  MonteCarloOptions o;
  o.adaptive = false;
  o.max_trials = 20000;
  o.seed = 77;
  o.threads = 1;
  const MonteCarloResult one = monte_carlo_a_priori(d, 0.95, o);
  o.threads = 2;
  const MonteCarloResult two = monte_carlo_a_priori(d, 0.95, o);
  o.seed = 78;
  const MonteCarloResult other = monte_carlo_a_priori(d, 0.95, o);
  ASSERT_EQ(one.values.size(), two.values.size());
  bool differs = false;
  for (size_t i = 0; i < one.values.size(); ++i) {
    EXPECT_EQ(one.values[i].low, two.values[i].low);
    EXPECT_EQ(one.values[i].std, two.values[i].std);
    differs = differs || one.values[i].std != other.values[i].std;
  }
  EXPECT_TRUE(differs);
}

TEST(MonteCarlo, EndpointsDoNotDependOnTheBatchingAndAreFoundToATenthOfTheTolerance) {
  // The trials are the same whatever the batch size (one stream per chunk of 1000), so
  // one batch of 100,000 and ten of 10,000 give the same mean and standard deviation
  // (to rounding) and endpoints within the resolution each is placed to (a tenth of the
  // numerical tolerance). With four significant digits the tolerance is a hundred times
  // finer: the endpoints are found by replaying the trials into narrower windows, and the
  // two-digit endpoints lie within their resolution of them.
  const Design d = test::paper_design('C');
  MonteCarloOptions o;
  o.adaptive = false;
  o.max_trials = 100000;
  o.batch_trials = 100000;
  o.threads = 2;
  const MonteCarloResult one = monte_carlo_a_priori(d, 0.95, o);
  o.batch_trials = 10000;
  const MonteCarloResult many = monte_carlo_a_priori(d, 0.95, o);
  o.significant_digits = 4;
  const MonteCarloResult fine = monte_carlo_a_priori(d, 0.95, o);
  EXPECT_EQ(one.refinement_passes, 0);
  EXPECT_GT(fine.refinement_passes, 0);
  ASSERT_EQ(one.values.size(), many.values.size());
  ASSERT_EQ(one.values.size(), fine.values.size());
  for (size_t v = 0; v < one.values.size(); ++v) {
    const MonteCarloValue &a = one.values[v], &b = many.values[v], &f = fine.values[v];
    EXPECT_NEAR(a.mean, b.mean, 1e-12 + 1e-9 * a.std) << v;
    EXPECT_NEAR(a.std, b.std, 1e-9 * a.std) << v;
    const double res2 = 0.1 * std::min(numerical_tolerance(a.std, 2), a.delta);
    const double res4 = 0.1 * std::min(numerical_tolerance(f.std, 4), f.delta);
    EXPECT_NEAR(a.low, b.low, 2 * res2) << v;
    EXPECT_NEAR(a.high, b.high, 2 * res2) << v;
    EXPECT_NEAR(a.low, f.low, res2 + res4) << v;
    EXPECT_NEAR(a.high, f.high, res2 + res4) << v;
  }
}

// Coverage: over 2000 simulated data sets the reported 95% intervals (linear where
// Monte Carlo validates it, Monte Carlo otherwise) contain the truth 95% of the time,
// within the binomial tolerance, per value and pooled.
struct CoverageCase {
  const char* name;
  bool fourier;
  bool normal;
};

class Coverage95 : public ::testing::TestWithParam<CoverageCase> {};

TEST_P(Coverage95, IntervalsContainTheTruth) {
  const CoverageCase& c = GetParam();
  Design d = test::paper_design('C');
  if (c.fourier) d.errors = {ErrorModel::Kind::Fourier, 3};
  if (c.normal) {
    d.noise.distribution = NoiseModel::Distribution::Normal;
    d.noise.std_um = 0.6;
  }
  MonteCarloOptions o;
  o.adaptive = false;
  o.max_trials = 200000;
  o.threads = 2;
  const MonteCarloResult mc =
      monte_carlo_a_priori(d, 0.95, o);  // offsets of the value from the truth
  std::mt19937_64 rng(5);
  std::normal_distribution<double> n01;
  const int sets = 2000;
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
