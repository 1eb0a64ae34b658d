// The kit (kit.hpp): block stacks, the travel extent over the arc, the bar chosen for a
// position.

#include "dbbkit/kit.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <tuple>

#include "dbbkit/error.hpp"
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
    const AxisFrame& axis = t % 2 ? test::kAxisC : test::kAxisB;
    Installation in;
    in.L_mm = 150 + 100 * u(rng);
    in.D_mm = 40 * u(rng);
    in.H_mm = axis == test::kAxisC ? 100 + 50 * u(rng) : 0;
    in.direction = Direction::named(axis, static_cast<Direction::Kind>(t % 3));
    in.sign = u(rng) > 0 ? 1 : -1;
    in.bar_mm = 150;
    const double lo = axis == test::kAxisC ? 360 * u(rng) : -100 + 30 * u(rng);
    // Every fifth C arc a whole turn or more (its extremes are reached wherever they fall).
    const double hi =
        lo + (axis == test::kAxisC ? (t % 5 == 1 ? 400 + 40 * u(rng) : 180 + 180 * u(rng))
                                   : 90 + 20 * u(rng));
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

TEST(Kit, FitBarsIsFitBarForEachInstallation) {
  // The arc formed once for the design: each installation gets fit_bar's bar, sign and
  // excursion, and the largest excursion is returned; bars listed unsorted are sorted.
  Kit kit = formats_kit();
  kit.bars_mm = {300, 100, 250, 150};
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int t = 0; t < 100; ++t) {
    Design d;
    d.axis = t % 2 ? test::kAxisC : test::kAxisB;
    d.angles_deg = t % 3 ? kit_angles(kit, 15) : std::vector<double>{-40 + 10 * u(rng), 30};
    for (int i = 0; i < 5; ++i) {
      Installation in;
      in.L_mm = 150 + 150 * u(rng);
      in.D_mm = 60 * u(rng);
      in.H_mm = d.axis == test::kAxisC ? 100 + 80 * u(rng) : 0;
      in.direction = Direction::named(d.axis, static_cast<Direction::Kind>(i % 3));
      d.installations.push_back(in);
    }
    Design e = d;
    double worst = -std::numeric_limits<double>::infinity();
    for (Installation& in : e.installations)
      worst = std::max(worst, fit_bar(kit, e.axis, in, e.angles_deg));
    EXPECT_EQ(fit_bars(kit, d), worst);
    for (size_t i = 0; i < d.installations.size(); ++i) {
      EXPECT_EQ(d.installations[i].bar_mm, e.installations[i].bar_mm);
      EXPECT_EQ(d.installations[i].sign, e.installations[i].sign);
    }
  }
}

TEST(Kit, FitBarTakesTheShortestBarThatFits) {
  // y travel +-300 mm: a tangential bar reaches sqrt(L^2 + bar^2) from the axis.
  Kit kit = formats_kit();
  Installation in;
  in.L_mm = 250;
  in.H_mm = 45;
  in.direction = Direction::named(test::kAxisC, Direction::Kind::kTangential);
  const std::vector<double> turn = kit_angles(kit, 20);
  EXPECT_LE(fit_bar(kit, test::kAxisC, in, turn), 0);
  EXPECT_EQ(*in.bar_mm,
            100);  // sqrt(250^2 + 100^2) = 269 <= 300; 150 gives 292 too, but 100 is shorter
  kit.bars_mm = {250, 300};
  EXPECT_GT(fit_bar(kit, test::kAxisC, in, turn),
            0);  // sqrt(250^2 + 250^2) = 354 > 300: nothing fits
  EXPECT_NEAR(fit_bar(kit, test::kAxisC, in, turn), std::hypot(250.0, 250.0) - 300, 1e-9);
}

// A small C kit whose travel binds: x, y within +-220 mm, so a tangential bar of
// 100 mm allows L <= sqrt(220^2 - 100^2) = 196 mm of the 250 the table offers
// (a 150 mm block sets the heights apart, so that the radii limit the worst case).

// Bars as sold: a 100 mm base with 50, 150 and 300 mm extensions gives every sum of the
// base and a subset, each once, and each bar's parts are the fewest that make it.
TEST(Kit, BarSetAssembliesAndTheirParts) {
  BarSet set{100, {50, 150, 300}};
  // 100, +50, +150, +300, +50+150, +50+300, +150+300, +50+150+300
  EXPECT_EQ(assembled_bars(set), (std::vector<double>{100, 150, 250, 300, 400, 450, 550, 600}));
  Kit kit = formats_kit();
  kit.bar_set = set;
  kit.bars_mm = assembled_bars(set);
  EXPECT_EQ(bar_parts(kit, 450), (std::vector<double>{100, 50, 300}));
  EXPECT_EQ(bar_parts(kit, 100), (std::vector<double>{100}));
  EXPECT_TRUE(bar_parts(kit, 120).empty());
  // Two ways to make 300 (base + 50 + 150 or base + 200): the fewest parts.
  kit.bar_set = BarSet{100, {50, 150, 200}};
  EXPECT_EQ(bar_parts(kit, 300), (std::vector<double>{100, 200}));
  // A kit of bars as assembled: each bar is one part.
  Kit assembled = formats_kit();
  assembled.bar_set.reset();
  EXPECT_EQ(bar_parts(assembled, 250), (std::vector<double>{250}));
}

TEST(Kit, BarsAsSoldAreReadAndCheckedByKey) {
  const std::string head = R"({"format": "dbbkit.kit/1", "axis": "C", "reference_length_mm": 100,
    "pattern": "three_position", "L_mm": {"min": 20, "max": 250},
    "H_mm": {"base": 45, "blocks": [150], "max_stack": 1},
    "travel_mm": {"x": [-220, 220], "y": [-220, 220], "z": [-50, 400]},
    "angles_deg": {"range": [0, 360], "steps": [30]},
    "time_s": {"per_reading": 3, "per_installation": 60, "per_position": 180}, )";
  const Kit k = io::kit_from_text(
      head + R"("bars": {"base_mm": 100, "extensions_mm": [50, 150]}, "resolution_mm": 0.5})", "k");
  EXPECT_EQ(k.bars_mm, (std::vector<double>{100, 150, 250, 300}));
  ASSERT_TRUE(k.resolution_mm);
  EXPECT_EQ(*k.resolution_mm, 0.5);
  EXPECT_EQ(k.time_per_position_s, 180);
  auto where = [&](const std::string& tail) {
    try {
      io::kit_from_text(head + tail, "k");
    } catch (const InputError& e) {
      return e.where();
    }
    return std::string("no error");
  };
  EXPECT_EQ(where(R"("bars": {"base_mm": 100}, "bars_mm": [100]})"), "bars");
  EXPECT_EQ(where(R"("bars": {"base_mm": -1}})"), "bars.base_mm");
  EXPECT_EQ(where(R"("bars": {"base_mm": 100, "extensions_mm": [50, 0]}})"),
            "bars.extensions_mm[1]");
  EXPECT_EQ(where(R"("bars": {"base_mm": 100, "extensions_mm": [1,2,3,4,5,6,7,8,9]}})"),
            "bars.extensions_mm");
  EXPECT_EQ(where(R"("bars": {"base_mm": 100, "lengths": [50]}})"), "bars.lengths");
  // As many bars as eight extensions assemble, no more: the search tries each for each
  // installation.
  std::string bars = "[";
  for (int i = 0; i < kMaxBars + 1; ++i) bars += (i ? "," : "") + std::to_string(100 + i);
  EXPECT_EQ(where(R"("bars_mm": )" + bars + "]}"), "bars_mm");
  EXPECT_EQ(where(R"("bars_mm": [100], "resolution_mm": 0})"), "resolution_mm");
}

// angles_deg.max_step: read, and refused when not positive or finer than every step.
TEST(Kit, AnglesMaxStepIsReadAndChecked) {
  auto kit = [](const std::string& angles) {
    return io::kit_from_text(
        R"({"format": "dbbkit.kit/1", "axis": "C", "reference_length_mm": 100,
    "pattern": "three_position", "L_mm": {"min": 20, "max": 250},
    "H_mm": {"base": 45, "blocks": [150], "max_stack": 1}, "bars_mm": [100],
    "travel_mm": {"x": [-220, 220], "y": [-220, 220], "z": [-50, 400]},
    "time_s": {"per_reading": 3, "per_installation": 60}, "angles_deg": )" +
            angles + "}",
        "k");
  };
  const Kit k = kit(R"({"range": [0, 360], "steps": [10, 30], "max_step": 20})");
  ASSERT_TRUE(k.angle_max_step_deg);
  EXPECT_EQ(*k.angle_max_step_deg, 20);
  EXPECT_FALSE(kit(R"({"range": [0, 360], "steps": [10, 30]})").angle_max_step_deg);
  auto where = [&](const std::string& angles) {
    try {
      kit(angles);
    } catch (const InputError& e) {
      return e.where() + ": " + e.what();
    }
    return std::string("no error");
  };
  EXPECT_EQ(where(R"({"range": [0, 360], "steps": [10, 30], "max_step": 5})")
                .rfind("angles_deg.max_step: ", 0),
            0u);
  EXPECT_EQ(where(R"({"range": [0, 360], "steps": [10], "max_step": -1})")
                .rfind("angles_deg.max_step: ", 0),
            0u);
}

// Installations at one ball position share its set-up time.
TEST(Kit, DesignTimeCountsEachBallPositionOnce) {
  Kit kit = formats_kit();
  kit.time_per_position_s = 180;
  kit.time_per_installation_s = 60;
  kit.time_per_reading_s = 3;
  Design d;
  d.angles_deg = {0, 90, 180, 270, 360};
  for (auto [L, H, kind] : {std::tuple{100.0, 45.0, Direction::Kind::kRadial},
                            std::tuple{100.0, 45.0, Direction::Kind::kTangential},
                            std::tuple{0.0, 45.0, Direction::Kind::kAxial},
                            std::tuple{100.0, 145.0, Direction::Kind::kRadial}}) {
    Installation in;
    in.L_mm = L;
    in.H_mm = H;
    in.direction = Direction::named(test::kAxisC, kind);
    d.installations.push_back(in);
  }
  EXPECT_EQ(ball_positions(d), 3);
  EXPECT_DOUBLE_EQ(design_time_s(kit, d), 3 * 180 + 4 * 60 + 4 * 5 * 3);
}

}  // namespace
}  // namespace dbbkit
