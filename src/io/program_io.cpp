#include "dbbkit/io/program_io.hpp"

#include <cmath>
#include <cstdio>
#include <sstream>
#include <vector>

#include "dbbkit/error.hpp"
#include "dbbkit/io/escape.hpp"
#include "dbbkit/io/text.hpp"
#include "dbbkit/kinematics.hpp"
#include "dbbkit/limits.hpp"
#include "dbbkit/machine.hpp"

namespace dbbkit::io {

namespace {

// A coordinate with 4 decimals; a value that rounds to zero is written as 0 (never -0).
std::string coord(double x, bool plus_sign) {
  const double r = std::round(x * 1e4) / 1e4;
  char buf[64];
  std::snprintf(buf, sizeof buf, plus_sign ? "%+.4f" : "%.4f", r == 0 ? 0.0 : r);
  return buf;
}

// The most characters of one text in a program's comments (a description): at most four
// comment lines.
constexpr std::size_t kMaxCommentText = 4 * kProgramCommentLine;

// A comment's text (escape.hpp) in lines of at most kProgramCommentLine characters, broken at
// spaces where it can be.
std::vector<std::string> comment_lines(const std::string& text) {
  std::vector<std::string> lines;
  std::string rest = program_comment(text, kMaxCommentText);
  while (rest.size() > kProgramCommentLine) {
    size_t cut = rest.rfind(' ', kProgramCommentLine);
    if (cut == std::string::npos || cut == 0) cut = kProgramCommentLine;
    lines.push_back(rest.substr(0, cut));
    rest = rest.substr(cut + (rest[cut] == ' ' ? 1 : 0));
  }
  lines.push_back(rest);
  return lines;
}

// One line of code per call; the moves a control makes, each on its own line:
//   rapid_z / feed_z:    along Z alone (the clearance plane and the descents to it),
//   rapid_rotary:        the rotary axis alone,
//   rapid_xy:            sideways, at the plane,
//   move:                X Y Z and the rotary axis together at the feed (the measurement).
class Writer {
 public:
  Writer(Dialect d, char rotary) : dialect_(d), rotary_(rotary) {}

  void comment(const std::string& text) {
    for (const std::string& l : comment_lines(text)) {
      if (dialect_ == Dialect::kIso)
        line("(" + l + ")");
      else
        line("; " + l);
    }
  }
  // Every rotary axis given, in one block at rapid.
  // `m`: an M function the block carries (Heidenhain), or empty.
  void rapid_rotaries(const std::vector<DesignMachine::AxisAngle>& axes,
                      const std::string& m = "") {
    std::string words;
    for (const DesignMachine::AxisAngle& p : axes)
      words += std::string(words.empty() ? "" : " ") + p.letter + coord(p.angle_deg, plus());
    rapid(words, m);
  }
  void raw(const std::string& text) { line(text); }
  void rapid_z(double z) { rapid("Z" + coord(z, plus())); }
  void feed_z(double z, double feed) { feed_move("Z" + coord(z, plus()), feed); }
  void rapid_rotary(double angle) { rapid(std::string(1, rotary_) + coord(angle, plus())); }
  void rapid_xy(const Eigen::Vector3d& p) {
    rapid("X" + coord(p.x(), plus()) + " Y" + coord(p.y(), plus()));
  }
  void move(const Eigen::Vector3d& p, double angle, double feed) {
    feed_move(xyz(p) + " " + rotary_ + coord(angle, plus()), feed);
  }
  void stop(const std::string& why) {
    if (dialect_ == Dialect::kIso)
      line("M00 (" + program_comment(why, kProgramMessage) + ")");
    else if (dialect_ == Dialect::kSinumerik)
      line("M0 ; " + program_comment(why, kProgramMessage));
    else
      line("STOP ; " + program_comment(why, kProgramMessage));
  }
  void dwell(double seconds, const std::string& why) {
    if (dialect_ == Dialect::kIso) {
      line("G04 P" + std::to_string(static_cast<long long>(std::lround(seconds * 1000))) + " (" +
           program_comment(why, kProgramMessage) + ")");
    } else if (dialect_ == Dialect::kSinumerik) {
      line("G4 F" + fmt_rounded(seconds, 3) + " ; " + program_comment(why, kProgramMessage));
    } else {
      line("CYCL DEF 9.0 DWELL TIME ; " + program_comment(why, kProgramMessage));
      line("CYCL DEF 9.1 DWELL " + fmt_rounded(seconds, 3));
    }
  }
  // Tool-centre-point control on and off (the tool's length register stays the same).
  void tcpm(bool on, const std::string& tool) {
    if (dialect_ == Dialect::kIso)
      line((on ? "G43.4 H" : "G43 H") + tool);
    else if (dialect_ == Dialect::kSinumerik)
      line(on ? "TRAORI" : "TRAFOOF");
    else
      line(on ? "FUNCTION TCPM F TCP AXIS POS PATHCTRL AXIS" : "FUNCTION TCPM RESET");
  }
  std::string text() const { return out_.str(); }

 private:
  static std::string f(double feed) {
    return std::to_string(static_cast<long long>(std::lround(feed)));
  }
  bool plus() const { return dialect_ == Dialect::kHeidenhain; }
  void rapid(const std::string& words, const std::string& m = "") {
    if (dialect_ == Dialect::kIso)
      line("G00 " + words + (m.empty() ? "" : " " + m));
    else if (dialect_ == Dialect::kSinumerik)
      line("G0 " + words + (m.empty() ? "" : " " + m));
    else
      line("L " + words + " R0 FMAX" + (m.empty() ? "" : " " + m));
  }
  void feed_move(const std::string& words, double feed) {
    if (dialect_ == Dialect::kIso)
      line("G01 " + words + " F" + f(feed));
    else if (dialect_ == Dialect::kSinumerik)
      line("G1 " + words + " F" + f(feed));
    else
      line("L " + words + " R0 F" + f(feed));
  }
  std::string xyz(const Eigen::Vector3d& p) const {
    std::string s = "X";
    s.append(coord(p.x(), plus())).append(" Y").append(coord(p.y(), plus()));
    return s.append(" Z").append(coord(p.z(), plus()));
  }
  void line(const std::string& s) {
    if (dialect_ == Dialect::kHeidenhain) out_ << number_++ << " ";
    out_ << s << "\n";
  }
  Dialect dialect_;
  char rotary_;
  std::ostringstream out_;
  int number_ = 0;
};

std::string heidenhain_name(const std::string& name) {
  std::string s;
  for (char c : name) {
    const bool ok = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9');
    s += ok ? c : '_';
  }
  if (s.empty()) s = "DBB";
  return s.substr(0, 24);
}

std::string program_ball_text(const AxisFrame& axis, const Installation& inst) {
  std::string s =
      "ball L " + fmt_rounded(inst.L_mm, 4) + " mm, D " + fmt_rounded(inst.D_mm, 4) + " mm";
  if (axis.has_H()) s += ", H " + fmt_rounded(inst.H_mm, 4) + " mm";
  return s;
}

// How the rotating body turns for a positive (or negative) step, seen from the tip of the
// axis' direction: counter-clockwise (right-hand rule) for a positive one.
std::string sense_text(const AxisFrame& axis, bool positive) {
  return std::string(positive ? "counter-clockwise" : "clockwise") + " seen from " +
         direction_text(axis.direction());
}

std::string xyz_text(const Eigen::Vector3d& p) {
  return "X" + coord(p.x(), false) + " Y" + coord(p.y(), false) + " Z" + coord(p.z(), false);
}

// How the table's cup goes on (the set-up sheet says the same, installation_placement).
std::string placement_text(const Design& d, const Installation& inst) {
  std::string what = "the table cup";
  if (d.axis.table() && !inst.blocks_mm.empty()) {
    what += " on blocks";
    for (double b : inst.blocks_mm) what += " " + fmt_rounded(b, 3);
    what += " mm";
  }
  return "place " + what +
         " under the spindle ball: seat its ball against the spindle cup "
         "(the setting ball between them), lock its base, remove the setting ball";
}

}  // namespace

std::optional<Dialect> dialect_named(const std::string& name) {
  if (name == "iso") return Dialect::kIso;
  if (name == "heidenhain") return Dialect::kHeidenhain;
  if (name == "sinumerik") return Dialect::kSinumerik;
  return std::nullopt;
}

std::optional<std::string> program_number_refusal(Dialect dialect) {
  switch (dialect) {
    case Dialect::kIso:
      return std::nullopt;
    case Dialect::kHeidenhain:
      return "an O-number is an ISO program's; a heidenhain program is named by its BEGIN PGM "
             "line: leave the number out";
    case Dialect::kSinumerik:
      return "an O-number is an ISO program's; a sinumerik program is named by its file: leave "
             "the number out";
  }
  return std::nullopt;
}

std::string program_text(const Design& design, const MeasurementProgram& program, Dialect dialect,
                         int program_number) {
  // A program's Z is the machine's, up, away from the table: a head's frame whose spindle points
  // up at the axis' zero (the "B" shorthand's, the paper's convention) would send every retract
  // and the clearance plane through the table ball.
  if (const std::optional<Eigen::Vector3d> tool = head_tool_direction(design.axis, design.machine);
      !design.machine && tool && tool->z() > 1e-9)
    throw InputError("design", "axis",
                     "the design's frame has the spindle pointing " + direction_text(*tool) +
                         " at " + std::string(1, design.axis.letter()) +
                         "0 (the reference; the \"B\" shorthand's convention): a program "
                         "commands a machine whose Z points up, away from the table, so its "
                         "retracts and clearance plane would run through the table ball; write "
                         "the axis in the general form with the spindle pointing down "
                         "(\"reference\": [0, 0, -1]) or name the machine");

  if (program_number < limits::kMinProgramNumber || program_number > limits::kMaxProgramNumber)
    throw InputError("--program-number", "",
                     "an O-number is " + std::to_string(limits::kMinProgramNumber) + ".." +
                         std::to_string(limits::kMaxProgramNumber));
  const bool c = program.axis.table();
  const char rotary = program.axis.letter();
  const ProgramOptions& o = program.options;
  const double zc = program.clearance_z_mm;
  Writer w(dialect, rotary);
  const bool iso = dialect == Dialect::kIso;
  const std::string name = heidenhain_name(design.name);
  const std::string tool = std::to_string(o.tool_number);
  const bool sinumerik = dialect == Dialect::kSinumerik;
  const bool tcpm = o.tcpm;
  // A head under TCPM: every position is the tool tip (the spindle ball) in the workpiece frame,
  // TCPM on from the parks to the end; a table under TCPM: on for each sweep only.
  const bool tcpm_throughout = tcpm && !c;
  if (iso) {
    w.raw("%");
    char o_number[16];
    std::snprintf(o_number, sizeof o_number, "O%04d", program_number);
    w.raw(std::string(o_number) + " (DBB MEASUREMENT " +
          program_comment(design.name, kProgramMessage) + ")");
  } else if (!sinumerik) {
    w.raw("BEGIN PGM " + name + " MM");
  }
  std::vector<std::string> head = {
      std::string(o.air_run ? "AIR RUN (no bar) of the " : "") +
          "dbbkit measurement program of design " + design.name + ", axis " + program.axis.label() +
          ", " + std::to_string(program.installations.size()) + " installations, " +
          std::to_string(program.readings) + " readings; mm, deg",
  };
  const std::string L(1, rotary);
  const std::string offset = iso || sinumerik ? "G54" : "(the active preset)";
  if (program.machine) {
    const Machine& m = *program.machine->machine;
    const std::string parks = parked_text(*program.machine, 4);
    head.push_back("machine " + m.name + " (controller " + controller_name(m.controller) +
                   "): axis " + L + " measured" +
                   (parks.empty() ? "" : " with " + parks + " (parked)"));
    head.push_back(
        "every rotary axis is commanded first, before any linear move, where the tool change "
        "leaves the spindle (at the top of the Z travel on most machines: watch it in the air "
        "run); the cups are placed with the axis at its park angle, then turned");
  }
  if (c && program.machine) {
    head.push_back("work offset " + offset + ": origin at " + L +
                   "'s nominal point as the machine file has it, " +
                   xyz_text(program.machine->origin_mm()) +
                   " in the machine file's frame (machine coordinates where its origin is the "
                   "machine zero), axes parallel to the machine's");
    head.push_back(
        "set that preset from the controller's kinematics table, never by teaching it "
        "on the real axis: the location errors are the real axis line minus this one");
    head.push_back("tool T" + tool +
                   ": the ballbar's spindle cup with its ball, length measured to the ball "
                   "centre; X Y Z command the ball centre, no radius compensation");
    head.push_back(L + "+ turns the table " + sense_text(program.axis, true) +
                   " [right-hand rule]");
  } else if (c) {
    head.push_back(std::string("work offset ") + offset +
                   (program.axis.shorthand() == "C"
                        ? ": origin on the C axis at the table surface, Z up along the C axis; "
                          "teach it once: X Y on the C axis (centre of the table's rotation), Z "
                          "on the table surface"
                        : ": origin on the " + L + " axis line where the design's H is 0 (H " +
                              "along " + direction_text(program.axis.direction()) + ", L along " +
                              direction_text(program.axis.reference()) + " at " + L +
                              "0); teach it once on the axis line"));
    head.push_back("tool T" + tool +
                   ": the ballbar's spindle cup with its ball, length measured to the ball "
                   "centre; X Y Z command the ball centre, no radius compensation");
    head.push_back(L + "+ turns the table " + sense_text(program.axis, true) +
                   " [right-hand rule]");
  } else {
    head.push_back("work offset " + offset +
                   ": origin at the centre of the table ball, whose cup stays where it is "
                   "placed for the whole test");
    if (program.preset_range) {
      const MeasurementProgram::PresetRange& r = *program.preset_range;
      std::string box;
      for (int i = 0; i < 3; ++i)
        box += std::string(i ? ", " : "") + "XYZ"[i] + " " + coord(r.min_mm(i), false) + " to " +
               coord(r.max_mm(i), false);
      head.push_back("place the table ball so that its centre [the preset] lies at " + box +
                     " mm in the machine file's frame" +
                     (r.table_radius_mm
                          ? ", on the table [its surface at Z" +
                                coord(*r.table_surface_z_mm + 0.0, false) + ", within " +
                                coord(*r.table_radius_mm, false) + " mm of its axis]"
                          : std::string()));
      head.push_back(
          "there every pivot position and the clearance plane stay inside the linear "
          "travel [the pivot at " +
          xyz_text(program.machine->origin_mm()) + " with the linear axes at zero]");
      head.push_back(
          r.lowest_z_mm < 0
              ? "the pivot and the spindle ball come down to Z" + coord(r.lowest_z_mm, false) +
                    ": stand the table ball's centre at least " + coord(-r.lowest_z_mm, false) +
                    " mm above the table, more by what the head reaches below its pivot"
              : "the pivot and the spindle ball stay above the table ball's centre");
    }
    if (tcpm_throughout) {
      head.push_back("tool T" + tool +
                     ": its length measured to the spindle ball's centre, the tool tip the "
                     "controller's kinematics carries about the pivot; X Y Z command that "
                     "centre");
    } else {
      head.push_back(
          "tool T" + tool + ": X Y Z command the pivot (" + L +
          " axis x spindle axis): its length register holds the "
          "distance from the gauge line to the pivot, as the control's head kinematics has it");
    }
    const std::optional<Eigen::Vector3d>& tool = program.tool_direction;
    const std::string turns = L + "+ turns the head " + sense_text(program.axis, true);
    if (tool && (*tool - program.axis.reference()).norm() < 1e-9) {
      head.push_back("frame of the design: at " + L + "0 the spindle points " +
                     direction_text(*tool) + " from the pivot, the ball L along it; " + turns);
    } else {
      head.push_back(
          "frame of the design: at " + L + "0 " +
          (tool ? "the spindle points " + direction_text(snapped_to_machine_axis(*tool)) +
                      " from the pivot; "
                : std::string("the spindle's direction is not stated (the design names no "
                              "machine); ")) +
          "a ball's L lies along " + direction_text(program.axis.reference()) + ", D along " +
          direction_text(program.axis.e_D()) + ", H along " + direction_text(program.axis.e_H()) +
          " from the pivot; " + turns);
    }
  }
  head.push_back("clearance plane Z" + coord(zc, false) +
                 (o.clearance_z_mm
                      ? " [given]"
                      : std::string(c                 ? " [the highest point reached"
                                    : tcpm_throughout ? " [the highest point the spindle ball "
                                                        "reaches, at least " +
                                                            fmt_rounded(kHeadBallsAllowance_mm, 3) +
                                                            " mm for the balls,"
                                                      : " [the highest point reached or the "
                                                        "longest pivot-to-ball distance and " +
                                                            fmt_rounded(kHeadBallsAllowance_mm, 3) +
                                                            " mm for the balls, whichever is "
                                                            "more,") +
                            " plus " + fmt_rounded(o.clearance_margin_mm, 3) + " mm" +
                            std::string(c && program.machine ? ", the table and the solids "
                                                               "that turn with it included"
                                                             : "") +
                            "]") +
                 ": every sideways rapid runs there; each installation is left and reached "
                 "along Z alone at the feed");
  const std::string tcpm_code = iso         ? "G43.4 H" + tool + ", off by G43 H" + tool
                                : sinumerik ? "TRAORI, off by TRAFOOF"
                                            : "FUNCTION TCPM, off by FUNCTION TCPM RESET";
  if (tcpm && iso)
    head.push_back(
        "TCPM off is written G43 H" + tool +
        " (the tool length kept, no cancel move): on a control that leaves G43.4 only by G49, "
        "which may move Z by the tool length, check the change in the air run without the bar");
  if (tcpm && c) {
    head.push_back("TCPM on for each sweep (" + tcpm_code +
                   "): X Y Z are the spindle ball's centre in the workpiece frame, which turns "
                   "with the table (the same point at every angle)");
    head.push_back(
        "the controller moves the linear axes from its own kinematics, so each "
        "reading measures the real axis against its model; approaches, the cups' "
        "placing and retracts run with TCPM off");
  } else if (tcpm) {
    head.push_back("TCPM on from the parked axes to the end (" + tcpm_code +
                   "): X Y Z are the spindle ball's centre in the workpiece frame");
    head.push_back(
        "the controller moves the linear axes from its own kinematics, so each "
        "reading measures the real head against its model; each step is split so the "
        "bar changes by at most " +
        fmt_rounded(o.path_tolerance_mm, 4) + " mm along the tip's chord");
  } else {
    head.push_back(std::string(program.machine ? "TCPM off: the linear positions come from the "
                                                 "machine file's nominal axis points; "
                                               : "no tool-centre-point control: ") +
                   "each step is split so the bar changes by at most " +
                   fmt_rounded(o.path_tolerance_mm, 4) + " mm between positions");
  }
  head.push_back("readings: dwell " + fmt_rounded(o.dwell_s, 3) + " s at each design angle" +
                 (design.partial_sweeps() ? std::string(" an installation reads (its own, where "
                                                        "the design names them)")
                                          : std::string()) +
                 (design.return_reading
                      ? std::string(" and again at the first angle of each sweep after its last")
                      : std::string()) +
                 ", feed " + fmt_rounded(o.feed_mm_per_min, 1) + " mm/min");
  head.push_back("moves at the feed and dwells take about " +
                 fmt_rounded(program.motion_time_s / 60.0, 1) +
                 " min; rapids and set-ups not included");
  head.push_back(o.air_run
                     ? "AIR RUN: the same moves with no bar mounted, a stop at each installation "
                       "and after the first step of each sweep: watch the sense of the rotary "
                       "axis and the clearance before the measurement"
                     : "run it first as an air run (program --air-run), with no bar, and check "
                       "the sense of the rotary axis and every clearance");
  for (const std::string& h : head) w.comment(h);

  // Safe start, before any move: no compensation, cycle, tilted plane or tool-centre-point
  // control left active; absolute, metric; the spindle stopped (oriented), coolant off; the
  // tool and its length.
  // One M function per block (many controls take no more).
  // A design that names its machine: every rotary axis first, before any linear move, where the
  // tool change leaves the spindle (the others to their park angles, the axis under test to where
  // its first cup is placed); ISO's tool length comes with the first linear move (G43 H Z).
  auto rotaries_first = [&](const std::string& m) {
    if (!program.machine) return;
    w.comment("every rotary axis first, before any linear move");
    w.rapid_rotaries(
        program.machine->angles_with(program.installations.empty()
                                         ? program.machine->park_angles()[program.machine->axis]
                                         : program.installations.front().placement_angle_deg),
        m);
  };
  if (iso) {
    w.raw("G17 G21 G40 G49 G69 G80 G90 G94");
    w.raw("M05");
    w.raw("M09");
    w.raw("G54");
    w.raw("T" + tool + " M06");
    if (!o.orient_code.empty()) w.raw(o.orient_code);
    rotaries_first("");
    w.raw("G00 G43 H" + tool + " Z" + coord(zc, false));
  } else if (sinumerik) {
    w.raw("G17 G71 G90 G94 G40");
    w.raw("TRAFOOF");
    w.raw("CYCLE800()");
    w.raw("M5");
    w.raw("M9");
    w.raw("G54");
    w.raw("T" + tool);
    w.raw("M6");
    w.raw("D1");
    if (!o.orient_code.empty()) w.raw("SPOS=0");
    rotaries_first("");
    w.raw("G0 Z" + coord(zc, false));
  } else {
    w.raw("PLANE RESET STAY");
    w.raw("FUNCTION TCPM RESET");
    w.raw("TOOL CALL " + tool + " Z S0");
    // The spindle stopped with the first move (M5 on it).
    if (program.machine)
      rotaries_first("M5");
    else
      w.raw("L Z" + coord(zc, true) + " R0 FMAX M5");
    w.raw("L Z" + coord(zc, true) + " R0 FMAX M9");
    if (!o.orient_code.empty()) {
      w.raw("CYCL DEF 13.0 ORIENTATION");
      w.raw("CYCL DEF 13.1 ANGLE 0");
      w.raw("L Z" + coord(zc, true) + " R0 FMAX " + o.orient_code);
    }
  }
  if (tcpm_throughout) w.tcpm(true, tool);

  const int n = static_cast<int>(program.installations.size());
  for (int k = 0; k < n; ++k) {
    const InstallationProgram& ip = program.installations[k];
    const Installation& inst = design.installations[ip.installation];
    const ProgramPosition& start = ip.sweeps.front().positions.front();
    std::string sweeps;
    for (const ProgramSweep& s : ip.sweeps)
      sweeps += (sweeps.empty() ? "" : " then ") + std::string(sweep_name(s.direction));
    w.comment("installation " + inst.id + " (" + std::to_string(k + 1) + " of " +
              std::to_string(n) + "): " + program_ball_text(program.axis, inst) + ", " +
              inst.direction.label() + ", sign " + (inst.sign > 0 ? "+1" : "-1") + ", bar " +
              fmt_rounded(ip.bar_mm, 4) + " mm; sweep " + sweeps + ", " +
              std::to_string(ip.readings) + " readings");
    if (!inst.description.empty()) w.comment(inst.description);
    w.comment(c ? "table ball centre at " + xyz_text(ip.fixed_ball_mm) + " at " + L + "0"
                : "table ball centre at the origin");
    // Leave along Z alone, turn at the plane, move sideways there.
    w.rapid_z(zc);
    const bool turn_after_placing = ip.places_cup && ip.placement_angle_deg != start.angle_deg;
    w.rapid_rotary(turn_after_placing ? ip.placement_angle_deg : start.angle_deg);
    if (ip.places_cup) {
      const Eigen::Vector3d at = tcpm_throughout ? Eigen::Vector3d::Zero().eval() : ip.placement_mm;
      w.comment("the spindle ball goes where the table ball goes: " + placement_text(design, inst));
      w.rapid_xy(at);
      w.feed_z(at.z(), o.feed_mm_per_min);
      w.stop("place the table cup " + inst.id + ", then start");
      w.feed_z(zc, o.feed_mm_per_min);
      if (turn_after_placing) w.rapid_rotary(start.angle_deg);
    }
    const Eigen::Vector3d start_at = tcpm_throughout ? start.tcp_mm : start.linear_mm;
    w.rapid_xy(start_at);
    w.feed_z(start_at.z(), o.feed_mm_per_min);
    if (tcpm && c) {
      // The same place, now named in the workpiece frame.
      w.tcpm(true, tool);
      w.move(start.tcp_mm, start.angle_deg, o.feed_mm_per_min);
    }
    w.stop(o.air_run ? "AIR RUN " + inst.id + ": check the gap, start"
                     : "mount the bar " + inst.id + ", then start");
    for (size_t si = 0; si < ip.sweeps.size(); ++si) {
      const ProgramSweep& s = ip.sweeps[si];
      for (size_t pi = 0; pi < s.positions.size(); ++pi) {
        const ProgramPosition& p = s.positions[pi];
        if (pi > 0) w.move(tcpm ? p.tcp_mm : p.linear_mm, p.angle_deg, o.feed_mm_per_min);
        if (o.air_run && pi == 1) {
          const double turned = p.angle_deg - s.positions.front().angle_deg;
          w.comment(std::string("AIR RUN: ") + rotary + (turned > 0 ? "+" : "-") +
                    " step: the ball on the rotating body must have moved " +
                    sense_text(program.axis, turned > 0) +
                    ", the spindle ball with it, the gap unchanged");
          w.stop("AIR RUN: check the sense, then start");
        }
        if (p.reading) {
          w.dwell(o.dwell_s,
                  "reading " + inst.id + " " + fmt_rounded(p.angle_deg, 4) + " deg " +
                      (p.return_reading ? std::string("return ") + sweep_name(opposite(s.direction))
                                        : std::string(sweep_name(s.direction))));
        }
      }
    }
    w.stop(o.air_run ? "AIR RUN " + inst.id + " done, then start" : "remove the bar " + inst.id);
    if (tcpm && c) w.tcpm(false, tool);
    w.feed_z(zc, o.feed_mm_per_min);
  }
  if (tcpm_throughout) w.tcpm(false, tool);
  if (program.machine) {
    // Every rotary axis back to its park angle at the clearance plane: the table level, the
    // spindle upright, before the cups come off.
    w.rapid_z(zc);
    w.comment("every rotary axis back to its park angle");
    w.rapid_rotaries(
        program.machine->angles_with(program.machine->park_angles()[program.machine->axis]));
  }
  if (iso) {
    w.raw("M30");
    w.raw("%");
  } else if (sinumerik) {
    w.raw("M30");
  } else {
    w.raw("L Z" + coord(zc, true) + " R0 FMAX M30");
    w.raw("END PGM " + name + " MM");
  }
  return w.text();
}

}  // namespace dbbkit::io
