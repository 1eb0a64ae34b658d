#include "dbbkit/io/program_io.hpp"

#include <cmath>
#include <cstdio>
#include <sstream>
#include <vector>

#include "dbbkit/error.hpp"
#include "dbbkit/io/escape.hpp"
#include "dbbkit/io/text.hpp"
#include "dbbkit/kinematics.hpp"

namespace dbbkit::io {

namespace {

// A coordinate with 4 decimals; a value that rounds to zero is written as 0 (never -0).
std::string coord(double x, bool plus_sign) {
  const double r = std::round(x * 1e4) / 1e4;
  char buf[64];
  std::snprintf(buf, sizeof buf, plus_sign ? "%+.4f" : "%.4f", r == 0 ? 0.0 : r);
  return buf;
}

// The most characters of one text in a program's comments (a description, a stop's message):
// at most four comment lines.
constexpr std::size_t kMaxCommentText = 4 * kProgramCommentLine;

// Text a comment can hold (escape.hpp), cut to kMaxCommentText characters.
std::string comment_safe(const std::string& s) { return program_comment(s, kMaxCommentText); }

// A comment's text in lines of at most kProgramCommentLine characters, broken at spaces where
// it can be.
std::vector<std::string> comment_lines(const std::string& text) {
  std::vector<std::string> lines;
  std::string rest = comment_safe(text);
  while (rest.size() > kProgramCommentLine) {
    size_t cut = rest.rfind(' ', kProgramCommentLine);
    if (cut == std::string::npos || cut == 0) cut = kProgramCommentLine;
    lines.push_back(rest.substr(0, cut));
    rest = rest.substr(cut + (rest[cut] == ' ' ? 1 : 0));
  }
  lines.push_back(rest);
  return lines;
}

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
  void raw(const std::string& text) { line(text); }
  void rapid_rotary(double angle) {
    if (dialect_ == Dialect::kIso)
      line(std::string("G00 ") + rotary_ + coord(angle, false));
    else
      line(std::string("L ") + rotary_ + coord(angle, true) + " FMAX");
  }
  void rapid_linear(const Eigen::Vector3d& p) {
    if (dialect_ == Dialect::kIso)
      line("G00 " + xyz(p));
    else
      line("L " + xyz(p) + " FMAX");
  }
  void move(const Eigen::Vector3d& p, double angle, double feed) {
    const std::string f = std::to_string(static_cast<long long>(std::lround(feed)));
    if (dialect_ == Dialect::kIso)
      line("G01 " + xyz(p) + " " + rotary_ + coord(angle, false) + " F" + f);
    else
      line("L " + xyz(p) + " " + rotary_ + coord(angle, true) + " R0 F" + f);
  }
  void stop(const std::string& why) {
    if (dialect_ == Dialect::kIso)
      line("M00 (" + program_comment(why, kProgramMessage) + ")");
    else
      line("STOP ; " + program_comment(why, kProgramMessage));
  }
  void dwell(double seconds, const std::string& why) {
    if (dialect_ == Dialect::kIso) {
      line("G04 P" + std::to_string(static_cast<long long>(std::lround(seconds * 1000))) + " (" +
           program_comment(why, kProgramMessage) + ")");
    } else {
      line("CYCL DEF 9.0 DWELL TIME ; " + program_comment(why, kProgramMessage));
      line("CYCL DEF 9.1 DWELL " + fmt_rounded(seconds, 3));
    }
  }
  std::string text() const { return out_.str(); }

 private:
  std::string xyz(const Eigen::Vector3d& p) const {
    const bool plus = dialect_ == Dialect::kHeidenhain;
    std::string s = "X";
    s.append(coord(p.x(), plus)).append(" Y").append(coord(p.y(), plus));
    return s.append(" Z").append(coord(p.z(), plus));
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

std::string program_ball_text(Axis axis, const Installation& inst) {
  std::string s =
      "ball L " + fmt_rounded(inst.L_mm, 4) + " mm, D " + fmt_rounded(inst.D_mm, 4) + " mm";
  if (axis == Axis::kC) s += ", H " + fmt_rounded(inst.H_mm, 4) + " mm";
  return s;
}

}  // namespace

std::string program_text(const Design& design, const MeasurementProgram& program, Dialect dialect,
                         int program_number) {
  if (program_number < 1 || program_number > 9999)
    throw InputError("--program-number", "", "an O-number is 1..9999");
  const bool c = program.axis == Axis::kC;
  const char rotary = c ? 'C' : 'B';
  const ProgramOptions& o = program.options;
  Writer w(dialect, rotary);
  const std::string name = heidenhain_name(design.name);
  if (dialect == Dialect::kIso) {
    w.raw("%");
    char o_number[16];
    std::snprintf(o_number, sizeof o_number, "O%04d", program_number);
    w.raw(std::string(o_number) + " (DBB MEASUREMENT " +
          program_comment(design.name, kProgramMessage) + ")");
  } else {
    w.raw("BEGIN PGM " + name + " MM");
  }
  std::vector<std::string> head = {
      "dbbkit measurement program of design " + design.name + ", axis " + axis_name(program.axis) +
          ", " + std::to_string(program.installations.size()) + " installations, " +
          std::to_string(program.readings) + " readings",
  };
  if (c) {
    head.push_back("work offset: origin on the C axis at the table surface, Z up along the C axis");
    head.push_back(
        "X Y Z command the centre of the spindle's ball: tool length to the ball centre, "
        "no radius compensation");
    head.push_back("C+ turns the table counter-clockwise seen from +Z (right-hand rule)");
  } else {
    head.push_back(
        "work offset: origin where the pivot (B axis x spindle axis) stands at the first "
        "angle of each installation");
    head.push_back("X Y Z command the pivot: tool length 0 to the pivot, no radius compensation");
    head.push_back(o.tool_down
                       ? "the tool points to -Z at B0; B+ turns the head by the right-hand "
                         "rule about +Y"
                       : "frame of the design: at B0 the ball is +L along Z from the pivot; "
                         "B+ turns the head by the right-hand rule about +Y [--tool-down for a "
                         "tool pointing to -Z]");
  }
  head.push_back("no tool-centre-point control: each step is split so the bar changes by at most " +
                 fmt_rounded(o.path_tolerance_mm, 4) + " mm between positions");
  head.push_back("readings: dwell " + fmt_rounded(o.dwell_s, 3) + " s at each design angle; feed " +
                 fmt_rounded(o.feed_mm_per_min, 1) + " mm/min");
  head.push_back("the approach to each installation's first position is not collision-checked");
  head.push_back("moves and dwells take about " + fmt_rounded(program.motion_time_s / 60.0, 1) +
                 " min, set-ups not included");
  for (const std::string& h : head) w.comment(h);
  if (dialect == Dialect::kIso) {
    w.raw("G21 G90 G94 G17");
    w.raw("G54");
  }

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
    const std::string fixed = "X" + coord(ip.fixed_ball_mm.x(), false) + " Y" +
                              coord(ip.fixed_ball_mm.y(), false) + " Z" +
                              coord(ip.fixed_ball_mm.z(), false);
    w.comment(c ? "table ball centre at " + fixed + " at C0"
                : "table ball centre at " + fixed + " with the pivot at the origin");
    w.rapid_rotary(start.angle_deg);
    w.rapid_linear(start.linear_mm);
    w.stop("mount the bar " + inst.id + ", then start");
    for (size_t si = 0; si < ip.sweeps.size(); ++si) {
      const ProgramSweep& s = ip.sweeps[si];
      for (size_t pi = 0; pi < s.positions.size(); ++pi) {
        const ProgramPosition& p = s.positions[pi];
        if (pi > 0) w.move(p.linear_mm, p.angle_deg, o.feed_mm_per_min);
        if (p.reading) {
          w.dwell(o.dwell_s, "reading " + inst.id + " " + fmt_rounded(p.angle_deg, 4) + " deg " +
                                 sweep_name(s.direction));
        }
      }
    }
    w.stop("remove the bar " + inst.id);
  }
  w.raw("M30");
  if (dialect == Dialect::kIso)
    w.raw("%");
  else
    w.raw("END PGM " + name + " MM");
  return w.text();
}

}  // namespace dbbkit::io
