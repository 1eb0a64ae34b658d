// `dbbkit predict` against axes whose real lines are written out here: the readings of a design
// are computed from the exact two-ball geometry of a real axis line (Eigen::AngleAxisd about a
// displaced, tilted line, the axis standing at the commanded angle plus its zero error), not from
// the model; the point a pose names is turned about the same real line, so its true error is
// known without dbbkit's first-order algebra. Then what entering the location errors leaves is
// checked against a controller that turns the point about the identified line.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iomanip>
#include <optional>
#include <random>
#include <sstream>
#include <tuple>

#include "cli_util.hpp"
#include "dbbkit/chain.hpp"
#include "dbbkit/identify.hpp"
#include "dbbkit/io/chain_io.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/json_reader.hpp"
#include "dbbkit/io/machine_io.hpp"
#include "dbbkit/io/predict_io.hpp"
#include "dbbkit/io/result_io.hpp"
#include "dbbkit/iso230.hpp"
#include "dbbkit/kinematics.hpp"
#include "test_util.hpp"

namespace dbbkit {
namespace predict_test {

using test::kPi;

using test::RealLine;
using test::turn;

using test::line_of;

// The design's readings on the real line: the ball on the turning body turned about it, the
// other ball where the nominal path puts it, noise uniform within +-noise_um.
std::vector<Reading> real_readings(const Design& d, const RealLine& line, double noise_um,
                                   std::mt19937_64& rng) {
  std::uniform_real_distribution<double> U(-noise_um, noise_um);
  std::vector<Reading> out;
  for (const Installation& in : d.installations) {
    const double bar = in.bar_mm.value_or(test::kBar);
    const Eigen::Vector3d body = ball_body_mm(d.axis, in);
    for (const double a : d.angles_deg) {
      const Eigen::Matrix3d R = axis_rotation(d.axis, a);
      const Eigen::Vector3d P = turn(line, a, body);
      const Eigen::Vector3d F = R * body - in.sign * bar * (R * in.direction.body);
      Reading r;
      r.installation = in.id;
      r.angle_deg = a;
      r.reading_um = 1e3 * ((P - F).norm() - bar) + (noise_um > 0 ? U(rng) : 0.0);
      out.push_back(r);
    }
  }
  return out;
}

io::ResultFile measured(const Design& d, const std::vector<Reading>& readings) {
  IdentifyOptions o;
  o.iso_motion.enabled = false;
  const IdentifyResult r = identify(d, readings, o);
  const nlohmann::json j =
      io::identify_to_json(d, readings, r, {"d.json", "r.csv"}, nullptr, false);
  return io::result_from_text(io::dump_json(j), "r.json");
}

Design design(const std::string& name) {
  return io::read_design_file(std::string(DBBKIT_SOURCE_DIR) + "/designs/" + name);
}

// The poses asked about: every measured angle and the midpoints between them, at points of the
// body up to 250 mm from the axis frame's origin.
std::vector<Pose> poses_of(const Design& d) {
  std::vector<double> angles = d.angles_deg;
  for (std::size_t i = 0; i + 1 < d.angles_deg.size(); ++i)
    angles.push_back(0.5 * (d.angles_deg[i] + d.angles_deg[i + 1]));
  const std::array<Eigen::Vector3d, 3> points = {
      Eigen::Vector3d(200, 0, 50), Eigen::Vector3d(-120, 150, 120), Eigen::Vector3d(30, -80, 250)};
  std::vector<Pose> poses;
  for (const double a : angles)
    for (const Eigen::Vector3d& p : points) poses.push_back({a, p});
  return poses;
}

struct Kind {
  const char* design;
  double position_um, orientation_urad;  // uniform bounds of the planted location errors
};
const std::array<Kind, 3> kKinds = {{{"paper-c-turntable.json", 20, 30},
                                     {"a-trunnion.json", 20, 30},
                                     {"b-head-kit-optimized.json", 20, 30}}};

std::array<double, 5> planted(const Kind& k, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1, 1);
  return {k.position_um * u(rng), k.position_um * u(rng), k.orientation_urad * u(rng),
          k.orientation_urad * u(rng), k.orientation_urad * u(rng)};
}

// Noise-free readings of a real axis: the predicted error of every pose's point is its exact
// displacement on the real line (first order, and the identification on exact readings: within 0.03
// um), at measured angles and between them; and what entering leaves is what a controller turning
// the point about the identified line leaves.
TEST(Predict, APointOfARealAxisIsOffByWhatItsRealLineSays) {
  std::mt19937_64 rng(7);
  for (const Kind& k : kKinds) {
    const Design d = design(k.design);
    const std::array<double, 5> l = planted(k, rng);
    const RealLine real = line_of(d.axis, l);
    const io::ResultFile r = measured(d, real_readings(d, real, 0.0, rng));
    std::array<double, 5> identified{};
    for (int i = 0; i < 5; ++i) {
      ASSERT_TRUE(r.location[i].value) << k.design << " " << r.location[i].name;
      identified[i] = *r.location[i].value;
      EXPECT_NEAR(identified[i], l[i], 0.01) << k.design << " " << r.location[i].name;
    }
    const RealLine corrected = line_of(d.axis, identified);
    const io::PredictResult p = io::predict(r, poses_of(d), 0.95);
    int motions = 0, location = 0;
    for (const PointPrediction& x : p.points) {
      ASSERT_EQ(x.gap, PredictionGap::kNone);
      const Eigen::Vector3d nominal = axis_rotation(d.axis, x.pose.angle_deg) * x.pose.point_mm;
      const Eigen::Vector3d truth = 1e3 * (turn(real, x.pose.angle_deg, x.pose.point_mm) - nominal);
      const Eigen::Vector3d left = 1e3 * (turn(real, x.pose.angle_deg, x.pose.point_mm) -
                                          turn(corrected, x.pose.angle_deg, x.pose.point_mm));
      EXPECT_LT((x.error_um - truth).norm(), 0.03)
          << k.design << " at " << x.pose.angle_deg << ": " << x.error_um.transpose() << " vs "
          << truth.transpose();
      EXPECT_LT((x.after_um - left).norm(), 0.03) << k.design << " at " << x.pose.angle_deg;
      (x.basis == PredictionBasis::kMotions ? motions : location) += 1;
    }
    EXPECT_EQ(motions, 3 * static_cast<int>(d.angles_deg.size())) << k.design;
    EXPECT_EQ(location, 3 * static_cast<int>(d.angles_deg.size() - 1)) << k.design;
  }
}

// Coverage over random real axes with noise: one pose per truth (a random measured angle or a
// midpoint, a random point), so that the trials are independent. Each coordinate's interval
// +-k u covers its true error at the nominal 95 % within three binomial standard errors where
// the design declares no set-up (the B head's declared set-up, absent from the truth, makes
// its intervals wider: at least the nominal rate); so does the ball of radius U_length around
// the predicted error vector, before and after entering.
TEST(Predict, IntervalsCoverTheTruthAtTheirNominalRate) {
  const int n = 300;
  for (const Kind& k : kKinds) {
    const Design d = design(k.design);
    std::mt19937_64 rng(11);
    int coordinate_in = 0, sphere_in = 0, after_in = 0;
    const std::vector<Pose> all = poses_of(d);
    for (int t = 0; t < n; ++t) {
      const std::array<double, 5> l = planted(k, rng);
      const RealLine real = line_of(d.axis, l);
      const io::ResultFile r = measured(d, real_readings(d, real, 1.25, rng));
      std::array<double, 5> identified{};
      for (int i = 0; i < 5; ++i) identified[i] = r.location[i].value.value_or(0.0);
      const RealLine corrected = line_of(d.axis, identified);
      std::uniform_int_distribution<std::size_t> pick(0, all.size() - 1);
      const Pose pose = all[pick(rng)];
      const io::PredictResult p = io::predict(r, {pose}, 0.95);
      const PointPrediction& x = p.points[0];
      ASSERT_EQ(x.gap, PredictionGap::kNone);
      const Eigen::Vector3d nominal = axis_rotation(d.axis, pose.angle_deg) * pose.point_mm;
      const Eigen::Vector3d real_point = turn(real, pose.angle_deg, pose.point_mm);
      const Eigen::Vector3d truth = 1e3 * (real_point - nominal);
      const Eigen::Vector3d left =
          1e3 * (real_point - turn(corrected, pose.angle_deg, pose.point_mm));
      for (int c = 0; c < 3; ++c) {
        const double s = std::sqrt(x.covariance(c, c));
        coordinate_in += std::abs(x.error_um(c) - truth(c)) <= p.coverage.k * s;
      }
      sphere_in += (x.error_um - truth).norm() <= x.U_um;
      after_in += (x.after_um - left).norm() <= x.after_U_um;
    }
    const double se = std::sqrt(0.95 * 0.05 / n);
    const double coord = coordinate_in / (3.0 * n), sphere = sphere_in / double(n),
                 after = after_in / double(n);
    std::printf("%s: coordinates %.3f, sphere %.3f, after entering %.3f (of %d truths)\n", k.design,
                coord, sphere, after, n);
    EXPECT_GE(coord, 0.95 - 3 * se) << k.design;
    if (std::string(k.design) != "b-head-kit-optimized.json")
      EXPECT_LE(coord, 0.95 + 3 * se) << k.design;
    EXPECT_GE(sphere, 0.95 - 3 * se) << k.design;
    EXPECT_GE(after, 0.95 - 3 * se) << k.design;
    if (std::string(k.design) != "b-head-kit-optimized.json") {
      EXPECT_LE(sphere, 0.95 + 3 * se) << k.design;
      EXPECT_LE(after, 0.95 + 3 * se) << k.design;
    }
  }
}

// The radius of the ball that holds a Gaussian error with the coverage probability: the
// chi-squared quantiles where the covariance is isotropic in three, two or one directions, and
// by sampling (10^6 draws) where it is not.
TEST(Predict, LengthUncertaintyIsTheRadiusOfTheCoverageProbability) {
  const PredictionCoverage c = prediction_coverage(0.95, std::nullopt);
  auto diag = [](double a, double b, double d) {
    return Eigen::Matrix3d(Eigen::Vector3d(a, b, d).asDiagonal());
  };
  EXPECT_NEAR(length_uncertainty(diag(4, 4, 4), c), 2 * std::sqrt(7.814727903), 1e-4);
  EXPECT_NEAR(length_uncertainty(diag(0, 4, 4), c), 2 * std::sqrt(5.991464547), 1e-4);
  EXPECT_NEAR(length_uncertainty(diag(0, 0, 4), c), 2 * 1.959963985, 1e-4);
  std::mt19937_64 rng(5);
  std::normal_distribution<double> z;
  for (const Eigen::Vector3d& l : {Eigen::Vector3d(0.01, 0.3, 1), Eigen::Vector3d(0.5, 0.5, 1),
                                   Eigen::Vector3d(1e-6, 1, 1.2)}) {
    const Eigen::Matrix3d Q =
        Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).matrix();
    const Eigen::Matrix3d cov = Q * l.asDiagonal() * Q.transpose();
    const double U = length_uncertainty(cov, c);
    const int n = 1000000;
    int in = 0;
    for (int t = 0; t < n; ++t) {
      const Eigen::Vector3d x(std::sqrt(l(0)) * z(rng), std::sqrt(l(1)) * z(rng),
                              std::sqrt(l(2)) * z(rng));
      in += x.norm() <= U;
    }
    // 3 binomial standard errors of 10^6 draws: 0.00065.
    EXPECT_NEAR(in / double(n), 0.95, 0.00065) << l.transpose();
  }
}

// The Jacobian of a point's displacement is the displacement's own formula.
TEST(Predict, PointJacobianIsTheDisplacement) {
  Vector6d e;
  e << 1.5, -2, 0.5, 30, -12, 7;
  const Eigen::Vector3d P(120, -40, 75);
  EXPECT_TRUE(test::near(point_jacobian(P) * e, displacement_um(e, P), 1e-12));
}

// From the command line: identify, then predict; the poses file and a result without what a
// prediction needs are refused naming the line, the column or the key (exit 2).
TEST(PredictCli, PredictsFromAResultAndRefusesWhatItCannotUse) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("dbbkit_predict_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  auto write = [&](const std::string& name, const std::string& text) {
    const std::string path = (dir / name).string();
    std::ofstream(path) << text;
    return path;
  };
  const std::string design_path = std::string(DBBKIT_SOURCE_DIR) + "/designs/a-trunnion.json";
  const Design d = design("a-trunnion.json");
  std::mt19937_64 rng(3);
  const RealLine real = line_of(d.axis, {20, -10, 30, 0, 15});
  std::ostringstream csv;
  csv << "installation,angle_deg,reading_um\n";
  for (const Reading& r : real_readings(d, real, 1.25, rng))
    csv << r.installation << "," << r.angle_deg << "," << r.reading_um << "\n";
  const std::string data = write("a.csv", csv.str());
  const std::string result = (dir / "a.json").string();
  ASSERT_EQ(
      run_cli("identify --design " + design_path + " --data " + data + " --out " + result).status,
      0);
  const std::string poses =
      write("poses.csv", "angle_deg,x_mm,y_mm,z_mm\n60,0,100,80\n65,0,100,80\n");
  const std::string out = (dir / "p.json").string();
  const CliRun ok = run_cli("predict --result " + result + " --at " + poses + " --out " + out);
  ASSERT_EQ(ok.status, 0) << ok.err;
  EXPECT_NE(ok.out.find("Largest error"), std::string::npos) << ok.out;
  const nlohmann::json j = nlohmann::json::parse(slurp(out));
  EXPECT_EQ(j["format"], "dbbkit.predict/1");
  ASSERT_EQ(j["points"].size(), 2u);
  EXPECT_EQ(j["points"][0]["basis"], "motions");
  EXPECT_EQ(j["points"][1]["basis"], "location");
  // The true error of the point at A 60 deg lies within U of the predicted one.
  const Eigen::Vector3d P(0, 100, 80);
  const Eigen::Vector3d truth = 1e3 * (turn(real, 60, P) - axis_rotation(d.axis, 60) * P);
  Eigen::Vector3d e;
  for (int c = 0; c < 3; ++c) e(c) = j["points"][0]["error_um"][c].get<double>();
  EXPECT_LE((e - truth).norm(), j["points"][0]["U_um"].get<double>());

  struct Bad {
    std::string text, where;
  };
  const std::vector<Bad> bad = {
      {"angle_deg,x_mm,y_mm\n0,1,2\n", "required column 'z_mm' is missing"},
      {"angle_deg,x_mm,y_mm,z_mm,w\n0,1,2,3,4\n", "unknown column"},
      {"angle_deg,x_mm,y_mm,z_mm\n0,1,2\n", "line 2"},
      {"angle_deg,x_mm,y_mm,z_mm\n0,1,2,abc\n", "line 2, column z_mm"},
      {"angle_deg,x_mm,y_mm,z_mm\n150,1,2,3\n", "beyond the travel of the A"},
      {"angle_deg,x_mm,y_mm,z_mm\n0,1,2,1e9\n", "line 2, column z_mm"},
      {"angle_deg,x_mm,y_mm,z_mm\n", "no pose"},
      {"", "empty"}};
  for (const Bad& b : bad) {
    const CliRun r = run_cli("predict --result " + result + " --at " + write("bad.csv", b.text));
    EXPECT_EQ(r.status, 2) << b.text;
    EXPECT_NE(r.err.find(b.where), std::string::npos) << b.text << ": " << r.err;
  }
  // A result without the location errors' covariance (an earlier version's).
  nlohmann::json old = nlohmann::json::parse(slurp(result));
  old["iso230"].erase("location_covariance");
  const CliRun r = run_cli("predict --result " + write("old.json", old.dump()) + " --at " + poses);
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("iso230.location_covariance"), std::string::npos) << r.err;
  // A covariance that is not one.
  nlohmann::json skew = nlohmann::json::parse(slurp(result));
  skew["iso230"]["motion_covariance"]["at"][0]["matrix"][0][1] = 1e6;
  const CliRun s =
      run_cli("predict --result " + write("skew.json", skew.dump()) + " --at " + poses);
  EXPECT_EQ(s.status, 2);
  EXPECT_NE(s.err.find("motion_covariance.at[0].matrix"), std::string::npos) << s.err;
  // The covariance must fit the component's std and the location part's (a zero matrix cannot),
  // name the location errors in order, leave out no measured angle, hold no negative variance.
  struct Edit {
    std::function<void(nlohmann::json&)> f;
    std::string where;
  };
  const std::vector<Edit> edits = {
      {[](nlohmann::json& j) {
         for (auto& row : j["iso230"]["motion_covariance"]["at"][0]["matrix"])
           for (auto& x : row) x = 0.0;
       },
       "motion_covariance.at[0].matrix[0][0]"},
      {[](nlohmann::json& j) { j["iso230"]["motion_covariance"]["at"].erase(0); },
       "no entry for angle"},
      {[](nlohmann::json& j) { j["iso230"]["motion_covariance"]["at"][0]["matrix"][0][0] = -1e-9; },
       "a negative variance"},
      {[](nlohmann::json& j) {  // a correlation of 10: no covariance, named where it is
         auto& m = j["iso230"]["location_covariance"]["matrix"];
         const double c = 10 * std::sqrt(m[0][0].get<double>() * m[1][1].get<double>());
         m[0][1] = c, m[1][0] = c;
       },
       "iso230.location_covariance.matrix: not positive semidefinite"},
      {[](nlohmann::json& j) {
         j["design"]["axis_definition"]["reference"] = {1, 0, 0};
       },
       "design.axis_definition.reference"},
      {[](nlohmann::json& j) { j["design"]["axis"] = "C"; },
       "design.axis: 'C' is not the axis design.axis_definition describes"},
      {[](nlohmann::json& j) {
         std::swap(j["iso230"]["location_covariance"]["names"][0],
                   j["iso230"]["location_covariance"]["names"][1]);
       },
       "location_covariance.names[0]"},
      {[](nlohmann::json& j) { std::swap(j["iso230"]["location"][0], j["iso230"]["location"][1]); },
       "iso230.location"},
      {[](nlohmann::json& j) { j["budget"]["noise_evaluation"] = "Type A (residual)"; },
       "degrees of freedom"}};
  for (const Edit& e : edits) {
    nlohmann::json j = nlohmann::json::parse(slurp(result));
    e.f(j);
    const CliRun b = run_cli("predict --result " + write("edit.json", j.dump()) + " --at " + poses);
    EXPECT_EQ(b.status, 2) << e.where;
    EXPECT_NE(b.err.find(e.where), std::string::npos) << e.where << ": " << b.err;
  }
  // A map over the envelope: every measured angle, the axis line and a circle of six points
  // 150 mm from it, 80 mm along it. The largest error it names is the largest of its points, and
  // each point is what --at predicts for the same pose (whose intervals the tests above check).
  const CliRun m =
      run_cli("predict --result " + result +
              " --grid-radius-mm 0,150 --grid-height-mm 80 --grid-around 6 --out " + out);
  ASSERT_EQ(m.status, 0) << m.err;
  const nlohmann::json g = nlohmann::json::parse(slurp(out));
  const std::size_t angles = nlohmann::json::parse(slurp(result))["errors"].size();
  ASSERT_EQ(g["points"].size(), angles * 7);
  EXPECT_NE(m.out.find("a map of " + std::to_string(angles * 7) + " points"), std::string::npos)
      << m.out;
  EXPECT_EQ(m.out.find("angle deg"), std::string::npos) << "a map prints no row per point";
  double most = 0;
  std::ostringstream same;
  same << std::setprecision(17) << "angle_deg,x_mm,y_mm,z_mm\n";
  for (const auto& x : g["points"]) {
    most = std::max(most, std::hypot(x["error_um"][0].get<double>(), x["error_um"][1].get<double>(),
                                     x["error_um"][2].get<double>()));
    same << x["angle_deg"].get<double>() << "," << x["point_mm"][0].get<double>() << ","
         << x["point_mm"][1].get<double>() << "," << x["point_mm"][2].get<double>() << "\n";
  }
  EXPECT_NEAR(g["largest"]["error"]["length_um"].get<double>(), most, 1e-5);
  const std::string at_out = (dir / "same.json").string();
  ASSERT_EQ(run_cli("predict --result " + result + " --at " + write("same.csv", same.str()) +
                    " --out " + at_out)
                .status,
            0);
  const nlohmann::json h = nlohmann::json::parse(slurp(at_out));
  ASSERT_EQ(h["points"].size(), g["points"].size());
  for (std::size_t i = 0; i < g["points"].size(); ++i) {
    for (const char* key : {"error_um", "std_um"})
      for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(g["points"][i][key][c].get<double>(), h["points"][i][key][c].get<double>(),
                    1e-6)
            << i << " " << key;
    EXPECT_NEAR(g["points"][i]["U_um"].get<double>(), h["points"][i]["U_um"].get<double>(), 1e-6);
  }
  // Neither poses nor a map; both.
  EXPECT_EQ(run_cli("predict --result " + result).status, 2);
  EXPECT_EQ(
      run_cli("predict --result " + result + " --at " + poses + " --grid-radius-mm 10").status, 2);
  // The map states its parameters, defaults filled in; a radius 0's covariance and a point on the
  // axis line are never -0.
  EXPECT_EQ(g["grid"]["radii_mm"], nlohmann::json::parse("[0, 150]"));
  EXPECT_EQ(g["grid"]["heights_mm"], nlohmann::json::parse("[80]"));
  EXPECT_EQ(g["grid"]["around"].get<int>(), 6);
  EXPECT_EQ(g["grid"]["angles_deg"].size(), angles);
  EXPECT_EQ(slurp(out).find("-0.0,"), std::string::npos);
  EXPECT_EQ(slurp(out).find("-0.0\n"), std::string::npos);
  // A map's lists: each item a number, no value twice, each within its range; the error names the
  // option and the item.
  struct BadGrid {
    std::string options, says;
  };
  for (const BadGrid& b : std::vector<BadGrid>{
           {"--grid-radius-mm 1,,2", "--grid-radius-mm: item 2: empty"},
           {"--grid-radius-mm 1,", "--grid-radius-mm: item 2: empty"},
           {"--grid-radius-mm ''", "--grid-radius-mm: item 1: empty"},
           {"--grid-radius-mm 1,x", "--grid-radius-mm: item 2: 'x' is not"},
           {"--grid-radius-mm 100,50,100", "item 3: 100 is item 1 as well"},
           {"--grid-radius-mm 1e-5", "item 1: 1e-05 mm: a radius is 0 (the axis line) or from"},
           {"--grid-radius-mm -1", "item 1: -1 mm"},
           {"--grid-radius-mm 9000 --grid-height-mm 9000", "beyond 10000 mm from the axis"},
           {"--grid-radius-mm 10 --grid-height-mm 0,inf", "--grid-height-mm: item 2: 'inf'"},
           {"--grid-radius-mm 10 --grid-angles-deg 0,500",
            "--grid-angles-deg: item 2: 500 deg is "
            "beyond the travel"},
           {"--grid-radius-mm 10 --grid-angles-deg 0,0", "item 2: 0 is item 1 as well"},
           {"--grid-radius-mm 10 --grid-around 0", "--grid-around"},
           {"--grid-height-mm 10", "--grid-radius-mm"}}) {
    const CliRun r = run_cli("predict --result " + result + " " + b.options);
    EXPECT_EQ(r.status, 2) << b.options;
    EXPECT_NE(r.err.find(b.says), std::string::npos) << b.options << ": " << r.err;
  }
  // An angle not measured is never printed as a measured one's text.
  const double first = nlohmann::json::parse(slurp(result))["errors"][0]["angle_deg"];
  auto fmt = [](double x) {
    std::ostringstream t;
    t << std::setprecision(15) << x;
    return t.str();
  };
  const CliRun near =
      run_cli("predict --result " + result +
              " --grid-radius-mm 100 --grid-around 1 --grid-angles-deg " + fmt(first + 1e-7));
  ASSERT_EQ(near.status, 0) << near.err;
  EXPECT_NE(near.out.find(fmt(first + 1e-7) + " deg"), std::string::npos) << near.out;
  std::filesystem::remove_all(dir);
}

// The map's points: at each angle, `around` points on a circle of each radius about the axis
// line at each height along it, the first in the reference direction; the axis line once.
TEST(Predict, AnEnvelopeGridLiesOnCirclesAboutTheAxis) {
  const Design d = design("a-trunnion.json");
  EnvelopeGrid grid;
  grid.angles_deg = {-30, 60};
  grid.radii_mm = {0, 120};
  grid.heights_mm = {-40, 90};
  grid.around = 5;
  const std::vector<Pose> poses = envelope_poses(d.axis, grid);
  ASSERT_EQ(poses.size(), 2u * 2u * (1u + 5u));
  const Eigen::Vector3d w = d.axis.direction();
  int on_line = 0;
  for (const Pose& p : poses) {
    const double h = p.point_mm.dot(w), r = (p.point_mm - h * w).norm();
    EXPECT_TRUE(std::abs(h + 40) < 1e-9 || std::abs(h - 90) < 1e-9) << h;
    EXPECT_TRUE(r < 1e-9 || std::abs(r - 120) < 1e-9) << r;
    on_line += r < 1e-9;
  }
  EXPECT_EQ(on_line, 4);  // two angles, two heights
  // The first point of a circle is along the reference direction; the angle comes first.
  EXPECT_NEAR((poses[2].point_mm - (120 * d.axis.reference() - 40 * w)).norm(), 0, 1e-9);
  EXPECT_EQ(poses.front().angle_deg, -30);
  EXPECT_EQ(poses.back().angle_deg, 60);
  // Five points evenly spaced: consecutive ones 2 r sin(36 deg) apart.
  EXPECT_NEAR((poses[3].point_mm - poses[2].point_mm).norm(), 240 * std::sin(M_PI / 5), 1e-9);
}

// The README's predict example: every line of its output blocks is printed by the commands it
// names, run here on the same files.
TEST(Readme, WhereTheToolWillBeOffPrintsWhatTheReadmeShows) {
  const std::string section =
      readme_section("## Worked example: where the tool will be off, before and after entering");
  ASSERT_FALSE(section.empty());
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("dbbkit_readme_pr_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string src = DBBKIT_SOURCE_DIR;
  const std::string D = src + "/designs/a-trunnion.json";
  const std::string poses = src + "/tests/data/poses_a_trunnion.csv";
  std::string printed;
  for (const std::string& cmd :
       {"simulate --design " + D + " --truth " + src +
            "/tests/data/truth_a_trunnion_location.json --out a.csv",
        "identify --design " + D + " --data a.csv --out a.json",
        "predict --result a.json --at " + poses,
        "predict --result a.json --at " + poses + " --location-only",
        std::string("predict --result a.json --grid-radius-mm 0,100,200 "
                    "--grid-height-mm -50,0,100 --grid-around 12 --out map.json"),
        std::string("compensation --result a.json --format table --grid-radius-mm 0,100,200 "
                    "--grid-height-mm -50,0,100 --grid-around 12"),
        std::string("compensation --result a.json --format table --grid-radius-mm 0 "
                    "--grid-around 1")}) {
    const CliRun r = run_cli_shell("cd " + dir.string() + " && " + DBBKIT_CLI + " " + cmd);
    ASSERT_EQ(r.status, 0) << cmd << "\n" << r.err;
    printed += r.out;
  }
  int checked = 0;
  for (const std::string& line : readme_lines_not_printed(section, printed, false, checked))
    ADD_FAILURE() << "README line not printed:\n" << line;
  EXPECT_GE(checked, 23);
  std::filesystem::remove_all(dir);
}

// The report: the terminal's largest errors, a row per angle, and over a map with even steps the
// heat map of where the largest sits (an uneven map says why it has none).
TEST(PredictCli, TheReportStatesTheLargestErrorAtEachAngle) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("dbbkit_predict_rep_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string src = DBBKIT_SOURCE_DIR, d = dir.string();
  auto cli = [&](const std::string& args) {
    return run_cli_shell("cd " + d + " && " + DBBKIT_CLI + " " + args);
  };
  const std::string D = src + "/designs/a-trunnion.json";
  ASSERT_EQ(cli("simulate --design " + D + " --truth " + src +
                "/tests/data/truth_a_trunnion_location.json --out a.csv")
                .status,
            0);
  ASSERT_EQ(cli("identify --design " + D + " --data a.csv --out a.json").status, 0);
  const std::string grid = "--grid-radius-mm 0,100,200 --grid-height-mm -50,0,100 --grid-around 12";
  const CliRun map = cli("predict --result a.json " + grid + " --report p.html --summary p.md");
  ASSERT_EQ(map.status, 0) << map.err;
  const std::string md = slurp(d + "/p.md"), html = slurp(d + "/p.html");
  for (const char* says : {"Largest error: ", "Largest after entering the location errors: "}) {
    const std::size_t at = map.out.find(says);
    ASSERT_NE(at, std::string::npos) << map.out;
    const std::string line = map.out.substr(at, map.out.find('\n', at) - at);
    EXPECT_NE(md.find(line), std::string::npos) << line << "\n" << md;
  }
  int rows = 0;  // each angle's: 75 points (a circle of 12 at two radii, the axis, 3 heights)
  for (std::size_t at = md.find(" | 75 | motions | "); at != std::string::npos;
       at = md.find(" | 75 | motions | ", at + 1))
    ++rows;
  EXPECT_EQ(rows, 23) << md;
  std::size_t figures = 0;
  for (std::size_t at = html.find("<figure class=\"plot\""); at != std::string::npos;
       at = html.find("<figure class=\"plot\"", at + 1))
    ++figures;
  EXPECT_EQ(figures, 2u);
  const CliRun uneven = cli("predict --result a.json --grid-radius-mm 0,50,200 --summary u.md");
  ASSERT_EQ(uneven.status, 0) << uneven.err;
  EXPECT_NE(slurp(d + "/u.md").find("No heat map: the map's radii or angles are not evenly spaced"),
            std::string::npos);
  std::filesystem::remove_all(dir);
}

// ---------------------------------------------------------------- a machine result's chain

// The A/C trunnion's real axes: A's line (in the machine frame), C's line in A's body (the
// machine frame with A at 0), each from its five location errors (test::line_of), and where a
// point fixed to the C table is at (a, c): C turns it about its real line, then A turns both.
struct TrueChain {
  Machine m;
  int ia = 0, ic = 1;
  std::array<double, 5> la{}, lc{};
  RealLine A, C;  // machine frame, the preset at the machine's origin
  Eigen::Vector3d at(double a, double c, const Eigen::Vector3d& x) const {
    return turn(A, a, turn(C, c, x));
  }
};

TrueChain true_chain(const std::array<double, 5>& la, const std::array<double, 5>& lc) {
  TrueChain t;
  t.m =
      io::read_machine_file(std::string(DBBKIT_SOURCE_DIR) + "/designs/machines/a-c-trunnion.json");
  t.ia = t.m.find('A');
  t.ic = t.m.find('C');
  t.la = la, t.lc = lc;
  const std::vector<double> zero(t.m.rotary.size(), 0.0);
  t.A = line_of(t.m.axis_frame(t.ia, zero), la);
  t.A.point += t.m.point_at(t.ia, zero);
  t.C = line_of(t.m.axis_frame(t.ic, zero), lc);
  t.C.point += t.m.point_at(t.ic, zero);
  return t;
}

// One axis of a machine as a machine result states it, with its location errors given.
ChainErrors::Axis chain_axis(const Machine& m, int k, const std::array<double, 5>& l) {
  const std::vector<double> zero(m.rotary.size(), 0.0);
  const AxisFrame f = m.axis_frame(k, zero);
  const IsoFrame iso = iso_frame(f);
  ChainErrors::Axis a;
  a.letter = m.rotary[static_cast<std::size_t>(k)].letter;
  a.table = m.rotary[static_cast<std::size_t>(k)].side == AxisFrame::Side::kTable;
  a.point_mm = m.point_at(k, zero);
  a.direction = f.direction();
  a.vector = {iso.p1, iso.p2, iso.p1, iso.p2, iso.q};
  for (std::size_t q = 0; q < 5; ++q) a.location[q] = l[q];
  return a;
}

// The chain as a machine result states it, with the location errors given.
ChainErrors chain_errors(const TrueChain& t, const std::array<double, 5>& la,
                         const std::array<double, 5>& lc) {
  ChainErrors c;
  c.axes = {chain_axis(t.m, t.ia, la), chain_axis(t.m, t.ic, lc)};
  c.axes[1].on = 0;  // C on A
  c.covariance = Eigen::MatrixXd::Identity(10, 10);
  return c;
}

// The rate of true errors within U against 95 %: the poses of one machine share its chain's
// error, so the binomial error is taken as that of two independent ones per machine.
void expect_nominal_rate(int inside, int total, int machines) {
  const double rate = inside / double(total);
  const double se = std::sqrt(0.95 * 0.05 / (2.0 * machines));
  std::printf("%d of %d true errors within U (%.4f)\n", inside, total, rate);
  EXPECT_NEAR(rate, 0.95, 3 * se);
}

// A point of the C table at (A, C) is off by what the two real lines say: each axis turned about
// its own line (a rotation about a displaced, tilted line, the zero error added to the angle),
// C's line carried by A's turn; the prediction agrees with that geometry to 1e-6 um at any pose,
// and its nominal point is the machine file's.
TEST(PredictChain, APointOfATrunnionIsOffByWhatItsRealLinesSay) {
  const std::array<double, 5> la = {20, 5, 10, 20, 12}, lc = {10, 35, -15, 30, -8};
  const TrueChain t = true_chain(la, lc);
  const ChainErrors c = chain_errors(t, la, lc);
  const std::optional<ChainOrder> sides = chain_order(c);
  ASSERT_TRUE(sides);
  EXPECT_EQ(sides->table, (std::vector<int>{1, 0}));
  EXPECT_TRUE(sides->head.empty());
  const ChainOrder& order = *sides;
  const PredictionCoverage cov = prediction_coverage(0.95, std::nullopt);
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int i = 0; i < 200; ++i) {
    ChainPose pose;
    pose.angles_deg = {60 * u(rng) + 30, 180 * u(rng) + 180};
    pose.point_mm = Eigen::Vector3d(200 * u(rng), 200 * u(rng), -60 + 80 * (u(rng) + 1));
    const ChainPointPrediction p = predict_chain_point(c, order, pose, cov);
    ASSERT_TRUE(p.determined);
    const std::vector<double> angles = {pose.angles_deg[0], pose.angles_deg[1]};
    const Eigen::Vector3d nominal = t.m.body_point_at(t.ic, pose.point_mm, angles);
    EXPECT_LT((p.nominal_mm - nominal).norm(), 1e-9);
    const Eigen::Vector3d truth =
        1e3 * (t.at(pose.angles_deg[0], pose.angles_deg[1], pose.point_mm) - nominal);
    EXPECT_LT((p.error_um - truth).norm(), 1e-6) << i;
    EXPECT_GT(p.U_um, 0);
  }
  // With A and C at 0 only the zero errors move a point; at A 90 the A line's Y0A shows as 20 um
  // in Y and -20 um in Z at the table's centre (a hand derivation: the centre, 60 mm below A,
  // turns to 60 mm along +Y about a line 20 um off in +Y).
  const std::array<double, 5> only_y0a = {20, 0, 0, 0, 0}, none = {0, 0, 0, 0, 0};
  const ChainErrors y0a = chain_errors(t, only_y0a, none);
  ChainPose centre;
  centre.angles_deg = {90, 0};
  centre.point_mm = Eigen::Vector3d(0, 0, -60);
  const ChainPointPrediction h = predict_chain_point(y0a, order, centre, cov);
  EXPECT_NEAR(h.error_um.x(), 0, 1e-9);
  EXPECT_NEAR(h.error_um.y(), 20, 1e-6);
  EXPECT_NEAR(h.error_um.z(), -20, 1e-6);
  // A location error the result does not determine leaves the points it moves not determined.
  ChainErrors partial = c;
  partial.axes[1].location[4].reset();
  ChainPose turned = centre;
  turned.angles_deg = {0, 30};
  turned.point_mm = Eigen::Vector3d(100, 0, -60);
  EXPECT_FALSE(predict_chain_point(partial, order, turned, cov).determined);
}

// The whole way round: both axes of random A/C trunnions measured with the exact two-ball
// geometry (C with A at 0: its real line turned by A's), identified, combined by chain (its JSON
// read back as the command line reads it) and predicted at random poses of the C table: the true
// error lies within U at the coverage probability. Pooled over 100 machines of 10 poses each; the
// poses of one machine share its chain's error, so the binomial error is taken as that of 200
// independent ones.
TEST(PredictChain, IntervalsCoverTheTrueErrorAtTheirNominalRate) {
  const Design da =
      io::read_design_file(std::string(DBBKIT_SOURCE_DIR) + "/designs/a-c-trunnion-A.json");
  const Design dc =
      io::read_design_file(std::string(DBBKIT_SOURCE_DIR) + "/designs/a-c-trunnion-C.json");
  std::mt19937_64 rng(12);
  std::uniform_real_distribution<double> u(-1, 1);
  const int machines = 100, poses = 10;
  int inside = 0, total = 0;
  for (int t = 0; t < machines; ++t) {
    const std::array<double, 5> la = {20 * u(rng), 20 * u(rng), 30 * u(rng), 30 * u(rng),
                                      30 * u(rng)},
                                lc = {20 * u(rng), 20 * u(rng), 30 * u(rng), 30 * u(rng),
                                      30 * u(rng)};
    const TrueChain truth = true_chain(la, lc);
    const std::vector<double> zero(truth.m.rotary.size(), 0.0);
    // What each test sees, in its own frame (from its preset, the axis' nominal point): A's line;
    // C's line as A's real turn at 0 puts it.
    const Eigen::Vector3d oa = truth.m.point_at(truth.ia, zero),
                          oc = truth.m.point_at(truth.ic, zero);
    RealLine seen_a = truth.A, seen_c = truth.C;
    seen_a.point -= oa;
    seen_c.point = turn(truth.A, 0, truth.C.point) - oc;
    seen_c.direction = Eigen::AngleAxisd(truth.A.zero_rad, truth.A.direction) * truth.C.direction;
    const io::ResultFile ra = measured(da, real_readings(da, seen_a, 1.25, rng));
    const io::ResultFile rc = measured(dc, real_readings(dc, seen_c, 1.25, rng));
    const ChainResult chain =
        chain_machine(truth.m, {io::chain_input(truth.m, ra), io::chain_input(truth.m, rc)});
    const io::ChainFile f =
        io::chain_from_text(io::dump_json(io::chain_to_json(chain, truth.m, "m.json")), "M.json");
    const io::ChainPredictResult p = [&] {
      std::vector<ChainPose> asked;
      for (int i = 0; i < poses; ++i) {
        ChainPose pose;
        pose.angles_deg = {60 * u(rng) + 30, 180 * u(rng) + 180};
        pose.point_mm = Eigen::Vector3d(150 * u(rng), 150 * u(rng), -60 + 60 * (u(rng) + 1));
        asked.push_back(pose);
      }
      return io::predict_chain(f, io::chain_errors_of(f), asked, 0.95);
    }();
    for (const ChainPointPrediction& x : p.points) {
      ASSERT_TRUE(x.determined);
      const Eigen::Vector3d nominal =
          truth.m.body_point_at(truth.ic, x.pose.point_mm, x.pose.angles_deg);
      const Eigen::Vector3d error =
          1e3 * (truth.at(x.pose.angles_deg[0], x.pose.angles_deg[1], x.pose.point_mm) - nominal);
      inside += (x.error_um - error).norm() <= x.U_um;
      ++total;
    }
  }
  expect_nominal_rate(inside, total, machines);
}

// ------------------------------------------------- a machine with a table and a head axis

// The paper's B/C machine (a C table, a B head): each axis' real line in the machine frame (the
// pivot's where the linear axes at zero put it), the tool tip turned about B's, the workpiece's
// point about C's; the linear axes exact, so under TCPM the tool tip is off the workpiece's point
// by the tool tip's displacement less the point's.
struct TrueTableHead {
  Machine m;
  int ib = 0, ic = 0;
  RealLine B, C, nominal_B, nominal_C;
  Eigen::Vector3d tool_um(double b, const Eigen::Vector3d& tip) const {
    return 1e3 * (turn(B, b, tip) - turn(nominal_B, b, tip));
  }
  Eigen::Vector3d work_um(double c, const Eigen::Vector3d& x) const {
    return 1e3 * (turn(C, c, x) - turn(nominal_C, c, x));
  }
};

TrueTableHead true_table_head(const std::array<double, 5>& lb, const std::array<double, 5>& lc) {
  TrueTableHead t;
  t.m = io::read_machine_file(std::string(DBBKIT_SOURCE_DIR) + "/designs/machines/paper-b-c.json");
  t.ib = t.m.find('B');
  t.ic = t.m.find('C');
  const std::vector<double> zero(t.m.rotary.size(), 0.0);
  const std::array<double, 5> none{};
  for (auto [line, k, l] :
       {std::tuple{&t.B, t.ib, lb}, std::tuple{&t.C, t.ic, lc},
        std::tuple{&t.nominal_B, t.ib, none}, std::tuple{&t.nominal_C, t.ic, none}}) {
    *line = line_of(t.m.axis_frame(k, zero), l);
    line->point += t.m.point_at(k, zero);
  }
  return t;
}

ChainErrors table_head_errors(const TrueTableHead& t, const std::array<double, 5>& lb,
                              const std::array<double, 5>& lc) {
  ChainErrors c;
  c.axes = {chain_axis(t.m, t.ic, lc), chain_axis(t.m, t.ib, lb)};
  c.covariance = Eigen::MatrixXd::Identity(10, 10);
  return c;
}

// The tool tip in the B head against a point on the C table, at random poses: the prediction is
// the tool tip's exact displacement about B's real line less the point's about C's, to 1e-6 um; a
// hand derivation at B 90, C 90 with one offset per axis.
TEST(PredictChain, AToolTipAgainstAWorkpieceIsOffByWhatBothRealLinesSay) {
  const std::array<double, 5> lb = {15, -25, 20, -10, 30}, lc = {10, 35, -15, 30, -8};
  const TrueTableHead t = true_table_head(lb, lc);
  ChainErrors c = table_head_errors(t, lb, lc);
  const std::optional<ChainOrder> order = chain_order(c);
  ASSERT_TRUE(order);
  EXPECT_EQ(order->table, (std::vector<int>{0}));
  EXPECT_EQ(order->head, (std::vector<int>{1}));
  // A head carried by the table is no chain of either side.
  ChainErrors carried = c;
  carried.axes[1].on = 0;
  EXPECT_FALSE(chain_order(carried));
  const PredictionCoverage cov = prediction_coverage(0.95, std::nullopt);
  std::mt19937_64 rng(21);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int i = 0; i < 200; ++i) {
    ChainPose pose;
    pose.angles_deg = {180 * u(rng) + 180, 100 * u(rng)};  // C, B (the chain's order)
    pose.point_mm = Eigen::Vector3d(200 * u(rng), 200 * u(rng), 100 * (u(rng) + 1));
    pose.tool_mm = Eigen::Vector3d(0, 0, 250 - (100 + 100 * (u(rng) + 1)));
    const ChainPointPrediction p = predict_chain_point(c, *order, pose, cov);
    ASSERT_TRUE(p.determined);
    const Eigen::Vector3d tool = t.tool_um(pose.angles_deg[1], *pose.tool_mm),
                          work = t.work_um(pose.angles_deg[0], pose.point_mm);
    EXPECT_LT((p.error_um - (tool - work)).norm(), 1e-6) << i;
    ASSERT_TRUE(p.tool_um && p.workpiece_um);
    EXPECT_LT((*p.tool_um - tool).norm(), 1e-6) << i;
    EXPECT_LT((*p.workpiece_um - work).norm(), 1e-6) << i;
    EXPECT_LT((p.nominal_mm - turn(t.nominal_C, pose.angles_deg[0], pose.point_mm)).norm(), 1e-9);
    EXPECT_GT(p.U_um, 0);
  }
  // X0B = 20 um alone: at B 90 the tool tip, wherever it sits on the tool axis, turns about a
  // line 20 um off in +X: off by (20, 0, 20) um (its offset d less R d, R the turn about +Y).
  // X0C = 10 um alone: at C 90 a table point is off by (10, -10, 0) um. Together the tool tip is
  // off the point by (10, 10, 20) um.
  ASSERT_LT((iso_frame(t.m.axis_frame(t.ib, {0, 0})).p1 - Eigen::Vector3d::UnitX()).norm(), 1e-12);
  ASSERT_LT((iso_frame(t.m.axis_frame(t.ic, {0, 0})).p1 - Eigen::Vector3d::UnitX()).norm(), 1e-12);
  const ChainErrors x0 = table_head_errors(t, {20, 0, 0, 0, 0}, {10, 0, 0, 0, 0});
  ChainPose hand;
  hand.angles_deg = {90, 90};
  hand.point_mm = Eigen::Vector3d(50, 0, 40);
  for (const double tip : {100.0, 40.0}) {
    hand.tool_mm = Eigen::Vector3d(0, 0, tip);
    const ChainPointPrediction h = predict_chain_point(x0, *order, hand, cov);
    EXPECT_LT((h.error_um - Eigen::Vector3d(10, 10, 20)).norm(), 1e-6) << h.error_um.transpose();
  }
  // A tool tip is what a pose of both sides needs, and only it.
  hand.tool_mm.reset();
  EXPECT_THROW(predict_chain_point(x0, *order, hand, cov), std::invalid_argument);
  // B's zero not determined: every pose away from the pivot's line is not determined.
  c.axes[1].location[4].reset();
  hand.tool_mm = Eigen::Vector3d(0, 0, 100);
  EXPECT_FALSE(predict_chain_point(c, *order, hand, cov).determined);
}

// Both axes of random B/C machines measured with the exact two-ball geometry (the paper's
// designs on its machine, each on its own preset: C's on its line at the table surface, B's at
// the pivot), identified, combined by chain (its JSON read back) and predicted at random poses of
// a tool tip against a table point: the true error lies within U at the coverage probability.
// Pooled over 100 machines of 10 poses each, the binomial error taken as that of 200 independent.
TEST(PredictChain, AToolTipsIntervalsCoverTheTrueErrorAtTheirNominalRate) {
  // The paper's B design leaves B's tilt about X undetermined (its balls on the tool axis): two
  // installations 80 mm off it along Y (the general form's H: the axis direction) are added.
  const std::string dir = std::string(DBBKIT_SOURCE_DIR) + "/designs/";
  nlohmann::json jb = io::parse_json(io::read_json_file(dir + "paper-b-c-B.json"), "B");
  for (const char* id : {"3r", "3t"})
    jb["installations"].push_back({{"id", id},
                                   {"ball_mm", {{"L", 100}, {"H", 80}}},
                                   {"direction", id[1] == 'r' ? "radial" : "tangential"},
                                   {"sign", id[1] == 'r' ? -1 : 1},
                                   {"bar_mm", 150}});
  const Design db = io::design_from_json(jb, "b.json", dir), dc = design("paper-b-c-C.json");
  std::mt19937_64 rng(31);
  std::uniform_real_distribution<double> u(-1, 1);
  const int machines = 100, poses = 10;
  int inside = 0, total = 0;
  for (int k = 0; k < machines; ++k) {
    auto draw = [&] {
      return std::array<double, 5>{20 * u(rng), 20 * u(rng), 30 * u(rng), 30 * u(rng), 30 * u(rng)};
    };
    const std::array<double, 5> lb = draw(), lc = draw();
    const TrueTableHead truth = true_table_head(lb, lc);
    const std::vector<double> zero(truth.m.rotary.size(), 0.0);
    RealLine seen_b = truth.B, seen_c = truth.C;
    seen_b.point -= truth.m.point_at(truth.ib, zero);
    seen_c.point -= truth.m.point_at(truth.ic, zero);
    const io::ResultFile rb = measured(db, real_readings(db, seen_b, 1.25, rng));
    const io::ResultFile rc = measured(dc, real_readings(dc, seen_c, 1.25, rng));
    const ChainResult chain =
        chain_machine(truth.m, {io::chain_input(truth.m, rc), io::chain_input(truth.m, rb)});
    const io::ChainFile f = io::chain_from_text(
        io::dump_json(io::chain_to_json(chain, truth.m, "paper-b-c.json")), "M.json");
    const ChainErrors errors = io::chain_errors_of(f);
    std::vector<ChainPose> asked;
    for (int i = 0; i < poses; ++i) {
      ChainPose pose;
      for (const ChainErrors::Axis& a : errors.axes)
        pose.angles_deg.push_back(a.letter == 'C' ? 180 * u(rng) + 180 : 50 * u(rng) - 50);
      pose.point_mm = Eigen::Vector3d(150 * u(rng), 150 * u(rng), 60 * (u(rng) + 1));
      pose.tool_mm = Eigen::Vector3d(0, 0, 250 - (150 + 50 * u(rng)));
      asked.push_back(pose);
    }
    const io::ChainPredictResult p = io::predict_chain(f, errors, asked, 0.95);
    ASSERT_TRUE(p.order.both());
    for (const ChainErrors::Axis& a : errors.axes)
      for (std::size_t q = 0; q < 5; ++q) ASSERT_TRUE(a.location[q]) << a.letter << " " << q;
    for (const ChainPointPrediction& x : p.points) {
      ASSERT_TRUE(x.determined);
      double b = 0, c = 0;
      for (std::size_t a = 0; a < errors.axes.size(); ++a)
        (errors.axes[a].letter == 'B' ? b : c) = x.pose.angles_deg[a];
      const Eigen::Vector3d error =
          truth.tool_um(b, *x.pose.tool_mm) - truth.work_um(c, x.pose.point_mm);
      inside += (x.error_um - error).norm() <= x.U_um;
      ++total;
    }
  }
  expect_nominal_rate(inside, total, machines);
}

// The command line with a machine result: the poses' columns by the chain's letters, the JSON
// predict --out writes; what it cannot take is refused naming the option, line or key (exit 2).
TEST(PredictChainCli, PredictsAMachineResultAndRefusesWhatItCannotUse) {
  namespace fs = std::filesystem;
  const fs::path dir =
      fs::temp_directory_path() / ("dbbkit_predict_chain_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string src = DBBKIT_SOURCE_DIR, d = dir.string();
  auto cli = [&](const std::string& args) {
    return run_cli_shell("cd " + d + " && " + DBBKIT_CLI + " " + args);
  };
  for (const char* a : {"A", "C"}) {
    const std::string design = src + "/designs/a-c-trunnion-" + a + ".json";
    ASSERT_EQ(cli("simulate --design " + design + " --truth " + src +
                  "/tests/data/truth_a_c_trunnion_" + a + ".json --out " + a + ".csv")
                  .status,
              0);
    ASSERT_EQ(
        cli("identify --design " + design + " --data " + a + ".csv --out " + a + ".json --quiet")
            .status,
        0);
  }
  ASSERT_EQ(cli("chain --machine " + src +
                "/designs/machines/a-c-trunnion.json A.json C.json --out M.json --quiet")
                .status,
            0);
  const std::string poses = src + "/tests/data/poses_a_c_trunnion.csv";
  const CliRun ok = cli("predict --result M.json --at " + poses + " --out p.json");
  ASSERT_EQ(ok.status, 0) << ok.err;
  EXPECT_NE(ok.out.find("a workpiece's point on the C table"), std::string::npos) << ok.out;
  const nlohmann::json j = nlohmann::json::parse(slurp(d + "/p.json"));
  EXPECT_EQ(j["format"], "dbbkit.predict/1");
  EXPECT_EQ(j["basis"], "location");
  ASSERT_EQ(j["points"].size(), 5u);
  EXPECT_EQ(j["points"][1]["angles_deg"]["A"], 90.0);
  EXPECT_NEAR(j["points"][1]["error_um"][1].get<double>(), 20, 3);  // Y0A: 20 um at A 90
  EXPECT_NEAR(j["points"][1]["error_um"][2].get<double>(), -20, 3);
  EXPECT_TRUE(j["inputs"].contains("result_sha256"));
  auto refused = [&](const std::string& args, const std::string& says) {
    const CliRun r = cli(args);
    EXPECT_EQ(r.status, 2) << args << "\n" << r.out << r.err;
    EXPECT_NE(r.err.find(says), std::string::npos) << args << "\n" << r.err;
  };
  refused("predict --result M.json --grid-radius-mm 0,100", "--grid-radius-mm");
  refused("predict --result M.json --at " + poses + " --report r.html", "--report");
  refused("predict --result M.json --at " + poses + " --location-only", "--location-only");
  EXPECT_FALSE(fs::exists(d + "/r.html"));
  {
    std::ofstream(d + "/single.csv") << "angle_deg,x_mm,y_mm,z_mm\n0,100,0,-60\n";
    std::ofstream(d + "/far.csv") << "A_deg,C_deg,x_mm,y_mm,z_mm\n0,0,100,0,20000\n";
    std::ofstream(d + "/missing.csv") << "A_deg,x_mm,y_mm,z_mm\n0,100,0,-60\n";
  }
  refused("predict --result M.json --at single.csv",
          "single.csv: line 1: unknown column 'angle_deg'");
  refused("predict --result M.json --at far.csv", "far.csv: line 2, column z_mm");
  refused("predict --result M.json --at missing.csv", "'C_deg' is missing");
  // Axes that are not one chain on each side: A made a head, the C table still on it.
  nlohmann::json mixed = nlohmann::json::parse(slurp(d + "/M.json"));
  for (nlohmann::json& a : mixed["axes"])
    if (a["letter"] == "A") a["side"] = "head";
  std::ofstream(d + "/mixed.json") << mixed.dump();
  const CliRun m = cli("predict --result mixed.json --at " + poses);
  if (m.status == 2 && m.err.find("mixed.json: axes") != std::string::npos) {
    EXPECT_NE(m.err.find("on the other side"), std::string::npos) << m.err;
  } else {
    ADD_FAILURE() << "a table and a head axis: expected the axes refused, got " << m.status << "\n"
                  << m.err;
  }
  // The paper's own B design (balls on the tool axis) leaves the head's tilts and zero
  // undetermined: no tool tip off the B line is determined, and nothing is said to be largest.
  for (const auto& [design, truth] :
       {std::pair{"paper-b-c-B", "B"}, std::pair{"paper-b-c-C", "C"}}) {
    ASSERT_EQ(
        cli(std::string("simulate --design ") + src + "/designs/" + design + ".json --truth " +
            src + "/tests/data/truth_paper_b_c_" + truth + ".json --out p" + truth + ".csv")
            .status,
        0);
    ASSERT_EQ(cli(std::string("identify --design ") + src + "/designs/" + design +
                  ".json --data p" + truth + ".csv --out p" + truth + ".json --quiet")
                  .status,
              0);
  }
  ASSERT_EQ(cli("chain --machine " + src +
                "/designs/machines/paper-b-c.json pB.json pC.json --out PM.json --quiet")
                .status,
            0);
  const CliRun none =
      cli("predict --result PM.json --at " + src + "/tests/data/poses_paper_b_c.csv --out pp.json");
  ASSERT_EQ(none.status, 0) << none.err;
  EXPECT_NE(none.out.find("No point is determined"), std::string::npos) << none.out;
  const nlohmann::json pp = nlohmann::json::parse(slurp(d + "/pp.json"));
  EXPECT_TRUE(pp["largest"].is_null());
  for (const nlohmann::json& x : pp["points"]) EXPECT_FALSE(x["determined"].get<bool>());
  fs::remove_all(dir);
}

}  // namespace predict_test
}  // namespace dbbkit
