#include "dbbkit/estimate.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <random>

#include "../src/block_form.hpp"
#include "../src/series_l1.hpp"
#include "../src/simd.hpp"
#include "../src/spd_inverse.hpp"
#include "../src/wls_solver.hpp"
#include "dbbkit/linear_model.hpp"
#include "dbbkit/measurement.hpp"
#include "dbbkit/parameterisation.hpp"
#include "test_util.hpp"

namespace dbbkit {
namespace {

LinearModel model_of(const Eigen::MatrixXd& J, const Eigen::VectorXd& y,
                     const Eigen::VectorXd& sigma) {
  LinearModel m;
  m.J = J.sparseView();
  m.y_um = y;
  m.sigma_um = sigma;
  return m;
}

// Full rank: the SVD route gives the textbook normal-equation results.
TEST(Estimate, FullRankMatchesNormalEquations) {
  std::mt19937_64 rng(3);
  std::normal_distribution<double> n01;
  Eigen::MatrixXd J(12, 4);
  for (int i = 0; i < J.size(); ++i) J.data()[i] = n01(rng);
  J.col(2) *= 1e-3;  // badly scaled column: equilibration must not change the answer
  Eigen::VectorXd y(12), sigma(12);
  for (int i = 0; i < 12; ++i) y(i) = n01(rng), sigma(i) = 0.5 + 0.1 * i;
  const Estimate est = estimate_wls(model_of(J, y, sigma));
  ASSERT_EQ(est.status, EstimateStatus::kFullRank);
  EXPECT_EQ(est.rank, 4);
  EXPECT_EQ(est.dof, 8);
  const Eigen::MatrixXd W = sigma.cwiseAbs2().cwiseInverse().asDiagonal();
  const Eigen::MatrixXd M = J.transpose() * W * J;
  const Eigen::MatrixXd cov = M.inverse();
  const Eigen::VectorXd theta = cov * J.transpose() * W * y;
  EXPECT_TRUE(test::near(est.theta, theta, 1e-10, 1e-9));
  EXPECT_TRUE(test::near(est.covariance, cov, 1e-10, 1e-9));
  const Eigen::VectorXd r = y - J * theta;
  EXPECT_NEAR(est.chi2, r.transpose() * W * r, 1e-10);
  EXPECT_NEAR(est.rms_um, std::sqrt(r.squaredNorm() / 12), 1e-12);
  const Determined d = est.evaluate(Eigen::Vector4d(1, 0, 2, 0));
  ASSERT_TRUE(d.determined);
  EXPECT_NEAR(d.std, std::sqrt(cov(0, 0) + 4 * cov(2, 2) + 4 * cov(0, 2)), 1e-10);
}

// chi2 with 2 degrees of freedom: P(chi2 >= x) = exp(-x/2) exactly.
TEST(Estimate, PValueOfTwoDegreesOfFreedom) {
  const Eigen::MatrixXd J = Eigen::MatrixXd::Ones(3, 1);
  const Eigen::VectorXd y = Eigen::Vector3d(0, 1, 2), sigma = Eigen::Vector3d::Ones();
  const Estimate est = estimate_wls(model_of(J, y, sigma));
  EXPECT_NEAR(est.theta(0), 1.0, 1e-14);
  EXPECT_NEAR(est.chi2, 2.0, 1e-12);
  ASSERT_TRUE(est.p_value.has_value());
  EXPECT_NEAR(*est.p_value, std::exp(-1.0), 1e-12);
}

TEST(Estimate, NoRedundancyHasNoPValue) {
  const Estimate est = estimate_wls(
      model_of(Eigen::MatrixXd::Identity(2, 2), Eigen::Vector2d(1, 2), Eigen::Vector2d(1, 1)));
  EXPECT_EQ(est.dof, 0);
  EXPECT_FALSE(est.p_value.has_value());
}

// Two unknowns that always appear as a sum: each alone is undetermined, the sum is
// determined with the right uncertainty, and the null direction is (1, -1)/sqrt(2).
TEST(Estimate, RankLossIsReportedWithTheMissingCombination) {
  Eigen::MatrixXd J(4, 3);
  J << 1, 1, 0,  //
      1, 1, 1,   //
      2, 2, 0,   //
      0, 0, 1;
  const Eigen::VectorXd y = Eigen::Vector4d(3, 4, 6, 1), sigma = Eigen::Vector4d::Constant(0.5);
  const Estimate est = estimate_wls(model_of(J, y, sigma));
  ASSERT_EQ(est.status, EstimateStatus::kRankDeficient);
  EXPECT_EQ(est.rank, 2);
  EXPECT_FALSE(est.evaluate(Eigen::Vector3d(1, 0, 0)).determined);
  EXPECT_FALSE(est.evaluate(Eigen::Vector3d(0, 1, 0)).determined);
  const Determined sum = est.evaluate(Eigen::Vector3d(1, 1, 0));
  ASSERT_TRUE(sum.determined);
  // Reduced model y = a s + b t with columns (1,1,2,0) and (0,1,0,1).
  Eigen::MatrixXd Jr(4, 2);
  Jr << 1, 0, 1, 1, 2, 0, 0, 1;
  const Eigen::MatrixXd cov = (Jr.transpose() * Jr / 0.25).inverse();
  const Eigen::VectorXd theta = cov * Jr.transpose() * y / 0.25;
  EXPECT_NEAR(sum.value, theta(0), 1e-12);
  EXPECT_NEAR(sum.std, std::sqrt(cov(0, 0)), 1e-12);
  const Eigen::MatrixXd N = est.null_directions();
  ASSERT_EQ(N.cols(), 1);
  EXPECT_TRUE(test::near(N.col(0), Eigen::Vector3d(1, -1, 0) / std::sqrt(2.0), 1e-12));
}

TEST(Estimate, NegligibleColumnIsNotInflatedIntoInformation) {
  // Column 2 is 1e-17 times column 1 (a lever arm times cos(90 deg) in floating point):
  // scaling it to unit norm would make it look like column 1 and hide column 1's value.
  Eigen::MatrixXd J(3, 2);
  J << 1, 1e-17, 2, 2e-17, 1, 1e-17;
  const Estimate est = estimate_wls(model_of(J, Eigen::Vector3d(1, 2, 1), Eigen::Vector3d::Ones()));
  EXPECT_EQ(est.rank, 1);
  EXPECT_TRUE(est.evaluate(Eigen::Vector2d(1, 0)).determined);
  EXPECT_FALSE(est.evaluate(Eigen::Vector2d(0, 1)).determined);
}

// A block-diagonal J (two independent groups of unknowns, an unseen unknown and an
// empty reading) is factorised block by block: the result must be the dense one.
TEST(Estimate, BlockDiagonalEqualsDense) {
  std::mt19937_64 rng(8);
  std::normal_distribution<double> n01;
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(9, 6);
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 2; ++j) J(i, j) = n01(rng);
  }
  for (int i = 4; i < 8; ++i) {
    for (int j = 2; j < 5; ++j) J(i, j) = n01(rng);
  }
  // column 5 is seen by no reading, row 8 sees nothing
  Eigen::VectorXd y(9), sigma(9);
  for (int i = 0; i < 9; ++i) y(i) = n01(rng), sigma(i) = 0.3 + 0.05 * i;
  const Estimate est = estimate_wls(model_of(J, y, sigma));
  EXPECT_EQ(est.rank, 5);
  EXPECT_EQ(est.dof, 4);
  const Eigen::MatrixXd W = sigma.cwiseAbs2().cwiseInverse().asDiagonal();
  const Eigen::MatrixXd Js = J.leftCols(5);
  const Eigen::MatrixXd cov = (Js.transpose() * W * Js).inverse();
  const Eigen::VectorXd theta = cov * Js.transpose() * W * y;
  EXPECT_TRUE(test::near(est.theta.head(5), theta, 1e-10, 1e-9));
  EXPECT_TRUE(test::near(test::dense(est.covariance).topLeftCorner(5, 5), cov, 1e-10, 1e-9));
  EXPECT_FALSE(est.evaluate(Eigen::VectorXd::Unit(6, 5)).determined);
  const Eigen::VectorXd r = y - Js * theta;
  EXPECT_NEAR(est.chi2, r.transpose() * W * r, 1e-10);
  ASSERT_EQ(est.null_directions().cols(), 1);
  EXPECT_TRUE(test::near(est.null_directions().col(0), Eigen::VectorXd::Unit(6, 5), 0.0));
}

// Border columns (EstimateOptions): a block-diagonal model of 120 stations plus three
// columns seen at every station, one of them a combination of the others and the stations'
// columns (a direction through two stations and the border that the data cannot determine). Solved
// bordered and as one whole block, everything the data determine agrees: rank, residual, values and
// uncertainties of determined functions, which functions are determined, leverages, the gain's
// products.
TEST(Estimate, BorderedEqualsTheWholeBlock) {
  std::mt19937_64 rng(21);
  std::normal_distribution<double> n01;
  const int stations = 120, rows = 4, cols = 3, q = 3;
  const int n = stations * rows, p0 = stations * cols, p = p0 + q;
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(n, p);
  for (int s = 0; s < stations; ++s) {
    for (int i = 0; i < rows; ++i) {
      for (int j = 0; j < cols; ++j) J(s * rows + i, s * cols + j) = n01(rng);
    }
  }
  Eigen::VectorXd v =
      Eigen::VectorXd::Zero(p0);  // the undetermined direction: stations 3 and 50 and the border
  for (int j = 0; j < cols; ++j) v(3 * cols + j) = n01(rng), v(50 * cols + j) = n01(rng);
  for (int i = 0; i < n; ++i) J(i, p0) = 1.0, J(i, p0 + 1) = std::sin(0.05 * i) * 30.0;
  J.col(p0 + 2) = J.leftCols(p0) * v + 2.0 * J.col(p0);
  Eigen::VectorXd y(n), sigma(n);
  for (int i = 0; i < n; ++i) y(i) = 3.0 * n01(rng), sigma(i) = 0.5 + 0.01 * (i % 7);

  EstimateOptions whole_o, border_o;
  whole_o.border_min_columns = 0;
  border_o.border_min_columns = 100;
  const WlsSolver whole(test::sparse(J), sigma, whole_o),
      bordered(test::sparse(J), sigma, border_o);
  EXPECT_TRUE(whole.border().empty());
  EXPECT_EQ(bordered.border(), (std::vector<int>{p0, p0 + 1, p0 + 2}));
  EXPECT_EQ(whole.blocks().size(), 1u);
  EXPECT_EQ(bordered.blocks().size(), static_cast<std::size_t>(stations));
  const Estimate a = whole.solve(y), b = bordered.solve(y);
  EXPECT_EQ(a.rank, p - 1);
  EXPECT_EQ(b.rank, a.rank);
  EXPECT_EQ(b.dof, a.dof);
  EXPECT_EQ(b.status, EstimateStatus::kRankDeficient);
  EXPECT_NEAR(b.chi2, a.chi2, 1e-9 * a.chi2);
  EXPECT_TRUE(test::near(b.residual_um, a.residual_um, 1e-9, 1e-9));
  EXPECT_EQ(b.null_directions().cols(), 1);
  EXPECT_FALSE(b.condition_number.has_value());  // not computed for a bordered model

  // Unit functions and random combinations of a station's unknowns with the border's.
  std::vector<Eigen::VectorXd> functions;
  for (int j = 0; j < p; j += 7) functions.push_back(Eigen::VectorXd::Unit(p, j));
  for (int j = p0; j < p; ++j) functions.push_back(Eigen::VectorXd::Unit(p, j));
  for (int k = 0; k < 10; ++k) {
    Eigen::VectorXd c = Eigen::VectorXd::Zero(p);
    const int s = k == 0 ? 3 : k * 11;  // station 3's combinations are undetermined
    for (int j = 0; j < cols; ++j) c(s * cols + j) = n01(rng);
    c(p0 + k % q) = n01(rng);
    functions.push_back(c);
  }
  functions.push_back(J.row(17).transpose());  // a reading's prediction: always determined
  int determined = 0, undetermined = 0;
  for (const Eigen::VectorXd& c : functions) {
    const Determined da = a.evaluate(c), db = b.evaluate(c);
    ASSERT_EQ(db.determined, da.determined) << c.transpose();
    if (!da.determined) {
      ++undetermined;
      continue;
    }
    ++determined;
    EXPECT_NEAR(db.value, da.value, 1e-8 * (1.0 + std::abs(da.value)));
    EXPECT_NEAR(db.std, da.std, 1e-8 * da.std);
  }
  EXPECT_GT(determined, 10);
  EXPECT_GT(undetermined, 3);  // the border's three unknowns and the station combinations with them
  for (int i = 0; i < n; i += 13) EXPECT_NEAR(bordered.leverage(i), whole.leverage(i), 1e-10) << i;
  // J G: the same projector either way (it does not depend on the minimum-norm choice).
  const Eigen::MatrixXd Y = Eigen::MatrixXd::Random(n, 2);
  EXPECT_TRUE(test::near(J * (bordered.J_theta_reading() * Y), J * (whole.J_theta_reading() * Y),
                         1e-9, 1e-9));
}

TEST(Estimate, NoReadingsGivesNoNumbers) {
  const Estimate est =
      estimate_wls(model_of(Eigen::MatrixXd(0, 3), Eigen::VectorXd(0), Eigen::VectorXd(0)));
  EXPECT_EQ(est.status, EstimateStatus::kNoReadings);
  EXPECT_FALSE(est.evaluate(Eigen::Vector3d(1, 0, 0)).determined);
  EXPECT_FALSE(est.p_value.has_value());
}

// The paper's C design with five more installations (twelve), as the series benchmark.
Design twelve_installations(Design d) {
  for (int k = 0; k < 5; ++k) {
    Installation in = d.installations[static_cast<std::size_t>(k) % 7];
    in.id = "x" + std::to_string(k);
    in.L_mm += 30 + 10 * k;
    in.H_mm += 20 * k;
    d.installations.push_back(in);
  }
  return d;
}

// Gain::left_l1 of a series runs its kernels four doubles wide where the processor has AVX
// and two wide otherwise: both give the same bits, and both |C G|_1 of the dense gain. Two
// sets of angles: 91 at 360 i / 91 deg (few reflections to the bit: the angles in order) and
// every 5 deg with 7, 13 and 101 deg added (paired with their reflections, 0, 180 and the
// three added with none: 80 slots, two tiles and a half). Each leaves tails in every loop
// (tiles, chunks of 256, vector lanes). On a processor without AVX both runs take the
// two-wide path.
TEST(Estimate, SeriesL1IsTheSameOnEveryVectorWidth) {
  std::vector<double> uneven, paired;
  for (int i = 0; i < 91; ++i) uneven.push_back(360.0 * i / 91);
  for (int a = 0; a < 360; a += 5) paired.push_back(a);
  for (double a : {7.0, 13.0, 101.0}) paired.push_back(a);
  for (const auto& [angles, pairs] :
       {std::pair<std::vector<double>, bool>{uneven, false}, {paired, true}}) {
    SCOPED_TRACE(angles.size());
    Design d = twelve_installations(test::paper_design('C'));
    d.errors = {ErrorModel::Kind::kFourier, 20};
    d.angles_deg = angles;
    const Parameterisation param(d);
    const LinearModel model = build_linear_model(d, param, nominal_readings(d));
    ASSERT_TRUE(model.series);
    EXPECT_EQ(detail::series_angles_paired(*model.series), pairs);
    const WlsSolver factored(model);
    const WlsSolver::Gain& G = factored.J_theta_reading();
    ASSERT_TRUE(G.series_l1());
    std::vector<Eigen::Triplet<double>> t;
    int row = 0;
    for (int st = 0; st < param.n_stations(); ++st) {
      const Eigen::SparseMatrix<double> E = param.error_functions(st);
      for (int e = 0; e < 6; ++e, ++row) {
        for (Eigen::SparseMatrix<double>::InnerIterator it(E, e); it; ++it)
          t.emplace_back(row, static_cast<int>(it.row()), it.value());
      }
    }
    std::mt19937 rng(11);
    std::normal_distribution<double> z;
    for (int r = 0; r < 7; ++r, ++row) {  // across the errors' coefficients
      for (int j = 0; j < 9; ++j) t.emplace_back(row, (r * 31 + j * 17) % model.J.cols(), z(rng));
    }
    FunctionRows C(row, model.J.cols());
    C.setFromTriplets(t.begin(), t.end());
    ASSERT_EQ(C.rows(), 6 * static_cast<Eigen::Index>(angles.size()) + 7);
    detail::wide_vectors_allowed() = false;
    const Eigen::VectorXd narrow = G.left_l1(C);
    detail::wide_vectors_allowed() = true;
    const Eigen::VectorXd wide = G.left_l1(C);
    for (Eigen::Index v = 0; v < C.rows(); ++v) EXPECT_EQ(narrow(v), wide(v)) << v;
    const Eigen::VectorXd l1 =
        (test::dense(C) * test::dense(G.sparse())).cwiseAbs().rowwise().sum();
    EXPECT_TRUE(test::near(wide, l1, 0.0, 1e-9));
  }
}

// The reflection the pairing rests on: the Fourier basis at a and at 360 - a (and -a) is the
// same with the sines negated, to the bit, at the quadrants' halves too (45 deg and its
// multiples by the harmonics), wherever 360 - a is exact.
TEST(Estimate, FourierBasisIsEvenAndOddToTheBit) {
  const std::vector<int> parity = basis_parity({ErrorModel::Kind::kFourier, 20});
  for (double a : {0.0, 1.0, 9.0, 15.0, 45.0, 90.0, 135.0, 180.0, 33.75, 7.5}) {
    const Eigen::VectorXd f = fourier_basis(20, a), g = fourier_basis(20, 360.0 - a),
                          h = fourier_basis(20, -a);
    for (Eigen::Index j = 0; j < f.size(); ++j) {
      EXPECT_EQ(g(j), parity[static_cast<std::size_t>(j)] * f(j)) << a << " " << j;
      EXPECT_EQ(h(j), parity[static_cast<std::size_t>(j)] * f(j)) << a << " " << j;
    }
  }
}

}  // namespace
}  // namespace dbbkit

namespace dbbkit {
namespace {

// The normal-equations path (a series block of >= 32 columns whose condition bound holds)
// against the SVD of the same block (the path turned off): singular values, covariance,
// gain and the estimate agree; a block past the bound, or rank-deficient, takes the SVD.
TEST(Estimate, NormalEquationsPathAgreesWithTheSvd) {
  std::mt19937 rng(8);
  std::normal_distribution<double> z;
  const int n = 400, p = 40;
  EstimateOptions svd_only;
  svd_only.normal_equations_tolerance = 0;
  for (const double kappa : {10.0, 1e3, 1e6}) {
    // J = Q1 diag(s) Q2' with singular values from 1 down to 1/kappa (before equilibration).
    Eigen::MatrixXd A(n, p), B(p, p);
    for (Eigen::Index i = 0; i < A.size(); ++i) A.data()[i] = z(rng);
    for (Eigen::Index i = 0; i < B.size(); ++i) B.data()[i] = z(rng);
    const Eigen::MatrixXd Q1 =
        Eigen::HouseholderQR<Eigen::MatrixXd>(A).householderQ() * Eigen::MatrixXd::Identity(n, p);
    const Eigen::MatrixXd Q2 = Eigen::HouseholderQR<Eigen::MatrixXd>(B).householderQ();
    Eigen::VectorXd s(p);
    for (int k = 0; k < p; ++k) s(k) = std::pow(kappa, -static_cast<double>(k) / (p - 1));
    const Eigen::MatrixXd J = Q1 * s.asDiagonal() * Q2.transpose();
    Eigen::VectorXd sigma(n), y(n);
    for (int i = 0; i < n; ++i) sigma(i) = 0.5 + 0.01 * (i % 7), y(i) = z(rng);
    const WlsSolver normal(J, sigma), svd(J, sigma, svd_only);
    EXPECT_EQ(svd.a_priori().normal_equation_blocks, 0);
    // kappa^2 n eps <= 1e-6 holds for the equilibrated block up to kappa ~ 2e3
    EXPECT_EQ(normal.a_priori().normal_equation_blocks, kappa < 1e4 ? 1 : 0) << kappa;
    const Estimate a = normal.solve(y), b = svd.solve(y);
    EXPECT_TRUE(test::near(a.singular_values, b.singular_values, 0, 1e-9)) << kappa;
    const double tol = 1e-9 * std::max(1.0, kappa * kappa * 1e-6);  // the bound's own allowance
    EXPECT_TRUE(test::near(a.covariance, b.covariance,
                           tol * test::dense(b.covariance).cwiseAbs().maxCoeff()))
        << kappa;
    EXPECT_TRUE(test::near(normal.J_theta_reading().sparse(), svd.J_theta_reading().sparse(),
                           tol * test::dense(svd.J_theta_reading().sparse()).cwiseAbs().maxCoeff()))
        << kappa;
    EXPECT_TRUE(test::near(a.theta, b.theta, tol * b.theta.cwiseAbs().maxCoeff())) << kappa;
    EXPECT_EQ(a.rank, p);
  }
  // Rank-deficient: two equal columns. The eigenvalue 0 fails the bound; the SVD answers.
  Eigen::MatrixXd J(n, p);
  for (Eigen::Index i = 0; i < J.size(); ++i) J.data()[i] = z(rng);
  J.col(p - 1) = J.col(0);
  const WlsSolver deficient(J, Eigen::VectorXd::Ones(n));
  EXPECT_EQ(deficient.a_priori().normal_equation_blocks, 0);
  EXPECT_EQ(deficient.a_priori().rank, p - 1);
}

// A per-angle model's stations (blocks of six columns) take the normal equations where the
// condition bound holds and the SVD where a station loses rank (the B head's): against the
// SVD of every block, the same rank, null space, singular values, covariance, gain and
// estimate, within the bound's allowance.
TEST(Estimate, PerAngleStationsTakeTheNormalEquationsWhereTheBoundHolds) {
  EstimateOptions svd_only;
  svd_only.normal_equations_tolerance = 0;
  std::mt19937 rng(12);
  std::normal_distribution<double> z;
  for (const char axis : {'C', 'B'}) {
    SCOPED_TRACE(axis);
    const Design d = test::paper_design(axis);
    const Parameterisation param(d);
    std::vector<Reading> readings = nominal_readings(d);
    for (Reading& r : readings) r.reading_um = z(rng);
    const LinearModel model = build_linear_model(d, param, readings);
    const WlsSolver normal(model.J, model.sigma_um), svd(model.J, model.sigma_um, svd_only);
    const Estimate a = normal.solve(model.y_um), b = svd.solve(model.y_um);
    EXPECT_EQ(svd.a_priori().normal_equation_blocks, 0);
    const int blocks = static_cast<int>(normal.blocks().size());
    int short_blocks = 0;  // fewer readings than unknowns: the SVD, not the normal equations
    for (const WlsSolver::Block& blk : normal.blocks())
      short_blocks += blk.rows.size() < blk.cols.size();
    if (axis == 'C') {
      EXPECT_EQ(short_blocks, 0);
      EXPECT_EQ(a.normal_equation_blocks, blocks);  // every block full rank
    } else {
      // The B head's stations: blocks of fewer readings than unknowns (rank deficient, its
      // undetermined errors) take the SVD, the others the normal equations.
      EXPECT_GT(short_blocks, 0);
      EXPECT_EQ(a.normal_equation_blocks, blocks - short_blocks);
      EXPECT_LT(a.rank, a.n_unknowns);
    }
    EXPECT_EQ(a.rank, b.rank);
    EXPECT_EQ(a.null_space_scaled.cols(), b.null_space_scaled.cols());
    EXPECT_TRUE(test::near(a.singular_values, b.singular_values, 0, 1e-9));
    EXPECT_TRUE(test::near(a.covariance, b.covariance,
                           1e-9 * test::dense(b.covariance).cwiseAbs().maxCoeff()));
    EXPECT_TRUE(
        test::near(normal.J_theta_reading().sparse(), svd.J_theta_reading().sparse(),
                   1e-9 * test::dense(svd.J_theta_reading().sparse()).cwiseAbs().maxCoeff()));
    EXPECT_TRUE(test::near(a.theta, b.theta, 1e-9 * b.theta.cwiseAbs().maxCoeff()));
    EXPECT_NEAR(a.chi2, b.chi2, 1e-9 * b.chi2);
    // Within the bound, the normal equations are near the SVD; not identical (the two paths
    // differ in rounding), so a path that silently fell back would not pass for this one.
    if (axis == 'C') EXPECT_NE(test::dense(a.covariance), test::dense(b.covariance));
  }
  // An ill-conditioned station (kappa^2 rows eps > 1e-6): two nearly parallel columns in a
  // block of six; the bound fails and the SVD answers, with the SVD's numbers exactly.
  const int n = 8, p = 6;
  Eigen::MatrixXd J(n, p);
  for (Eigen::Index i = 0; i < J.size(); ++i) J.data()[i] = z(rng);
  for (int i = 0; i < n; ++i) J(i, 1) = J(i, 0) + 1e-6 * z(rng);
  const WlsSolver ill(J, Eigen::VectorXd::Ones(n)), ill_svd(J, Eigen::VectorXd::Ones(n), svd_only);
  EXPECT_EQ(ill.a_priori().normal_equation_blocks, 0);
  EXPECT_EQ(test::dense(ill.a_priori().covariance), test::dense(ill_svd.a_priori().covariance));
  // A well-conditioned one of six columns takes the normal equations.
  for (int i = 0; i < n; ++i) J(i, 1) = z(rng);
  EXPECT_EQ(WlsSolver(J, Eigen::VectorXd::Ones(n)).a_priori().normal_equation_blocks, 1);
}

// A Fourier identification (order 20, 246 unknowns) takes the normal equations and gives
// the SVD's values and uncertainties.
TEST(Estimate, FourierIdentificationTakesTheNormalEquations) {
  Design d = test::paper_design('C');
  d.angles_deg.clear();
  for (int i = 0; i < 72; ++i) d.angles_deg.push_back(5.0 * i);
  d.errors = {ErrorModel::Kind::kFourier, 20};
  const Parameterisation param(d);
  const LinearModel model = build_linear_model(d, param, nominal_readings(d));
  EstimateOptions svd_only;
  svd_only.normal_equations_tolerance = 0;
  const WlsSolver normal(model.J, model.sigma_um), svd(model.J, model.sigma_um, svd_only);
  EXPECT_GT(normal.a_priori().normal_equation_blocks,
            0);  // the model splits into independent blocks
  EXPECT_TRUE(test::near(normal.a_priori().covariance, svd.a_priori().covariance,
                         1e-9 * test::dense(svd.a_priori().covariance).cwiseAbs().maxCoeff()));
  EXPECT_TRUE(test::near(normal.J_theta_reading().sparse(), svd.J_theta_reading().sparse(),
                         1e-9 * test::dense(svd.J_theta_reading().sparse()).cwiseAbs().maxCoeff()));
}

// The factored rows of a series model (LinearModel::series) give the general solver's result:
// the blocks, singular values, covariance, estimate and every use of the (implicit) gain,
// on C and B designs, Fourier and Legendre, split into independent blocks or not. Where the
// path cannot answer (a block too small for the normal equations, or rank loss) the general
// path does, with identical results.
TEST(Estimate, SeriesRowsGiveTheGeneralSolversResult) {
  struct Case {
    const char* name;
    Design d;
    bool fast;  // expected to take the factored path
  };
  std::vector<Case> cases;
  auto with = [](Design d, ErrorModel e, int angles, double span) {
    d.errors = e;
    d.angles_deg.clear();
    for (int i = 0; i < angles; ++i) d.angles_deg.push_back(span * i / angles);
    return d;
  };
  cases.push_back({"C fourier 20, 72 angles (independent blocks)",
                   with(test::paper_design('C'), {ErrorModel::Kind::kFourier, 20}, 72, 360), true});
  const auto twelve = twelve_installations;  // as the benchmark: more installations, one block
  cases.push_back({"C fourier 8, 12 installations",
                   twelve(with(test::paper_design('C'), {ErrorModel::Kind::kFourier, 8}, 90, 360)),
                   true});
  {
    Design d = test::paper_design('B');
    d.errors = {ErrorModel::Kind::kLegendre, 7};
    cases.push_back({"B legendre 7 (its three null directions: rank loss)", d, false});
  }
  cases.push_back({"C legendre 9 over 300 degrees, 12 installations",
                   twelve(with(test::paper_design('C'), {ErrorModel::Kind::kLegendre, 9}, 61, 300)),
                   true});
  cases.push_back({"C fourier 2 (blocks below the normal equations' size)",
                   with(test::paper_design('C'), {ErrorModel::Kind::kFourier, 2}, 36, 360), false});
  {
    Design d = with(test::paper_design('C'), {ErrorModel::Kind::kFourier, 20}, 72, 360);
    d.installations.resize(1);  // one radial installation: most errors unseen (rank loss)
    cases.push_back({"C fourier 20, one installation", d, false});
  }
  std::mt19937 rng(3);
  std::normal_distribution<double> z;
  int fast = 0;
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const Parameterisation param(c.d);
    std::vector<Reading> readings = nominal_readings(c.d);
    for (Reading& r : readings) r.reading_um = z(rng);
    const LinearModel model = build_linear_model(c.d, param, readings);
    ASSERT_TRUE(model.series);
    const WlsSolver general(model.J, model.sigma_um), factored(model);
    const WlsSolver::Gain &Gg = general.J_theta_reading(), &Gf = factored.J_theta_reading();
    EXPECT_EQ(Gf.implicit(), c.fast);
    fast += Gf.implicit();
    const Estimate a = factored.solve(model.y_um), b = general.solve(model.y_um);
    EXPECT_EQ(a.rank, b.rank);
    EXPECT_EQ(a.status, b.status);
    ASSERT_EQ(factored.blocks().size(), general.blocks().size());
    for (std::size_t k = 0; k < general.blocks().size(); ++k) {
      EXPECT_EQ(factored.blocks()[k].cols, general.blocks()[k].cols) << k;
      EXPECT_EQ(factored.blocks()[k].rows, general.blocks()[k].rows) << k;
    }
    if (!c.fast) {  // the general path itself: the same numbers
      EXPECT_TRUE(test::near(test::dense(a.covariance), test::dense(b.covariance), 0.0));
      EXPECT_TRUE(test::near(a.theta, b.theta, 0.0));
      continue;
    }
    const double cov_max = test::dense(b.covariance).cwiseAbs().maxCoeff();
    EXPECT_TRUE(test::near(test::dense(a.covariance), test::dense(b.covariance), 1e-10 * cov_max));
    EXPECT_TRUE(test::near(a.column_scale, b.column_scale, 0.0, 1e-12));
    EXPECT_TRUE(test::near(a.singular_values, b.singular_values, 0.0, 1e-9));
    ASSERT_TRUE(a.condition_number && b.condition_number);
    EXPECT_NEAR(*a.condition_number, *b.condition_number, 1e-9 * *b.condition_number);
    EXPECT_EQ(a.null_space_scaled.cols(), 0);
    EXPECT_TRUE(test::near(a.theta, b.theta, 1e-9 * b.theta.cwiseAbs().maxCoeff()));
    EXPECT_TRUE(
        test::near(a.residual_um, b.residual_um, 1e-9 * b.residual_um.cwiseAbs().maxCoeff()));
    EXPECT_NEAR(a.chi2, b.chi2, 1e-9 * b.chi2);
    // The covariance's dense blocks are the sparse matrix.
    for (Eigen::Index i = 0; i < a.covariance.rows(); i += 7) {
      for (Eigen::Index j = 0; j < a.covariance.cols(); j += 5)
        EXPECT_EQ(a.covariance_at(i, j), a.covariance.coeff(i, j)) << i << "," << j;
    }
    // The gain, implicit, in each of its uses.
    const Eigen::MatrixXd Gd = test::dense(Gg.sparse());
    const double g_max = Gd.cwiseAbs().maxCoeff();
    EXPECT_TRUE(test::near(test::dense(Gf.sparse()), Gd, 1e-9 * g_max));
    Eigen::MatrixXd M(model.J.rows(), 3), L(4, model.J.cols());
    for (Eigen::Index i = 0; i < M.size(); ++i) M.data()[i] = z(rng);
    for (Eigen::Index i = 0; i < L.size(); ++i) L.data()[i] = z(rng);
    EXPECT_TRUE(test::near(Gf * M, Gd * M, 1e-9 * (Gd * M).cwiseAbs().maxCoeff()));
    EXPECT_TRUE(test::near(Gf.left(L), L * Gd, 1e-9 * (L * Gd).cwiseAbs().maxCoeff()));
    std::vector<Eigen::Triplet<double>> t;
    for (int r = 0; r < 5; ++r) {
      for (int j = 0; j < 6; ++j) t.emplace_back(r, (r * 13 + j * 7) % model.J.cols(), z(rng));
    }
    FunctionRows C(5, model.J.cols());
    C.setFromTriplets(t.begin(), t.end());
    const Eigen::MatrixXd CG = test::dense(C) * Gd;
    EXPECT_TRUE(test::near(test::dense(Gf.left(C)), CG, 1e-9 * CG.cwiseAbs().maxCoeff()));
    ASSERT_TRUE(Gf.series_l1());
    const Eigen::VectorXd l1 = CG.cwiseAbs().rowwise().sum();
    EXPECT_TRUE(test::near(Gf.left_l1(C), l1, 0.0, 1e-9));
    for (Eigen::Index i = 0; i < model.J.rows(); i += 37) {
      EXPECT_TRUE(test::near(Gf.col(i), Gd.col(i), 1e-9 * g_max)) << i;
      EXPECT_NEAR(factored.leverage(i), general.leverage(i), 1e-9) << i;
    }
  }
  EXPECT_EQ(fast, 3);
}

}  // namespace
}  // namespace dbbkit

namespace dbbkit {
namespace {

// detail::block_form over a span with gaps (a's missing places summed and dropped) gives the
// bits of the sums over a's own places in their order: the form as written out, for places
// with gaps, without, and out of order (no span).
TEST(Estimate, BlockFormOverASpanIsTheSumOverThePlaces) {
  std::mt19937 rng(21);
  std::normal_distribution<double> z;
  Eigen::MatrixXd B(40, 40);
  for (Eigen::Index i = 0; i < B.size(); ++i) B.data()[i] = z(rng);
  B = (B + B.transpose()).eval();
  const std::vector<std::vector<int>> places = {
      {3, 4, 6, 7, 8, 10, 11, 12, 15}, {20, 21, 22, 23, 24}, {9, 2, 30, 5}, {0}, {1, 39}};
  std::vector<double> work;
  for (const std::vector<int>& ia : places) {
    for (const std::vector<int>& jb : places) {
      std::vector<double> a(ia.size()), b(jb.size());
      for (double& v : a) v = z(rng);
      for (double& v : b) v = z(rng);
      double expected = 0;
      for (std::size_t x = 0; x < ia.size(); ++x) {
        double inner = 0;
        for (std::size_t y = 0; y < jb.size(); ++y) inner += B(ia[x], jb[y]) * b[y];
        expected += a[x] * inner;
      }
      EXPECT_EQ(detail::block_form(B, a.data(), ia.data(), ia.size(), b.data(), jb.data(),
                                   jb.size(), work),
                expected)
          << ia.size() << " x " << jb.size();
    }
  }
}

// detail::inverse_from_cholesky (potri by halves) against Eigen's solve of the identity, at
// sizes below, at and past the unblocked size and odd splits; symmetric to the bit, and
// A A^-1 = I.
TEST(Estimate, InverseFromCholeskyIsTheInverse) {
  std::mt19937 rng(17);
  std::normal_distribution<double> z;
  for (Eigen::Index n : {1, 2, 5, 24, 25, 49, 100, 246}) {
    SCOPED_TRACE(n);
    Eigen::MatrixXd R(n + 3, n);
    for (Eigen::Index i = 0; i < R.size(); ++i) R.data()[i] = z(rng);
    const Eigen::MatrixXd A = R.transpose() * R;
    const Eigen::LLT<Eigen::MatrixXd> llt(A);
    ASSERT_EQ(llt.info(), Eigen::Success);
    const Eigen::MatrixXd X = detail::inverse_from_cholesky(llt.matrixLLT());
    const Eigen::MatrixXd reference = llt.solve(Eigen::MatrixXd::Identity(n, n));
    const double scale = reference.cwiseAbs().maxCoeff();
    EXPECT_TRUE(test::near(X, reference, 1e-10 * scale));
    EXPECT_EQ(X, X.transpose());
    EXPECT_TRUE(test::near(A * X, Eigen::MatrixXd::Identity(n, n), 1e-9));
  }
}

}  // namespace
}  // namespace dbbkit
