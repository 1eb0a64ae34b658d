// The simulator's exact two-ball geometry with a real set-up, checked by hand
// derivations that do not use the first-order model (kinematics.hpp,
// exact_setup_reading_um), and the drawn set-up errors.

#include "dbbkit/simulate.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <random>

#include "dbbkit/error.hpp"
#include "dbbkit/identify.hpp"
#include "dbbkit/io/truth_io.hpp"
#include "test_util.hpp"

namespace dbbkit {
namespace {

using test::kBar;

TEST(ExactSetup, APerfectSetUpWithoutErrorsReadsZero) {
  for (char axis : {'C', 'B'}) {
    const Design d = test::paper_design(axis);
    for (const Installation& in : d.installations) {
      for (double a : d.angles_deg) {
        EXPECT_NEAR(exact_setup_reading_um(d.axis, in, a, Vector6d::Zero(), kBar, {}), 0.0, 1e-9)
            << in.id << " " << a;
      }
    }
  }
}

TEST(ExactSetup, ABallPlacedOutwardsIsAConstantRadiallyAndSecondOrderTangentially) {
  // The ball sits dL further out than designed; the following ball follows the designed path.
  // Radial bar: the two balls stay on one line, so the bar reads s dL at every angle.
  // Tangential bar: dL is perpendicular to it, so it reads sqrt(bar^2 + dL^2) - bar.
  const Design d = test::paper_design('C');
  SetupError e;
  e.ball_mm = {0.1, 0, 0};
  for (const Installation& in : d.installations) {
    if (in.direction.kind != Direction::Kind::kRadial &&
        in.direction.kind != Direction::Kind::kTangential)
      continue;
    const double expected = in.direction.kind == Direction::Kind::kRadial
                                ? in.sign * 100.0
                                : 1e3 * (std::sqrt(kBar * kBar + 0.01) - kBar);
    for (double a : d.angles_deg) {
      EXPECT_NEAR(exact_setup_reading_um(d.axis, in, a, Vector6d::Zero(), kBar, e), expected, 1e-7)
          << in.id << " " << a;
    }
  }
}

TEST(ExactSetup, CentringAndLengthOffsetByHand) {
  // The following ball's path centre moved by c: |s bar u - c| - bar, written with the
  // components of c along and across u; the length offset adds itself.
  const Design d = test::paper_design('C');
  SetupError e;
  e.centring_um = {6, -3, 2};
  e.length_offset_um = 1.5;
  const Eigen::Vector3d c = 1e-3 * e.centring_um;
  for (const Installation& in : d.installations) {
    for (double a : {0.0, 40.0, 135.0, 270.0}) {
      const double g = a * M_PI / 180.0;
      Eigen::Vector3d u;
      switch (in.direction.kind) {
        case Direction::Kind::kRadial:
          u = {std::cos(g), std::sin(g), 0};
          break;
        case Direction::Kind::kTangential:
          u = {-std::sin(g), std::cos(g), 0};
          break;
        default:
          u = {0, 0, 1};
      }
      const double along = u.dot(c);
      const double across2 = c.squaredNorm() - along * along;
      const double expected =
          1e3 * (std::sqrt(std::pow(kBar - in.sign * along, 2) + across2) - kBar) + 1.5;
      EXPECT_NEAR(exact_setup_reading_um(d.axis, in, a, Vector6d::Zero(), kBar, e), expected, 1e-7)
          << in.id << " " << a;
    }
  }
}

TEST(ExactSetup, WithoutSetUpItIsTheExactTransformOfTheErrors) {
  const Design d = test::paper_design('B');
  std::mt19937_64 rng(3);
  std::normal_distribution<double> n01;
  for (const Installation& in : d.installations) {
    for (double a : d.angles_deg) {
      Vector6d e;
      for (int k = 0; k < 6; ++k) e(k) = (k < 3 ? 20.0 : 100.0) * n01(rng);
      EXPECT_NEAR(exact_setup_reading_um(d.axis, in, a, e, kBar, {}),
                  exact_reading_um(d.axis, in, a, e, kBar), 1e-9);
    }
  }
}

Truth exact_truth(const Design& d) {
  Truth t;
  t.model = {ErrorModel::Kind::kFourier, 1};
  for (int k = 0; k < 6; ++k) t.coefficients[k] = {2.0 + k, 1.0, -1.0};
  t.exact = true;
  t.noiseless = true;
  (void)d;
  return t;
}

TEST(ExactSetup, DrawsHaveTheDeclaredSizeAreReproducibleAndGivenValuesWin) {
  Design d = test::paper_design('C');
  const std::vector<Installation> base = d.installations;
  d.installations.clear();
  for (int k = 0; k < 700; ++k) {
    Installation in = base[k % base.size()];
    in.id = "i" + std::to_string(k);
    d.installations.push_back(in);
  }
  Truth t = exact_truth(d);
  t.setup_draw.length_offset_um = 10;
  t.setup_draw.centring_um = 5;
  t.setup_draw.ball_mm = {0.05, 0.02, 0.1};
  SetupError given;
  given.length_offset_um = 123;
  t.setup_given = {{"i3", given}};
  const std::vector<SetupError> s = simulated_setup_errors(d, t, 9);
  const std::vector<SetupError> again = simulated_setup_errors(d, t, 9);
  ASSERT_EQ(s.size(), 700u);
  EXPECT_EQ(s[3].length_offset_um, 123.0);
  EXPECT_EQ(s[3].centring_um, Eigen::Vector3d::Zero());
  double v_len = 0, v_c = 0;
  Eigen::Array3d v_ball = Eigen::Array3d::Zero();
  int n = 0;
  for (size_t i = 0; i < s.size(); ++i) {
    EXPECT_EQ(s[i].length_offset_um, again[i].length_offset_um);
    if (i == 3) continue;
    v_len += s[i].length_offset_um * s[i].length_offset_um;
    v_c += s[i].centring_um.squaredNorm() / 3;
    v_ball += s[i].ball_mm.array().square();
    ++n;
  }
  // Sample standard deviations of 699 (centring: 3 x 699) normal draws: within 10 %
  // (the relative standard error of a standard deviation from n draws is 1/sqrt(2n) < 3 %).
  EXPECT_NEAR(std::sqrt(v_len / n), 10.0, 1.0);
  EXPECT_NEAR(std::sqrt(v_c / n), 5.0, 0.5);
  const Eigen::Array3d sd = (v_ball / n).sqrt();
  EXPECT_NEAR(sd(0), 0.05, 0.005);
  EXPECT_NEAR(sd(1), 0.02, 0.002);
  EXPECT_NEAR(sd(2), 0.1, 0.01);
}

TEST(ExactSetup, IdentifyRecoversTheErrorsFromExactReadingsWithAPerfectSetUp) {
  // Readings from the exact geometry (no linearisation): the first-order estimator
  // must recover the axis errors to within their stated uncertainty (here far above the
  // second-order terms of errors of a few um and urad).
  Design d = test::paper_design('C');
  d.errors = {ErrorModel::Kind::kFourier, 1};
  Truth t = exact_truth(d);
  t.noiseless = false;
  const IdentifyResult r = identify(d, simulate(d, t, 5));
  const Parameterisation param(d);
  for (int s = 0; s < param.n_stations(); ++s) {
    const double a = param.station_angle_deg(s);
    const Vector6d truth = truth_errors(t, d.axis, a);
    for (int k = 0; k < 6; ++k) {
      Eigen::VectorXd c = param.error_map(s).row(k).transpose();
      const Determined v = r.estimate.evaluate(c);
      ASSERT_TRUE(v.determined);
      EXPECT_LE(std::abs(v.value - truth(k)), 4 * v.std + 1e-6) << kErrorNames[k] << " at " << a;
    }
  }
}

TEST(ExactSetup, TheTruthFileDeclaresGeometryAndSetUp) {
  const Design d = test::paper_design('C');
  const nlohmann::json j = nlohmann::json::parse(R"({
    "format": "dbbkit.truth/1",
    "errors": {"model": "fourier", "order": 0,
               "coefficients": {"dx": [1], "dy": [2], "dz": [3], "ex": [4], "ey": [5], "ez": [6]}},
    "noise": {"distribution": "none"}, "geometry": "exact",
    "setup": {"draw": {"length_offset_um": 2, "centring_um": 1, "ball_mm": {"L": 0.01}},
              "installations": {"3r": {"centring_um": [6, -3], "ball_mm": {"H": -0.2}}}}
  })");
  const Truth t = io::truth_from_json(j, "t.json");
  EXPECT_TRUE(t.exact);
  ASSERT_EQ(t.setup_given.size(), 1u);
  EXPECT_EQ(t.setup_given[0].second.centring_um, Eigen::Vector3d(6, -3, 0));
  EXPECT_EQ(t.setup_given[0].second.ball_mm, Eigen::Vector3d(0, 0, -0.2));
  EXPECT_NO_THROW(validate_truth(t, d, "t.json"));
  const std::vector<Reading> r = simulate(d, t, 1);
  const std::vector<SetupError> s = simulated_setup_errors(d, t, 1);
  for (const Reading& x : r) {
    const int i = d.find_installation(x.installation);
    // As the instrument counted (reading_sign), the bar's change.
    EXPECT_NEAR(d.installations[i].reading_sign * x.reading_um,
                exact_setup_reading_um(d.axis, d.installations[i], x.angle_deg,
                                       truth_errors(t, d.axis, x.angle_deg),
                                       *d.installations[i].bar_mm, s[i]),
                1e-12);
  }

  nlohmann::json first = j;
  first.erase("geometry");
  try {
    validate_truth(io::truth_from_json(first, "t.json"), d, "t.json");
    ADD_FAILURE() << "set-up errors without the exact geometry were accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.where(), "setup");
  }
  nlohmann::json unknown = j;
  unknown["setup"]["installations"] = {{"9z", {{"length_offset_um", 1}}}};
  try {
    validate_truth(io::truth_from_json(unknown, "t.json"), d, "t.json");
    ADD_FAILURE() << "an unknown installation was accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.where(), "setup.installations.9z");
  }
  nlohmann::json negative = j;
  negative["setup"]["draw"]["centring_um"] = -1;
  EXPECT_THROW(io::truth_from_json(negative, "t.json"), InputError);
  nlohmann::json typo = j;
  typo["setup"]["draw"]["centering_um"] = 1;
  EXPECT_THROW(io::truth_from_json(typo, "t.json"), InputError);
}

// A sweep direction run twice (ccw, cw, ccw) with repeats: the second ccw run continues the
// repeat numbers, so the readings are valid as simulate writes them (no two share installation,
// angle, sweep and repeat).
TEST(Simulate, RepeatsOfASweepRunTwiceAreNumberedOn) {
  const Design d = test::paper_design('C');
  Truth t;
  t.model.kind = ErrorModel::Kind::kPerAngle;
  for (double a : d.angles_deg) t.per_angle.push_back({a, Vector6d::Zero()});
  t.repeats = 2;
  t.schedule = Schedule{10, 240, {Sweep::kCCW, Sweep::kCW, Sweep::kCCW}};
  const std::vector<Reading> r = simulate(d, t, 3);
  EXPECT_NO_THROW(validate_readings(d, r, "simulated"));
  int late = 0;
  for (const Reading& x : r) {
    ASSERT_TRUE(x.repeat && x.sweep);
    if (*x.sweep == Sweep::kCCW && *x.repeat >= 2) ++late;
    if (*x.sweep == Sweep::kCW) EXPECT_LT(*x.repeat, 2);
  }
  EXPECT_EQ(late, static_cast<int>(d.installations.size() * d.angles_deg.size() * 2));
}

}  // namespace
}  // namespace dbbkit
