// A drift seen by design: the return reading (each sweep reads its first angle again at its end)
// in the design file, the program, simulate and readings, and evaluate's statement of how far an
// undetected drift or warm-up over the whole test moves each error, checked against what identify
// does with simulated readings (exact two-ball geometry) that carry one.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>
#include <string>

#include "dbbkit/error.hpp"
#include "dbbkit/identify.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/kit_io.hpp"
#include "dbbkit/io/program_io.hpp"
#include "dbbkit/observability.hpp"
#include "dbbkit/optimize.hpp"
#include "dbbkit/program.hpp"
#include "dbbkit/setup_sheet.hpp"
#include "dbbkit/simulate.hpp"
#include "dbbkit/trace.hpp"
#include "test_util.hpp"

namespace dbbkit {
namespace {

Design b_head(bool return_reading) {
  Design d = io::read_design_file(test::source_path("designs/b-head-kit-optimized.json"));
  d.return_reading = return_reading;
  return d;
}

TEST(ReturnReading, TheDesignKeyIsReadWrittenAndChecked) {
  nlohmann::json j = io::design_to_json(b_head(false));
  EXPECT_FALSE(j.contains("return_reading"));
  j["return_reading"] = true;
  const Design d = io::design_from_json(j, "d.json");
  EXPECT_TRUE(d.return_reading);
  EXPECT_EQ(d.readings_per_sweep(0), static_cast<int>(d.angles_deg.size()) + 1);
  EXPECT_EQ(io::design_to_json(d)["return_reading"], true);
  j["return_reading"] = "yes";
  try {
    io::design_from_json(j, "d.json");
    FAIL() << "a return_reading that is not true or false was taken";
  } catch (const InputError& e) {
    EXPECT_EQ(e.where(), "return_reading");
  }
}

// The program turns back along the sweep's arc to the first angle and dwells there once more,
// the dwell named the return reading and its approach; simulate takes the same reading, the
// opposite sweep, after the sweep's last.
TEST(ReturnReading, ProgramAndSimulateTakeItAtTheEndOfEachSweep) {
  // A head on its machine (a part program needs the spindle pointing down).
  Design d = io::read_design_file(test::source_path("designs/paper-b-c-B-off-axis.json"));
  d.return_reading = true;
  ProgramOptions o;
  o.sweeps = ProgramOptions::Sweeps::kBoth;
  const MeasurementProgram p = measurement_program(d, o);
  const std::size_t n_angles = d.angles_deg.size();
  const double lo = *std::min_element(d.angles_deg.begin(), d.angles_deg.end());
  const double hi = *std::max_element(d.angles_deg.begin(), d.angles_deg.end());
  for (const InstallationProgram& ip : p.installations) {
    ASSERT_EQ(ip.sweeps.size(), 2u);
    EXPECT_EQ(ip.readings, static_cast<int>(2 * (n_angles + 1)));
    for (const ProgramSweep& s : ip.sweeps) {
      std::vector<const ProgramPosition*> reads;
      for (const ProgramPosition& q : s.positions)
        if (q.reading) reads.push_back(&q);
      ASSERT_EQ(reads.size(), n_angles + 1);
      EXPECT_TRUE(reads.back()->return_reading);
      EXPECT_EQ(reads.back()->angle_deg, reads.front()->angle_deg);
      EXPECT_EQ(reads.front()->angle_deg, s.direction == Sweep::kCCW ? lo : hi);
      // No position outside the sweep's arc: the return retraces it.
      for (const ProgramPosition& q : s.positions) {
        EXPECT_GE(q.angle_deg, lo - 1e-9);
        EXPECT_LE(q.angle_deg, hi + 1e-9);
      }
    }
  }
  // Between sweeps too: after a return reading the next sweep's start is reached along the arc,
  // never in one move (the bar would leave its path).
  for (const InstallationProgram& ip : p.installations) {
    double at = ip.sweeps.front().positions.front().angle_deg;
    for (const ProgramSweep& s : ip.sweeps) {
      for (const ProgramPosition& q : s.positions) {
        EXPECT_LE(std::abs(q.angle_deg - at), 20.0 + 1e-9);
        at = q.angle_deg;
      }
    }
  }
  const std::string text = io::program_text(d, p, io::Dialect::kIso);
  EXPECT_NE(text.find("-100 deg return cw)"), std::string::npos);
  EXPECT_NE(text.find(" 0 deg return ccw)"), std::string::npos);

  // readings matches a trace's dwells to the same stops: the return is a stop of its own.
  const std::vector<Stop> stops = program_stops(d, 0, {Sweep::kCCW, Sweep::kCW});
  ASSERT_EQ(stops.size(), 2 * (n_angles + 1));
  EXPECT_EQ(stops[n_angles].angle_deg, lo);
  EXPECT_EQ(stops[n_angles].sweeps, std::vector<Sweep>{Sweep::kCW});
  EXPECT_EQ(stops.back().angle_deg, hi);
  EXPECT_EQ(stops.back().sweeps, std::vector<Sweep>{Sweep::kCCW});

  Truth t;
  t.model = d.errors;
  t.errors_given = false;
  t.noiseless = true;
  t.schedule = Schedule{10, 240, {Sweep::kCCW, Sweep::kCW}};
  const std::vector<Reading> r = simulate(d, t, 1);
  ASSERT_EQ(r.size(), d.installations.size() * 2 * (n_angles + 1));
  const Reading& ret = r[n_angles];  // the first sweep's return reading
  EXPECT_EQ(ret.installation, d.installations[0].id);
  EXPECT_EQ(ret.angle_deg, r[0].angle_deg);
  EXPECT_EQ(*ret.sweep, Sweep::kCW);
  EXPECT_GT(*ret.time_s, *r[n_angles - 1].time_s);

  // Angles written in decreasing order: the return is still the program's (the smallest angle
  // for a ccw sweep).
  Design reversed = d;
  std::reverse(reversed.angles_deg.begin(), reversed.angles_deg.end());
  t.schedule = Schedule{10, 240, {Sweep::kCCW}};
  const std::vector<Reading> rr = simulate(reversed, t, 1);
  EXPECT_EQ(rr[n_angles].angle_deg, lo);
  EXPECT_EQ(*rr[n_angles].sweep, Sweep::kCW);
}

// Evaluate's bias per um of a drift (or warm-up) over the test is what identify does with
// readings carrying exactly that: exact two-ball geometry, no axis error, no noise, the drift on
// simulate's own clock (3 s a reading, 240 s between installations, one ccw sweep).
// No axis errors, no noise, the exact geometry, evaluate's nominal clock (3 s a reading, 240 s
// between installations, one increasing sweep): what a drift added to it does alone.
Truth drift_only_truth(const Design& d) {
  Truth t;
  t.model = d.errors;
  t.errors_given = false;
  t.noiseless = true;
  t.exact = true;
  t.schedule = Schedule{3, 240, {Sweep::kCCW}};
  return t;
}

TEST(DriftCheck, TheStatedBiasIsWhatIdentifyMoves) {
  for (const bool ret : {false, true}) {
    Design d = b_head(ret);
    d.setup_std.length_offset_um = 1;
    d.setup_std.centring_um = 5;
    const double ref = 100;
    const Evaluation ev = evaluate_design(d, ref);
    ASSERT_EQ(ev.drift.effects.size(), 2u);
    const double T_min = ev.drift.test_min;
    // The test's length on simulate's clock: installations x (readings x 3 s + 240 s), less the
    // 240 s after the last and the 3 s after the last reading.
    const double per_inst = d.readings_per_sweep(0) * 3.0 + 240.0;
    EXPECT_NEAR(T_min * 60, d.installations.size() * per_inst - 240 - 3, 1e-9);
    for (const DriftCheck& c : ev.drift.effects) {
      ASSERT_TRUE(c.bias_per_um) << c.label;
      Truth t = drift_only_truth(d);
      TruthEffect e;
      e.effect.kind = c.kind;
      e.effect.tau_min = c.tau_min;
      // 1 um over the test: a drift of 1 / T um/min; a warm-up whose curve rises 1 um by the end.
      e.value = Eigen::VectorXd::Constant(1, c.kind == EffectKind::kDrift
                                                 ? 1.0 / T_min
                                                 : 1.0 / (1.0 - std::exp(-T_min / c.tau_min)));
      t.effects.push_back(e);
      const IdentifyResult id = identify(d, simulate(d, t, 1));
      double largest = 0;
      int at_error = -1;
      double at_angle = 0;
      for (const auto& ea : id.errors) {
        for (int k = 0; k < 6; ++k) {
          if (!ea.errors[k].determined) continue;
          const double v = std::abs(ea.errors[k].value) * (k >= 3 ? 1e-3 * ref : 1.0);
          if (v > largest) largest = v, at_error = k, at_angle = ea.angle_deg;
        }
      }
      EXPECT_EQ(at_error, c.bias_error) << c.label << (ret ? " with return" : "");
      EXPECT_EQ(at_angle, c.bias_angle_deg) << c.label;
      EXPECT_NEAR(largest, *c.bias_um_per_um, 0.01 * *c.bias_um_per_um) << c.label;
    }
  }
}

// The test's clock runs the installations in the order the program runs them, not the design's:
// on a design whose set-up sheet reorders them, simulate's first reading is the program's first
// installation's, and the bias evaluate states for a drift over the test is what identify moves.
TEST(DriftCheck, TheClockFollowsTheProgramsOrder) {
  const Design d =
      io::read_design_file(test::source_path("designs/c-turntable-kit-setup-optimized.json"));
  const SetupOrder order = setup_order(d);
  ASSERT_NE(order.steps.front().installation, 0) << "a design the program reorders";
  const std::string first = d.installations[order.steps.front().installation].id,
                    last = d.installations[order.steps.back().installation].id;
  const Evaluation ev = evaluate_design(d, 100);
  const DriftCheck* drift = nullptr;
  for (const DriftCheck& c : ev.drift.effects)
    if (c.kind == EffectKind::kDrift) drift = &c;
  ASSERT_TRUE(drift && drift->bias_um_per_um);
  Truth t = drift_only_truth(d);
  TruthEffect e;
  e.effect.kind = EffectKind::kDrift;
  e.value = Eigen::VectorXd::Constant(1, 1.0 / ev.drift.test_min);
  t.effects.push_back(e);
  const std::vector<Reading> rd = simulate(d, t, 1);
  double t_end = 0;
  std::string at_end;
  for (const Reading& r : rd) {
    if (*r.time_s == 0) EXPECT_EQ(r.installation, first);
    if (*r.time_s >= t_end) t_end = *r.time_s, at_end = r.installation;
  }
  EXPECT_EQ(at_end, last);
  EXPECT_NEAR(t_end / 60, ev.drift.test_min, 1e-9);
  const IdentifyResult id = identify(d, rd);
  double largest = 0;
  for (const auto& ea : id.errors) {
    for (int k = 0; k < 6; ++k) {
      if (ea.errors[k].determined)
        largest = std::max(largest, std::abs(ea.errors[k].value) * (k >= 3 ? 0.1 : 1.0));
    }
  }
  EXPECT_NEAR(largest, *drift->bias_um_per_um, 0.01 * *drift->bias_um_per_um);
}

// A design with a return reading says what it detects; one without says what the return reading
// would bring when it brings something.
TEST(DriftCheck, EvaluateStatesTheLimitWithAndWithoutTheReturnReading) {
  const Evaluation without = evaluate_design(b_head(false), 100);
  ASSERT_TRUE(without.drift_with_return);
  const Evaluation with = evaluate_design(b_head(true), 100);
  EXPECT_FALSE(with.drift_with_return);
  EXPECT_EQ(with.prior.n_readings,
            without.prior.n_readings + static_cast<int>(b_head(true).installations.size()));
  for (std::size_t k = 0; k < 2; ++k) {
    const DriftCheck &a = with.drift.effects[k], &b = without.drift_with_return->effects[k];
    EXPECT_EQ(a.label, b.label);
    EXPECT_EQ(a.detectable, b.detectable);
    ASSERT_EQ(a.detection_limit_um.has_value(), b.detection_limit_um.has_value());
    if (a.detection_limit_um)
      EXPECT_NEAR(*a.detection_limit_um, *b.detection_limit_um, 1e-9 * *a.detection_limit_um);
  }
}

}  // namespace
}  // namespace dbbkit

namespace dbbkit {
namespace {

// The kit's B head at one angle step (two choices): optimize --require-detect drift=UM keeps the
// designs whose drift over the test diagnose detects from UM (evaluate then states a limit no
// larger, on the kit's clock) and that determine every error; a size no full-rank design reaches
// leaves no feasible design, never a design that meets it by losing rank.
TEST(DriftCheck, OptimizeRequiresTheDriftDetected) {
  Kit kit = io::read_kit_file(test::source_path("designs/kits/b-head-kit.json"));
  kit.angle_steps_deg = {20};
  kit.require_drift_detection_um = 30;
  const OptimizeResult met = optimize_kit(kit, {Criterion::kWorstTotal, 2});
  ASSERT_TRUE(met.best);
  ASSERT_TRUE(met.best->detection);
  EXPECT_LE(met.best->detection->ratio, 1.0);
  EXPECT_EQ(met.best_evaluation.prior.rank, met.best_evaluation.prior.n_unknowns);
  const TestClock clock{kit.time_per_reading_s, kit.time_per_installation_s};
  const DriftChecks d = design_drift_checks(met.best->design, kit.reference_length_mm,
                                            met.best->detection->settings, clock);
  ASSERT_FALSE(d.effects.empty());
  ASSERT_TRUE(d.effects[0].detection_limit_um);
  EXPECT_LE(*d.effects[0].detection_limit_um, 30.0);

  kit.require_drift_detection_um = 15;
  const OptimizeResult unmet = optimize_kit(kit, {Criterion::kWorstTotal, 2});
  EXPECT_FALSE(unmet.best && unmet.best->feasible);
}

// A required drift is a size a result can print (at least 1 nm) and a machine can have (at most
// 1 mm): below or above, the kit's key is refused saying both bounds (1e-300 was taken, and
// printed as 0).
TEST(DriftCheck, ARequiredDriftIsOneAResultCanState) {
  std::ifstream in(test::source_path("designs/kits/b-head-kit.json"));
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string head = "\"format\": \"dbbkit.kit/1\",";
  ASSERT_NE(text.find(head), std::string::npos);
  const auto with = [&](const std::string& value) {
    std::string t = text;
    t.insert(t.find(head) + head.size(), " \"require_drift_detection_um\": " + value + ",");
    return t;
  };
  for (const char* bad : {"0", "1e-300", "0.0009", "1000.5"}) {
    try {
      io::kit_from_text(with(bad), "kit.json");
      ADD_FAILURE() << bad << " was taken";
    } catch (const InputError& e) {
      const std::string m = e.what();
      EXPECT_NE(m.find("require_drift_detection_um"), std::string::npos) << m;
      EXPECT_NE(m.find("at least 0.001 and at most 1000"), std::string::npos) << m;
    }
  }
  EXPECT_EQ(*io::kit_from_text(with("0.001"), "kit.json").require_drift_detection_um, 0.001);
}

}  // namespace
}  // namespace dbbkit
