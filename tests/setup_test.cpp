// Set-up errors as nuisance effects with a prior (setup.hpp), checked against
// forms that do not share its algebra: generalised least squares with the full
// covariance V = Sigma + X P X', the factorised augmented problem, the normal
// approximation of the noncentral F, and data from the exact two-ball geometry.

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <Eigen/QR>
#include <Eigen/SVD>
#include <boost/math/distributions/fisher_f.hpp>
#include <boost/math/distributions/normal.hpp>
#include <random>

#include "dbbkit/identify.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/observability.hpp"
#include "dbbkit/setup.hpp"
#include "dbbkit/simulate.hpp"
#include "test_util.hpp"

namespace dbbkit {
namespace {

Design with_setup(Design d, double length_um, double centring_um) {
  d.setup_std.length_offset_um = length_um;
  d.setup_std.centring_um = centring_um;
  return d;
}

Eigen::MatrixXd stacked(const std::vector<SetupEffect>& effects, int n) {
  int q = 0;
  for (const SetupEffect& e : effects) q += static_cast<int>(e.X.cols());
  Eigen::MatrixXd X(n, q);
  int j = 0;
  for (const SetupEffect& e : effects) {
    X.middleCols(j, e.X.cols()) = e.X;
    j += static_cast<int>(e.X.cols());
  }
  return X;
}

Eigen::VectorXd prior_variances(const std::vector<SetupEffect>& effects) {
  std::vector<double> v;
  for (const SetupEffect& e : effects) {
    for (int c = 0; c < e.X.cols(); ++c) v.push_back(e.std_um * e.std_um);
  }
  return Eigen::Map<Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size()));
}

TEST(SetupSolver, AgreesWithGeneralisedLeastSquaresOnTheFullCovariance) {
  // Full rank (the paper's C design, 7 readings per angle): theta_hat, the total
  // covariance and its noise and set-up parts against the textbook GLS with V explicit.
  Design d = with_setup(test::paper_design('C'), 10, 5);
  d.installations[5].setup_std.centring_um = 8;  // a per-installation override
  const Parameterisation param(d);
  const LinearModel model = design_model(d, param);
  const WlsSolver base(model.J, model.sigma_um);
  ASSERT_EQ(base.a_priori().status, EstimateStatus::kFullRank);
  const std::vector<SetupEffect> effects = setup_effects(d, model, true);
  const SetupSolver solver(base, effects);
  const int n = static_cast<int>(model.J.rows());
  const Eigen::MatrixXd X = stacked(effects, n);
  const Eigen::VectorXd P = prior_variances(effects);
  EXPECT_EQ(solver.n_columns(), X.cols());
  EXPECT_EQ((P.array() == 64.0).count(), 2);  // cx, cy of the override (radial and tangential: no cz)
  EXPECT_EQ((P.array() == 25.0).count(), 2 * 5 + 1);  // the other five radial/tangential; the axial 1a sees only cz

  const Eigen::MatrixXd Sigma = model.sigma_um.cwiseAbs2().asDiagonal();
  const Eigen::MatrixXd V = Sigma + X * P.asDiagonal() * X.transpose();
  const Eigen::MatrixXd Vi = V.ldlt().solve(Eigen::MatrixXd::Identity(n, n));
  const Eigen::MatrixXd M = model.J.transpose() * Vi * model.J;
  const Eigen::MatrixXd C = M.ldlt().solve(Eigen::MatrixXd::Identity(M.rows(), M.cols()));
  const Eigen::MatrixXd G = C * model.J.transpose() * Vi;

  std::mt19937_64 rng(5);
  std::normal_distribution<double> z;
  Eigen::VectorXd y(n);
  for (int i = 0; i < n; ++i) y(i) = 3 * z(rng);
  const Estimate est = solver.solve(y);
  EXPECT_TRUE(test::near(est.theta, G * y, 1e-9, 1e-7));
  const Eigen::VectorXd r = y - model.J * est.theta;
  EXPECT_NEAR(est.chi2, r.dot(Vi * r), 1e-7 * est.chi2);
  EXPECT_EQ(est.dof, n - static_cast<int>(model.J.cols()));

  const Eigen::MatrixXd noise = G * Sigma * G.transpose();
  const Eigen::MatrixXd setup = G * X * P.asDiagonal() * X.transpose() * G.transpose();
  for (int j = 0; j < M.rows(); ++j) {
    const Eigen::VectorXd c = Eigen::VectorXd::Unit(M.rows(), j);
    const SetupSolver::Parts parts = solver.parts(c);
    EXPECT_NEAR(parts.noise, noise(j, j), 1e-9 + 1e-7 * noise(j, j)) << j;
    EXPECT_NEAR(parts.setup, setup(j, j), 1e-9 + 1e-7 * setup(j, j)) << j;
    EXPECT_NEAR(solver.a_priori().evaluate(c).std, std::sqrt(C(j, j)), 1e-9 + 1e-7 * std::sqrt(C(j, j))) << j;
  }
  // The set-up part is not negligible here: the check means something.
  EXPECT_GT(setup.diagonal().maxCoeff(), 0.1 * noise.diagonal().maxCoeff());
  // Response to an arbitrary reading pattern.
  const Eigen::MatrixXd Y = Eigen::MatrixXd::Random(n, 3);
  EXPECT_TRUE(test::near(solver.gain_times(Y), G * Y, 1e-9, 1e-7));
  // Posterior covariance of beta: (X' (Sigma^-1 - Sigma^-1 J (J'Sigma^-1 J)^-1 J' Sigma^-1) X + P^-1)^-1.
  const Eigen::MatrixXd Wi = model.sigma_um.cwiseAbs2().cwiseInverse().asDiagonal();
  const Eigen::MatrixXd M0 = model.J.transpose() * Wi * model.J;
  const Eigen::MatrixXd Q = Wi - Wi * model.J * M0.ldlt().solve(model.J.transpose() * Wi);
  Eigen::MatrixXd Sb = X.transpose() * Q * X;
  Sb.diagonal() += P.cwiseInverse();
  EXPECT_TRUE(test::near(solver.beta_covariance(), Sb.inverse(), 1e-9, 1e-6));
}

TEST(SetupSolver, DeterminedFunctionsAgreeWithTheFactorisedAugmentedProblem) {
  // Rank-deficient (the paper's B design): the whitened augmented matrix
  // [W^1/2 J, W^1/2 X; 0, P^-1/2], pseudo-inverted, gives the covariance of every
  // determined function of theta; the undetermined stay undetermined.
  Design d = with_setup(test::paper_design('B'), 20, 6);
  const Parameterisation param(d);
  const LinearModel model = design_model(d, param);
  const WlsSolver base(model.J, model.sigma_um);
  ASSERT_EQ(base.a_priori().status, EstimateStatus::kRankDeficient);
  const std::vector<SetupEffect> effects = setup_effects(d, model, true);
  const SetupSolver solver(base, effects);
  const int n = static_cast<int>(model.J.rows()), p = static_cast<int>(model.J.cols());
  const Eigen::MatrixXd X = stacked(effects, n);
  const Eigen::VectorXd P = prior_variances(effects);
  const int q = static_cast<int>(X.cols());
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(n + q, p + q);
  const Eigen::VectorXd w = model.sigma_um.cwiseInverse();
  A.topLeftCorner(n, p) = w.asDiagonal() * model.J;
  A.topRightCorner(n, q) = w.asDiagonal() * X;
  A.bottomRightCorner(q, q) = P.cwiseSqrt().cwiseInverse().asDiagonal();
  const Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod(A.transpose() * A);
  const Eigen::MatrixXd Caug = cod.pseudoInverse();
  const std::vector<ErrorsAtAngle> total = error_parts(param, solver).total;
  int determined = 0, undetermined = 0;
  for (int s = 0; s < param.n_stations(); ++s) {
    const Eigen::MatrixXd E = param.error_map(s);
    for (int k = 0; k < 6; ++k) {
      Eigen::VectorXd c = Eigen::VectorXd::Zero(p + q);
      c.head(p) = E.row(k).transpose();
      const bool det = base.a_priori().determined(E.row(k).transpose());
      EXPECT_EQ(total[s].errors[k].determined, det);
      if (!det) {
        ++undetermined;
        continue;
      }
      ++determined;
      const double expected = std::sqrt(c.dot(Caug * c));
      EXPECT_NEAR(total[s].errors[k].std, expected, 1e-6 * expected) << s << " " << k;
    }
  }
  EXPECT_GT(determined, 0);
  EXPECT_GT(undetermined, 0);
}

TEST(SetupSolver, NoToleranceIsTheWeightedLeastSquaresOfJAlone) {
  const Design d = test::paper_design('C');
  const Parameterisation param(d);
  const LinearModel model = design_model(d, param);
  const WlsSolver base(model.J, model.sigma_um);
  const SetupSolver solver(base, setup_effects(d, model, true));
  EXPECT_FALSE(solver.any());
  const Evaluation ev = evaluate_design(d, 100);
  EXPECT_FALSE(ev.setup_included);
  EXPECT_FALSE(ev.worst_total.has_value());
  EXPECT_NE(ev.setup_note.find("not included"), std::string::npos);
}

TEST(Detection, NoncentralityMatchesTheNormalLimitForOneColumn) {
  // q = 1 and dof -> infinity: F is the square of a normal with mean sqrt(lambda), so
  // power 0.9 at level alpha (two-sided) needs sqrt(lambda) = z(1 - alpha/2) + z(0.9)
  // up to the far tail, P(Z < -z(1 - alpha/2) - sqrt(lambda)), which is below 1e-9 here.
  const boost::math::normal nd;
  for (double alpha : {0.01, 0.05, 0.01 / 30}) {
    const double expected = std::pow(boost::math::quantile(nd, 1 - alpha / 2) + boost::math::quantile(nd, 0.9), 2);
    EXPECT_NEAR(noncentrality_for_power(1, 10000000, alpha, 0.9), expected, 2e-3 * expected) << alpha;
  }
}

TEST(Detection, AnEffectAtItsDetectionLimitIsFoundNineTimesInTen) {
  // Draw readings with a length offset on 2r of exactly its stated detection limit
  // (the paper's C design detects it) and test it as diagnose does: the nested F test
  // of [J] against [J X_e] at level alpha. The rate must be 0.9 within binomial bounds.
  const Design d = test::paper_design('C');
  const DetectionSettings settings{0.01, 3, 0.9};
  const Evaluation ev = evaluate_design(d, 100, {}, settings);
  const SetupEffectCheck* check = nullptr;
  for (const SetupEffectCheck& c : ev.setup_checks) {
    if (c.label == "length_offset[2r]") check = &c;
  }
  ASSERT_NE(check, nullptr);
  ASSERT_TRUE(check->detectable);
  ASSERT_TRUE(check->detection_limit_um.has_value());
  const Parameterisation param(d);
  const LinearModel model = design_model(d, param);
  const int n = static_cast<int>(model.J.rows()), p = static_cast<int>(model.J.cols());
  Eigen::VectorXd x = Eigen::VectorXd::Zero(n);
  const int inst = d.find_installation("2r");
  for (int i = 0; i < n; ++i) x(i) = model.row_installation[i] == inst ? 1.0 : 0.0;
  Eigen::MatrixXd Jx(n, p + 1);
  Jx << model.J, x;
  const WlsSolver s0(model.J, model.sigma_um), s1(Jx, model.sigma_um);
  const int dof1 = n - s1.a_priori().rank;
  boost::math::fisher_f fdist(1, dof1);
  const double f_crit = boost::math::quantile(boost::math::complement(fdist, 0.01 / 3));
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-1.25, 1.25);  // the declared instrument
  const int trials = 2000;
  int found = 0;
  for (int t = 0; t < trials; ++t) {
    Eigen::VectorXd y = *check->detection_limit_um * x;
    for (int i = 0; i < n; ++i) y(i) += u(rng);
    const double c0 = s0.solve(y).chi2, c1 = s1.solve(y).chi2;
    found += ((c0 - c1) / (c1 / dof1)) > f_crit;
  }
  EXPECT_TRUE(test::within_binomial(found, trials, 0.9, 3.5)) << found << " of " << trials;
}

}  // namespace
}  // namespace dbbkit
