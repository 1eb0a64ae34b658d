#include "dbbkit/diagnose.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <sstream>

#include "../src/wls_solver.hpp"
#include "dbbkit/identify.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/diagnose_text.hpp"
#include "dbbkit/io/measurement_io.hpp"
#include "dbbkit/io/reports.hpp"
#include "dbbkit/io/truth_io.hpp"
#include "dbbkit/simulate.hpp"
#include "diagnose_util.hpp"
#include "test_util.hpp"

namespace dbbkit {
namespace {

// The paper's C installations with 150 mm bars and a Fourier order-2 error model,
// swept ccw, cw, ccw, 10 s per reading: the redundancy diagnosis needs (with ccw then cw
// alone, a drift and a reversal of one installation are nearly collinear).
using test::fourier_design;
using test::random_fourier_truth;

using test::effect;
using test::has;
using test::placed;
using test::step;
using test::thermal;

TEST(Diagnose, CleanDataAddsNothing) {
  const Design d = fourier_design();
  std::mt19937_64 rng(1);
  const int seeds = 300;
  const auto [clean, flagged] = test::clean_runs(d, random_fourier_truth, rng, seeds, 5000);
  EXPECT_GE(clean, 0.97 * seeds) << clean << " of " << seeds;
  EXPECT_LE(flagged, 0.03 * seeds);
}

struct EffectCase {
  const char* name;
  std::vector<TruthEffect> effects;
  std::vector<std::string> labels;  // what diagnose must add
  // For an effect of the whole test: no per-installation term of these kinds may be added
  // beside it (one global drift must not come out as a drift per installation).
  std::vector<EffectKind> not_per_installation = {};
};

void PrintTo(const EffectCase& c, std::ostream* os) { *os << c.name; }

class FindsEffect : public ::testing::TestWithParam<EffectCase> {};

TEST_P(FindsEffect, AddsItAndExplainsTheResidual) {
  const EffectCase& c = GetParam();
  const Design d = fourier_design();
  std::mt19937_64 rng(2);
  // 60 random machines a case: at most 3 missed, at most 6 inconsistent.
  const int seeds = 60;
  int found = 0, consistent = 0, right_value = 0, values = 0;
  double inside = 0, total = 0;
  for (int s = 0; s < seeds; ++s) {
    Truth t = random_fourier_truth(d, rng);
    t.effects = placed(d, t, c.effects);
    const DiagnoseResult r = diagnose(d, simulate(d, t, 7000 + s));
    bool all = true;
    for (const std::string& l : c.labels) all = all && has(r, l);
    for (const AddedEffect& a : r.added) {
      for (EffectKind k : c.not_per_installation)
        all = all && !(a.block.effect.kind == k && a.block.effect.installation >= 0);
    }
    found += all;
    consistent += r.after.p_value && *r.after.p_value > 0.01;
    test::count_errors_within_3u(r, t, d.axis, inside, total);
    // The added effect's value against the truth, component by component.
    for (const AddedEffect& a : r.added) {
      for (const TruthEffect& te : t.effects) {
        if (a.block.effect.kind != te.effect.kind) continue;
        // A step found at another reading, a warm-up with another time constant: their sizes
        // differ.
        if (te.effect.kind == EffectKind::kStep && a.block.effect.at_s != te.effect.at_s) continue;
        if (te.effect.kind == EffectKind::kThermal) {  // the plateau and the fitted time constant
          ASSERT_EQ(a.values.size(), 2u);
          right_value += std::abs(a.values[0].value - te.value(0)) <= 3 * a.values[0].std;
          right_value += std::abs(a.values[1].value - te.effect.tau_min) <= 3 * a.values[1].std;
          values += 2;
          continue;
        }
        const std::vector<std::string> names = effect_parameter_names(te.effect.kind);
        for (std::size_t k = 0; k < a.block.parameters.size(); ++k) {
          const auto at =
              std::find(names.begin(), names.end(), a.block.parameters[k]) - names.begin();
          right_value += std::abs(a.values[k].value - te.value(at)) <= 3 * a.values[k].std;
          ++values;
        }
      }
    }
  }
  EXPECT_GE(found, 0.95 * seeds) << c.name;
  EXPECT_GE(consistent, 0.90 * seeds) << c.name;
  EXPECT_GE(inside / total, 0.98) << c.name;
  EXPECT_GE(right_value, 0.95 * values) << c.name << " " << right_value << " of " << values;
}

INSTANTIATE_TEST_SUITE_P(
    Library, FindsEffect,
    ::testing::Values(
        EffectCase{"length_offset",
                   {effect(EffectKind::kLengthOffset, "2r", {10})},
                   {"length_offset[2r]"}},
        EffectCase{"centring", {effect(EffectKind::kCentring, "2r", {6, -4})}, {"centring[2r]"}},
        EffectCase{"drift", {effect(EffectKind::kDrift, "1t", {0.4})}, {"drift[1t]"}},
        EffectCase{"reversal", {effect(EffectKind::kReversal, "3r", {3})}, {"reversal[3r]"}},
        EffectCase{"scale", {effect(EffectKind::kScale, "", {40, 0, 0})}, {"scale.x"}},
        EffectCase{
            "squareness", {effect(EffectKind::kSquareness, "", {25, 0, 0})}, {"squareness.xy"}},
        EffectCase{"offset_and_drift",
                   {effect(EffectKind::kLengthOffset, "2r", {-8}),
                    effect(EffectKind::kDrift, "3t", {0.3})},
                   {"length_offset[2r]", "drift[3t]"}},
        EffectCase{"centring_and_reversal",
                   {effect(EffectKind::kCentring, "2r", {-5, 7}),
                    effect(EffectKind::kReversal, "2t", {-4})},
                   {"centring[2r]", "reversal[2t]"}},
        // Effects of the whole test: one drift on the test's clock (0.3 um/min), one reversal
        // common to every installation (a length change common to every reading, the bar's
        // own, is confounded on this design: WholeTestLengthIsConfoundedAndNeverAdded).
        EffectCase{"whole_test_drift",
                   {effect(EffectKind::kDrift, "", {0.3})},
                   {"drift[all]"},
                   {EffectKind::kDrift}},
        EffectCase{"whole_test_reversal",
                   {effect(EffectKind::kReversal, "", {4})},
                   {"reversal[all]"},
                   {EffectKind::kReversal}},
        EffectCase{
            "whole_test_drift_and_centring",
            {effect(EffectKind::kDrift, "", {-0.2}), effect(EffectKind::kCentring, "2r", {4, 5})},
            {"drift[all]", "centring[2r]"},
            {EffectKind::kDrift}},
        // A 5 um jump halfway through one installation: a step, not that installation's drift
        // and centring.
        EffectCase{
            "step", {step("2t", 5)}, {"step[2t]"}, {EffectKind::kDrift, EffectKind::kCentring}},
        EffectCase{"step_and_length_offset",
                   {step("1t", -4), effect(EffectKind::kLengthOffset, "2r", {6})},
                   {"step[1t]", "length_offset[2r]"},
                   {EffectKind::kDrift}},
        // A warm-up: 8 um approached with a time constant of 20 min over a test of about 70 min.
        EffectCase{"thermal", {thermal(8, 20)}, {"thermal[all]"}, {EffectKind::kDrift}}),
    [](const auto& info) { return std::string(info.param.name); });

// A 3-per-turn term is outside the library: it must stay a flagged, described,
// unexplained residual, not be pinned on an effect of the library.
TEST(Diagnose, UnknownEffectIsFlaggedNotMisattributed) {
  const Design d = fourier_design();
  std::mt19937_64 rng(3);
  const int seeds = 50;
  int flagged = 0, described = 0, misattributed = 0;
  for (int s = 0; s < seeds; ++s) {
    Truth t = random_fourier_truth(d, rng);
    t.effects = {effect(EffectKind::kPeriodic, "1r", {4}, 3)};
    const std::vector<Reading> rd = simulate(d, t, 9000 + s);
    const DiagnoseResult r = diagnose(d, rd);
    const std::string verdict = io::diagnose_verdict(d, rd, r);
    flagged += r.significant_after;
    described +=
        r.signature_after.dominant &&
        io::describe_feature(d, rd, *r.signature_after.dominant).find("3-per-turn") !=
            std::string::npos &&
        io::describe_feature(d, rd, *r.signature_after.dominant).find("1r") != std::string::npos &&
        verdict.find("no effect of the library explains") != std::string::npos;
    misattributed += !r.added.empty();
  }
  EXPECT_GE(flagged, 0.95 * seeds);
  EXPECT_GE(described, 0.95 * seeds);
  EXPECT_LE(misattributed, 0.05 * seeds);
}

// A length change common to every reading (the bar's own length, its thermal growth) is, on
// this design, a combination of the axis errors: diagnose must say so and never add it.
TEST(Diagnose, WholeTestLengthIsConfoundedAndNeverAdded) {
  const Design d = fourier_design();
  std::mt19937_64 rng(4);
  for (int s = 0; s < 5; ++s) {
    Truth t = random_fourier_truth(d, rng);
    t.effects = {effect(EffectKind::kLengthOffset, "", {3})};
    const DiagnoseResult r = diagnose(d, simulate(d, t, 9500 + s));
    EXPECT_FALSE(has(r, "length_offset[all]"));
    const auto c =
        std::find_if(r.candidates.begin(), r.candidates.end(),
                     [](const CandidateStatus& cs) { return cs.label == "length_offset[all]"; });
    ASSERT_NE(c, r.candidates.end());
    EXPECT_EQ(c->state, CandidateState::kConfounded) << io::candidate_detail(*c);
  }
}

// Drifts of different slopes in two installations are two per-installation terms, not one
// of the whole test: the structure comparison keeps them and reports the rejected one.
TEST(Diagnose, PerInstallationDriftsAreKeptAgainstOneWholeTestDrift) {
  const Design d = fourier_design();
  std::mt19937_64 rng(6);
  const int seeds = 20;
  int kept = 0, reported = 0;
  for (int s = 0; s < seeds; ++s) {
    Truth t = random_fourier_truth(d, rng);
    t.effects = {effect(EffectKind::kDrift, "1t", {0.4}), effect(EffectKind::kDrift, "3r", {-0.3})};
    const std::vector<Reading> rd = simulate(d, t, 9600 + s);
    const DiagnoseResult r = diagnose(d, rd);
    const std::string verdict = io::diagnose_verdict(d, rd, r);
    kept += has(r, "drift[1t]") && has(r, "drift[3r]") && !has(r, "drift[all]");
    for (const StructureComparison& c : r.structures) {
      reported += c.kind == "drift" && c.rejected == std::vector<std::string>{"drift[all]"} &&
                  c.bic_chosen < c.bic_rejected &&
                  verdict.find("was preferred to one for the whole test") != std::string::npos;
    }
  }
  // A step scanned over 3r's readings takes the place of its drift in 2 of these 20 seeds
  // (seeds 2 and 12: the step fits better than the true drift by more than the close margin).
  EXPECT_GE(kept, seeds - 3);
  EXPECT_GE(reported, seeds - 3);
}

// An effect that, fitted, would move the bar beyond the instrument's range in these readings is
// no finding (the readings could not hold it): it is named implausible with its reach and never
// added. A drift of 3 um/min in one installation of a long test is an ordinary finding under the
// default 1 mm range (its reach is its installation's, not the test's).
TEST(Diagnose, AnEffectTheReadingsCouldNotHoldIsNoFinding) {
  Design d = fourier_design();
  std::mt19937_64 rng(8);
  int named = 0, found = 0;
  const int seeds = 5;
  for (int s = 0; s < seeds; ++s) {
    Truth t = random_fourier_truth(d, rng);
    t.effects = {effect(EffectKind::kDrift, "3r", {3.0})};
    const std::vector<Reading> rd = simulate(d, t, 9700 + s);
    double t0 = 1e300, t1 = -1e300;
    for (const Reading& r : rd) {
      if (r.installation == "3r") t0 = std::min(t0, *r.time_s), t1 = std::max(t1, *r.time_s);
    }
    const double reach_um = 3.0 * (t1 - t0) / 60.0;
    Design narrow = d;  // a range the drift's reach in these readings exceeds
    narrow.instrument_range_mm = 1e-3 * 0.5 * reach_um;
    const DiagnoseResult wide = diagnose(d, rd), tight = diagnose(narrow, rd);
    found += has(wide, "drift[3r]");
    for (const CandidateStatus& c : tight.candidates) {
      if (c.label != "drift[3r]") continue;
      named += c.state == CandidateState::kImplausible && !has(tight, "drift[3r]") &&
               std::abs(c.implied_um - reach_um) < 0.1 * reach_um &&
               io::candidate_detail(c).find("beyond the instrument's range") != std::string::npos;
    }
  }
  EXPECT_EQ(found, seeds);
  EXPECT_EQ(named, seeds);
}

// A drift faster than any machine or bar drifts (40 um/min, the design's bound 10 um/min)
// whose reach in its installation the instrument could read is no finding: named implausible
// with its rate, never added; with the bound raised above it, it is found.
TEST(Diagnose, ADriftNoMachineHasIsNoFinding) {
  const Design d = fourier_design();
  std::mt19937_64 rng(9);
  int named = 0, found = 0;
  const int seeds = 5;
  for (int s = 0; s < seeds; ++s) {
    Truth t = random_fourier_truth(d, rng);
    t.effects = {effect(EffectKind::kDrift, "3r", {40.0})};
    const std::vector<Reading> rd = simulate(d, t, 9800 + s);
    Design lax = d;
    lax.max_drift_um_per_min = 50;
    const DiagnoseResult bounded = diagnose(d, rd), free = diagnose(lax, rd);
    found += has(free, "drift[3r]");
    for (const CandidateStatus& c : bounded.candidates) {
      if (c.label != "drift[3r]") continue;
      named += c.state == CandidateState::kImplausible && !has(bounded, "drift[3r]") &&
               c.reason == CandidateReason::kBeyondDriftRate &&
               std::abs(c.implied_um_per_min - 40.0) < 1.0 && c.level == 10.0 &&
               io::candidate_detail(c).find("(instrument.max_drift_um_per_min, 10 um/min)") !=
                   std::string::npos;
    }
    bool said = false;
    for (const io::BriefItem& b : io::diagnose_brief(d, bounded))
      said = said || b.text.rfind("Not a finding: drift[3r], a drift of 4", 0) == 0;
    EXPECT_TRUE(said);
    for (const AddedEffect& a : bounded.added)
      if (a.block.effect.kind == EffectKind::kDrift)
        EXPECT_LE(std::abs(a.values[0].value), d.max_drift_um_per_min) << a.block.label;
  }
  EXPECT_EQ(found, seeds);
  EXPECT_EQ(named, seeds);
}

// A warm-up of 80 um with a time constant of 4 min starts at 20 um/min, twice the design's bound:
// no warm-up is found whose slope at its start (its plateau over its time constant, as finally
// fitted) is above the bound, nor any drift, and the warm-up is named implausible.
TEST(Diagnose, AWarmUpStartingFasterThanAnyMachineIsNoFinding) {
  const Design d = fourier_design();
  std::mt19937_64 rng(10);
  int named = 0;
  const int seeds = 3;
  for (int s = 0; s < seeds; ++s) {
    Truth t = random_fourier_truth(d, rng);
    t.effects = {thermal(80, 4)};
    const DiagnoseResult r = diagnose(d, simulate(d, t, 9900 + s));
    for (const AddedEffect& a : r.added) {
      if (a.block.effect.kind == EffectKind::kThermal) {
        ASSERT_EQ(a.values.size(), 2u);
        EXPECT_GT(a.values[1].value, 0) << a.block.label;
        EXPECT_LE(std::abs(a.values[0].value) / a.values[1].value, d.max_drift_um_per_min)
            << a.block.label;
      }
      if (a.block.effect.kind == EffectKind::kDrift)
        EXPECT_LE(std::abs(a.values[0].value), d.max_drift_um_per_min) << a.block.label;
    }
    for (const CandidateStatus& c : r.candidates)
      named += c.label.rfind("thermal", 0) == 0 && c.state == CandidateState::kImplausible &&
               c.reason == CandidateReason::kBeyondDriftRate &&
               io::candidate_detail(c).find("a warm-up whose slope at its start is") !=
                   std::string::npos;
  }
  EXPECT_EQ(named, seeds);
  // A warm-up of 20 um with the same 4 min starts at 5 um/min, an ordinary one: its time
  // constant lies below the scan's, where the linearised correction would leave it below 0; it
  // is found at the search's least time constant, never refused as implausible.
  for (int s = 0; s < seeds; ++s) {
    Truth t = random_fourier_truth(d, rng);
    t.effects = {thermal(20, 4)};
    const DiagnoseResult r = diagnose(d, simulate(d, t, 9950 + s));
    EXPECT_TRUE(has(r, "thermal[all]"));
    for (const AddedEffect& a : r.added)
      if (a.block.effect.kind == EffectKind::kThermal)
        EXPECT_GT(a.values.size() > 1 ? a.values[1].value : a.block.effect.tau_min, 0)
            << a.block.label;
    for (const CandidateStatus& c : r.candidates)
      EXPECT_FALSE(c.label.rfind("thermal", 0) == 0 && c.state == CandidateState::kImplausible)
          << io::candidate_detail(c);
  }
}

// An A trunnion with its set-up tolerances declared, a 4 um warm-up and a 6/7 um centring on 3t
// (the exact geometry): diagnose adds nothing no machine could have, its errors are identify's
// (the declared set-up carried as identify carries it), and where the design cannot see a drift
// in these readings it says so instead of stating an absurd limit as findable.
TEST(Diagnose, ATrunnionWithAWarmUpNamesNothingAbsurdAndAgreesWithIdentify) {
  const Design d =
      io::read_design_file(test::source_path("tests/data/a_trunnion_kit_optimized.json"));
  const Truth t =
      io::read_truth_file(test::source_path("tests/data/truth_a_trunnion_warm_up.json"));
  for (std::uint64_t seed = 1; seed <= 5; ++seed) {
    const std::vector<Reading> rd = simulate(d, t, seed);
    const DiagnoseResult r = diagnose(d, rd);
    const IdentifyResult id = identify(d, rd);
    for (const AddedEffect& a : r.added) {
      for (const CandidateStatus& c : r.candidates)
        EXPECT_FALSE(c.label == a.block.label && c.state == CandidateState::kImplausible);
    }
    if (r.added.empty()) {
      ASSERT_EQ(r.errors_after.size(), id.errors.size());
      for (std::size_t s = 0; s < id.errors.size(); ++s) {
        for (int k = 0; k < 6; ++k) {
          EXPECT_NEAR(r.errors_after[s].errors[k].value, id.errors[s].errors[k].value, 1e-6);
          EXPECT_NEAR(r.errors_after[s].errors[k].std, id.errors[s].errors[k].std, 1e-6);
        }
      }
    }
    // Its installations last under a minute: the least drift it would find is hundreds of
    // um/min, beyond the 10 um/min default bound, so it cannot see a drift and says so.
    bool drift_unseen = false;
    for (const DetectionLimit& l : r.detection_limits)
      drift_unseen = drift_unseen || (l.label.rfind("drift", 0) == 0 && l.unseeable());
    EXPECT_TRUE(drift_unseen);
    if (const auto& top = r.signature_before.dominant) EXPECT_FALSE(top->implausible());
    if (drift_unseen) {
      bool said = false;
      for (const io::BriefItem& b : io::diagnose_brief(d, r))
        said = said || b.text.find("cannot see drift") != std::string::npos;
      EXPECT_TRUE(said) << "a drift beyond what the readings could hold is said unseeable";
      for (const io::BriefItem& b : io::diagnose_brief(d, r))
        EXPECT_TRUE(b.topic != "evidence" || b.text.find("drift of") == std::string::npos)
            << b.text;
    }
  }
}

TEST(Diagnose, NearlyCollinearCandidatesAreReported) {
  // Swept ccw then cw only, a drift looks much like a reversal: when noise makes the
  // reversal win, the drift must be named as a close alternative, never silently lost.
  const Design d = fourier_design();
  std::mt19937_64 rng(6);
  int wrong = 0, warned = 0, right = 0;
  for (int s = 0; s < 60; ++s) {
    Truth t = random_fourier_truth(d, rng);
    t.schedule->sweeps = {Sweep::kCCW, Sweep::kCW};
    t.effects = {effect(EffectKind::kDrift, "1t", {0.4})};
    const DiagnoseResult r = diagnose(d, simulate(d, t, 300 + s));
    if (has(r, "drift[1t]")) {
      ++right;
      continue;
    }
    for (const AddedEffect& a : r.added) {
      if (a.block.label != "reversal[1t]") continue;
      ++wrong;
      warned += std::find(a.close_alternatives.begin(), a.close_alternatives.end(), "drift[1t]") !=
                a.close_alternatives.end();
    }
  }
  EXPECT_GE(right, 50);
  EXPECT_EQ(warned, wrong) << wrong << " wrong attributions";
}

TEST(Diagnose, ConfoundedEffectIsNeverAdded) {
  // An offset of the axial installation is dz's order-0 coefficient: it must be reported
  // as confounded, not added, and the errors must not pretend to know the split.
  const Design d = fourier_design();
  std::mt19937_64 rng(4);
  Truth t = random_fourier_truth(d, rng);
  t.effects = {effect(EffectKind::kLengthOffset, "1a", {15})};
  const DiagnoseResult r = diagnose(d, simulate(d, t, 1));
  EXPECT_FALSE(has(r, "length_offset[1a]"));
  const auto it =
      std::find_if(r.candidates.begin(), r.candidates.end(),
                   [](const CandidateStatus& c) { return c.label == "length_offset[1a]"; });
  ASSERT_NE(it, r.candidates.end());
  EXPECT_EQ(it->state, CandidateState::kConfounded);
}

TEST(Diagnose, PaperTurntableNeedsTheSecondRadialSetUp) {
  // Result on the paper's data (tests/data/paper): radial readings do not depend on L, so
  // 1r and 2r must agree at every angle; 2r carries a length offset and a centring offset.
  const Design d = test::paper_design('C');
  const DiagnoseResult r = diagnose(
      d, io::read_measurement_file(test::source_path("tests/data/paper/paper_c_turntable.csv"), d));
  EXPECT_TRUE(r.significant_before);
  EXPECT_TRUE(has(r, "length_offset[2r]"));
  EXPECT_TRUE(has(r, "centring[2r]"));
  EXPECT_FALSE(r.significant_after);
  EXPECT_LT(r.after.chi2, r.before.chi2 / 1000);
}

}  // namespace
}  // namespace dbbkit

namespace dbbkit {
namespace {

// added_rank (projection, linear in the readings) against the rank of the factorised
// augmented model [J X], for every candidate effect of the committed designs and the
// Fourier test design, on readings with times and both sweeps (so that drift and
// reversal apply): the two tests must agree on every effect.
TEST(Detectability, ProjectionAgreesWithTheAugmentedFactorisation) {
  std::vector<Design> designs = {fourier_design(), test::paper_design('C'),
                                 test::paper_design('B')};
  for (const char* f :
       {"designs/c-turntable-kit-optimized.json", "designs/b-head-kit-optimized.json"}) {
    designs.push_back(io::read_design_file(test::source_path(f)));
  }
  int compared = 0, confounded = 0;
  for (const Design& d : designs) {
    Truth t;
    t.model = ErrorModel{};
    for (double a : d.angles_deg) test::add_truth_value(t, d.axis, a, Vector6d::Zero());
    t.noiseless = true;
    t.schedule = Schedule{10, 240, {Sweep::kCCW, Sweep::kCW}};
    const std::vector<Reading> readings = simulate(d, t, 0);
    const Parameterisation param(d);
    const LinearModel model = build_linear_model(d, param, readings);
    const WlsSolver solver(model.J, model.sigma_um);
    const int rank = solver.a_priori().rank;
    for (const EffectBlock& b : candidate_effects(d, readings)) {
      if (!b.applicability.applicable()) continue;
      Eigen::MatrixXd A(model.J.rows(), model.J.cols() + b.J_reading_effect.cols());
      A << test::dense(model.J), b.J_reading_effect;
      const int full = WlsSolver(A, model.sigma_um).a_priori().rank - rank;
      EXPECT_EQ(added_rank(solver, b.J_reading_effect), full) << d.name << " " << b.label;
      ++compared;
      confounded += full < b.J_reading_effect.cols();
    }
  }
  EXPECT_GT(compared, 100);
  EXPECT_GT(confounded, 5);  // both outcomes are exercised
}

}  // namespace
}  // namespace dbbkit

namespace dbbkit {
namespace {

// A per-angle design at 8 deg (46 angles, 276 unknowns) with a drift of installation 2r and a
// reversal of the whole test: every candidate model solved bordered (the effects' columns set
// aside, EstimateOptions; by default from 512 unknowns, here from 100) and as one whole block.
// The same effects are added and the errors after agree to rounding.
TEST(DiagnoseBordered, AgreesWithTheWholeBlock) {
  Design d = test::paper_design('C');
  d.angles_deg.clear();
  for (int i = 0; i <= 45; ++i) d.angles_deg.push_back(8.0 * i);
  Truth t;
  t.model = d.errors;
  std::mt19937_64 rng(4);
  std::normal_distribution<double> n01;
  for (double a : d.angles_deg) {
    Vector6d e;
    for (int k = 0; k < 6; ++k) e(k) = 3.0 * n01(rng);
    test::add_truth_value(t, d.axis, a, e);
  }
  t.schedule = Schedule{5, 60, {Sweep::kCCW, Sweep::kCW}};
  t.effects = {effect(EffectKind::kDrift, "2r", {0.5}), effect(EffectKind::kReversal, "", {1.5})};
  const std::vector<Reading> r = simulate(d, t, 31);
  DiagnoseOptions whole_o, border_o;
  whole_o.estimate.border_min_columns = 0;
  border_o.estimate.border_min_columns = 100;
  const DiagnoseResult bordered = diagnose(d, r, border_o), whole = diagnose(d, r, whole_o);
  EXPECT_TRUE(has(bordered, "drift[2r]"));
  EXPECT_TRUE(has(bordered, "reversal[all]"));
  ASSERT_EQ(bordered.added.size(), whole.added.size());
  for (std::size_t k = 0; k < whole.added.size(); ++k)
    EXPECT_EQ(bordered.added[k].block.label, whole.added[k].block.label);
  EXPECT_FALSE(bordered.significant_after);
  EXPECT_EQ(bordered.after.rank, whole.after.rank);
  EXPECT_NEAR(bordered.after.chi2, whole.after.chi2, 1e-9 * whole.after.chi2);
  ASSERT_EQ(bordered.errors_after.size(), whole.errors_after.size());
  for (std::size_t s = 0; s < whole.errors_after.size(); ++s) {
    for (int k = 0; k < 6; ++k) {
      const Determined& a = whole.errors_after[s].errors[k];
      const Determined& b = bordered.errors_after[s].errors[k];
      ASSERT_EQ(a.determined, b.determined) << s << " " << k;
      EXPECT_NEAR(a.value, b.value, 1e-8) << s << " " << k;
      EXPECT_NEAR(a.std, b.std, 1e-8) << s << " " << k;
    }
  }
  EXPECT_EQ(io::diagnose_verdict(d, r, bordered), io::diagnose_verdict(d, r, whole));
}

// After --exclude-gross the result's rows index the readings given, not the readings fitted:
// the report must name the reading the JSON names. (It described the checks' features with
// the fitted readings: two readings excluded before a step put it two readings late.)
TEST(Diagnose, ReportNamesTheReadingsGivenAfterExcludingGrossOnes) {
  const Design d = fourier_design();
  const Truth t = io::read_truth_file(test::source_path("tests/data/truth_step.json"));
  std::vector<Reading> given = simulate(d, t, 1);
  for (std::size_t r : {given.size() / 3, 2 * given.size() / 3}) given[r].reading_um += 30;
  DiagnoseOptions o;
  o.exclude_gross = true;
  const DiagnoseResult r = diagnose(d, given, o);
  ASSERT_EQ(r.excluded_rows.size(), 2u);
  const std::string report = io::diagnose_report(io::ReportFormat::kMarkdown, {"test", {}}, d,
                                                 given, r, a_priori_expansion());
  // The five most significant features the report lists; those placed at a reading after an
  // excluded one were named wrongly.
  std::vector<const ResidualFeature*> top;
  for (const ResidualFeature& f : r.features_after) top.push_back(&f);
  std::sort(top.begin(), top.end(),
            [](const ResidualFeature* a, const ResidualFeature* b) { return a->p < b->p; });
  top.resize(std::min<std::size_t>(5, top.size()));
  int checked = 0;
  for (const ResidualFeature* f : top) {
    if (f->row <= r.excluded_rows.front()) continue;
    const Reading& at = given[static_cast<std::size_t>(f->row)];
    std::ostringstream where;
    where << "installation " << at.installation << " at " << at.angle_deg << " deg"
          << (at.sweep == Sweep::kCW ? " cw" : " ccw") << ", t = " << *at.time_s << " s";
    EXPECT_NE(report.find(where.str()), std::string::npos) << where.str() << "\n" << report;
    ++checked;
  }
  EXPECT_GT(checked, 0);
  // The HTML report's Details block keeps its lines (each line feed the block's own, no
  // replacement character in their place).
  const std::string html =
      io::diagnose_report(io::ReportFormat::kHtml, {"test", {}}, d, given, r, a_priori_expansion());
  const std::size_t pre = html.find("<pre>summary:\n");
  EXPECT_NE(pre, std::string::npos);
  EXPECT_EQ(html.find("\xEF\xBF\xBD"), std::string::npos);
}

// On the paper's C design one reading per angle is redundant: a gross reading in 2r at 100 deg
// explains the residual exactly as one in 1r at that angle would (their unexplained indicators
// are parallel). Both are named, with the offset each would have, and --exclude-gross leaves
// both in: dropping one would be a guess (before, it dropped 1r, kept the bad reading and
// reported dy 50.8 +- 1.3 um where the truth is 2).
TEST(Diagnose, AGrossReadingTheDataCannotPlaceIsNamedWithItsTwinsAndNotExcluded) {
  const Design d = test::paper_design('C');
  const Truth t = io::read_truth_file(test::source_path("tests/data/truth_c_per_angle.json"));
  std::vector<Reading> given = simulate(d, t, 3);
  int bad = -1;
  for (std::size_t j = 0; j < given.size(); ++j) {
    if (given[j].installation == "2r" && given[j].angle_deg == 100) bad = static_cast<int>(j);
  }
  ASSERT_GE(bad, 0);
  given[static_cast<std::size_t>(bad)].reading_um += 30;
  DiagnoseOptions o;
  o.exclude_gross = true;
  const DiagnoseResult r = diagnose(d, given, o);
  EXPECT_TRUE(r.excluded.empty());
  ASSERT_EQ(r.not_excluded.size(), 1u);
  const GrossReading& g = r.not_excluded[0];
  std::vector<int> named = g.indistinguishable;
  named.push_back(g.row);
  EXPECT_NE(std::find(named.begin(), named.end(), bad), named.end());
  for (int j : named) EXPECT_EQ(given[static_cast<std::size_t>(j)].angle_deg, 100);
  // Each with its own offset: 2r's is the 30 um put in (within the noise).
  for (std::size_t k = 0; k < g.indistinguishable.size(); ++k) {
    if (g.indistinguishable[k] == bad) EXPECT_NEAR(g.alternative_values_um[k], 30, 3);
  }
  if (g.row == bad) EXPECT_NEAR(g.value_um, 30, 3);
  const std::string verdict = io::diagnose_verdict(d, given, r);
  EXPECT_NE(verdict.find("installation 2r at 100 deg"), std::string::npos) << verdict;
  EXPECT_NE(verdict.find("the data cannot tell which"), std::string::npos) << verdict;
  EXPECT_NE(verdict.find("Not excluded"), std::string::npos) << verdict;
}

}  // namespace
}  // namespace dbbkit

namespace dbbkit {
namespace {

// The paper's B head data: scale.x and scale.z are the best candidates of step 3 with the same
// F and p to rounding (a symmetric design). The first in the pool's order, scale.x, is named
// the step's best; rounding had decided it (more_significant's tie, as for the scans).
TEST(Diagnose, TiedCandidatesNameTheFirst) {
  const Design d = test::paper_design('B');
  const DiagnoseResult r = diagnose(
      d, io::read_measurement_file(test::source_path("tests/data/paper/paper_b_head.csv"), d));
  const CandidateStatus* x = nullptr;
  const CandidateStatus* z = nullptr;
  for (const CandidateStatus& c : r.candidates) {
    if (c.label == "scale.x") x = &c;
    if (c.label == "scale.z") z = &c;
  }
  ASSERT_TRUE(x && z);
  ASSERT_GT(x->p, 0);
  EXPECT_NEAR(x->p, z->p, kSignificanceTie * x->p);  // a tie
  EXPECT_NEAR(x->F, z->F, kSignificanceTie * x->F);
  EXPECT_TRUE(x->missed.has_value());
  EXPECT_FALSE(z->missed.has_value());
}

}  // namespace
}  // namespace dbbkit
