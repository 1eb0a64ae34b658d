// The design (design.hpp): the named reading directions against the ball's own geometry,
// validation naming the key at fault, and per-installation set-up tolerances.

#include "dbbkit/design.hpp"

#include <gtest/gtest.h>

#include "dbbkit/error.hpp"
#include "dbbkit/kinematics.hpp"
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
