// The Monte Carlo propagation (JCGM 101, monte_carlo.hpp): agreement with the linear
// result, a non-Gaussian output, the factored set-up gain, reproducibility whatever the
// threads, and the interval endpoints' numerical tolerance.

#include "dbbkit/monte_carlo.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "dbbkit/identify.hpp"
#include "dbbkit/io/result_io.hpp"
#include "dbbkit/setup.hpp"
#include "dbbkit/simulate.hpp"
#include "test_util.hpp"

namespace dbbkit {
namespace {

TEST(MonteCarlo, AgreesWithTheLinearResultForNormalNoise) {
  Design d = test::paper_design('C');
  d.noise.distribution = NoiseModel::Distribution::kNormal;
  d.noise.std_um = 0.7;
  MonteCarloOptions o;
  o.significant_digits = 1;
  o.threads = 2;
  const MonteCarloResult mc = monte_carlo_a_priori(d, 0.95, o);
  EXPECT_TRUE(mc.converged);
  EXPECT_EQ(mc.n_validated, 108) << io::monte_carlo_message(mc);
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

}  // namespace
}  // namespace dbbkit
