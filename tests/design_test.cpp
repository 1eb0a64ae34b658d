// The design (design.hpp): the named reading directions against the ball's own geometry,
// validation naming the key at fault, and per-installation set-up tolerances.

#include "dbbkit/design.hpp"

#include <gtest/gtest.h>

#include <functional>
#include <nlohmann/json.hpp>

#include "dbbkit/error.hpp"
#include "dbbkit/identify.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/kinematics.hpp"
#include "dbbkit/simulate.hpp"
#include "test_util.hpp"

namespace dbbkit {
namespace {

Installation ball(const AxisFrame& axis, Direction::Kind kind) {
  Installation in;
  in.id = "1";
  in.L_mm = 120;
  in.H_mm = axis == test::kAxisC ? 60 : 0;
  in.direction = Direction::named(axis, kind);
  return in;
}

// Radial: from the axis to the ball, perpendicular to the axis; tangential: the ball's path
// (d P / d angle, central differences); axial: the axis. Both axes, at several angles.
TEST(Direction, NamedDirectionsAreTheBallsRadialTangentialAndAxialDirections) {
  for (Axis axis : {test::kAxisC, test::kAxisB}) {
    const Eigen::Vector3d along =
        axis == test::kAxisC ? Eigen::Vector3d::UnitZ() : Eigen::Vector3d::UnitY();
    for (double a : {-100.0, -30.0, 0.0, 45.0, 170.0}) {
      const Eigen::Vector3d P = ball_position_mm(axis, ball(axis, Direction::Kind::kRadial), a);
      const Eigen::Vector3d radial = (P - P.dot(along) * along).normalized();
      const double h = 1e-4;
      const Installation t = ball(axis, Direction::Kind::kTangential);
      const Eigen::Vector3d path =
          (ball_position_mm(axis, t, a + h) - ball_position_mm(axis, t, a - h)).normalized();
      EXPECT_TRUE(test::near(direction_machine(axis, ball(axis, Direction::Kind::kRadial), a),
                             radial, 1e-12));
      EXPECT_TRUE(test::near(direction_machine(axis, t, a), path, 1e-9));
      EXPECT_TRUE(test::near(direction_machine(axis, ball(axis, Direction::Kind::kAxial), a), along,
                             1e-12));
    }
  }
}

TEST(DesignValidation, NamesTheKeyAtFault) {
  auto where = [](const Design& d) {
    try {
      validate_design(d);
    } catch (const InputError& e) {
      return e.where();
    }
    return std::string("(accepted)");
  };
  const Design paper = test::paper_design('C');
  EXPECT_EQ(where(paper), "(accepted)");
  Design d = paper;
  d.installations[2].direction = Direction::vector({1, 0, 0});
  d.installations[2].direction.body = {1.001, 0, 0};  // |v| - 1 = 1e-3 > 1e-6
  EXPECT_EQ(where(d), "installations[2].direction");
  d = paper;
  d.angles_deg[3] = d.angles_deg[1];
  EXPECT_EQ(where(d), "angles_deg[3]");
  d = paper;
  d.installations[1].sign = 0;
  EXPECT_EQ(where(d), "installations[1].sign");
  // The hardware as assembled must add up: bar parts to bar_mm, the cup and blocks to H.
  d = paper;  // bar 150 mm, H 60 mm at installation 0
  d.installations[0].bar_parts_mm = {100, 50};
  d.installations[0].cup_mm = 45;
  d.installations[0].blocks_mm = {15};
  EXPECT_EQ(where(d), "(accepted)");
  d.installations[0].bar_parts_mm = {100, 40};
  EXPECT_EQ(where(d), "installations[0].bar_parts_mm");
  d.installations[0].bar_parts_mm = {100, 50};
  d.installations[0].blocks_mm = {25};
  EXPECT_EQ(where(d), "installations[0].stack_mm");
  d.installations[0].blocks_mm = {-5, 20};
  EXPECT_EQ(where(d), "installations[0].stack_mm.blocks[0]");
  d = paper;
  d.installations[3].blocks_mm = {25};
  EXPECT_EQ(where(d), "installations[3].stack_mm");
  d = paper;
  d.installations[4].bar_mm.reset();
  d.installations[4].bar_parts_mm = {100};
  EXPECT_EQ(where(d), "installations[4].bar_parts_mm");
}

// A design of the paper's with `edit` applied to its JSON: the message of the reader, or
// "(accepted)".
std::string message_of(const std::function<void(nlohmann::json&)>& edit) {
  nlohmann::json j = io::design_to_json(test::paper_design('C'));
  edit(j);
  try {
    io::design_from_json(j, "d.json");
  } catch (const InputError& e) {
    return e.what();
  }
  return "(accepted)";
}

// A reading noise whose three standard deviations reach the instrument's range (a noise given in
// mm where um is meant) is refused at the noise; one well inside it is not.
TEST(DesignValidation, ANoiseAsWideAsTheInstrumentsRangeIsRefused) {
  std::string m = message_of([](nlohmann::json& j) {
    j["noise"] = {{"distribution", "normal"}, {"std_um", 400}};
  });
  EXPECT_NE(m.find("d.json: noise: a reading noise of 400 um"), std::string::npos) << m;
  EXPECT_NE(m.find("range of +-1 mm"), std::string::npos) << m;
  m = message_of([](nlohmann::json& j) {
    j["noise"] = {{"distribution", "normal"}, {"std_um", 400}};
    j["instrument"] = {{"range_mm", 2}};
  });
  EXPECT_EQ(m, "(accepted)");
  EXPECT_EQ(message_of([](nlohmann::json& j) {
              j["noise"] = {{"accuracy_um", 500}};
            }),
            "(accepted)");  // sigma 289 um: three of it are 0.87 mm
}

// A misspelling is suggested only among the keys the object may hold and does not: never a key
// that is present and valid (ball_mm {L, h} used to suggest 'L' for H; {start, stop, stpo}
// 'stop' for step).
TEST(DesignValidation, AMisspellingIsSuggestedOnlyAmongKeysAllowedAndAbsent) {
  std::string m = message_of([](nlohmann::json& j) {
    j["installations"][0]["ball_mm"] = {{"L", 100}, {"h", 60}};
  });
  EXPECT_NE(m.find("ball_mm.H: required key is missing (is 'h' a misspelling of it?)"),
            std::string::npos)
      << m;
  m = message_of([](nlohmann::json& j) {
    j["installations"][0]["ball_mm"] = {{"D", 0}, {"H", 60}};  // no L: D and H are valid
  });
  EXPECT_NE(m.find("ball_mm.L: required key is missing"), std::string::npos) << m;
  EXPECT_EQ(m.find("misspelling"), std::string::npos) << m;
  m = message_of([](nlohmann::json& j) {
    j["angles_deg"] = {{"start", 0}, {"stop", 360}, {"stpo", 20}};
  });
  EXPECT_NE(m.find("angles_deg.step: required key is missing"), std::string::npos) << m;
  EXPECT_EQ(m.find("'stop'"), std::string::npos) << m;
  m = message_of([](nlohmann::json& j) {
    j["angles_deg"] = {{"start", 0}, {"stpo", 360}, {"step", 20}};
  });
  EXPECT_NE(m.find("angles_deg.stop: required key is missing (is 'stpo' a misspelling of it?)"),
            std::string::npos)
      << m;
  // An unknown key names the absent key it may stand for.
  m = message_of([](nlohmann::json& j) {
    j["installations"][0].erase("sign");
    j["installations"][0]["sgin"] = 1;
  });
  EXPECT_NE(m.find("installations[0].sgin: unknown key (a misspelling of 'sign'?)"),
            std::string::npos)
      << m;
  // A key present and valid is never the one an unknown key stands for.
  m = message_of([](nlohmann::json& j) { j["installations"][0]["drection"] = "radial"; });
  EXPECT_NE(m.find("installations[0].drection: unknown key (misspelt?)"), std::string::npos) << m;
}

// The key of the other distribution is said to be that, not a typo.
TEST(DesignValidation, NoiseKeysOfTheOtherDistributionAreNamedAsSuch) {
  std::string m = message_of([](nlohmann::json& j) {
    j["noise"] = {{"distribution", "uniform"}, {"std_um", 1}};
  });
  EXPECT_NE(m.find("noise.std_um: std_um belongs to the normal distribution"), std::string::npos)
      << m;
  EXPECT_NE(m.find("give accuracy_um"), std::string::npos) << m;
  m = message_of([](nlohmann::json& j) { j["noise"] = {{"std_um", 1}}; });
  EXPECT_NE(m.find("the default without \"distribution\""), std::string::npos) << m;
  m = message_of([](nlohmann::json& j) {
    j["noise"] = {{"distribution", "normal"}, {"accuracy_um", 1}};
  });
  EXPECT_NE(m.find("noise.accuracy_um: accuracy_um belongs to the uniform distribution"),
            std::string::npos)
      << m;
}

TEST(SetupOverride, ReplacesOnlyTheKeysGiven) {
  SetupUncertainty base;
  base.length_offset_um = 10;
  base.centring_um = 5;
  base.L_mm = 0.1;
  SetupOverride o;
  o.centring_um = 2;
  o.H_mm = 0.05;
  const SetupUncertainty u = o.over(base);
  EXPECT_EQ(u.length_offset_um, 10);
  EXPECT_EQ(u.centring_um, 2);
  EXPECT_EQ(u.L_mm, 0.1);
  EXPECT_EQ(u.D_mm, 0);
  EXPECT_EQ(u.H_mm, 0.05);
  EXPECT_TRUE(u.placement() && u.nuisance());
  EXPECT_FALSE(SetupOverride{}.any());
}

}  // namespace
}  // namespace dbbkit

namespace dbbkit {
namespace {

// A head's table ball lies beyond the tool tip: a radial bar with sign +1 (the table ball
// between the pivot and the spindle ball) is refused naming the installation's sign; across
// the tool either sign stands; every committed head design keeps the rule.
TEST(HeadGeometry, TheTableBallLiesBeyondTheToolTip) {
  Design d = test::paper_design('B');
  for (const Installation& in : d.installations) {
    const Eigen::Vector3d P = ball_position_mm(d.axis, in, 0);
    const Eigen::Vector3d F = P - in.sign * *in.bar_mm * direction_machine(d.axis, in, 0);
    EXPECT_GE((F - P).dot(d.axis.reference()), -1e-9) << in.id;
    EXPECT_GE(F.norm(), P.norm()) << in.id;
  }
  d.installations[0].sign = 1;  // 1r radial: the table ball 150 mm toward the pivot
  try {
    validate_design(d, "d.json");
    ADD_FAILURE() << "accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("installations[0].sign"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("beyond the tool tip"), std::string::npos) << e.what();
  }
  for (int sign : {1, -1}) {
    EXPECT_TRUE(table_ball_beyond_tool(
        d.axis, Direction::named(d.axis, Direction::Kind::kTangential), sign));
    EXPECT_TRUE(
        table_ball_beyond_tool(d.axis, Direction::named(d.axis, Direction::Kind::kAxial), sign));
  }
  // A table takes either sign.
  EXPECT_TRUE(table_ball_beyond_tool(test::kAxisC,
                                     Direction::named(test::kAxisC, Direction::Kind::kRadial), 1));
  for (const char* f : {"designs/b-head-kit-optimized.json",
                        "designs/b-head-kit-on-axis-optimized.json", "designs/paper-b-head.json"})
    EXPECT_NO_THROW(io::read_design_file(test::source_path(f))) << f;
}

// reading_sign is how the instrument counted, not geometry: readings recorded with the
// opposite count, declared so, identify to the same errors as the bar's length changes.
TEST(ReadingSign, DataCountedTheOtherWayIdentifyTheSame) {
  Design d = test::paper_design('C');
  Truth t;
  t.model = {ErrorModel::Kind::kFourier, 2};
  for (int k = 0; k < 6; ++k) t.coefficients[k] = {1.0 + k, 2.0, -1.0, 0.5, 0.25};
  t.seed = 3;
  const std::vector<Reading> plain = simulate(d, t, 3);
  Design counted = d;
  counted.installations[1].reading_sign = -1;
  counted.installations[3].reading_sign = -1;
  const std::vector<Reading> flipped = simulate(counted, t, 3);
  ASSERT_EQ(plain.size(), flipped.size());
  int negated = 0;
  for (size_t i = 0; i < plain.size(); ++i) {
    const bool other = plain[i].installation == d.installations[1].id ||
                       plain[i].installation == d.installations[3].id;
    EXPECT_EQ(flipped[i].reading_um, other ? -plain[i].reading_um : plain[i].reading_um);
    negated += other;
  }
  EXPECT_GT(negated, 0);
  const IdentifyResult a = identify(d, plain), b = identify(counted, flipped);
  for (size_t s = 0; s < a.errors.size(); ++s) {
    for (int k = 0; k < 6; ++k) {
      EXPECT_NEAR(a.errors[s].errors[k].value, b.errors[s].errors[k].value, 1e-9);
      EXPECT_NEAR(a.errors[s].errors[k].std, b.errors[s].errors[k].std, 1e-12);
    }
  }
  // The file keeps it.
  const Design again = io::design_from_json(io::design_to_json(counted), "again");
  EXPECT_EQ(again.installations[1].reading_sign, -1);
  EXPECT_EQ(again.installations[0].reading_sign, 1);
}

}  // namespace
}  // namespace dbbkit
