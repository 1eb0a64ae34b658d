// The set-up sheet: the order against an exhaustive search over every order that keeps each
// ball position's installations together, the rounded design scored and checked again, and
// the command for every committed design.
#include "dbbkit/setup_sheet.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <random>
#include <sstream>
#include <tuple>

#include "cli_util.hpp"
#include "dbbkit/error.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/kit_io.hpp"
#include "dbbkit/io/setup_sheet_io.hpp"
#include "dbbkit/observability.hpp"
#include "test_util.hpp"

namespace dbbkit {
namespace {

// (stack changes, bar changes, cup moves) along an order of installations, counted here.
std::tuple<int, int, int> changes(const Design& d, const std::vector<int>& order) {
  int stacks = 0, bars = 0, cups = 0;
  for (size_t k = 1; k < order.size(); ++k) {
    const Installation &a = d.installations[order[k - 1]], &b = d.installations[order[k]];
    const bool same_place = a.L_mm == b.L_mm && a.D_mm == b.D_mm && a.H_mm == b.H_mm;
    cups += !same_place;
    stacks += a.H_mm != b.H_mm;  // no cup and blocks given: the stack is the height
    bars += *a.bar_mm != *b.bar_mm;
  }
  return {stacks, bars, cups};
}

// The least (stack, bar, cup) over every order that keeps each position's installations
// together: every order of the positions times every order within each position.
std::tuple<int, int, int> exhaustive_least(const Design& d) {
  std::vector<std::vector<int>> groups;
  for (int i = 0; i < static_cast<int>(d.installations.size()); ++i) {
    const Installation& in = d.installations[i];
    auto it = std::find_if(groups.begin(), groups.end(), [&](const std::vector<int>& g) {
      const Installation& o = d.installations[g[0]];
      return o.L_mm == in.L_mm && o.D_mm == in.D_mm && o.H_mm == in.H_mm;
    });
    if (it == groups.end())
      groups.push_back({i});
    else
      it->push_back(i);
  }
  std::tuple<int, int, int> least{1 << 20, 0, 0};
  std::vector<int> perm(groups.size());
  for (size_t g = 0; g < groups.size(); ++g) perm[g] = static_cast<int>(g);
  do {
    // Every within-group order: walk all combinations of permutations.
    std::vector<std::vector<int>> inner(groups.size());
    for (size_t g = 0; g < groups.size(); ++g) {
      inner[g] = groups[g];
      std::sort(inner[g].begin(), inner[g].end());
    }
    for (;;) {
      std::vector<int> order;
      for (int g : perm) order.insert(order.end(), inner[g].begin(), inner[g].end());
      least = std::min(least, changes(d, order));
      size_t g = 0;
      while (g < inner.size() && !std::next_permutation(inner[g].begin(), inner[g].end())) ++g;
      if (g == inner.size()) break;
    }
  } while (std::next_permutation(perm.begin(), perm.end()));
  return least;
}

Design random_c_design(std::mt19937_64& rng) {
  Design d;
  d.name = "random";
  d.axis = test::kAxisC;
  d.angles_deg = {0, 90, 180, 270, 360};
  d.reference_length_mm = 100;
  const int positions = 2 + static_cast<int>(rng() % 4);
  int id = 0;
  for (int p = 0; p < positions; ++p) {
    const double L = 40.0 * (p + 1), H = std::vector<double>{45, 95, 145}[rng() % 3];
    const int n = 1 + static_cast<int>(rng() % 3);
    for (int k = 0; k < n; ++k) {
      Installation in;
      in.id = std::to_string(id++);
      in.L_mm = L;
      in.H_mm = H;
      in.direction = Direction::named(test::kAxisC, static_cast<Direction::Kind>(k % 3));
      in.bar_mm = std::vector<double>{100, 150, 250}[rng() % 3];
      d.installations.push_back(in);
    }
  }
  // Shuffle the installations so that the design's order is rarely the best.
  std::shuffle(d.installations.begin(), d.installations.end(), rng);
  return d;
}

TEST(SetupOrder, IsTheLeastOverEveryOrderOfThePositions) {
  std::mt19937_64 rng(7);
  int better_than_design = 0;
  for (int trial = 0; trial < 60; ++trial) {
    const Design d = random_c_design(rng);
    const SetupOrder o = setup_order(d);
    ASSERT_TRUE(o.exhaustive);
    std::vector<int> order;
    for (const SetupStep& s : o.steps) order.push_back(s.installation);
    std::vector<int> sorted = order;
    std::sort(sorted.begin(), sorted.end());
    for (size_t i = 0; i < sorted.size(); ++i) ASSERT_EQ(sorted[i], static_cast<int>(i));
    const auto got = changes(d, order);
    EXPECT_EQ(std::get<0>(got), o.stack_changes);
    EXPECT_EQ(std::get<1>(got), o.bar_changes);
    EXPECT_EQ(std::get<2>(got), o.cup_moves);
    const auto least = exhaustive_least(d);
    // Stack changes, then bar changes, are the least; the design's order may be kept when it
    // moves the cup more but changes no stack or bar more.
    EXPECT_EQ(std::get<0>(got), std::get<0>(least)) << "trial " << trial;
    EXPECT_EQ(std::get<1>(got), std::get<1>(least)) << "trial " << trial;
    std::vector<int> given(d.installations.size());
    for (size_t i = 0; i < given.size(); ++i) given[i] = static_cast<int>(i);
    better_than_design += got < changes(d, given);
    // The flags agree with the order.
    for (size_t k = 0; k < o.steps.size(); ++k) {
      if (k == 0) {
        EXPECT_TRUE(o.steps[k].moves_cup && o.steps[k].changes_bar && o.steps[k].changes_stack);
        continue;
      }
      const Installation &a = d.installations[order[k - 1]], &b = d.installations[order[k]];
      EXPECT_EQ(o.steps[k].changes_bar, *a.bar_mm != *b.bar_mm);
      EXPECT_EQ(o.steps[k].changes_stack, a.H_mm != b.H_mm);
    }
  }
  EXPECT_GT(better_than_design, 30) << "the shuffled designs' own orders are rarely the best";
}

TEST(SetupOrder, KeepsTheDesignsOrderWhenNoneChangesLess) {
  const Design d = test::paper_design('C');
  const SetupOrder o = setup_order(d);
  for (size_t k = 0; k < o.steps.size(); ++k)
    EXPECT_EQ(o.steps[k].installation, static_cast<int>(k));
  EXPECT_EQ(o.stack_changes, 1);  // H1 to H3 once
  EXPECT_EQ(o.bar_changes, 0);
}

// The sheet's table lists the steps in the set-up order: each row's spindle ball, sweep and
// readings are its own installation's (the program's installations come in that order, not the
// design's), as the step's instructions below state them.
TEST(SetupSheet, EachRowIsItsOwnInstallationsWhenTheOrderDiffersFromTheDesigns) {
  Design d = test::paper_design('C');
  // Interleave the positions: 1r 2r 1t 2t 1a 3r 3t, which the sheet regroups.
  std::vector<Installation> ins = d.installations;  // 1r 1t 1a 2r 2t 3r 3t
  d.installations = {ins[0], ins[3], ins[1], ins[4], ins[2], ins[5], ins[6]};
  const SetupSheet sheet = make_setup_sheet(d, ProgramOptions{}, std::nullopt, nullptr);
  bool reordered = false;
  for (size_t k = 0; k < sheet.order.steps.size(); ++k)
    reordered = reordered || sheet.order.steps[k].installation != static_cast<int>(k);
  ASSERT_TRUE(reordered);
  const std::string md =
      io::setup_sheet_report(io::ReportFormat::kMarkdown, io::RunContext{"test", {}}, sheet, "");
  for (size_t k = 0; k < sheet.order.steps.size(); ++k) {
    const Installation& in = d.installations[sheet.order.steps[k].installation];
    const std::string row_start = "| " + std::to_string(k + 1) + " | " + in.id + " |";
    const size_t row = md.find(row_start);
    ASSERT_NE(row, std::string::npos) << row_start;
    const std::string line = md.substr(row, md.find('\n', row) - row);
    const size_t step = md.find("## Step " + std::to_string(k + 1) + ": installation " + in.id);
    ASSERT_NE(step, std::string::npos);
    const size_t at = md.find("with the spindle's ball at ", step);
    ASSERT_NE(at, std::string::npos);
    const size_t from = at + std::string("with the spindle's ball at ").size();
    const std::string xyz = md.substr(from, md.find(" mm.", from) - from);
    EXPECT_NE(line.find("| " + xyz + " |"), std::string::npos) << line << " / " << xyz;
  }
}

TEST(RoundDesign, RoundsScoresAgainAndChecksTheTravel) {
  Design d = test::paper_design('C');
  for (Installation& in : d.installations) in.bar_mm = 150;
  d.installations[0].L_mm = d.installations[1].L_mm = 100.3;  // 1r, 1t
  const RoundedDesign r = round_design(d, 1.0, nullptr);
  EXPECT_DOUBLE_EQ(r.design.installations[0].L_mm, 100);
  EXPECT_NEAR(r.largest_shift_mm, 0.3, 1e-12);
  EXPECT_FALSE(r.travel_checked);
  const WorstCase before = design_worst_case(d, *d.reference_length_mm);
  const WorstCase after = design_worst_case(r.design, *d.reference_length_mm);
  EXPECT_EQ(r.worst_std_um, before.worst_std_um);
  EXPECT_EQ(r.rounded_worst_std_um, after.worst_std_um);
  EXPECT_NE(*r.worst_std_um, *r.rounded_worst_std_um);
  EXPECT_FALSE(r.worst_total_std_um);  // the paper's design declares no set-up tolerances
  // With them, the total as given and as rounded, each as evaluate_design states it.
  Design declared = d;
  declared.setup_std.length_offset_um = 1;
  declared.setup_std.centring_um = 5;
  const RoundedDesign rt = round_design(declared, 1.0, nullptr);
  ASSERT_TRUE(rt.worst_total_std_um && rt.rounded_worst_total_std_um);
  const Evaluation eb = evaluate_design(declared, *d.reference_length_mm);
  const Evaluation ea = evaluate_design(rt.design, *d.reference_length_mm);
  ASSERT_TRUE(eb.worst_total && ea.worst_total);
  EXPECT_NEAR(*rt.worst_total_std_um, *eb.worst_total->worst_std_um, 1e-9);
  EXPECT_NEAR(*rt.rounded_worst_total_std_um, *ea.worst_total->worst_std_um, 1e-9);
  EXPECT_GT(*rt.rounded_worst_total_std_um, *rt.rounded_worst_std_um);
  // 1r's following ball circles at |100.3 - 150| = 49.7 mm; rounded, at 50 mm. A travel of
  // +-49.8 mm in x and y holds the design as given, not as rounded.
  Kit kit = io::read_kit_file(test::source_path("designs/kits/c-turntable-kit.json"));
  kit.travel_mm = {Interval{-49.8, 49.8}, Interval{-400, 400}, Interval{-200, 500}};
  Design only = d;
  only.installations = {d.installations[0]};
  EXPECT_LE(travel_violation_mm(kit, test::kAxisC, only.installations[0], d.angles_deg), 0);
  const RoundedDesign t = round_design(only, 1.0, &kit);
  ASSERT_TRUE(t.travel_checked);
  ASSERT_EQ(t.outside_travel.size(), 1u);
  EXPECT_EQ(t.outside_travel[0].first, "1r");
  EXPECT_NEAR(t.outside_travel[0].second, 0.2, 1e-9);
  EXPECT_THROW(round_design(d, 0, nullptr), InputError);
}

TEST(SetupSheetCli, EveryCommittedDesignHasASheet) {
  int designs = 0;
  for (const auto& entry : std::filesystem::directory_iterator(DBBKIT_SOURCE_DIR "/designs")) {
    if (entry.path().extension() != ".json") continue;
    const Design d = io::read_design_file(entry.path().string());
    const CliRun r = run_cli("setup-sheet --design " + entry.path().string());
    ASSERT_EQ(r.status, 0) << entry.path() << r.err;
    EXPECT_NE(r.out.find("Order: "), std::string::npos) << entry.path();
    for (const Installation& in : d.installations)
      EXPECT_NE(r.out.find(": installation " + in.id + "\n"), std::string::npos) << in.id;
    ++designs;
  }
  EXPECT_GE(designs, 8);
}

// On a machine, each cup's stack is given by the ball's height above the table: on the B/C
// trunnion the B test's L runs along the table's normal from the B axis, the surface 50 mm
// below it (a hand derivation: L 0, 100, 200 mm stand 50, 150, 250 mm above the surface).
TEST(SetupSheetCli, OnAMachineEachCupsHeightAboveTheTableIsStated) {
  const CliRun r =
      run_cli("setup-sheet --design " DBBKIT_SOURCE_DIR "/designs/b-c-trunnion-B.json --tcpm on");
  ASSERT_EQ(r.status, 0) << r.err;
  for (const char* h : {"50", "150", "250"})
    EXPECT_NE(r.out.find(std::string("its centre ") + h + " mm above the surface of the C table"),
              std::string::npos)
        << h << "\n"
        << r.out;
  EXPECT_EQ(r.out.find("rebuild the stack to H"), std::string::npos) << r.out;
  // Under TCPM the sheet also names the start in the workpiece frame, as the program does: the
  // 1r start at B -30 (a hand derivation: L 100 + 150 along +Z turned by -30 deg about +Y:
  // X -125, Z 216.506) is X 0, Z 250 on the table at B 0.
  EXPECT_NE(r.out.find("with the spindle's ball at X -125, Y 60, Z 216.506 mm (X 0, Y 60, Z 250 "
                       "mm in the workpiece frame"),
            std::string::npos)
      << r.out;
}

TEST(SetupSheetCli, WithAKitItStatesSetUpTimesRoundsAndDrawsEachStep) {
  const auto dir = std::filesystem::temp_directory_path() / "dbbkit_setup_sheet_test";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string kit = test::source_path("designs/kits/c-turntable-kit.json");
  const std::string design = test::source_path("designs/c-turntable-kit-optimized.json");
  const std::string html = (dir / "s.html").string();
  CliRun r = run_cli("setup-sheet --design " + design + " --kit " + kit +
                     " --resolution-mm 0.5 --report " + html);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("rounded to 0.5 mm"), std::string::npos) << r.out;
  const std::string page = slurp(html);
  const Design d = io::read_design_file(design);
  size_t svgs = 0;
  for (size_t at = page.find("<svg"); at != std::string::npos; at = page.find("<svg", at + 1))
    ++svgs;
  EXPECT_EQ(svgs, d.installations.size());
  EXPECT_NE(page.find("Time, by the kit&#39;s model"), std::string::npos);
  // The drawings' captions stay within their 320 px panels (at most 6.6 px per character at
  // 12 px): the two views' titles never run into each other.
  int captions = 0;
  for (size_t at = page.find("font-size='12'>"); at != std::string::npos;
       at = page.find("font-size='12'>", at + 1)) {
    const size_t from = at + std::string("font-size='12'>").size();
    const std::string text = page.substr(from, page.find("</text>", from) - from);
    EXPECT_LE(6.6 * static_cast<double>(text.size()), 320 - 12) << text;
    ++captions;
  }
  EXPECT_GE(captions, 2 * static_cast<int>(d.installations.size()));
  // A kit of the other axis is refused, naming it.
  r = run_cli("setup-sheet --design " + design + " --kit " +
              test::source_path("designs/kits/b-head-kit.json"));
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("--kit"), std::string::npos) << r.err;
  // optimize --report closes with the best design's sheet.
  const std::string report = (dir / "o.md").string();
  r = run_cli("optimize --kit " + test::source_path("designs/kits/b-head-kit-on-axis.json") +
              " --summary " + report + " --quiet");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(slurp(report).find("## Set-up sheet: "), std::string::npos);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace dbbkit

namespace dbbkit {
namespace {

// The README's journey (kit -> optimize -> set-up sheet -> program -> simulate -> identify ->
// diagnose) prints what the README shows: every output line of its section (the lines in its
// text blocks and the sheet's table rows; "..." and the elapsed time aside) is printed by the
// commands it names, run here on the same files.
TEST(Readme, TheJourneyPrintsWhatTheReadmeShows) {
  const std::string section =
      readme_section("## Worked example: from the kit to the machine and back");
  ASSERT_FALSE(section.empty());
  const auto dir = std::filesystem::temp_directory_path() / "dbbkit_readme_journey";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string cli = DBBKIT_CLI;
  const std::string cd = "cd " + dir.string() + " && ";
  const std::string src = DBBKIT_SOURCE_DIR;
  std::string printed;
  for (const std::string& cmd :
       {" optimize --kit " + src + "/designs/kits/qc20-c-turntable-kit.json --out best.json",
        " setup-sheet --design best.json --kit " + src +
            "/designs/kits/qc20-c-turntable-kit.json --report sheet.html --summary sheet.md",
        " program --design best.json --kit " + src +
            "/designs/kits/qc20-c-turntable-kit.json --dialect heidenhain --out best.h",
        " simulate --design best.json --truth " + src +
            "/tests/data/truth_length_offset_2r.json --out readings.csv",
        std::string(" identify --design best.json --data readings.csv --out id.json"),
        std::string(" diagnose --design best.json --data readings.csv --out dg.json")}) {
    const CliRun r = run_cli_shell(cd + cli + cmd);
    ASSERT_EQ(r.status, 0) << cmd << "\n" << r.err;
    printed += r.out;
  }
  printed += slurp((dir / "sheet.md").string()) + slurp((dir / "best.h").string());
  // The kit's file as the README names it.
  const std::string kit_path = src + "/designs/kits/";
  for (size_t at = printed.find(kit_path); at != std::string::npos; at = printed.find(kit_path))
    printed.replace(at, kit_path.size(), "designs/kits/");
  int checked = 0;
  for (const std::string& line :
       readme_lines_not_printed(section, printed, true, checked, "designs scored in"))
    ADD_FAILURE() << "README line not printed:\n" << line;
  EXPECT_GT(checked, 40);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace dbbkit
