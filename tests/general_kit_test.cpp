// Kits and optimize for any rotary axis (issue: the axis under test as data): a table whose
// normal is its axis (a primed C table, a machining centre's B table), a trunnion (the table's
// normal across the axis) and a head in the general form.
//
// Independent checks: a kit turned by a rotation of the machine frame (the axis, the table's
// normal and the travel turned with it) describes the same measurement, so its optimum must
// be the original kit's (the search and the model never see the rotation); and on small kits
// no point of an exhaustive grid beats the search.

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <fstream>
#include <functional>
#include <iostream>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>

#include "dbbkit/error.hpp"
#include "dbbkit/io/kit_io.hpp"
#include "dbbkit/io/setup_sheet_io.hpp"
#include "dbbkit/kit.hpp"
#include "dbbkit/observability.hpp"
#include "dbbkit/optimize.hpp"
#include "dbbkit/setup_sheet.hpp"
#include "test_util.hpp"

namespace dbbkit {
namespace {

using Eigen::Vector3d;

// The machine axes' ranges of a box turned by a signed permutation (each axis to +-another).
std::array<Interval, 3> turned_box(const std::array<Interval, 3>& travel,
                                   const Eigen::Matrix3d& R) {
  std::array<Interval, 3> out;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      if (std::abs(R(j, i)) < 0.5) continue;
      out[j] = R(j, i) > 0 ? travel[i] : Interval{-travel[i].max, -travel[i].min};
    }
  }
  return out;
}

// The kit with its axis in the general form, turned by R (a signed permutation).
Kit turned_kit(const Kit& kit, const Eigen::Matrix3d& R, char letter) {
  Kit k = kit;
  const AxisFrame& a = kit.axis;
  k.axis = AxisFrame::general(letter, a.side(), R * a.direction(), R * a.reference(), a.full_turn(),
                              a.travel_min_deg(), a.travel_max_deg());
  k.table_normal = R * kit.table_normal;
  k.travel_mm = turned_box(kit.travel_mm, R);
  k.name = kit.name + "-turned";
  return k;
}

// The head's pattern in the general form offsets along H (the axis), the "B" shorthand along
// its D: the same ball.
Kit b_shorthand_as_general_head(const Kit& b) {
  Kit k = b;
  k.axis = AxisFrame::general('B', AxisFrame::Side::kHead, Vector3d::UnitY(), Vector3d::UnitZ(),
                              b.axis.full_turn(), b.axis.travel_min_deg(), b.axis.travel_max_deg());
  k.pattern = *builtin_pattern("three_position", k.axis);
  k.axial_mm = b.D_mm;
  k.D_mm = {0, 0};
  return k;
}

// The optimum of kit a, its design placed in kit b's frame (`place`: a's ball coordinates in
// b's), scores the same in b to rounding: the model does not see the rotation. b's own search
// finds that optimum to the search's tolerance (it may take another path through the same
// landscape).
void expect_same_optimum(const Kit& a, const Kit& b,
                         const std::function<void(Installation&)>& place = {}) {
  const OptimizeResult ra = optimize_kit(a, {Criterion::kWorst, 2});
  const OptimizeResult rb = optimize_kit(b, {Criterion::kWorst, 2});
  ASSERT_TRUE(ra.best && rb.best);
  EXPECT_TRUE(rb.best->feasible);
  EXPECT_EQ(ra.best->n_undetermined, rb.best->n_undetermined);
  EXPECT_EQ(ra.best_evaluation.prior.rank, rb.best_evaluation.prior.rank);
  EXPECT_NEAR(rb.best->objective, ra.best->objective, 1e-3 * ra.best->objective)
      << a.name << " against " << b.name;
  Design moved = ra.best->design;
  moved.axis = b.axis;
  for (Installation& in : moved.installations) {
    in.direction = Direction::named(b.axis, in.direction.kind);
    if (place) place(in);
  }
  const Evaluation ea = evaluate_design(ra.best->design, a.reference_length_mm),
                   eb = evaluate_design(moved, b.reference_length_mm);
  ASSERT_TRUE(ea.worst.worst_std_um && eb.worst.worst_std_um);
  EXPECT_NEAR(*eb.worst.worst_std_um, *ea.worst.worst_std_um, 1e-9 * *ea.worst.worst_std_um);
  EXPECT_LE(fit_bars(b, moved), 1e-9);  // it fits b's turned travel
  std::cout << a.name << " " << ra.best->objective << " um, " << b.name << " " << rb.best->objective
            << " um\n";
}

TEST(GeneralKit, TheCShorthandInTheGeneralFormSearchesTheSame) {
  const Kit c = test::small_c_kit();
  Kit g = turned_kit(c, Eigen::Matrix3d::Identity(), 'C');
  validate_kit(g);
  EXPECT_EQ(table_carriage(g), TableCarriage::kAlongAxis);
  EXPECT_TRUE(stack_is_H(c));
  EXPECT_FALSE(stack_is_H(g));  // a general design does not state its table's normal
  expect_same_optimum(c, g);
}

TEST(GeneralKit, APrimedCTableIsTheCTableMirrored) {
  // Turning the other way about the same line: direction -Z, the table's normal still +Z, so a
  // height h above the table is H = -h. The measured angles are symmetric about 0, so the
  // optimum is the C table's.
  Kit p = turned_kit(test::small_c_kit(), Eigen::Matrix3d::Identity(), 'C');
  p.axis =
      AxisFrame::general('C', AxisFrame::Side::kTable, -Vector3d::UnitZ(), Vector3d::UnitX(), true);
  validate_kit(p);
  EXPECT_EQ(height_coordinate(p), 2);
  EXPECT_DOUBLE_EQ(height_to_coordinate(p, 45), -45);
  EXPECT_FALSE(stack_is_H(p));
  expect_same_optimum(test::small_c_kit(), p, [](Installation& in) { in.H_mm = -in.H_mm; });
}

TEST(GeneralKit, AMachiningCentresBTableIsTheCTableTurned) {
  // B about +Y, L along +Z at B0: the rotation taking Z to Y and X to Z (and Y to X).
  Eigen::Matrix3d R;
  R << 0, 1, 0, 0, 0, 1, 1, 0, 0;
  const Kit b = turned_kit(test::small_c_kit(), R, 'B');
  validate_kit(b);
  EXPECT_EQ(b.axis.direction(), Vector3d::UnitY());
  EXPECT_EQ(b.axis.reference(), Vector3d::UnitZ());
  expect_same_optimum(test::small_c_kit(), b);
}

TEST(GeneralKit, AnAHeadIsTheBHeadTurned) {
  // The "B" head about +Y with its tool line +Z, turned half a turn about (X + Y)/sqrt(2):
  // about +X with the spindle pointing down (-Z).
  Eigen::Matrix3d R;
  R << 0, 1, 0, 1, 0, 0, 0, 0, -1;
  const Kit b = b_shorthand_as_general_head(test::small_b_kit());
  const Kit a = turned_kit(b, R, 'A');
  validate_kit(a);
  EXPECT_EQ(a.axis.reference(), -Vector3d::UnitZ());
  // The shorthand's D (along its axis) is the general form's H.
  const auto d_to_h = [](Installation& in) { std::swap(in.D_mm, in.H_mm); };
  expect_same_optimum(test::small_b_kit(), b, d_to_h);
  expect_same_optimum(test::small_b_kit(), a, d_to_h);
}

// A small trunnion: A about +X, the table's normal +Z with its surface 40 mm below the axis
// line, one 100 mm block; the cup slides +-60 mm across the table and along the axis.
Kit small_trunnion_kit() {
  Kit k;
  k.name = "small-a-trunnion";
  k.axis = AxisFrame::general('A', AxisFrame::Side::kTable, Vector3d::UnitX(), Vector3d::UnitZ(),
                              false, -120, 120);
  k.table_normal = Vector3d::UnitZ();
  k.table_surface_mm = -40;
  k.pattern = *builtin_pattern("three_position", k.axis, TableCarriage::kAcrossAxis);
  k.reference_length_mm = 100;
  k.D_mm = {-60, 60};
  k.axial_mm = {-60, 60};
  k.H_base_mm = 45;
  k.blocks_mm = {100};
  k.max_stack = 1;
  k.bars_mm = {100, 150};
  k.travel_mm = {Interval{-400, 400}, Interval{-400, 400}, Interval{-400, 400}};
  k.min_separation_mm = 30;
  k.angle_range_deg = {-90, 90};
  k.angle_steps_deg = {30};
  k.time_per_reading_s = 3;
  k.time_per_installation_s = 240;
  validate_kit(k);
  return k;
}

TEST(GeneralKit, ATrunnionsBlocksSetTheDistanceFromTheAxisLine) {
  const Kit k = small_trunnion_kit();
  EXPECT_EQ(table_carriage(k), TableCarriage::kAcrossAxis);
  EXPECT_EQ(height_coordinate(k), 0);
  EXPECT_DOUBLE_EQ(height_to_coordinate(k, 45), 5);  // the cup on the table: 5 mm above the line
  EXPECT_DOUBLE_EQ(height_to_coordinate(k, 145), 105);
  const OptimizeResult r = optimize_kit(k, {Criterion::kWorst, 2});
  ASSERT_TRUE(r.best);
  EXPECT_TRUE(r.best->feasible);
  EXPECT_EQ(r.best_evaluation.prior.rank, r.best_evaluation.prior.n_unknowns);
  for (const Installation& in : r.best->design.installations) {
    EXPECT_TRUE(std::abs(in.L_mm - 5) < 1e-9 || std::abs(in.L_mm - 105) < 1e-9) << in.id;
    EXPECT_LE(std::abs(in.D_mm), 60 + 1e-9);
    EXPECT_LE(std::abs(in.H_mm), 60 + 1e-9);
    EXPECT_FALSE(in.cup_mm);  // the design's H is not the stack's height: said in words
    EXPECT_NE(in.description.find("cup"), std::string::npos) << in.description;
  }
}

// The search on `kit` against every point of a grid over `grid_kit` (the same kit, or one whose
// pattern leaves more free).
void expect_search_beats_grid(const Kit& kit, double grid_mm, const Kit* grid_kit = nullptr) {
  const OptimizeResult opt = optimize_kit(kit, {Criterion::kWorst, 2});
  const OptimizeResult grid =
      exhaustive_search(grid_kit ? *grid_kit : kit, Criterion::kWorst, grid_mm, 2);
  ASSERT_TRUE(opt.best && grid.best);
  EXPECT_TRUE(opt.best->feasible);
  EXPECT_EQ(opt.best->n_undetermined, 0);
  EXPECT_EQ(grid.best->n_undetermined, 0);
  EXPECT_LE(opt.best->objective, 1.005 * grid.best->objective)
      << "a grid point is more than 0.5% better: " << grid.best->objective << " um vs "
      << opt.best->objective;
  std::cout << kit.name << ": optimize " << opt.best->objective << " um (" << opt.evaluations
            << " designs), grid " << grid_mm << " mm " << grid.best->objective << " um ("
            << grid.evaluations << " designs)\n";
}

TEST(Exhaustive, SmallATrunnionNoGridPointBeatsTheSearch) {
  // The grid also frees the third ball's place along the axis (S3), which the built-in
  // pattern ties to the second's: the tie costs nothing here.
  const Kit k = small_trunnion_kit();
  Kit untied = k;
  ASSERT_EQ(untied.pattern.positions[2].H.variable, "S2");
  untied.pattern.positions[2].H.variable = "S3";
  untied.pattern.builtin = false;
  validate_kit(untied);
  expect_search_beats_grid(k, 20, &untied);
}

TEST(Exhaustive, SmallAHeadNoGridPointBeatsTheSearch) {
  Eigen::Matrix3d R;
  R << 0, 1, 0, 1, 0, 0, 0, 0, -1;
  expect_search_beats_grid(turned_kit(b_shorthand_as_general_head(test::small_b_kit()), R, 'A'), 5);
}

// A 45 deg nutating table, which no rotation of the machine frame takes to the C table (the
// tool line meets its table at 45 deg): the C kit's table swivelled 45 deg from Z towards -Y,
// its normal along its axis. The travel binds.
TEST(Exhaustive, SmallNutatingTableNoGridPointBeatsTheSearch) {
  Kit k = turned_kit(test::small_c_kit(), Eigen::Matrix3d::Identity(), 'B');
  k.name = "small-nutating";
  const Vector3d n = Vector3d(0, -1, 1).normalized();
  k.axis = AxisFrame::general('B', AxisFrame::Side::kTable, n, Vector3d::UnitX(), true);
  k.table_normal = n;
  validate_kit(k);
  EXPECT_EQ(height_coordinate(k), 2);
  expect_search_beats_grid(k, 5);
  Kit free = k;
  free.travel_mm = {Interval{-2000, 2000}, Interval{-2000, 2000}, Interval{-2000, 2000}};
  const OptimizeResult loose = optimize_kit(free, {Criterion::kWorst, 2});
  const OptimizeResult bound = optimize_kit(k, {Criterion::kWorst, 2});
  ASSERT_TRUE(loose.best && bound.best);
  EXPECT_LT(loose.best->objective, 0.9 * bound.best->objective);
}

// The tables the rotation tests above compare with the C table, each on its own grid with a
// workspace that binds (the general table's clash checks; a turned C kit tests the C table's):
// a machining centre's B table over a quarter turn under its spindle (horizontal, along Z),
// and a primed C table on a table of 400 mm.
TEST(Exhaustive, TablesInTheirWorkspaceNoGridPointBeatsTheSearch) {
  Eigen::Matrix3d R;
  R << 0, 1, 0, 0, 0, 1, 1, 0, 0;
  Kit b_table = turned_kit(test::small_c_kit(), R, 'B');
  b_table.name = "small-hmc-b-table";
  b_table.angle_range_deg = {0, 90};
  Workspace spindle;
  spindle.table_diameter_mm = 400;
  spindle.footprint_mm = 60;
  spindle.spindle_diameter_mm = 60;
  spindle.ball_to_nose_mm = 60;
  Kit primed = turned_kit(test::small_c_kit(), Eigen::Matrix3d::Identity(), 'C');
  primed.name = "small-primed-c";
  primed.axis =
      AxisFrame::general('C', AxisFrame::Side::kTable, -Vector3d::UnitZ(), Vector3d::UnitX(), true);
  primed.travel_mm = {Interval{-2000, 2000}, Interval{-2000, 2000}, Interval{-50, 2000}};
  Workspace table;
  table.table_diameter_mm = 400;  // a cup's centre at most 200 - 30 = 170 mm from the axis
  table.footprint_mm = 60;
  for (auto [k, w] : {std::pair{b_table, spindle}, std::pair{primed, table}}) {
    SCOPED_TRACE(k.name);
    const OptimizeResult loose = optimize_kit(k, {Criterion::kWorst, 2});
    k.workspace = w;
    validate_kit(k);
    expect_search_beats_grid(k, 5);
    const OptimizeResult bound = optimize_kit(k, {Criterion::kWorst, 2});
    ASSERT_TRUE(loose.best && bound.best);
    EXPECT_LT(loose.best->objective, 0.99 * bound.best->objective);
  }
}

TEST(GeneralKit, TheCommittedKitsOfNewKindsFindFullRankDesigns) {
  for (const char* f : {"designs/kits/a-trunnion-kit.json", "designs/kits/b-table-kit.json",
                        "designs/kits/a-head-kit.json"}) {
    const Kit k = io::read_kit_file(test::source_path(f));
    OptimizeOptions o;
    o.criterion = Criterion::kWorstTotal;
    o.threads = 2;
    const OptimizeResult r = optimize_kit(k, o);
    ASSERT_TRUE(r.best) << f;
    EXPECT_TRUE(r.best->feasible) << f;
    EXPECT_EQ(r.best_evaluation.prior.rank, r.best_evaluation.prior.n_unknowns) << f;
    std::cout << f << ": worst_total " << r.best->objective << " um\n";
  }
}

nlohmann::json kit_json(const std::string& relative) {
  std::ifstream in(test::source_path(relative));
  return nlohmann::json::parse(in);
}

// A kit that states no reference length weighs a tilt where the machine cuts: the table's edge
// on a table axis, the farthest ball along the tool on a head; nothing to default from is refused.
TEST(GeneralKit, AKitWithoutAReferenceLengthWeighsTiltsWhereTheMachineCuts) {
  const Kit trunnion = io::read_kit_file(test::source_path("designs/kits/a-trunnion-kit.json"));
  EXPECT_EQ(trunnion.reference_length_basis, Kit::ReferenceLengthBasis::kTableRadius);
  EXPECT_DOUBLE_EQ(trunnion.reference_length_mm, 200.0);  // its 400 mm table
  EXPECT_NE(reference_length_basis_text(trunnion).find("table's radius"), std::string::npos);

  nlohmann::json head = kit_json("designs/kits/a-head-kit.json");
  head.erase("reference_length_mm");
  const Kit h = io::kit_from_json(head, "head.json");
  EXPECT_EQ(h.reference_length_basis, Kit::ReferenceLengthBasis::kToolReach);
  EXPECT_DOUBLE_EQ(h.reference_length_mm, h.L_mm.max);

  nlohmann::json bare = kit_json("designs/kits/c-turntable-kit.json");
  bare.erase("reference_length_mm");
  ASSERT_FALSE(bare.contains("workspace"));
  try {
    io::kit_from_json(bare, "c.json");
    ADD_FAILURE() << "a C table kit with neither a reference length nor a table was accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.where(), "reference_length_mm") << e.what();
    EXPECT_NE(std::string(e.what()).find("workspace.table"), std::string::npos) << e.what();
  }
}

// Weighed at 100 mm, the trunnion's search put its balls 20 and 45 mm from the axis and left
// the tilts at 45 urad (9 um at the table's 200 mm edge, beyond the 5.2 um it reported); weighed
// at the table's radius it determines them there: its worst at the edge is well below the
// 100 mm design's, and no error at the edge exceeds the worst it reports.
TEST(GeneralKit, TheTrunnionDesignSeesItsTiltsAtTheTablesEdge) {
  const Kit edge = io::read_kit_file(test::source_path("designs/kits/a-trunnion-kit.json"));
  Kit hundred = edge;
  hundred.reference_length_mm = 100;
  OptimizeOptions o;
  o.criterion = Criterion::kWorstTotal;
  o.threads = 2;
  const OptimizeResult at_edge = optimize_kit(edge, o), at_100 = optimize_kit(hundred, o);
  ASSERT_TRUE(at_edge.best && at_100.best);
  const TotalWorstCase mine = design_worst_total(at_edge.best->design, 200.0),
                       theirs = design_worst_total(at_100.best->design, 200.0);
  ASSERT_TRUE(mine.total.worst_std_um && theirs.total.worst_std_um);
  EXPECT_GE(theirs.total.at_error, 3) << "the 100 mm design's worst at the edge is a tilt";
  EXPECT_LT(*mine.total.worst_std_um, 0.7 * *theirs.total.worst_std_um);
  EXPECT_NEAR(*mine.total.worst_std_um, at_edge.best->objective, 1e-6);
  std::cout << "worst total at the 200 mm edge: " << *mine.total.worst_std_um
            << " um (weighed there), " << *theirs.total.worst_std_um << " um (weighed at 100 mm)\n";
}

TEST(GeneralKit, AKitSaysWhatItsTableLacks) {
  const std::string base = R"({"format": "dbbkit.kit/1", "pattern": "three_position",
    "reference_length_mm": 100, "H_mm": {"base": 45, "blocks": [50], "max_stack": 1},
    "bars_mm": [100], "travel_mm": {"x": [-400, 400], "y": [-400, 400], "z": [-400, 400]},
    "angles_deg": {"range": [-90, 90], "steps": [30]},
    "time_s": {"per_reading": 3, "per_installation": 240}, )";
  const std::string a =
      R"("axis": {"letter": "A", "side": "table", "direction": [1, 0, 0], "reference": [0, 0, 1],
       "travel_deg": [-120, 120]}, )";
  auto expect_refused = [&](const std::string& rest, const std::string& key,
                            const std::string& what) {
    try {
      io::kit_from_json(nlohmann::json::parse(base + rest), "k.json");
      ADD_FAILURE() << "accepted: " << rest;
    } catch (const InputError& e) {
      EXPECT_EQ(e.where(), key) << e.what();
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  };
  // A general table states its normal and surface; nothing is guessed.
  expect_refused(a + R"("D_mm": {"min": -50, "max": 50}})", "table", "");
  expect_refused(a + R"("table": {"normal": [0, 0, 1]}, "D_mm": {"min": -50, "max": 50}})",
                 "table.surface_mm", "");
  // Neither along the axis nor along the reference.
  expect_refused(a + R"("table": {"normal": [0, 1, 0], "surface_mm": 0},
      "D_mm": {"min": -50, "max": 50}})",
                 "table.normal", "neither along the axis");
  // A trunnion's distance from the axis line is its blocks'.
  expect_refused(a + R"("table": {"normal": [0, 0, 1], "surface_mm": -50},
      "L_mm": {"min": 0, "max": 100}})",
                 "L_mm", "trunnion");
  // The shorthands keep their own geometry.
  expect_refused(R"("axis": "C", "table": {"normal": [0, 0, 1], "surface_mm": 0},
      "L_mm": {"min": 0, "max": 100}})",
                 "table", "general form");
  expect_refused(
      R"("axis": "C", "axial_mm": {"min": 0, "max": 10}, "L_mm": {"min": 0, "max": 100}})",
      "axial_mm", "cushion blocks");
  // Accepted: the trunnion as the committed kit writes it.
  EXPECT_NO_THROW(io::kit_from_json(
      nlohmann::json::parse(base + a + R"("table": {"normal": [0, 0, 1], "surface_mm": -50},
      "D_mm": {"min": -50, "max": 50}, "axial_mm": {"min": -50, "max": 50}})"),
      "k.json"));
}

}  // namespace
}  // namespace dbbkit

namespace dbbkit {
namespace {

// From a hostile round on general-form kits.
TEST(GeneralKit, ATrunnionsSetUpSheetFollowsItsStacks) {
  Kit k = small_trunnion_kit();
  k.table_surface_mm = -50;  // the cup alone puts the ball 5 mm below the axis line
  k.blocks_mm = {25, 100};
  k.max_stack = 2;
  validate_kit(k);
  const OptimizeResult r = optimize_kit(k, {Criterion::kWorst, 2});
  ASSERT_TRUE(r.best);
  const Design& d = r.best->design;
  // A ball below the axis line (L < 0) is a place on a trunnion, and its design reads back.
  Design low = d;
  low.installations[0].L_mm = -5;
  EXPECT_NO_THROW(validate_design(low));
  Design c = test::paper_design('C');
  c.installations[0].L_mm = -5;  // the "C" shorthand's L is a radius
  EXPECT_THROW(validate_design(c), InputError);
  // The sheet's stack changes are the kit's stacks changing from step to step (the stack sets
  // L here, not H).
  const SetupSheet sheet = make_setup_sheet(d, ProgramOptions{}, std::nullopt, &k);
  ASSERT_EQ(sheet.kit_stacks.size(), d.installations.size());
  EXPECT_TRUE(sheet.fits_kit());
  for (size_t s = 1; s < sheet.order.steps.size(); ++s) {
    const auto& a = sheet.kit_stacks[sheet.order.steps[s - 1].installation];
    const auto& b = sheet.kit_stacks[sheet.order.steps[s].installation];
    ASSERT_TRUE(a && b);
    EXPECT_EQ(sheet.order.steps[s].changes_stack, a->height_mm != b->height_mm) << s;
  }
  // The program's order is the sheet's.
  for (size_t s = 0; s < sheet.order.steps.size(); ++s)
    EXPECT_EQ(sheet.program.installations[s].installation, sheet.order.steps[s].installation);
  // Against a kit whose surface lies elsewhere no stack builds the heights: it does not fit.
  Kit moved = k;
  moved.table_surface_mm = -45;
  const SetupSheet off = make_setup_sheet(d, ProgramOptions{}, std::nullopt, &moved);
  EXPECT_FALSE(off.fits_kit());
  int unbuilt = 0;
  for (const auto& [id, clash] : off.clashes) {
    if (clash.what.find("no stack") == std::string::npos) continue;
    ++unbuilt;
    EXPECT_NEAR(clash.by_mm, 5, 1e-9) << id;  // 5 mm off every stack
  }
  EXPECT_EQ(unbuilt, static_cast<int>(d.installations.size()));
  // Another travel: the message says what differs.
  Kit other = k;
  other.axis = AxisFrame::general('A', AxisFrame::Side::kTable, Vector3d::UnitX(),
                                  Vector3d::UnitZ(), false, -110, 110);
  try {
    make_setup_sheet(d, ProgramOptions{}, std::nullopt, &other);
    ADD_FAILURE() << "accepted another axis";
  } catch (const InputError& e) {
    EXPECT_NE(e.detail().find("travel -110..110 deg against -120..120 deg"), std::string::npos)
        << e.what();
  }
}

TEST(GeneralKit, APatternsFixedHeightMustBeAStack) {
  Kit k = small_trunnion_kit();
  k.pattern.builtin = false;
  k.pattern.positions[1].L = PatternCoordinate{"", 60};  // no stack builds 60 mm
  try {
    validate_kit(k);
    ADD_FAILURE() << "accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.where(), "pattern.positions[1].L");
  }
  k.pattern.positions[1].L = PatternCoordinate{"", 145};  // the cup on the 100 mm block
  EXPECT_NO_THROW(validate_kit(k));
  // The design says the height above the table, not its L (5 + 100 mm above the axis line).
  const OptimizeResult r = optimize_kit(k, {Criterion::kWorst, 2});
  ASSERT_TRUE(r.best);
  int fixed = 0;
  for (const Installation& in : r.best->design.installations) {
    if (in.description.find("fixed by the pattern") == std::string::npos) continue;
    ++fixed;
    EXPECT_NE(in.description.find("the height above the table = 145 mm"), std::string::npos)
        << in.description;
    EXPECT_NEAR(in.L_mm, 105, 1e-9);
  }
  EXPECT_GT(fixed, 0);
}

// --- the drawings of a general-form table: the kit's table, cup and blocks ---------------------

// Every match of `pattern` in an SVG: its captured numbers (a polygon's points split at ',' and
// ' '), in the order drawn.
std::vector<std::vector<double>> svg_numbers(const std::string& svg, const std::string& pattern) {
  std::vector<std::vector<double>> out;
  const std::regex re(pattern);
  for (auto m = std::sregex_iterator(svg.begin(), svg.end(), re); m != std::sregex_iterator();
       ++m) {
    std::vector<double> v;
    for (size_t g = 1; g < m->size(); ++g) {
      std::string text = (*m)[g].str();
      std::replace(text.begin(), text.end(), ',', ' ');
      std::istringstream in(text);
      for (double x; in >> x;) v.push_back(x);
    }
    out.push_back(v);
  }
  return out;
}
const char* const kRedBall = "<circle cx='([-0-9.]+)' cy='([-0-9.]+)' r='5' fill='#d62728'";
const char* const kTableLine =
    "<line x1='([-0-9.]+)' y1='([-0-9.]+)' x2='([-0-9.]+)' y2='([-0-9.]+)' "
    "style='stroke:#333;stroke-width:2'";
// The distance of (x, y) from the line through (x1, y1) and (x2, y2), px.
double off_line(double x, double y, const std::vector<double>& l) {
  const double dx = l[2] - l[0], dy = l[3] - l[1];
  return std::abs(dx * (y - l[1]) - dy * (x - l[0])) / std::hypot(dx, dy);
}

TEST(GeneralKit, ATrunnionsDrawingsStandTheCupOnItsBlocksOnTheTurnedTable) {
  Kit k = small_trunnion_kit();
  k.table_surface_mm = -50;
  k.blocks_mm = {25, 100};
  k.max_stack = 2;
  validate_kit(k);
  const OptimizeResult r = optimize_kit(k, {Criterion::kWorst, 2});
  ASSERT_TRUE(r.best);
  const SetupSheet sheet = make_setup_sheet(r.best->design, ProgramOptions{}, std::nullopt, &k);
  const SetupSheet bare = make_setup_sheet(r.best->design, ProgramOptions{}, std::nullopt, nullptr);
  ASSERT_EQ(sheet.kit_stacks.size(), r.best->design.installations.size());
  for (size_t step = 0; step < sheet.order.steps.size(); ++step) {
    const std::string svg = io::installation_drawing(sheet, static_cast<int>(step));
    const auto& stack = sheet.kit_stacks[sheet.order.steps[step].installation];
    ASSERT_TRUE(stack);
    const auto blocks = svg_numbers(svg, "<polygon points='([^']*)' fill='#e0c080'");
    const auto cups = svg_numbers(svg, "<polygon points='([^']*)' fill='#bbbbbb'");
    const auto tables = svg_numbers(svg, kTableLine);
    const auto balls = svg_numbers(svg, kRedBall);
    ASSERT_EQ(blocks.size(), stack->blocks_mm.size()) << step;
    ASSERT_EQ(cups.size(), 1u);
    ASSERT_EQ(tables.size(), 1u);  // the table along the axis; none across it
    ASSERT_FALSE(balls.empty());
    // The stack stands on the table (its foot's corners on the table's line) and the cup's top
    // edge centres on the ball, to the drawing's 0.1 px.
    const std::vector<double>& foot = blocks.empty() ? cups[0] : blocks[0];
    EXPECT_LE(off_line(foot[0], foot[1], tables[0]), 0.15) << svg;
    EXPECT_LE(off_line(foot[2], foot[3], tables[0]), 0.15) << svg;
    // ... within the table's drawn length (not past its end).
    const std::vector<double>& l = tables[0];
    for (int c : {0, 2}) {
      const double along = (foot[c] - l[0]) * (l[2] - l[0]) + (foot[c + 1] - l[1]) * (l[3] - l[1]);
      EXPECT_GE(along, 0) << svg;
      EXPECT_LE(along, std::pow(l[2] - l[0], 2) + std::pow(l[3] - l[1], 2)) << svg;
    }
    const std::vector<double>& cup = cups[0];
    EXPECT_NEAR(0.5 * (cup[4] + cup[6]), balls[0][0], 0.15) << svg;
    EXPECT_NEAR(0.5 * (cup[5] + cup[7]), balls[0][1], 0.15) << svg;
    // Without the kit the design does not state its table: its balls alone are drawn.
    const std::string plain = io::installation_drawing(bare, static_cast<int>(step));
    EXPECT_EQ(plain.find("<polygon"), std::string::npos);
    EXPECT_TRUE(svg_numbers(plain, kTableLine).empty());
  }
}

TEST(GeneralKit, APrimedTablesDrawingsStandTheCupUpOnItsBlocks) {
  // Direction -Z: the frame's H is down. The view turns so that the table's normal is up: the
  // table's line below the ball, the cup's top at the ball.
  Kit p = turned_kit(test::small_c_kit(), Eigen::Matrix3d::Identity(), 'C');
  p.axis =
      AxisFrame::general('C', AxisFrame::Side::kTable, -Vector3d::UnitZ(), Vector3d::UnitX(), true);
  p.table_surface_mm = 20;
  validate_kit(p);
  const OptimizeResult r = optimize_kit(p, {Criterion::kWorst, 2});
  ASSERT_TRUE(r.best);
  const SetupSheet sheet = make_setup_sheet(r.best->design, ProgramOptions{}, std::nullopt, &p);
  int on_blocks = 0;
  for (size_t step = 0; step < sheet.order.steps.size(); ++step) {
    const std::string svg = io::installation_drawing(sheet, static_cast<int>(step));
    const auto& stack = sheet.kit_stacks[sheet.order.steps[step].installation];
    ASSERT_TRUE(stack);
    on_blocks += !stack->blocks_mm.empty();
    const auto rect =
        "<rect x='([-0-9.]+)' y='([-0-9.]+)' width='([-0-9.]+)' height='([-0-9.]+)' "
        "fill='";
    const auto blocks = svg_numbers(svg, std::string(rect) + "#e0c080'");
    const auto cups = svg_numbers(svg, std::string(rect) + "#bbbbbb'");
    const auto tables = svg_numbers(svg, kTableLine);
    const auto balls = svg_numbers(svg, kRedBall);
    ASSERT_EQ(blocks.size(), stack->blocks_mm.size());
    ASSERT_EQ(cups.size(), 1u);
    ASSERT_EQ(tables.size(), 1u);
    ASSERT_EQ(balls.size(), 2u);  // from above, from the side
    std::string words;            // the captions' lines joined
    const std::regex text_re("<text[^>]*>([^<]*)</text>");
    for (auto m = std::sregex_iterator(svg.begin(), svg.end(), text_re);
         m != std::sregex_iterator(); ++m)
      words += (*m)[1].str() + " ";
    EXPECT_NE(words.find("onto the table, its normal toward you (X right, Y up)"),
              std::string::npos)
        << words;
    const std::vector<double>& side_ball = balls[1];
    EXPECT_NEAR(tables[0][1], tables[0][3], 1e-9);       // level
    EXPECT_GT(tables[0][1], side_ball[1] + 10);          // below the ball (SVG y grows down)
    EXPECT_NEAR(cups[0][1], side_ball[1], 0.15) << svg;  // the cup's top at the ball
    // The stack from the table up: its bottom on the table's line, each block on the last.
    double bottom = tables[0][1];
    for (const auto& b : blocks) {
      EXPECT_NEAR(b[1] + b[3], bottom, 0.15) << svg;
      bottom = b[1];
    }
    EXPECT_NEAR(cups[0][1] + cups[0][3], bottom, 0.15) << svg;
  }
  EXPECT_GT(on_blocks, 0);  // the optimum raises a ball on the 150 mm block
}

}  // namespace
}  // namespace dbbkit
