// The kit's workspace (kit.hpp, installation_clashes): each check against a hand derivation or
// an independent dense sampling of the geometry, fit_bar and optimize keeping to it, an
// exhaustive search against the search where the table binds, and the command line refusing a
// set-up that clashes (setup-sheet exit 1, program not written).

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>

#include "cli_util.hpp"
#include "dbbkit/error.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/kit_io.hpp"
#include "dbbkit/kinematics.hpp"
#include "dbbkit/kit.hpp"
#include "dbbkit/optimize.hpp"
#include "dbbkit/setup_sheet.hpp"
#include "test_util.hpp"

namespace dbbkit {
namespace {

Kit c_kit_of_formats() {
  return io::read_kit_file(test::source_path("designs/kits/c-turntable-kit.json"));
}

Installation c_installation(double L, double D, double H, Direction::Kind kind, int sign,
                            double bar) {
  Installation in;
  in.id = "x";
  in.L_mm = L;
  in.D_mm = D;
  in.H_mm = H;
  in.direction = Direction::named(test::kAxisC, kind);
  in.sign = sign;
  in.bar_mm = bar;
  return in;
}

double clash(const std::vector<Clash>& all, const std::string& what) {
  for (const Clash& c : all)
    if (c.what == what) return c.by_mm;
  return -std::numeric_limits<double>::infinity();
}

constexpr double kNone = -1e9;  // list every check, clear or not

TEST(Workspace, TheCupOnTheTableByHand) {
  Kit kit = c_kit_of_formats();
  Workspace w;
  w.table_diameter_mm = 500;
  w.footprint_mm = 60;
  kit.workspace = w;
  const std::vector<double> turn = kit_angles(kit, 30);
  // hypot(240, 70) + 30 - 250 = 30
  Installation in = c_installation(240, 70, 45, Direction::Kind::kRadial, 1, 100);
  EXPECT_NEAR(clash(installation_clashes(kit, test::kAxisC, in, turn, kNone),
                    "the cup and blocks overhang the table"),
              30, 1e-9);
  in.L_mm = 200, in.D_mm = 0;  // 200 + 30 - 250 = -20: clear, and not listed at tolerance 0
  EXPECT_NEAR(clash(installation_clashes(kit, test::kAxisC, in, turn, kNone),
                    "the cup and blocks overhang the table"),
              -20, 1e-9);
  EXPECT_TRUE(installation_clashes(kit, test::kAxisC, in, turn).empty());
  // A rectangle: x in [-300, 300], y in [-200, 200]; (280, -190) overhangs by 10 in x, 20 in y.
  w.table_diameter_mm.reset();
  w.table_x_mm = Interval{-300, 300};
  w.table_y_mm = Interval{-200, 200};
  kit.workspace = w;
  in.L_mm = 280, in.D_mm = -190;
  EXPECT_NEAR(clash(installation_clashes(kit, test::kAxisC, in, turn, kNone),
                    "the cup and blocks overhang the table"),
              20, 1e-9);
}

TEST(Workspace, TheSpindleBallStaysAboveACupOnAnyCTable) {
  // No workspace stated: the C table's surface is still known (H = 0), and the spindle ball
  // below a ball in its cup (H_base 45 mm) is a clash. Axial, sign +1, the bar 100 mm down
  // from H 95: the spindle ball at z = -5, 50 mm too low.
  const Kit kit = c_kit_of_formats();
  ASSERT_FALSE(kit.workspace);
  const std::vector<double> turn = kit_angles(kit, 30);
  Installation in = c_installation(0, 0, 95, Direction::Kind::kAxial, 1, 100);
  EXPECT_NEAR(clash(installation_clashes(kit, test::kAxisC, in, turn),
                    "the spindle ball is below a cup's height"),
              50, 1e-9);
  // fit_bar takes the other sign (the bar upwards), which the travel z [-50, 500] alone allowed
  // either way.
  EXPECT_LE(travel_violation_mm(kit, test::kAxisC, in, turn), 0);
  EXPECT_LE(fit_bar(kit, test::kAxisC, in, turn), 0);
  EXPECT_EQ(in.sign, -1);
  EXPECT_TRUE(installation_clashes(kit, test::kAxisC, in, turn).empty());
}

TEST(Workspace, TheSpindleNoseOverTheTableCupByHand) {
  Kit kit = c_kit_of_formats();
  Workspace w;
  w.spindle_diameter_mm = 250;
  w.ball_to_nose_mm = 5;
  w.footprint_mm = 60;
  w.clearance_mm = 10;
  kit.workspace = w;
  const std::vector<double> turn = kit_angles(kit, 30);
  // Radial 100 mm at one height: (250 + 60) / 2 = 155 > 100, so the nose (5 mm above the
  // spindle ball) is over the cup, whose top needs 10 mm: 10 - 5 = 5 mm short.
  Installation in = c_installation(200, 0, 95, Direction::Kind::kRadial, 1, 100);
  EXPECT_NEAR(clash(installation_clashes(kit, test::kAxisC, in, turn, kNone),
                    "the spindle nose reaches the table cup"),
              5, 1e-9);
  // A 200 mm bar puts the nose beyond the cup's footprint: not checked, not listed.
  in.bar_mm = 200;
  EXPECT_EQ(clash(installation_clashes(kit, test::kAxisC, in, turn, kNone),
                  "the spindle nose reaches the table cup"),
            -std::numeric_limits<double>::infinity());
}

// A B head swinging -100..0 deg, tool along +Z at B0 (the table's normal -Z), radial bar of
// 100 mm with the table ball beyond the tool tip (sign -1) at L 250: the table ball at
// 350 mm along the tool. Independently of the code's harmonics: the heights sampled every
// 0.001 deg in the table's own frame.
TEST(Workspace, AHeadAgainstTheTableSampledIndependently) {
  Kit kit = io::read_kit_file(test::source_path("designs/kits/b-head-kit.json"));
  Workspace w;
  w.table_ball_height_mm = 45;
  w.spindle_diameter_mm = 100;
  w.ball_to_nose_mm = 70;
  w.clearance_mm = 10;
  kit.workspace = w;
  Installation in;
  in.id = "1r";
  in.L_mm = 250;
  in.direction = Direction::named(test::kAxisB, Direction::Kind::kRadial);
  in.sign = -1;
  in.bar_mm = 100;
  const std::vector<double> angles = {-100, -50, 0};
  double ball_low = 1e300, nose_low = 1e300;
  for (int i = 0; i <= 100000; ++i) {
    const double b = -100.0 * i / 100000, r = b * M_PI / 180;
    // Pivot frame: tool t = (sin b, 0, cos b); the table ball at 350 t, the spindle ball at
    // 250 t, the nose from 180 t to the pivot. Height above the table ball: -(z - 350 cos b).
    const double table_z = 350 * std::cos(r);
    auto height = [&](double along) { return -(along * std::cos(r) - table_z); };
    const double tilt = 50 * std::abs(std::sin(r));
    ball_low = std::min(ball_low, height(250));
    nose_low = std::min({nose_low, height(180) - tilt, height(0) - tilt});
  }
  const std::vector<Clash> all = installation_clashes(kit, test::kAxisB, in, angles, kNone);
  EXPECT_NEAR(clash(all, "the spindle ball nears the table"), -45 + 10 - ball_low, 1e-6);
  EXPECT_NEAR(clash(all, "the spindle nose reaches the table"), -45 + 10 - nose_low, 1e-3);
  EXPECT_GT(clash(all, "the spindle nose reaches the table"), 40);  // on a 45 mm cup: it does
  // The nose's axis ends 170 mm from the table ball: 50 + 10 - 170.
  EXPECT_NEAR(clash(all, "the spindle nose reaches the table ball"), -110, 1e-9);
  // On a 300 mm stand the same set-up is clear.
  kit.workspace->table_ball_height_mm = 300;
  EXPECT_TRUE(installation_clashes(kit, test::kAxisB, in, angles).empty());
}

// A head turning about Z (a fork head's C, no machine): its table faces +Z whatever the frame's
// reference (+X here, across the spindle), so an axial bar with the table ball above the
// spindle ball points 90 deg below the cup's plane: into it by bar (1 - sin 20 deg); the other
// side is clear by bar (1 + sin 20 deg). Taken along the reference, both would read level.
TEST(Workspace, AHeadTurningAboutZMeasuresTheCupAlongZ) {
  Kit kit = io::read_kit_file(test::source_path("designs/kits/b-head-kit.json"));
  kit.workspace.reset();
  kit.axis = AxisFrame::general('C', AxisFrame::Side::kHead, Eigen::Vector3d::UnitZ(),
                                Eigen::Vector3d::UnitX(), true);
  Installation in;
  in.id = "1a";
  in.L_mm = 100;
  in.direction = Direction::vector(Eigen::Vector3d::UnitZ());
  in.bar_mm = 100;
  const std::vector<double> angles = {-90, 0, 90};
  const double s20 = std::sin(20 * M_PI / 180);
  in.sign = -1;  // the table ball bar above the spindle ball
  EXPECT_NEAR(clash(installation_clashes(kit, kit.axis, in, angles, kNone),
                    "the bar dips into the table ball's cup"),
              100 * (1 - s20), 1e-9);
  in.sign = 1;
  EXPECT_NEAR(clash(installation_clashes(kit, kit.axis, in, angles, kNone),
                    "the bar dips into the table ball's cup"),
              -100 * (1 + s20), 1e-9);
}

TEST(Workspace, ReadFromTheKitFileAndCheckedByKey) {
  nlohmann::json j =
      nlohmann::json::parse(slurp(test::source_path("designs/kits/c-turntable-kit.json")));
  j["workspace"] = {{"table", {{"diameter_mm", 630}}},
                    {"footprint_mm", 60},
                    {"spindle", {{"diameter_mm", 100}, {"ball_to_nose_mm", 70}}}};
  const Kit k = io::kit_from_text(j.dump(), "k.json");
  ASSERT_TRUE(k.workspace);
  EXPECT_EQ(*k.workspace->table_diameter_mm, 630);
  EXPECT_EQ(k.workspace->clearance_mm, 10);
  auto refused = [&](const nlohmann::json& bad, const std::string& key) {
    try {
      io::kit_from_text(bad.dump(), "k.json");
      ADD_FAILURE() << "accepted " << bad["workspace"].dump();
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
    }
  };
  nlohmann::json bad = j;
  bad["workspace"]["table"]["x_mm"] = {-300, 300};
  refused(bad, "diameter_mm");
  bad = j;
  bad["workspace"]["footprint_mm"] = -1;
  refused(bad, "workspace.footprint_mm");
  bad = j;
  bad["workspace"]["table_ball_height_mm"] = 45;
  refused(bad, "table_ball_height_mm");
  bad = j;
  bad["workspace"]["table"]["diameter_mm"] = 50;
  refused(bad, "workspace.footprint_mm");
  // A head's workspace has the table ball's height, no table outline.
  nlohmann::json b =
      nlohmann::json::parse(slurp(test::source_path("designs/kits/b-head-kit.json")));
  b["workspace"] = {{"table", {{"diameter_mm", 630}}}};
  refused(b, "table_ball_height_mm");
}

// Where the table binds (the travel set wide), the search keeps every cup on the table and no
// point of a 2.5 mm grid does better; without the table it does better.
TEST(Exhaustive, SmallCKitOnASmallTableNoGridPointBeatsTheSearch) {
  Kit kit = test::small_c_kit();
  kit.name = "small-table";
  kit.travel_mm = {Interval{-2000, 2000}, Interval{-2000, 2000}, Interval{-50, 2000}};
  Workspace w;
  w.table_diameter_mm = 400;  // a cup's centre at most 200 - 30 = 170 mm from the axis
  w.footprint_mm = 60;
  kit.workspace = w;
  validate_kit(kit);
  const OptimizeResult opt = optimize_kit(kit, {Criterion::kWorst, 2});
  const OptimizeResult grid = exhaustive_search(kit, Criterion::kWorst, 2.5, 2);
  ASSERT_TRUE(opt.best && grid.best);
  ASSERT_TRUE(opt.best->feasible);
  EXPECT_LE(opt.best->objective, 1.005 * grid.best->objective);
  for (const Installation& in : opt.best->design.installations) {
    EXPECT_LE(std::hypot(in.L_mm, in.D_mm), 170 + 1e-6) << in.id;
    EXPECT_TRUE(installation_clashes(kit, kit.axis, in, opt.best->design.angles_deg, 1e-6).empty());
  }
  Kit free = kit;
  free.workspace.reset();
  const OptimizeResult loose = optimize_kit(free, {Criterion::kWorst, 2});
  ASSERT_TRUE(loose.best);
  EXPECT_LT(loose.best->objective, 0.99 * opt.best->objective);
}

// The README's kits state their workspace, and the designs optimize finds in them clear it.
TEST(Workspace, TheReadmeKitsDesignsClearTheirWorkspace) {
  for (const char* file : {"designs/kits/qc20-c-turntable-kit.json"}) {
    const Kit kit = io::read_kit_file(test::source_path(file));
    ASSERT_TRUE(kit.workspace) << file;
    const OptimizeResult opt = optimize_kit(kit, {Criterion::kWorst, 2});
    ASSERT_TRUE(opt.best && opt.best->feasible) << file;
    for (const Installation& in : opt.best->design.installations) {
      EXPECT_TRUE(
          installation_clashes(kit, kit.axis, in, opt.best->design.angles_deg, 1e-6).empty())
          << file << " " << in.id;
    }
  }
}

// One time model: the set-up sheet's total with the kit is optimize's time of the design.
TEST(TimeModel, TheSetupSheetStatesOptimizesTime) {
  const Kit kit = c_kit_of_formats();
  const Design d =
      io::read_design_file(test::source_path("designs/c-turntable-kit-optimized.json"));
  const SetupSheet sheet = make_setup_sheet(d, ProgramOptions{}, std::nullopt, &kit);
  ASSERT_TRUE(sheet.time);
  const TimeEstimate t = design_time(kit, d);
  EXPECT_EQ(sheet.time->total_s, t.total_s);
  EXPECT_EQ(sheet.total_time_s, design_time_s(kit, d));
  EXPECT_EQ(t.readings, static_cast<int>(d.installations.size() * d.angles_deg.size()));
  EXPECT_DOUBLE_EQ(t.setups_s + t.readings_s, t.total_s);
  double steps = 0;
  for (double s : sheet.step_time_s) steps += s;
  EXPECT_NEAR(steps, t.total_s, 1e-9);
  // The design as optimize wrote it states the same time.
  const nlohmann::json j =
      nlohmann::json::parse(slurp(test::source_path("designs/c-turntable-kit-optimized.json")));
  EXPECT_EQ(j["predicted"]["time_s"].get<double>(), t.total_s);
  // Both sweeps read every angle twice.
  ProgramOptions both;
  both.sweeps = ProgramOptions::Sweeps::kBoth;
  const SetupSheet twice = make_setup_sheet(d, both, std::nullopt, &kit);
  EXPECT_EQ(twice.time->readings, 2 * t.readings);
  EXPECT_EQ(twice.program.readings, twice.time->readings);
}

TEST(WorkspaceCli, ASetupThatClashesIsRefusedAndSaysWhere) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("dbbkit_ws_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  nlohmann::json j =
      nlohmann::json::parse(slurp(test::source_path("designs/kits/c-turntable-kit.json")));
  j["workspace"] = {{"table", {{"diameter_mm", 500}}}, {"footprint_mm", 60}};
  const std::string kit = (dir / "kit.json").string();
  std::ofstream(kit) << j.dump();
  const std::string design = test::source_path("designs/c-turntable-kit-optimized.json");
  CliRun r = run_cli("setup-sheet --design " + design + " --kit " + kit + " --summary " +
                     (dir / "s.md").string());
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_NE(r.out.find("CLASH 3r: the cup and blocks overhang the table by 29.987 mm"),
            std::string::npos)
      << r.out;
  const std::string prog = (dir / "p.nc").string();
  r = run_cli("program --design " + design + " --dialect iso --kit " + kit + " --out " + prog);
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find("not written"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("CLASH 3t"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(prog));
  // On a 630 mm table it fits: the program is written and states the kit's time.
  j["workspace"]["table"]["diameter_mm"] = 630;
  std::ofstream(kit) << j.dump();
  r = run_cli("program --design " + design + " --dialect iso --kit " + kit + " --out " + prog);
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(fs::exists(prog));
  EXPECT_NE(r.out.find("the kit's time model"), std::string::npos) << r.out;
  fs::remove_all(dir);
}

}  // namespace
}  // namespace dbbkit
