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
#include <functional>
#include <map>
#include <random>
#include <regex>
#include <sstream>

#include "cli_util.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/hashing.hpp"
#include "dbbkit/io/json_reader.hpp"
#include "dbbkit/io/machine_io.hpp"
#include "dbbkit/program.hpp"
#include "test_util.hpp"

namespace dbbkit {
namespace {

using nlohmann::json;
using test::kPi;

using test::RealLine;
using test::turn;

// The readings of a design measured on the real machine: the table ball turned about the real
// line of the axis under test (the C line first set where A's real pose at 0 puts it), the
// spindle ball where the nominal program commands it; noise uniform within +-a um. With
// `controller`, the program runs under TCPM on a controller whose line of the axis is that one:
// the spindle ball's workpiece position (the nominal line's) is turned about it.
std::string readings_csv(const Design& d, const RealLine& line, double noise_um,
                         std::mt19937_64& rng, const RealLine* controller = nullptr) {
  std::uniform_real_distribution<double> U(-noise_um, noise_um);
  std::ostringstream csv;
  csv << "installation,angle_deg,reading_um\n";
  const Eigen::Vector3d origin = d.machine->origin_mm();
  for (std::size_t i = 0; i < d.installations.size(); ++i) {
    const Installation& in = d.installations[i];
    const Eigen::Vector3d body = d.axis.body_point(in.L_mm, in.D_mm, in.H_mm);
    for (double a : d.angles_of(static_cast<int>(i))) {
      const Eigen::Vector3d P = turn(line, a, origin + body);
      Eigen::Vector3d F = origin + commanded_point_mm(d.axis, in, *in.bar_mm, a);
      if (controller) {
        const RealLine nominal{origin, d.axis.direction(), 0};
        F = turn(*controller, a, turn(nominal, -a, F));
      }
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
                       const std::filesystem::path& dir,
                       const std::string& a_design = "a-c-trunnion-A") {
  std::mt19937_64 rng(seed);
  const std::string a_file = test::source_path("designs/" + a_design + ".json");
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
  // Where it came from: the machine file's and each result's SHA-256.
  EXPECT_EQ(exact["machine"]["sha256"],
            io::sha256_file(test::source_path("designs/machines/a-c-trunnion.json")));
  for (const json& a : exact["axes"])
    EXPECT_EQ(
        a["result_sha256"],
        io::sha256_file((dir / "exact" / (a["letter"].get<std::string>() + ".json")).string()));
  // C's errors as its result gave them, beside those in A's body (A's zero error turned back:
  // A0C moves by it, 50 urad).
  for (const json& a : exact["axes"]) {
    if (a["letter"] != "C") continue;
    EXPECT_NEAR(find(a["location"], "name", "A0C")["as_measured"].get<double>(), 50, 0.2);
  }
  // A machine file whose travel changed since is the same machine for chain (the lines did not
  // move); the text shows C's errors as measured.
  json travel = json::parse(slurp(test::source_path("designs/machines/a-c-trunnion.json")));
  travel["rotary"][0]["travel_deg"] = {-120, 120};
  std::ofstream(dir / "travel.json") << travel.dump(2);
  const CliRun again =
      run_cli("chain --machine " + (dir / "travel.json").string() + " " +
              (dir / "exact" / "A.json").string() + " " + (dir / "exact" / "C.json").string());
  EXPECT_EQ(again.status, 0) << again.err;
  EXPECT_NE(again.out.find("in the body of A (measured with A at 0; its zero error turned back)"),
            std::string::npos)
      << again.out;
  EXPECT_NE(again.out.find(", as measured 50"), std::string::npos) << again.out;
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

// The A design over the whole travel the machine allows (-100..100 deg, the tangential bars
// changing side at A0) against the one over -30..90 (the bars on one side): the same planted
// chain comes back, noise-free to the first-order model's own error, and every location error of
// A is stated more certain; with noise, each planted term within its U.
TEST(Chain, TheWholeTravelOfATrunnionGivesThePlantedChainMoreCertainly) {
  const auto dir = std::filesystem::temp_directory_path() / "dbbkit_chain_whole";
  std::filesystem::remove_all(dir);
  const Planted p;
  const json exact = measure_and_chain(p, 0, 1, dir / "exact", "a-c-trunnion-A-whole");
  EXPECT_NEAR(location(exact, "A", "Y0A", "value"), 20, 0.02);
  EXPECT_NEAR(location(exact, "A", "Z0A", "value"), 0, 0.02);
  EXPECT_NEAR(location(exact, "A", "A0A", "value"), 50, 0.2);
  EXPECT_NEAR(location(exact, "A", "B0A", "value"), 0, 0.2);
  EXPECT_NEAR(location(exact, "A", "C0A", "value"), 0, 0.2);
  EXPECT_NEAR(find(exact["chain"], "name", "distance")["value"].get<double>(), 15, 0.02);
  EXPECT_NEAR(find(exact["chain"], "name", "squareness")["value"].get<double>(), -30, 0.2);
  const json part = measure_and_chain(p, 0, 1, dir / "part");
  for (const char* name : {"Y0A", "Z0A", "B0A", "C0A", "A0A"})
    EXPECT_LT(location(exact, "A", name, "std"), 0.85 * location(part, "A", name, "std")) << name;
  const json noisy = measure_and_chain(p, 1.25, 20261129, dir / "noisy", "a-c-trunnion-A-whole");
  const json& d = find(noisy["chain"], "name", "distance");
  EXPECT_NEAR(d["value"].get<double>(), 15, d["U"].get<double>());
  const json& s = find(noisy["chain"], "name", "squareness");
  EXPECT_NEAR(s["value"].get<double>(), -30, s["U"].get<double>());
  EXPECT_NEAR(location(noisy, "A", "Y0A", "value"), 20, location(noisy, "A", "Y0A", "U"));
  EXPECT_NEAR(location(noisy, "A", "A0A", "value"), 50, location(noisy, "A", "A0A", "U"));
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
  // A result whose location errors' names are out of ISO 230-1's order.
  {
    json swapped = json::parse(slurp((dir / "A.json").string()));
    std::swap(swapped["iso230"]["location"][0]["name"], swapped["iso230"]["location"][1]["name"]);
    std::ofstream(dir / "swapped.json") << swapped.dump(2);
    r = run_cli("chain --machine " + machine + " " + (dir / "swapped.json").string() + " " +
                (dir / "A.json").string());
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("iso230.location[0].name"), std::string::npos) << r.err;
  }
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

// ---- The corrected chain through a controller built here ----

// A controller's lines of the trunnion's two axes (A, then C in A's body).
struct Controller {
  RealLine a, c;
};

Controller nominal_controller() {
  return {{Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX(), 0},
          {Eigen::Vector3d(0, 0, -60), Eigen::Vector3d::UnitZ(), 0}};
}

// The record's vectors by name (l1 ... l4, v1, v2), as written for record 1 (`was`: the values
// each line says the record held).
std::map<std::string, Eigen::Vector3d> siemens_vectors(const std::string& mpf, bool was = false) {
  std::map<int, double> v;
  const std::regex assignment(R"(^\$TC_CARR(\d+)\[1\]=([-0-9.]+) ; \S+ [xyz], was ([-0-9.]+))");
  std::istringstream in(mpf);
  for (std::string line; std::getline(in, line);) {
    std::smatch m;
    if (std::regex_search(line, m, assignment)) v[std::stoi(m[1])] = std::stod(m[was ? 3 : 2]);
  }
  std::map<std::string, Eigen::Vector3d> out;
  for (const auto& [name, first] : {std::pair{"l1", 1}, std::pair{"l2", 4}, std::pair{"l3", 15},
                                    std::pair{"l4", 18}, std::pair{"v1", 7}, std::pair{"v2", 10}})
    if (v.count(first) && v.count(first + 1) && v.count(first + 2))
      out[name] = Eigen::Vector3d(v[first], v[first + 1], v[first + 2]);
  return out;
}

// Siemens: the swivel data record's assignments as the function manual chains them (type P):
// the table turns about v1 through the end of l2, then about v2 through the end of l2 + l3.
Controller siemens_controller(const std::string& mpf) {
  const std::map<std::string, Eigen::Vector3d> v = siemens_vectors(mpf);
  auto vec = [&](const char* name) {
    const auto it = v.find(name);
    EXPECT_NE(it, v.end()) << name;
    return it == v.end() ? Eigen::Vector3d(Eigen::Vector3d::Zero()) : it->second;
  };
  const Eigen::Vector3d l2 = vec("l2"), l3 = vec("l3"), l4 = vec("l4");
  EXPECT_LT((l2 + l3 + l4).norm(), 1e-9) << "the chain is closed";
  return {{l2, vec("v1").normalized(), 0}, {l2 + l3, vec("v2").normalized(), 0}};
}

// LinuxCNC xyzac-trt: C about (x-rot-point, y-rot-point) along Z, A about (y-rot-point +
// y-offset, z-rot-point + z-offset) along X; the pins start at the nominal machine's (all 0).
Controller linuxcnc_controller(const std::string& hal) {
  std::map<std::string, double> pin;
  const std::regex setp(R"(^setp xyzac-trt-kins\.([a-z-]+) ([-0-9.e]+)$)");
  std::istringstream in(hal);
  for (std::string line; std::getline(in, line);) {
    std::smatch m;
    if (std::regex_search(line, m, setp)) pin[m[1]] = std::stod(m[2]);
  }
  Controller c = nominal_controller();
  c.a.point = Eigen::Vector3d(0, pin["y-rot-point"] + pin["y-offset"],
                              pin["z-rot-point"] + pin["z-offset"]);
  c.c.point = Eigen::Vector3d(pin["x-rot-point"], pin["y-rot-point"], -60);
  return c;
}

// ISG: the kernel adds each location error to its line: an offset along the machine axis its
// name's first letter says, a tilt about the one its first letter says (X0C, B0C; mm and rad).
Controller isg_controller(const std::string& csv) {
  std::vector<std::string> rows;
  std::istringstream in(csv);
  for (std::string line; std::getline(in, line);)
    if (!line.empty() && line.rfind("//", 0) != 0 && line[0] != '#') rows.push_back(line);
  EXPECT_EQ(rows.size(), 2u) << csv;
  std::istringstream names(rows.at(0)), values(rows.at(1));
  Controller c = nominal_controller();
  std::string name;
  double value = 0;
  while (names >> name && values >> value) {
    RealLine& l = name.back() == 'A' ? c.a : c.c;
    const Eigen::Vector3d e = Eigen::Vector3d::Unit(std::string("XYZ").find(name[0]) % 3);
    if (name[0] == 'X' || name[0] == 'Y' || name[0] == 'Z')
      l.point += value * e;
    else if (name[0] != name.back())  // a zero error is the joint's, not the line's
      l.direction =
          (l.direction +
           value * Eigen::Vector3d::Unit(std::string("ABC").find(name[0])).cross(l.direction))
              .normalized();
  }
  return c;
}

// What remains of a real line against a controller's: the offsets across the controller's
// line at its point (um) and the tilt (urad), as ISO names them for A (Y, Z; B, C) and C (X, Y;
// A, B).
std::array<double, 4> remaining(const RealLine& real, const RealLine& ctrl) {
  const Eigen::Vector3d d = ctrl.direction;
  const double t = (ctrl.point - real.point).dot(d) / real.direction.dot(d);
  const Eigen::Vector3d offset = 1e3 * (real.point + t * real.direction - ctrl.point);
  const Eigen::Vector3d tilt = 1e6 * d.cross(real.direction);
  if (d.x() > 0.5) return {offset.y(), offset.z(), tilt.y(), tilt.z()};
  return {offset.x(), offset.y(), tilt.x(), tilt.y()};
}

TEST(ChainCompensation, SiemensLinuxCncAndIsgRoundTripsLeaveWhatRemainsWithinU) {
  const auto dir = std::filesystem::temp_directory_path() / "dbbkit_chain_compensation";
  std::filesystem::remove_all(dir);
  const Planted p;
  const json before = measure_and_chain(p, 1.25, 20261127, dir / "before");
  const std::string m_file = (dir / "before" / "M.json").string();
  // The real lines, as measure_and_chain plants them (C in A's body).
  const double t = 1e-6 * p.squareness_urad;
  const RealLine real_a{Eigen::Vector3d(0, 1e-3 * p.Y0A_um, 0), Eigen::Vector3d::UnitX(),
                        1e-6 * p.A0A_urad};
  const RealLine real_c{Eigen::Vector3d(0, 1e-3 * (p.Y0A_um + p.distance_um), -60),
                        Eigen::Vector3d(std::sin(t), 0, std::cos(t)), 0};
  const std::array<const char*, 4> a_names{"Y0A", "Z0A", "B0A", "C0A"};
  const std::array<const char*, 4> c_names{"X0C", "Y0C", "A0C", "B0C"};
  // Before: what the nominal controller leaves is the planted chain.
  EXPECT_NEAR(remaining(real_c, nominal_controller().c)[3], 30, 1e-6);

  struct Case {
    std::string format, options;
    Controller (*controller)(const std::string&);
    bool tilts;  // whether the target takes the axes' tilts
  };
  const std::vector<Case> cases = {
      {"siemens", "--record 1", siemens_controller, true},
      {"linuxcnc", "--current x-rot-point=0 y-rot-point=0 z-rot-point=0 y-offset=0 z-offset=0",
       linuxcnc_controller, false},
      {"isg", "", isg_controller, true}};
  for (const Case& k : cases) {
    SCOPED_TRACE(k.format);
    const CliRun r = run_cli("compensation --result " + m_file + " --format " + k.format + " " +
                             k.options + " --k 2");
    ASSERT_EQ(r.status, 0) << r.err;
    const Controller ctrl = k.controller(r.out);
    // Every line's remainder against what was written: within the measurement's U (k = 2),
    // where the target takes the quantity; the tilts it does not take remain as planted.
    const std::array<double, 4> ra = remaining(real_a, ctrl.a), rc = remaining(real_c, ctrl.c);
    for (int e = 0; e < 4; ++e) {
      const bool taken = e < 2 || k.tilts;
      const double Ua = 2 * location(before, "A", a_names[e], "std");
      const double Uc = 2 * location(before, "C", c_names[e], "std");
      if (taken) {
        EXPECT_LE(std::abs(ra[e]), Ua) << a_names[e];
        EXPECT_LE(std::abs(rc[e]), Uc) << c_names[e];
      }
    }
    if (!k.tilts) EXPECT_NEAR(rc[3], 30, 1e-6) << "B0C is not the module's to correct";
    // The planted chain was not within U of the nominal controller: correcting did something.
    EXPECT_GT(std::abs(remaining(real_a, nominal_controller().a)[0]),
              2 * location(before, "A", "Y0A", "std"));

    if (k.format != "siemens") continue;
    // Measured again on the corrected controller (under TCPM: the program's workpiece
    // positions turned about the controller's lines), with the corrected machine file, without
    // noise: the second measurement must find what remains, to the first-order model's error.
    const std::filesystem::path again = dir / "again";
    std::filesystem::create_directories(again);
    json mj = json::parse(slurp(test::source_path("designs/machines/a-c-trunnion.json")));
    auto arr = [](const Eigen::Vector3d& v) { return json::array({v.x(), v.y(), v.z()}); };
    mj["rotary"][0]["point_mm"] = arr(ctrl.a.point);
    mj["rotary"][0]["direction"] = arr(ctrl.a.direction);
    mj["rotary"][1]["point_mm"] = arr(ctrl.c.point);
    mj["rotary"][1]["direction"] = arr(ctrl.c.direction);
    std::ofstream((again / "m.json").string()) << mj.dump(2);
    std::mt19937_64 rng(1);
    for (const char* axis : {"A", "C"}) {
      json dj = json::parse(
          slurp(test::source_path(std::string("designs/a-c-trunnion-") + axis + ".json")));
      dj["machine"] = (again / "m.json").string();
      const std::string design = (again / (std::string(axis) + "-design.json")).string();
      std::ofstream(design) << dj.dump(2);
      const Design d = io::read_design_file(design);
      // C is measured with A at 0, where A's real zero error turns it.
      RealLine line = axis[0] == 'A' ? real_a : real_c;
      RealLine ctrl_line = axis[0] == 'A' ? ctrl.a : ctrl.c;
      if (axis[0] == 'C') {
        line.point = turn(real_a, 0, real_c.point);
        line.direction = Eigen::AngleAxisd(real_a.zero_rad, real_a.direction) * real_c.direction;
      }
      std::ofstream(again / (std::string(axis) + ".csv"))
          << readings_csv(d, line, 0.0, rng, &ctrl_line);
      const CliRun id = run_cli("identify --design " + design + " --data " +
                                (again / (std::string(axis) + ".csv")).string() + " --out " +
                                (again / (std::string(axis) + ".json")).string() + " --quiet");
      ASSERT_EQ(id.status, 0) << id.err;
    }
    // TCPM off is refused on a machine file holding a corrected vector.
    EXPECT_EQ(run_cli("program --design " + (again / "C-design.json").string() +
                      " --dialect sinumerik --tcpm off --out " + (again / "p.mpf").string())
                  .status,
              2);
    const CliRun c = run_cli("chain --machine " + (again / "m.json").string() + " " +
                             (again / "A.json").string() + " " + (again / "C.json").string() +
                             " --out " + (again / "M.json").string() + " --quiet");
    ASSERT_EQ(c.status, 0) << c.err;
    const json after = json::parse(slurp((again / "M.json").string()));
    // The chain's lines are the controller's (its vector, not the machine axis), and what the
    // second measurement finds is what remains.
    for (const json& a : after["axes"]) {
      const RealLine& l = a["letter"] == "A" ? ctrl.a : ctrl.c;
      for (int k2 = 0; k2 < 3; ++k2)
        EXPECT_NEAR(a["direction"][k2].get<double>(), l.direction(k2), 1e-12);
    }
    for (int e = 0; e < 4; ++e) {
      EXPECT_NEAR(location(after, "A", a_names[e], "value"), ra[e], 0.01) << a_names[e];
      EXPECT_NEAR(location(after, "C", c_names[e], "value"), rc[e], 0.01) << c_names[e];
    }
  }
  std::filesystem::remove_all(dir);
}

// ---- Siemens' records of machines with a head axis (kinematic types M and T) ----

// How far a controller's line lies from a real one: the offset across it at its point (um) and
// the angle between them (urad).
std::pair<double, double> apart(const RealLine& real, const RealLine& ctrl) {
  const Eigen::Vector3d d = ctrl.direction.normalized();
  const Eigen::Vector3d w = real.point - ctrl.point;
  return {1e3 * (w - w.dot(d) * d).norm(), 1e6 * d.cross(real.direction.normalized()).norm()};
}

// The machine's axis k moved by the location errors l (ISO order), as test::line_of puts it.
RealLine planted_line(const Machine& m, int k, const std::array<double, 5>& l) {
  const std::vector<double> zero(m.rotary.size(), 0.0);
  RealLine r = test::line_of(m.axis_frame(k, zero), l);
  r.point += m.point_at(k, zero);
  return r;
}

// A controller's line of axis k on its planted one (to the first-order model's error on
// noise-free readings), the planted one well apart from the nominal: the record corrected it.
void expect_on_planted_line(const Machine& m, int k, const std::array<double, 5>& l,
                            const RealLine& ctrl) {
  const auto [offset_um, tilt_urad] = apart(planted_line(m, k, l), ctrl);
  EXPECT_LT(offset_um, 0.05) << k;
  EXPECT_LT(tilt_urad, 0.5) << k;
  EXPECT_GT(apart(planted_line(m, k, l), planted_line(m, k, {})).first, 5) << k;
}

// Each axis' test simulated without noise (exact geometry) from its own planted errors,
// identified and chained: the machine result's path.
std::string noise_free_chain(const std::filesystem::path& dir, const std::string& machine,
                             const std::vector<std::pair<std::string, json>>& tests) {
  std::filesystem::create_directories(dir);
  std::string results;
  for (const auto& [design, location] : tests) {
    const std::string stem = (dir / design).string();
    std::ofstream(stem + ".truth.json") << json{
        {"format", "dbbkit.truth/1"},
        {"location", location},
        {"geometry", "exact"},
        {"noise", {{"distribution", "none"}}}}.dump();
    const std::string d = test::source_path("designs/" + design + ".json");
    EXPECT_EQ(run_cli("simulate --design " + d + " --truth " + stem + ".truth.json --out " + stem +
                      ".csv")
                  .status,
              0);
    EXPECT_EQ(run_cli("identify --design " + d + " --data " + stem + ".csv --out " + stem +
                      ".json --quiet")
                  .status,
              0);
    results += " " + stem + ".json";
  }
  const std::string out = (dir / "M.json").string();
  EXPECT_EQ(run_cli("chain --machine " + test::source_path("designs/machines/" + machine) +
                    results + " --out " + out + " --quiet")
                .status,
            0);
  return out;
}

// The paper's B/C machine (a B head, a C table: type M) and the head/head fork (type T): the
// record's vectors chained as the commissioning manual chains them (M: the head turns about v1
// through the tool adapter's point + l2, l1 = -l2; the table about v2 through l3, l4 = -l3. T: the
// inner head about v2 through the tool adapter's point + l3, the outer about v1 through it + l3 +
// l2, l1 = -(l2 + l3)) put each axis on its planted line, to the first-order model's error on
// noise-free readings; without the tool adapter's point the record is refused.
TEST(ChainCompensation, SiemensRecordsOfHeadsPutEachLineWhereItIs) {
  const auto dir = std::filesystem::temp_directory_path() / "dbbkit_chain_siemens_heads";
  std::filesystem::remove_all(dir);
  // Off both C lines, so that a tool adapter's point written into a table's vector would show.
  const Eigen::Vector3d tool(3, -2, 100);
  {
    const std::array<double, 5> lb = {12, -8, 25, 0, -15}, lc = {0, 10, 0, 20, 0};
    const std::string m = noise_free_chain(
        dir / "bc", "paper-b-c.json",
        {{"paper-b-c-B-off-axis", {{"X0B", 12}, {"Z0B", -8}, {"A0B", 25}, {"B0B", -15}}},
         {"paper-b-c-C", {{"Y0C", 10}, {"B0C", 20}}}});
    const CliRun without = run_cli("compensation --result " + m + " --format siemens --record 1");
    EXPECT_EQ(without.status, 2);
    EXPECT_NE(without.err.find("--tool-reference-mm: required"), std::string::npos) << without.err;
    const CliRun r = run_cli("compensation --result " + m +
                             " --format siemens --record 1 --tool-reference-mm 3,-2,100");
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_NE(r.out.find("kinematic type M (swivel head and swivel table)"), std::string::npos)
        << r.out;
    const auto v = siemens_vectors(r.out);
    ASSERT_EQ(v.size(), 6u) << r.out;
    EXPECT_LT((v.at("l1") + v.at("l2")).norm(), 1e-9);
    EXPECT_LT((v.at("l3") + v.at("l4")).norm(), 1e-9);
    // What each line says the record held: the machine file's, from the tool adapter given.
    const auto was = siemens_vectors(r.out, true);
    ASSERT_EQ(was.size(), 6u) << r.out;
    EXPECT_LT((was.at("l2") - Eigen::Vector3d(-3, 2, 150)).norm(), 1e-9);
    EXPECT_LT((was.at("l1") - Eigen::Vector3d(3, -2, -150)).norm(), 1e-9);
    EXPECT_LT(was.at("l3").norm(), 1e-9);
    EXPECT_LT((was.at("v1") - Eigen::Vector3d::UnitY()).norm(), 1e-9);
    EXPECT_LT((was.at("v2") - Eigen::Vector3d::UnitZ()).norm(), 1e-9);
    const Machine machine =
        io::read_machine_file(test::source_path("designs/machines/paper-b-c.json"));
    const RealLine head{tool + v.at("l2"), v.at("v1"), 0}, table{v.at("l3"), v.at("v2"), 0};
    expect_on_planted_line(machine, machine.find('B'), lb, head);
    expect_on_planted_line(machine, machine.find('C'), lc, table);
  }
  {
    // The fork's A design determines Z0A alone of A's offsets.
    const std::array<double, 5> la = {0, -10, 0, 0, 0}, lc = {-12, 9, 0, 0, 0};
    const std::string m = noise_free_chain(
        dir / "fork", "a-c-fork-head.json",
        {{"a-c-fork-head-C", {{"X0C", -12}, {"Y0C", 9}}}, {"a-c-fork-head-A", {{"Z0A", -10}}}});
    const CliRun r = run_cli("compensation --result " + m +
                             " --format siemens --record 1 --tool-reference-mm 3,-2,100");
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_NE(r.out.find("kinematic type T (swivel head)"), std::string::npos) << r.out;
    const auto v = siemens_vectors(r.out);
    ASSERT_EQ(v.size(), 5u) << r.out;  // no l4
    EXPECT_LT((v.at("l1") + v.at("l2") + v.at("l3")).norm(), 1e-9);
    const auto was = siemens_vectors(r.out, true);
    ASSERT_EQ(was.size(), 5u) << r.out;
    EXPECT_LT((was.at("l3") - Eigen::Vector3d(-3, 2, 200)).norm(), 1e-9);
    EXPECT_LT(was.at("l2").norm(), 1e-9);
    EXPECT_LT((was.at("l1") - Eigen::Vector3d(3, -2, -200)).norm(), 1e-9);
    EXPECT_LT((was.at("v1") - Eigen::Vector3d::UnitZ()).norm(), 1e-9);  // C, the outer
    EXPECT_LT((was.at("v2") - Eigen::Vector3d::UnitX()).norm(), 1e-9);  // A, the inner
    const Machine machine =
        io::read_machine_file(test::source_path("designs/machines/a-c-fork-head.json"));
    const RealLine outer{tool + v.at("l3") + v.at("l2"), v.at("v1"), 0},
        inner{tool + v.at("l3"), v.at("v2"), 0};
    expect_on_planted_line(machine, machine.find('C'), lc, outer);
    expect_on_planted_line(machine, machine.find('A'), la, inner);
    // Only a record takes the tool adapter's point, even given empty.
    EXPECT_EQ(run_cli("compensation --result " + (dir / "bc" / "M.json").string() +
                      " --format table --tool-reference-mm ''")
                  .status,
              2);
    const CliRun trunnion = run_cli("compensation --result " + (dir / "bc" / "M.json").string() +
                                    " --format isg --tool-reference-mm 0,0,100");
    EXPECT_EQ(trunnion.status, 2);
    EXPECT_NE(trunnion.err.find("--tool-reference-mm"), std::string::npos) << trunnion.err;
  }
  std::filesystem::remove_all(dir);
}

// What a format cannot hold is refused by name; the machine's texts reach comments only.
TEST(ChainCompensation, WhatAFormatCannotHoldIsRefusedAndTextStaysInComments) {
  const auto dir = std::filesystem::temp_directory_path() / "dbbkit_chain_compensation_refusals";
  std::filesystem::remove_all(dir);
  measure_and_chain(Planted{}, 0.5, 3, dir);
  const std::string m = (dir / "M.json").string();
  CliRun r = run_cli("compensation --result " + m + " --format siemens");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("--record: required"), std::string::npos) << r.err;
  // A record's number with a leading zero is decimal: 010 is record 10, never octal 8.
  r = run_cli("compensation --result " + m + " --format siemens --record 010");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("Sinumerik swivel data record 10 (--record 10)"), std::string::npos)
      << r.out.substr(0, 800);
  EXPECT_TRUE(std::regex_search(r.out, std::regex(R"(\$TC_CARR\d+\[10\]=)"))) << r.out;
  EXPECT_FALSE(std::regex_search(r.out, std::regex(R"(\$TC_CARR\d+\[8\]=)"))) << r.out;
  r = run_cli("compensation --result " + m + " --format isg --record 2");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("--record"), std::string::npos) << r.err;
  r = run_cli("compensation --result " + m + " --format linuxcnc --kins xyzbc-trt");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("xyzac-trt"), std::string::npos) << r.err;
  // One axis' result has no chain to write.
  r = run_cli("compensation --result " + (dir / "A.json").string() +
              " --format siemens --record 1");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("machine result"), std::string::npos) << r.err;
  // A head in the chain: the record (then of kinematic type M) needs the tool adapter's point;
  // LinuxCNC's trt modules cannot hold it; the table can.
  json j = json::parse(slurp(m));
  json head = j;
  head["axes"][1]["side"] = "head";
  head["axes"][1]["on"] = nullptr;
  std::ofstream(dir / "head.json") << head.dump(2);
  r = run_cli("compensation --result " + (dir / "head.json").string() +
              " --format siemens --record 1");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("--tool-reference-mm: required"), std::string::npos) << r.err;
  r = run_cli("compensation --result " + (dir / "head.json").string() +
              " --format linuxcnc --current x-rot-point=0");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("two table axes"), std::string::npos) << r.err;
  EXPECT_EQ(
      run_cli("compensation --result " + (dir / "head.json").string() + " --format table").status,
      0);
  // An edited covariance no longer gives the std: refused, naming the key.
  json edited = j;
  edited["location_covariance"]["matrix"][0][0] = 1e4;
  std::ofstream(dir / "edited.json") << edited.dump(2);
  r = run_cli("compensation --result " + (dir / "edited.json").string() + " --format table");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("location_covariance.matrix"), std::string::npos) << r.err;
  // A hostile machine name: in comments only, every line of code one of the record's.
  json hostile = j;
  hostile["machine"]["name"] = "m\"; $TC_CARR1[1]=999 M30 (x) %";
  hostile["machine"]["controller"] = "fanuc";
  std::ofstream(dir / "hostile.json") << hostile.dump(2);
  r = run_cli("compensation --result " + (dir / "hostile.json").string() +
              " --format siemens --record 3");
  ASSERT_EQ(r.status, 0) << r.err;
  std::istringstream lines(r.out);
  int code = 0;
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind(";", 0) == 0) continue;
    ++code;
    EXPECT_TRUE(
        std::regex_match(
            line,
            std::regex(
                R"(\$TC_CARR(4|5|6|7|8|9|10|11|12|15|16|17|18|19|20)\[3\]=[-0-9.]+ ;[^;]*)")) ||
        line == "M30")
        << line;
  }
  EXPECT_EQ(code, 16);
  // Fanuc's table names its parameters, with the corrected vectors.
  r = run_cli("compensation --result " + (dir / "hostile.json").string() + " --format table");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("19700-19702"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("19703-19705"), std::string::npos) << r.out;
  std::filesystem::remove_all(dir);
}

// A machine result edited by hand: every edit that would make a writer put a number in the
// wrong place, or state an uncertainty no measurement has, is refused naming its key.
TEST(ChainCompensation, AnEditedMachineResultIsRefusedWhereItWouldMislead) {
  const auto dir = std::filesystem::temp_directory_path() / "dbbkit_chain_compensation_edits";
  std::filesystem::remove_all(dir);
  measure_and_chain(Planted{}, 0.5, 5, dir);
  const json good = json::parse(slurp((dir / "M.json").string()));
  struct Edit {
    const char* what;
    std::function<void(json&)> edit;
    const char* key;
  };
  const std::vector<Edit> edits = {
      {"names swapped",
       [](json& j) {
         std::swap(j["axes"][0]["location"][0]["name"], j["axes"][0]["location"][1]["name"]);
       },
       "location[0].name"},
      {"empty name", [](json& j) { j["axes"][0]["location"][0]["name"] = ""; }, "location[0].name"},
      {"unit", [](json& j) { j["axes"][0]["location"][0]["unit"] = "urad"; }, "location[0].unit"},
      {"vector along the axis",
       [](json& j) {
         j["axes"][0]["location"][0]["vector"] = {1, 0, 0};
       },
       "location[0].vector"},
      {"letter and direction",
       [](json& j) {
         j["axes"][0]["direction"] = {0, 0, 1};
       },
       "axes[0].direction"},
      {"carries itself", [](json& j) { j["axes"][0]["on"] = "A"; }, "axes"},
      {"a circle", [](json& j) { j["axes"][0]["on"] = "C"; }, "axes"},
      {"head on a table", [](json& j) { j["axes"][1]["side"] = "head"; }, "axes"},
      {"asymmetric", [](json& j) { j["location_covariance"]["matrix"][0][6] = 50; },
       "location_covariance.matrix"},
      {"not a covariance",
       [](json& j) {
         j["location_covariance"]["matrix"][0][6] = 5;
         j["location_covariance"]["matrix"][6][0] = 5;
       },
       "location_covariance.matrix"},
      {"std 0", [](json& j) { j["axes"][0]["location"][1]["std"] = 0; }, "location[1].std"},
      {"U not k std", [](json& j) { j["axes"][0]["location"][1]["U"] = 99; }, "location[1].U"},
      {"a tilt of 90 deg", [](json& j) { j["axes"][0]["location"][2]["value"] = 1e9 - 1; },
       "location[2].value"},
      {"a point beyond the machine",
       [](json& j) {
         j["axes"][0]["point_mm"] = {0, 0, 9e5};
       },
       "axes[0].point_mm"},
      {"k", [](json& j) { j["k"] = "drop"; }, "k"},
      {"between",
       [](json& j) {
         j["chain"][0]["between"] = {"", "Zebra"};
       },
       "chain[0].between"},
      {"warning's axis", [](json& j) { j["warnings"][0]["axis"] = json::object(); },
       "warnings[0].axis"},
  };
  for (const Edit& e : edits) {
    json j = good;
    e.edit(j);
    std::ofstream(dir / "e.json") << j.dump(2);
    const CliRun r =
        run_cli("compensation --result " + (dir / "e.json").string() + " --format table");
    EXPECT_EQ(r.status, 2) << e.what << "\n" << r.out;
    EXPECT_NE(r.err.find(e.key), std::string::npos) << e.what << ": " << r.err;
  }
  // The file as written passes.
  EXPECT_EQ(
      run_cli("compensation --result " + (dir / "M.json").string() + " --format table").status, 0);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace dbbkit
