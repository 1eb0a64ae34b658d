// The part program, read back by a parser of its own (ISO words and Heidenhain blocks), is
// checked against the geometry of model.md written out here with std::sin and std::cos:
// every commanded following-ball position within 1 um of the nominal path, every reading at
// a design angle in sweep order, and the bar length along each interpolated move within the
// path tolerance.
#include "dbbkit/program.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <map>
#include <random>
#include <sstream>

#include "cli_util.hpp"
#include "dbbkit/error.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/program_io.hpp"
#include "dbbkit/kinematics.hpp"
#include "program_lines.hpp"
#include "test_util.hpp"

namespace dbbkit {
namespace {

using test::kPi;

// --- the geometry, independently of kinematics.cpp -------------------------------------
// formats.md's definitions: a positive angle turns by the right-hand rule about the direction;
// the ball at L reference + D (direction x reference) + H direction (the B shorthand: L along
// +Z, D along +Y).
Eigen::Matrix3d rotation(const AxisFrame& axis, double deg) {
  return Eigen::AngleAxisd(deg * kPi / 180, axis.direction()).toRotationMatrix();
}
// The ball (moving body) and the following ball at an angle, model frame.
Eigen::Vector3d ball(const AxisFrame& axis, const Installation& in, double deg) {
  const Eigen::Vector3d a = axis.direction(), r = axis.reference();
  const Eigen::Vector3d body =
      axis.shorthand() == "B" ? Eigen::Vector3d(0, in.D_mm, in.L_mm)
                              : Eigen::Vector3d(in.L_mm * r + in.D_mm * a.cross(r) + in.H_mm * a);
  return rotation(axis, deg) * body;
}
Eigen::Vector3d following(const AxisFrame& axis, const Installation& in, double deg) {
  return ball(axis, in, deg) - in.sign * *in.bar_mm * (rotation(axis, deg) * in.direction.body);
}

// --- the parser -------------------------------------------------------------------------
struct Commanded {
  std::string installation;
  double angle = 0;
  Eigen::Vector3d xyz;
  bool mounted = false;  // after the stop that mounts the bar
  bool rapid = false;
  std::string axes;        // the axes the block names: "Z", "XY", "C", "XYZC", ...
  Eigen::Vector3d before;  // the position before the block
};
struct Dwell {
  std::string installation;
  double angle = 0;
  Eigen::Vector3d xyz;
};
struct Parsed {
  std::vector<Commanded> moves;
  std::vector<Dwell> dwells;
  int mounts = 0, placements = 0;
  // Lines before the first motion block (the safe start, the tool and its length).
  std::vector<std::string> before_first_move;
  std::string first_move;
};

// The stop where the bar is mounted (an air run's: where it would be).
bool mount_stop(const std::string& comment) {
  return comment.find("mount the bar") != std::string::npos ||
         comment.find("check the gap") != std::string::npos;
}

Parsed parse(const std::string& text, io::Dialect dialect, char rotary) {
  Parsed out;
  std::istringstream in(text);
  std::string line, installation;
  double x = NAN, y = NAN, z = NAN, r = NAN;
  bool mounted = false;
  while (std::getline(in, line)) {
    const test::ProgramLine pl = test::program_line(line, dialect);
    const std::string &code = pl.code, &comment = pl.comment;
    const std::vector<std::string>& w = pl.words;
    if (const std::string id = test::opened_installation(comment); !id.empty()) {
      installation = id;
      mounted = false;
    }
    if (w.empty()) continue;
    bool motion = false, rapid = false;
    if (dialect == io::Dialect::kIso) {
      for (const std::string& t : w) {
        if (t == "G00" || t == "G01") motion = true, rapid = t == "G00";
        if (t == "M00" && mount_stop(comment)) {
          mounted = true;
          ++out.mounts;
        }
        if (t == "M00" && comment.find("place the table cup") != std::string::npos)
          ++out.placements;
        if (t == "G04") out.dwells.push_back({installation, r, {x, y, z}});
      }
    } else {
      motion = w[0] == "L";
      rapid = std::find(w.begin(), w.end(), "FMAX") != w.end();
      if (w[0] == "STOP" && mount_stop(comment)) {
        mounted = true;
        ++out.mounts;
      }
      if (w[0] == "STOP" && comment.find("place the table cup") != std::string::npos)
        ++out.placements;
      if (w.size() >= 4 && w[0] == "CYCL" && w[2] == "9.1")
        out.dwells.push_back({installation, r, {x, y, z}});
    }
    if (!motion) {
      if (out.first_move.empty()) out.before_first_move.push_back(code);
      continue;
    }
    if (out.first_move.empty()) out.first_move = code;
    const Eigen::Vector3d before(x, y, z);
    std::string axes;
    for (const std::string& t : w) {
      if (t.size() < 2) continue;
      const char a = t[0];
      if (a != 'X' && a != 'Y' && a != 'Z' && a != rotary) continue;
      if (t == "FMAX") continue;
      const double v = std::stod(t.substr(1));
      (a == 'X' ? x : a == 'Y' ? y : a == 'Z' ? z : r) = v;
      axes += a;
    }
    if (axes.empty()) continue;  // an M function with the block
    out.moves.push_back({installation, r, {x, y, z}, mounted, rapid, axes, before});
  }
  return out;
}

// --- random designs ----------------------------------------------------------------------
// The shorthands, a B head whose spindle points down at B0, an A trunnion, an A head pointing
// down and a primed C table.
const std::vector<AxisFrame>& program_frames() {
  using S = AxisFrame::Side;
  static const std::vector<AxisFrame> frames = {
      test::kAxisC,
      AxisFrame::general('B', S::kHead, Eigen::Vector3d::UnitY(), -Eigen::Vector3d::UnitZ(), false,
                         -180, 180),
      AxisFrame::general('A', S::kTable, Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitZ(), false,
                         -120, 120),
      AxisFrame::general('A', S::kHead, Eigen::Vector3d::UnitX(), -Eigen::Vector3d::UnitZ(), false,
                         -120, 120),
      AxisFrame::general('C', S::kTable, -Eigen::Vector3d::UnitZ(), Eigen::Vector3d::UnitX(),
                         true)};
  return frames;
}

// Whether the bar stays within kMaxBarBelowCup_deg below the table ball's cup over the design's
// arc (sampled every 0.5 deg, with a margin for the samples between): the table faces +Z, on the
// "B" shorthand -Z (its reference, the spindle at B0); a table not about Z states no face.
bool clear_of_cup(const AxisFrame& axis, const Installation& in, const std::vector<double>& deg) {
  if (axis.table() && axis.machine_axis() != 2) return true;
  const Eigen::Vector3d up =
      axis.shorthand() == "B" ? Eigen::Vector3d(0, 0, -1) : Eigen::Vector3d::UnitZ();
  const double lo = *std::min_element(deg.begin(), deg.end());
  const double hi = *std::max_element(deg.begin(), deg.end());
  for (double a = lo; a <= hi + 1e-9; a += 0.5) {
    const Eigen::Vector3d v =
        (axis.table() ? -1.0 : 1.0) * in.sign *
        (Eigen::AngleAxisd(a * kPi / 180, axis.direction()) * in.direction.body);
    if (-v.dot(up) > std::sin((kMaxBarBelowCup_deg - 1) * kPi / 180)) return false;
  }
  return true;
}

Design random_design(std::mt19937_64& rng, const AxisFrame& axis) {
  std::uniform_real_distribution<double> U(0, 1);
  Design d;
  d.name = "random";
  d.axis = axis;
  const double step = std::vector<double>{5, 10, 15, 20, 30, 45}[rng() % 6];
  const double start = axis.full_turn() ? 0 : -120 + 5 * static_cast<int>(rng() % 8);
  const int steps = axis.full_turn() ? static_cast<int>(std::lround(360 / step))
                                     : std::max(2, static_cast<int>(std::lround(100 / step)));
  for (int k = 0; k <= steps; ++k) d.angles_deg.push_back(start + k * step);
  const int n = 1 + static_cast<int>(rng() % 5);
  for (int i = 0; i < n; ++i) {
    // Drawn again until a side keeps the bar out of the table ball's cup.
    Installation in;
    for (;;) {
      in.id = "i" + std::to_string(i);
      in.L_mm = 20 + 380 * U(rng);
      in.D_mm = U(rng) < 0.5 ? 0 : -100 + 200 * U(rng);
      in.H_mm = axis.table() ? 20 + 300 * U(rng) : 0;
      const int kind = static_cast<int>(rng() % 4);
      if (kind < 3) {
        in.direction = Direction::named(axis, static_cast<Direction::Kind>(kind));
      } else {
        Eigen::Vector3d v(U(rng) - 0.5, U(rng) - 0.5, U(rng) - 0.5);
        in.direction = Direction::vector(v.normalized());
      }
      in.sign = U(rng) < 0.5 ? 1 : -1;
      // A head's table ball lies beyond the tool tip (validate_design).
      if (!table_ball_beyond_tool(axis, in.direction, in.sign)) in.sign = -in.sign;
      in.bar_mm = std::vector<double>{100, 150, 250, 300, 400}[rng() % 5];
      // On the C shorthand the spindle ball stays above the table surface (program.hpp): the turn
      // about Z keeps its height H - sign bar u_z.
      if (axis.shorthand() == "C" && in.H_mm - in.sign * *in.bar_mm * in.direction.body.z() < 0)
        in.sign = -in.sign;
      if (clear_of_cup(axis, in, d.angles_deg)) break;
      in.sign = -in.sign;
      if (table_ball_beyond_tool(axis, in.direction, in.sign) &&
          (axis.shorthand() != "C" ||
           in.H_mm - in.sign * *in.bar_mm * in.direction.body.z() >= 0) &&
          clear_of_cup(axis, in, d.angles_deg))
        break;
    }
    d.installations.push_back(in);
  }
  return d;
}

TEST(Program, CommandedPositionsFollowTheNominalPathInBothDialectsAndAxes) {
  std::mt19937_64 rng(20261125);
  int designs = 0, moves = 0;
  for (int trial = 0; trial < 40; ++trial) {
    const AxisFrame& axis = program_frames()[trial % program_frames().size()];
    const Design d = random_design(rng, axis);
    ProgramOptions o;
    o.sweeps = static_cast<ProgramOptions::Sweeps>(rng() % 3);
    o.path_tolerance_mm = std::vector<double>{0.01, 0.05, 0.2}[rng() % 3];
    const MeasurementProgram program = measurement_program(d, o);
    for (const io::Dialect dialect : {io::Dialect::kIso, io::Dialect::kHeidenhain}) {
      const char rotary = axis.letter();
      const Parsed p = parse(io::program_text(d, program, dialect), dialect, rotary);
      ASSERT_EQ(p.mounts, static_cast<int>(d.installations.size()));
      // The commanded point against the nominal path, and the table ball's position for B.
      std::map<std::string, Eigen::Vector3d> table_ball;
      // The positions of the measurement: every move of all axes at once, and where the bar is
      // mounted (the end of the descent before it).
      for (const Commanded& m : p.moves) {
        const bool measuring =
            m.axes.size() == 4 || (m.mounted && m.axes == "Z" && !m.rapid &&
                                   &m != &p.moves.back() && (&m + 1)->axes.size() == 4);
        if (!measuring) continue;
        const Installation& in = d.installations[d.find_installation(m.installation)];
        const Eigen::Vector3d F = following(axis, in, m.angle);
        if (axis.table()) {
          EXPECT_LE((m.xyz - F).norm(), 1e-3) << m.installation << " at " << m.angle;
        } else {
          // The pivot Q and the table ball T: T - Q = F; the table ball at the work frame's
          // origin for every installation.
          const Eigen::Vector3d T = m.xyz + F;
          table_ball.emplace(m.installation, T);
          EXPECT_LE(T.norm(), 1e-3) << m.installation << " at " << m.angle;
        }
        ++moves;
      }
      // Readings: the design's angles, in sweep order, at mounted positions.
      std::map<std::string, std::vector<double>> read;
      for (const Dwell& dw : p.dwells) read[dw.installation].push_back(dw.angle);
      std::vector<double> ccw = d.angles_deg, cw(ccw.rbegin(), ccw.rend()), expect;
      if (o.sweeps != ProgramOptions::Sweeps::kCW) expect = ccw;
      if (o.sweeps != ProgramOptions::Sweeps::kCCW)
        expect.insert(expect.end(), cw.begin(), cw.end());
      for (const Installation& in : d.installations) {
        ASSERT_EQ(read[in.id].size(), expect.size()) << in.id;
        for (size_t k = 0; k < expect.size(); ++k) EXPECT_NEAR(read[in.id][k], expect[k], 1e-9);
      }
      // The bar along each interpolated move (mounted, within one installation).
      for (size_t k = 1; k < p.moves.size(); ++k) {
        const Commanded &a = p.moves[k - 1], &b = p.moves[k];
        if (!a.mounted || !b.mounted || a.installation != b.installation || b.axes.size() != 4)
          continue;
        const Installation& in = d.installations[d.find_installation(a.installation)];
        for (int j = 1; j < 10; ++j) {
          const double t = j / 10.0, ang = a.angle + t * (b.angle - a.angle);
          const Eigen::Vector3d q = a.xyz + t * (b.xyz - a.xyz);
          // C: the spindle ball at q; B: the head ball at q + P, the table ball fixed.
          const double bar = axis.table()
                                 ? (ball(axis, in, ang) - q).norm()
                                 : (ball(axis, in, ang) + q - table_ball[a.installation]).norm();
          EXPECT_LE(std::abs(bar - *in.bar_mm), o.path_tolerance_mm + 1e-3)
              << in.id << " between " << a.angle << " and " << b.angle;
        }
      }
    }
    ++designs;
  }
  EXPECT_EQ(designs, 40);
  EXPECT_GT(moves, 1000);
}

// What a careful operator checks before running a program: the safe start and the tool length
// before the first move; every sideways rapid at the clearance plane with Z alone moved in
// rapid and only upwards to it; every descent along Z alone at the feed; the bar mounted after
// a descent; the cup placed once per ball position (B: once).
void expect_safe(const Design& d, const MeasurementProgram& program, io::Dialect dialect) {
  const AxisFrame& axis = d.axis;
  const ProgramOptions& o = program.options;
  const double zc = program.clearance_z_mm;
  const std::string tool = std::to_string(o.tool_number);
  const bool iso = dialect == io::Dialect::kIso;
  const std::string text = io::program_text(d, program, dialect);
  const Parsed p = parse(text, dialect, axis.letter());
  std::string start;
  for (const std::string& l : p.before_first_move) start += l + "\n";
  for (const char* must :
       iso ? std::vector<const char*>{"G17 G21 G40 G49 G69 G80 G90 G94", "M05", "M09", "G54"}
           : std::vector<const char*>{"PLANE RESET STAY", "FUNCTION TCPM RESET"})
    EXPECT_NE(start.find(must), std::string::npos) << must << "\n" << start;
  EXPECT_NE(start.find(iso ? "T" + tool + " M06" : "TOOL CALL " + tool + " Z"), std::string::npos)
      << start;
  ASSERT_FALSE(p.moves.empty());
  // A design that names its machine turns its rotary axes first (machine_test.cpp checks every
  // one of them); the first linear move is Z alone to the plane, with the tool length.
  const auto first_linear = std::find_if(p.moves.begin(), p.moves.end(), [&](const Commanded& m) {
    return m.axes.find_first_of("XYZ") != std::string::npos;
  });
  ASSERT_NE(first_linear, p.moves.end());
  if (!d.machine) {
    EXPECT_EQ(first_linear, p.moves.begin());
    if (iso) EXPECT_NE(p.first_move.find("G43 H" + tool), std::string::npos) << p.first_move;
  }
  EXPECT_NEAR(first_linear->xyz.z(), zc, 1e-4);
  EXPECT_EQ(first_linear->axes, "Z");
  int descents = 0;
  for (const Commanded& m : p.moves) {
    if (&m < &*first_linear) {
      EXPECT_EQ(m.axes.find_first_of("XYZ"), std::string::npos);  // the rotary axes first
      continue;
    }
    if (m.rapid) {
      // Sideways or rotary only at the plane; Z alone, and only up to the plane.
      if (m.axes == "Z") {
        EXPECT_NEAR(m.xyz.z(), zc, 1e-4);
        if (!std::isnan(m.before.z())) EXPECT_GE(m.xyz.z(), m.before.z() - 1e-4);
      } else {
        EXPECT_EQ(m.axes.find('Z'), std::string::npos) << m.axes;
        EXPECT_NEAR(m.before.z(), zc, 1e-4) << "a rapid " << m.axes << " off the plane";
      }
    } else if (m.axes == "Z") {
      ++descents;
      EXPECT_EQ(m.before.x(), m.xyz.x());
      EXPECT_EQ(m.before.y(), m.xyz.y());
    }
    // The measurement's moves run below the plane.
    if (m.axes.size() == 4) EXPECT_LT(m.xyz.z(), zc);
  }
  EXPECT_EQ(p.mounts, static_cast<int>(d.installations.size()));
  // The ball positions in the program's order (the set-up sheet's): a cup placed at each change.
  int positions = 1;
  for (size_t k = 1; k < program.installations.size(); ++k) {
    const Installation& a = d.installations[program.installations[k - 1].installation];
    const Installation& b = d.installations[program.installations[k].installation];
    positions += (ball_body_mm(axis, a) - ball_body_mm(axis, b)).norm() > kAssemblyTolerance_mm;
  }
  EXPECT_EQ(p.placements, axis.table() ? positions : 1);
  // Down to each placement and each mounting, up after each: two feeds along Z apiece.
  EXPECT_EQ(descents, 2 * (p.placements + static_cast<int>(d.installations.size())));
  EXPECT_NE(text.find(o.air_run ? "AIR RUN" : "mount the bar"), std::string::npos);
  // Every angle the comments name is the design's own axis (an A/C trunnion has a C axis too).
  for (const char other : {'A', 'B', 'C'}) {
    if (other == axis.letter()) continue;
    EXPECT_EQ(text.find(std::string(" at ") + other + "0"), std::string::npos) << other;
    EXPECT_EQ(text.find(std::string(1, other) + "+ turns"), std::string::npos) << other;
  }
  if (o.air_run) EXPECT_EQ(text.find("mount the bar"), std::string::npos);
}

TEST(Program, SafeStartToolLengthAndClearanceMovesInBothDialects) {
  std::mt19937_64 rng(20261126);
  for (int trial = 0; trial < 20; ++trial) {
    const AxisFrame& axis = program_frames()[trial % program_frames().size()];
    const Design d = random_design(rng, axis);
    ProgramOptions o;
    o.air_run = rng() % 2;
    o.tool_number = 1 + static_cast<int>(rng() % 200);
    const MeasurementProgram program = measurement_program(d, o);
    for (const io::Dialect dialect : {io::Dialect::kIso, io::Dialect::kHeidenhain})
      expect_safe(d, program, dialect);
  }
}

TEST(Program, AnInstallationWithoutABarIsRefusedByName) {
  Design d = io::read_design_file(DBBKIT_SOURCE_DIR "/designs/paper-c-turntable.json");
  d.installations[2].bar_mm.reset();
  try {
    measurement_program(d, ProgramOptions{});
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.where(), "installations[2].bar_mm");
    EXPECT_NE(e.detail().find("1a"), std::string::npos);
  }
}

// On the C shorthand the work frame's origin is on the table surface: a following ball below it
// (an axial bar hanging down from the table ball) is refused by name, never written.
TEST(Program, ASpindleBallBelowTheTableSurfaceIsRefused) {
  Design d = io::read_design_file(DBBKIT_SOURCE_DIR "/designs/paper-c-turntable.json");
  const int a = d.find_installation("1a");
  ASSERT_EQ(d.installations[a].sign, -1);
  EXPECT_NO_THROW(measurement_program(d, ProgramOptions{}));
  d.installations[a].sign = 1;
  try {
    measurement_program(d, ProgramOptions{});
    FAIL() << "written";
  } catch (const InputError& e) {
    EXPECT_EQ(e.where(), "installations[" + std::to_string(a) + "].sign");
    EXPECT_NE(e.detail().find("Z -90 mm, below the table surface"), std::string::npos)
        << e.detail();
  }
}

TEST(Program, OptionsOutsideTheirLimitsAreRefused) {
  const Design d = io::read_design_file(DBBKIT_SOURCE_DIR "/designs/paper-c-turntable.json");
  for (auto set : {+[](ProgramOptions& o) { o.dwell_s = 0; },
                   +[](ProgramOptions& o) { o.feed_mm_per_min = NAN; },
                   +[](ProgramOptions& o) { o.path_tolerance_mm = 2; },
                   // The command line's and Python's edges are the library's: a dwell of
                   // 0.5 ms or a feed of 0.5 mm/min, refused there, is refused here too.
                   +[](ProgramOptions& o) { o.dwell_s = 5e-4; },
                   +[](ProgramOptions& o) { o.feed_mm_per_min = 0.5; },
                   +[](ProgramOptions& o) { o.clearance_margin_mm = 0.5; }}) {
    ProgramOptions o;
    set(o);
    EXPECT_THROW(measurement_program(d, o), InputError);
  }
  for (auto set :
       {+[](ProgramOptions& o) { o.dwell_s = 1e-3; }, +[](ProgramOptions& o) { o.dwell_s = 600; },
        +[](ProgramOptions& o) { o.feed_mm_per_min = 1; }}) {
    ProgramOptions o;
    set(o);
    EXPECT_NO_THROW(measurement_program(d, o));
  }
}

// A clearance plane given below the highest point the program reaches plus the margin would
// send the sideways rapids through the table and the balls (--clearance-z-mm -5 was written as
// given): refused, naming the option, the value and the least plane; at the least, taken.
TEST(Program, AClearancePlaneBelowTheHighestPointIsRefused) {
  const Design d = io::read_design_file(DBBKIT_SOURCE_DIR "/designs/paper-c-turntable.json");
  const double lowest = measurement_program(d, ProgramOptions{}).clearance_z_mm;
  ProgramOptions o;
  o.clearance_z_mm = -5;
  try {
    measurement_program(d, o);
    ADD_FAILURE() << "a plane at Z -5 was taken";
  } catch (const InputError& e) {
    EXPECT_EQ(e.source(), "--clearance-z-mm");
    std::ostringstream least;
    least << std::setprecision(6) << lowest;
    EXPECT_NE(e.detail().find("Z -5 mm is below the lowest safe clearance plane, Z " + least.str() +
                              " mm"),
              std::string::npos)
        << e.detail();
    EXPECT_NE(e.detail().find("plus --clearance-margin-mm 50 mm"), std::string::npos) << e.detail();
  }
  o.clearance_z_mm = lowest;
  EXPECT_EQ(measurement_program(d, o).clearance_z_mm, lowest);
  o.clearance_z_mm = lowest + 100;
  EXPECT_EQ(measurement_program(d, o).clearance_z_mm, lowest + 100);
  const CliRun r = run_cli("program --design " DBBKIT_SOURCE_DIR
                           "/designs/paper-c-turntable.json --dialect iso --clearance-z-mm -5");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("--clearance-z-mm: Z -5 mm is below"), std::string::npos) << r.err;
  EXPECT_TRUE(r.out.empty()) << r.out;
}

// Only the spindle orientation code is taken: another M-code (M3 starts the spindle, M8 the
// coolant) would be written where the cup sits in the spindle.
TEST(Program, OnlyTheOrientationCodeOrientsTheSpindle) {
  const Design d = io::read_design_file(DBBKIT_SOURCE_DIR "/designs/paper-c-turntable.json");
  for (const char* code : {"M3", "M03", "M04", "M8", "M30", "M190", "m19", "M19 ", "G19"}) {
    ProgramOptions o;
    o.orient_code = code;
    try {
      measurement_program(d, o);
      ADD_FAILURE() << code << " was taken";
    } catch (const InputError& e) {
      EXPECT_EQ(e.where(), "orient_code") << code;
    }
  }
  for (const char* code : {"M19", ""}) {
    ProgramOptions o;
    o.orient_code = code;
    EXPECT_NO_THROW(measurement_program(d, o)) << code;
  }
}

TEST(Program, FinerPathToleranceSplitsStepsFurtherAndStaysWithinIt) {
  const Design d = io::read_design_file(DBBKIT_SOURCE_DIR "/designs/paper-c-turntable.json");
  size_t previous = 0;
  for (double tol : {0.5, 0.05, 0.005}) {
    ProgramOptions o;
    o.path_tolerance_mm = tol;
    const MeasurementProgram p = measurement_program(d, o);
    size_t positions = 0;
    for (const InstallationProgram& ip : p.installations) {
      EXPECT_LE(ip.largest_bar_change_mm, tol);
      for (const ProgramSweep& s : ip.sweeps) positions += s.positions.size();
    }
    EXPECT_GT(positions, previous) << tol;
    previous = positions;
    EXPECT_EQ(p.readings, 7 * 19);
  }
}

}  // namespace
}  // namespace dbbkit

namespace dbbkit {
namespace {

// Every committed design has a program in both dialects, read back with one reading per
// installation, angle of that installation and sweep.
TEST(ProgramCli, EveryCommittedDesignHasAProgramInBothDialects) {
  int designs = 0, refused = 0;
  for (const auto& entry : std::filesystem::directory_iterator(DBBKIT_SOURCE_DIR "/designs")) {
    if (entry.path().extension() != ".json") continue;
    const Design d = io::read_design_file(entry.path().string());
    if (d.axis.shorthand() == "B") {
      // The "B" shorthand's spindle points +Z at B0: its retracts would run through the table
      // ball, so no program is written (the general form with the spindle down is).
      const CliRun r = run_cli("program --design " + entry.path().string() + " --dialect iso");
      EXPECT_EQ(r.status, 2) << entry.path();
      EXPECT_NE(r.err.find("axis: the design's frame has the spindle pointing +Z at B0"),
                std::string::npos)
          << r.err;
      ++refused;
      continue;
    }
    for (const std::string dialect : {"iso", "heidenhain"}) {
      const CliRun r = run_cli("program --design " + entry.path().string() + " --dialect " +
                               dialect + " --sweeps both" + (d.machine ? " --tcpm off" : ""));
      ASSERT_EQ(r.status, 0) << entry.path() << r.err;
      const Parsed p = parse(r.out, dialect == "iso" ? io::Dialect::kIso : io::Dialect::kHeidenhain,
                             d.axis.letter());
      EXPECT_EQ(p.dwells.size(), 2 * static_cast<std::size_t>(d.readings_per_round()))
          << entry.path();
      EXPECT_EQ(p.mounts, static_cast<int>(d.installations.size()));
    }
    ProgramOptions o;
    o.sweeps = ProgramOptions::Sweeps::kBoth;
    for (const io::Dialect dialect : {io::Dialect::kIso, io::Dialect::kHeidenhain})
      expect_safe(d, measurement_program(d, o), dialect);
    ++designs;
  }
  EXPECT_GE(designs, 8);
  EXPECT_EQ(refused, 3);  // paper-b-head and the two optimized B-head designs
}

TEST(ProgramCli, WholeNumbersWithLeadingZerosAreDecimal) {
  // An O-number or a tool written with leading zeros (O0010, T012) is that decimal number, never
  // the octal one the option parser would otherwise read (T012 would call tool 10).
  const std::string c = DBBKIT_SOURCE_DIR "/designs/paper-c-turntable.json";
  CliRun r = run_cli("program --design " + c + " --dialect iso --program-number 0010 --tool 012");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("O0010"), std::string::npos) << r.out.substr(0, 300);
  EXPECT_NE(r.out.find("T12 M06"), std::string::npos) << r.out.substr(0, 600);
  EXPECT_EQ(r.out.find("T10 M06"), std::string::npos);
  // Hexadecimal and signs beyond the range stay refused, naming the option.
  for (const char* bad : {"0x10", "1e1", "10.0", "-0"}) {
    r = run_cli("program --design " + c + " --dialect iso --tool " + bad);
    EXPECT_EQ(r.status, 2) << bad;
    EXPECT_NE(r.err.find("--tool"), std::string::npos) << bad << ": " << r.err;
  }
  // The swivel data record's number likewise (it was read by CLI11's own range: 0x10 was 16).
  r = run_cli("compensation --result " DBBKIT_SOURCE_DIR
              "/reports/paper-c-turntable-diagnose.json --format siemens --record 0x10");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("--record"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("is not a whole number"), std::string::npos) << r.err;
}

TEST(ProgramCli, BadRequestsExitTwoSayingWhy) {
  const std::string c = DBBKIT_SOURCE_DIR "/designs/paper-c-turntable.json";
  // Retired: a spindle pointing down is the design's frame, so that identify models it too.
  CliRun r = run_cli("program --design " + c + " --dialect iso --tool-down");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("--tool-down is retired"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("\"reference\": [0, 0, -1]"), std::string::npos) << r.err;
  r = run_cli("program --design " + c + " --dialect fanuc");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("--dialect"), std::string::npos) << r.err;
  r = run_cli("program --design " + c + " --dialect iso --path-tolerance-mm 0");
  EXPECT_EQ(r.status, 2);
  // An O-number is an ISO program's: asked of another dialect it is refused, not dropped.
  for (const std::string dialect : {"heidenhain", "sinumerik"}) {
    r = run_cli("program --design " + c + " --dialect " + dialect + " --program-number 7");
    EXPECT_EQ(r.status, 2) << dialect;
    EXPECT_NE(r.err.find("--program-number"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("an O-number is an ISO program's; a " + dialect), std::string::npos)
        << r.err;
    EXPECT_TRUE(r.out.empty()) << r.out.substr(0, 200);
  }
  // A design without a bar: the file and the key are named.
  const auto dir = std::filesystem::temp_directory_path() / "dbbkit_program_test";
  std::filesystem::create_directories(dir);
  std::string text = slurp(c);
  const std::string bar = ",\n      \"bar_mm\": 150\n";
  text.replace(text.find(bar), bar.size(), "\n");
  const std::string nobar = (dir / "nobar.json").string();
  std::ofstream(nobar) << text;
  r = run_cli("program --design " + nobar + " --dialect heidenhain");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find(nobar), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("installations[0].bar_mm"), std::string::npos) << r.err;
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace dbbkit
