// Set-up errors as nuisance effects with a prior (setup.hpp), checked against
// forms that do not share its algebra: generalised least squares with the full
// covariance V = Sigma + X P X', the factorised augmented problem, the normal
// approximation of the noncentral F, and data from the exact two-ball geometry.

#include "dbbkit/setup.hpp"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <Eigen/QR>
#include <Eigen/SVD>
#include <boost/math/distributions/fisher_f.hpp>
#include <boost/math/distributions/non_central_f.hpp>
#include <boost/math/distributions/normal.hpp>
#include <random>

#include "../src/setup_solver.hpp"
#include "../src/tolerances.hpp"
#include "../src/wls_solver.hpp"
#include "dbbkit/diagnose.hpp"
#include "dbbkit/identify.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/diagnose_text.hpp"
#include "dbbkit/io/result_io.hpp"
#include "dbbkit/observability.hpp"
#include "dbbkit/residual_checks.hpp"
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
  for (const SetupEffect& e : effects) q += static_cast<int>(e.J_reading_effect.cols());
  Eigen::MatrixXd X(n, q);
  int j = 0;
  for (const SetupEffect& e : effects) {
    X.middleCols(j, e.J_reading_effect.cols()) = e.J_reading_effect;
    j += static_cast<int>(e.J_reading_effect.cols());
  }
  return X;
}

Eigen::VectorXd prior_variances(const std::vector<SetupEffect>& effects) {
  std::vector<double> v;
  for (const SetupEffect& e : effects) {
    for (int c = 0; c < e.J_reading_effect.cols(); ++c) v.push_back(e.std_um * e.std_um);
  }
  return Eigen::Map<Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size()));
}

// A design's model with its declared set-up effects and both solvers.
struct Fixture {
  explicit Fixture(const Design& design)
      : d(design),
        param(d),
        model(design_model(d, param)),
        base(model.J, model.sigma_um),
        effects(setup_effects(d, model, true)),
        solver(base, effects) {}
  Design d;
  Parameterisation param;
  LinearModel model;
  WlsSolver base;
  std::vector<SetupEffect> effects;
  SetupSolver solver;
};

TEST(SetupSolver, AgreesWithGeneralisedLeastSquaresOnTheFullCovariance) {
  // Full rank (the paper's C design, 7 readings per angle): theta_hat, the total
  // covariance and its noise and set-up parts against the textbook GLS with V explicit.
  Design design = with_setup(test::paper_design('C'), 10, 5);
  design.installations[5].setup_std.centring_um = 8;  // a per-installation override
  const Fixture f(design);
  const LinearModel& model = f.model;
  const SetupSolver& solver = f.solver;
  const std::vector<SetupEffect>& effects = f.effects;
  ASSERT_EQ(f.base.a_priori().status, EstimateStatus::kFullRank);
  const int n = static_cast<int>(model.J.rows());
  const Eigen::MatrixXd X = stacked(effects, n);
  const Eigen::VectorXd P = prior_variances(effects);
  EXPECT_EQ(solver.n_columns(), X.cols());
  EXPECT_EQ((P.array() == 64.0).count(),
            2);  // cx, cy of the override (radial and tangential: no cz)
  EXPECT_EQ((P.array() == 25.0).count(),
            2 * 5 + 1);  // the other five radial/tangential; the axial 1a sees only cz

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
    EXPECT_NEAR(solver.a_priori().evaluate(c).std, std::sqrt(C(j, j)),
                1e-9 + 1e-7 * std::sqrt(C(j, j)))
        << j;
  }
  // The set-up part is not negligible here: the check means something.
  EXPECT_GT(setup.diagonal().maxCoeff(), 0.1 * noise.diagonal().maxCoeff());
  // Response to an arbitrary reading pattern.
  const Eigen::MatrixXd Y = Eigen::MatrixXd::Random(n, 3);
  EXPECT_TRUE(test::near(solver.gain_times(Y), G * Y, 1e-9, 1e-7));
  // Functions of theta (every third unknown, and a sum of two): the map formed and applied.
  std::vector<Eigen::Triplet<double>> rows;
  int m = 0;
  for (int j = 0; j < M.rows(); j += 3) rows.emplace_back(m++, j, 1.0);
  rows.emplace_back(m, 0, 1.0), rows.emplace_back(m++, 7, -2.0);
  FunctionRows Cf(m, M.rows());
  Cf.setFromTriplets(rows.begin(), rows.end());
  const Eigen::MatrixXd CG = Eigen::MatrixXd(Cf) * G;
  EXPECT_TRUE(test::near(solver.left_gain(Cf), CG, 1e-9, 1e-7));
  EXPECT_TRUE(
      test::near(solver.left_gain_times(Cf, solver.left_gain_setup(Cf), Y), CG * Y, 1e-9, 1e-7));
  // Posterior covariance of beta: (X' (Sigma^-1 - Sigma^-1 J (J'Sigma^-1 J)^-1 J' Sigma^-1) X +
  // P^-1)^-1.
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
  const Fixture f(with_setup(test::paper_design('B'), 20, 6));
  const Parameterisation& param = f.param;
  const LinearModel& model = f.model;
  const WlsSolver& base = f.base;
  const SetupSolver& solver = f.solver;
  const std::vector<SetupEffect>& effects = f.effects;
  ASSERT_EQ(base.a_priori().status, EstimateStatus::kRankDeficient);
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
  EXPECT_NE(io::evaluation_setup_note(ev).find("not included"), std::string::npos);
}

TEST(Detection, NoncentralityMatchesTheNormalLimitForOneColumn) {
  // q = 1 and dof -> infinity: F is the square of a normal with mean sqrt(lambda), so
  // power 0.9 at level alpha (two-sided) needs sqrt(lambda) = z(1 - alpha/2) + z(0.9)
  // up to the far tail, P(Z < -z(1 - alpha/2) - sqrt(lambda)), which is below 1e-9 here.
  const boost::math::normal nd;
  for (double alpha : {0.01, 0.05, 0.01 / 30}) {
    const double expected =
        std::pow(boost::math::quantile(nd, 1 - alpha / 2) + boost::math::quantile(nd, 0.9), 2);
    EXPECT_NEAR(noncentrality_for_power(1, 10000000, alpha, 0.9), expected, 2e-3 * expected)
        << alpha;
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
  Jx << test::dense(model.J), x;
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

namespace dbbkit {
namespace {

Design optimised_c() {
  return io::read_design_file(test::source_path("designs/c-turntable-kit-optimized.json"));
}

// Errors of a few um and urad at every angle (first order: far below where the
// second-order terms matter), from the exact two-ball geometry.
Truth exact_truth_with_errors(const Design& d) {
  Truth t;
  t.model = {ErrorModel::Kind::kPerAngle, 0};
  for (double a : d.angles_deg) {
    Vector6d e;
    const double r = a * M_PI / 180;
    e << 3 * std::cos(r), -2 * std::sin(r), 1.5, 8 * std::sin(2 * r), -5 + 6 * std::cos(r), 4;
    test::add_truth_value(t, d.axis, a, e);
  }
  t.exact = true;
  t.bar_mm = 150;
  return t;
}

TEST(SetupDetection, AFiveMicrometreCentringOnAnyInstallationOfTheSetupKitDesignIsFound) {
  // The design of the kit with set-up tolerances and require_setup_detection (12
  // installations at 10 deg): evaluate states every declared length offset and centring
  // detected at its declared size (the limit of each <= 10 um and 5 um). Then, not from the
  // model under test: the exact two-ball readings of a 5 um centring on the installation
  // with the largest limit, in its least favourable direction, plus axis errors and the
  // declared instrument, tested as diagnose's first step tests it (nested F test of [J]
  // against [J X_e], level 0.01 over the candidates it tests). It must be found in at least
  // 9 data sets of 10 (binomial bounds); at the limit itself, in 9 of 10.
  const Design d =
      io::read_design_file(test::source_path("designs/c-turntable-kit-setup-optimized.json"));
  ASSERT_EQ(d.setup_std.centring_um, 5);
  ASSERT_EQ(d.setup_std.length_offset_um, 10);
  const DetectionSettings settings =
      diagnose_detection_settings(effect_detectability(d, nominal_readings(d)));
  const Evaluation ev = evaluate_design(d, 100, {}, settings);
  const SetupEffectCheck* worst = nullptr;
  for (const SetupEffectCheck& c : ev.setup_checks) {
    ASSERT_TRUE(c.detection_limit_um) << c.label;
    EXPECT_LE(*c.detection_limit_um, c.declared_std_um) << c.label;
    if (c.kind == EffectKind::kCentring &&
        (!worst || *c.detection_limit_um > *worst->detection_limit_um))
      worst = &c;
  }
  ASSERT_NE(worst, nullptr);

  Truth t = exact_truth_with_errors(d);
  const std::vector<Reading> first = simulate(d, t, 1);
  const Parameterisation param(d);
  const LinearModel model = build_linear_model(d, param, first);
  const EffectBlock block = effect_block(d, first, {EffectKind::kCentring, worst->installation});
  const int q = static_cast<int>(block.J_reading_effect.cols());
  ASSERT_EQ(q, 2) << "a radial or tangential reading sees the centring in the plane of the table";
  const WlsSolver s0(model.J, model.sigma_um);
  Eigen::MatrixXd Jx(model.J.rows(), model.J.cols() + q);
  Jx << test::dense(model.J), block.J_reading_effect;
  const WlsSolver s1(Jx, model.sigma_um);
  // The least favourable direction: the right singular vector of the smallest singular value.
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(unexplained(s0, block.J_reading_effect),
                                              Eigen::ComputeThinV);
  const Eigen::VectorXd v = svd.matrixV().col(q - 1);
  const int dof1 = static_cast<int>(model.J.rows()) - s1.a_priori().rank;
  const double f_crit = boost::math::quantile(
      boost::math::complement(boost::math::fisher_f(q, dof1), settings.level / settings.n_tests));
  const int trials = 400;
  for (const double size : {*worst->detection_limit_um, 5.0}) {
    SetupError centring;
    for (int k = 0; k < q; ++k) {
      centring.centring_um(block.parameters[k] == "cx"   ? 0
                           : block.parameters[k] == "cy" ? 1
                                                         : 2) = size * v(k);
    }
    t.setup_given = {{d.installations[worst->installation].id, centring}};
    int found = 0;
    for (int k = 0; k < trials; ++k) {
      const std::vector<Reading> readings = simulate(d, t, 100 + k);
      const LinearModel m = build_linear_model(d, param, readings);
      const double c0 = s0.solve(m.y_um).chi2, c1 = s1.solve(m.y_um).chi2;
      found += ((c0 - c1) / q) / (c1 / dof1) > f_crit;
    }
    std::printf(
        "%s (detection limit %.3f um): a centring of %.3f um in its least favourable direction "
        "found in %d "
        "of %d data sets (exact two-ball readings)\n",
        worst->label.c_str(), *worst->detection_limit_um, size, found, trials);
    if (size == 5.0) {
      EXPECT_GE(found, 0.9 * trials - 3 * std::sqrt(0.9 * 0.1 * trials))
          << found << " of " << trials;
    } else {
      EXPECT_TRUE(test::within_binomial(found, trials, 0.9, 3.5)) << found << " of " << trials;
    }
  }
}

TEST(SetupCase, CentringOnAnUndetectableInstallationIsNamedByDiagnoseAndCoveredByTheTotal) {
  // The case of a new user: an optimised design, a centring of (6, -3) um on its 3r,
  // well within any real set-up. The readings fit (3r's centring is confounded with
  // the errors), so the residual cannot tell; diagnose must still name the effect and
  // the error it biases, and with a declared tolerance the total uncertainty must cover
  // the error's shift.
  const Design d = optimised_c();
  Truth t = exact_truth_with_errors(d);
  SetupError centring;
  centring.centring_um = {6, -3, 0};
  t.setup_given = {{"3r", centring}};
  const std::vector<Reading> readings = simulate(d, t, 21);

  const DiagnoseResult diag = diagnose(d, readings);
  const SetupRisk* risk = nullptr;
  for (const SetupRisk& r : diag.setup_risks) {
    if (r.label == "centring[3r]") risk = &r;
  }
  const std::string verdict = io::diagnose_verdict(d, readings, diag);
  ASSERT_NE(risk, nullptr) << verdict;
  EXPECT_EQ(risk->error, 4) << "ey";  // the error it moves most relative to its uncertainty
  EXPECT_FALSE(risk->exceeds);        // nothing declared: no claim at a declared size
  EXPECT_NE(verdict.find("cannot be detected"), std::string::npos) << verdict;
  EXPECT_NE(verdict.find("assume a perfect set-up"), std::string::npos) << verdict;

  // The shift of ey at the angle named, noise-only and with the declared tolerance.
  const Parameterisation param(d);
  const int st = param.station_of(risk->angle_deg);
  const double truth_ey = truth_errors(t, d.axis, risk->angle_deg)(4);
  const IdentifyResult noise_only = identify(d, readings);
  const Determined& e0 = noise_only.errors[st].errors[4];
  const double shift = e0.value - truth_ey;
  // 6.7 um of centring times its bias per um: the shift the risk predicts (first order, noise
  // aside).
  EXPECT_NEAR(std::abs(shift), risk->bias_per_um * centring.centring_um.norm(),
              3 * e0.std + 0.1 * std::abs(shift));
  EXPECT_GT(std::abs(shift), 3 * e0.std) << "the noise-only uncertainty does not cover it";

  Design declared = d;
  declared.setup_std.centring_um = 5;
  declared.setup_std.length_offset_um = 10;
  const IdentifyResult total = identify(declared, readings);
  const Determined& e1 = total.errors[st].errors[4];
  EXPECT_LT(std::abs(e1.value - truth_ey), 2 * e1.std)
      << e1.value << " +- " << e1.std << " vs " << truth_ey;
  // diagnose carries the declared tolerance as identify does: no longer a risk, its corrected
  // error covers the truth with the same uncertainty, and the centring is a declared set-up
  // effect carried in the uncertainty (the readings cannot tell it), not a finding.
  const DiagnoseResult diag_declared = diagnose(declared, readings);
  for (const SetupRisk& r : diag_declared.setup_risks) EXPECT_NE(r.label, "centring[3r]");
  const Determined& e2 = diag_declared.errors_after[st].errors[4];
  EXPECT_LT(std::abs(e2.value - truth_ey), 2 * e2.std)
      << e2.value << " +- " << e2.std << " vs " << truth_ey;
  if (diag_declared.added.empty()) {
    EXPECT_NEAR(e2.value, e1.value, 1e-9 + 1e-9 * std::abs(e1.value));
    EXPECT_NEAR(e2.std, e1.std, 1e-6 * e1.std);
  }
  bool carried = false;
  for (const CandidateStatus& c : diag_declared.candidates) {
    if (c.label == "centring[3r]")
      carried = c.state == CandidateState::kSetUp && c.reason == CandidateReason::kSetUpCarried;
  }
  EXPECT_TRUE(carried) << io::diagnose_verdict(declared, readings, diag_declared);
}

}  // namespace
}  // namespace dbbkit

namespace dbbkit {
namespace {

TEST(SetupCoverage, TotalIntervalsCoverWhereNoiseOnlyIntervalsDoNot) {
  // 500 data sets on the optimised C design from the exact two-ball geometry, each with
  // set-up errors drawn from the declared tolerances (length offset 10 um, centring
  // 5 um per component) and the instrument's rectangular noise. For every determined
  // error at every angle: does the stated 95 % interval (value +- U) hold the truth?
  // Asserted on the error most exposed to the set-up (largest set-up part against its
  // noise part) within binomial bounds, and pooled over every error; the noise-only
  // intervals of the same data (no tolerance declared) must under-cover.
  const Design plain = optimised_c();
  Design declared = plain;
  declared.setup_std.length_offset_um = 10;
  declared.setup_std.centring_um = 5;
  Truth t = exact_truth_with_errors(plain);
  t.setup_draw.length_offset_um = 10;
  t.setup_draw.centring_um = 5;

  const Evaluation ev = evaluate_design(declared, 100);
  ASSERT_TRUE(ev.setup_included);
  int exposed_station = -1, exposed_error = -1;
  double ratio = 0;
  for (std::size_t s = 0; s < ev.errors.size(); ++s) {
    for (int k = 0; k < 6; ++k) {
      const double r = ev.setup_errors[s].errors[k].std / ev.errors[s].errors[k].std;
      if (r > ratio) ratio = r, exposed_station = static_cast<int>(s), exposed_error = k;
    }
  }
  ASSERT_GT(ratio, 3) << "the study needs an error the set-up dominates";

  const int datasets = 500;
  int total_in = 0, noise_in = 0;
  long pooled_total_in = 0, pooled = 0;
  const Parameterisation param(plain);
  for (int ds = 0; ds < datasets; ++ds) {
    const std::vector<Reading> readings = simulate(plain, t, 1000 + ds);
    const IdentifyResult with = identify(declared, readings);
    const IdentifyResult without = identify(plain, readings);
    for (const ValueBudget& v : with.budget.values) {
      const double truth = truth_errors(t, plain.axis, v.angle_deg)(v.error);
      const bool in = std::abs(v.value - truth) <= v.U;
      pooled_total_in += in;
      ++pooled;
      if (v.station == exposed_station && v.error == exposed_error) total_in += in;
    }
    for (const ValueBudget& v : without.budget.values) {
      if (v.station != exposed_station || v.error != exposed_error) continue;
      const double truth = truth_errors(t, plain.axis, v.angle_deg)(v.error);
      noise_in += std::abs(v.value - truth) <= v.U;
    }
  }
  const double band = 3 * std::sqrt(0.95 * 0.05 / datasets);
  EXPECT_TRUE(test::within_binomial(total_in, datasets, 0.95, 3)) << total_in << " of " << datasets;
  EXPECT_LT(noise_in, (0.95 - band) * datasets) << noise_in << " of " << datasets;
  // Pooled over every error: correlated within a data set, so a wider band (0.93 .. 0.97).
  const double pooled_rate = static_cast<double>(pooled_total_in) / pooled;
  EXPECT_NEAR(pooled_rate, 0.95, 0.02) << pooled_total_in << " of " << pooled;
  std::printf(
      "coverage of the 95 %% intervals of %s at station %d over %d data sets: total %d, noise-only "
      "%d; "
      "pooled total %.4f\n",
      kErrorNames[exposed_error], exposed_station, datasets, total_in, noise_in, pooled_rate);
}

}  // namespace
}  // namespace dbbkit

namespace dbbkit {
namespace {

TEST(SetupFormat, ToleranceDefaultAndOverridesSurviveTheDesignFile) {
  Design d = test::paper_design('C');
  d.setup_std.length_offset_um = 10;
  d.setup_std.centring_um = 5;
  d.setup_std.L_mm = 0.1;
  d.installations[5].setup_std.centring_um = 8;
  d.installations[1].setup_std.H_mm = 0.5;
  const Design back = io::design_from_json(io::design_to_json(d), "round trip");
  for (int i = 0; i < static_cast<int>(d.installations.size()); ++i) {
    const SetupUncertainty a = d.setup_of(i), b = back.setup_of(i);
    EXPECT_EQ(a.length_offset_um, b.length_offset_um) << i;
    EXPECT_EQ(a.centring_um, b.centring_um) << i;
    EXPECT_EQ(a.L_mm, b.L_mm) << i;
    EXPECT_EQ(a.H_mm, b.H_mm) << i;
  }
  EXPECT_EQ(back.setup_of(5).centring_um, 8);
  EXPECT_EQ(back.setup_of(4).centring_um, 5);
  EXPECT_TRUE(back.setup_nuisance_declared());
  // The short form of the ball placement alone is still read, and declares no nuisance effect.
  const Design legacy = io::design_from_json(
      nlohmann::json::parse(
          R"({"format": "dbbkit.design/1", "axis": "C", "angles_deg": [0, 90, 180, 270],
        "setup_std_mm": {"L": 0.2}, "installations": [{"id": "r", "ball_mm": {"L": 100, "H": 50}, "direction": "radial"}]})"),
      "legacy");
  EXPECT_EQ(legacy.setup_of(0).L_mm, 0.2);
  EXPECT_FALSE(legacy.setup_nuisance_declared());
}

}  // namespace
}  // namespace dbbkit

namespace dbbkit {
namespace {

TEST(SetupSearch, TheSearchCriterionEqualsEvaluatesWorstTotal) {
  // optimize's worst_total_std_um (design_worst_total) is evaluate's worst_total, and
  // without declared tolerances it is the noise-only worst case.
  const Design d =
      io::read_design_file(test::source_path("designs/c-turntable-kit-optimized-with-setup.json"));
  const Evaluation ev = evaluate_design(d, 100);
  const TotalWorstCase t = design_worst_total(d, 100);
  ASSERT_TRUE(ev.worst_total && ev.worst_total->worst_std_um && t.total.worst_std_um);
  // The search's figure comes from the per-angle path (fast_worst_total), evaluate's from the
  // stacked model: equal up to rounding.
  EXPECT_NEAR(*t.total.worst_std_um, *ev.worst_total->worst_std_um, 1e-9 * *t.total.worst_std_um);
  EXPECT_NEAR(*t.noise->worst_std_um, *ev.worst.worst_std_um, 1e-9 * *t.total.worst_std_um);
  EXPECT_GT(*t.total.worst_std_um, 10 * *t.noise->worst_std_um);
  Design plain = d;
  plain.setup_std = {};
  const TotalWorstCase p = design_worst_total(plain, 100);
  EXPECT_DOUBLE_EQ(*p.total.worst_std_um, *p.noise->worst_std_um);
  EXPECT_NEAR(*p.noise->worst_std_um, *design_worst_case(plain, 100).worst_std_um, 1e-12);
}

}  // namespace
}  // namespace dbbkit

namespace dbbkit {
namespace {

// left_gain: C theta_hat = left_gain(C) y for any readings y (the estimate the set-up solver
// returns), and left_gain_l1 the 1-norms of its rows without forming it; with and without
// declared tolerances, on a per-angle and a Fourier design.
TEST(LeftGain, IsTheEstimatesResponseAndItsRowNormsAreFormedWithoutIt) {
  Design fourier = test::paper_design('C');
  fourier.errors = {ErrorModel::Kind::kFourier, 3};
  // The set-up kit's design detects its set-up effects (the paper's designs do not: there the
  // correction is zero to rounding).
  Design kit_design =
      io::read_design_file(test::source_path("designs/c-turntable-kit-setup-optimized.json"));
  kit_design.setup_std = {};
  for (Installation& in : kit_design.installations) in.setup_std = {};
  for (const Design& base :
       {test::paper_design('C'), fourier, test::paper_design('B'), kit_design}) {
    for (const bool tolerances : {false, true}) {
      const Design d = tolerances ? with_setup(base, 10, 5) : base;
      const Parameterisation param(d);
      const LinearModel model = build_linear_model(d, param, nominal_readings(d));
      const WlsSolver solver(model.J, model.sigma_um);
      const SetupSolver setup(solver, setup_effects(d, model, true));
      ASSERT_EQ(setup.any(), tolerances);
      Eigen::MatrixXd C(6 * param.n_stations(), param.n_parameters());
      for (int s = 0; s < param.n_stations(); ++s) C.middleRows(6 * s, 6) = param.error_map(s);
      const Eigen::MatrixXd A = setup.left_gain(FunctionRows(C.sparseView()));
      std::mt19937 rng(4);
      std::normal_distribution<double> z(0.0, 3.0);
      Eigen::VectorXd y(model.J.rows());
      for (Eigen::Index i = 0; i < y.size(); ++i) y(i) = z(rng);
      const Eigen::VectorXd response = C * setup.solve(y).theta;
      EXPECT_TRUE(test::near(A * y, response, 1e-9 * response.cwiseAbs().maxCoeff())) << tolerances;
      // The same map as the gain without the set-up and its correction of rank q,
      // C G0 - L N (setup_noise_map), also where J loses rank (B: rank 5 per station).
      const FunctionRows Cs(C.sparseView());
      const Eigen::MatrixXd A0 = Eigen::MatrixXd(solver.J_theta_reading().left(Cs));
      const Eigen::MatrixXd low_rank = setup.left_gain_setup(Cs) * setup.setup_noise_map();
      EXPECT_TRUE(test::near(A0 - low_rank, A, 1e-10 * A.cwiseAbs().maxCoeff())) << tolerances;
      if (tolerances && &base == &kit_design)
        EXPECT_GT(low_rank.cwiseAbs().maxCoeff(), 1e-2 * A.cwiseAbs().maxCoeff());
      const Eigen::VectorXd l1 = setup.left_gain_l1(FunctionRows(C.sparseView()));
      const Eigen::VectorXd expected = A.rowwise().lpNorm<1>();
      EXPECT_TRUE(test::near(l1, expected, 1e-12 * expected.maxCoeff(), 1e-10)) << tolerances;
    }
  }
}

// The noncentrality for a power is the root of power(lambda) = target to a relative width of
// 1e-9, on its upper side: checked against Boost's noncentral F in its default (long double)
// precision, independently of the double-precision evaluation and the root finder used.
TEST(Noncentrality, ReachesThePowerWithinTheRootsWidth) {
  namespace bm = boost::math;
  for (int q : {1, 2, 3, 6}) {
    for (int dof : {3, 30, 500}) {
      for (double power : {0.5, 0.9, 0.99}) {
        for (double alpha :
             {0.05 / 14, 0.01 / 30}) {  // the roots are kept per (q, dof, alpha, power)
          const double lambda = noncentrality_for_power(q, dof, alpha, power);
          EXPECT_EQ(noncentrality_for_power(q, dof, alpha, power), lambda);  // asked again
          const double f_crit = bm::quantile(bm::complement(bm::fisher_f(q, dof), alpha));
          auto power_at = [&](double l) {
            return bm::cdf(bm::complement(bm::non_central_f(q, dof, l), f_crit));
          };
          EXPECT_GE(power_at(lambda), power - 1e-12) << q << " " << dof << " " << power;
          EXPECT_LE(power_at(lambda * (1 - 2e-9)), power + 1e-12)
              << q << " " << dof << " " << power;
        }
      }
    }
  }
}

}  // namespace
}  // namespace dbbkit

namespace dbbkit {
namespace {

// A symmetric design has exact ties between stations that rounding breaks one way or the
// other. Each set-up check names its largest bias at the first (station, error) within the
// tie tolerance of the largest: recomputed here from the SVD's gain (not the normal
// equations evaluate takes), every (station, error) scanned in order.
TEST(SetupChecks, TheLargestBiasIsNamedAtTheFirstOfItsTies) {
  const Design d = test::paper_design('C');
  const Evaluation ev = evaluate_design(d, 100.0);
  const Parameterisation param(d);
  const LinearModel model = design_model(d, param);
  EstimateOptions svd_only;
  svd_only.normal_equations_tolerance = 0;
  const WlsSolver svd(model.J, model.sigma_um, svd_only);
  const std::vector<SetupEffect> effects = setup_effects(d, model, false);
  ASSERT_EQ(effects.size(), ev.setup_checks.size());
  int with_ties = 0;
  for (std::size_t e = 0; e < effects.size(); ++e) {
    const SetupEffectCheck& ch = ev.setup_checks[e];
    SCOPED_TRACE(ch.label);
    const Eigen::MatrixXd GX = svd.J_theta_reading() * effects[e].J_reading_effect;
    struct Bias {
      double angle_deg, b_um;
      int error;
    };
    std::vector<Bias> all;
    double largest = 0;
    for (int s = 0; s < param.n_stations(); ++s) {
      const Eigen::MatrixXd C = test::dense(error_functions(param, s, svd.a_priori().n_unknowns));
      for (int k = 0; k < 6; ++k) {
        if (!svd.a_priori().determined(Eigen::SparseVector<double>(C.col(k).sparseView())))
          continue;
        const double b = (C.col(k).transpose() * GX).norm();
        all.push_back({param.station_angle_deg(s), k >= 3 ? 0.1 * b : b, k});
        largest = std::max(largest, all.back().b_um);
      }
    }
    ASSERT_GT(largest, 0);
    ASSERT_TRUE(ch.bias_um_per_um);
    EXPECT_NEAR(*ch.bias_um_per_um, largest, 1e-9 * largest);
    // The ties: within 1e-6 of the largest, and none between 1e-9 and 1e-6 (so that the
    // two paths' rounding cannot make a tie of one and not of the other).
    const Bias* first = nullptr;
    int ties = 0;
    for (const Bias& x : all) {
      const double gap = (largest - x.b_um) / largest;
      EXPECT_FALSE(gap > 1e-9 && gap <= 1e-6) << x.angle_deg << " " << x.error;
      if (gap <= 1e-6) {
        ++ties;
        if (!first) first = &x;
      }
    }
    ASSERT_NE(first, nullptr);
    with_ties += ties > 1;
    EXPECT_EQ(ch.bias_angle_deg, first->angle_deg);
    EXPECT_EQ(ch.bias_error, first->error);
  }
  EXPECT_GT(with_ties, 0);  // the rule is exercised: some effect's largest bias is a tie
}

}  // namespace
}  // namespace dbbkit

namespace dbbkit {
namespace {

// The place of the largest: the first value offered is taken; a later one only when it exceeds
// the value at the place by more than tol::kTieRelative; NaN never. Every value offered is at
// most (1 + kTieRelative) times the value at the place (random sequences with near-ties).
TEST(Ties, PlaceOfLargestKeepsTheFirstOfTies) {
  PlaceOfLargest p;
  EXPECT_FALSE(p.offer(std::nan("")));
  EXPECT_TRUE(p.offer(0.0));
  EXPECT_TRUE(p.offer(1.0));
  EXPECT_FALSE(p.offer(1.0));
  EXPECT_FALSE(p.offer(1.0 + 1e-12));
  EXPECT_FALSE(p.offer(0.5));
  EXPECT_FALSE(p.offer(std::nan("")));
  EXPECT_TRUE(p.offer(1.0 + 1e-6));
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(0, 1);
  for (int trial = 0; trial < 200; ++trial) {
    PlaceOfLargest q;
    double at = -1, largest = -1;
    int place = -1;
    for (int i = 0; i < 50; ++i) {
      // values clustered near 1 at steps around the tolerance
      const double v = 1.0 + std::floor(u(rng) * 8) * 0.4 * tol::kTieRelative;
      largest = std::max(largest, v);
      if (q.offer(v)) at = v, place = i;
    }
    EXPECT_GE(place, 0);
    EXPECT_LE(largest, at * (1.0 + tol::kTieRelative));
  }
}

// Significance: the smaller p; p within kSignificanceTie (or both zero) is a tie, decided by
// F only where F differs by more than the tie; otherwise neither is more significant.
TEST(Ties, MoreSignificantIsAStrictOrderWithTies) {
  EXPECT_TRUE(more_significant(0.01, 1.0, 0.02, 9.0));
  EXPECT_FALSE(more_significant(0.02, 9.0, 0.01, 1.0));
  EXPECT_FALSE(more_significant(0.01 * (1 + 1e-12), 8.548, 0.01, 8.548));
  EXPECT_FALSE(more_significant(0.01, 8.548, 0.01 * (1 + 1e-12), 8.548 * (1 + 1e-12)));
  EXPECT_TRUE(more_significant(0.0, 300.0, 0.0, 200.0));  // both below the smallest double
  EXPECT_FALSE(more_significant(0.0, 200.0, 0.0, 300.0));
  EXPECT_FALSE(more_significant(std::nan(""), 1.0, 0.5, 1.0));
  EXPECT_FALSE(more_significant(0.5, 1.0, std::nan(""), 1.0));
  for (const double p : {0.3, 1e-5, 1e-200}) {
    EXPECT_FALSE(more_significant(p, 2.0, p, 2.0));  // irreflexive
    EXPECT_TRUE(more_significant(p * 0.99, 2.0, p, 2.0));
  }
}

}  // namespace
}  // namespace dbbkit
