// `dbbkit verify` against machines written out here: each test's readings come from the exact
// two-ball geometry of a real axis line (Eigen::AngleAxisd about a displaced, tilted line, the
// axis standing at the commanded angle plus its zero error), the body further displaced by
// component error motions (harmonics of the angle the model never sees as such) and by each
// test's own constant parts (a preset taught anew), not from dbbkit's model. One test is
// identified, another verified against it: a right result must fail at the nominal rate, a
// result with a location error left out must fail, and the fail must name that error.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <optional>
#include <random>
#include <utility>

#include "cli_util.hpp"
#include "dbbkit/identify.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/json_reader.hpp"
#include "dbbkit/io/measurement_io.hpp"
#include "dbbkit/io/result_io.hpp"
#include "dbbkit/io/verify_io.hpp"
#include "dbbkit/iso230.hpp"
#include "dbbkit/kinematics.hpp"
#include "test_util.hpp"

namespace dbbkit {
namespace verify_test {

using test::kPi;
using test::RealLine;
using test::turn;

using test::line_of;

// A machine: its axis line, and component motions a_k cos(h gamma) + b_k sin(h gamma) for the
// harmonics 2 and 3 of each of the six (um, urad).
struct TrueMachine {
  RealLine line;
  std::array<double, 5> location{};
  Eigen::Matrix<double, 6, 4> harmonics = Eigen::Matrix<double, 6, 4>::Zero();
};

TrueMachine machine(const AxisFrame& axis, bool components, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1, 1);
  TrueMachine m;
  m.location = {20 * u(rng), 20 * u(rng), 30 * u(rng), 30 * u(rng), 30 * u(rng)};
  m.line = line_of(axis, m.location);
  if (components)
    for (int k = 0; k < 6; ++k)
      for (int h = 0; h < 4; ++h) m.harmonics(k, h) = (k < 3 ? 2.0 : 8.0) * u(rng);
  return m;
}

// One test's own set-up: a translation (um) and a tilt perpendicular to the axis (urad) of the
// turning body, as a preset taught anew puts it.
struct Constants {
  Eigen::Vector3d d = Eigen::Vector3d::Zero(), e = Eigen::Vector3d::Zero();
};
Constants constants(const AxisFrame& axis, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1, 1);
  const IsoFrame f = iso_frame(axis);
  return {Eigen::Vector3d(15 * u(rng), 15 * u(rng), 15 * u(rng)),
          20 * u(rng) * f.p1 + 20 * u(rng) * f.p2};
}

// The design's readings on the machine: noise of the design's standard deviation, uniform (as
// the design declares it: within +-1.25 um) or normal; each installation's set-up drawn from
// the design's declared tolerances (the bar's length offset, the centring of the following
// ball's path).
std::vector<Reading> readings(const Design& d, const TrueMachine& m, const Constants& c,
                              std::mt19937_64& rng, bool normal_noise = false) {
  std::uniform_real_distribution<double> uniform(-1.25, 1.25);
  std::normal_distribution<double> normal(0.0, 1.25 / std::sqrt(3.0)), unit(0.0, 1.0);
  auto noise = [&](std::mt19937_64& g) { return normal_noise ? normal(g) : uniform(g); };
  std::vector<Reading> out;
  for (std::size_t i = 0; i < d.installations.size(); ++i) {
    const Installation& in = d.installations[i];
    const SetupUncertainty u = d.setup_of(static_cast<int>(i));
    const double length_offset = u.length_offset_um * unit(rng);
    const Eigen::Vector3d centring =
        1e-3 * u.centring_um * Eigen::Vector3d(unit(rng), unit(rng), unit(rng));
    const double bar = in.bar_mm.value_or(test::kBar);
    const Eigen::Vector3d body = ball_body_mm(d.axis, in);
    for (const double a : d.angles_deg) {
      const double g = a * kPi / 180;
      const Eigen::Vector4d h(std::cos(2 * g), std::sin(2 * g), std::cos(3 * g), std::sin(3 * g));
      const Eigen::Matrix<double, 6, 1> motion = m.harmonics * h;
      const Eigen::Vector3d e = 1e-6 * (c.e + motion.tail<3>());
      const Eigen::Vector3d d_mm = 1e-3 * (c.d + motion.head<3>());
      const Eigen::Vector3d on_line = turn(m.line, a, body);
      const Eigen::Vector3d P =
          (e.norm() > 0 ? Eigen::AngleAxisd(e.norm(), e.normalized()) * on_line : on_line) + d_mm;
      const Eigen::Matrix3d R = axis_rotation(d.axis, a);
      const Eigen::Vector3d F = R * body - in.sign * bar * (R * in.direction.body) + centring;
      Reading r;
      r.installation = in.id;
      r.angle_deg = a;
      r.reading_um = in.reading_sign * (1e3 * ((P - F).norm() - bar) + length_offset + noise(rng));
      out.push_back(r);
    }
  }
  return out;
}

io::ResultFile identified(const Design& d, const std::vector<Reading>& rows) {
  IdentifyOptions o;
  o.iso_motion.enabled = false;
  const IdentifyResult r = identify(d, rows, o);
  return io::result_from_text(
      io::dump_json(io::identify_to_json(d, rows, r, {"d.json", "d.csv"}, nullptr, false)),
      "r.json");
}

Design design(const std::string& path) {
  return io::read_design_file(std::string(DBBKIT_SOURCE_DIR) + "/" + path);
}

// The paper's C design with its balls moved: the same angles (the result's motions predict every
// reading), other ball positions.
Design moved_c_design() {
  Design d = design("designs/paper-c-turntable.json");
  d.name = "held-out";
  for (Installation& in : d.installations) {
    in.L_mm = in.L_mm * 1.4 + (in.L_mm == 0 ? 0 : 10);
    in.H_mm += 40;
  }
  return d;
}

struct Kind {
  const char* name;
  Design fitted, held_out;
  bool components;
};
std::vector<Kind> kinds() {
  return {{"C turntable, the same angles, component motions",
           design("designs/paper-c-turntable.json"), moved_c_design(), true},
          {"A trunnion, other angles and balls", design("designs/a-trunnion.json"),
           design("tests/data/a_trunnion_kit_optimized.json"), false}};
}

// A right result fails a test it was not fitted to at 1 - coverage, within three binomial
// standard errors, with normal noise (the designs declaring it), and with the designs' uniform
// noise (the same variance, lighter tails: the statistic's distribution follows; the C table).
TEST(Verify, ARightResultFailsAtTheNominalRate) {
  const int n = 300;
  const double se = std::sqrt(0.05 * 0.95 / n);
  const std::vector<Kind> all = kinds();
  for (std::size_t i = 0; i <= all.size(); ++i) {
    const bool normal = i < all.size();
    Kind k = all[normal ? i : 0];
    if (normal)  // as the designs declare it: the same standard deviation
      for (Design* d : {&k.fitted, &k.held_out}) {
        d->noise.distribution = NoiseModel::Distribution::kNormal;
        d->noise.std_um = 1.25 / std::sqrt(3.0);
      }
    std::mt19937_64 rng(21);
    int fails = 0;
    double ratio = 0;
    for (int t = 0; t < n; ++t) {
      const TrueMachine m = machine(k.fitted.axis, k.components, rng);
      const io::ResultFile r =
          identified(k.fitted, readings(k.fitted, m, constants(k.fitted.axis, rng), rng, normal));
      const std::vector<Reading> test =
          readings(k.held_out, m, constants(k.held_out.axis, rng), rng, normal);
      const io::VerifyReport v = io::verify(r, k.held_out, test, "k.json", "k.csv", 0.95);
      fails += !v.v.pass;
      ratio += v.v.chi2 / v.v.dof / n;
    }
    const double rate = fails / double(n);
    std::printf("%s, %s noise: %d of %d right results failed (%.3f); mean chi2 / dof %.3f\n",
                k.name, normal ? "normal" : "uniform", fails, n, rate, ratio);
    EXPECT_NEAR(rate, 0.05, 3 * se) << k.name;
    EXPECT_NEAR(ratio, 1.0, 0.05) << k.name;
  }
}

// A test's readings predicted before it is run (predict --design) lie within U at the coverage
// probability: the test run on the result's preset (the same constant parts of the motions, a
// translation of up to 15 um and a tilt of up to 20 urad at every angle), its declared set-up
// drawn, the same machines (exact geometry) as above. Pooled over the readings of 150 machines per
// kind; the readings of one machine share the result's error, so the binomial error is that of 150
// x (readings / 10) independent ones (a bound found wide enough by the spread between seeds).
TEST(Verify, PredictedReadingsCoverWhatIsReadAtTheirNominalRate) {
  const int n = 150;
  for (const Kind& k : kinds()) {
    std::mt19937_64 rng(33);
    long inside = 0, total = 0;
    for (int t = 0; t < n; ++t) {
      const TrueMachine m = machine(k.fitted.axis, k.components, rng);
      const Constants preset = constants(k.fitted.axis, rng);
      const io::ResultFile r = identified(k.fitted, readings(k.fitted, m, preset, rng));
      const std::vector<Reading> test = readings(k.held_out, m, preset, rng);
      const io::TestPrediction p = io::predict_test(r, k.held_out, "k.json", 0.95);
      ASSERT_EQ(p.p.readings.size(), test.size());
      if (t == 0) {  // verify states each reading as the instrument read it (its count included)
        const io::VerifyReport v = io::verify(r, k.held_out, test, "k.json", "k.csv", 0.95);
        for (const VerifiedReading& c : v.v.readings_checked)
          EXPECT_NEAR(c.read_um, test[c.index].reading_um, 1e-9) << k.name;
      }
      for (std::size_t i = 0; i < test.size(); ++i) {
        const PredictedReading& pr = p.p.readings[i];
        ASSERT_EQ(pr.reading.installation, test[i].installation);
        ASSERT_EQ(pr.reading.angle_deg, test[i].angle_deg);
        ASSERT_GT(pr.std_um, 0);
        inside += std::abs(test[i].reading_um - pr.predicted_um) <= p.k * pr.std_um;
        ++total;
      }
    }
    const double rate = inside / double(total);
    const double effective = n * (total / double(n)) / 10;
    const double se = std::sqrt(0.95 * 0.05 / effective);
    std::printf("%s: %ld of %ld readings within U (%.4f)\n", k.name, inside, total, rate);
    EXPECT_NEAR(rate, 0.95, 3 * se) << k.name;
  }
}

// A result with one location error set to 0, the machine's being 10 times the test's standard
// uncertainty of it (the explanation's change_std, which the readings do not change), fails;
// the location error that explains most of the fail is that one, its change within U of the
// value left out (U of the test's and the result's uncertainty together).
TEST(Verify, AResultWithALocationErrorLeftOutFailsAndNamesIt) {
  const int n = 40;
  for (const Kind& k : kinds()) {
    std::mt19937_64 rng(5);
    for (int q = 0; q < 5; ++q) {
      const auto qi = static_cast<std::size_t>(q);
      auto trial = [&](std::optional<double> planted) {
        TrueMachine m = machine(k.fitted.axis, k.components, rng);
        if (planted) m.location[qi] = *planted;
        m.line = line_of(k.fitted.axis, m.location);
        io::ResultFile r =
            identified(k.fitted, readings(k.fitted, m, constants(k.fitted.axis, rng), rng));
        const io::ResultQuantity left_out = r.location[qi];
        r.location[qi].value = 0.0;
        return std::make_pair(
            left_out,
            io::verify(r, k.held_out, readings(k.held_out, m, constants(k.held_out.axis, rng), rng),
                       "k.json", "k.csv", 0.95));
      };
      double std = 0;
      for (const VerifyExplanation& x : trial(std::nullopt).second.v.explanations)
        if (x.location == q) std = x.change_std;
      ASSERT_GT(std, 0) << k.name << " " << q;
      const double planted = 10 * std;
      int fails = 0, named = 0, within = 0;
      for (int t = 0; t < n; ++t) {
        const auto [left_out, v] = trial(planted);
        if (v.v.pass) continue;
        ++fails;
        ASSERT_FALSE(v.v.explanations.empty());
        const VerifyExplanation& x = v.v.explanations.front();
        if (x.location != q) continue;
        ++named;
        // The change is the test's estimate of the value left out (the result's), its error
        // the test's and the result's together.
        within +=
            std::abs(x.change - *left_out.value) <= v.k * std::hypot(x.change_std, *left_out.std);
      }
      std::printf("%s, %s = %.1f left out: %d of %d failed, %d named it, %d within U\n", k.name,
                  iso230_names(k.fitted.axis).location[qi].c_str(), planted, fails, n, named,
                  within);
      EXPECT_GE(fails, n * 9 / 10) << k.name << " " << q;
      EXPECT_GE(named, fails * 9 / 10) << k.name << " " << q;
      EXPECT_GE(within, named * 85 / 100) << k.name << " " << q;
    }
  }
}

// The command line: a right result passes (exit 0), one with Y0A left out fails (exit 1) naming
// Y0A, and what cannot be checked is refused (exit 2) naming the file and the key.
TEST(VerifyCli, PassesFailsAndRefusesWhatItCannotCheck) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("dbbkit_verify_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string src = DBBKIT_SOURCE_DIR, d = dir.string();
  const std::string D = src + "/designs/a-trunnion.json",
                    K = src + "/tests/data/a_trunnion_kit_optimized.json",
                    T = src + "/tests/data/truth_a_trunnion_location.json";
  auto cli = [&](const std::string& args) {
    return run_cli_shell("cd " + d + " && " + DBBKIT_CLI + " " + args);
  };
  ASSERT_EQ(cli("simulate --design " + D + " --truth " + T + " --out a.csv").status, 0);
  ASSERT_EQ(cli("identify --design " + D + " --data a.csv --out a.json").status, 0);
  ASSERT_EQ(cli("simulate --design " + K + " --truth " + T + " --seed 9 --out k.csv").status, 0);
  const CliRun pass = cli("verify --result a.json --design " + K + " --data k.csv --out v.json");
  EXPECT_EQ(pass.status, 0) << pass.out << pass.err;
  EXPECT_NE(pass.out.find("PASS"), std::string::npos) << pass.out;
  const nlohmann::json v = nlohmann::json::parse(slurp(d + "/v.json"));
  EXPECT_EQ(v["format"], "dbbkit.verify/1");
  EXPECT_TRUE(v["pass"].get<bool>());
  EXPECT_EQ(v["readings"], 63);
  EXPECT_EQ(v["constant_parts"], 5);
  EXPECT_EQ(v["dof"], 58);
  EXPECT_LE(v["chi2"].get<double>(), v["threshold"].get<double>());

  // Y0A left out of the result.
  nlohmann::json r = nlohmann::json::parse(slurp(d + "/a.json"));
  for (nlohmann::json& q : r["iso230"]["location"])
    if (q["name"] == "Y0A") q["value"] = 0.0;
  std::ofstream(d + "/a0.json") << r.dump();
  const CliRun fail = cli("verify --result a0.json --design " + K + " --data k.csv --out f.json");
  EXPECT_EQ(fail.status, 1) << fail.out << fail.err;
  EXPECT_NE(fail.out.find("FAIL"), std::string::npos) << fail.out;
  EXPECT_NE(fail.out.find("What explains it: Y0A changed by +"), std::string::npos) << fail.out;
  const nlohmann::json f = nlohmann::json::parse(slurp(d + "/f.json"));
  EXPECT_FALSE(f["pass"].get<bool>());
  EXPECT_EQ(f["explanations"][0]["name"], "Y0A");
  EXPECT_NEAR(f["explanations"][0]["change"].get<double>(), 12,
              3 * f["explanations"][0]["change_std"].get<double>() + 1);
  EXPECT_EQ(f["worst"].size(), 5u);

  // Refused: another axis' test; readings of another design; a result without the location
  // errors' covariance; too few readings to check anything.
  const std::string C = src + "/designs/paper-c-turntable.json";
  const CliRun other_axis = cli("verify --result a.json --design " + C + " --data k.csv");
  EXPECT_EQ(other_axis.status, 2);
  EXPECT_NE(other_axis.err.find("paper-c-turntable.json: axis:"), std::string::npos)
      << other_axis.err;
  const CliRun other_data = cli("verify --result a.json --design " + K + " --data a.csv");
  EXPECT_EQ(other_data.status, 2) << other_data.err;
  nlohmann::json old = nlohmann::json::parse(slurp(d + "/a.json"));
  old["iso230"].erase("location_covariance");
  std::ofstream(d + "/old.json") << old.dump();
  const CliRun earlier = cli("verify --result old.json --design " + K + " --data k.csv");
  EXPECT_EQ(earlier.status, 2);
  EXPECT_NE(earlier.err.find("location_covariance"), std::string::npos) << earlier.err;
  {
    std::ofstream few(d + "/few.csv");
    few << "installation,angle_deg,reading_um\n1r,0,1.5\n1t,0,-2\n1a,0,0.5\n";
  }
  // A covariance beyond double precision: a noise of 1e-4 um beside a set-up of 100 mm.
  nlohmann::json ill = nlohmann::json::parse(slurp(K));
  ill["noise"] = {{"accuracy_um", 1.732e-4}, {"distribution", "uniform"}};
  ill["setup_std"] = {{"L_mm", 100},
                      {"D_mm", 100},
                      {"H_mm", 100},
                      {"centring_um", 10000},
                      {"length_offset_um", 10000}};
  std::ofstream(d + "/ill.json") << ill.dump();
  const CliRun beyond = cli("verify --result a.json --design ill.json --data k.csv");
  EXPECT_EQ(beyond.status, 2) << beyond.out << beyond.err;
  EXPECT_NE(beyond.err.find("double precision"), std::string::npos) << beyond.err;
  const CliRun too_few = cli("verify --result a.json --design " + K + " --data few.csv");
  EXPECT_EQ(too_few.status, 2);
  EXPECT_NE(too_few.err.find("take up every one"), std::string::npos) << too_few.err;

  // A result whose motions come without their covariance: said so (not "measured no motions").
  nlohmann::json nocov = nlohmann::json::parse(slurp(d + "/a.json"));
  nocov["iso230"].erase("motion_covariance");
  std::ofstream(d + "/nocov.json") << nocov.dump();
  const CliRun without =
      cli("verify --result nocov.json --design " + K + " --data k.csv --out nc.json");
  EXPECT_EQ(without.status, 0) << without.err;
  EXPECT_NE(without.out.find("at 5 of the test's 9 angles the result states its motions without "
                             "their covariance"),
            std::string::npos)
      << without.out;
  EXPECT_NE(without.out.find("at 4 of the test's 9 angles the result measured no motions"),
            std::string::npos)
      << without.out;
  const nlohmann::json nc = nlohmann::json::parse(slurp(d + "/nc.json"));
  EXPECT_EQ(nc["angles_without_covariance"], 5);
  EXPECT_EQ(nc["angles_location_only"], 9);
  // The result's own readings are no held-out test; uncertainties so large that the statistic
  // lies far below its degrees of freedom are said to make the check lenient.
  const CliRun own = cli("verify --result a.json --design " + D + " --data a.csv");
  EXPECT_NE(own.out.find("Note: the test's readings are the result's own"), std::string::npos)
      << own.out;
  EXPECT_EQ(pass.out.find("Note:"), std::string::npos) << pass.out;
  nlohmann::json loose = nlohmann::json::parse(slurp(K));
  loose["noise"] = {{"accuracy_um", 12.5}, {"distribution", "uniform"}};
  std::ofstream(d + "/loose.json") << loose.dump();
  const CliRun lenient = cli("verify --result a.json --design loose.json --data k.csv");
  EXPECT_EQ(lenient.status, 0) << lenient.err;
  EXPECT_NE(lenient.out.find("Note: chi-squared lies far below"), std::string::npos) << lenient.out;
  // `angles` counts the angles the readings hold, not the design's.
  {
    std::ifstream in(d + "/k.csv");
    std::ofstream part(d + "/part.csv");
    std::string line;
    std::getline(in, line);
    part << line << "\n";
    while (std::getline(in, line)) {
      const std::string angle =
          line.substr(line.find(',') + 1, line.find(',', line.find(',') + 1) - line.find(',') - 1);
      if (angle == "0" || angle == "30" || angle == "60") part << line << "\n";
    }
  }
  const CliRun some = cli("verify --result a.json --design " + K + " --data part.csv --out s.json");
  EXPECT_NE(some.status, 2) << some.err;
  EXPECT_EQ(nlohmann::json::parse(slurp(d + "/s.json"))["angles"], 3);
  EXPECT_EQ(nlohmann::json::parse(slurp(d + "/s.json"))["readings"], 21);
  EXPECT_NE(some.out.find("Note: 42 of the design's 63 readings are not in the data (by "
                          "installation: 1a 6,"),
            std::string::npos)
      << some.out;

  // The test's readings before it is run (predict --design): each of the design's, in its order,
  // with U; what the prediction cannot take is refused as verify refuses it.
  const CliRun before = cli("predict --result a.json --design " + K + " --out kp.json");
  ASSERT_EQ(before.status, 0) << before.err;
  EXPECT_NE(before.out.find("before it is run"), std::string::npos) << before.out;
  const nlohmann::json kp = nlohmann::json::parse(slurp(d + "/kp.json"));
  EXPECT_EQ(kp["format"], "dbbkit.predict/1");
  ASSERT_EQ(kp["readings"].size(), 63u);
  EXPECT_EQ(kp["readings"][0]["installation"], "1r");
  for (const nlohmann::json& q : kp["readings"]) {
    EXPECT_GT(q["std_um"].get<double>(), 0);
    EXPECT_NEAR(q["U_um"].get<double>(), kp["k"].get<double>() * q["std_um"].get<double>(), 1e-5);
  }
  for (const nlohmann::json& q : kp["readings"]) EXPECT_FALSE(q["return"].get<bool>());
  // With the sweep's return reading: one more per installation, marked.
  nlohmann::json with_return = nlohmann::json::parse(slurp(K));
  with_return["return_reading"] = true;
  std::ofstream(d + "/kr.json") << with_return.dump();
  const CliRun returns = cli("predict --result a.json --design kr.json --out kpr.json");
  ASSERT_EQ(returns.status, 0) << returns.err;
  EXPECT_NE(returns.out.find("A -30 deg (return): "), std::string::npos) << returns.out;
  const nlohmann::json kpr = nlohmann::json::parse(slurp(d + "/kpr.json"));
  ASSERT_EQ(kpr["readings"].size(), 70u);
  EXPECT_TRUE(kpr["readings"][9]["return"].get<bool>());
  EXPECT_FALSE(kpr["readings"][8]["return"].get<bool>());
  // An instrument counting the other way on one installation: its header says so, its readings
  // are predicted in that count.
  nlohmann::json reversed = with_return;
  reversed["installations"][0]["reading_sign"] = -1;
  std::ofstream(d + "/kn.json") << reversed.dump();
  const CliRun counted = cli("predict --result a.json --design kn.json --out kpn.json");
  ASSERT_EQ(counted.status, 0) << counted.err;
  const std::string first = reversed["installations"][0]["id"].get<std::string>();
  EXPECT_NE(counted.out.find("installation " + first +
                             " (um, in the instrument's reversed count: reading_sign -1):"),
            std::string::npos)
      << counted.out;
  const nlohmann::json kpn = nlohmann::json::parse(slurp(d + "/kpn.json"));
  EXPECT_NEAR(kpn["readings"][1]["predicted_um"].get<double>(),
              -kpr["readings"][1]["predicted_um"].get<double>(), 1e-6);
  EXPECT_EQ(returns.out.find("reversed count"), std::string::npos);
  const CliRun before_other_axis = cli("predict --result a.json --design " + C);
  EXPECT_EQ(before_other_axis.status, 2);
  EXPECT_NE(before_other_axis.err.find("paper-c-turntable.json: axis:"), std::string::npos)
      << before_other_axis.err;
  const CliRun before_report = cli("predict --result a.json --design " + K + " --report r.html");
  EXPECT_EQ(before_report.status, 2);
  EXPECT_NE(before_report.err.find("--report"), std::string::npos) << before_report.err;
  EXPECT_FALSE(std::filesystem::exists(d + "/r.html"));
  const CliRun before_old = cli("predict --result old.json --design " + K);
  EXPECT_EQ(before_old.status, 2);
  EXPECT_NE(before_old.err.find("location_covariance"), std::string::npos) << before_old.err;
  std::filesystem::remove_all(dir);
}

TEST(Readme, AHeldOutTestPrintsWhatTheReadmeShows) {
  const std::string section =
      readme_section("## Worked example: a held-out test the result must explain");
  ASSERT_FALSE(section.empty());
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("dbbkit_readme_vf_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string src = DBBKIT_SOURCE_DIR;
  const std::string D = src + "/designs/a-trunnion.json",
                    K = src + "/tests/data/a_trunnion_kit_optimized.json";
  std::string printed;
  for (const auto& [cmd, status] : std::vector<std::pair<std::string, int>>{
           {"simulate --design " + D + " --truth " + src +
                "/tests/data/truth_a_trunnion_location.json --out a.csv",
            0},
           {"identify --design " + D + " --data a.csv --out a.json", 0},
           {"simulate --design " + K + " --truth " + src +
                "/tests/data/truth_a_trunnion_location.json --seed 9 --out k.csv",
            0},
           {"verify --result a.json --design " + K + " --data k.csv", 0},
           {"simulate --design " + K + " --truth " + src +
                "/tests/data/truth_a_trunnion_moved.json --out moved.csv",
            0},
           {"verify --result a.json --design " + K + " --data moved.csv", 1}}) {
    const CliRun r = run_cli_shell("cd " + dir.string() + " && " + DBBKIT_CLI + " " + cmd);
    ASSERT_EQ(r.status, status) << cmd << "\n" << r.err;
    if (cmd.rfind("verify", 0) == 0) printed += r.out;
  }
  int checked = 0;
  for (const std::string& line : readme_lines_not_printed(section, printed, false, checked))
    ADD_FAILURE() << "README line not printed:\n" << line;
  EXPECT_GE(checked, 9);
  std::filesystem::remove_all(dir);
}

// The README's check on the five-axis machine: the program, the readings predicted before the
// test is run, the test simulated and verified; every line of its output blocks printed, and
// every reading within the U predicted for it.
TEST(Readme, ACheckPredictedBeforeItIsRunPrintsWhatTheReadmeShows) {
  const std::string section =
      readme_section("## Worked example: on the machine, a check predicted before it is run");
  ASSERT_FALSE(section.empty());
  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    ("dbbkit_readme_check_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string src = DBBKIT_SOURCE_DIR;
  const std::string A = src + "/designs/a-c-trunnion-A.json",
                    K = src + "/tests/data/a_c_trunnion_A_check.json",
                    T = src + "/tests/data/truth_a_c_trunnion_A.json";
  std::string printed;
  for (const std::string& cmd :
       {"simulate --design " + A + " --truth " + T + " --out A.csv",
        "identify --design " + A + " --data A.csv --out A.json --quiet",
        "program --design " + K + " --dialect heidenhain --tcpm on --out check.h",
        "predict --result A.json --design " + K + " --out check-predicted.json",
        "predict --result A.json --design " + K,
        "simulate --design " + K + " --truth " + T + " --seed 5 --out check.csv",
        "verify --result A.json --design " + K + " --data check.csv"}) {
    const CliRun r = run_cli_shell("cd " + dir.string() + " && " + DBBKIT_CLI + " " + cmd);
    ASSERT_EQ(r.status, 0) << cmd << "\n" << r.err;
    printed += r.out;
  }
  printed += slurp(dir.string() + "/check.h");
  int checked = 0;
  for (const std::string& line : readme_lines_not_printed(section, printed, false, checked))
    ADD_FAILURE() << "README line not printed:\n" << line;
  EXPECT_GE(checked, 12);
  // 26 of the 27 readings within their predicted U, as the README says.
  const nlohmann::json p = nlohmann::json::parse(slurp(dir.string() + "/check-predicted.json"));
  EXPECT_EQ(p["format"], "dbbkit.predict/1");
  const Design k = io::read_design_file(K);
  const std::vector<Reading> read = io::read_measurement_file(dir.string() + "/check.csv", k);
  ASSERT_EQ(p["readings"].size(), read.size());
  ASSERT_EQ(read.size(), 27u);
  int inside = 0;
  for (std::size_t i = 0; i < read.size(); ++i) {
    const nlohmann::json& q = p["readings"][i];
    EXPECT_EQ(q["installation"], read[i].installation);
    EXPECT_NEAR(q["U_um"].get<double>(), p["k"].get<double>() * q["std_um"].get<double>(), 1e-5);
    inside +=
        std::abs(read[i].reading_um - q["predicted_um"].get<double>()) <= q["U_um"].get<double>();
  }
  EXPECT_EQ(inside, 26);
  std::filesystem::remove_all(dir);
}

}  // namespace verify_test
}  // namespace dbbkit
