// The machine file (formats.md, "Machine file"): its reader, the chain of nominal axis lines,
// designs that name their machine, and the programs that command the whole machine. The chain
// is checked against rotations written out here with Eigen::AngleAxisd; every program of every
// committed machine design is read back by a parser of its own (ISO, Heidenhain, Sinumerik) and
// checked against that geometry: every rotary axis commanded before any sideways move, TCPM on
// and off as its mode says, cups placed with the axis at its park angle, and the bar's length
// at every reading and along every interpolated move.
#include "dbbkit/machine.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <tuple>

#include "cli_util.hpp"
#include "dbbkit/error.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/kit_io.hpp"
#include "dbbkit/io/machine_io.hpp"
#include "dbbkit/io/program_io.hpp"
#include "dbbkit/measurement.hpp"
#include "dbbkit/observability.hpp"
#include "dbbkit/optimize.hpp"
#include "dbbkit/program.hpp"
#include "program_lines.hpp"
#include "test_util.hpp"

namespace dbbkit {
namespace {

using nlohmann::json;
using test::kPi;

// --- the chain, written out ------------------------------------------------------------------
// A point fixed to the body of axis k at zero, moved by the angles: the innermost rotation
// first, each about its nominal line.
Eigen::Vector3d hand_point(const Machine& m, int k, Eigen::Vector3d x,
                           const std::vector<double>& deg) {
  for (int a = k; a >= 0; a = m.rotary[a].on) {
    const RotaryAxisSpec& r = m.rotary[a];
    x = r.point_mm + Eigen::AngleAxisd(deg[a] * kPi / 180, r.direction) * (x - r.point_mm);
  }
  return x;
}

const std::vector<std::string>& machine_designs() {
  static const std::vector<std::string> files = {
      "a-c-trunnion-A",       "a-c-trunnion-A-whole", "a-c-trunnion-C", "b-c-trunnion-B",
      "b-c-trunnion-B-whole", "b-c-trunnion-C",       "paper-b-c-B",    "paper-b-c-C",
      "a-c-fork-head-A",      "a-c-fork-head-C"};
  return files;
}

std::string design_path(const std::string& name) {
  return test::source_path("designs/" + name + ".json");
}

// A design with one edit, written to `file` and read: refused at `key` (where() holds it),
// saying `says`.
struct DesignEdit {
  const char* what;
  void (*edit)(nlohmann::json&);
  const char* key;
  const char* says;
};
void expect_edits_refused(const nlohmann::json& good, const std::filesystem::path& file,
                          const std::vector<DesignEdit>& edits) {
  for (const DesignEdit& c : edits) {
    nlohmann::json e = good;
    c.edit(e);
    std::ofstream(file) << e.dump(2);
    try {
      io::read_design_file(file.string());
      ADD_FAILURE() << c.what << ": taken";
    } catch (const InputError& err) {
      EXPECT_NE(err.where().find(c.key), std::string::npos) << c.what << ": " << err.what();
      EXPECT_NE(std::string(err.what()).find(c.says), std::string::npos)
          << c.what << ": " << err.what();
    }
  }
}

TEST(Machine, CommittedMachinesReadAndTheirChainIsTheRotationsWrittenOut) {
  int machines = 0;
  for (const auto& e : std::filesystem::directory_iterator(test::source_path("designs/machines"))) {
    const Machine m = io::read_machine_file(e.path().string());
    EXPECT_FALSE(m.name.empty()) << e.path();
    // Round trip through the writer.
    const Machine back = io::machine_from_json(io::machine_to_json(m), "round trip");
    ASSERT_EQ(back.rotary.size(), m.rotary.size());
    const std::vector<double> angles = {37.5, -61.25, 12};
    for (std::size_t k = 0; k < m.rotary.size(); ++k) {
      EXPECT_EQ(back.rotary[k].letter, m.rotary[k].letter);
      EXPECT_EQ(back.rotary[k].on, m.rotary[k].on);
      const Eigen::Vector3d x0(123.4, -56.7, 89.1);
      const Eigen::Vector3d x = m.body_point_at(static_cast<int>(k), x0, angles);
      EXPECT_LE((x - hand_point(m, static_cast<int>(k), x0, angles)).norm(), 1e-9) << e.path();
      EXPECT_LE((m.to_body(static_cast<int>(k), x, angles) - x0).norm(), 1e-9);
      EXPECT_LE((back.body_point_at(static_cast<int>(k), x0, angles) - x).norm(), 1e-9);
    }
    ++machines;
  }
  EXPECT_EQ(machines, 4);
  // The A/C trunnion with A at 90 deg: the C axis stands along -Y, through (0, 60, 0).
  const Machine m = io::read_machine_file(test::source_path("designs/machines/a-c-trunnion.json"));
  const AxisFrame c = m.axis_frame(1, {90, 0});
  EXPECT_EQ(c.direction(), Eigen::Vector3d(0, -1, 0));
  EXPECT_EQ(c.reference(), Eigen::Vector3d(1, 0, 0));
  EXPECT_LE((m.point_at(1, {90, 0}) - Eigen::Vector3d(0, 60, 0)).norm(), 1e-12);
  EXPECT_EQ(c.letter(), 'C');
}

// A machine file with one key changed, and the key the refusal must name.
TEST(Machine, BadMachineFilesAreRefusedNamingTheKey) {
  const json good = json::parse(slurp(test::source_path("designs/machines/a-c-trunnion.json")));
  struct Case {
    const char* what;
    void (*edit)(json&);
    const char* key;
  };
  const Case cases[] = {
      {"format", [](json& j) { j["format"] = "dbbkit.machine/2"; }, "format"},
      {"typo", [](json& j) { j["rotory"] = 1; }, "rotory"},
      {"controller", [](json& j) { j["controller"] = "okuma"; }, "controller"},
      {"travel",
       [](json& j) {
         j["linear_travel_mm"]["y"] = {5, -5};
       },
       "linear_travel_mm.y"},
      {"letter", [](json& j) { j["rotary"][1]["letter"] = "B"; }, "rotary[1].letter"},
      {"twice", [](json& j) { j["rotary"][1]["letter"] = "A"; }, "rotary[1]"},
      {"not unit",
       [](json& j) {
         j["rotary"][0]["direction"] = {2, 0, 0};
       },
       "rotary[0].direction"},
      {"carrier", [](json& j) { j["rotary"][1]["on"] = "B"; }, "rotary[1].on"},
      {"side", [](json& j) { j["rotary"][1]["side"] = "head"; }, "rotary[1]"},
      {"park", [](json& j) { j["rotary"][0]["park_deg"] = 120; }, "rotary[0].park_deg"},
      {"no park", [](json& j) { j["rotary"][0].erase("park_deg"); }, "rotary[0].park_deg"},
      {"nutating",
       [](json& j) {
         j["rotary"][1]["direction"] = {0.6, 0, 0.8};
       },
       "rotary[1].reference"},
      {"box",
       [](json& j) {
         j["workspace"]["solids"][0]["box_mm"] = {{0, 0, 0}, {-1, 1, 1}};
       },
       "box_mm"},
      {"turns", [](json& j) { j["workspace"]["solids"][0]["turns_with"] = "B"; }, "turns_with"},
      {"no carrier", [](json& j) { j["rotary"][1].erase("on"); }, "rotary[1].on"},
      {"name", [](json& j) { j["name"] = "a\nb"; }, "name"},
      {"nameless", [](json& j) { j.erase("name"); }, "name"},
      {"empty name", [](json& j) { j["name"] = ""; }, "name"},
      {"four",
       [](json& j) {
         j["rotary"].push_back(j["rotary"][0]);
         j["rotary"].push_back(j["rotary"][0]);
       },
       "rotary"},
  };
  for (const Case& c : cases) {
    json j = good;
    c.edit(j);
    try {
      io::machine_from_json(j, "m.json");
      ADD_FAILURE() << c.what << ": taken";
    } catch (const InputError& e) {
      EXPECT_EQ(e.source(), "m.json");
      EXPECT_NE(e.where().find(c.key), std::string::npos) << c.what << ": " << e.what();
    }
  }
  EXPECT_NO_THROW(io::machine_from_json(good, "m.json"));
  // A park angle out of travel says both.
  json park = good;
  park["rotary"][0]["park_deg"] = 120;
  try {
    io::machine_from_json(park, "m.json");
  } catch (const InputError& e) {
    EXPECT_NE(e.detail().find("120 deg: the park angle must lie in the axis' travel (-115 to 115 "
                              "deg)"),
              std::string::npos)
        << e.what();
  }
  // A key misspelt too far for a guess ("yy" for "y", "park" for "park_deg") is named beside the
  // one missing, whichever is read first.
  const std::pair<void (*)(json&), const char*> misspelt[] = {
      {[](json& j) {
         j["linear_travel_mm"].erase("y");
         j["linear_travel_mm"]["yy"] = {-400, 400};
       },
       "linear_travel_mm.y: required key is missing, and 'yy' is no key of this object (its keys: "
       "x, y, z): misspelt?"},
      {[](json& j) {
         j["rotary"][0].erase("park_deg");
         j["rotary"][0]["park"] = 0;
       },
       "rotary[0].park_deg: required key is missing, and 'park' is no key of this object"},
      {[](json& j) {
         j["rotary"][1]["table"].erase("surface_mm");
         j["rotary"][1]["table"]["surface"] = -60;
       },
       "rotary[1].table.surface_mm: required key is missing, and 'surface' is no key"}};
  for (const auto& [edit, says] : misspelt) {
    json j = good;
    edit(j);
    try {
      io::machine_from_json(j, "m.json");
      ADD_FAILURE() << says << ": taken";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(says), std::string::npos) << e.what();
    }
  }
}

// A controller's corrected vector (within 1 mrad of a machine axis) is that axis for dbbkit's
// frame and kept as the controller's; beyond 1 mrad the axis is a nutating one.
TEST(Machine, ADirectionNearAMachineAxisIsTheControllersVectorOnThatAxis) {
  json j = json::parse(slurp(test::source_path("designs/machines/a-c-trunnion.json")));
  j["rotary"][1]["direction"] = {3e-5, 0, 1};  // a unit vector to 1e-6
  const Machine m = io::machine_from_json(j, "m.json");
  EXPECT_EQ(m.rotary[1].direction, Eigen::Vector3d::UnitZ());
  ASSERT_TRUE(m.rotary[1].controller_direction);
  EXPECT_NEAR(m.rotary[1].controller_direction->x(), 3e-5, 1e-12);
  EXPECT_NEAR(m.rotary[1].controller_direction->norm(), 1, 1e-15);
  // Written back as the controller's vector.
  EXPECT_NEAR(io::machine_to_json(m)["rotary"][1]["direction"][0].get<double>(), 3e-5, 1e-12);
  EXPECT_FALSE(m.rotary[0].controller_direction);
  j["rotary"][1]["direction"] = {2e-3, 0, 0.999998};
  EXPECT_THROW(io::machine_from_json(j, "m.json"), InputError);  // no reference for a nutating C
}

TEST(Machine, ADesignTakesItsFrameFromItsMachineAtTheParkAngles) {
  const Design d = io::read_design_file(design_path("a-c-trunnion-C"));
  ASSERT_TRUE(d.machine);
  EXPECT_EQ(d.axis.direction(), Eigen::Vector3d::UnitZ());
  EXPECT_EQ(d.axis.reference(), Eigen::Vector3d::UnitX());
  EXPECT_TRUE(d.axis.table());
  EXPECT_EQ(d.machine->origin_mm(), Eigen::Vector3d(0, 0, -60));
  // Written back: the machine and the letter, not a frame of its own.
  const json j = io::design_to_json(d);
  EXPECT_EQ(j["machine"], "machines/a-c-trunnion.json");
  EXPECT_EQ(j["axis"], "C");

  // In a folder of its own: the machine path is relative to the design's folder, wherever the
  // command runs.
  const auto dir = std::filesystem::temp_directory_path() / "dbbkit_machine_test";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir / "m");
  std::filesystem::copy_file(test::source_path("designs/machines/a-c-trunnion.json"),
                             dir / "m" / "t.json");
  json dj = json::parse(slurp(design_path("a-c-trunnion-C")));
  dj["machine"] = "m/t.json";
  dj["park_deg"] = {{"A", 90}};
  // The cups stand on the table turned on its side: a program refuses nothing here, the frame
  // is what is checked.
  std::ofstream(dir / "d.json") << dj.dump(2);
  const Design turned = io::read_design_file((dir / "d.json").string());
  EXPECT_EQ(turned.axis.direction(), Eigen::Vector3d(0, -1, 0));
  EXPECT_LE((turned.machine->origin_mm() - Eigen::Vector3d(0, 60, 0)).norm(), 1e-12);

  expect_edits_refused(
      dj, dir / "bad.json",
      {
          {"letter", [](json& j) { j["axis"] = "B"; }, "axis", "its axes: A, C"},
          {"form",
           [](json& j) {
             j["axis"] = {{"letter", "C"}};
           },
           "axis", "letter"},
          {"park axis",
           [](json& j) {
             j["park_deg"] = {{"B", 0}};
           },
           "park_deg.B", "its axes"},
          {"park range",
           [](json& j) {
             j["park_deg"] = {{"A", 130}};
           },
           "park_deg.A", "travel"},
          {"no file", [](json& j) { j["machine"] = "m/none.json"; }, "", "none.json"},
          {"no machine",
           [](json& j) {
             j.erase("machine");
             j["axis"] = "C";
             j["park_deg"] = {{"A", 0}};
           },
           "park_deg", "machine"},
      });
  std::filesystem::remove_all(dir);
}

// --- the programs, read back -------------------------------------------------------------------
struct Block {
  std::map<char, double> at;  // every axis' position after the block
  std::string axes;           // the axes the block names
  bool rapid = false, tcpm = false;
  std::string installation;
  bool mounted = false;
  std::string code;  // the block as written (its comment taken off)
  double z_before = NAN;
};
struct Read {
  std::vector<Block> moves;
  std::vector<Block> dwells;      // the state at each dwell
  std::vector<Block> placements;  // the state at each stop that places a cup
  int tcpm_on = 0, tcpm_off = 0;
  bool reset_before_moves = false;
  bool tcpm_at_end = false;
};

Read read_program(const std::string& text, io::Dialect dialect, const std::string& tool) {
  Read out;
  std::istringstream in(text);
  std::string line, installation;
  std::map<char, double> at;
  bool tcpm = false, mounted = false;
  while (std::getline(in, line)) {
    const test::ProgramLine pl = test::program_line(line, dialect);
    const std::string &code = pl.code, &comment = pl.comment;
    const std::vector<std::string>& w = pl.words;
    if (const std::string id = test::opened_installation(comment); !id.empty()) {
      installation = id;
      mounted = false;
    }
    if (w.empty()) continue;
    const std::string joined = code;
    // TCPM on and off, and the reset of the safe start.
    const bool on = dialect == io::Dialect::kIso         ? w[0] == "G43.4"
                    : dialect == io::Dialect::kSinumerik ? w[0] == "TRAORI"
                                                         : joined.find("FUNCTION TCPM F") == 0;
    const bool off = dialect == io::Dialect::kIso         ? (tcpm && joined == "G43 H" + tool)
                     : dialect == io::Dialect::kSinumerik ? w[0] == "TRAFOOF"
                                                          : joined.find("FUNCTION TCPM RESET") == 0;
    if (out.moves.empty() &&
        (dialect == io::Dialect::kIso ? joined.find("G49") != std::string::npos : off))
      out.reset_before_moves = true;
    if (on) ++out.tcpm_on, tcpm = true;
    if (off && !out.moves.empty()) ++out.tcpm_off, tcpm = false;
    const bool stop = w[0] == "M00" || w[0] == "M0" || w[0] == "STOP";
    if (stop && comment.find("mount the bar") != std::string::npos) mounted = true;
    Block state{at, "", false, tcpm, installation, mounted};
    if (stop && comment.find("place the table cup") != std::string::npos)
      out.placements.push_back(state);
    const bool dwell = w[0] == "G04" || w[0] == "G4" || (w.size() >= 3 && w[2] == "9.1");
    if (dwell) out.dwells.push_back(state);
    const bool motion = w[0] == "G00" || w[0] == "G01" || w[0] == "G0" || w[0] == "G1" ||
                        w[0] == "L" || (w[0] == "G00" && w.size() > 1);
    if (!motion || dwell) continue;
    Block b;
    b.code = code;
    b.z_before = at.count('Z') ? at.at('Z') : NAN;
    b.rapid = w[0] == "G00" || w[0] == "G0" || joined.find("FMAX") != std::string::npos;
    for (const std::string& t : w) {
      if (t.size() < 2 || t == "FMAX" || std::string("XYZABC").find(t[0]) == std::string::npos)
        continue;
      if (!std::isdigit(static_cast<unsigned char>(t[1])) && t[1] != '-' && t[1] != '+') continue;
      at[t[0]] = std::stod(t.substr(1));
      b.axes += t[0];
    }
    if (b.axes.empty()) continue;
    b.at = at, b.tcpm = tcpm, b.installation = installation, b.mounted = mounted;
    out.moves.push_back(b);
  }
  out.tcpm_at_end = tcpm;
  return out;
}

Eigen::Vector3d xyz(const std::map<char, double>& at) {
  return {at.at('X'), at.at('Y'), at.at('Z')};
}

// The spindle ball and the table ball (machine frame, or the table ball's frame on a head) at a
// block's positions, from the chain written out: what a controller does with them.
struct Balls {
  Eigen::Vector3d spindle, table;
};
Balls balls_at(const Design& d, const Installation& in, const std::map<char, double>& at,
               bool tcpm) {
  const Machine& m = *d.machine->machine;
  const int k = d.machine->axis;
  std::vector<double> angles = d.machine->park_angles();
  for (std::size_t a = 0; a < m.rotary.size(); ++a) angles[a] = at.at(m.rotary[a].letter);
  std::vector<double> zero_k = d.machine->park_angles();
  zero_k[k] = 0;
  const Eigen::Vector3d origin = d.machine->origin_mm();
  // The ball on the turning body at zero of the axis under test (the others parked), machine
  // frame; every committed design parks the axes that carry the one under test at 0.
  const Eigen::Vector3d body = origin + d.axis.body_point(in.L_mm, in.D_mm, in.H_mm);
  Balls b;
  if (d.axis.table()) {
    b.table = hand_point(m, k, body, angles);
    b.spindle = tcpm ? hand_point(m, k, origin + xyz(at), angles) : origin + xyz(at);
  } else {
    // The table ball at the work frame's origin; off: X Y Z the pivot (the axis' point), on:
    // the tool tip.
    b.table = Eigen::Vector3d::Zero();
    b.spindle = tcpm ? xyz(at) : xyz(at) + hand_point(m, k, body, angles) - origin;
  }
  return b;
}

TEST(MachineProgram, EveryRotaryAxisCommandedTcpmSetAndResetAndTheBarKeptInEveryDialect) {
  int programs = 0, readings = 0;
  for (const std::string& name : machine_designs()) {
    const Design d = io::read_design_file(design_path(name));
    ASSERT_TRUE(d.machine) << name;
    const Machine& m = *d.machine->machine;
    const char tested = d.axis.letter();
    for (const bool tcpm : {false, true}) {
      ProgramOptions o;
      o.tcpm = tcpm;
      o.sweeps = ProgramOptions::Sweeps::kBoth;
      const MeasurementProgram program = measurement_program(d, o);
      for (const io::Dialect dialect :
           {io::Dialect::kIso, io::Dialect::kHeidenhain, io::Dialect::kSinumerik}) {
        const std::string where =
            name + (tcpm ? " tcpm on " : " tcpm off ") + std::to_string(static_cast<int>(dialect));
        const Read r = read_program(io::program_text(d, program, dialect), dialect, "99");
        ASSERT_FALSE(r.moves.empty()) << where;
        // The safe start resets TCPM; the first move commands every rotary axis and no linear
        // one: every rotary axis before the first linear move.
        EXPECT_TRUE(r.reset_before_moves) << where;
        std::string rotaries;
        for (const RotaryAxisSpec& a : m.rotary) rotaries += a.letter;
        std::string first = r.moves.front().axes;
        std::sort(first.begin(), first.end());
        std::sort(rotaries.begin(), rotaries.end());
        EXPECT_EQ(first, rotaries) << where;
        // The first linear move is Z alone up to the plane, with the tool length (ISO: G43 H;
        // Heidenhain and Sinumerik: TOOL CALL and D1 before it).
        const auto linear = std::find_if(r.moves.begin(), r.moves.end(), [](const Block& b) {
          return b.axes.find_first_of("XYZ") != std::string::npos;
        });
        ASSERT_NE(linear, r.moves.end());
        EXPECT_EQ(linear->axes, "Z") << where;
        EXPECT_NEAR(linear->at.at('Z'), program.clearance_z_mm, 1e-4) << where;
        if (dialect == io::Dialect::kIso)
          EXPECT_NE(linear->code.find("G43 H99"), std::string::npos) << where << linear->code;
        // Sideways rapids only at the clearance plane.
        for (const Block& b : r.moves)
          if (b.rapid && b.axes.find_first_of("XY") != std::string::npos)
            EXPECT_NEAR(b.z_before, program.clearance_z_mm, 1e-4) << where << ": " << b.code;
        // The parked axes never move again.
        for (const Block& b : r.moves)
          for (const RotaryAxisSpec& a : m.rotary)
            if (a.letter != tested && b.at.count(a.letter))
              EXPECT_EQ(b.at.at(a.letter), d.machine->park_angles()[m.find(a.letter)]) << where;
        // TCPM on and off as the mode says, off at the end; sideways rapids of a table test
        // run with it off.
        if (tcpm) {
          EXPECT_GE(r.tcpm_on, 1) << where;
          EXPECT_EQ(r.tcpm_on, r.tcpm_off) << where;
        } else {
          EXPECT_EQ(r.tcpm_on, 0) << where;
        }
        EXPECT_FALSE(r.tcpm_at_end) << where;
        // The program ends with every rotary axis at its park angle.
        for (auto it = r.moves.rbegin(); it != r.moves.rend(); ++it) {
          if (it->axes.find_first_of("ABC") == std::string::npos) continue;
          for (const RotaryAxisSpec& a : m.rotary)
            EXPECT_EQ(it->at.at(a.letter), d.machine->park_angles()[m.find(a.letter)]) << where;
          break;
        }
        // Cups placed with the axis at its park angle (the table level, the spindle upright).
        ASSERT_FALSE(r.placements.empty()) << where;
        for (const Block& p : r.placements)
          EXPECT_EQ(p.at.at(tested), d.machine->park_angles()[d.machine->axis]) << where;
        // Every reading: TCPM as the mode says, the bar's length between the balls; each
        // installation read at its own angles (both sweeps), and at nothing else.
        ASSERT_EQ(r.dwells.size(), 2 * static_cast<std::size_t>(d.readings_per_round())) << where;
        std::map<std::string, std::multiset<double>> read_at;
        for (const Block& dw : r.dwells) read_at[dw.installation].insert(dw.at.at(tested));
        for (std::size_t i = 0; i < d.installations.size(); ++i) {
          std::multiset<double> expected;
          for (const double a : d.angles_of(static_cast<int>(i))) expected.insert({a, a});
          EXPECT_EQ(read_at[d.installations[i].id], expected)
              << where << " " << d.installations[i].id;
        }
        for (const Block& dw : r.dwells) {
          EXPECT_EQ(dw.tcpm, tcpm) << where;
          const Installation& in = d.installations[d.find_installation(dw.installation)];
          const Balls b = balls_at(d, in, dw.at, tcpm);
          EXPECT_NEAR((b.spindle - b.table).norm(), *in.bar_mm, 1e-3)
              << where << " " << in.id << " at " << dw.at.at(tested);
          ++readings;
        }
        // Along each interpolated move of a sweep: the controller interpolates X Y Z and the
        // axis linearly (under TCPM, the tip in the workpiece frame).
        for (std::size_t i = 1; i < r.moves.size(); ++i) {
          const Block &a = r.moves[i - 1], &b = r.moves[i];
          if (!a.mounted || !b.mounted || a.installation != b.installation ||
              b.axes.find(tested) == std::string::npos || b.axes.size() < 4)
            continue;
          const Installation& in = d.installations[d.find_installation(a.installation)];
          for (int j = 1; j < 8; ++j) {
            const double t = j / 8.0;
            std::map<char, double> mid = b.at;
            for (char c : std::string("XYZ") + tested)
              mid[c] = a.at.at(c) + t * (b.at.at(c) - a.at.at(c));
            const Balls bl = balls_at(d, in, mid, tcpm);
            EXPECT_LE(std::abs((bl.spindle - bl.table).norm() - *in.bar_mm),
                      o.path_tolerance_mm + 1e-3)
                << where << " " << in.id;
          }
        }
        ++programs;
      }
    }
  }
  EXPECT_EQ(programs, 10 * 2 * 3);
  EXPECT_GT(readings, 8000);
}

TEST(MachineProgram, WhatLeavesTheTravelOrMeetsASolidIsRefusedByName) {
  json dj = json::parse(slurp(design_path("a-c-trunnion-C")));
  const auto dir = std::filesystem::temp_directory_path() / "dbbkit_machine_clash";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  std::filesystem::copy(test::source_path("designs/machines"), dir / "machines");
  auto refusal = [&](const json& design, const ProgramOptions& o) -> std::string {
    std::ofstream(dir / "d.json") << design.dump(2);
    const Design d = io::read_design_file((dir / "d.json").string());
    try {
      measurement_program(d, o);
    } catch (const InputError& e) {
      EXPECT_EQ(e.where(), "machine");
      return e.detail();
    }
    return "";
  };
  EXPECT_EQ(refusal(dj, ProgramOptions{}), "");
  // A 250 mm tangential bar at 200 mm from the C axis sweeps through a cradle cheek.
  json bar = dj;
  for (auto& in : bar["installations"])
    if (in["id"] == "2t") in["bar_mm"] = 250;
  std::string why = refusal(bar, ProgramOptions{});
  EXPECT_NE(why.find("installation 2t"), std::string::npos) << why;
  EXPECT_NE(why.find("'cradle cheek"), std::string::npos) << why;
  // A ball beyond the table's edge (diameter 420 mm).
  json edge = dj;
  for (auto& in : edge["installations"])
    if (in["id"] == "2r" || in["id"] == "2t") in["ball_mm"]["L"] = 230;
  why = refusal(edge, ProgramOptions{});
  EXPECT_NE(why.find("beyond the edge of the C table"), std::string::npos) << why;
  // The axial installation with its spindle ball below the table: out of the Z travel.
  json below = dj;
  for (auto& in : below["installations"])
    if (in["id"] == "1a") in["sign"] = 1;
  why = refusal(below, ProgramOptions{});
  EXPECT_NE(why.find("installation 1a"), std::string::npos) << why;
  EXPECT_NE(why.find("Z -150"), std::string::npos) << why;
  // The same with the Z travel reaching below the table: the table's surface refuses it.
  {
    json m = json::parse(slurp((dir / "machines" / "a-c-trunnion.json").string()));
    m["linear_travel_mm"]["z"] = {-400, 450};
    std::ofstream(dir / "machines" / "a-c-trunnion.json") << m.dump(2);
    why = refusal(below, ProgramOptions{});
    EXPECT_NE(why.find("the spindle ball lies 90 mm below the surface of the C table"),
              std::string::npos)
        << why;
    // The cups are placed on a level table: A, which tilts the C table, stands at 0 then
    // (TCPM on or off).
    json parked = dj;
    parked["park_deg"] = {{"A", 10}};
    std::ofstream(dir / "d.json") << parked.dump(2);
    ProgramOptions on;
    on.tcpm = true;
    for (const ProgramOptions& o : {ProgramOptions{}, on}) {
      try {
        measurement_program(io::read_design_file((dir / "d.json").string()), o);
        ADD_FAILURE() << "A parked at 10 deg under the cups was taken";
      } catch (const InputError& e) {
        EXPECT_NE(e.detail().find("table axis A stands at 10 deg while the cups are placed: the "
                                  "table would be tilted"),
                  std::string::npos)
            << e.what();
      }
    }
    // Under TCPM another table axis must stand at 0 (the controller's workpiece frame), even
    // one that only turns the table (C, while A is measured).
    json a = json::parse(slurp(design_path("a-c-trunnion-A")));
    a["machine"] = (dir / "machines" / "a-c-trunnion.json").string();
    a["park_deg"] = {{"C", 90}};
    std::ofstream(dir / "d.json") << a.dump(2);
    try {
      measurement_program(io::read_design_file((dir / "d.json").string()), on);
      ADD_FAILURE() << "TCPM with C parked at 90 deg was taken";
    } catch (const InputError& e) {
      EXPECT_NE(e.detail().find("table axis C parks at 90 deg"), std::string::npos) << e.what();
    }
  }
  // A clearance plane above the Z travel.
  ProgramOptions high;
  high.clearance_z_mm = 600;
  why = refusal(dj, high);
  EXPECT_NE(why.find("clearance plane"), std::string::npos) << why;
  std::filesystem::remove_all(dir);
}

// The set-up sheet of a machine's axis says where the other axes stand and how the preset is set.
TEST(MachineProgram, TheSetUpSheetNamesTheParkedAxesAndThePreset) {
  const CliRun r = run_cli("setup-sheet --design " + design_path("a-c-trunnion-C"));
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("Machine a-c-trunnion (controller heidenhain): axis C is measured with A "
                       "at 0 deg (parked: the program commands it)"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("X 0, Y 0, Z -60 mm in the machine file's frame"), std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("never by teaching it on the real axis"), std::string::npos) << r.out;
}

// The trunnions' designs over the whole travel the kit allows: the tangential bars change side at
// the axis' zero (sign -1 below, +1 above), every angle from -100 to 100 deg is read, and one step
// further is refused by the program as the description says: the radial spindle ball leaves the
// Z travel beyond +-100 deg (2r beyond +-90), a tangential bar kept on its side beyond zero leaves
// it on the other side (A at -60, B at -50 deg).
TEST(MachineProgram, ATrunnionsWholeTravelChangesTheBarsSideAtZero) {
  for (const auto& [name, one_side_deg] :
       {std::pair{"a-c-trunnion-A-whole", -60.0}, {"b-c-trunnion-B-whole", -50.0}}) {
    const json good = json::parse(slurp(design_path(name)));
    const Design d = io::read_design_file(design_path(name));
    EXPECT_TRUE(d.partial_sweeps()) << name;
    std::set<double> read;
    for (std::size_t i = 0; i < d.installations.size(); ++i) {
      const Installation& in = d.installations[i];
      const std::vector<double>& a = d.angles_of(static_cast<int>(i));
      read.insert(a.begin(), a.end());
      if (in.direction.kind != Direction::Kind::kTangential) continue;
      const auto [lo, hi] = std::minmax_element(a.begin(), a.end());
      // One side each, meeting at zero.
      EXPECT_EQ(in.sign < 0 ? *hi : *lo, 0.0) << name << " " << in.id;
      EXPECT_EQ(in.sign < 0 ? *lo : *hi, in.sign < 0 ? -100.0 : 100.0) << name << " " << in.id;
    }
    EXPECT_EQ(read.size(), 21u) << name;
    EXPECT_EQ(*read.begin(), -100.0);
    EXPECT_EQ(*read.rbegin(), 100.0);
    // One step beyond what the design reads, or a tangential bar left on its side: refused,
    // naming the installation, the angle and the Z travel.
    struct Case {
      const char* id;
      std::vector<double> angles;
      int sign;
      std::string says;
    };
    const double beyond = one_side_deg;
    const Case cases[] = {{"1r", {-110, 110}, -1, "installation 1r at "},
                          {"2r", {-100, 100}, -1, "installation 2r at "},
                          {"1t-pos", {beyond, 100}, 1, "installation 1t-pos at "}};
    for (const Case& c : cases) {
      json e = good;
      e["angles_deg"] = {{"start", -110}, {"stop", 110}, {"step", 10}};
      for (json& in : e["installations"]) {
        if (in["id"] != c.id) continue;
        in["angles_deg"] = {{"start", c.angles[0]}, {"stop", c.angles[1]}, {"step", 10}};
        in["sign"] = c.sign;
      }
      e["machine"] = test::source_path("designs/" + good["machine"].get<std::string>());
      const auto f = std::filesystem::temp_directory_path() / "dbbkit_beyond.json";
      std::ofstream(f) << e.dump(2);
      const CliRun r = run_cli("program --design " + f.string() + " --dialect iso --tcpm on");
      std::filesystem::remove(f);
      EXPECT_EQ(r.status, 2) << name << " " << c.id;
      EXPECT_NE(r.err.find(c.says), std::string::npos) << name << " " << c.id << ": " << r.err;
      EXPECT_NE(r.err.find("Z "), std::string::npos) << r.err;
      EXPECT_NE(r.err.find("beyond the travel"), std::string::npos) << r.err;
    }
  }
}

// An installation's own angles (installations[i].angles_deg): angles of the design, each once,
// every design angle read by some installation, readings at the installation's angles alone; the
// a-priori uncertainty at each angle is that of the readings taken there (written out here:
// rows (u, 1e-3 P x u) of the balls and directions turned by the axis, per angle, inverted).
TEST(MachineDesign, AnInstallationsOwnAnglesAreTheOnesItIsReadAt) {
  const std::string file = design_path("a-c-trunnion-A-whole");
  json good = json::parse(slurp(file));
  good["machine"] = test::source_path("designs/machines/a-c-trunnion.json");
  const auto dir = std::filesystem::temp_directory_path() / "dbbkit_own_angles";
  std::filesystem::create_directories(dir);
  expect_edits_refused(
      good, dir / "d.json",
      {
          {"not the design's",
           [](json& j) {
             j["installations"][1]["angles_deg"] = json::array({-100, -95});
           },
           "installations[1].angles_deg[1]", "not an angle of the design's"},
          {"twice",
           [](json& j) {
             j["installations"][1]["angles_deg"] = json::array({-100, -90, -100});
           },
           "installations[1].angles_deg[2]", "given twice"},
          {"read by none",
           [](json& j) {
             for (json& in : j["installations"])
               if (in.contains("angles_deg")) in["angles_deg"] = json::array({0, 10});
             j["installations"][3]["angles_deg"] = json::array({0, 10});
           },
           "angles_deg", "read by no installation"},
          {"empty", [](json& j) { j["installations"][1]["angles_deg"] = json::array(); },
           "installations[1].angles_deg", "empty"},
          {"step",
           [](json& j) {
             j["installations"][1]["angles_deg"] = {{"start", 0}, {"stop", 10}, {"step", 0}};
           },
           "installations[1].angles_deg.step", "must not be 0"},
      });

  const Design d = io::read_design_file(file);
  // An installation's angle within the tolerance of a design angle is that angle.
  {
    json near = good;
    near["installations"][1]["angles_deg"] = json::array({-100.0000000001, -90, 0});
    std::ofstream(dir / "near.json") << near.dump(2);
    const Design n = io::read_design_file((dir / "near.json").string());
    EXPECT_EQ(n.installations[1].angles_deg, (std::vector<double>{-100, -90, 0}));
    std::filesystem::remove_all(dir);
  }
  // The design written and read back keeps each installation's angles.
  const Design back = io::design_from_json(io::design_to_json(d), "round trip",
                                           std::filesystem::path(file).parent_path().string());
  for (std::size_t i = 0; i < d.installations.size(); ++i)
    EXPECT_EQ(back.angles_of(static_cast<int>(i)), d.angles_of(static_cast<int>(i)));
  // A reading of 1t-pos at a negative angle is refused, naming the line and the installation.
  std::vector<Reading> readings = nominal_readings(d);
  EXPECT_EQ(readings.size(), 148u);
  for (Reading& r : readings) r.reading_um = 0;
  validate_readings(d, readings, "data.csv");
  Reading wrong;
  wrong.installation = "1t-pos";
  wrong.angle_deg = -10;
  wrong.line = 7;
  readings.push_back(wrong);
  try {
    validate_readings(d, readings, "data.csv");
    ADD_FAILURE() << "a reading off the installation's angles taken";
  } catch (const InputError& err) {
    EXPECT_NE(std::string(err.what()).find("line 7"), std::string::npos) << err.what();
    EXPECT_NE(std::string(err.what()).find("not an angle of installation 1t-pos"),
              std::string::npos)
        << err.what();
  }

  // The a-priori uncertainty at each angle, written out.
  const Evaluation ev = evaluate_design(d, 100.0);
  ASSERT_EQ(ev.errors.size(), 21u);
  // The worst case alone (the closed forms take every installation at every angle: not these).
  ASSERT_TRUE(ev.worst.worst_std_um && design_worst_case(d, 100.0).worst_std_um);
  EXPECT_NEAR(*design_worst_case(d, 100.0).worst_std_um, *ev.worst.worst_std_um, 1e-9);
  EXPECT_NEAR(*design_worst_total(d, 100.0).total.worst_std_um, *ev.worst.worst_std_um, 1e-9);
  const double w = 1.0 / std::pow(d.noise.sigma_um(), 2);
  for (const ErrorsAtAngle& ea : ev.errors) {
    const Eigen::AngleAxisd R(ea.angle_deg * kPi / 180, Eigen::Vector3d::UnitX());
    Eigen::Matrix<double, 6, 6> M = Eigen::Matrix<double, 6, 6>::Zero();
    int n = 0;
    for (std::size_t i = 0; i < d.installations.size(); ++i) {
      const std::vector<double>& a = d.angles_of(static_cast<int>(i));
      if (std::find(a.begin(), a.end(), ea.angle_deg) == a.end()) continue;
      const Installation& in = d.installations[i];
      // The A axis' frame: L along +Z (the table's normal at A0), H along +X.
      const Eigen::Vector3d P = R * Eigen::Vector3d(in.H_mm, 0, in.L_mm);
      const Eigen::Vector3d u = R * in.direction.body;
      Eigen::Matrix<double, 6, 1> row;
      row << u, 1e-3 * P.cross(u);
      M += w * row * row.transpose();
      ++n;
    }
    EXPECT_EQ(n, std::abs(ea.angle_deg) == 100 ? 6 : ea.angle_deg == 0 ? 10 : 7) << ea.angle_deg;
    const Eigen::Matrix<double, 6, 6> C = M.inverse();
    for (int k = 0; k < 6; ++k) {
      ASSERT_TRUE(ea.errors[k].determined) << ea.angle_deg;
      EXPECT_NEAR(ea.errors[k].std, std::sqrt(C(k, k)), 1e-9 * std::sqrt(C(k, k)))
          << kErrorNames[k] << " at " << ea.angle_deg;
    }
  }
}

// A head's test: the table ball is the work frame's origin, placed by the operator. The program,
// its header and the set-up sheet say where it may stand: at every corner of that box the
// linear axes' values of every commanded position (the pivot at the preset plus X Y Z, less
// where it stands with the axes at zero) and of the clearance plane lie inside the travel, and
// 1 mm beyond any face some lie outside; the pivot and the spindle ball come down to the lowest
// Z stated. A travel too short for the test is refused.
TEST(MachineProgram, AHeadTestSaysWhereTheTableBallMayStand) {
  for (const char* name :
       {"paper-b-c-B", "paper-b-c-B-off-axis", "a-c-fork-head-A", "a-c-fork-head-C"}) {
    const Design d = io::read_design_file(design_path(name));
    const MeasurementProgram p = measurement_program(d, ProgramOptions{});
    ASSERT_TRUE(p.preset_range) << name;
    const MeasurementProgram::PresetRange& r = *p.preset_range;
    const Machine& m = *d.machine->machine;
    const Eigen::Vector3d zero = d.machine->origin_mm();
    // The largest excess over the travel of any commanded position with the preset q.
    auto excess = [&](const Eigen::Vector3d& q) {
      double worst = -1e300;
      auto at = [&](const Eigen::Vector3d& x) {
        const Eigen::Vector3d axes = q + x - zero;
        for (int i = 0; i < 3; ++i)
          worst = std::max(
              {worst, m.linear_travel_mm[i][0] - axes(i), axes(i) - m.linear_travel_mm[i][1]});
      };
      double lowest = 1e300;
      for (const InstallationProgram& ip : p.installations) {
        at(ip.placement_mm);
        for (const ProgramSweep& s : ip.sweeps)
          for (const ProgramPosition& pos : s.positions) {
            at(pos.linear_mm);
            at(Eigen::Vector3d(pos.linear_mm.x(), pos.linear_mm.y(), p.clearance_z_mm));
            lowest = std::min(lowest, pos.linear_mm.z());
            if (pos.reading) {
              // The spindle ball: one bar from the table ball at the origin, where the program
              // puts the pivot.
              const Installation& in = d.installations[ip.installation];
              const Eigen::Vector3d ball =
                  pos.linear_mm + ball_position_mm(d.axis, in, pos.angle_deg);
              EXPECT_NEAR(ball.norm(), *in.bar_mm, 1e-6) << name;
              lowest = std::min(lowest, ball.z());
            }
          }
      }
      EXPECT_GE(lowest, r.lowest_z_mm - 1e-9) << name;
      return worst;
    };
    for (int c = 0; c < 8; ++c) {
      Eigen::Vector3d q;
      for (int i = 0; i < 3; ++i) q(i) = (c >> i) & 1 ? r.max_mm(i) : r.min_mm(i);
      EXPECT_LE(excess(q), 1e-9) << name << " corner " << c;
    }
    for (int i = 0; i < 3; ++i) {
      for (const double side : {-1.0, 1.0}) {
        Eigen::Vector3d q = 0.5 * (r.min_mm + r.max_mm);
        q(i) = (side < 0 ? r.min_mm(i) : r.max_mm(i)) + side;
        EXPECT_NEAR(excess(q), 1.0, 1e-9) << name << " axis " << i << " side " << side;
      }
    }
    // Said in the program's header and on the set-up sheet.
    const std::string text = io::program_text(d, p, io::Dialect::kIso);
    EXPECT_NE(text.find("place the table ball so that its centre [the preset] lies at X"),
              std::string::npos)
        << name;
    EXPECT_EQ(text.find("..."), std::string::npos) << name << ": a comment cut short";
    // Under TCPM the plane's moves command the spindle ball: the pivot stands where the ball at
    // the plane puts it, at every angle the head turns through there; the box keeps those in the
    // travel too.
    ProgramOptions on;
    on.tcpm = true;
    MeasurementProgram t;
    try {
      t = measurement_program(d, on);
    } catch (const InputError&) {
      continue;  // a ball off the tool axis: no TCPM program
    }
    ASSERT_TRUE(t.preset_range) << name;
    for (int c = 0; c < 8; ++c) {
      Eigen::Vector3d q;
      for (int i = 0; i < 3; ++i)
        q(i) = (c >> i) & 1 ? t.preset_range->max_mm(i) : t.preset_range->min_mm(i);
      double worst = -1e300;
      for (const InstallationProgram& ip : t.installations) {
        const Installation& in = d.installations[ip.installation];
        for (const ProgramSweep& s : ip.sweeps)
          for (const ProgramPosition& pos : s.positions) {
            for (const Eigen::Vector3d& pivot :
                 {pos.linear_mm, Eigen::Vector3d(Eigen::Vector3d(pos.tcp_mm.x(), pos.tcp_mm.y(),
                                                                 t.clearance_z_mm) -
                                                 ball_position_mm(d.axis, in, pos.angle_deg))}) {
              const Eigen::Vector3d axes = q + pivot - zero;
              for (int i = 0; i < 3; ++i)
                worst = std::max({worst, m.linear_travel_mm[i][0] - axes(i),
                                  axes(i) - m.linear_travel_mm[i][1]});
            }
          }
      }
      EXPECT_LE(worst, 1e-9) << name << " tcpm corner " << c;
    }
  }
  const CliRun sheet =
      run_cli("setup-sheet --design " + design_path("paper-b-c-B") + " --tcpm off");
  ASSERT_EQ(sheet.status, 0) << sheet.err;
  EXPECT_NE(sheet.out.find("The work frame's origin (the preset) is the table ball's centre"),
            std::string::npos)
      << sheet.out;
  EXPECT_NE(sheet.out.find("mm below the table ball's centre: stand it at least that high"),
            std::string::npos)
      << sheet.out;
  // A Z travel that takes the pivot below the table: the table bounds the ball's height (its
  // surface at Z 0; at B-100 the tool points 10 deg above the horizontal, so installation 2r's
  // pivot, 200 + 150 mm back along it from the table ball, stands 350 sin 10 deg below).
  json mj = json::parse(slurp(test::source_path("designs/machines/paper-b-c.json")));
  {
    Machine deep = io::machine_from_json(mj, "m.json");
    deep.linear_travel_mm[2] = {-400, 500};
    Design d = io::read_design_file(design_path("paper-b-c-B"));
    d.machine->machine = std::make_shared<const Machine>(deep);
    const MeasurementProgram p = measurement_program(d, ProgramOptions{});
    ASSERT_TRUE(p.preset_range && p.preset_range->table_surface_z_mm);
    EXPECT_NEAR(*p.preset_range->table_surface_z_mm, 0, 1e-12);
    EXPECT_NEAR(p.preset_range->min_mm.z(), -p.preset_range->lowest_z_mm, 1e-9);
    EXPECT_NEAR(p.preset_range->min_mm.z(), 350 * std::sin(10 * kPi / 180), 1e-9);
    EXPECT_NEAR(*p.preset_range->table_radius_mm, 300, 1e-12);
  }
  // A Z travel shorter than the test's reach: refused, saying so.
  mj["linear_travel_mm"]["z"] = {0, 300};
  const auto dir = std::filesystem::temp_directory_path() / "dbbkit_head_preset";
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "m.json") << mj.dump(2);
  json dj = json::parse(slurp(design_path("paper-b-c-B")));
  dj["machine"] = (dir / "m.json").string();
  std::ofstream(dir / "d.json") << dj.dump(2);
  const CliRun r =
      run_cli("program --design " + (dir / "d.json").string() + " --dialect iso --tcpm off");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("no place of the table ball keeps it inside the travel"), std::string::npos)
      << r.err;
  std::filesystem::remove_all(dir);
}

// The table ball stands in a cup on a stand: no committed design's program drives the spindle
// ball or the bar more than kMaxBarBelowCup_deg below the plane of that cup, on a table or a
// head, with or without a machine. The balls' places are written out here from the program's
// commanded points and rotations about the axis (Eigen::AngleAxisd); "up" is each design's own:
// a machine's table faces +Z and tilts with a trunnion; the "B" shorthand's frame has the
// spindle along +Z at B0, so up is -Z there. A bar on the wrong side is refused by name.
TEST(MachineProgram, NoBallIsDrivenIntoTheTableBallsCup) {
  const double limit = std::sin(kMaxBarBelowCup_deg * kPi / 180);
  std::vector<std::string> names;
  for (const auto& e : std::filesystem::directory_iterator(test::source_path("designs")))
    if (e.path().extension() == ".json") names.push_back(e.path().stem().string());
  std::sort(names.begin(), names.end());
  ASSERT_GE(names.size(), 20u);
  double deepest_accepted = 0;  // the deepest dip below the cup's plane taken [sin]
  int checked = 0;
  for (const std::string& name : names) {
    const Design d = io::read_design_file(design_path(name));
    const AxisFrame& axis = d.axis;
    if (axis.table() && axis.machine_axis() != 2 && !d.machine)
      continue;  // the table's face unknown
    const MeasurementProgram p = measurement_program(d, ProgramOptions{});
    for (const InstallationProgram& ip : p.installations) {
      const Installation& in = d.installations[ip.installation];
      const Eigen::Vector3d body = ball_body_mm(axis, in);
      for (const ProgramSweep& s : ip.sweeps) {
        for (const ProgramPosition& pos : s.positions) {
          const Eigen::Matrix3d R =
              Eigen::AngleAxisd(pos.angle_deg * kPi / 180, axis.direction()).toRotationMatrix();
          Eigen::Vector3d table_ball, spindle_ball, up;
          if (axis.table()) {
            table_ball = R * body;
            spindle_ball = pos.linear_mm;
            up = R * Eigen::Vector3d::UnitZ();
          } else {
            table_ball = Eigen::Vector3d::Zero();
            spindle_ball = pos.linear_mm + R * body;  // the pivot, and the ball on the head
            up = axis.shorthand() == "B" ? Eigen::Vector3d(0, 0, -1) : Eigen::Vector3d::UnitZ();
          }
          const Eigen::Vector3d v = spindle_ball - table_ball;
          EXPECT_NEAR(v.norm(), ip.bar_mm, 1e-6) << name << " " << in.id;
          const double dip = -v.dot(up) / v.norm();
          EXPECT_LE(dip, limit + 1e-9) << name << " " << in.id << " at " << pos.angle_deg;
          deepest_accepted = std::max(deepest_accepted, dip);
          ++checked;
        }
      }
    }
  }
  EXPECT_GT(checked, 5000);
  // The paper's radial bars at B-100 point 10 deg below the cup's plane, and are taken.
  EXPECT_NEAR(deepest_accepted, std::sin(10 * kPi / 180), 1e-6);

  // The other side of the bar: refused, naming the installation's sign and the cup.
  const auto f = std::filesystem::temp_directory_path() / "dbbkit_cup_clash.json";
  for (const auto& [name, index, says] : std::vector<std::tuple<std::string, int, std::string>>{
           {"paper-b-c-B", 1, "at B-90: the spindle ball stands 150 mm below"},
           {"paper-b-head", 4, "at B-90: the spindle ball stands 150 mm below"},
           {"a-c-fork-head-A", 1, "at A-90: the spindle ball stands 150 mm below"},
           {"c-turntable-kit-setup-optimized", 7, "at C0: the spindle ball stands 100 mm below"}}) {
    json e = json::parse(slurp(design_path(name)));
    if (e.contains("machine"))
      e["machine"] = test::source_path("designs/" + e["machine"].get<std::string>());
    json& in = e["installations"][index];
    in["sign"] = -in.value("sign", 1);
    std::ofstream(f) << e.dump(2);
    try {
      measurement_program(io::read_design_file(f.string()), ProgramOptions{});
      ADD_FAILURE() << name << ": taken";
    } catch (const InputError& err) {
      EXPECT_EQ(err.where(), "installations[" + std::to_string(index) + "].sign") << err.what();
      const std::string what = err.what();
      EXPECT_NE(what.find(says), std::string::npos) << what;
      EXPECT_NE(what.find("90 deg below the plane of its cup (at most 20 deg"), std::string::npos)
          << what;
    }
  }
  // Over -90..90 deg no side of a tangential bar on the paper's head keeps it out of the cup:
  // the refusal says to read it as two installations, one side each.
  {
    json e = json::parse(slurp(design_path("paper-b-head")));
    e["angles_deg"] = {{"start", -90}, {"stop", 90}, {"step", 10}};
    std::ofstream(f) << e.dump(2);
    try {
      measurement_program(io::read_design_file(f.string()), ProgramOptions{});
      ADD_FAILURE() << "a tangential bar over -90..90 deg: taken";
    } catch (const InputError& err) {
      EXPECT_EQ(err.where(), "installations[1].sign") << err.what();
      EXPECT_NE(std::string(err.what()).find("neither side keeps the bar out of the cup"),
                std::string::npos)
          << err.what();
    }
  }
  // A bar 25 deg below the plane (the limit is 20): refused; 15 deg: taken. A C table, a ball
  // on blocks, the bar tilted down towards the spindle ball by an explicit direction.
  for (const double tilt : {25.0, 15.0}) {
    const double t = tilt * kPi / 180;
    json c = {{"format", "dbbkit.design/1"},
              {"name", "tilted"},
              {"axis", "C"},
              {"angles_deg", {{"start", 0}, {"stop", 360}, {"step", 30}}},
              {"noise", {{"accuracy_um", 1.0}, {"distribution", "uniform"}}},
              {"installations",
               {{{"id", "1"},
                 {"ball_mm", {{"L", 100}, {"H", 200}}},
                 {"direction", {std::cos(t), 0.0, std::sin(t)}},
                 {"bar_mm", 100}}}}};
    std::ofstream(f) << c.dump(2);
    const Design d = io::read_design_file(f.string());
    if (tilt > kMaxBarBelowCup_deg) {
      try {
        measurement_program(d, ProgramOptions{});
        ADD_FAILURE() << "a bar 25 deg below its cup's plane: taken";
      } catch (const InputError& err) {
        EXPECT_EQ(err.where(), "installations[0].sign");
        EXPECT_NE(std::string(err.what()).find("the bar 25 deg below the plane of its cup"),
                  std::string::npos)
            << err.what();
      }
    } else {
      EXPECT_NO_THROW(measurement_program(d, ProgramOptions{}));
    }
  }
  std::filesystem::remove(f);
}

// A kit that names its machine: its frame, table and travel are the machine file's, and the
// search offers only designs the machine's program takes. A block fixed to the machine's frame
// where the best design's spindle ball stands at one reading: the program refuses that design on
// the machine with the block, and the search on that machine finds another that it takes.
TEST(MachineKit, TheSearchOnAMachineOffersOnlyWhatItsProgramTakes) {
  const std::string kit_file = test::source_path("designs/kits/a-c-trunnion-A-kit.json");
  json kj = json::parse(slurp(kit_file));
  // One step and one block: the three searches kept short.
  kj["angles_deg"]["steps"] = {15};
  kj["H_mm"]["blocks"] = {50, 100};
  kj["H_mm"]["max_stack"] = 1;
  kj["machine"] = test::source_path("designs/machines/a-c-trunnion.json");
  const Kit k = io::kit_from_json(kj, "kit.json");
  ASSERT_TRUE(k.machine);
  const Design a = io::read_design_file(design_path("a-c-trunnion-A"));
  EXPECT_EQ(axis_difference(k.axis, a.axis), "");
  EXPECT_EQ(k.table_normal, Eigen::Vector3d::UnitZ());
  EXPECT_DOUBLE_EQ(k.table_surface_mm, -60);  // the C table's surface, below the A axis
  const double travel[3][2] = {{-350, 350}, {-400, 400}, {-60, 450}};
  for (int i = 0; i < 3; ++i) {
    EXPECT_DOUBLE_EQ(k.travel_mm[i].min, travel[i][0]);
    EXPECT_DOUBLE_EQ(k.travel_mm[i].max, travel[i][1]);
  }
  ASSERT_TRUE(k.workspace && k.workspace->table_diameter_mm);
  EXPECT_DOUBLE_EQ(*k.workspace->table_diameter_mm, 420);
  // What comes from the machine is not stated twice; the axis under test is not parked.
  for (const auto& [key, value] : std::vector<std::pair<std::string, json>>{
           {"table", {{"normal", {0, 0, 1}}, {"surface_mm", -60}}},
           {"travel_mm", {{"x", {-1, 1}}, {"y", {-1, 1}}, {"z", {-1, 1}}}},
           {"park_deg", {{"A", 10}}}}) {
    json bad = kj;
    bad[key] = value;
    try {
      io::kit_from_json(bad, "kit.json");
      ADD_FAILURE() << key << ": taken";
    } catch (const InputError& e) {
      EXPECT_EQ(e.where(), key) << e.what();
    }
  }

  OptimizeOptions o;
  o.criterion = Criterion::kWorstTotal;
  o.threads = 2;
  const OptimizeResult r = optimize_kit(k, o);
  ASSERT_TRUE(r.best && r.best->feasible);
  const Design& best = r.best->design;
  ASSERT_TRUE(best.machine);
  for (const bool tcpm : {false, true}) {
    ProgramOptions po;
    po.tcpm = tcpm;
    EXPECT_NO_THROW(measurement_program(best, po)) << "tcpm " << tcpm;
  }

  // The block: 10 mm about the spindle ball of the first installation at its first reading.
  const MeasurementProgram p = measurement_program(best, ProgramOptions{});
  const Eigen::Vector3d at = best.machine->origin_mm() +
                             p.installations.front().sweeps.front().positions.front().linear_mm;
  json mj = json::parse(slurp(test::source_path("designs/machines/a-c-trunnion.json")));
  mj["workspace"]["solids"].push_back(
      {{"name", "fixture"},
       {"box_mm", {{at.x() - 5, at.y() - 5, at.z() - 5}, {at.x() + 5, at.y() + 5, at.z() + 5}}}});
  const auto dir = std::filesystem::temp_directory_path() / "dbbkit_machine_kit";
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "m.json") << mj.dump(2);
  Design blocked_best = best;
  blocked_best.machine->machine =
      std::make_shared<const Machine>(io::read_machine_file((dir / "m.json").string()));
  try {
    measurement_program(blocked_best, ProgramOptions{});
    ADD_FAILURE() << "the block was not met";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("lies inside 'fixture'"), std::string::npos) << e.what();
  }
  kj["machine"] = (dir / "m.json").string();
  const Kit blocked = io::kit_from_json(kj, "kit.json");
  const OptimizeResult rb = optimize_kit(blocked, o);
  ASSERT_TRUE(rb.best && rb.best->feasible);
  EXPECT_NO_THROW(measurement_program(rb.best->design, ProgramOptions{}));
  EXPECT_GE(rb.best->objective, r.best->objective * (1 - 1e-9));

  // From the command line: the design written elsewhere names the machine relative to itself,
  // and the program takes it.
  kj["machine"] = test::source_path("designs/machines/a-c-trunnion.json");
  std::filesystem::create_directories(dir / "out");
  std::ofstream(dir / "kit.json") << kj.dump(2);
  const std::string out = (dir / "out" / "best.json").string();
  CliRun c = run_cli("optimize --kit " + (dir / "kit.json").string() + " --out " + out +
                     " --quiet --threads 2");
  ASSERT_EQ(c.status, 0) << c.err;
  const json written = json::parse(slurp(out));
  EXPECT_EQ(written["axis"], "A");
  EXPECT_EQ(std::filesystem::path(written["machine"].get<std::string>()).is_relative(), true)
      << written["machine"];
  c = run_cli("program --design " + out + " --dialect heidenhain --tcpm on");
  EXPECT_EQ(c.status, 0) << c.err;
  std::filesystem::remove_all(dir);
}

TEST(MachineProgram, TcpmIsChosenAndNeedsAMachine) {
  const std::string a = design_path("a-c-trunnion-A");
  CliRun r = run_cli("program --design " + a + " --dialect sinumerik");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("--tcpm"), std::string::npos) << r.err;
  r = run_cli("program --design " + a + " --dialect sinumerik --tcpm on");
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("TRAORI"), std::string::npos);
  r = run_cli("program --design " + test::kDesignC + " --dialect iso --tcpm on");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("must name its machine"), std::string::npos) << r.err;
  // Without a machine, --tcpm off is today's program.
  const CliRun plain = run_cli("program --design " + test::kDesignC + " --dialect iso");
  r = run_cli("program --design " + test::kDesignC + " --dialect iso --tcpm off");
  EXPECT_EQ(r.status, 0);
  EXPECT_EQ(r.out, plain.out);
  // A head under TCPM: the ball must be the tool tip.
  json h = json::parse(slurp(design_path("paper-b-c-B")));
  h["installations"][0]["ball_mm"]["H"] = 20;
  h["machine"] = test::source_path("designs/machines/paper-b-c.json");
  const auto f = std::filesystem::temp_directory_path() / "dbbkit_tcpm_head.json";
  std::ofstream(f) << h.dump(2);
  r = run_cli("program --design " + f.string() + " --dialect iso --tcpm on");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("tool tip is the spindle ball"), std::string::npos) << r.err;
  r = run_cli("program --design " + f.string() + " --dialect iso --tcpm off");
  EXPECT_EQ(r.status, 0) << r.err;
  std::filesystem::remove(f);
}

}  // namespace
}  // namespace dbbkit

namespace dbbkit {
namespace {

// The README's five-axis example, run as it is written: every line of its output blocks printed.
TEST(Readme, AFiveAxisMachinePrintsWhatTheReadmeShows) {
  namespace fs = std::filesystem;
  const std::string section = readme_section("## Worked example: a five-axis machine");
  ASSERT_FALSE(section.empty());
  const fs::path dir = fs::temp_directory_path() / "dbbkit_readme_five_axis";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string src = DBBKIT_SOURCE_DIR;
  std::string printed;
  for (const std::string& cmd :
       {"program --design " + src +
            "/designs/a-c-trunnion-C.json --dialect heidenhain --tcpm on "
            "--out C.h",
        "simulate --design " + src + "/designs/a-c-trunnion-A.json --truth " + src +
            "/tests/data/truth_a_c_trunnion_A.json --out A.csv",
        "simulate --design " + src + "/designs/a-c-trunnion-C.json --truth " + src +
            "/tests/data/truth_a_c_trunnion_C.json --out C.csv",
        "identify --design " + src +
            "/designs/a-c-trunnion-A.json --data A.csv --out A.json --quiet",
        "identify --design " + src +
            "/designs/a-c-trunnion-C.json --data C.csv --out C.json --quiet",
        "chain --machine " + src + "/designs/machines/a-c-trunnion.json A.json C.json --out M.json",
        // A over the whole travel the machine allows.
        "simulate --design " + src + "/designs/a-c-trunnion-A-whole.json --truth " + src +
            "/tests/data/truth_a_c_trunnion_A.json --out Aw.csv",
        "identify --design " + src +
            "/designs/a-c-trunnion-A-whole.json --data Aw.csv --out Aw.json --quiet",
        "chain --machine " + src +
            "/designs/machines/a-c-trunnion.json Aw.json C.json --out MW.json",
        "predict --result M.json --at " + src + "/tests/data/poses_a_c_trunnion.csv",
        std::string("compensation --result M.json --format siemens --record 1 --out "
                    "trunnion.mpf"),
        // The paper's B/C machine: a tool tip in the head against a point on the table.
        "simulate --design " + src + "/designs/paper-b-c-B-off-axis.json --truth " + src +
            "/tests/data/truth_paper_b_c_B.json --out pB.csv",
        "simulate --design " + src + "/designs/paper-b-c-C.json --truth " + src +
            "/tests/data/truth_paper_b_c_C.json --out pC.csv",
        "identify --design " + src +
            "/designs/paper-b-c-B-off-axis.json --data pB.csv --out pB.json --quiet",
        "identify --design " + src +
            "/designs/paper-b-c-C.json --data pC.csv --out pC.json --quiet",
        "chain --machine " + src +
            "/designs/machines/paper-b-c.json pB.json pC.json --out PM.json --quiet",
        "predict --result PM.json --at " + src + "/tests/data/poses_paper_b_c.csv"}) {
    const CliRun r = run_cli_shell("cd " + dir.string() + " && " + DBBKIT_CLI + " " + cmd);
    ASSERT_EQ(r.status, 0) << cmd << "\n" << r.err;
    printed += r.out;
  }
  printed += slurp((dir / "C.h").string());
  printed += slurp((dir / "trunnion.mpf").string());
  int checked = 0;
  for (const std::string& line : readme_lines_not_printed(section, printed, false, checked))
    ADD_FAILURE() << "README line not printed:\n" << line;
  EXPECT_GE(checked, 64);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace dbbkit
