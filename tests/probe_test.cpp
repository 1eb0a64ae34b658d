// The touch probe on calibration spheres, the second instrument (instrument.hpp): its readings
// made here from the real axis line alone (test_util's RealLine, no first-order algebra of
// dbbkit's), identified, and the location errors found against the line's; the row against the
// exact reading; the file forms; what only a ball bar has refused.

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <random>
#include <sstream>

#include "cli_util.hpp"
#include "dbbkit/diagnose.hpp"
#include "dbbkit/effects.hpp"
#include "dbbkit/error.hpp"
#include "dbbkit/identify.hpp"
#include "dbbkit/instrument.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/diagnose_io.hpp"
#include "dbbkit/io/kit_io.hpp"
#include "dbbkit/io/measurement_io.hpp"
#include "dbbkit/io/optimize_io.hpp"
#include "dbbkit/io/result_io.hpp"
#include "dbbkit/iso230.hpp"
#include "dbbkit/kinematics.hpp"
#include "dbbkit/limits.hpp"
#include "dbbkit/observability.hpp"
#include "dbbkit/optimize.hpp"
#include "dbbkit/program.hpp"
#include "dbbkit/simulate.hpp"
#include "test_util.hpp"

namespace dbbkit {
namespace probe_test {

// A probe design on `axis`: spheres at the body coordinates given, per-angle errors.
Design probe_design(const AxisFrame& axis, const std::vector<Sphere>& spheres,
                    const std::vector<double>& angles, double sigma_um) {
  Design d;
  d.name = "probe";
  d.axis = axis;
  d.angles_deg = angles;
  d.noise.distribution = NoiseModel::Distribution::kNormal;
  d.noise.std_um = sigma_um;
  d.instrument = InstrumentKind::kProbe;
  d.spheres = spheres;
  d.installations = probe_channels(axis, spheres);
  validate_design(d);
  return d;
}

std::vector<double> steps(double start, double stop, double step) {
  std::vector<double> a;
  for (double x = start; x <= stop + 1e-9; x += step) a.push_back(x);
  return a;
}

Design three_spheres_c() {
  return probe_design(test::kAxisC,
                      {{"s1", 150, 0, 80, ""}, {"s2", 150, 0, 230, ""}, {"s3", 100, 120, 80, ""}},
                      steps(0, 330, 30), 0.5);
}

Design three_points_b() {
  return probe_design(test::kAxisB,
                      {{"p1", 150, 0, 0, ""}, {"p2", 250, 0, 0, ""}, {"p3", 150, 80, 0, ""}},
                      steps(-90, 90, 15), 0.5);
}

// The probe's readings of the real axis line, by hand: a sphere on a table is really at the
// body point turned about the real line, nominally turned about the nominal one, and the probe
// reads the difference; on a head the probe's tip is the point so turned and the sphere stands
// still, so the probed centre moves the other way. Plus normal noise of sigma.
std::vector<Reading> readings_of_line(const Design& d, const test::RealLine& line,
                                      std::mt19937_64& rng, double sigma_um) {
  std::normal_distribution<double> noise(0.0, sigma_um);
  std::vector<Reading> out;
  for (const Sphere& s : d.spheres) {
    const Eigen::Vector3d P0 = d.axis.body_point(s.L_mm, s.D_mm, s.H_mm);
    for (double a : d.angles_deg) {
      const Eigen::Vector3d real = test::turn(line, a, P0);
      const Eigen::Vector3d nominal = axis_rotation(d.axis, a) * P0;
      const Eigen::Vector3d moved_um = 1e3 * (real - nominal) * (d.axis.head() ? -1.0 : 1.0);
      for (int k = 0; k < 3; ++k) {
        Reading r;
        r.installation = probe_channel_id(s.id, k);
        r.angle_deg = a;
        r.reading_um = moved_um(k) + (sigma_um > 0 ? noise(rng) : 0.0);
        out.push_back(r);
      }
    }
  }
  return out;
}

// A truth of the five location errors (the axis' ISO order), errors none beside them.
Truth location_truth(const AxisFrame& axis, const std::array<double, 5>& loc) {
  Truth t;
  const IsoNames names = iso230_names(axis);
  for (int j = 0; j < 5; ++j)
    t.location.emplace_back(names.location[static_cast<std::size_t>(j)], loc[j]);
  t.errors_given = false;
  return t;
}

// Random location errors: positions within +-20 um, orientations within +-50 urad, the zero
// within +-30 urad.
std::array<double, 5> random_location(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1, 1);
  return {20 * u(rng), 20 * u(rng), 50 * u(rng), 50 * u(rng), 30 * u(rng)};
}

void check_recovers_line(const Design& d, int cases, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  IdentifyOptions options;
  options.iso_motion.enabled = false;
  int held = 0, checked = 0;
  for (int c = 0; c < cases; ++c) {
    const std::array<double, 5> loc = random_location(rng);
    const test::RealLine line = test::line_of(d.axis, loc);
    // Without noise: the location errors to the second order of the line's (a few nm).
    {
      const IdentifyResult r = identify(d, readings_of_line(d, line, rng, 0.0), options);
      ASSERT_EQ(r.iso.location.size(), 5u);
      for (int j = 0; j < 5; ++j) {
        ASSERT_TRUE(r.iso.location[static_cast<std::size_t>(j)].value.determined)
            << r.iso.location[static_cast<std::size_t>(j)].name;
        EXPECT_NEAR(r.iso.location[static_cast<std::size_t>(j)].value.value, loc[j], 0.02)
            << r.iso.location[static_cast<std::size_t>(j)].name << " case " << c;
      }
    }
    // With the declared noise: the truth within 3 standard uncertainties.
    const IdentifyResult r = identify(d, readings_of_line(d, line, rng, d.noise.std_um), options);
    for (int j = 0; j < 5; ++j) {
      const Determined& v = r.iso.location[static_cast<std::size_t>(j)].value;
      ++checked;
      held += std::abs(v.value - loc[j]) <= 3 * v.std;
    }
  }
  // P(|z| > 3) = 0.27 %: of 5 cases x 5 values, none outside but by chance.
  EXPECT_GE(held, checked - 1) << held << " of " << checked;
}

TEST(Probe, ATableRealLineIsFoundFromItsSpheresByHandGeometry) {
  check_recovers_line(three_spheres_c(), 5, 11);
}

TEST(Probe, AHeadRealLineIsFoundFromItsProbeTipByHandGeometry) {
  check_recovers_line(three_points_b(), 5, 12);
}

TEST(Probe, TheSimulatorsExactReadingIsTheRealLinesByHand) {
  // simulate's exact geometry (the transform of the error motions) against the line turned by
  // hand, through a truth of location errors.
  for (const Design& d : {three_spheres_c(), three_points_b()}) {
    const std::array<double, 5> loc = {12, -7, 20, -15, 25};
    Truth t = location_truth(d.axis, loc);
    t.exact = true;
    t.noiseless = true;
    std::mt19937_64 rng(1);
    const std::vector<Reading> by_hand = readings_of_line(d, test::line_of(d.axis, loc), rng, 0.0);
    const std::vector<Reading> simulated = simulate(d, t, 1);
    ASSERT_EQ(simulated.size(), by_hand.size());
    std::map<std::pair<std::string, double>, double> want;
    for (const Reading& r : by_hand) want[{r.installation, r.angle_deg}] = r.reading_um;
    for (const Reading& r : simulated)
      // The truth adds the location errors to first order (iso230.md), the line turns exactly:
      // apart by the tilt times the offset, 1e-3 um.
      EXPECT_NEAR(r.reading_um, (want.at({r.installation, r.angle_deg})), 5e-3)
          << r.installation << " at " << r.angle_deg;
  }
}

TEST(Probe, TheRowIsTheExactReadingsDerivative) {
  const Design d = three_spheres_c();
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  for (const Installation& c : d.installations) {
    for (double a : {0.0, 37.0, 211.0}) {
      const RowVector6d row = J_reading_error(d.axis, c, a);
      for (int k = 0; k < 6; ++k) {
        Vector6d e = Vector6d::Zero();
        e(k) = 1e-2;  // um or urad: the second order is 1e-4 of the first
        const double fd = exact_probe_reading_um(d.axis, c, a, e, {}) / 1e-2;
        EXPECT_NEAR(fd, row(k), 1e-6 * (1 + std::abs(row(k)))) << c.id << " " << a << " " << k;
      }
    }
  }
  // A head's channel reads the other way: the probe's tip moves, the sphere does not.
  const Design b = three_points_b();
  const Installation& x = b.installations[0];
  EXPECT_EQ(x.sign, -1);
  Vector6d e = Vector6d::Zero();
  e(0) = 1.0;
  EXPECT_DOUBLE_EQ(J_reading_error(b.axis, x, 30.0)(0), -1.0);
  EXPECT_NEAR(exact_probe_reading_um(b.axis, x, 30.0, e, {}), -1.0, 1e-9);
}

TEST(Probe, TwoSpheresOnOneVerticalLineCannotSeeARotationAboutIt) {
  // The rigid motion no reading sees: a rotation about the line through both spheres, at every
  // angle (by hand: both centres lie on it, so neither moves).
  const Design d = probe_design(test::kAxisC, {{"s1", 150, 0, 80, ""}, {"s2", 150, 0, 230, ""}},
                                steps(0, 330, 30), 0.5);
  const Evaluation ev = evaluate_design(d, 100.0);
  EXPECT_EQ(ev.prior.rank, ev.prior.n_unknowns - 12);
  ASSERT_EQ(ev.unidentifiable.size(), 12u);
  for (const Unidentifiable& u : ev.unidentifiable) {
    ASSERT_TRUE(u.motion && u.angle_deg);
    EXPECT_EQ(u.motion->kind, RigidMotion::Kind::kRotation);
    EXPECT_TRUE(u.motion->on_all_balls);
    EXPECT_NEAR(std::abs(u.motion->direction.z()), 1.0, 1e-9);
    const Eigen::Vector3d through =
        axis_rotation(d.axis, *u.angle_deg) * Eigen::Vector3d(150, 0, 0);
    EXPECT_NEAR(u.motion->point_mm.x(), through.x(), 1e-6);
    EXPECT_NEAR(u.motion->point_mm.y(), through.y(), 1e-6);
    // Said of the spheres' centres, not of balls.
    const std::string said = io::unidentifiable_interpretation(u);
    EXPECT_NE(said.find("every sphere's centre of the design lies on that line"), std::string::npos)
        << said;
    EXPECT_EQ(said.find("ball"), std::string::npos) << said;
  }
  // A third sphere off that line sees every error at every angle.
  EXPECT_EQ(evaluate_design(three_spheres_c(), 100.0).prior.rank,
            evaluate_design(three_spheres_c(), 100.0).prior.n_unknowns);
}

TEST(Probe, APlacementAcrossThePlaneOfThreeSpheresIsTakenByTheAxisErrors) {
  // By hand: with the other two spheres fixed, the one rigid motion that moves a sphere is the
  // rotation about the line through the other two, which moves it along the normal of the
  // three spheres' plane; per-angle errors take any rigid motion at each angle, so a placement
  // of s1 along that normal is never seen, and every other direction is.
  const Design d = three_spheres_c();
  const Evaluation ev = evaluate_design(d, 100.0);
  const Eigen::Vector3d s1(150, 0, 80), s2(150, 0, 230), s3(100, 120, 80);
  const Eigen::Vector3d n = ((s2 - s1).cross(s3 - s1)).normalized();
  int checked = 0;
  for (const SetupEffectCheck& c : ev.setup_checks) {
    if (c.kind != EffectKind::kPlacement) continue;
    EXPECT_FALSE(c.detectable) << c.label;
    ASSERT_EQ(c.hidden_directions.size(), 1u) << c.label;
    ASSERT_EQ(c.parameters, (std::vector<std::string>{"dL", "dD", "dH"}));
    const std::vector<double>& v = c.hidden_directions[0];
    const Eigen::Vector3d h(v[0], v[1], v[2]);
    EXPECT_NEAR(h.norm(), 1.0, 1e-12);
    EXPECT_NEAR(std::abs(h.dot(n)), 1.0, 1e-6) << c.label << ": " << h.transpose();
    const std::string text = io::hidden_directions_text(c);
    EXPECT_NE(text.find("as a whole: the axis errors take (dL, dD, dH) = ("), std::string::npos)
        << text;
    ++checked;
  }
  EXPECT_EQ(checked, 3);
  // The warning's bias is that of the unseen direction, and says so (the check's is the largest
  // over every direction).
  bool warned = false;
  for (const Warning& w : ev.warnings)
    if (w.kind == "setup_undeclared") {
      warned = true;
      EXPECT_NE(w.text.find("along the direction no reading sees"), std::string::npos) << w.text;
    }
  EXPECT_TRUE(warned);
  // Each component alone adds what the axis errors cannot reproduce: diagnose can find it.
  int components = 0;
  for (const CandidateStatus& c : effect_detectability(d, nominal_readings(d)))
    if (c.label.rfind("placement.", 0) == 0 && ++components)
      EXPECT_EQ(c.state, CandidateState::kDetectable) << c.label;
  EXPECT_EQ(components, 9);
  // The JSON states the direction by parameter.
  const nlohmann::json j = io::setup_checks_to_json(ev.setup_checks, 100.0);
  for (const nlohmann::json& e : j)
    if (e["effect"].get<std::string>().rfind("placement", 0) == 0)
      EXPECT_EQ(e["hidden_directions"].size(), 1u) << e.dump();
    else
      EXPECT_TRUE(e["hidden_directions"].empty()) << e.dump();
}

TEST(Probe, DiagnoseFindsASphereOffItsStatedCentreAndATriggerOffset) {
  const Design d = three_spheres_c();
  Truth t = location_truth(d.axis, {8, -5, 15, 10, 0});
  t.exact = true;
  TruthEffect placed;
  placed.effect.kind = EffectKind::kPlacement;
  placed.installation = "s3";
  // In the plane of the three spheres: across it, a placement of s3 is a rotation of the table
  // about the line through s1 and s2 at every angle, which no reading tells apart.
  placed.value = Eigen::Vector3d(-5.0, 12.0, 0.0);
  TruthEffect trigger;
  trigger.effect.kind = EffectKind::kTriggerOffset;
  trigger.installation = "s1:z";
  trigger.value = Eigen::VectorXd::Constant(1, 3.0);
  t.effects = {placed, trigger};
  const std::vector<Reading> readings = simulate(d, t, 5);
  const DiagnoseResult r = diagnose(d, readings);
  std::vector<std::string> found;
  for (const AddedEffect& a : r.added) found.push_back(a.block.label);
  auto has = [&](const std::string& prefix) {
    for (const std::string& f : found)
      if (f.rfind(prefix, 0) == 0) return true;
    return false;
  };
  EXPECT_TRUE(has("placement.dL[s3]") || has("placement.dD[s3]"))
      << ::testing::PrintToString(found);
  EXPECT_TRUE(has("trigger_offset[s1:z]")) << ::testing::PrintToString(found);
  EXPECT_FALSE(r.significant_after);
  // The residual's tables name a row by its channel and place the sphere fully: s3 lies off the
  // plane through the axis (D = 120 mm), so D is a column beside L and H.
  const std::string text = io::diagnose_summary(d, readings, r);
  EXPECT_NE(text.find(" channel    L_mm    D_mm    H_mm    n"), std::string::npos) << text;
  EXPECT_NE(text.find("    s3:x   100.0   120.0    80.0"), std::string::npos) << text;
  EXPECT_EQ(text.find("inst "), std::string::npos) << text;
}

TEST(Probe, EffectsBelongToTheirInstrument) {
  const Design d = three_spheres_c();
  EXPECT_EQ(effect_from_label(d, "placement[s2]", "x", "k").installation, 3);
  EXPECT_EQ(effect_from_label(d, "placement[s2]", "x", "k").label(d), "placement[s2]");
  EXPECT_EQ(effect_from_label(d, "trigger_offset[s2:y]", "x", "k").installation, 4);
  EXPECT_THROW(effect_from_label(d, "length_offset[s1:x]", "x", "k"), InputError);
  EXPECT_THROW(effect_from_label(d, "placement[s9]", "x", "k"), InputError);
  const Design bar = test::paper_design('C');
  EXPECT_THROW(effect_from_label(bar, "trigger_offset[1r]", "x", "k"), InputError);
  // No ball bar effect among a probe's candidates, and no probe effect among a ball bar's.
  for (const EffectBlock& b : candidate_effects(d, nominal_readings(d)))
    EXPECT_TRUE(effect_fits_instrument(b.effect.kind, InstrumentKind::kProbe)) << b.label;
  for (const EffectBlock& b : candidate_effects(bar, nominal_readings(bar)))
    EXPECT_TRUE(effect_fits_instrument(b.effect.kind, InstrumentKind::kBallbar)) << b.label;
}

TEST(Probe, DeclaredSetupTolerancesWidenTheIntervals) {
  Design d = three_spheres_c();
  const Evaluation plain = evaluate_design(d, 100.0);
  d.setup_std.trigger_offset_um = 1.0;
  d.setup_std.placement_um = 5.0;
  const Evaluation with = evaluate_design(d, 100.0);
  ASSERT_TRUE(with.setup_included);
  ASSERT_TRUE(with.worst_total && with.worst_total->worst_determined_std_um);
  EXPECT_GT(*with.worst_total->worst_determined_std_um, *plain.worst.worst_determined_std_um);
  // A ball bar's tolerance is no probe's.
  Design wrong = three_spheres_c();
  wrong.setup_std.length_offset_um = 1.0;
  EXPECT_THROW(validate_design(wrong), InputError);
}

TEST(Probe, TheDesignAndTheReadingsFilesRoundTrip) {
  Design d = three_spheres_c();
  d.setup_std.placement_um = 5.0;
  const Design back = io::design_from_json(io::design_to_json(d), "back", ".");
  ASSERT_EQ(back.instrument, InstrumentKind::kProbe);
  ASSERT_EQ(back.spheres.size(), 3u);
  EXPECT_EQ(back.spheres[2].D_mm, 120);
  EXPECT_EQ(back.installations.size(), 9u);
  EXPECT_EQ(back.setup_std.placement_um, 5.0);
  Truth t = location_truth(d.axis, {8, -5, 15, 10, 0});
  t.repeats = 2;
  const std::vector<Reading> readings = simulate(d, t, 7);
  std::ostringstream csv;
  io::write_measurements_csv(csv, readings, d);
  EXPECT_EQ(csv.str().substr(0, csv.str().find('\n')), "sphere,angle_deg,dx_um,dy_um,dz_um,repeat");
  const std::vector<Reading> read = io::parse_measurements(csv.str(), "m.csv");
  ASSERT_EQ(read.size(), readings.size());
  validate_readings(d, read, "m.csv");
  const IdentifyResult a = identify(d, readings), b = identify(d, read);
  for (int j = 0; j < 5; ++j)
    EXPECT_NEAR(a.iso.location[static_cast<std::size_t>(j)].value.value,
                b.iso.location[static_cast<std::size_t>(j)].value.value, 1e-5);
}

TEST(Probe, BadInputIsRefusedWithItsPlace) {
  auto message = [](const std::function<void()>& f) {
    try {
      f();
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message([] {
              io::parse_measurements("sphere,angle_deg,dx_um,dy_um\ns1,0,1,2\n", "m");
            }).find("'dz_um' is missing"),
            std::string::npos);
  EXPECT_NE(message([] {
              io::parse_measurements("sphere,angle_deg,dx_um,dy_um,dz_um,time_s\n", "m");
            }).find("unknown column"),
            std::string::npos);
  EXPECT_NE(message([] {
              io::parse_measurements("sphere,angle_deg,dx_um,dy_um,dz_um\ns1,0,1,x,2\n", "m");
            }).find("line 2, column dy_um"),
            std::string::npos);
  // What only a ball bar has.
  const Design d = three_spheres_c();
  EXPECT_NE(
      message([&] { measurement_program(d, {}); }).find("a measurement program is a ball bar's"),
      std::string::npos);
  Design twice = d;
  twice.spheres[1].id = "s1";
  twice.installations = probe_channels(twice.axis, twice.spheres);
  EXPECT_NE(message([&] { validate_design(twice); }).find("duplicate sphere id"),
            std::string::npos);
  for (const char* id : {"all", "s1:x"}) {
    Design bad = d;
    bad.spheres[1].id = id;
    bad.installations = probe_channels(bad.axis, bad.spheres);
    EXPECT_NE(message([&] { validate_design(bad); }).find("spheres[1].id"), std::string::npos)
        << id;
  }
  Design many = d;
  many.spheres.assign(limits::kMaxSpheres + 1, d.spheres[0]);
  for (std::size_t i = 0; i < many.spheres.size(); ++i)
    many.spheres[i].id = "s" + std::to_string(i);
  many.installations = probe_channels(many.axis, many.spheres);
  EXPECT_NE(message([&] { validate_design(many); }).find("more than 100 spheres"),
            std::string::npos);
  // One effect whole and one of its components.
  IdentifyOptions both;
  both.effects = effects_from_list(d, "placement.dL[s1],placement[s1]", "--effects");
  EXPECT_NE(
      message([&] { identify(d, nominal_readings(d), both); }).find("overlaps placement.dL[s1]"),
      std::string::npos);
  EXPECT_NE(message([] {
              io::parse_measurements("angle_deg,dx_um,dy_um,dz_um\n0,1,2,3\n", "m");
            }).find("a touch probe's: its file has the column sphere"),
            std::string::npos);
  Design channels_off = d;
  channels_off.installations.pop_back();
  EXPECT_NE(message([&] { validate_design(channels_off); }).find("spheres' channels"),
            std::string::npos);
}

TEST(Probe, TheCommandLineReadsTheFilesAndRefusesTheOtherInstruments) {
  const std::string design = test::source_path("designs/probe/c-table-three-spheres.json");
  const std::string data = test::source_path("tests/data/probe/c_table_three_spheres.csv");
  const CliRun ok = run_cli("identify --design " + design + " --data " + data);
  EXPECT_EQ(ok.status, 0) << ok.err;
  EXPECT_NE(ok.out.find("X0C"), std::string::npos) << ok.out;
  const CliRun wrong = run_cli("identify --design " + test::kDesignC + " --data " + data);
  EXPECT_EQ(wrong.status, 2);
  EXPECT_NE(wrong.err.find("a touch probe's readings (a column sphere) for a ball bar's design"),
            std::string::npos)
      << wrong.err;
  const CliRun other = run_cli("identify --design " + design + " --data " + test::kDataC);
  EXPECT_EQ(other.status, 2);
  EXPECT_NE(other.err.find("the design is a touch probe's"), std::string::npos) << other.err;
  const CliRun program = run_cli("program --dialect iso --design " + design);
  EXPECT_EQ(program.status, 2);
  EXPECT_NE(program.err.find("instrument.kind"), std::string::npos) << program.err;
}

// A model constant over the angle (a series of order 0) holds no offset or tilt of the axis line:
// they are not determined from it, and no 0 +- 0 is printed for them (the B head's readings from
// the head's probe tip, location errors checked by hand in the test above).
TEST(Probe, AnOrderZeroModelStatesNoLocationError) {
  Design d = probe_design(test::kAxisB,
                          {{"t1", 150, 0, 0, ""}, {"t2", 250, 0, 0, ""}, {"t3", 200, 50, 0, ""}},
                          steps(-90, 90, 15), 0.5);
  d.errors.kind = ErrorModel::Kind::kLegendre;
  d.errors.order = 0;
  const IdentifyResult r = identify(d, nominal_readings(d));
  // The line's offsets and tilts; its zero (B0B, a constant rotation about it) the model holds.
  for (int j = 0; j < 4; ++j)
    EXPECT_FALSE(r.iso.location[static_cast<std::size_t>(j)].value.determined)
        << r.iso.location[static_cast<std::size_t>(j)].name;
  EXPECT_TRUE(r.iso.location[4].value.determined);
  EXPECT_EQ(r.iso.location[4].name, "B0B");
  EXPECT_EQ(r.iso.not_in_model, (std::vector<std::string>{"X0B", "Z0B", "A0B", "C0B"}));
  EXPECT_NE(io::iso_gaps_note(r.iso).find("not in the error model"), std::string::npos);
  d.errors.order = 2;
  const IdentifyResult r2 = identify(d, nominal_readings(d));
  for (const auto& q : r2.iso.location) EXPECT_TRUE(q.value.determined) << q.name;
}

// A probe kit on a C table (formats.md "A second instrument"): `extra` replaces or adds keys.
std::string probe_kit_text(const std::string& extra = "") {
  return R"({"format": "dbbkit.kit/1", "name": "k", "axis": "C",
    "instrument": {"kind": "probe", "approach_mm": 20},
    "noise": {"std_um": 0.5, "distribution": "normal"}, "reference_length_mm": 100,
    "errors": {"model": "per_angle"},
    "L_mm": {"min": 50, "max": 220}, "D_mm": {"min": -150, "max": 150},
    "H_mm": {"base": 80, "blocks": [150], "max_stack": 1},
    "min_separation_mm": 60,
    "angles_deg": {"range": [0, 360], "steps": [45]},
    "time_s": {"per_reading": 20, "per_position": 300},
    "workspace": {"table": {"diameter_mm": 500}, "footprint_mm": 40})" +
         extra + R"(, "travel_mm": {"x": [-300, 300], "y": [-250, 250], "z": [0, 400]}})";
}

// Each sphere's probing points over the arc, sampled every 0.25 deg with the exact rotation (not
// the kit's harmonics): the least margin [mm] to the travel and the table's edge (> 0: inside).
double least_margin(const Kit& kit, const Design& d) {
  double margin = std::numeric_limits<double>::infinity();
  const double a = kit.probe.approach_mm;
  for (const Sphere& sp : d.spheres) {
    const Eigen::Vector3d B = d.axis.body_point(sp.L_mm, sp.D_mm, sp.H_mm);
    const double radius = std::hypot(B.x(), B.y()) + kit.workspace->footprint_mm / 2;
    margin = std::min(margin, *kit.workspace->table_diameter_mm / 2 - radius);
    for (double g = 0; g <= 360.0; g += 0.25) {
      const Eigen::Vector3d c = axis_rotation(d.axis, g) * B;
      for (const Eigen::Vector3d& q : {Eigen::Vector3d(c + a * Eigen::Vector3d::UnitX()),
                                       Eigen::Vector3d(c - a * Eigen::Vector3d::UnitX()),
                                       Eigen::Vector3d(c + a * Eigen::Vector3d::UnitY()),
                                       Eigen::Vector3d(c - a * Eigen::Vector3d::UnitY()),
                                       Eigen::Vector3d(c + a * Eigen::Vector3d::UnitZ()), c}) {
        for (int k = 0; k < 3; ++k)
          margin = std::min({margin, q(k) - kit.travel_mm[static_cast<std::size_t>(k)].min,
                             kit.travel_mm[static_cast<std::size_t>(k)].max - q(k)});
      }
    }
  }
  return margin;
}

TEST(Probe, AKitsSearchPlacesSpheresTheApproachAndTheTableAllow) {
  const Kit kit = io::kit_from_text(probe_kit_text(), "kit");
  const OptimizeResult res = optimize_kit(kit, {Criterion::kWorst, 2});
  ASSERT_TRUE(res.best);
  const Design& d = res.best->design;
  EXPECT_EQ(d.instrument, InstrumentKind::kProbe);
  // Per-angle errors need three spheres off one line: the search takes both optional ones.
  ASSERT_EQ(d.spheres.size(), 3u);
  EXPECT_EQ(d.installations.size(), 9u);
  EXPECT_EQ(res.best->n_undetermined, 0);
  // Each set of heights once (the spheres differ by their names alone): 2 + 3 + 4 choices of
  // the two stacks for one, two and three spheres.
  EXPECT_EQ(res.choices.size(), 9u);
  // Two stands never share a spot: apart in the table's plane, whatever their heights.
  for (std::size_t i = 0; i < d.spheres.size(); ++i)
    for (std::size_t j = 0; j < i; ++j)
      EXPECT_GE(
          std::hypot(d.spheres[i].L_mm - d.spheres[j].L_mm, d.spheres[i].D_mm - d.spheres[j].D_mm),
          kit.min_separation_mm - 1e-6);
  // Every probing point inside the travel and every stand on the table, by sampling.
  EXPECT_GE(least_margin(kit, d), -1e-6);
  // The written design is one identify takes, and the time is the probe's: spheres set up and
  // centres probed.
  const Design back = io::design_from_json(io::design_to_json(d), "best");
  EXPECT_EQ(back.spheres.size(), 3u);
  EXPECT_DOUBLE_EQ(res.best->time_s, 3 * 300.0 + 3 * 9 * 20.0);
  // No worse than the hand-placed three spheres of designs/probe (inside the kit as well).
  const Design hand =
      io::read_design_file(test::source_path("designs/probe/c-table-three-spheres.json"));
  Design hand_at_45 = hand;
  hand_at_45.angles_deg = d.angles_deg;
  const Reference ref = make_reference(kit, hand_at_45, "hand");
  ASSERT_TRUE(ref.worst.worst_std_um);
  EXPECT_LE(*res.best->worst.worst_std_um, *ref.worst.worst_std_um * (1 + 1e-9));
  EXPECT_GE(fit_spheres(kit, hand_at_45), -1e9);  // scored against the same checks
  EXPECT_LE(fit_spheres(kit, hand_at_45), 0.0);
}

TEST(Probe, ATightTravelPullsTheSpheresInAndIsSaidWhenNothingFits) {
  // The x travel leaves 120 mm of radius for a sphere's centre: the search keeps to it.
  std::string tight = probe_kit_text();
  tight.replace(tight.find("\"x\": [-300, 300]"), 16, "\"x\": [-140, 140]");
  const Kit kit = io::kit_from_text(tight, "kit");
  const OptimizeResult res = optimize_kit(kit, {Criterion::kWorst, 2});
  ASSERT_TRUE(res.best);
  const double margin = least_margin(kit, res.best->design);
  EXPECT_GE(margin, -1e-6);
  EXPECT_LT(margin, 1.0);  // the travel binds: worst sigma falls with the spheres' spread
  // A travel no sphere fits: the reason, named.
  std::string none = probe_kit_text();
  none.replace(none.find("\"z\": [0, 400]"), 13, "\"z\": [0, 90]");
  const Kit k2 = io::kit_from_text(none, "kit");
  const OptimizeResult r2 = optimize_kit(k2, {Criterion::kWorst, 2});
  EXPECT_FALSE(r2.best);
  const std::string why = io::binding_text(k2, r2);
  EXPECT_NE(why.find("the probe's approach inside travel"), std::string::npos) << why;
}

TEST(Probe, ATrunnionsSphereStemTiltsWithTheTable) {
  const Kit kit = io::kit_from_text(R"({"format": "dbbkit.kit/1", "axis": {"letter": "A",
      "side": "table", "direction": [1, 0, 0], "reference": [0, 0, 1], "travel_deg": [-120, 120]},
    "table": {"normal": [0, 0, 1], "surface_mm": -50},
    "instrument": {"kind": "probe", "approach_mm": 20, "max_stem_tilt_deg": 60},
    "noise": {"std_um": 0.5, "distribution": "normal"}, "reference_length_mm": 100,
    "errors": {"model": "per_angle"}, "D_mm": {"min": -100, "max": 100},
    "axial_mm": {"min": -100, "max": 100}, "H_mm": {"base": 80, "blocks": [], "max_stack": 0},
    "travel_mm": {"x": [-400, 400], "y": [-400, 400], "z": [-400, 400]},
    "angles_deg": {"range": [-90, 90], "steps": [30]},
    "min_separation_mm": 30, "time_s": {"per_reading": 20, "per_position": 300}})",
                                    "kit");
  // A stem on the table tilts as far as the table: 90 deg at the arc's ends, beyond 60.
  Sphere sp{"s1", 30, 0, 0, ""};
  const std::vector<Clash> c = sphere_clashes(kit, kit.axis, sp, kit_angles(kit, 30));
  ASSERT_EQ(c.size(), 1u);
  EXPECT_EQ(c[0].what, "the sphere's stem tilts too far");
  EXPECT_NEAR(c[0].by_mm, 30.0, 1e-9);
  EXPECT_TRUE(sphere_clashes(kit, kit.axis, sp, steps(-60, 60, 30), 1e-9).empty());
  const OptimizeResult res = optimize_kit(kit, {Criterion::kWorst, 2});
  EXPECT_FALSE(res.best);
  EXPECT_NE(io::binding_text(kit, res).find("the stems within their tilt"), std::string::npos);
}

// Set-up detection required: only a design that determines every error meets it (at rank loss
// the axis errors would take less of a placement, which would then seem detectable).
TEST(Probe, RequiredDetectionIsMetOnlyByADesignThatDeterminesEveryError) {
  Kit kit = io::kit_from_text(
      probe_kit_text(R"(, "setup_std": {"placement_um": 5}, "require_setup_detection": true)"),
      "kit");
  const OptimizeResult res = optimize_kit(kit, {Criterion::kWorstTotal, 2});
  for (const ChoiceResult& cr : res.choices)
    if (cr.best && cr.best->feasible) EXPECT_EQ(cr.best->n_undetermined, 0) << cr.label;
  if (res.best) EXPECT_EQ(res.best->n_undetermined, 0);
}

TEST(InstrumentTable, EachInstrumentsWordsAndFlagsAreItsEntrys) {
  // The writers, the checks and the commands read what differs between instruments from one
  // entry (instrument_info), in the enum's order; every word a text needs is there.
  const Design ballbar = io::read_design_file(test::kDesignC);
  const Design probe = three_spheres_c();
  for (const Design* d : {&ballbar, &probe}) {
    const InstrumentInfo& info = instrument_info(d->instrument);
    EXPECT_EQ(info.kind, d->instrument);
    EXPECT_EQ(instrument_named(info.name), d->instrument);
    EXPECT_EQ(d->directions_turn(), info.directions_turn);
    // An item's rows are the design's installations: a ball bar's one each, a probe sphere's
    // three channels.
    EXPECT_EQ(measured_count(*d) * info.rows_per_item, d->installations.size()) << info.name;
    EXPECT_EQ(info.rows_per_item > 1, !std::string(info.item_read).empty()) << info.name;
    EXPECT_LE(std::string(info.row_column).size(), 8u) << info.name;
    for (const char* word : {info.noun,
                             info.item,
                             info.items,
                             info.items_capitalised,
                             info.points,
                             info.row_carrier,
                             info.row_column,
                             info.setup_effect_nouns,
                             info.setup_effects_plural,
                             info.setup_tolerance_keys,
                             info.setup_tolerance_phrase,
                             info.setup_tolerance_none,
                             info.evaluate_add_next,
                             info.identify_add_next,
                             info.measure_next,
                             info.widen_next,
                             info.motion_on_all_points,
                             info.motion_across_readings,
                             info.design_caption,
                             info.equivalent_determined,
                             info.equivalent_convention,
                             info.polar_plot,
                             info.polar_reading,
                             info.first_order_term})
      EXPECT_GT(std::string(word).size(), 0u) << info.name;
    // A design without a clock says why wherever a drift is asked of it.
    EXPECT_EQ(info.has_clock, std::string(info.no_clock_reason).empty()) << info.name;
    // require_ballbar refuses exactly a design whose instrument has no program.
    bool refused = false;
    try {
      require_ballbar(*d, "design.json", "a part program");
    } catch (const InputError& e) {
      refused = true;
      EXPECT_NE(std::string(e.what()).find(instrument_info(d->instrument).noun), std::string::npos)
          << e.what();
    }
    EXPECT_EQ(refused, !info.has_program) << info.name;
  }
  EXPECT_TRUE(instrument_info(InstrumentKind::kBallbar).has_clock);
  EXPECT_FALSE(instrument_info(InstrumentKind::kProbe).has_clock);
  // The words as the results print them.
  EXPECT_EQ(measured_phrase(ballbar),
            std::to_string(ballbar.installations.size()) + " installations");
  EXPECT_EQ(measured_phrase(probe), "3 spheres probed in x, y and z (9 channels)");
  // What a design counts: a ball bar's installations, a probe's spheres (not its channels).
  EXPECT_EQ(measured_count(ballbar), ballbar.installations.size());
  EXPECT_EQ(measured_count(probe), probe.spheres.size());
  Evaluation ev;
  ev.instrument = InstrumentKind::kBallbar;
  EXPECT_EQ(io::evaluation_setup_note(ev),
            "set-up uncertainty is not included: the design declares no length offset or "
            "centring tolerance (setup_std)");
  ev.setup_included = true;
  EXPECT_EQ(io::evaluation_setup_note(ev),
            "the uncertainties include the declared length offset and centring tolerances "
            "(total = noise and set-up); the ball placement (L, D, H) is propagated at the "
            "identified errors by identify");
  ev.instrument = InstrumentKind::kProbe;
  EXPECT_EQ(io::evaluation_setup_note(ev),
            "the uncertainties include the declared trigger offset and sphere placement "
            "tolerances (total = noise and set-up)");
}

TEST(Probe, AnEffectsLabelIsToldInTheProbesTerms) {
  const Design d = three_spheres_c();
  auto message = [&](const std::string& label) {
    try {
      effect_from_label(d, label, "--effects", "");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  // A channel's effect named by its sphere: told which channels there are.
  EXPECT_NE(message("trigger_offset[s1]")
                .find("'s1' is a sphere; trigger_offset is one channel's: "
                      "s1:x, s1:y or s1:z"),
            std::string::npos)
      << message("trigger_offset[s1]");
  // A ball bar's effect: said so first, wherever it is placed.
  for (const char* label : {"length_offset[s1]", "centring[s1]", "length_offset[s1:x]"})
    EXPECT_NE(message(label).find("is an effect of a ball bar; this design's instrument is a touch "
                                  "probe"),
              std::string::npos)
        << message(label);
  // No such channel or sphere: named as the probe's.
  EXPECT_NE(message("trigger_offset[s9:x]").find("'s9:x' is no channel of the design"),
            std::string::npos)
      << message("trigger_offset[s9:x]");
  EXPECT_NE(message("placement[s9]").find("'s9' is no sphere of the design"), std::string::npos);
  EXPECT_EQ(message("trigger_offset[s1:x]"), "no error");
  EXPECT_EQ(message("placement[s2]"), "no error");
}

TEST(Probe, TheSearchsCriterionIsTheOneTheKitAllows) {
  // One rule for the command line and Python (search_criterion): worst_total by default where
  // the kit declares set-up tolerances, worst elsewhere; worst_total or set-up detection asked of
  // a kit without them is refused at setup_std, in the instrument's words, by the caller's names.
  Kit bare = io::kit_from_text(probe_kit_text(), "kit.json");
  EXPECT_EQ(search_criterion(bare, std::nullopt, false, "kit.json", "--criterion", "--detect"),
            Criterion::kWorst);
  EXPECT_EQ(search_criterion(bare, "D", false, "kit.json", "--criterion", "--detect"),
            Criterion::kD);
  EXPECT_FALSE(bare.require_setup_detection);
  auto refusal = [](Kit k, const std::optional<std::string>& name, bool detect) {
    try {
      search_criterion(k, name, detect, "kit.json", "criterion", "require_setup_detection");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string total = refusal(bare, "worst_total", false);
  EXPECT_NE(total.find("kit.json"), std::string::npos) << total;
  EXPECT_NE(total.find("setup_std"), std::string::npos) << total;
  EXPECT_NE(total.find("criterion worst_total needs a trigger offset or placement tolerance"),
            std::string::npos)
      << total;
  const std::string detect = refusal(bare, std::nullopt, true);
  EXPECT_NE(detect.find("require_setup_detection needs a trigger offset or placement tolerance"),
            std::string::npos)
      << detect;
  EXPECT_NE(refusal(bare, "best", false).find("unknown criterion"), std::string::npos);
  // An empty name is asked for and is no criterion's; it is not the default.
  EXPECT_NE(refusal(bare, "", false).find("unknown criterion ''"), std::string::npos)
      << refusal(bare, "", false);

  Kit declared =
      io::kit_from_text(probe_kit_text(R"(, "setup_std": {"placement_um": 5})"), "kit.json");
  EXPECT_EQ(search_criterion(declared, std::nullopt, true, "kit.json", "--criterion", "--detect"),
            Criterion::kWorstTotal);
  EXPECT_TRUE(declared.require_setup_detection);
}

TEST(Probe, AProbeKitRefusesWhatOnlyABallBarHas) {
  auto message_of = [](const std::string& text) {
    try {
      io::kit_from_text(text, "kit");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  auto message = [&](const std::string& extra) { return message_of(probe_kit_text(extra)); };
  // The kit with `from` replaced by `to`.
  auto replaced = [](const std::string& from, const std::string& to) {
    std::string t = probe_kit_text();
    return t.replace(t.find(from), from.size(), to);
  };
  EXPECT_NE(message(R"(, "bars_mm": [100])").find("bars_mm: a probe kit has no bars"),
            std::string::npos);
  EXPECT_NE(message(R"(, "return_reading": true)").find("return_reading"), std::string::npos);
  EXPECT_NE(message(R"(, "setup_std": {"centring_um": 5})").find("a probe's set-up tolerances"),
            std::string::npos);
  EXPECT_NE(message(R"(, "pattern": {"positions": [{"id": "s1", "L": "L1", "H": "H1",
      "directions": ["radial"]}]})")
                .find("no directions"),
            std::string::npos);
  EXPECT_NE(message(R"(, "pattern": {"positions": [{"id": "s:1", "L": "L1", "H": "H1"}]})")
                .find("pattern.positions[0].id"),
            std::string::npos);
  EXPECT_NE(message(R"(, "pattern": "three_position")").find("for a probe kit"), std::string::npos);
  EXPECT_NE(message(R"(, "pattern": {"positions": [{"id": "s1", "L": "L1", "H": "H1",
      "separated": false}]})")
                .find("pattern.positions[0].separated: every sphere's stand stands apart"),
            std::string::npos);
  EXPECT_NE(
      message_of(replaced("\"footprint_mm\": 40}", "\"footprint_mm\": 40, \"clearance_mm\": 5}"))
          .find("workspace.clearance_mm: is the spindle's clearance"),
      std::string::npos);
  EXPECT_NE(message_of(replaced("\"per_position\"", "\"per_installation\""))
                .find("a probe has no installations"),
            std::string::npos);
  EXPECT_NE(
      message_of(replaced("\"per_position\": 300", "\"budget\": 3000")).find("time_s.per_position"),
      std::string::npos);
  EXPECT_NE(message_of(replaced("\"approach_mm\": 20", "\"approach_mm\": 0"))
                .find("instrument.approach_mm"),
            std::string::npos);
  EXPECT_NE(message_of(replaced("\"min_separation_mm\": 60", "\"min_separation_mm\": 0"))
                .find("min_separation_mm: a probe kit states how far apart"),
            std::string::npos);
  // A ball bar kit told of spheres: the probe's key named.
  EXPECT_NE(message_of(replaced("\"instrument\": {\"kind\": \"probe\", \"approach_mm\": 20},",
                                "\"pattern\": \"spheres\","))
                .find("is a touch probe kit's: add \"instrument\""),
            std::string::npos);
  // A ball bar's design is no reference for a probe kit.
  const Kit kit = io::kit_from_text(probe_kit_text(), "kit");
  try {
    make_reference(kit, io::read_design_file(test::kDesignC), "ref");
    ADD_FAILURE() << "a ball bar reference taken";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("compare instruments"), std::string::npos);
  }
}

TEST(Probe, OptimizeOnTheCommandLineWritesADesignIdentifyTakes) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("dbbkit_probe_kit_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  {
    std::ofstream f(dir / "kit.json");
    f << probe_kit_text();
  }
  const CliRun r = run_cli_shell("cd " + dir.string() + " && " + DBBKIT_CLI +
                                 " optimize --kit kit.json --out best.json --report r.html " +
                                 "--result res.json --pareto-csv front.csv");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("Best: 3 spheres"), std::string::npos) << r.out;
  // The result and the Pareto front count spheres (each three channels).
  const nlohmann::json res = nlohmann::json::parse(slurp((dir / "res.json").string()));
  EXPECT_EQ(res["best"]["n_spheres"], 3);
  EXPECT_EQ(res["best"]["added_spheres"], "s2 s3");
  EXPECT_FALSE(res["best"].contains("n_installations"));
  const std::string front = slurp((dir / "front.csv").string());
  EXPECT_EQ(front.substr(0, front.find('\n')),
            "time_s,n_spheres,n_angles,step_deg,worst_std_um,added_spheres");
  EXPECT_NE(r.out.find("3 spheres x 300 s + 27 probings x 20 s"), std::string::npos) << r.out;
  const CliRun e =
      run_cli_shell("cd " + dir.string() + " && " + DBBKIT_CLI + " evaluate --design best.json");
  EXPECT_EQ(e.status, 0) << e.err;
  EXPECT_NE(e.out.find("Determined: every error at every angle"), std::string::npos) << e.out;
  // A budget for one sphere: a design that leaves errors undetermined, said so, its report
  // written (a plot of nothing determined says so).
  const CliRun one = run_cli_shell(
      "cd " + dir.string() + " && sed 's/\"per_position\": 300}/\"per_position\": 300, " +
      "\"budget\": 700}/' kit.json > one.json && " + DBBKIT_CLI +
      " optimize --kit one.json --out one-best.json --report one.html");
  ASSERT_EQ(one.status, 0) << one.err;
  EXPECT_NE(one.out.find("Best: 1 sphere,"), std::string::npos) << one.out;
  EXPECT_NE(one.out.find("1 sphere x 300 s"), std::string::npos) << one.out;
  EXPECT_NE(one.out.find("Not determined: no error at any angle"), std::string::npos) << one.out;
  EXPECT_NE(one.out.find("Next: widen what binds"), std::string::npos) << one.out;
  EXPECT_NE(slurp((dir / "one.html").string()).find("not determined at any angle"),
            std::string::npos);
  const CliRun head = run_cli_shell(
      "cd " + dir.string() + " && sed 's/\"axis\": \"C\"/\"axis\": \"B\"/' kit.json > b.json && " +
      DBBKIT_CLI + " optimize --quiet --kit b.json");
  EXPECT_EQ(head.status, 2);
  EXPECT_NE(head.err.find("instrument.kind"), std::string::npos) << head.err;
  const CliRun drift = run_cli_shell("cd " + dir.string() + " && " + DBBKIT_CLI +
                                     " optimize --quiet --kit kit.json --require-detect drift=2");
  EXPECT_EQ(drift.status, 2);
  EXPECT_NE(drift.err.find("no time column"), std::string::npos) << drift.err;
  std::filesystem::remove_all(dir);
}

// The README's probe example: every line of its output blocks printed by the commands it shows.
TEST(Readme, ATouchProbeOnCalibrationSpheresPrintsWhatTheReadmeShows) {
  const std::string section =
      readme_section("## Worked example: a touch probe on calibration spheres");
  ASSERT_FALSE(section.empty());
  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    ("dbbkit_readme_probe_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string src = DBBKIT_SOURCE_DIR;
  const std::string two = src + "/designs/probe/c-table-two-spheres.json",
                    three = src + "/designs/probe/c-table-three-spheres.json",
                    four = src + "/designs/probe/c-table-four-spheres.json",
                    truth = src + "/tests/data/probe/truth_c_table.json";
  std::string printed;
  for (const std::string& cmd :
       {"evaluate --design " + two, "evaluate --design " + three,
        "simulate --design " + three + " --truth " + truth + " --out three.csv",
        "identify --design " + three + " --data three.csv --out id3.json",
        "diagnose --design " + three + " --data three.csv --out dg3.json",
        "simulate --design " + four + " --truth " + truth + " --out four.csv",
        "diagnose --design " + four + " --data four.csv --out dg4.json",
        "optimize --kit designs/kits/probe-c-table-kit.json --reference "
        "designs/probe/c-table-three-spheres.json --out " +
            (dir / "probe-best.json").string()}) {
    // optimize from the source tree (the README's paths), the others in the scratch folder.
    const std::string where = cmd.rfind("optimize", 0) == 0 ? src : dir.string();
    const CliRun r = run_cli_shell("cd " + where + " && " + DBBKIT_CLI + " " + cmd);
    ASSERT_EQ(r.status, 0) << cmd << "\n" << r.err;
    printed += r.out;
  }
  printed += slurp((dir / "three.csv").string());
  int checked = 0;
  for (const std::string& line : readme_lines_not_printed(section, printed, false, checked))
    ADD_FAILURE() << "README line not printed:\n" << line;
  EXPECT_GE(checked, 20);
  std::filesystem::remove_all(dir);
}

}  // namespace probe_test
}  // namespace dbbkit
