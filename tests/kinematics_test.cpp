#include "dbbkit/kinematics.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "test_util.hpp"

namespace dbbkit {
namespace {

using test::kPi;

Installation make(double L, double D, double H, Direction dir, int sign = 1) {
  Installation in;
  in.id = "x";
  in.L_mm = L;
  in.D_mm = D;
  in.H_mm = H;
  in.direction = dir;
  in.sign = sign;
  return in;
}

TEST(Kinematics, SincosDegIsExactAtQuarterTurns) {
  for (int q = -8; q <= 8; ++q) {
    double s, c;
    sincos_deg(90.0 * q, s, c);
    EXPECT_EQ(s, std::round(std::sin(q * kPi / 2)));
    EXPECT_EQ(c, std::round(std::cos(q * kPi / 2)));
  }
  for (double a : {-359.7, -123.4, -45.0, 0.3, 12.5, 89.99, 135.0, 271.2, 1000.1}) {
    double s, c;
    sincos_deg(a, s, c);
    EXPECT_NEAR(s, std::sin(a * kPi / 180), 1e-14) << a;
    EXPECT_NEAR(c, std::cos(a * kPi / 180), 1e-14) << a;
  }
}

// model.md §3, paper Eq. 9 (D = 0), read through radial, tangential and axial directions.
TEST(Kinematics, TurntableRowsMatchPaperEquation9) {
  const double L = 120, H = 75;
  for (double g_deg : {0.0, 20.0, 135.0, 290.0}) {
    const double g = g_deg * kPi / 180;
    // dP for each single error, from Eq. 9, columns dx dy dz ex ey ez (urad -> 1e-3 um/mm).
    Eigen::Matrix<double, 3, 6> dP;
    dP << 1, 0, 0, 0, 1e-3 * H, -1e-3 * L * std::sin(g),  //
        0, 1, 0, -1e-3 * H, 0, 1e-3 * L * std::cos(g),    //
        0, 0, 1, 1e-3 * L * std::sin(g), -1e-3 * L * std::cos(g), 0;
    const Eigen::Vector3d u_r(std::cos(g), std::sin(g), 0), u_t(-std::sin(g), std::cos(g), 0),
        u_a(0, 0, 1);
    const std::pair<Direction::Kind, Eigen::Vector3d> dirs[] = {{Direction::Kind::kRadial, u_r},
                                                                {Direction::Kind::kTangential, u_t},
                                                                {Direction::Kind::kAxial, u_a}};
    for (const auto& [kind, u] : dirs) {
      const Installation in = make(L, 0, H, Direction::named(test::kAxisC, kind));
      EXPECT_TRUE(test::near(J_reading_error(test::kAxisC, in, g_deg), u.transpose() * dP, 1e-12))
          << g_deg;
    }
  }
}

// model.md §4: P(b) = (L sin b, 0, L cos b), dX = L cos b ey + dx, dY = L (ez sin b - ex cos b) +
// dy, dZ = -L sin b ey + dz; u_r = (sin b, 0, cos b), u_t = (cos b, 0, -sin b), u_a = (0, 1, 0).
TEST(Kinematics, SwingingHeadRowsMatchModel) {
  const double L = 150;
  for (double b_deg : {0.0, -30.0, -90.0, -100.0}) {
    const double b = b_deg * kPi / 180;
    Eigen::Matrix<double, 3, 6> dP;
    dP << 1, 0, 0, 0, 1e-3 * L * std::cos(b), 0,                      //
        0, 1, 0, -1e-3 * L * std::cos(b), 0, 1e-3 * L * std::sin(b),  //
        0, 0, 1, 0, -1e-3 * L * std::sin(b), 0;
    const Eigen::Vector3d u_r(std::sin(b), 0, std::cos(b)), u_t(std::cos(b), 0, -std::sin(b)),
        u_a(0, 1, 0);
    const std::pair<Direction::Kind, Eigen::Vector3d> dirs[] = {{Direction::Kind::kRadial, u_r},
                                                                {Direction::Kind::kTangential, u_t},
                                                                {Direction::Kind::kAxial, u_a}};
    for (const auto& [kind, u] : dirs) {
      const Installation in = make(L, 0, 0, Direction::named(test::kAxisB, kind));
      EXPECT_TRUE(test::near(J_reading_error(test::kAxisB, in, b_deg), u.transpose() * dP, 1e-12))
          << b_deg;
      EXPECT_TRUE(test::near(ball_position_mm(test::kAxisB, in, b_deg),
                             Eigen::Vector3d(L * std::sin(b), 0, L * std::cos(b)), 1e-12));
    }
  }
}

TEST(Kinematics, SignFlipsTheRow) {
  Installation in = make(100, 5, 60, Direction::named(test::kAxisC, Direction::Kind::kRadial));
  const RowVector6d plus = J_reading_error(test::kAxisC, in, 40);
  in.sign = -1;
  EXPECT_TRUE(test::near(J_reading_error(test::kAxisC, in, 40), -plus, 0.0));
}

TEST(Kinematics, ExplicitVectorEqualsNamedDirection) {
  // An explicit body vector equal to the named one gives the same row; the body frame is the
  // machine frame at 0.
  for (Axis axis : {test::kAxisC, test::kAxisB}) {
    for (auto kind :
         {Direction::Kind::kRadial, Direction::Kind::kTangential, Direction::Kind::kAxial}) {
      const Direction named = Direction::named(axis, kind);
      const Installation a = make(80, 10, axis == test::kAxisC ? 40 : 0, named);
      const Installation b =
          make(80, 10, axis == test::kAxisC ? 40 : 0, Direction::vector(named.body));
      EXPECT_TRUE(test::near(J_reading_error(axis, a, 33), J_reading_error(axis, b, 33), 0.0));
    }
  }
}

// The row is the derivative of the exact reading at zero error: central differences of the
// exact homogeneous transform (tests/test_util.hpp, jacobian_matches), both axes, named and
// explicit directions, both signs.
TEST(Kinematics, RowIsTheDerivativeOfTheExactReading) {
  std::mt19937_64 rng(8);
  std::uniform_real_distribution<double> uni(-1, 1);
  for (Axis axis : {test::kAxisC, test::kAxisB}) {
    for (int trial = 0; trial < 40; ++trial) {
      const int k = trial % 4;
      const Direction dir =
          k < 3 ? Direction::named(axis, static_cast<Direction::Kind>(k))
                : Direction::vector(Eigen::Vector3d(uni(rng), uni(rng), uni(rng)).normalized());
      const Installation in =
          make(250 * std::abs(uni(rng)), 50 * uni(rng),
               axis == test::kAxisC ? 200 * std::abs(uni(rng)) : 0, dir, trial % 2 ? 1 : -1);
      const double angle = 180 * uni(rng);
      auto exact = [&](const Eigen::VectorXd& e) {
        return Eigen::VectorXd::Constant(1, exact_reading_um(axis, in, angle, e, 150.0));
      };
      EXPECT_TRUE(test::jacobian_matches(exact, Eigen::VectorXd::Zero(6),
                                         J_reading_error(axis, in, angle), 1.0, 1e-8, 1e-7))
          << "axis " << axis.label() << " trial " << trial;
    }
  }
}

// The first-order row against the exact homogeneous transform: for errors
// t * e, |exact(t e) - t J e| must shrink as t^2 (halving t quarters it).
TEST(Kinematics, RowAgreesWithExactTransformToSecondOrder) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> uni(-1, 1);
  int checked = 0;
  for (Axis axis : {test::kAxisC, test::kAxisB}) {
    for (int trial = 0; trial < 40; ++trial) {
      Direction dir;
      const int k = trial % 4;
      if (k < 3) {
        dir = Direction::named(axis, static_cast<Direction::Kind>(k));
      } else {
        dir = Direction::vector(Eigen::Vector3d(uni(rng), uni(rng), uni(rng)).normalized());
      }
      const Installation in =
          make(250 * std::abs(uni(rng)), 50 * uni(rng),
               axis == test::kAxisC ? 200 * std::abs(uni(rng)) : 0, dir, trial % 2 ? 1 : -1);
      const double angle = 180 * uni(rng);
      Vector6d e;
      for (int i = 0; i < 6; ++i) e(i) = 50 * uni(rng);  // um and urad
      const RowVector6d row = J_reading_error(axis, in, angle);
      const double bar = 150;
      double previous = 0;
      for (double t : {40.0, 20.0, 10.0, 5.0}) {
        const double err = std::abs(exact_reading_um(axis, in, angle, t * e, bar) - t * row.dot(e));
        if (previous > 1e-9) {  // above rounding of the exact reading (~1e-10 um)
          EXPECT_NEAR(previous / err, 4.0, 0.25)
              << "axis " << axis.label() << " trial " << trial << " t " << t;
          ++checked;
        }
        previous = err;
      }
    }
  }
  EXPECT_GT(checked, 150);
}

}  // namespace
}  // namespace dbbkit
