// The effect library's rows (effects.hpp, J_reading_effect) against the geometry they
// stand for: the set-up effects as derivatives of the exact two-ball reading with a real
// set-up (kinematics.hpp, exact_setup_reading_um), scale and squareness as derivatives
// of the exact bar length with the following ball moved by the linear axes' errors,
// and the time effects by hand.

#include "dbbkit/effects.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "dbbkit/kinematics.hpp"
#include "test_util.hpp"

namespace dbbkit {
namespace {

using test::kBar;

EffectCandidate candidate(EffectKind kind, int installation) {
  EffectCandidate e;
  e.kind = kind;
  e.installation = installation;
  return e;
}

// Every installation and angle of both paper designs, with the design's bars.
template <typename Check>
void for_every_reading(const Check& check) {
  for (char which : {'C', 'B'}) {
    Design d = test::paper_design(which);
    for (Installation& in : d.installations) {
      if (!in.bar_mm) in.bar_mm = kBar;
    }
    const std::vector<Reading> readings = nominal_readings(d);
    for (const Reading& r : readings) {
      int i = 0;
      while (d.installations[i].id != r.installation) ++i;
      check(d, i, r);
    }
  }
}

TEST(EffectJacobian, LengthOffsetAndCentringAreDerivativesOfTheExactReading) {
  int checked = 0;
  for_every_reading([&](const Design& d, int i, const Reading& r) {
    const Installation& in = d.installations[i];
    Eigen::MatrixXd J(1, 4);
    J(0, 0) = J_reading_effect(d, r, 0.0, candidate(EffectKind::kLengthOffset, i))(0);
    const Eigen::VectorXd c = J_reading_effect(d, r, 0.0, candidate(EffectKind::kCentring, i));
    ASSERT_EQ(c.size(), 3);
    J.rightCols(3) = c.transpose();
    // x = (length offset, centring x, y, z) [um].
    auto exact = [&](const Eigen::VectorXd& x) {
      SetupError s;
      s.length_offset_um = x(0);
      s.centring_um = x.tail(3);
      return Eigen::VectorXd::Constant(
          1, exact_setup_reading_um(d.axis, in, r.angle_deg, Vector6d::Zero(), *in.bar_mm, s));
    };
    EXPECT_TRUE(test::jacobian_matches(exact, Eigen::VectorXd::Zero(4), J, 1.0, 1e-8, 1e-7))
        << d.name << " " << in.id << " at " << r.angle_deg << " deg";
    ++checked;
  });
  EXPECT_GT(checked, 100);
}

TEST(EffectJacobian, ScaleAndSquarenessAreDerivativesOfTheBarWithTheFollowingBallMoved) {
  int checked = 0;
  for_every_reading([&](const Design& d, int i, const Reading& r) {
    const Installation& in = d.installations[i];
    const Eigen::Vector3d P = ball_position_mm(d.axis, in, r.angle_deg);
    const Eigen::Vector3d F = P - in.sign * *in.bar_mm * direction_machine(d.axis, in, r.angle_deg);
    // The linear axes place the following ball at F + dF: scale k [um/m] gives
    // dF_j = 1e-6 k_j F_j [mm]; squareness S [urad] gives dF = 1e-6 (S_xy F_y, S_yz F_z,
    // S_zx F_x) [mm]. The reading is the change of the bar length [um].
    auto bar_change = [&](const Eigen::Vector3d& dF_mm) {
      return 1e3 * ((P - F - dF_mm).norm() - (P - F).norm());
    };
    auto scale = [&](const Eigen::VectorXd& k) {
      return Eigen::VectorXd::Constant(1, bar_change(1e-6 * k.cwiseProduct(F)));
    };
    auto squareness = [&](const Eigen::VectorXd& s) {
      return Eigen::VectorXd::Constant(
          1, bar_change(1e-6 * Eigen::Vector3d(s(0) * F.y(), s(1) * F.z(), s(2) * F.x())));
    };
    const Eigen::MatrixXd Jk =
        J_reading_effect(d, r, 0.0, candidate(EffectKind::kScale, -1)).transpose();
    const Eigen::MatrixXd Js =
        J_reading_effect(d, r, 0.0, candidate(EffectKind::kSquareness, -1)).transpose();
    EXPECT_TRUE(test::jacobian_matches(scale, Eigen::VectorXd::Zero(3), Jk, 1.0, 1e-8, 1e-7))
        << d.name << " " << in.id << " at " << r.angle_deg << " deg";
    EXPECT_TRUE(test::jacobian_matches(squareness, Eigen::VectorXd::Zero(3), Js, 1.0, 1e-8, 1e-7))
        << d.name << " " << in.id << " at " << r.angle_deg << " deg";
    ++checked;
  });
  EXPECT_GT(checked, 100);
}

TEST(EffectRow, TimeEffectsByHand) {
  // drift: (t - t0) / 60 [min]; reversal: +1/2 on cw, -1/2 on ccw; step at 100 s: 0 before,
  // 1 from it on; a reading without a sweep has no reversal (0).
  const Design d = test::paper_design('C');
  Reading r;
  r.installation = d.installations[1].id;
  r.angle_deg = 30;
  r.time_s = 250;
  r.sweep = Sweep::kCW;
  EXPECT_DOUBLE_EQ(J_reading_effect(d, r, 100.0, candidate(EffectKind::kDrift, 1))(0), 2.5);
  EXPECT_DOUBLE_EQ(J_reading_effect(d, r, 100.0, candidate(EffectKind::kReversal, 1))(0), 0.5);
  r.sweep = Sweep::kCCW;
  EXPECT_DOUBLE_EQ(J_reading_effect(d, r, 100.0, candidate(EffectKind::kReversal, 1))(0), -0.5);
  EffectCandidate step = candidate(EffectKind::kStep, 1);
  step.at_s = 250;
  EXPECT_DOUBLE_EQ(J_reading_effect(d, r, 100.0, step)(0), 1.0);
  step.at_s = 251;
  EXPECT_DOUBLE_EQ(J_reading_effect(d, r, 100.0, step)(0), 0.0);
  // Another installation's effect does not touch the reading.
  EXPECT_DOUBLE_EQ(J_reading_effect(d, r, 100.0, candidate(EffectKind::kDrift, 2))(0), 0.0);
}

}  // namespace
}  // namespace dbbkit
