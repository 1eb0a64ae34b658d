// diagnose with set-up tolerances declared: the set-up effects within them are nuisance, carried
// as identify carries them (not findings); one read beyond its tolerance is found and said to be
// beyond it; with a real set-up (drawn within the tolerances, exact two-ball geometry) a drift of
// one installation is found as a drift, not a step, and clean readings add nothing, at about the
// rates of readings without set-up errors.
#include <gtest/gtest.h>

#include <iostream>
#include <random>
#include <string>

#include "dbbkit/diagnose.hpp"
#include "dbbkit/identify.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/diagnose_text.hpp"
#include "dbbkit/simulate.hpp"
#include "diagnose_util.hpp"
#include "test_util.hpp"

namespace dbbkit {
namespace {

// The optimised B head of the kit with tolerances of 1 um (length offset) and 5 um (centring)
// declared.
Design declared_b_head() {
  Design d = io::read_design_file(test::source_path("designs/b-head-kit-optimized.json"));
  d.setup_std.length_offset_um = 1;
  d.setup_std.centring_um = 5;
  return d;
}

// Location errors, exact two-ball geometry, a set-up drawn within the tolerances, three sweeps of
// each installation (ccw, cw, ccw: with two, a drift of one installation is mostly its mean, which
// its length offset takes, and its size is seldom told), a reading every 10 s and 4 min between
// installations.
Truth truth_with_setup(const Design& d, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1, 1);
  Truth t;
  t.model = d.errors;
  t.exact = true;
  t.errors_given = false;
  t.location = {{"X0B", 20 * u(rng)}, {"Z0B", 20 * u(rng)}, {"A0B", 30 * u(rng)}};
  t.setup_draw.length_offset_um = 1;
  t.setup_draw.centring_um = 5;
  t.schedule = Schedule{10, 240, {Sweep::kCCW, Sweep::kCW, Sweep::kCCW}};
  return t;
}

bool any_setup_effect(const DiagnoseResult& r) {
  for (const AddedEffect& a : r.added) {
    const EffectKind k = a.block.effect.kind;
    if (k == EffectKind::kLengthOffset || k == EffectKind::kCentring) return true;
  }
  return false;
}

// Clean readings within the tolerances: nothing found in at least 90 % (the level is 1 %; the
// exact geometry's second order and the set-up's third centring component are not in the
// model), no set-up effect found in at least 90 %; and where nothing is found, diagnose's
// errors are identify's: the same values and uncertainties (the declared tolerances in both).
TEST(DiagnoseDeclaredSetUp, WithinTheTolerancesNothingIsFoundAndTheErrorsAreIdentifys) {
  const Design d = declared_b_head();
  std::mt19937_64 rng(58);
  const int n = 40;
  int nothing = 0, setup_found = 0, compared = 0;
  for (int s = 0; s < n; ++s) {
    const Truth t = truth_with_setup(d, rng);
    const std::vector<Reading> readings = simulate(d, t, 5800 + s);
    const DiagnoseResult r = diagnose(d, readings);
    setup_found += any_setup_effect(r);
    if (!r.added.empty()) continue;
    ++nothing;
    const IdentifyResult id = identify(d, readings);
    for (std::size_t st = 0; st < id.errors.size(); ++st) {
      for (int k = 0; k < 6; ++k) {
        const Determined &a = id.errors[st].errors[k], &b = r.errors_after[st].errors[k];
        ASSERT_EQ(a.determined, b.determined);
        if (!a.determined) continue;
        // The same to the solvers' rounding (two factorisations of one model).
        EXPECT_NEAR(b.value, a.value, 1e-4 * a.std);
        EXPECT_NEAR(b.std, a.std, 1e-4 * a.std);
      }
    }
    int carried = 0;
    for (const CandidateStatus& c : r.candidates) {
      if (c.state != CandidateState::kSetUp) continue;
      ++carried;
      EXPECT_TRUE(c.label.rfind("length_offset[", 0) == 0 || c.label.rfind("centring[", 0) == 0)
          << c.label;
    }
    EXPECT_GT(carried, 0);
    ++compared;
  }
  std::cout << "within the declared tolerances: nothing found in " << nothing << " of " << n
            << ", a set-up effect found in " << setup_found << "\n";
  EXPECT_GE(nothing, 0.9 * n);
  EXPECT_LE(setup_found, 0.1 * n);
  EXPECT_GT(compared, 0);
}

// A drift of 1.5 um/min in one installation (drawn), with a real set-up: found as that drift in
// at least 90 % (when diagnose sought the set-up's centrings as findings, the declared
// tolerances aside, a step won over the drift in 6 of 60).
TEST(DiagnoseDeclaredSetUp, ADriftIsFoundAsADriftNotAStep) {
  const Design d = declared_b_head();
  std::mt19937_64 rng(59);
  const int n = 40;
  int right = 0, steps = 0;
  std::uniform_int_distribution<int> pick(0, static_cast<int>(d.installations.size()) - 1);
  for (int s = 0; s < n; ++s) {
    Truth t = truth_with_setup(d, rng);
    const std::string inst = d.installations[static_cast<std::size_t>(pick(rng))].id;
    t.effects = {test::effect(EffectKind::kDrift, inst, {1.5})};
    const DiagnoseResult r = diagnose(d, simulate(d, t, 5900 + s));
    right += test::has(r, "drift[" + inst + "]");

    for (const AddedEffect& a : r.added) steps += a.block.effect.kind == EffectKind::kStep;
  }
  std::cout << "a 1.5 um/min drift with a real set-up: found as the drift in " << right << " of "
            << n << ", a step added in " << steps << "\n";
  EXPECT_GE(right, 0.9 * n);
  EXPECT_LE(steps, 0.1 * n);
}

// A bar 15 um long in installation 3r, where 1 um is declared: found, and said to be beyond the
// declared tolerance. (In 2r this design cannot tell it from a squareness of the linear axes,
// and says so; in a tangential or axial installation it cannot see it at all.)
TEST(DiagnoseDeclaredSetUp, ALengthOffsetBeyondItsToleranceIsFoundAndSaidSo) {
  const Design d = declared_b_head();
  std::mt19937_64 rng(60);
  Truth t = truth_with_setup(d, rng);
  t.setup_draw = {};
  SetupError offset;
  offset.length_offset_um = 15;
  t.setup_given = {{"3r", offset}};
  const DiagnoseResult r = diagnose(d, simulate(d, t, 61));
  bool found = false;
  for (const AddedEffect& a : r.added) found = found || a.block.label == "length_offset[3r]";
  EXPECT_TRUE(found) << io::diagnose_verdict(d, {}, r);
  std::string text;
  for (const io::BriefItem& b : io::diagnose_brief(d, r)) text += b.text + "\n";
  EXPECT_NE(text.find("(beyond its declared tolerance, 1 um)"), std::string::npos) << text;
}

}  // namespace
}  // namespace dbbkit
