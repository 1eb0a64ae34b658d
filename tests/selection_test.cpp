// Model selection on small synthetic problems whose answer is known by construction,
// checked against least squares solved here with Eigen's column-pivoting QR (not
// the project's WLS solver).
#include "dbbkit/selection.hpp"

#include <gtest/gtest.h>

#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <random>

#include "dbbkit/io/diagnose_text.hpp"
#include "test_util.hpp"

namespace dbbkit {
namespace {

EffectBlock column(EffectKind kind, int installation, const std::string& label,
                   const Eigen::VectorXd& x) {
  EffectBlock b;
  b.effect.kind = kind;
  b.effect.installation = installation;
  b.label = label;
  b.parameters = {"value"};
  b.J_reading_effect = x;
  return b;
}

// Residual sum of squares of y on the columns of A (unit weights), by pivoted QR.
double rss(const Eigen::MatrixXd& A, const Eigen::VectorXd& y) {
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(A);
  return (y - A * qr.solve(y)).squaredNorm();
}

const AddedEffect* find_added(const Selection& s, const std::string& label) {
  for (const AddedEffect& a : s.added) {
    if (a.block.label == label) return &a;
  }
  return nullptr;
}

const CandidateStatus& status_of(const Selection& s, const std::string& label) {
  auto it = std::find_if(s.candidates.begin(), s.candidates.end(),
                         [&](const CandidateStatus& c) { return c.label == label; });
  EXPECT_NE(it, s.candidates.end()) << label;
  return *it;
}

// Two "installations" of n/2 readings each, an offset common to all (the model J)
// and noise N(0, 1): a drift of each half, the same drift on one clock over both.
struct TwoHalves {
  int n = 60;
  Eigen::MatrixXd J;
  Eigen::VectorXd sigma, t, a, b, w;
  explicit TwoHalves(int n_readings = 60) : n(n_readings) {
    J = Eigen::MatrixXd::Ones(n, 1);
    sigma = Eigen::VectorXd::Ones(n);
    t = Eigen::VectorXd::LinSpaced(n, 0.0, 1.0);
    a = Eigen::VectorXd::Zero(n);
    b = Eigen::VectorXd::Zero(n);
    for (int i = 0; i < n; ++i) (i < n / 2 ? a : b)(i) = t(i) - (i < n / 2 ? 0.0 : t(n / 2));
    w = t;
  }
  std::vector<EffectBlock> pool() const {
    return {column(EffectKind::kDrift, 0, "drift[0]", a),
            column(EffectKind::kDrift, 1, "drift[1]", b),
            column(EffectKind::kDrift, -1, "drift[all]", w)};
  }
  Eigen::VectorXd noise(std::mt19937_64& rng) const {
    std::normal_distribution<double> n01;
    Eigen::VectorXd e(n);
    for (int i = 0; i < n; ++i) e(i) = n01(rng);
    return e;
  }
};

TEST(Selection, CandidateStateNamesAreDistinct) {
  const std::vector<CandidateState> all = {
      CandidateState::kAdded,         CandidateState::kNotSignificant, CandidateState::kConfounded,
      CandidateState::kNotApplicable, CandidateState::kEquivalent,     CandidateState::kDetectable};
  std::vector<std::string> names;
  for (CandidateState s : all) names.emplace_back(candidate_state_name(s));
  EXPECT_EQ(names, (std::vector<std::string>{"added", "not significant", "confounded",
                                             "not applicable", "equivalent", "detectable"}));
}

TEST(Selection, BicIsTheTextbookFormula) {
  const TwoHalves h;
  std::mt19937_64 rng(3);
  const Eigen::VectorXd y = 2.0 + 5.0 * h.w.array() + h.noise(rng).array();
  const Selection s = select_effects(test::sparse(h.J), h.sigma, y, h.pool());
  const double n = h.n;
  EXPECT_NEAR(bic(s.before), n * std::log(rss(h.J, y) / n) + 1 * std::log(n), 1e-9);
}

// Pure noise: at a family-wise level of 0.01 per step, at most about 1 % of seeds add anything.
TEST(Selection, CleanDataAddsNothing) {
  const TwoHalves h;
  std::mt19937_64 rng(11);
  int clean = 0;
  const int seeds = 300;
  for (int s = 0; s < seeds; ++s)
    clean += select_effects(test::sparse(h.J), h.sigma, 1.0 + h.noise(rng).array(), h.pool())
                 .added.empty();
  EXPECT_GE(clean, 0.97 * seeds) << clean;
}

// A drift on one clock is added as one whole-test term; the F-test, chi2 and value
// agree with least squares solved here, and the structure comparison reports the
// per-installation pair it rejected with both BICs.
TEST(Selection, WholeTestDriftIsOneTermWithTheRejectedPairReported) {
  const TwoHalves h;
  std::mt19937_64 rng(5);
  const Eigen::VectorXd y = 2.0 + 4.0 * h.w.array() + h.noise(rng).array();
  const Selection s = select_effects(test::sparse(h.J), h.sigma, y, h.pool());
  ASSERT_EQ(s.added.size(), 1u);
  const AddedEffect& d = s.added[0];
  EXPECT_EQ(d.block.label, "drift[all]");
  Eigen::MatrixXd A(h.n, 2);
  A << h.J, h.w;
  const Eigen::VectorXd theta = A.colPivHouseholderQr().solve(y);
  const double rss_after = rss(A, y), rss_before = rss(h.J, y);
  EXPECT_NEAR(s.after.chi2, rss_after, 1e-9);
  EXPECT_NEAR(d.values.at(0).value, theta(1), 1e-9);
  EXPECT_NEAR(d.evidence.F, (rss_before - rss_after) / (rss_after / (h.n - 2)), 1e-6);
  EXPECT_EQ(d.evidence.dof, h.n - 2);
  EXPECT_EQ(status_of(s, "drift[0]").state, CandidateState::kNotSignificant);
  ASSERT_EQ(s.structures.size(), 1u);
  const StructureComparison& c = s.structures[0];
  EXPECT_EQ(c.kind, "drift");
  EXPECT_EQ(c.chosen, std::vector<std::string>{"drift[all]"});
  EXPECT_EQ(c.rejected, (std::vector<std::string>{"drift[0]", "drift[1]"}));
  Eigen::MatrixXd B(h.n, 3);
  B << h.J, h.a, h.b;
  const double n = h.n;
  EXPECT_NEAR(c.bic_chosen, n * std::log(rss_after / n) + 2 * std::log(n), 1e-9);
  EXPECT_NEAR(c.bic_rejected, n * std::log(rss(B, y) / n) + 3 * std::log(n), 1e-9);
  EXPECT_LT(c.bic_chosen, c.bic_rejected);
}

// Different drifts per installation (one flat, one steep): two terms, and the single
// whole-test drift is reported as the rejected alternative with the higher BIC.
TEST(Selection, DifferentDriftsPerInstallationKeepTwoTerms) {
  const TwoHalves h;
  std::mt19937_64 rng(7);
  int kept = 0;
  const int seeds = 100;
  for (int seed = 0; seed < seeds; ++seed) {
    const Eigen::VectorXd y = 2.0 + 12.0 * h.a.array() - 12.0 * h.b.array() + h.noise(rng).array();
    const Selection s = select_effects(test::sparse(h.J), h.sigma, y, h.pool());
    const bool both =
        find_added(s, "drift[0]") && find_added(s, "drift[1]") && !find_added(s, "drift[all]");
    const bool reported = s.structures.size() == 1 &&
                          s.structures[0].rejected == std::vector<std::string>{"drift[all]"} &&
                          s.structures[0].bic_chosen < s.structures[0].bic_rejected;
    kept += both && reported;
  }
  EXPECT_GE(kept, 95) << kept << " of " << seeds;
}

// A candidate in the span of J is confounded and never added, however large.
TEST(Selection, CandidateInTheSpanOfTheModelIsConfounded) {
  const TwoHalves h;
  std::mt19937_64 rng(9);
  const Eigen::VectorXd y = 50.0 + h.noise(rng).array();
  std::vector<EffectBlock> pool = h.pool();
  pool.push_back(column(EffectKind::kLengthOffset, -1, "length_offset[all]",
                        Eigen::VectorXd::Constant(h.n, 1.0)));
  const Selection s = select_effects(test::sparse(h.J), h.sigma, y, pool);
  EXPECT_EQ(status_of(s, "length_offset[all]").state, CandidateState::kConfounded);
  EXPECT_EQ(find_added(s, "length_offset[all]"), nullptr);
}

// The model J holds a slope and the offset common to both halves: the offset of half 0
// and that of half 1 are each identifiable alone, and each lies in the span of J plus
// the other. The later installation carries the effect.
TEST(Selection, EquivalentCandidatesGoToTheLaterInstallation) {
  const TwoHalves h;
  std::mt19937_64 rng(13);
  Eigen::VectorXd o0 = Eigen::VectorXd::Zero(h.n), o1 = Eigen::VectorXd::Zero(h.n);
  o0.head(h.n / 2).setOnes();
  o1.tail(h.n - h.n / 2).setOnes();
  Eigen::MatrixXd J(h.n, 2);
  J << h.t, o0 + o1;  // the axis errors see only the common offset
  const Eigen::VectorXd y = 3.0 * h.t.array() + 6.0 * o0.array() + h.noise(rng).array();
  const Selection s =
      select_effects(test::sparse(J), h.sigma, y,
                     {column(EffectKind::kLengthOffset, 0, "length_offset[0]", o0),
                      column(EffectKind::kLengthOffset, 1, "length_offset[1]", o1)});
  ASSERT_EQ(s.added.size(), 1u);
  EXPECT_EQ(s.added[0].block.label, "length_offset[1]");
  EXPECT_EQ(s.added[0].equivalent_to, std::vector<std::string>{"length_offset[0]"});
  EXPECT_EQ(status_of(s, "length_offset[0]").state, CandidateState::kEquivalent);
  // Only the difference is determined: the later installation's offset is minus the earlier's 6.
  EXPECT_NEAR(s.added[0].values.at(0).value, -6.0, 4 * s.added[0].values.at(0).std);
  // Without a design the text names an installation, as a ball bar's does; a probe's design
  // names the later channel, or the later sphere for a sphere's effect (selection sets the note
  // from the instrument's entry).
  CandidateStatus equivalent = status_of(s, "length_offset[0]");
  EXPECT_NE(io::candidate_detail(equivalent).find("the later installation carries it"),
            std::string::npos)
      << io::candidate_detail(equivalent);
  for (const char* carrier : {"the later channel", "the component found first"}) {
    equivalent.note = carrier;
    EXPECT_NE(io::candidate_detail(equivalent)
                  .find(std::string("by convention ") + carrier + " carries it"),
              std::string::npos)
        << io::candidate_detail(equivalent);
  }
}

// The data are 8 a + 5 b. Forward selection takes first the candidate nearest them
// (c, nearly a + b), then a, then b, which together explain the data to the noise;
// c is then no longer significant and is dropped.
TEST(Selection, AnEarlyChoiceMadeRedundantIsDropped) {
  const int n = 80;
  std::mt19937_64 rng(17);
  std::normal_distribution<double> n01;
  Eigen::VectorXd a(n), b(n), noise(n);
  for (int i = 0; i < n; ++i) a(i) = n01(rng), b(i) = n01(rng), noise(i) = 0.05 * n01(rng);
  const Eigen::VectorXd c =
      a + b + 0.3 * Eigen::VectorXd::NullaryExpr(n, [&](Eigen::Index) { return n01(rng); });
  const Eigen::VectorXd y = 8.0 * a + 5.0 * b + noise;
  const Eigen::MatrixXd J = Eigen::MatrixXd::Ones(n, 1);
  const Selection s = select_effects(
      test::sparse(J), Eigen::VectorXd::Constant(n, 0.05), y,
      {column(EffectKind::kPeriodic, 0, "a", a), column(EffectKind::kPeriodic, 0, "b", b),
       column(EffectKind::kPeriodic, 0, "c", c)});
  EXPECT_NE(find_added(s, "a"), nullptr);
  EXPECT_NE(find_added(s, "b"), nullptr);
  EXPECT_EQ(find_added(s, "c"), nullptr);
  EXPECT_EQ(status_of(s, "c").state, CandidateState::kNotSignificant);
  EXPECT_EQ(s.added.size(), 2u);
  EXPECT_NEAR(s.after.chi2, rss((Eigen::MatrixXd(n, 3) << J, a, b).finished(), y) / (0.05 * 0.05),
              1e-6);
}

}  // namespace
}  // namespace dbbkit

namespace dbbkit {
namespace {

// With room for two effects only, forward selection takes c (nearly a + b) and then a;
// the exchange pass puts b in c's place, which explains the data to the noise.
TEST(Selection, ExchangeUndoesAnEarlyChoiceThatFitsWorse) {
  const int n = 80;
  std::mt19937_64 rng(19);
  std::normal_distribution<double> n01;
  Eigen::VectorXd a(n), b(n), z(n), noise(n);
  for (int i = 0; i < n; ++i)
    a(i) = n01(rng), b(i) = n01(rng), z(i) = n01(rng), noise(i) = 0.05 * n01(rng);
  const Eigen::VectorXd c = a + b + 0.3 * z;
  const Eigen::VectorXd y = 8.0 * a + 5.0 * b + noise;
  const Eigen::MatrixXd J = Eigen::MatrixXd::Ones(n, 1);
  SelectionOptions options;
  options.max_effects = 2;
  const Selection s = select_effects(
      test::sparse(J), Eigen::VectorXd::Constant(n, 0.05), y,
      {column(EffectKind::kPeriodic, 0, "a", a), column(EffectKind::kPeriodic, 0, "b", b),
       column(EffectKind::kPeriodic, 0, "c", c)},
      options);
  ASSERT_EQ(s.added.size(), 2u);
  EXPECT_NE(find_added(s, "a"), nullptr);
  EXPECT_NE(find_added(s, "b"), nullptr);
  EXPECT_NE(io::candidate_detail(status_of(s, "b")).find("exchanged in for c"), std::string::npos)
      << io::candidate_detail(status_of(s, "b"));
  EXPECT_EQ(status_of(s, "c").state, CandidateState::kNotSignificant);
  // The values are those of least squares on [1, a, b], each under its own label.
  Eigen::MatrixXd A(n, 3);
  A << J, a, b;
  const Eigen::VectorXd theta = A.colPivHouseholderQr().solve(y);
  EXPECT_NEAR(find_added(s, "a")->values.at(0).value, theta(1), 1e-9);
  EXPECT_NEAR(find_added(s, "b")->values.at(0).value, theta(2), 1e-9);
}

}  // namespace
}  // namespace dbbkit
