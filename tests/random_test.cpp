// The Monte Carlo propagations' random deviates (src/random.hpp): the ziggurat's tables close,
// and the normal and chi-squared deviates follow their distributions (binned against the exact
// CDFs of Boost.Math, the tails counted on their own, the first four moments).

#include "../src/random.hpp"

#include <gtest/gtest.h>

#include <boost/math/distributions/chi_squared.hpp>
#include <boost/math/distributions/normal.hpp>
#include <cmath>
#include <vector>

#include "test_util.hpp"

namespace dbbkit {
namespace {

using detail::ChiSquared;
using detail::NormalZiggurat;
using detail::Xoshiro256pp;
using detail::Xoshiro256ppX4;

// The four-lane generator's words are, lane by lane, those of the one-stream generator from
// the lane's state: the vector code computes xoshiro256++ itself.
TEST(Xoshiro256ppX4, EachLaneIsTheScalarGeneratorFromItsState) {
  for (std::uint64_t seed : {0ULL, 1ULL, 0xDEADBEEFULL, ~0ULL}) {
    Xoshiro256ppX4 x4(seed);
    std::vector<Xoshiro256pp> lanes;
    for (int l = 0; l < Xoshiro256ppX4::kLanes; ++l) {
      std::uint64_t state[4];
      x4.lane_state(l, state);
      lanes.push_back(Xoshiro256pp::from_state(state));
    }
    std::vector<std::uint64_t> words(4000);
    for (int round = 0; round < 3; ++round) {  // the state carries over between calls
      x4.fill(words.data(), words.size());
      for (std::size_t k = 0; k < words.size(); ++k)
        ASSERT_EQ(words[k], lanes[k % 4]()) << "seed " << seed << " word " << k;
    }
  }
  // Different seeds give different lanes, and the lanes of one seed differ.
  std::uint64_t a[4], b[4], c[4];
  Xoshiro256ppX4(1).lane_state(0, a);
  Xoshiro256ppX4(2).lane_state(0, b);
  Xoshiro256ppX4(1).lane_state(1, c);
  EXPECT_NE(a[0], b[0]);
  EXPECT_NE(a[0], c[0]);
}

TEST(Ziggurat, LayersHaveEqualAreaAndTheTopOneCloses) {
  const NormalZiggurat::Tables& t = NormalZiggurat::tables();
  const double v = t.area;
  // The base layer: rectangle [0, r] x [0, f(r)] and the tail beyond r, by the normal CDF.
  const double tail = std::sqrt(2 * std::acos(-1.0)) *
                      boost::math::cdf(boost::math::complement(boost::math::normal(), t.x[1]));
  EXPECT_NEAR(t.x[1] * t.fx[1] + tail, v, 1e-15);
  EXPECT_NEAR(t.x[0] * t.fx[1], v, 1e-15);
  for (int i = 1; i < NormalZiggurat::kLayers; ++i) {
    EXPECT_GT(t.x[i], t.x[i + 1]) << i;
    EXPECT_NEAR(t.x[i] * (t.fx[i + 1] - t.fx[i]), v, 1e-12 * v) << i;
  }
  // The top layer (x in [0, x_255], y in [f(x_255), 1]) has area v when r is right: the
  // recursion's end, not imposed.
  const int top = NormalZiggurat::kLayers - 1;
  EXPECT_NEAR(t.x[top] * (1.0 - t.fx[top]), v, 1e-9 * v);
  EXPECT_EQ(t.fx[NormalZiggurat::kLayers], 1.0);
}

// Pearson's statistic of n draws in `bins` equiprobable bins of the distribution `cdf` (whose
// quantiles are given), against the chi-squared quantile of level 1 - 1e-6.
template <class Draw, class Quantile>
void expect_fits(const char* what, long n, int bins, Draw draw, Quantile quantile) {
  std::vector<double> edges;
  for (int b = 1; b < bins; ++b) edges.push_back(quantile(static_cast<double>(b) / bins));
  std::vector<long> count(bins, 0);
  for (long k = 0; k < n; ++k) {
    const double x = draw();
    ASSERT_TRUE(std::isfinite(x));
    count[std::upper_bound(edges.begin(), edges.end(), x) - edges.begin()] += 1;
  }
  const double expected = static_cast<double>(n) / bins;
  double x2 = 0;
  for (long c : count) x2 += (c - expected) * (c - expected) / expected;
  const double limit = boost::math::quantile(boost::math::chi_squared(bins - 1), 1 - 1e-6);
  EXPECT_LT(x2, limit) << what;
}

TEST(Ziggurat, DeviatesAreStandardNormal) {
  Xoshiro256pp rng(42);
  const NormalZiggurat n01;
  const boost::math::normal N;
  expect_fits(
      "normal", 2000000, 200, [&] { return n01(rng); },
      [&](double p) { return boost::math::quantile(N, p); });

  // The tails (beyond the base layer's r, drawn by their own method, and far beyond) and the
  // moments.
  const long n = 4000000;
  long beyond_r = 0, beyond_4 = 0, negative = 0;
  double m1 = 0, m2 = 0, m3 = 0, m4 = 0;
  for (long k = 0; k < n; ++k) {
    const double x = n01(rng);
    beyond_r += std::abs(x) > NormalZiggurat::kR;
    beyond_4 += std::abs(x) > 4.0;
    negative += x < 0;
    m1 += x;
    m2 += x * x;
    m3 += x * x * x;
    m4 += x * x * x * x;
  }
  const double p_r = 2 * boost::math::cdf(boost::math::complement(N, NormalZiggurat::kR));
  const double p_4 = 2 * boost::math::cdf(boost::math::complement(N, 4.0));
  EXPECT_TRUE(test::within_binomial(beyond_r, n, p_r, 4.5)) << beyond_r << " vs " << p_r * n;
  EXPECT_TRUE(test::within_binomial(beyond_4, n, p_4, 4.5)) << beyond_4 << " vs " << p_4 * n;
  EXPECT_TRUE(test::within_binomial(negative, n, 0.5, 4.5)) << negative;
  const double dn = static_cast<double>(n);
  // Standard errors of the sample moments of N(0, 1): sqrt(1/n), sqrt(2/n), sqrt(15/n), sqrt(96/n).
  EXPECT_NEAR(m1 / dn, 0.0, 4.5 * std::sqrt(1 / dn));
  EXPECT_NEAR(m2 / dn, 1.0, 4.5 * std::sqrt(2 / dn));
  EXPECT_NEAR(m3 / dn, 0.0, 4.5 * std::sqrt(15 / dn));
  EXPECT_NEAR(m4 / dn, 3.0, 4.5 * std::sqrt(96 / dn));
}

TEST(Ziggurat, TheStreamIsFixedBySeed) {
  Xoshiro256pp a(7), b(7), c(8);
  const NormalZiggurat n01;
  bool differs = false;
  for (int k = 0; k < 1000; ++k) {
    const double x = n01(a);
    EXPECT_EQ(x, n01(b));
    differs = differs || x != n01(c);
  }
  EXPECT_TRUE(differs);
}

TEST(ChiSquaredDeviates, FollowTheirDistribution) {
  for (double nu : {1.0, 1.5, 2.0, 5.0, 30.0, 400.0}) {
    Xoshiro256pp rng(static_cast<std::uint64_t>(nu * 10));
    const ChiSquared chi2(nu);
    const boost::math::chi_squared C(nu);
    const std::string what = "nu = " + std::to_string(nu);
    expect_fits(
        what.c_str(), 400000, 100, [&] { return chi2(rng); },
        [&](double p) { return boost::math::quantile(C, p); });
  }
}

// The conversion to [0, 1): the top 52 bits, every multiple of 2^-52, both ends exact.
TEST(UnitInterval, IsTheTop52BitsTimes2ToTheMinus52) {
  EXPECT_EQ(detail::unit_interval(0), 0.0);
  EXPECT_EQ(detail::unit_interval(0xFFFULL), 0.0);  // the low 12 bits are dropped
  EXPECT_EQ(detail::unit_interval(~0ULL), 1.0 - 0x1.0p-52);
  EXPECT_EQ(detail::unit_interval(1ULL << 12), 0x1.0p-52);
  EXPECT_EQ(detail::unit_interval(1ULL << 63), 0.5);
  std::uint64_t w = 0x0123456789ABCDEFULL;
  EXPECT_EQ(detail::unit_interval(w), static_cast<double>(w >> 12) * 0x1.0p-52);
  // Uniform, as the Monte Carlo draws rectangular noise from the block generator's words.
  detail::BlockXoshiro rng(7);
  std::vector<std::uint64_t> words(1000);
  std::size_t next = words.size();
  expect_fits(
      "uniform", 2000000, 200,
      [&] {
        if (next == words.size()) {
          rng.fill(words.data(), words.size());
          next = 0;
        }
        return detail::unit_interval(words[next++]);
      },
      [](double p) { return p; });
}

// The ziggurat on the block generator's words (as the Monte Carlo draws its normals).
TEST(Ziggurat, DeviatesFromTheBlockGeneratorAreStandardNormal) {
  detail::BlockXoshiro rng(43);
  const NormalZiggurat n01;
  const boost::math::normal N;
  expect_fits(
      "normal (block words)", 2000000, 200, [&] { return n01(rng); },
      [&](double p) { return boost::math::quantile(N, p); });
}

}  // namespace
}  // namespace dbbkit
