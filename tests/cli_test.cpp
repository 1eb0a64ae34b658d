// The command line as a user meets it: exit statuses and messages for bad input,
// and the identify / simulate round trip through files.

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <boost/math/distributions/normal.hpp>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "cli_util.hpp"
#include "dbbkit/io/hashing.hpp"
#include "test_util.hpp"

namespace dbbkit {
namespace {

std::string bad(const std::string& name) { return test::source_path("tests/data/bad/" + name); }
using test::kDataC;
using test::kDesignB;
using test::kDesignC;

struct BadCase {
  std::string file;    // the broken file, under tests/data/bad
  std::string args;    // the command line, with {} for the broken file
  std::string where;   // the line or key the message must name
  std::string detail;  // what it must say is wrong
};

void PrintTo(const BadCase& c, std::ostream* os) { *os << c.file; }

class BadInput : public ::testing::TestWithParam<BadCase> {};

TEST_P(BadInput, ExitsTwoNamingFileAndPlace) {
  const BadCase& c = GetParam();
  std::string args = c.args;
  args.replace(args.find("{}"), 2, bad(c.file));
  const CliRun r = run_cli(args);
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_NE(r.err.find(c.file), std::string::npos) << "file not named: " << r.err;
  EXPECT_NE(r.err.find(c.where), std::string::npos)
      << "place '" << c.where << "' not named: " << r.err;
  EXPECT_NE(r.err.find(c.detail), std::string::npos) << "'" << c.detail << "' not said: " << r.err;
  EXPECT_TRUE(r.out.empty()) << "a failed run must write no result: " << r.out;
}

const std::string kIdentifyDesign = "identify --data " + kDataC + " --design {}";
const std::string kIdentifyDesignB =
    "identify --data " + test::source_path("tests/data/paper/paper_b_head.csv") + " --design {}";
const std::string kIdentifyDataC = "identify --design " + kDesignC + " --data {}";
const std::string kIdentifyDataB = "identify --design " + kDesignB + " --data {}";
const std::string kSimulateC = "simulate --design " + kDesignC + " --truth {}";
const std::string kOptimize = "optimize --quiet --kit {}";
const std::string kBench = "bench " + kDesignC + " --baseline {}";
const std::string kTolerancesC =
    "identify --design " + kDesignC + " --data " + kDataC + " --tolerances {}";

INSTANTIATE_TEST_SUITE_P(
    Catalogue, BadInput,
    ::testing::Values(
        BadCase{"design_missing_axis.json", kIdentifyDesign, "axis", "required key is missing"},
        BadCase{"design_axis_not_unit.json", kIdentifyDesign, "axis.direction",
                "unit vector (|v| = 2)"},
        BadCase{"design_axis_not_perpendicular.json", kIdentifyDesign, "axis.reference",
                "perpendicular to direction (d . r = 0.8)"},
        BadCase{"design_axis_letter.json", kIdentifyDesign, "axis.letter",
                "'D' is not a rotary axis' letter"},
        BadCase{"design_axis_side.json", kIdentifyDesign, "axis.side",
                "'spindle' (expected \"table\" or \"head\")"},
        BadCase{"design_axis_letter_mismatch.json", kIdentifyDesign, "axis.letter",
                "an axis along +Y is B (ISO 841), not 'C'"},
        BadCase{"design_axis_travel.json", kIdentifyDesign, "axis.travel_deg",
                "min 90 must be below max -90"},
        BadCase{"design_unknown_key.json", kIdentifyDesign, "angles_deg",
                "is 'anlges_deg' a misspelling"},
        BadCase{"design_direction_typo.json", kIdentifyDesign, "installations[1].direction",
                "unknown direction 'tangental'"},
        BadCase{"design_duplicate_id.json", kIdentifyDesign, "installations[2].id",
                "duplicate installation id '1r'"},
        BadCase{"design_wrong_format.json", kIdentifyDesign, "format", "dbbkit.design/1"},
        BadCase{"design_text_number.json", kIdentifyDesign, "installations[0].ball_mm.L",
                "expected a number, found a string"},
        BadCase{"design_b_angle_out_of_range.json", kIdentifyDesignB, "angles_deg[0]",
                "outside [-180, 180]"},
        BadCase{"design_step_zero.json", kIdentifyDesign, "angles_deg.step", "must not be 0"},
        BadCase{"design_grid_not_whole.json", kIdentifyDesign, "angles_deg.stop",
                "not start + k * step"},
        BadCase{"design_not_unit_vector.json", kIdentifyDesign, "installations[3].direction",
                "unit vector"},
        BadCase{"design_b_with_h.json", kIdentifyDesignB, "installations[0].ball_mm.H",
                "not used for the swinging head"},
        BadCase{"design_negative_noise.json", kIdentifyDesign, "noise.accuracy_um", "positive"},
        BadCase{"design_fourier_on_b.json", kIdentifyDesignB, "errors.model",
                "full-turn axis such as the turntable C; axis B turns through an arc"},
        BadCase{"design_bad_sign.json", kIdentifyDesign, "installations[0].sign", "+1 or -1"},
        BadCase{"design_setup_negative.json", kIdentifyDesign, "setup_std.centring_um",
                "standard uncertainty in [0, 10000] um"},
        BadCase{"design_setup_unknown_key.json", kIdentifyDesign,
                "installations[2].setup_std.centering_um", "unknown key"},
        BadCase{"design_setup_both_forms.json", kIdentifyDesign, "setup_std_mm", "not both"},
        BadCase{"design_setup_huge.json", kIdentifyDesign,
                "installations[1].setup_std.length_offset_um", "[0, 10000] um"},
        BadCase{"design_ball_unknown_key.json", kIdentifyDesign, "installations[4].ball_mm.Hh",
                "unknown key"},
        BadCase{"design_normal_with_accuracy.json", kIdentifyDesign, "noise.accuracy_um", "std_um"},
        BadCase{"design_no_installations.json", kIdentifyDesign, "installations",
                "no installations"},
        BadCase{"design_per_angle_order.json", kIdentifyDesign, "errors.order", "no order"},
        BadCase{"design_syntax_error.json", kIdentifyDesign, "line 3", "not valid JSON"},
        BadCase{"design_nan.json", kIdentifyDesign, "line 11", "not valid JSON"},
        BadCase{"design_duplicate_key.json", kIdentifyDesign, "key 'axis'", "appears twice"},
        BadCase{"design_empty.json", kIdentifyDesign, "", "the file is empty"},
        BadCase{"design_number_overflow.json", kIdentifyDesign, "line 40",
                "beyond the range of a double"},
        BadCase{"data_empty.csv", kIdentifyDataC, "", "the file is empty"},
        BadCase{"data_unknown_installation.csv", kIdentifyDataC, "line 3",
                "installation '4r' is not in the design"},
        BadCase{"data_nan.csv", kIdentifyDataC, "line 2, column reading_mm", "not a finite number"},
        BadCase{"data_text_in_number.csv", kIdentifyDataC, "line 4, column reading_mm",
                "'abc' is not a number"},
        BadCase{"data_missing_column.csv", kIdentifyDataC, "line 1", "required column 'angle_deg'"},
        BadCase{"data_unknown_column.csv", kIdentifyDataC, "line 1", "unknown column 'reading_mn'"},
        BadCase{"data_angle_not_in_design.csv", kIdentifyDataC, "line 2",
                "angle 25 deg is not a position of the design"},
        BadCase{"data_b_angle_out_of_range.csv", kIdentifyDataB, "line 3",
                "outside its range -100 .. 0 deg"},
        BadCase{"data_field_count.csv", kIdentifyDataC, "line 3", "expected 3 fields, found 2"},
        BadCase{"data_both_units.csv", kIdentifyDataC, "line 1", "both reading_mm and reading_um"},
        BadCase{"data_bad_sweep.csv", kIdentifyDataC, "line 3, column sweep",
                "'clockwise' is not a sweep"},
        BadCase{"data_header_only.csv", kIdentifyDataC, "", "no readings"},
        BadCase{
            "data_unit_mixup.csv", kIdentifyDataC, "line 3",
            "reading_mm 52.2 is beyond the instrument's range of +-1 mm: are the readings in um?"},
        BadCase{
            "data_um_beyond_range.csv", kIdentifyDataC, "line 3",
            "reading 2500 um is beyond the instrument's range of +-1 mm; the range is the design's "
            "instrument.range_mm"},
        BadCase{"data_negative_time.csv", kIdentifyDataC, "line 3", "time_s"},
        BadCase{"data_repeat_not_integer.csv", kIdentifyDataC, "line 3, column repeat",
                "not an integer"},
        BadCase{"data_empty_id.csv", kIdentifyDataC, "line 3, column installation",
                "empty installation id"},
        BadCase{"data_quoted.csv", kIdentifyDataC, "line 2", "quoted fields"},
        BadCase{"data_duplicate_column.csv", kIdentifyDataC, "line 1",
                "column 'angle_deg' appears twice"},
        BadCase{"truth_missing_angle.json", kSimulateC, "errors.values",
                "no errors given at angle 340"},
        BadCase{"truth_wrong_coefficient_count.json", kSimulateC, "errors.coefficients.dz",
                "expected 3 coefficients"},
        BadCase{"truth_unknown_key.json", kSimulateC, "noize", "unknown key"},
        BadCase{"truth_no_seed.json", kSimulateC, "seed", "give --seed"},
        BadCase{"kit_wrong_format.json", kOptimize, "format", "expected \"dbbkit.kit/1\""},
        BadCase{"kit_unknown_key.json", kOptimize, "bars_mm", "misspelling"},
        BadCase{"kit_free_pattern.json", kOptimize, "pattern", "\"free\" is not supported"},
        BadCase{"kit_b_misses_zero.json", kOptimize, "angles_deg.steps[0]",
                "steps of 20 deg from -110 deg never reach B = 0"},
        BadCase{"kit_general_axis.json", kOptimize, "table",
                "required for a table in the general form"},
        BadCase{"kit_L_min_above_max.json", kOptimize, "L_mm", "min is larger than max"},
        BadCase{"kit_pattern_bad_direction.json", kOptimize, "pattern.positions[0].directions[1]",
                "unknown direction 'sideways'"},
        BadCase{"kit_pattern_variable_two_roles.json", kOptimize, "pattern.positions[0].D",
                "is used as L and as D"},
        BadCase{"kit_pattern_all_optional.json", kOptimize, "pattern.positions",
                "at least one must be required"},
        BadCase{"kit_pattern_duplicate_id.json", kOptimize, "pattern.positions[0].directions",
                "installation '3r' appears twice"},
        BadCase{"kit_pattern_distinct_not_height.json", kOptimize, "pattern.distinct[0]",
                "'L1' is not a height variable"},
        BadCase{"kit_pattern_height_on_b.json", kOptimize, "pattern.positions[0].H",
                "H is not used for the swinging head B"},
        BadCase{"kit_pattern_too_many_choices.json", kOptimize, "pattern",
                "more than 20000 discrete choices"},
        BadCase{"kit_negative_block.json", kOptimize, "H_mm.blocks[1]", "positive height"},
        BadCase{"kit_one_height.json", kOptimize, "H_mm", "needs two heights"},
        BadCase{"kit_no_bars.json", kOptimize, "bars_mm", "no bars"},
        BadCase{"kit_travel_reversed.json", kOptimize, "travel_mm.y", "min < max"},
        BadCase{"kit_travel_not_pair.json", kOptimize, "travel_mm.z", "expected [min, max]"},
        BadCase{"kit_step_not_dividing.json", kOptimize, "angles_deg.steps[1]",
                "whole number of steps"},
        BadCase{"kit_negative_budget.json", kOptimize, "time_s.budget", "positive time"},
        BadCase{"kit_b_with_h.json", kOptimize, "H_mm", "carries the head"},
        BadCase{"kit_b_offset_excludes_zero.json", kOptimize, "D_mm", "must include 0"},
        BadCase{"kit_missing_reference_length.json", kOptimize, "reference_length_mm",
                "absent, the table's radius: give workspace.table"},
        BadCase{"kit_range_over_a_turn.json", kOptimize, "angles_deg.range", "more than one turn"},
        BadCase{"kit_syntax_error.json", kOptimize, "line 5", "not valid JSON"},
        // Absurd values (README, "Limits"): refused where read, never a silent loss of rank or an
        // abort.
        BadCase{"design_ball_L_huge.json", kIdentifyDesign, "installations[0].ball_mm.L",
                "within +-10000 mm"},
        BadCase{"design_noise_huge.json", kIdentifyDesign, "noise.std_um", "[1e-4, 1e4]"},
        BadCase{"design_noise_tiny.json", kIdentifyDesign, "noise.std_um", "[1e-4, 1e4]"},
        BadCase{"design_instrument_range_huge.json", kIdentifyDesign, "instrument.range_mm",
                "to 10 mm, got 20"},
        BadCase{"design_order_huge.json", kIdentifyDesign, "errors.order", "at most 100"},
        BadCase{"design_too_many_angles.json", kIdentifyDesign, "angles_deg.step",
                "more than 100000 angles"},
        BadCase{"data_hex_float.csv", kIdentifyDataC, "line 2, column reading_mm",
                "decimal notation"},
        BadCase{"truth_angle_not_a_position.json", kSimulateC, "errors.values[2].angle_deg",
                "angle 25 deg is not a position of the design (its 19 angles, 0 .. 360 deg): a "
                "value there would be ignored"},
        BadCase{"truth_angle_twice.json", kSimulateC, "errors.values[18].angle_deg",
                "with other values"},
        BadCase{"truth_many_sweeps.json", kSimulateC, "schedule.sweeps", "more than 100 sweeps"},
        BadCase{"truth_too_many_repeats.json", kSimulateC, "repeats",
                "more than 10000000 readings"},
        BadCase{"baseline_bad_tolerance.json", kBench, "tolerance_relative", "fraction"},
        BadCase{"baseline_unknown_key.json", kBench, "designs.paper-c-turntable.json.worst_std",
                "unknown key"},
        BadCase{"tolerances_quantity_of_b.json", kTolerancesC, "limits[0].quantity",
                "'X0B' is not a quantity of axis C"},
        BadCase{"tolerances_wrong_dimension.json", kTolerancesC, "limits[0].unit",
                "X0C is a length (um)"},
        BadCase{"tolerances_unknown_unit.json", kTolerancesC, "limits[0].unit",
                "unknown unit 'microns'"},
        BadCase{"tolerances_both_forms.json", kTolerancesC, "limits[0].max_abs",
                "either max_abs or lower/upper"},
        BadCase{"tolerances_duplicate.json", kTolerancesC, "limits[1].quantity",
                "has a limit already (limits[0])"},
        BadCase{"tolerances_no_limit.json", kTolerancesC, "limits[0]",
                "needs max_abs, lower or upper (none is given)"},
        BadCase{"tolerances_reversed.json", kTolerancesC, "limits[0].upper", "must exceed lower"},
        BadCase{"tolerances_unknown_key.json", kTolerancesC, "limits[0].level", "unknown key"},
        // Silent wrong answers (a NaN, a row counted twice, an infinite zone) refused instead.
        BadCase{"design_setup_underflow.json", kIdentifyDesign, "setup_std.length_offset_um",
                "a positive tolerance is at least 0.0001 um"},
        BadCase{"design_number_underflow.json", kIdentifyDesign, "line 22",
                "below the smallest a double holds"},
        BadCase{"design_predicted_negative_time.json", kIdentifyDesign, "predicted.time_s",
                "must be a time >= 0 s"},
        BadCase{"data_duplicate_row.csv", kIdentifyDataC, "line 4",
                "the same reading as line 2 (installation 1r, angle 0 deg, repeat 0)"},
        BadCase{"data_duplicate_time.csv", kIdentifyDataC, "line 4",
                "the same time_s as line 3 (installation 1r, angle 20 deg, time_s 6), another "
                "reading_um (2.7 here, 2.5 there): two readings of one position at one time"},
        BadCase{"data_json.csv", kIdentifyDataC, "line 1",
                "this looks like JSON, not a CSV measurement file"},
        BadCase{"data_semicolons.csv", kIdentifyDataC, "line 1",
                "the delimiter is ','; this header uses ';' ('installation;angle_deg;reading_um')"},
        BadCase{"data_tabs.csv", kIdentifyDataC, "line 1",
                "the delimiter is ','; this header uses tabs"},
        BadCase{"data_same_repeat_other_time.csv", kIdentifyDataC, "line 4",
                "the same repeat as line 2 (installation 1r, angle 0 deg, repeat 0), another "
                "time_s (12 here, 0 there) and reading_um (1.6 here, 1.5 there)"},
        BadCase{"data_number_underflow.csv", kIdentifyDataC, "line 3, column reading_um",
                "below the smallest number a double holds"},
        BadCase{"data_angle_near_a_position.csv", kIdentifyDataC, "line 2",
                "angle 20.000001 deg is not a position"},
        BadCase{"truth_beyond_instrument_range.json", kSimulateC, "",
                "beyond the instrument's range of +-1 mm"},
        BadCase{"tolerances_limit_overflow.json", kTolerancesC, "limits[0].max_abs",
                "1e+307 mm is beyond +-1e9 um"}),
    [](const auto& info) {
      std::string name = info.param.file;
      for (char& ch : name) {
        if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
      }
      return name;
    });

TEST(Cli, MissingFileAndMissingOptionExitTwo) {
  CliRun r = run_cli("identify --design /nonexistent/d.json --data " + kDataC);
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("/nonexistent/d.json: cannot open"), std::string::npos) << r.err;
  r = run_cli("identify --design " + kDesignC);
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("--data"), std::string::npos) << r.err;
  r = run_cli("no-such-command");
  EXPECT_EQ(r.status, 2);
  // An option given twice: said in dbbkit's words.
  r = run_cli("identify --design " + kDesignC + " --design " + kDesignC + " --data " + kDataC);
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("--design: given 2 times; give it once"), std::string::npos) << r.err;
}

TEST(Cli, OutputOverAnInputIsRefused) {
  const std::string copy =
      (std::filesystem::temp_directory_path() / "dbbkit_cli_copy.csv").string();
  std::filesystem::copy_file(kDataC, copy, std::filesystem::copy_options::overwrite_existing);
  const CliRun r = run_cli("identify --design " + kDesignC + " --data " + copy + " --out " + copy);
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("would overwrite the input"), std::string::npos) << r.err;
  EXPECT_EQ(slurp(copy), slurp(kDataC));
  std::filesystem::remove(copy);
}

TEST(Cli, AFailedRunLeavesNoFile) {
  const std::string out =
      (std::filesystem::temp_directory_path() / "dbbkit_never_written.json").string();
  std::filesystem::remove(out);
  const CliRun r =
      run_cli("identify --design " + kDesignC + " --data " + bad("data_nan.csv") + " --out " + out);
  EXPECT_EQ(r.status, 2);
  EXPECT_FALSE(std::filesystem::exists(out));
  EXPECT_FALSE(std::filesystem::exists(out + ".tmp"));
}

TEST(Cli, OptimizeWithoutADesignLeavesOutAsItIsAndSaysWhy) {
  // The three-position kit with set-up tolerances cannot let diagnose detect them at any
  // position: exit 1, the reason once for every choice, --out untouched, --result written.
  const auto dir = std::filesystem::temp_directory_path();
  const std::string out = (dir / "dbbkit_optimize_kept.json").string();
  const std::string result = (dir / "dbbkit_optimize_result.json").string();
  { std::ofstream(out) << "kept\n"; }
  std::filesystem::remove(result);
  const std::string kit = test::source_path("designs/kits/c-turntable-kit-tolerances.json");
  const CliRun r = run_cli("optimize --kit " + kit + " --require-setup-detection --out " + out +
                           " --result " + result);
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_NE(r.err.find("252 choices"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("the axis errors take length_offset[1t]"), std::string::npos) << r.err;
  std::ifstream kept(out);
  std::string line;
  std::getline(kept, line);
  EXPECT_EQ(line, "kept");
  ASSERT_TRUE(std::filesystem::exists(result));
  std::ifstream rj(result);
  const nlohmann::json j = nlohmann::json::parse(rj);
  EXPECT_TRUE(j["best"].is_null());
  EXPECT_EQ(j["choices"].size(), 252u);
  EXPECT_EQ(j["choices"][0]["setup_detection"]["met"], false);
  std::filesystem::remove(out);
  std::filesystem::remove(result);
  // The flag without a tolerance to detect is refused (exit 2, the key named).
  const CliRun plain =
      run_cli("optimize --kit " + test::source_path("designs/kits/c-turntable-kit.json") +
              " --require-setup-detection --out " + out);
  EXPECT_EQ(plain.status, 2);
  EXPECT_NE(plain.err.find("setup_std"), std::string::npos) << plain.err;
  EXPECT_FALSE(std::filesystem::exists(out));
  // An empty criterion is asked for and names none: refused before the search, not the default.
  const CliRun empty =
      run_cli("optimize --kit " + test::source_path("designs/kits/c-turntable-kit.json") +
              " --criterion '' --out " + out);
  EXPECT_EQ(empty.status, 2);
  EXPECT_NE(empty.err.find("unknown criterion ''"), std::string::npos) << empty.err;
  EXPECT_FALSE(std::filesystem::exists(out));
}

TEST(Cli, IdentifyPaperBReportsNullsAndTheCombination) {
  const CliRun r = run_cli("identify --design " + kDesignB + " --data " +
                           test::source_path("tests/data/paper/paper_b_head.csv"));
  ASSERT_EQ(r.status, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["format"], "dbbkit.identify/1");
  EXPECT_EQ(j["rank"], 105);
  EXPECT_EQ(j["n_unknowns"], 126);
  ASSERT_EQ(j["errors"].size(), 21u);
  for (const auto& e : j["errors"]) {
    const double a = e["angle_deg"];
    for (const char* k : {"dx", "dy", "dz", "ey"}) {
      EXPECT_TRUE(e["value"][k].is_number()) << a << k;
      EXPECT_TRUE(e["std"][k].is_number()) << a << k;
    }
    EXPECT_EQ(e["value"]["ex"].is_null(), a != 0.0) << a;
    EXPECT_EQ(e["std"]["ex"].is_null(), a != 0.0) << a;
    EXPECT_EQ(e["value"]["ez"].is_null(), a != -90.0) << a;
  }
  EXPECT_EQ(j["unidentifiable"].size(), 21u);
  EXPECT_NE(j["unidentifiable"][0]["interpretation"].get<std::string>().find("tool axis"),
            std::string::npos);
  for (const char* k : {"rms_um", "chi2", "dof", "p_value"})
    EXPECT_TRUE(j["residual"].contains(k)) << k;
}

TEST(Cli, SimulateThenIdentifyRoundTrip) {
  const auto dir = std::filesystem::temp_directory_path();
  const std::string csv = (dir / "dbbkit_sim.csv").string();
  const std::string result = (dir / "dbbkit_sim.json").string();
  const std::string truth = test::source_path("tests/data/truth_c_per_angle.json");
  CliRun r =
      run_cli("simulate --design " + kDesignC + " --truth " + truth + " --seed 9 --out " + csv);
  ASSERT_EQ(r.status, 0) << r.err;
  const std::string first = slurp(csv);
  r = run_cli("simulate --design " + kDesignC + " --truth " + truth + " --seed 9");
  EXPECT_EQ(r.out, first) << "the same seed must give the same readings";
  r = run_cli("identify --design " + kDesignC + " --data " + csv + " --out " + result);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("full rank"), std::string::npos) << r.out;  // the summary table
  const nlohmann::json j = nlohmann::json::parse(slurp(result));
  // The truth is dx..ez = 1..6 at every angle.
  for (const auto& e : j["errors"]) {
    int k = 1;
    for (const char* name : {"dx", "dy", "dz", "ex", "ey", "ez"}) {
      const double v = e["value"][name], s = e["std"][name];
      EXPECT_LE(std::abs(v - k), 5 * s) << e["angle_deg"] << name;
      ++k;
    }
  }
  std::filesystem::remove(csv);
  std::filesystem::remove(result);
}

TEST(Cli, OptimizeWritesADesignThatEvaluateAndIdentifyAccept) {
  const auto dir = std::filesystem::temp_directory_path();
  const std::string best = (dir / "dbbkit_opt_best.json").string();
  const std::string result = (dir / "dbbkit_opt_result.json").string();
  const std::string front = (dir / "dbbkit_opt_front.csv").string();
  const std::string kit = test::source_path("designs/kits/c-turntable-kit.json");
  CliRun r =
      run_cli("optimize --kit " + kit + " --out " + best + " --result " + result + " --reference " +
              kDesignC + " --pareto --pareto-csv " + front + " --threads 2");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("ratio optimised / reference: 0.387"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("Pareto front"), std::string::npos) << r.out;
  const nlohmann::json res = nlohmann::json::parse(slurp(result));
  EXPECT_EQ(res["format"], "dbbkit.optimize/1");
  EXPECT_NEAR(
      res["reference"]["ratio_worst_std_um"].get<double>(),
      res["best"]["worst_std_um"].get<double>() / res["reference"]["worst_std_um"].get<double>(),
      1e-12);
  EXPECT_EQ(res["choices"].size(), 252u);  // 7 heights x 6 other heights x 6 steps
  EXPECT_FALSE(res["pareto"].empty());
  const std::string front_csv = slurp(front);
  EXPECT_EQ(front_csv.substr(0, front_csv.find('\n') + 1),
            "time_s,n_installations,n_angles,step_deg,worst_std_um,added_installations\n");
  EXPECT_NE(front_csv.find(",-\n"), std::string::npos);  // the three_position pattern adds nothing
  // The design file: evaluate recomputes the prediction it carries.
  const nlohmann::json design = nlohmann::json::parse(slurp(best));
  r = run_cli("evaluate --design " + best + " --out -");
  ASSERT_EQ(r.status, 0) << r.err;
  const nlohmann::json ev = nlohmann::json::parse(r.out);
  EXPECT_NEAR(ev["worst_std_um"].get<double>(), design["predicted"]["worst_std_um"].get<double>(),
              1e-9);
  EXPECT_EQ(ev["rank"], design["predicted"]["rank"]);
  // identify accepts it as it is: simulate readings for it and identify them.
  const std::string csv = (dir / "dbbkit_opt_sim.csv").string();
  const std::string truth = (dir / "dbbkit_opt_truth.json").string();
  std::ofstream(truth)
      << R"({"format": "dbbkit.truth/1", "seed": 4, "errors": {"model": "fourier", "order": 0,
    "coefficients": {"dx": [1], "dy": [2], "dz": [3], "ex": [4], "ey": [5], "ez": [6]}}})";
  r = run_cli("simulate --design " + best + " --truth " + truth + " --out " + csv);
  ASSERT_EQ(r.status, 0) << r.err;
  r = run_cli("identify --design " + best + " --data " + csv + " --out -");
  ASSERT_EQ(r.status, 0) << r.err;
  const nlohmann::json id = nlohmann::json::parse(r.out);
  EXPECT_EQ(id["rank"], id["n_unknowns"]);
  for (const std::string& f : {best, result, front, csv, truth}) std::filesystem::remove(f);
}

TEST(Cli, OptimizeRefusesAReferenceWithOtherNoise) {
  const std::string kit = test::source_path("designs/kits/c-turntable-kit.json");
  nlohmann::json d = nlohmann::json::parse(slurp(kDesignC));
  d["noise"] = {{"distribution", "uniform"}, {"accuracy_um", 0.5}};
  const std::string ref =
      (std::filesystem::temp_directory_path() / "dbbkit_ref_noise.json").string();
  std::ofstream(ref) << d.dump(2);
  const CliRun r = run_cli("optimize --kit " + kit + " --reference " + ref + " --out -");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("compare instruments, not designs"), std::string::npos) << r.err;
  std::filesystem::remove(ref);
}

TEST(Cli, DesignGatePassesTheCommittedDesignsAndFailsADegradedOne) {
  const std::string baseline = test::source_path("benchmarks/designs-baseline.json");
  std::string all;
  for (const auto& e : std::filesystem::directory_iterator(test::source_path("designs"))) {
    if (e.path().extension() == ".json") all += " " + e.path().string();
  }
  CliRun r = run_cli("bench" + all + " --baseline " + baseline);
  EXPECT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_NE(r.out.find(" 0 worse than the baseline"), std::string::npos) << r.out;
  // Degrade the paper C design under the same file name (the baseline key): the second ball
  // moves in from 200 to 130 mm, the positions crowd together, and the gate fails.
  const auto dir = std::filesystem::temp_directory_path() / "dbbkit_gate";
  std::filesystem::create_directories(dir);
  nlohmann::json d = nlohmann::json::parse(slurp(kDesignC));
  for (auto& in : d["installations"]) {
    if (in["id"] == "2r" || in["id"] == "2t") in["ball_mm"]["L"] = 130;  // L2 from 200 to 130 mm
  }
  const std::string degraded = (dir / "paper-c-turntable.json").string();
  std::ofstream(degraded) << d.dump(2);
  r = run_cli("bench " + degraded + " --baseline " + baseline);
  EXPECT_EQ(r.status, 1) << r.out << r.err;
  EXPECT_NE(r.out.find("worse"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("worst_std_um 2.0565 ->"), std::string::npos) << r.out;
  // A rank loss fails too: drop the axial reading (dz is then seen by no reading).
  nlohmann::json e = nlohmann::json::parse(slurp(kDesignC));
  nlohmann::json kept = nlohmann::json::array();
  for (auto& in : e["installations"]) {
    if (in["id"] != "1a") kept.push_back(in);
  }
  e["installations"] = kept;
  std::ofstream(degraded) << e.dump(2);
  r = run_cli("bench " + degraded + " --baseline " + baseline);
  EXPECT_EQ(r.status, 1) << r.out << r.err;
  EXPECT_NE(r.out.find("rank deficiency 0 -> 18"), std::string::npos) << r.out;
  // The total with declared set-up tolerances is guarded too: a larger centring
  // tolerance on 3r leaves worst_std_um alone and raises worst_total_std_um.
  const std::string with_setup =
      test::source_path("designs/c-turntable-kit-optimized-with-setup.json");
  nlohmann::json t = nlohmann::json::parse(slurp(with_setup));
  for (auto& in : t["installations"]) {
    if (in["id"] == "3r") in["setup_std"] = {{"centring_um", 20}};
  }
  const std::string degraded_total = (dir / "c-turntable-kit-optimized-with-setup.json").string();
  std::ofstream(degraded_total) << t.dump(2);
  r = run_cli("bench " + degraded_total + " --baseline " + baseline);
  EXPECT_EQ(r.status, 1) << r.out << r.err;
  EXPECT_NE(r.out.find("worst_total_std_um 12.362 ->"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("worst_std_um 0.79629 ->"), std::string::npos) << r.out;
  // Removing the tolerances does not slip through either.
  t.erase("setup_std");
  for (auto& in : t["installations"]) in.erase("setup_std");
  std::ofstream(degraded_total) << t.dump(2);
  r = run_cli("bench " + degraded_total + " --baseline " + baseline);
  EXPECT_EQ(r.status, 1) << r.out << r.err;
  EXPECT_NE(r.out.find("declares no set-up tolerance"), std::string::npos) << r.out;
  std::filesystem::remove_all(dir);
}

TEST(Cli, DesignGateFailsNewDesignsAndLimitsAndWritesSummaryAndJUnit) {
  const std::string baseline = test::source_path("benchmarks/designs-baseline.json");
  const auto dir = std::filesystem::temp_directory_path() / "dbbkit_gate_checks";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  // A design the baseline does not know fails, unless --allow-new.
  const std::string fresh = (dir / "fresh-design.json").string();
  std::filesystem::copy_file(kDesignC, fresh);
  CliRun r = run_cli("bench " + fresh + " --baseline " + baseline);
  EXPECT_EQ(r.status, 1) << r.out << r.err;
  EXPECT_NE(r.out.find("no baseline for this design"), std::string::npos) << r.out;
  r = run_cli("bench " + fresh + " --baseline " + baseline + " --allow-new");
  EXPECT_EQ(r.status, 0) << r.out << r.err;
  // Absolute limits: the paper's C design has worst_std_um 2.0565 um, no set-up tolerance
  // and no predicted time; the optimised kit design states its time (1869 s).
  const std::string optimised = test::source_path("designs/c-turntable-kit-optimized.json");
  r = run_cli("bench " + kDesignC + " --baseline " + baseline + " --max-worst-std-um 2.1");
  EXPECT_EQ(r.status, 0) << r.out << r.err;
  r = run_cli("bench " + kDesignC + " --baseline " + baseline + " --max-worst-std-um 2.0");
  EXPECT_EQ(r.status, 1) << r.out << r.err;
  EXPECT_NE(r.out.find("FAIL max_worst_std_um: 2.0565 um > 2 um"), std::string::npos) << r.out;
  r = run_cli("bench " + kDesignC + " --baseline " + baseline + " --max-worst-total-std-um 50");
  EXPECT_EQ(r.status, 1) << r.out << r.err;
  EXPECT_NE(r.out.find("declares no set-up tolerance"), std::string::npos) << r.out;
  r = run_cli("bench " + optimised + " --baseline " + baseline + " --max-time-s 2000");
  EXPECT_EQ(r.status, 0) << r.out << r.err;
  r = run_cli("bench " + kDesignC + " --baseline " + baseline + " --max-time-s 2000");
  EXPECT_EQ(r.status, 1) << r.out << r.err;
  EXPECT_NE(r.out.find("states no measurement time"), std::string::npos) << r.out;
  // The Markdown summary and the JUnit XML, read back by a JUnit consumer (junitparser):
  // two designs, the baseline and two limit checks each; the paper's design fails the time.
  const std::string md = (dir / "gate.md").string(), xml = (dir / "gate.xml").string();
  r = run_cli("bench " + kDesignC + " " + optimised + " --baseline " + baseline +
              " --max-worst-std-um 2.1 --max-time-s 2000 --summary " + md + " --junit " + xml);
  EXPECT_EQ(r.status, 1) << r.out << r.err;
  EXPECT_NE(r.out.find("wrote --junit " + xml), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("wrote --summary " + md), std::string::npos) << r.out;
  const std::string summary = slurp(md);
  EXPECT_NE(summary.find("| paper-c-turntable.json | C |"), std::string::npos) << summary;
  EXPECT_NE(summary.find("FAIL: max_time_s"), std::string::npos) << summary;
  const std::string script = (dir / "read.py").string();
  std::ofstream(script)
      << "import sys\n"
         "from junitparser import JUnitXml, Failure\n"
         "xml = JUnitXml.fromfile(sys.argv[1])\n"
         "for suite in xml:\n"
         "    print('suite', suite.name, suite.tests, suite.failures)\n"
         "    for case in suite:\n"
         "        failed = [r for r in case.result if isinstance(r, Failure)]\n"
         "        print('case', case.classname, case.name, 'FAIL' if failed else 'pass',\n"
         "              failed[0].message if failed else '')\n";
  const CliRun parsed = run_cli_shell("/usr/bin/python3 " + script + " " + xml);
  ASSERT_EQ(parsed.status, 0) << parsed.err;
  EXPECT_NE(parsed.out.find("suite dbbkit bench 6 1"), std::string::npos) << parsed.out;
  EXPECT_NE(parsed.out.find("case bench.paper-c-turntable.json max_time_s FAIL the design states "
                            "no measurement time"),
            std::string::npos)
      << parsed.out;
  EXPECT_NE(parsed.out.find("case bench.c-turntable-kit-optimized.json max_time_s pass"),
            std::string::npos)
      << parsed.out;
  EXPECT_NE(parsed.out.find("case bench.paper-c-turntable.json baseline pass"), std::string::npos)
      << parsed.out;
  // --junit -: standard output holds the XML alone (the table goes to the error stream).
  r = run_cli("bench " + kDesignC + " --baseline " + baseline + " --junit -");
  EXPECT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_EQ(r.out.rfind("<?xml", 0), 0u) << r.out;
  EXPECT_NE(r.err.find("1 designs, 0 worse than the baseline, 0 failed"), std::string::npos)
      << r.err;
  std::filesystem::remove_all(dir);
}

TEST(Cli, TheTotalCriterionNeedsDeclaredTolerances) {
  const CliRun r =
      run_cli("optimize --quiet --kit " + test::source_path("designs/kits/c-turntable-kit.json") +
              " --criterion worst_total");
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_NE(r.err.find("setup_std"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("needs a length offset or centring tolerance"), std::string::npos) << r.err;
  EXPECT_TRUE(r.out.empty()) << r.out;
}

TEST(Cli, ATerminalGetsTablesAPipeGetsJson) {
  // script(1) (util-linux, in every Debian) runs the command on a pseudo-terminal.
  const std::string cmd = "identify --design " + kDesignC + " --data " + kDataC;
  const CliRun tty =
      run_cli_shell("script -qec '" + std::string(DBBKIT_CLI) + " " + cmd + "' /dev/null");
  ASSERT_EQ(tty.status, 0) << tty.err;
  EXPECT_NE(tty.out.find("full rank: 108 unknowns from 133 readings"), std::string::npos)
      << tty.out.substr(0, 500);
  EXPECT_EQ(tty.out.find("\"format\""), std::string::npos) << "no JSON on a terminal without --out";
  const CliRun pipe = run_cli(cmd);
  ASSERT_EQ(pipe.status, 0) << pipe.err;
  EXPECT_EQ(nlohmann::json::parse(pipe.out)["format"], "dbbkit.identify/1");
  const CliRun quiet =
      run_cli_shell("script -qec '" + std::string(DBBKIT_CLI) + " " + cmd + " --quiet' /dev/null");
  ASSERT_EQ(quiet.status, 0) << quiet.err;
  EXPECT_EQ(quiet.out.find("full rank"), std::string::npos) << quiet.out;
}

// --quiet leaves only the files asked for, in every command, on a terminal and in a pipe; and
// optimize without --out behaves as the others: the summary on a terminal, the design in a pipe.
TEST(Cli, QuietLeavesOnlyTheFilesAskedForAndOptimizeMatchesTheOthers) {
  const auto dir = std::filesystem::temp_directory_path() / "dbbkit_quiet";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string d = dir.string() + "/";
  const std::string kit = test::source_path("designs/kits/b-head-kit-on-axis.json");
  const std::string truth = test::source_path("tests/data/truth_c_per_angle.json");
  const std::vector<std::pair<std::string, std::string>> commands = {
      {"evaluate --design " + kDesignC + " --out " + d + "e.json --summary " + d + "e.md",
       "e.json"},
      {"identify --design " + kDesignC + " --data " + kDataC + " --out " + d + "i.json", "i.json"},
      {"diagnose --design " + kDesignC + " --data " + kDataC + " --out " + d + "d.json", "d.json"},
      {"simulate --design " + kDesignC + " --truth " + truth + " --out " + d + "s.csv", "s.csv"},
      {"optimize --kit " + kit + " --out " + d + "o.json --result " + d + "r.json", "o.json"},
      {"bench " + kDesignC + " --allow-new --summary " + d + "b.md", "b.md"},
      {"program --design " + kDesignC + " --dialect iso --out " + d + "p.nc", "p.nc"},
      {"setup-sheet --design " + kDesignC + " --summary " + d + "s.md", "s.md"},
  };
  for (const auto& [cmd, file] : commands) {
    for (bool tty : {false, true}) {
      std::filesystem::remove(d + file);
      const std::string line = std::string(DBBKIT_CLI) + " " + cmd + " --quiet";
      const CliRun r =
          tty ? run_cli_shell("script -qec '" + line + "' /dev/null") : run_cli_shell(line);
      EXPECT_EQ(r.status, 0) << cmd << "\n" << r.err;
      EXPECT_EQ(r.out, "") << cmd << (tty ? " (terminal)" : " (pipe)");
      EXPECT_EQ(r.err, "") << cmd << (tty ? " (terminal)" : " (pipe)");
      EXPECT_TRUE(std::filesystem::exists(d + file)) << cmd;
    }
  }
  const std::string optimize = std::string(DBBKIT_CLI) + " optimize --kit " + kit;
  const CliRun tty = run_cli_shell("script -qec '" + optimize + "' /dev/null");
  ASSERT_EQ(tty.status, 0) << tty.err;
  EXPECT_EQ(tty.out.find("\"format\""), std::string::npos) << "no JSON on a terminal without --out";
  EXPECT_NE(tty.out.find("worst"), std::string::npos) << tty.out.substr(0, 500);
  const CliRun pipe = run_cli_shell(optimize);
  ASSERT_EQ(pipe.status, 0) << pipe.err;
  EXPECT_EQ(nlohmann::json::parse(pipe.out)["format"], "dbbkit.design/1");
  std::filesystem::remove_all(dir);
}

TEST(Report, Sha256KnownVectors) {
  EXPECT_EQ(io::sha256_hex(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(io::sha256_hex("abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(io::sha256_hex(std::string(1000000, 'a')),
            "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
}

TEST(Report, IdentifyWritesHtmlWithPlotsAndAMarkdownSummary) {
  const auto dir = std::filesystem::temp_directory_path();
  const std::string html = (dir / "dbbkit_report.html").string(),
                    md = (dir / "dbbkit_report.md").string();
  const CliRun r = run_cli("identify --design " + kDesignC + " --data " + kDataC +
                           " --out - --report " + html + " --summary " + md);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["format"],
            "dbbkit.identify/1");  // --out -: JSON alone on stdout
  const std::string h = slurp(html), m = slurp(md);
  int plots = 0;
  for (size_t at = h.find("<figure class=\"plot\"><svg"); at != std::string::npos;
       at = h.find("<figure class=\"plot\"><svg", at + 1)) {
    ++plots;
  }
  EXPECT_EQ(plots, 4);  // design, errors, residual panels, residual polar trace
  EXPECT_EQ(h.find("src=\"http"), std::string::npos) << "the report must not fetch anything";
  const std::string hash = io::sha256_file(kDesignC);
  for (const std::string* page : {&h, &m}) {
    EXPECT_NE(page->find(hash), std::string::npos)
        << "the design's SHA-256 is part of the conditions";
    EXPECT_NE(page->find("Uncertainty budget (JCGM 100)"), std::string::npos);
  }
  EXPECT_NE(m.find("| angle [deg] | dx ± U [um] |"), std::string::npos) << m.substr(0, 2000);
  EXPECT_NE(m.find("| 20 | 36.09 ± 2.19 |"), std::string::npos) << "a row of the errors table";
  EXPECT_EQ(m.find("<svg"), std::string::npos);
  std::filesystem::remove(html);
  std::filesystem::remove(md);
}

}  // namespace
}  // namespace dbbkit

namespace dbbkit {
namespace {

TEST(Cli, SimulateExactGeometryWritesTheSetUpErrorsUsed) {
  const auto dir = std::filesystem::temp_directory_path();
  const std::string csv = (dir / ("dbbkit_exact_" + std::to_string(::getpid()) + ".csv")).string();
  const std::string setup = csv + ".setup.json";
  const CliRun r =
      run_cli("simulate --design " + test::source_path("designs/paper-c-turntable.json") +
              " --truth " + test::source_path("tests/data/truth_exact_setup.json") + " --out " +
              csv + " --setup-out " + setup);
  ASSERT_EQ(r.status, 0) << r.err;
  const nlohmann::json s = nlohmann::json::parse(slurp(setup));
  EXPECT_EQ(s["format"], "dbbkit.setup-errors/1");
  ASSERT_EQ(s["installations"].size(), 7u);
  int drawn_nonzero = 0;
  for (const auto& in : s["installations"]) {
    if (in["id"] == "3r") {
      EXPECT_EQ(in["centring_um"], nlohmann::json({6.0, -3.0, 0.0}));
      EXPECT_EQ(in["length_offset_um"], 0.0);
    } else {
      drawn_nonzero += in["length_offset_um"].get<double>() != 0.0;
    }
  }
  EXPECT_EQ(drawn_nonzero, 6);
  // A zero (D of a ball without lateral tolerance) is written 0, never -0.
  EXPECT_EQ(slurp(setup).find("-0.0,"), std::string::npos);
  EXPECT_EQ(slurp(setup).find("-0.0\n"), std::string::npos);
  // A first-order truth has no set-up errors to write: refused, and no file is left.
  std::filesystem::remove(csv);
  std::filesystem::remove(setup);
  const CliRun bad =
      run_cli("simulate --design " + test::source_path("designs/paper-c-turntable.json") +
              " --truth " + test::source_path("tests/data/truth_c_per_angle.json") + " --out " +
              csv + " --setup-out " + setup);
  EXPECT_EQ(bad.status, 2);
  EXPECT_NE(bad.err.find("--setup-out"), std::string::npos) << bad.err;
  EXPECT_FALSE(std::filesystem::exists(csv));
  EXPECT_FALSE(std::filesystem::exists(setup));
}

}  // namespace
}  // namespace dbbkit

namespace dbbkit {
namespace {

// evaluate --coverage p states U = k u with k the normal quantile for p (Boost here), in the
// sentence and in every value of the table, at 0.95 and 0.99 alike.
TEST(Report, EvaluateStatesTheCoverageAskedFor) {
  const auto dir = std::filesystem::temp_directory_path();
  const std::string md = (dir / "dbbkit_coverage.md").string();
  for (double p : {0.95, 0.99}) {
    char arg[32];
    std::snprintf(arg, sizeof arg, "%g", p);
    const CliRun r = run_cli("evaluate --design " + kDesignC + " --coverage " + arg +
                             " --out - --summary " + md);
    ASSERT_EQ(r.status, 0) << r.err;
    const double u_dx0 = nlohmann::json::parse(r.out)["errors"][0]["std"]["dx"];
    const double k = boost::math::quantile(boost::math::normal(), 0.5 * (1 + p));
    char sentence[64], row[64];
    std::snprintf(sentence, sizeof sentence, "U = %.4g u (%g %%, infinite", k, 100 * p);
    std::snprintf(row, sizeof row, "| 0 | %.2f |", k * u_dx0);
    const std::string m = slurp(md);
    EXPECT_NE(m.find(sentence), std::string::npos) << sentence;
    EXPECT_NE(m.find(row), std::string::npos) << row;
  }
  std::filesystem::remove(md);
}

}  // namespace
}  // namespace dbbkit

namespace dbbkit {
namespace {

// The reports name what a person needs: the effects a design cannot detect (evaluate), the
// change of the errors (diagnose, the figures of the JSON), the runner-up designs (optimize).
TEST(Cli, ReportsListUndetectableEffectsTheChangeOfTheErrorsAndRunnerUps) {
  const auto dir = std::filesystem::temp_directory_path() / "dbbkit_report_sections";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string d = dir.string() + "/";
  CliRun r = run_cli("evaluate --design " + kDesignC + " --summary " + d + "e.md --quiet");
  ASSERT_EQ(r.status, 0) << r.err;
  const std::string e = slurp(d + "e.md");
  EXPECT_NE(e.find("## Effects this design cannot detect"), std::string::npos);
  EXPECT_NE(e.find("| length_offset[1t] | taken by the axis errors |"), std::string::npos);
  EXPECT_NE(e.find("| drift[1r] | not applicable to these readings |"), std::string::npos);
  r = run_cli("diagnose --design " + kDesignC + " --data " + kDataC + " --out " + d +
              "g.json --summary " + d + "g.md --quiet");
  ASSERT_EQ(r.status, 0) << r.err;
  const nlohmann::json g = nlohmann::json::parse(slurp(d + "g.json"));
  const std::string md = slurp(d + "g.md");
  ASSERT_NE(md.find("## Change of the errors"), std::string::npos);
  const double dx = g["largest_change_of_errors"]["dx"].get<double>();
  std::ostringstream row;
  row << "| dx | " << std::round(dx * 1000) / 1000 << " um |";
  EXPECT_NE(md.find(row.str()), std::string::npos) << row.str();
  r = run_cli("optimize --kit " + test::source_path("designs/kits/c-turntable-kit.json") +
              " --summary " + d + "o.md --quiet");
  ASSERT_EQ(r.status, 0) << r.err;
  const std::string o = slurp(d + "o.md");
  EXPECT_NE(o.find("## Runner-up designs"), std::string::npos);
  EXPECT_NE(o.find("| H1 = 45 mm (cup on the table), H3 = 145 mm (cup of 45 mm on block 100 mm), "
                   "step 45 deg |"),
            std::string::npos);
  std::filesystem::remove_all(dir);
}

// The paper's B design lacks the rotation about the tool line at every L: a map over L1 is
// undetermined everywhere. The report says so instead of failing in the plot, and the map's
// CSV is written.
TEST(Cli, ADesignMapUndeterminedEverywhereIsReportedNotPlotted) {
  const std::string dir =
      (std::filesystem::temp_directory_path() / ("dbbkit_map_" + std::to_string(::getpid())))
          .string();
  std::filesystem::create_directories(dir);
  const CliRun r = run_cli("evaluate --design " + kDesignB + " --sweep L1=100:200:50 --report " +
                           dir + "/e.html --map-csv " + dir + "/m.csv --quiet");
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_NE(slurp(dir + "/e.html").find("undetermined everywhere"), std::string::npos);
  const std::string csv = slurp(dir + "/m.csv");
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 4) << csv;  // the header and 3 points
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace dbbkit
