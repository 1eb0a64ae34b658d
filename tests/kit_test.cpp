// The kit (kit.hpp): block stacks, the travel extent over the arc, the bar chosen for a
// position.

#include "dbbkit/kit.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "dbbkit/io/kit_io.hpp"
#include "dbbkit/kinematics.hpp"
#include "test_util.hpp"

namespace dbbkit {
namespace {

Kit formats_kit() {
  return io::read_kit_file(test::source_path("designs/kits/c-turntable-kit.json"));
}

TEST(Kit, BlockStacksAreTheDistinctHeights) {
  const std::vector<Stack> s =
      block_stacks(formats_kit());  // base 45, blocks 25, 50, 100, at most 2
  std::vector<double> h;
  for (const Stack& x : s) h.push_back(x.height_mm);
  EXPECT_EQ(h, (std::vector<double>{45, 70, 95, 120, 145, 170, 195}));
  EXPECT_EQ(s[4].blocks_mm,
            (std::vector<double>{100}));  // 145 = 45 + 100, one block rather than none
  EXPECT_EQ(s[3].blocks_mm, (std::vector<double>{25, 50}));
}

TEST(Kit, TravelExtentIsExactOverTheArc) {
  Kit kit = formats_kit();
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int t = 0; t < 300; ++t) {
    const Axis axis = t % 2 ? Axis::kC : Axis::kB;
    Installation in;
    in.L_mm = 150 + 100 * u(rng);
    in.D_mm = 40 * u(rng);
    in.H_mm = axis == Axis::kC ? 100 + 50 * u(rng) : 0;
    in.direction = Direction::named(axis, static_cast<Direction::Kind>(t % 3));
    in.sign = u(rng) > 0 ? 1 : -1;
    in.bar_mm = 150;
    const double lo = axis == Axis::kC ? 360 * u(rng) : -100 + 30 * u(rng);
    const double hi = lo + (axis == Axis::kC ? 180 + 180 * u(rng) : 90 + 20 * u(rng));
    const double v = travel_violation_mm(kit, axis, in, {lo, hi});
    // Dense sampling can only find less (or equal) excursion, and nearly as much.
    double sampled = -1e300;
    for (int i = 0; i <= 20000; ++i) {
      const double a = lo + (hi - lo) * i / 20000.0;
      const Eigen::Vector3d F =
          ball_position_mm(axis, in, a) - in.sign * 150.0 * direction_machine(axis, in, a);
      for (int k = 0; k < 3; ++k) {
        sampled = std::max({sampled, kit.travel_mm[k].min - F(k), F(k) - kit.travel_mm[k].max});
      }
    }
    EXPECT_LE(sampled, v + 1e-9);
    EXPECT_GE(sampled, v - 1e-3);
  }
}

TEST(Kit, FitBarTakesTheShortestBarThatFits) {
  // y travel +-300 mm: a tangential bar reaches sqrt(L^2 + bar^2) from the axis.
  Kit kit = formats_kit();
  Installation in;
  in.L_mm = 250;
  in.H_mm = 45;
  in.direction = Direction::named(Axis::kC, Direction::Kind::kTangential);
  const std::vector<double> turn = kit_angles(kit, 20);
  EXPECT_LE(fit_bar(kit, Axis::kC, in, turn), 0);
  EXPECT_EQ(*in.bar_mm,
            100);  // sqrt(250^2 + 100^2) = 269 <= 300; 150 gives 292 too, but 100 is shorter
  kit.bars_mm = {250, 300};
  EXPECT_GT(fit_bar(kit, Axis::kC, in, turn), 0);  // sqrt(250^2 + 250^2) = 354 > 300: nothing fits
  EXPECT_NEAR(fit_bar(kit, Axis::kC, in, turn), std::hypot(250.0, 250.0) - 300, 1e-9);
}

// A small C kit whose travel binds: x, y within +-220 mm, so a tangential bar of
// 100 mm allows L <= sqrt(220^2 - 100^2) = 196 mm of the 250 the table offers
// (a 150 mm block sets the heights apart, so that the radii limit the worst case).

}  // namespace
}  // namespace dbbkit
