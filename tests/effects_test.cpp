// The effect library's rows (effects.hpp, J_reading_effect) against the geometry they
// stand for: the set-up effects as derivatives of the exact two-ball reading with a real
// set-up (kinematics.hpp, exact_setup_reading_um), scale and squareness as derivatives
// of the exact bar length with the following ball moved by the linear axes' errors,
// and the time effects by hand.

#include "dbbkit/effects.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <set>
#include <string>

#include "dbbkit/instrument.hpp"
#include "dbbkit/io/truth_io.hpp"
#include "dbbkit/kinematics.hpp"
#include "dbbkit/simulate.hpp"
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

// What else the table holds of each kind, read back where it is used: its row (the same as
// J_reading_effect's), its label read back to the same effect (effect_from_label), its value
// read from a truth file in the form the table states (truth_from_json), its next step's
// placeholders those diagnose fills, and every set-up effect's declared tolerance read from the
// member the table names.
TEST(EffectTable, EachKindsRowLabelTruthFormAndNextStepAreItsEntrys) {
  Design ballbar = test::paper_design('C');
  for (Installation& in : ballbar.installations) in.bar_mm = kBar;
  Design probe;
  probe.name = "probe";
  probe.axis = test::kAxisC;
  probe.angles_deg = {0, 90, 180, 270};
  probe.noise.std_um = 0.5;
  probe.instrument = InstrumentKind::kProbe;
  probe.spheres = {{"s1", 150, 0, 80, ""}, {"s2", 100, 120, 230, ""}};
  probe.installations = probe_channels(probe.axis, probe.spheres);
  validate_design(probe);
  for (const EffectKind k : effect_kinds()) {
    const EffectInfo& info = effect_info(k);
    SCOPED_TRACE(info.name);
    ASSERT_NE(info.row, nullptr);
    const Design& d = effect_fits_instrument(k, InstrumentKind::kBallbar) ? ballbar : probe;
    EffectCandidate e = candidate(k, info.shared || info.whole_test_only ? -1 : 0);
    e.at_s = 100;
    e.tau_min = 10;
    e.harmonic = 2;
    // The row the table's function writes is J_reading_effect's.
    std::vector<Reading> readings = nominal_readings(d);
    for (std::size_t j = 0; j < readings.size(); ++j) {
      readings[j].time_s = 10.0 * j;
      readings[j].sweep = j % 2 ? Sweep::kCW : Sweep::kCCW;
    }
    // The last reading the effect applies to (after the step's time).
    std::size_t j = readings.size() - 1;
    while (!effect_applies_to(d, e, d.find_installation(readings[j].installation))) --j;
    const Reading& r = readings[j];
    const int inst = d.find_installation(r.installation);
    double row[3] = {0, 0, 0};
    info.row({d, r, d.installations[inst], 1.0, e}, row);
    const Eigen::VectorXd J = J_reading_effect(d, r, 1.0, e);
    for (Eigen::Index c = 0; c < J.size(); ++c) EXPECT_EQ(row[c], J(c));
    EXPECT_GT(std::abs(row[0]) + std::abs(row[1]) + std::abs(row[2]), 0.0);
    // The label names the same effect again (a harmonic has no label form).
    if (info.position != EffectPosition::kHarmonic) {
      const EffectCandidate back = effect_from_label(d, e.label(d), "t", "k");
      EXPECT_EQ(back.kind, k);
      EXPECT_EQ(back.installation, e.installation);
      if (info.position == EffectPosition::kTime) EXPECT_EQ(back.at_s, e.at_s);
      if (info.position == EffectPosition::kTimeConstant) EXPECT_EQ(back.tau_min, e.tau_min);
    }
    // A truth file states the value in the table's form.
    const std::vector<std::string> names = effect_parameter_names(k);
    nlohmann::json value;
    switch (info.truth_value) {
      case TruthValue::kNumber:
        value = 1.0;
        break;
      case TruthValue::kList:
        value = nlohmann::json::array();
        for (std::size_t c = 0; c < names.size(); ++c) value.push_back(1.0 + c);
        break;
      case TruthValue::kNamed:
        for (std::size_t c = 0; c < names.size(); ++c) value[names[c]] = 1.0 + c;
        break;
      case TruthValue::kObject:
        value[info.truth_value_key] = 1.0;
        if (info.position == EffectPosition::kTime) value["at_s"] = 100;
        if (info.position == EffectPosition::kTimeConstant) value["tau_min"] = 10;
        if (info.position == EffectPosition::kHarmonic) value["harmonic"] = 2;
        break;
    }
    const nlohmann::json truth = {{"format", io::kTruthFormat},
                                  {"location", {{"X0C", 1.0}}},
                                  {"effects", {{{"name", info.name}, {"value", value}}}}};
    const Truth t = io::truth_from_json(truth, "truth");
    ASSERT_EQ(t.effects.size(), 1u);
    EXPECT_EQ(t.effects[0].effect.kind, k);
    ASSERT_EQ(t.effects[0].value.size(), static_cast<Eigen::Index>(names.size()));
    for (std::size_t c = 0; c < names.size(); ++c)
      EXPECT_EQ(t.effects[0].value(static_cast<Eigen::Index>(c)),
                names.size() == 1 ? 1.0 : 1.0 + c);
    if (info.position == EffectPosition::kTime) EXPECT_EQ(t.effects[0].effect.at_s, 100);
    if (info.position == EffectPosition::kTimeConstant) EXPECT_EQ(t.effects[0].effect.tau_min, 10);
    if (info.position == EffectPosition::kHarmonic) EXPECT_EQ(t.effects[0].effect.harmonic, 2);
    // The next step: every placeholder one diagnose fills.
    for (const char* text : {info.next_step, info.next_step_whole_test, info.next_step_on_head}) {
      if (!text) continue;
      std::string rest = text;
      EXPECT_FALSE(rest.empty());
      for (const char* key : {"{where}", "{settle_min}", "{harmonic}"})
        for (std::size_t at; (at = rest.find(key)) != std::string::npos;)
          rest.erase(at, std::string(key).size());
      EXPECT_EQ(rest.find_first_of("{}"), std::string::npos) << text;
    }
    // A set-up effect's declared tolerance is where the table says.
    EXPECT_EQ(info.setup, info.setup_std != nullptr);
    if (info.setup) {
      SetupUncertainty u;
      u.*info.setup_std = 7.0;
      EXPECT_EQ(setup_std_um(u, k), 7.0);
    }
  }
}

}  // namespace
}  // namespace dbbkit
