// The results' first screens: diagnose's (io::diagnose_brief) names the effect found and where,
// how sure, what it changes and one concrete next step; identify's and evaluate's say whether
// everything is determined, how well, and what to do next. At most six sentences within the
// limit each.
#include <gtest/gtest.h>

#include <random>
#include <string>

#include "dbbkit/diagnose.hpp"
#include "dbbkit/identify.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/diagnose_text.hpp"
#include "dbbkit/io/kit_io.hpp"
#include "dbbkit/io/measurement_io.hpp"
#include "dbbkit/io/optimize_io.hpp"
#include "dbbkit/io/result_io.hpp"
#include "dbbkit/observability.hpp"
#include "dbbkit/optimize.hpp"
#include "dbbkit/simulate.hpp"
#include "diagnose_util.hpp"
#include "test_util.hpp"

namespace dbbkit {
namespace {

using io::BriefItem;

// The text of the item with `topic`, or empty.
std::string item(const std::vector<BriefItem>& brief, const std::string& topic) {
  for (const BriefItem& b : brief)
    if (b.topic == topic) return b.text;
  return "";
}

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// Within the limits, and nothing cut to fit them (add_brief_item cuts with " ..."): the cases
// here must fit whole.
void expect_within_limits(const std::vector<BriefItem>& brief) {
  EXPECT_FALSE(brief.empty());
  EXPECT_LE(brief.size(), 6u);
  for (const BriefItem& b : brief) {
    EXPECT_LE(b.text.size(), io::kBriefItemMaxChars) << b.text;
    EXPECT_FALSE(b.text.empty()) << b.topic;
    EXPECT_EQ(b.text.find(" ..."), std::string::npos) << b.text;
  }
}

// The paper's C data: the length offset and centring of 2r (or 1r), the location errors the
// choice leaves uncertain, and the set-up to redo.
TEST(DiagnoseBrief, PaperDataNamesTheInstallationAndWhatToRedo) {
  const Design d = test::paper_design('C');
  const std::vector<Reading> readings =
      io::read_measurement_file(test::source_path("tests/data/paper/paper_c_turntable.csv"), d);
  const DiagnoseResult r = diagnose(d, readings);
  const std::vector<BriefItem> brief = io::diagnose_brief(d, r);
  expect_within_limits(brief);
  const std::string found = item(brief, "found");
  EXPECT_TRUE(contains(found, "a length offset of -20.3 um")) << found;
  EXPECT_TRUE(contains(found, "a centring error")) << found;
  EXPECT_TRUE(contains(found, "installation 2r (or in 1r instead")) << found;
  const std::string uncertain = item(brief, "uncertainty");
  EXPECT_TRUE(contains(uncertain, "X0C (")) << uncertain;
  EXPECT_TRUE(contains(uncertain, "B0C (")) << uncertain;
  EXPECT_TRUE(contains(uncertain, "Y0C, A0C and C0C hold")) << uncertain;
  std::string next;
  for (const BriefItem& b : brief)
    if (b.topic == "next") next += b.text;
  EXPECT_TRUE(contains(next, "re-seat the balls of installation 2r or 1r")) << next;
  EXPECT_TRUE(contains(next, "re-centre the cup of installation 2r or 1r")) << next;
  EXPECT_TRUE(contains(item(brief, "evidence"), "from chi2 7612 on 25 dof"));
}

// Alternatives of one family (ten warm-ups at their time constants) are said once in the
// verdict, both where the effect was chosen over them and in what the errors carry; the
// alternatives of different kinds keep their labels.
TEST(DiagnoseVerdict, AFamilyOfAlternativesIsSaidOnce) {
  const Design d = test::paper_design('C');
  const std::vector<Reading> readings =
      io::read_measurement_file(test::source_path("tests/data/paper/paper_c_turntable.csv"), d);
  DiagnoseResult r = diagnose(d, readings);
  ASSERT_FALSE(r.added.empty());
  std::vector<std::string> warm_ups;
  for (int tau = 5; tau <= 50; tau += 5)
    warm_ups.push_back("thermal[all](tau=" + std::to_string(tau) + "min)");
  r.added[0].close_alternatives = warm_ups;
  Attribution at;
  at.effect = r.added[0].block.label;
  at.alternatives = warm_ups;
  r.attributions = {at};
  const std::string v = io::diagnose_verdict(d, readings, r);
  EXPECT_FALSE(contains(v, "thermal[all]")) << v;
  EXPECT_TRUE(contains(v, "was chosen over a warm-up with a time constant between 5 and 50 min"))
      << v;
  EXPECT_TRUE(contains(v, "should a warm-up with a time constant between 5 and 50 min be the"))
      << v;
  r.added[0].close_alternatives = {"scale.z", "squareness.zx"};
  const std::string w = io::diagnose_verdict(d, readings, r);
  EXPECT_TRUE(contains(w, "was chosen over scale.z or squareness.zx,")) << w;
}

struct HiddenCase {
  const char* name;
  std::vector<TruthEffect> effects;
  const char* found;  // part of the "found" item
  const char* next;   // part of a "next" item
};

// Simulated readings with one hidden effect each (random Fourier truth): the summary names the
// effect, its installation and the step that removes it; clean readings say nothing to explain.
TEST(DiagnoseBrief, HiddenEffectsAreNamedWithTheirNextStep) {
  const Design d = test::fourier_design();
  const std::vector<HiddenCase> cases = {
      {"drift", {test::effect(EffectKind::kDrift, "1t", {0.4})}, "a drift of 0.4", "warm the"},
      {"step", {test::step("2t", 5.0)}, "a step of 5", "knocked or loose ball in installation 2t"},
      {"warm-up", {test::thermal(8, 20)}, "a warm-up of", "three time constants"},
      // Centring 1r and 2r are equivalent here: the later installation is named, the other beside.
      {"centring",
       {test::effect(EffectKind::kCentring, "1r", {3, -2})},
       "a centring error",
       "re-centre the cup of installation 2r or 1r"},
      {"clean", {}, "", "declare set-up tolerances"},
  };
  std::mt19937_64 rng(46);
  for (const HiddenCase& c : cases) {
    Truth t = test::random_fourier_truth(d, rng);
    t.effects = test::placed(d, t, c.effects);
    const DiagnoseResult r = diagnose(d, simulate(d, t, 4600));
    const std::vector<BriefItem> brief = io::diagnose_brief(d, r);
    expect_within_limits(brief);
    std::string next;
    for (const BriefItem& b : brief)
      if (b.topic == "next") next += b.text;
    if (c.effects.empty()) {
      EXPECT_TRUE(contains(item(brief, "residual"), "Nothing to explain")) << c.name;
      EXPECT_TRUE(contains(item(brief, "evidence"), "would have been found")) << c.name;
    } else {
      EXPECT_TRUE(contains(item(brief, "found"), c.found))
          << c.name << ": " << item(brief, "found");
      EXPECT_TRUE(contains(item(brief, "evidence"), "the residual falls from")) << c.name;
      EXPECT_FALSE(item(brief, "changes").empty()) << c.name;
    }
    EXPECT_TRUE(contains(next, c.next)) << c.name << ": " << next;
  }
}

// evaluate without declared set-up tolerances states what typical ones would make the worst
// standard uncertainty: the figure is that of the same design with those tolerances declared
// (evaluated separately here), in the warning and the summary.
TEST(EvaluateBrief, UndeclaredSetUpGetsTheTypicalFigure) {
  const Design d = test::paper_design('C');
  const double ref = *d.reference_length_mm;
  const DesignAssessment a = assess_design(d, ref);
  ASSERT_TRUE(a.evaluation.worst_total_typical);
  Design declared = d;
  declared.setup_std.length_offset_um = kTypicalLengthOffsetStd_um;
  declared.setup_std.centring_um = kTypicalCentringStd_um;
  const Evaluation with = evaluate_design(declared, ref);
  ASSERT_TRUE(with.worst_total && with.worst_total->worst_determined_std_um);
  const double typical = *a.evaluation.worst_total_typical->worst_determined_std_um;
  EXPECT_EQ(typical, *with.worst_total->worst_determined_std_um);
  EXPECT_GT(typical, 3 * *a.evaluation.worst.worst_determined_std_um);
  const std::string figure = io::fmt_num(typical, 3) + " um";
  ASSERT_FALSE(a.evaluation.warnings.empty());
  EXPECT_TRUE(contains(a.evaluation.warnings[0].text, "would be " + figure))
      << a.evaluation.warnings[0].text;
  const std::vector<BriefItem> brief = io::evaluate_brief(d, a.evaluation);
  expect_within_limits(brief);
  EXPECT_TRUE(contains(item(brief, "setup"), "would be " + figure)) << item(brief, "setup");
  EXPECT_TRUE(contains(item(brief, "determined"), "every error at every angle"));
  EXPECT_TRUE(contains(item(brief, "next"), "declare length offset and centring tolerances"));
  // Declared: no typical figure; the worst is the total one.
  const DesignAssessment b = assess_design(declared, ref);
  EXPECT_FALSE(b.evaluation.worst_total_typical);
  const std::vector<BriefItem> with_brief = io::evaluate_brief(declared, b.evaluation);
  EXPECT_TRUE(contains(item(with_brief, "worst"), "with the declared set-up tolerances"));
  EXPECT_TRUE(item(with_brief, "setup").empty());
}

// optimize's first screen: the new user's kit (set-up tolerances, a coarsest step) and the
// formats kit (neither): the typical figure is that of the best design with the typical
// tolerances declared, and the coarsest step is said to be chosen for time alone.
TEST(OptimizeBrief, SaysTheStepAndTheSetUp) {
  const Kit qc20 = io::read_kit_file(test::source_path("designs/kits/qc20-c-turntable-kit.json"));
  const OptimizeResult a = optimize_kit(qc20, {Criterion::kWorstTotal, 2});
  ASSERT_TRUE(a.best);
  const std::vector<BriefItem> with = io::optimize_brief(qc20, a, std::nullopt);
  expect_within_limits(with);
  EXPECT_TRUE(contains(item(with, "best"), "(step 20 deg)")) << item(with, "best");
  EXPECT_TRUE(contains(item(with, "worst"), "with the kit's set-up tolerances"));
  EXPECT_TRUE(item(with, "setup").empty());
  EXPECT_TRUE(item(with, "angles").empty());
  const Kit plain = io::read_kit_file(test::source_path("designs/kits/c-turntable-kit.json"));
  const OptimizeResult b = optimize_kit(plain, {Criterion::kWorst, 2});
  ASSERT_TRUE(b.best);
  const std::vector<BriefItem> without = io::optimize_brief(plain, b, std::nullopt);
  expect_within_limits(without);
  const std::optional<WorstCase> typical =
      typical_setup_worst(b.best->design, plain.reference_length_mm);
  ASSERT_TRUE(typical);
  EXPECT_TRUE(contains(item(without, "setup"),
                       "would be " + io::fmt_num(*typical->worst_determined_std_um, 3) + " um"))
      << item(without, "setup");
  EXPECT_TRUE(contains(item(without, "angles"), "angles_deg.max_step")) << item(without, "angles");
}

// identify's first screen on the paper's data (the residual contradicts the noise) and on clean
// simulated readings (it agrees).
TEST(IdentifyBrief, SaysWhetherTheResidualBearsTheUncertaintiesOut) {
  const Design d = test::paper_design('C');
  const std::vector<Reading> readings =
      io::read_measurement_file(test::source_path("tests/data/paper/paper_c_turntable.csv"), d);
  const std::vector<BriefItem> paper = io::identify_brief(d, identify(d, readings));
  expect_within_limits(paper);
  EXPECT_TRUE(contains(item(paper, "residual"), "contradicts the declared noise"));
  EXPECT_TRUE(contains(item(paper, "location"), "X0C -18.6 +- "));
  EXPECT_TRUE(contains(item(paper, "next"), "dbbkit diagnose"));
  EXPECT_TRUE(contains(item(paper, "location"), "standard uncertainty, k = 1"));
  // Stated from the scatter (Type A): said so, and --type-a is not offered again.
  IdentifyOptions type_a;
  type_a.budget.type_a = true;
  const std::vector<BriefItem> scatter = io::identify_brief(d, identify(d, readings, type_a));
  EXPECT_TRUE(contains(item(scatter, "residual"), "Type A")) << item(scatter, "residual");
  EXPECT_FALSE(contains(item(scatter, "next"), "--type-a")) << item(scatter, "next");
  const Design f = test::fourier_design();
  std::mt19937_64 rng(7);
  const Truth t = test::random_fourier_truth(f, rng);
  const std::vector<BriefItem> clean = io::identify_brief(f, identify(f, simulate(f, t, 4601)));
  expect_within_limits(clean);
  EXPECT_TRUE(contains(item(clean, "residual"), "agrees with the declared noise"))
      << item(clean, "residual");
}

}  // namespace
}  // namespace dbbkit
