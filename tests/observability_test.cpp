#include "dbbkit/observability.hpp"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>

#include "../src/factorised.hpp"
#include "../src/wls_solver.hpp"
#include "dbbkit/io/result_io.hpp"
#include "dbbkit/linear_model.hpp"
#include "dbbkit/parameterisation.hpp"
#include "test_util.hpp"

namespace dbbkit {
namespace {

using test::kPi;

// J = [1 0; 1 1; 0 1], sigma = 2 um. By hand:
//   M = J'J / 4 = [2 1; 1 2] / 4: det = 3/16, trace M^-1 = 4 * 4/3 = 16/3, min eig = 1/4;
//   hat diagonal of J (J'J)^-1 J' = 2/3 for every row.
//   Columns of J/2 have norm sqrt(2)/2, so Js = J / sqrt(2): Js'Js = [2 1; 1 2]/2, singular values
//   sqrt(3/2), sqrt(1/2).
TEST(Observability, IndicesAndCriteriaAgainstHandValues) {
  Eigen::MatrixXd J(3, 2);
  J << 1, 0, 1, 1, 0, 1;
  const WlsSolver solver(J, Eigen::Vector3d::Constant(2.0));
  const Estimate& est = solver.a_priori();
  const double s1 = std::sqrt(1.5), s2 = std::sqrt(0.5);
  EXPECT_NEAR(est.singular_values(0), s1, 1e-14);
  EXPECT_NEAR(est.singular_values(1), s2, 1e-14);
  EXPECT_NEAR(*est.condition_number, std::sqrt(3.0), 1e-13);
  const ObservabilityIndices o = observability_indices(est.singular_values, est.rank, 2, 3);
  EXPECT_NEAR(o.O1, std::sqrt(s1 * s2) / std::sqrt(3.0), 1e-14);
  EXPECT_NEAR(o.O2, 1 / std::sqrt(3.0), 1e-14);
  EXPECT_NEAR(o.O3, s2, 1e-14);
  EXPECT_NEAR(o.O4, 0.5 / s1, 1e-14);
  EXPECT_NEAR(o.O5, 1 / (1 / s1 + 1 / s2), 1e-14);
  const DesignCriteria c = design_criteria(solver);
  ASSERT_TRUE(c.D_logdet && c.A_trace);
  EXPECT_NEAR(*c.D_logdet, std::log(3.0 / 16.0), 1e-13);
  EXPECT_NEAR(*c.A_trace, 16.0 / 3.0, 1e-13);
  EXPECT_NEAR(c.E_min_eigenvalue, 0.25, 1e-13);
  EXPECT_NEAR(c.G_max_leverage, 2.0 / 3.0, 1e-13);
}

TEST(Observability, RankLossZeroesIndicesAndHidesDA) {
  Eigen::MatrixXd J(3, 2);
  J << 1, 1, 2, 2, 3, 3;
  const WlsSolver solver(J, Eigen::Vector3d::Ones());
  const Estimate& est = solver.a_priori();
  EXPECT_EQ(est.rank, 1);
  const ObservabilityIndices o = observability_indices(est.singular_values, est.rank, 2, 3);
  EXPECT_EQ(o.O1, 0.0);
  EXPECT_EQ(o.O3, 0.0);
  const DesignCriteria c = design_criteria(solver);
  EXPECT_FALSE(c.D_logdet.has_value());
  EXPECT_FALSE(c.A_trace.has_value());
  EXPECT_EQ(c.E_min_eigenvalue, 0.0);
}

// E, the smallest eigenvalue of M = J' W J, against the whole M (dense, Eigen's solver on all
// unknowns at once, not block by block). Its stations tie to rounding in the paper's
// symmetric C design, and their eigenvalues are then not all computed: E lies within 1e-9
// relative of the true one, and never below it by more than rounding. The C design with its
// installations lengthened unequally and uneven angles has no ties; B is the head.
TEST(Observability, SmallestEigenvalueOfTheWholeInformation) {
  Design uneven = test::paper_design('C');
  for (std::size_t k = 0; k < uneven.installations.size(); ++k) {
    if (uneven.installations[k].L_mm > 0) uneven.installations[k].L_mm += 7.0 * k;
  }
  for (std::size_t i = 1; i + 1 < uneven.angles_deg.size(); ++i)
    uneven.angles_deg[i] += 0.3 * static_cast<double>(i % 3);
  int checked = 0;
  for (const Design& d : {test::paper_design('C'), uneven, test::paper_design('B')}) {
    const Parameterisation param(d);
    const LinearModel model = design_model(d, param);
    const WlsSolver solver(model.J, model.sigma_um);
    if (solver.a_priori().rank < solver.a_priori().n_unknowns) continue;  // E only at full rank
    const Eigen::MatrixXd J = Eigen::MatrixXd(model.J);
    const Eigen::MatrixXd M =
        J.transpose() * model.sigma_um.cwiseAbs2().cwiseInverse().asDiagonal() * J;
    const double lambda_min = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(M).eigenvalues()(0);
    ASSERT_GT(lambda_min, 0);
    const double E = design_criteria(solver).E_min_eigenvalue;
    EXPECT_GE(E, lambda_min * (1 - 1e-12)) << d.name;
    EXPECT_LE(E, lambda_min * (1 + 1e-9)) << d.name;
    ++checked;
  }
  EXPECT_EQ(checked, 2);  // both C designs; the head is rank-deficient
}

// The same on blocks whose smallest eigenvalues fall by about 0.4 % from block to block
// (two unknowns each, rows (1, 1) and (1, 1 - b_k)): every block lowers E, none is within the
// tie width of another, so E is the exact minimum, the last block's.
TEST(Observability, SmallestEigenvalueOverBlocksThatEachLowerIt) {
  constexpr int kBlocks = 12;
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(2 * kBlocks, 2 * kBlocks);
  for (int k = 0; k < kBlocks; ++k) {
    const double b = 0.5 * (1.0 - 0.002 * k);
    J(2 * k, 2 * k) = J(2 * k, 2 * k + 1) = 1.0;
    J(2 * k + 1, 2 * k) = 1.0;
    J(2 * k + 1, 2 * k + 1) = 1.0 - b;
  }
  const WlsSolver solver(J, Eigen::VectorXd::Constant(2 * kBlocks, 2.0));
  ASSERT_EQ(solver.blocks().size(), static_cast<std::size_t>(kBlocks));
  const Eigen::MatrixXd M = J.transpose() * J / 4.0;
  const Eigen::VectorXd block_last =
      Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(M.bottomRightCorner(2, 2)).eigenvalues();
  const double lambda_min = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(M).eigenvalues()(0);
  EXPECT_NEAR(lambda_min, block_last(0), 1e-15);
  EXPECT_NEAR(design_criteria(solver).E_min_eigenvalue, lambda_min, 1e-14 * lambda_min);
}

// Closed form for the paper's C design (model.md §3), per angle g, k = 1e-3 um/(urad mm):
//   radial at (L, H):     a + k H et,            a = dx c + dy s,   et = -ex s + ey c
//   tangential at (L, H): b - k H er + k L ez,   b = -dx s + dy c,  er = ex c + ey s
//   axial at (0, H1):     dz
// Radial readings do not depend on L: 1r and 2r repeat a + k H1 et, 3r gives a + k H3 et,
// a straight-line fit in H with Sxx = (2/3) dH^2, so u(et) = sigma / (k dH sqrt(2/3)).
// Tangential: t2 - t1 = k (L2 - L1) ez gives u(ez) = sqrt(2) sigma / (k dL) (the L1/L2 pair
// alone), t3 - t1 = -k dH er gives u(er) = sqrt(2) sigma / (k dH). dz = the axial reading: u =
// sigma. er and et come from disjoint readings, so u(ex)^2 = c^2 u(er)^2 + s^2 u(et)^2 and u(ey)^2
// = s^2 u(er)^2 + c^2 u(et)^2. At 0 deg the readings at 360 deg halve every variance. Every
// station's uncertainties of the paper's C design (L1 = 100, L2 = 200, H1 = 60, H3 = 160 mm)
// against the closed form above, whatever the angle step.
void expect_turntable_closed_form(const Evaluation& ev) {
  const double sigma = 1.25 / std::sqrt(3.0), k = 1e-3;
  const double dL = 200 - 100, dH = 160 - 60;
  const double u_et = sigma / (k * dH * std::sqrt(2.0 / 3.0));
  const double u_er = std::sqrt(2.0) * sigma / (k * dH);
  const double u_ez = std::sqrt(2.0) * sigma / (k * dL);
  int failures = 0;
  for (const ErrorsAtAngle& ea : ev.errors) {
    const double g = ea.angle_deg * kPi / 180, c = std::cos(g), s = std::sin(g);
    const double repeat = ea.angle_deg == 0.0 ? std::sqrt(2.0) : 1.0;
    const double expected[4] = {
        sigma / repeat, std::sqrt(c * c * u_er * u_er + s * s * u_et * u_et) / repeat,
        std::sqrt(s * s * u_er * u_er + c * c * u_et * u_et) / repeat, u_ez / repeat};
    const int error[4] = {2, 3, 4, 5};
    for (int i = 0; i < 4 && failures < 10; ++i) {
      const double tol = i == 0 ? 1e-12 : 1e-9;
      if (std::abs(ea.errors[error[i]].std - expected[i]) > tol) ++failures;
      EXPECT_NEAR(ea.errors[error[i]].std, expected[i], tol)
          << kErrorNames[error[i]] << " at " << ea.angle_deg;
    }
  }
}

TEST(Observability, PaperTurntableMatchesClosedForm) {
  const Evaluation ev = evaluate_design(test::paper_design('C'), 100.0);
  ASSERT_EQ(ev.prior.rank, 108);
  ASSERT_EQ(ev.errors.size(), 18u);
  expect_turntable_closed_form(ev);
  ASSERT_TRUE(ev.worst.worst_std_um.has_value());
  EXPECT_EQ(ev.worst.n_undetermined, 0);
}

// A per-angle model is solved station by station: at 0.1 deg steps (3,601 angles, 25,207
// readings, 21,600 unknowns) every station has the closed form of the test above, as at
// 20 deg. Too large for a dense factorisation (8.7 GB for the Jacobian and the gain alone).
TEST(Observability, TenthDegreeTurntableIsTheClosedFormAtEveryStation) {
  Design d = test::paper_design('C');
  d.angles_deg.clear();
  for (int i = 0; i <= 3600; ++i) d.angles_deg.push_back(0.1 * i);
  const Evaluation ev = evaluate_design(d, 100.0);
  ASSERT_EQ(ev.prior.n_readings, 7 * 3601);
  ASSERT_EQ(ev.prior.rank, 6 * 3600);
  ASSERT_EQ(ev.errors.size(), 3600u);
  expect_turntable_closed_form(ev);
  EXPECT_EQ(ev.worst.n_undetermined, 0);
  EXPECT_GT(ev.criteria.E_min_eigenvalue, 0.0);
}

// The rank-deficient head at 0.1 deg steps: one undetermined combination per station (the
// rotation about the tool axis), each confined to its station, as at the paper's steps.
TEST(Observability, TenthDegreeHeadNamesOneCombinationPerStation) {
  Design d = test::paper_design('B');
  const double lo = d.angles_deg.front(), hi = d.angles_deg.back();
  d.angles_deg.clear();
  const int steps = static_cast<int>(std::lround((hi - lo) / 0.1));
  for (int i = 0; i <= steps; ++i) d.angles_deg.push_back(lo + (hi - lo) * i / steps);
  const Evaluation ev = evaluate_design(d, 100.0);
  const int stations = steps + 1;
  EXPECT_EQ(ev.prior.n_unknowns, 6 * stations);
  EXPECT_EQ(ev.prior.rank, 5 * stations);
  ASSERT_EQ(static_cast<int>(ev.unidentifiable.size()), stations);
  for (const Unidentifiable& u : ev.unidentifiable) {
    ASSERT_TRUE(u.angle_deg.has_value());
    ASSERT_TRUE(u.motion);
    EXPECT_TRUE(u.motion->tool_axis) << io::unidentifiable_interpretation(u);
  }
}

TEST(Observability, PaperHeadIsRankFiveOfSixAndNamesTheCombination) {
  const Evaluation ev = evaluate_design(test::paper_design('B'), 100.0);
  EXPECT_EQ(ev.prior.rank, 105);
  EXPECT_EQ(ev.prior.n_unknowns, 126);
  EXPECT_EQ(ev.unidentifiable.size(), 21u);
  EXPECT_FALSE(ev.worst.worst_std_um.has_value());
  EXPECT_EQ(ev.worst.n_undetermined, 40);  // ex and ez at 21 angles, less ex at 0 and ez at -90
  ASSERT_TRUE(ev.worst.worst_determined_std_um.has_value());
  for (const Unidentifiable& u : ev.unidentifiable) {
    ASSERT_TRUE(u.motion);
    EXPECT_TRUE(u.motion->tool_axis) << io::unidentifiable_interpretation(u);
  }
}

TEST(Observability, WorstCaseConvertsAngularErrorsAtTheReferenceLength) {
  ErrorsAtAngle ea;
  ea.angle_deg = 10;
  for (int k = 0; k < 6; ++k) ea.errors[k] = {true, 0.0, 1.0};
  ea.errors[4].std = 30.0;  // urad: 3 um at 100 mm, 0.6 um at 20 mm
  WorstCase w = worst_case({ea}, 100.0);
  EXPECT_DOUBLE_EQ(*w.worst_std_um, 3.0);
  EXPECT_EQ(w.at_error, 4);
  w = worst_case({ea}, 20.0);
  EXPECT_DOUBLE_EQ(*w.worst_std_um, 1.0);  // dx..dz at 1 um now dominate
}

}  // namespace
}  // namespace dbbkit

#include "dbbkit/error.hpp"
#include "dbbkit/io/sweep_io.hpp"

namespace dbbkit {
namespace {

TEST(DesignMap, EveryPointIsTheEvaluationOfThatDesign) {
  const Design d = test::paper_design('C');
  const std::vector<SweepVariable> vars = {io::parse_sweep(d, "L2=150:250:50"),
                                           io::parse_sweep(d, "H@3r,3t=100:200:100")};
  EXPECT_EQ(vars[0].installations, (std::vector<int>{3, 4}));  // 2r, 2t
  EXPECT_EQ(vars[1].installations, (std::vector<int>{5, 6}));
  const std::vector<SweepPoint> map = sweep_design(d, vars, 100.0);
  ASSERT_EQ(map.size(), 6u);
  EXPECT_EQ(map[1].values, (std::vector<double>{150, 200}));  // the first variable varies slowest
  for (const SweepPoint& p : map) {
    Design m = d;
    m.installations[3].L_mm = m.installations[4].L_mm = p.values[0];
    m.installations[5].H_mm = m.installations[6].H_mm = p.values[1];
    const Evaluation ev = evaluate_design(m, 100.0);
    ASSERT_TRUE(p.worst_std_um.has_value());
    EXPECT_DOUBLE_EQ(*p.worst_std_um, *ev.worst.worst_std_um);
    EXPECT_DOUBLE_EQ(*p.condition_number, *ev.prior.condition_number);
  }
  // A longer lever arm L2 - L1 shrinks u(ez) = sqrt(2) sigma / (k (L2 - L1)), so the worst case
  // cannot grow.
  EXPECT_LE(*map[4].worst_std_um, *map[0].worst_std_um);
}

TEST(DesignMap, BadSpecificationsAreRefused) {
  const Design d = test::paper_design('C');
  for (const char* spec :
       {"L2", "X2=1:2:1", "L9=1:2:1", "L@4r=1:2:1", "L2=1:2", "L2=5:1:1", "L2=1:2:0", "L2=a:2:1"}) {
    EXPECT_THROW(io::parse_sweep(d, spec), InputError) << spec;
  }
  EXPECT_THROW(io::parse_sweep(test::paper_design('B'), "H1=1:2:1"), InputError);
  // L below 0 makes an invalid turntable design.
  EXPECT_THROW(sweep_design(d, {io::parse_sweep(d, "L2=-10:0:10")}, 100.0), InputError);
}

}  // namespace
}  // namespace dbbkit
