// identify with effects fitted as free unknowns (IdentifyOptions::effects, --effects): the
// labels diagnose writes read back as the same effects; the same model as diagnose's final one
// gives diagnose's corrected values; a hidden effect of a known size comes back; what cannot be
// fitted is refused by name.

#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "../src/factorised.hpp"
#include "cli_util.hpp"
#include "dbbkit/diagnose.hpp"
#include "dbbkit/effects.hpp"
#include "dbbkit/error.hpp"
#include "dbbkit/identify.hpp"
#include "dbbkit/io/measurement_io.hpp"
#include "dbbkit/io/truth_io.hpp"
#include "dbbkit/simulate.hpp"
#include "test_util.hpp"

namespace dbbkit {
namespace {

std::vector<Reading> drift_readings(const Design& d) {
  return simulate(d, io::read_truth_file(test::source_path("tests/data/truth_drift_example.json")),
                  3);
}

// Every label of diagnose's pool and of its scanned families (a timed step, a warm-up) reads
// back as an effect whose label is the same.
TEST(IdentifyEffects, EveryLabelDiagnoseWritesReadsBack) {
  const Design d = test::paper_design('C');
  const std::vector<Reading> readings = drift_readings(d);
  std::vector<std::string> labels;
  for (const EffectBlock& b : candidate_effects(d, readings)) labels.push_back(b.label);
  for (const ScanFamily& f : scan_families(d, readings)) {
    ASSERT_FALSE(f.alternatives.empty() && f.rows.empty()) << f.label;
    labels.push_back(f.alternative(d, readings, 0).label);
    labels.push_back(f.alternative(d, readings, 1).label);
  }
  int steps = 0, warmups = 0;
  for (const std::string& l : labels) {
    const EffectCandidate e = effect_from_label(d, l, "test", "label");
    EXPECT_EQ(e.label(d), l);
    steps += e.kind == EffectKind::kStep;
    warmups += e.kind == EffectKind::kThermal;
  }
  EXPECT_GT(steps, 0);
  EXPECT_GT(warmups, 0);
  EXPECT_GE(labels.size(), 30u);
}

TEST(IdentifyEffects, BadLabelsAreRefusedByName) {
  const Design d = test::paper_design('C');
  for (const char* bad :
       {"length_offset[9z]", "foo[1r]", "scale[1r]", "centring", "thermal[all]",
        "thermal[1r](tau=3min)", "step[1r](t=abc)", "step[1r]", "step[1r](t=1e999s)",
        "periodic[1r](1/turn)", "length_offset[2r]x", "centring.q[1r]", "length_offset.x[1r]",
        "centring[all]", "length_offset[2r", "drift[all](t=1s)"}) {
    EXPECT_THROW(effect_from_label(d, bad, "--effects", "effect 1"), InputError) << bad;
  }
  EXPECT_THROW(effects_from_list(d, "length_offset[1r],,drift[all]", "--effects"), InputError);
  EXPECT_TRUE(effects_from_list(d, "  ", "--effects").empty());
  EXPECT_EQ(effects_from_list(d, " length_offset[1r] , scale.x", "--effects").size(), 2u);
  // Given twice, or not formed by the readings (a drift without times): refused by identify.
  const std::vector<Reading> untimed =
      io::read_measurement_file(test::source_path("tests/data/paper/paper_c_turntable.csv"), d);
  IdentifyOptions o;
  o.effects = effects_from_list(d, "length_offset[2r],length_offset[2r]", "--effects");
  EXPECT_THROW(identify(d, untimed, o), InputError);
  o.effects = effects_from_list(d, "drift[1r]", "--effects");
  try {
    identify(d, untimed, o);
    ADD_FAILURE() << "a drift without times must be refused";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("needs time_s"), std::string::npos) << e.what();
  }
}

// The effects diagnose added, given to identify, are diagnose's final model: the same values
// of every error and effect (diagnose's uncertainties add the attributions' share); the drift
// hidden in 1t (0.4 um/min) comes back within its uncertainty.
TEST(IdentifyEffects, DiagnoseModelReusedGivesItsValues) {
  const Design d = test::paper_design('C');
  const std::vector<Reading> readings = drift_readings(d);
  const DiagnoseResult g = diagnose(d, readings);
  ASSERT_FALSE(g.added.empty());
  IdentifyOptions o;
  std::string list;
  for (const AddedEffect& a : g.added) list += (list.empty() ? "" : ",") + a.block.label;
  o.effects = effects_from_list(d, list, "--effects");
  const IdentifyResult r = identify(d, readings, o);
  ASSERT_EQ(r.effects.size(), g.added.size());
  for (std::size_t k = 0; k < g.added.size(); ++k) {
    EXPECT_EQ(r.effects[k].label, g.added[k].block.label);
    for (std::size_t q = 0; q < g.added[k].values.size(); ++q)
      EXPECT_NEAR(r.effects[k].values[q].value, g.added[k].values[q].value, 1e-9);
  }
  for (std::size_t s = 0; s < r.errors.size(); ++s) {
    for (int e = 0; e < 6; ++e) {
      const Determined &a = r.errors[s].errors[e], &b = g.errors_after[s].errors[e];
      ASSERT_EQ(a.determined, b.determined);
      if (!a.determined) continue;
      EXPECT_NEAR(a.value, b.value, 1e-9);
      EXPECT_LE(a.std, b.std * (1 + 1e-9));  // diagnose's carries the attributions' share
    }
  }
  EXPECT_NEAR(r.estimate.chi2, g.after.chi2, 1e-6);
  const FittedEffect* drift = nullptr;
  for (const FittedEffect& f : r.effects)
    if (f.label == "drift[1t]") drift = &f;
  ASSERT_NE(drift, nullptr) << list;
  EXPECT_EQ(drift->unit, "um/min");
  EXPECT_NEAR(drift->values[0].value, 0.4, 3 * drift->values[0].std);
  // A drift of one installation's readings is no other effect of the library.
  EXPECT_TRUE(drift->equivalent_to.empty());
  // Without the effect the residual contradicts the noise; with it, it does not.
  EXPECT_LT(*identify(d, readings).estimate.p_value, 0.01);
  EXPECT_GT(*r.estimate.p_value, 0.01);
}

// A free effect replaces its declared set-up prior; the budget, Monte Carlo and ISO terms
// work on the extended model; an effect the design confounds with the axis errors leaves the
// combination undetermined and says so by name.
TEST(IdentifyEffects, SetUpPriorReplacedAndConfoundedEffectNamed) {
  Design d = test::paper_design('C');
  const Truth t = io::read_truth_file(test::source_path("tests/data/truth_length_offset_2r.json"));
  const std::vector<Reading> readings = simulate(d, t, 11);
  d.setup_std.length_offset_um = 2.0;
  IdentifyOptions o;
  o.effects = effects_from_list(d, "length_offset[2r]", "--effects");
  const IdentifyResult r = identify(d, readings, o);
  ASSERT_EQ(r.effects.size(), 1u);
  EXPECT_NEAR(r.effects[0].values[0].value, 15.0, 3 * r.effects[0].values[0].std);
  for (const SetupEstimate& e : r.setup_estimates) EXPECT_NE(e.label, "length_offset[2r]");
  EXPECT_FALSE(r.setup_estimates.empty());
  MonteCarloOptions mo;
  mo.adaptive = false;
  mo.max_trials = 20000;
  const MonteCarloResult mc = monte_carlo(d, r, mo);
  EXPECT_EQ(mc.values.size(), r.budget.values.size());
  EXPECT_TRUE(r.iso.location[0].value.determined);
  // A whole-test length offset on a per-angle C table: confounded with the axis errors.
  const Design p = test::paper_design('C');
  const std::vector<CandidateStatus> st = effect_detectability(p, readings);
  std::string confounded;
  for (const CandidateStatus& c : st)
    if (c.state == CandidateState::kConfounded && confounded.empty()) confounded = c.label;
  ASSERT_FALSE(confounded.empty());
  o.effects = effects_from_list(p, confounded, "--effects");
  const IdentifyResult c = identify(p, readings, o);
  EXPECT_LT(c.estimate.rank, c.estimate.n_unknowns);
  bool named = false;
  for (const Unidentifiable& u : c.unidentifiable)
    for (const auto& term : u.terms) named = named || term.first.rfind(confounded, 0) == 0;
  EXPECT_TRUE(named) << confounded;
}

// An effect the readings cannot tell from another of the library (a bar offset of 2r and one of
// 1r on the paper's C design): identify names the other, and the largest change of the errors
// is that between the two fits, each run here with identify; the warning says so.
TEST(IdentifyEffects, EquivalentEffectIsNamedWithTheChange) {
  const Design d = test::paper_design('C');
  const Truth t = io::read_truth_file(test::source_path("tests/data/truth_length_offset_2r.json"));
  const std::vector<Reading> readings = simulate(d, t, 11);
  IdentifyOptions o;
  o.effects = effects_from_list(d, "length_offset[2r]", "--effects");
  const IdentifyResult r = identify(d, readings, o);
  o.effects = effects_from_list(d, "length_offset[1r]", "--effects");
  const IdentifyResult other = identify(d, readings, o);
  ASSERT_EQ(r.effects.size(), 1u);
  EXPECT_EQ(r.effects[0].equivalent_to, std::vector<std::string>{"length_offset[1r]"});
  EXPECT_NEAR(other.estimate.chi2, r.estimate.chi2, 1e-6 * (1 + r.estimate.chi2));
  std::array<double, 6> change{};
  for (std::size_t s = 0; s < r.errors.size(); ++s) {
    for (int k = 0; k < 6; ++k) {
      if (r.errors[s].errors[k].determined && other.errors[s].errors[k].determined)
        change[k] = std::max(
            change[k], std::abs(r.errors[s].errors[k].value - other.errors[s].errors[k].value));
    }
  }
  for (int k = 0; k < 6; ++k) EXPECT_NEAR(r.effects[0].largest_change[k], change[k], 1e-6) << k;
  EXPECT_GT(change[0], 10.0);  // dx: the 15 um offset, seen from the other installation
  bool warned = false;
  for (const Warning& w : r.warnings) warned = warned || w.kind == "equivalent_effects";
  EXPECT_TRUE(warned);
}

// The command line: --effects fits them, the JSON lists them; a bad label exits 2 naming it.
TEST(IdentifyEffects, CommandLine) {
  const std::string base = "identify --design " +
                           test::source_path("designs/paper-c-turntable.json") + " --data " +
                           test::source_path("tests/data/paper/paper_c_turntable.csv") + " --out -";
  CliRun r = run_cli(base + " --effects 'length_offset[2r],centring[2r]'");
  ASSERT_EQ(r.status, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  ASSERT_EQ(j["effects"].size(), 2u);
  EXPECT_EQ(j["effects"][1]["label"], "centring[2r]");
  EXPECT_TRUE(j["effects"][1]["value"].contains("cx"));
  EXPECT_EQ(j["effects"][0]["equivalent_to"][0], "length_offset[1r]");
  EXPECT_GT(j["effects"][0]["largest_change"]["dx"].get<double>(), 30.0);
  r = run_cli(base + " --effects 'length_offset[7q]'");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("'7q' is no installation"), std::string::npos) << r.err;
  EXPECT_TRUE(nlohmann::json::parse(run_cli(base).out)["effects"].empty());
}

}  // namespace
}  // namespace dbbkit
