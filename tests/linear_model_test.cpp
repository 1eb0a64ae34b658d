// The linear model's set-up sensitivity (linear_model.hpp, J_reading_setup: the change of
// the model readings per mm of a ball's placement L, D, H) against the exact two-ball
// geometry (kinematics.hpp, exact_setup_reading_um): the reading the errors cause with the
// ball placed off its design position, the following ball on its programmed path.

#include "dbbkit/linear_model.hpp"

#include <gtest/gtest.h>

#include <random>

#include "dbbkit/kinematics.hpp"
#include "test_util.hpp"

namespace dbbkit {
namespace {

using test::kBar;

TEST(SetupJacobian, IsTheDerivativeOfTheExactReadingOfTheErrorsWithTheBallMoved) {
  std::mt19937_64 rng(17);
  std::uniform_real_distribution<double> uni(-1, 1);
  int checked = 0;
  for (char which : {'C', 'B'}) {
    Design d = test::paper_design(which);
    d.setup_std.L_mm = d.setup_std.D_mm = 0.1;
    d.setup_std.H_mm = d.axis == test::kAxisC ? 0.1 : 0.0;  // B: the ball is (0, D, L)
    for (Installation& in : d.installations) {
      if (!in.bar_mm) in.bar_mm = kBar;
    }
    const Parameterisation param(d);
    const std::vector<Reading> readings = nominal_readings(d);
    const LinearModel model = build_linear_model(d, param, readings);
    const std::vector<SetupInput> inputs = setup_inputs(d);
    ASSERT_FALSE(inputs.empty());
    Eigen::VectorXd theta(param.n_parameters());
    for (Eigen::Index j = 0; j < theta.size(); ++j) theta(j) = 5 * uni(rng);  // um, urad
    const Eigen::MatrixXd D = J_reading_setup(d, param, model, inputs, theta);
    for (std::size_t j = 0; j < inputs.size(); ++j) {
      const Installation& in = d.installations[inputs[j].installation];
      for (Eigen::Index i = 0; i < D.rows(); ++i) {
        if (model.row_installation[i] != inputs[j].installation) continue;
        const double a = model.row_angle_deg[i];
        const Vector6d e = param.errors_at_angle(a, theta);
        // x [mm]: the ball moved along input j's coordinate; the reading the errors cause.
        auto of_errors = [&](const Eigen::VectorXd& x) {
          SetupError s;
          s.ball_mm(inputs[j].coord) = x(0);
          return Eigen::VectorXd::Constant(
              1, exact_setup_reading_um(d.axis, in, a, e, *in.bar_mm, s) -
                     exact_setup_reading_um(d.axis, in, a, Vector6d::Zero(), *in.bar_mm, s));
        };
        // Second order in the errors (|e|^2 / bar, about 2e-4 um here) stays in the
        // difference; its change per mm is far below the tolerance.
        EXPECT_TRUE(test::jacobian_matches(of_errors, Eigen::VectorXd::Zero(1), D.block(i, j, 1, 1),
                                           0.05, 2e-5, 1e-3))
            << d.name << " " << in.id << " coord " << inputs[j].coord << " at " << a << " deg";
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 100);
}

}  // namespace
}  // namespace dbbkit
