// The touch probe on calibration spheres, the second instrument (instrument.hpp): its readings
// made here from the real axis line alone (test_util's RealLine, no first-order algebra of
// dbbkit's), identified, and the location errors found against the line's; the row against the
// exact reading; the file forms; what only a ball bar has refused.

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <functional>
#include <random>
#include <sstream>

#include "cli_util.hpp"
#include "dbbkit/diagnose.hpp"
#include "dbbkit/effects.hpp"
#include "dbbkit/error.hpp"
#include "dbbkit/identify.hpp"
#include "dbbkit/instrument.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/measurement_io.hpp"
#include "dbbkit/iso230.hpp"
#include "dbbkit/kinematics.hpp"
#include "dbbkit/limits.hpp"
#include "dbbkit/observability.hpp"
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
  }
  // A third sphere off that line sees every error at every angle.
  EXPECT_EQ(evaluate_design(three_spheres_c(), 100.0).prior.rank,
            evaluate_design(three_spheres_c(), 100.0).prior.n_unknowns);
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
        "diagnose --design " + four + " --data four.csv --out dg4.json"}) {
    const CliRun r = run_cli_shell("cd " + dir.string() + " && " + DBBKIT_CLI + " " + cmd);
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
