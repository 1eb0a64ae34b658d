// The effect library's rows (effects.hpp, J_reading_effect) against the geometry they
// stand for: the set-up effects as derivatives of the exact two-ball reading with a real
// set-up (kinematics.hpp, exact_setup_reading_um), scale and squareness as derivatives
// of the exact bar length with the following ball moved by the linear axes' errors,
// and the time effects by hand.

#include "dbbkit/effects.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <string>

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

// The table of effects (effect_info): every kind once, in the enum's order, its name read back
// to it, its parameters as many as the columns of its row, and what it needs as its block says.
TEST(EffectTable, EveryKindOnceItsParametersItsRowsColumnsAndItsNeeds) {
  Design d = test::paper_design('C');
  for (Installation& in : d.installations) in.bar_mm = kBar;
  std::vector<Reading> readings = nominal_readings(d);
  for (std::size_t j = 0; j < readings.size(); ++j) readings[j].time_s = 10.0 * j;
  const std::vector<EffectKind> kinds = {
      EffectKind::kLengthOffset, EffectKind::kCentring, EffectKind::kDrift,
      EffectKind::kReversal,     EffectKind::kScale,    EffectKind::kSquareness,
      EffectKind::kPeriodic,     EffectKind::kStep,     EffectKind::kThermal};
  std::set<std::string> names;
  for (const EffectKind k : kinds) {
    const EffectInfo& info = effect_info(k);
    EXPECT_EQ(info.kind, k) << info.name;
    EXPECT_TRUE(names.insert(info.name).second) << info.name;
    EXPECT_EQ(effect_kind(info.name, "t", "k"), k);
    EXPECT_EQ(std::string(effect_name(k)), info.name);
    EXPECT_EQ(std::string(effect_unit(k)), info.unit);
    EXPECT_FALSE(std::string(info.noun).empty());
    EffectCandidate e = candidate(k, info.shared || info.whole_test_only ? -1 : 0);
    e.at_s = 100;
    e.tau_min = 10;
    e.harmonic = 2;
    const std::vector<std::string> parameters = effect_parameter_names(k);
    EXPECT_EQ(J_reading_effect(d, readings[0], 0.0, e).size(),
              static_cast<Eigen::Index>(parameters.size()))
        << info.name;
    EXPECT_EQ(effect_info(k).whole_test_form, effect_has_whole_test_form(k));
    EXPECT_TRUE(!info.whole_test_only || info.whole_test_form) << info.name;
    // What it needs, as its block on readings without it says.
    std::vector<Reading> without = readings;
    for (Reading& r : without) r.time_s.reset();
    EXPECT_EQ(effect_block(d, without, e).applicability.why == NotApplicable::kNeedsTimes,
              info.needs_times)
        << info.name;
    Design no_bar = d;
    for (Installation& in : no_bar.installations) in.bar_mm.reset();
    EXPECT_EQ(effect_block(no_bar, readings, e).applicability.why == NotApplicable::kNeedsBar,
              info.needs_bar)
        << info.name;
    EXPECT_EQ(effect_block(d, readings, e).applicability.why == NotApplicable::kNeedsBothSweeps,
              info.needs_both_sweeps)
        << info.name;
  }
}

}  // namespace
}  // namespace dbbkit
