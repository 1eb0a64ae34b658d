// `dbbkit chain` against a machine built here: the A/C trunnion of designs/machines with its
// axes moved off the controller's lines (the A axis 20 um off in Y and 50 urad off its zero, the
// C axis 15 um off the A axis and 30 urad out of square), each test's readings computed from the
// exact two-ball geometry of those real lines (rotations written out with Eigen::AngleAxisd,
// the spindle ball where the program puts it), identified by the command line, and combined.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

#include "cli_util.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/json_reader.hpp"
#include "dbbkit/program.hpp"
#include "test_util.hpp"

namespace dbbkit {
namespace {

using nlohmann::json;
using test::kPi;

struct RealLine {
  Eigen::Vector3d point, direction;
  double zero_rad = 0;  // the zero-position error: the axis stands at commanded + zero
};

Eigen::Vector3d turn(const RealLine& l, double deg, const Eigen::Vector3d& x) {
  return l.point + Eigen::AngleAxisd(deg * kPi / 180 + l.zero_rad, l.direction) * (x - l.point);
}

// The readings of a design measured on the real machine: the table ball turned about the real
// line of the axis under test (the C line first set where A's real pose at 0 puts it), the
// spindle ball where the nominal program commands it; noise uniform within +-a um.
std::string readings_csv(const Design& d, const RealLine& line, double noise_um,
                         std::mt19937_64& rng) {
  std::uniform_real_distribution<double> U(-noise_um, noise_um);
  std::ostringstream csv;
  csv << "installation,angle_deg,reading_um\n";
  const Eigen::Vector3d origin = d.machine->origin_mm();
  for (const Installation& in : d.installations) {
    const Eigen::Vector3d body = d.axis.body_point(in.L_mm, in.D_mm, in.H_mm);
    for (double a : d.angles_deg) {
      const Eigen::Vector3d P = turn(line, a, origin + body);
      const Eigen::Vector3d F = origin + commanded_point_mm(d.axis, in, *in.bar_mm, a);
      const double reading = 1e3 * ((P - F).norm() - *in.bar_mm);
      csv << in.id << "," << a << "," << std::setprecision(12) << reading + U(rng) << "\n";
    }
  }
  return csv.str();
}

struct Planted {
  double Y0A_um = 20, A0A_urad = 50, distance_um = 15, squareness_urad = 30;
};

// Runs the two tests and chain; returns the chain's JSON.
json measure_and_chain(const Planted& p, double noise_um, std::uint64_t seed,
                       const std::filesystem::path& dir) {
  std::mt19937_64 rng(seed);
  const std::string a_file = test::source_path("designs/a-c-trunnion-A.json");
  const std::string c_file = test::source_path("designs/a-c-trunnion-C.json");
  const Design A = io::read_design_file(a_file), C = io::read_design_file(c_file);
  // The real A line: 20 um off in +Y, its zero 50 urad off.
  RealLine a{Eigen::Vector3d(0, 1e-3 * p.Y0A_um, 0), Eigen::Vector3d::UnitX(), 1e-6 * p.A0A_urad};
  // The real C line in A's body: off the A line by the distance along +Y (the nominal lines
  // cross at the origin), tilted about +Y (B0C) so that its angle to A is 90 deg minus it.
  const double t = 1e-6 * p.squareness_urad;
  RealLine c_body{Eigen::Vector3d(0, 1e-3 * (p.Y0A_um + p.distance_um), -60),
                  Eigen::Vector3d(std::sin(t), 0, std::cos(t)), 0};
  // Measured with A at 0, where A's real pose (its zero error about its real line) puts it.
  RealLine c = c_body;
  c.point = turn(a, 0, c_body.point);
  c.direction = Eigen::AngleAxisd(a.zero_rad, a.direction) * c_body.direction;
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "A.csv") << readings_csv(A, a, noise_um, rng);
  std::ofstream(dir / "C.csv") << readings_csv(C, c, noise_um, rng);
  for (const char* axis : {"A", "C"}) {
    const CliRun r =
        run_cli("identify --design " + (axis[0] == 'A' ? a_file : c_file) + " --data " +
                (dir / (std::string(axis) + ".csv")).string() + " --out " +
                (dir / (std::string(axis) + ".json")).string() + " --quiet");
    EXPECT_EQ(r.status, 0) << r.err;
  }
  const CliRun r =
      run_cli("chain --machine " + test::source_path("designs/machines/a-c-trunnion.json") + " " +
              (dir / "A.json").string() + " " + (dir / "C.json").string() + " --out " +
              (dir / "M.json").string());
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("squareness C to A"), std::string::npos) << r.out;
  // The results warn (no set-up tolerance declared): the chain says so first, and carries it.
  EXPECT_EQ(r.out.rfind("WARNING: the result of axis A", 0), 0u) << r.out;
  return json::parse(slurp((dir / "M.json").string()));
}

const json& find(const json& list, const std::string& key, const std::string& value) {
  for (const json& e : list)
    if (e[key] == value) return e;
  ADD_FAILURE() << value << " not found";
  static const json none;
  return none;
}

double location(const json& m, const char* axis, const char* name, const char* what) {
  for (const json& a : m["axes"])
    if (a["letter"] == axis) return find(a["location"], "name", name)[what].get<double>();
  ADD_FAILURE() << axis;
  return NAN;
}

TEST(Chain, APlantedChainComesBackOnTheControllersReference) {
  const auto dir = std::filesystem::temp_directory_path() / "dbbkit_chain_test";
  std::filesystem::remove_all(dir);
  const Planted p;
  // Without noise the first-order model's own error is all that is left.
  const json exact = measure_and_chain(p, 0, 1, dir / "exact");
  EXPECT_NEAR(location(exact, "A", "Y0A", "value"), 20, 0.02);
  EXPECT_NEAR(location(exact, "A", "A0A", "value"), 50, 0.2);
  // C in A's body: A's zero error turned back; its own position and tilt remain.
  EXPECT_NEAR(location(exact, "C", "Y0C", "value"), 35, 0.02);
  EXPECT_NEAR(location(exact, "C", "A0C", "value"), 0, 0.2);
  EXPECT_NEAR(location(exact, "C", "B0C", "value"), 30, 0.2);
  const json& dist = find(exact["chain"], "name", "distance");
  const json& sq = find(exact["chain"], "name", "squareness");
  // The common normal of X and Z, along +Y: C lies 15 um along +Y of A.
  EXPECT_EQ(dist["along"], json::array({0.0, 1.0, 0.0}));
  EXPECT_NEAR(dist["value"].get<double>(), 15, 0.02);
  EXPECT_NEAR(sq["value"].get<double>(), -30, 0.2);
  EXPECT_EQ(sq["between"], json::array({"A", "C"}));
  // The uncertainty: both results' (C's includes A's zero error through the turn back).
  EXPECT_GT(dist["std"].get<double>(), location(exact, "C", "Y0C", "std") * 0.99);
  EXPECT_GT(location(exact, "C", "A0C", "std"),
            std::hypot(0.0, location(exact, "A", "A0A", "std")) * 0.99);
  EXPECT_NEAR(dist["U"].get<double>(), exact["k"].get<double>() * dist["std"].get<double>(), 1e-9);
  ASSERT_FALSE(exact["warnings"].empty());
  EXPECT_NE(exact["warnings"][0]["text"].get<std::string>().find("may be too small"),
            std::string::npos);

  // With the instrument's noise: every planted term within its U.
  const json noisy = measure_and_chain(p, 1.25, 20261127, dir / "noisy");
  const double dU = find(noisy["chain"], "name", "distance")["U"].get<double>();
  EXPECT_NEAR(find(noisy["chain"], "name", "distance")["value"].get<double>(), 15, dU);
  const double sU = find(noisy["chain"], "name", "squareness")["U"].get<double>();
  EXPECT_NEAR(find(noisy["chain"], "name", "squareness")["value"].get<double>(), -30, sU);
  EXPECT_NEAR(location(noisy, "A", "Y0A", "value"), 20, location(noisy, "A", "Y0A", "U"));
  std::filesystem::remove_all(dir);
}

TEST(Chain, ResultsThatDoNotBelongTogetherAreRefusedByName) {
  const auto dir = std::filesystem::temp_directory_path() / "dbbkit_chain_refusals";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string machine = test::source_path("designs/machines/a-c-trunnion.json");
  const std::string a = test::source_path("designs/a-c-trunnion-A.json");
  // A result of a design without a machine.
  CliRun r = run_cli("identify --design " + test::kDesignC + " --data " + test::kDataC + " --out " +
                     (dir / "paper.json").string() + " --quiet");
  ASSERT_EQ(r.status, 0) << r.err;
  r = run_cli("evaluate --design " + a + " --out " + (dir / "e.json").string() + " --quiet");
  ASSERT_EQ(r.status, 0) << r.err;
  // Simulated readings of the A design (nothing planted) and its result, twice.
  const Design A = io::read_design_file(a);
  {
    std::ofstream csv(dir / "A.csv");
    csv << "installation,angle_deg,reading_um\n";
    for (const Installation& in : A.installations)
      for (double g : A.angles_deg) csv << in.id << "," << g << ",0.1\n";
  }
  r = run_cli("identify --design " + a + " --data " + (dir / "A.csv").string() + " --out " +
              (dir / "A.json").string() + " --quiet");
  ASSERT_EQ(r.status, 0) << r.err;
  r = run_cli("chain --machine " + machine + " " + (dir / "A.json").string() + " " +
              (dir / "paper.json").string());
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("paper.json: design.machine"), std::string::npos) << r.err;
  r = run_cli("chain --machine " + machine + " " + (dir / "A.json").string() + " " +
              (dir / "A.json").string());
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("a second result of axis A"), std::string::npos) << r.err;
  r = run_cli("chain --machine " + machine + " " + (dir / "A.json").string());
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("at least two"), std::string::npos) << r.err;
  // Another machine file of the same name whose A axis point moved: the preset differs.
  json mj = json::parse(slurp(machine));
  mj["rotary"][0]["point_mm"] = {0, 0, 5};
  std::ofstream(dir / "moved.json") << mj.dump(2);
  r = run_cli("chain --machine " + (dir / "moved.json").string() + " " + (dir / "A.json").string() +
              " " + (dir / "A.json").string());
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("origin_mm"), std::string::npos) << r.err;
  // A result without the covariance (an earlier version's).
  json aj = json::parse(slurp((dir / "A.json").string()));
  aj["iso230"].erase("location_covariance");
  std::ofstream(dir / "old.json") << aj.dump(2);
  r = run_cli("chain --machine " + machine + " " + (dir / "old.json").string() + " " +
              (dir / "A.json").string());
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("location_covariance"), std::string::npos) << r.err;
  std::filesystem::remove_all(dir);
}

// The covariance a result writes is the one its std come from, in identify and diagnose.
TEST(Chain, ALocationCovarianceIsTheOneItsStdComeFrom) {
  const auto dir = std::filesystem::temp_directory_path() / "dbbkit_chain_cov";
  std::filesystem::create_directories(dir);
  for (const char* command : {"identify", "diagnose"}) {
    const std::string out = (dir / (std::string(command) + ".json")).string();
    const CliRun r = run_cli(std::string(command) + " --design " + test::kDesignC + " --data " +
                             test::kDataC + " --out " + out + " --quiet");
    ASSERT_EQ(r.status, 0) << r.err;
    const json j = json::parse(slurp(out));
    const json& loc = j["iso230"]["location"];
    const json& m = j["iso230"]["location_covariance"]["matrix"];
    for (int i = 0; i < 5; ++i) {
      EXPECT_NEAR(std::sqrt(m[i][i].get<double>()), loc[i]["std"].get<double>(), 1e-6) << command;
      for (int k = 0; k < 5; ++k) {
        EXPECT_DOUBLE_EQ(m[i][k].get<double>(), m[k][i].get<double>());
        // A correlation, never beyond 1.
        EXPECT_LE(std::abs(m[i][k].get<double>()),
                  std::sqrt(m[i][i].get<double>() * m[k][k].get<double>()) * (1 + 1e-9));
      }
    }
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace dbbkit
