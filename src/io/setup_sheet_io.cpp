#include "dbbkit/io/setup_sheet_io.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <optional>
#include <sstream>
#include <vector>

#include "dbbkit/io/text.hpp"
#include "dbbkit/kinematics.hpp"
#include "dbbkit/machine.hpp"
#include "report_sections.hpp"

namespace dbbkit::io {

namespace {

std::string mm(double x) { return fmt_rounded(x, 3); }

std::string lengths(const std::vector<double>& v) {
  std::string t;
  for (size_t i = 0; i < v.size(); ++i) t += (i ? " + " : "") + mm(v[i]);
  return t;
}

std::string sheet_ball_text(const AxisFrame& axis, const Installation& in) {
  std::string t = "L " + mm(in.L_mm) + ", D " + mm(in.D_mm);
  if (axis.has_H()) t += ", H " + mm(in.H_mm);
  return t;
}

std::string stack_text(const AxisFrame& axis, const Installation& in,
                       const std::optional<Stack>* kit_stack = nullptr) {
  if (!axis.table())
    return "tool side: ball " + mm(ball_body_mm(axis, in).norm()) + " mm from the pivot";
  if (!in.cup_mm && kit_stack) {
    if (!*kit_stack) return "no stack of the kit puts the ball at its height";
    const Stack& st = **kit_stack;
    if (st.blocks_mm.empty()) return "the kit's cup on the table (" + mm(st.height_mm) + " mm)";
    return "the kit's cup on blocks " + lengths(st.blocks_mm) + " mm (" + mm(st.height_mm) +
           " mm above the table)";
  }
  if (!in.cup_mm && axis.shorthand().empty())
    return "as the design places the ball (L, D, H; its stack not given)";
  if (!in.cup_mm) return "H " + mm(in.H_mm) + " mm (cup and blocks not given in the design)";
  if (in.blocks_mm.empty()) return "cup on the table (" + mm(*in.cup_mm) + " mm)";
  return "cup (" + mm(*in.cup_mm) + " mm) on blocks " + lengths(in.blocks_mm) + " mm";
}

std::string bar_text(const Installation& in) {
  if (!in.bar_mm) return "not given";
  std::string t = mm(*in.bar_mm) + " mm";
  if (in.bar_parts_mm.size() > 1)
    t += " (" + lengths(in.bar_parts_mm) + ")";
  else if (in.bar_parts_mm.empty())
    t += " (parts not given)";
  return t;
}

// The measurement's time: the program's moves and dwells and, with a kit, the one time model
// (design_time) that optimize plans with, and whether the two agree.
std::string time_text(const SetupSheet& sheet, const std::string& kit_file) {
  const MeasurementProgram& pr = sheet.program;
  const ProgramOptions& po = pr.options;
  const std::string moves = "the program's moves and dwells (dwell " + fmt_num(po.dwell_s) +
                            " s, feed " + fmt_num(po.feed_mm_per_min) + " mm/min) take about " +
                            fmt_rounded(pr.motion_time_s / 60.0, 1) + " min";
  if (!sheet.time) {
    std::string t = moves + "; set-up times are not included (give --kit for them).";
    t[0] = static_cast<char>(std::toupper(static_cast<unsigned char>(t[0])));
    return t;
  }
  const TimeEstimate& e = *sheet.time;
  const double per_reading = e.readings > 0 ? e.readings_s / e.readings : 0.0;
  const double program_per_reading = pr.readings > 0 ? pr.motion_time_s / pr.readings : 0.0;
  std::string t = "Time, by the kit's model (" + kit_file +
                  ", what optimize plans with): set-ups " + fmt_rounded(e.setups_s / 60.0, 1) +
                  " min (" + std::to_string(e.positions) + " ball positions, " +
                  std::to_string(e.installations) + " installations), " +
                  std::to_string(e.readings) + " readings at " + fmt_num(per_reading) + " s " +
                  fmt_rounded(e.readings_s / 60.0, 1) + " min: about " +
                  fmt_rounded(e.total_s / 60.0, 1) + " min in all. Of the readings, " + moves +
                  ", " + fmt_rounded(program_per_reading, 1) + " s per reading";
  if (program_per_reading > 1.1 * per_reading) {
    t += ": MORE than the kit's per_reading, so the time above is short by about " +
         fmt_rounded((pr.motion_time_s - e.readings_s) / 60.0, 1) +
         " min; set time_s.per_reading to " + fmt_rounded(std::ceil(program_per_reading), 0) +
         " s in the kit for optimize to plan with it.";
  } else {
    t += ", within the kit's per_reading.";
  }
  return t;
}

// What the workspace check covered, and every clash.
std::string workspace_text(const SetupSheet& sheet) {
  if (!sheet.time) return "";  // no kit
  if (!sheet.clashes.empty()) {
    std::string t = "CLASH: this set-up cannot stand on the machine as designed:";
    for (const auto& [id, c] : sheet.clashes)
      t += " " + id + ": " + c.what + " by " + mm(c.by_mm) + " mm;";
    return t + " move these balls, choose other bars or blocks, or choose another design.";
  }
  std::string checked;
  for (const std::string& c : sheet.workspace_checks) checked += (checked.empty() ? "" : "; ") + c;
  return "Every installation clears the kit's workspace: " + checked +
         (sheet.workspace_stated ? "."
          : sheet.design.axis.head()
              ? ". The kit states no workspace (workspace.table_ball_height_mm, "
                "workspace.spindle): the head's clearance from the table is not checked; the air "
                "run must show it."
              : ". The kit states no workspace: the table's outline, the cup's footprint and the "
                "spindle nose are not checked.");
}

std::string times(int n) {
  if (n == 0) return "never";
  if (n == 1) return "once";
  if (n == 2) return "twice";
  return std::to_string(n) + " times";
}

// C: where the cup stands, in words ("on blocks 50 + 100 mm", "on the table").
std::string cup_on(const Installation& in) {
  if (!in.cup_mm) return "";
  if (in.blocks_mm.empty()) return " on the table";
  return " on blocks " + lengths(in.blocks_mm) + " mm";
}

std::string xyz(const Eigen::Vector3d& p) {
  return "X " + mm(p.x()) + ", Y " + mm(p.y()) + ", Z " + mm(p.z());
}

std::string sweeps_text(const InstallationProgram& ip) {
  std::string t;
  for (const ProgramSweep& s : ip.sweeps)
    t += (t.empty() ? "" : " then ") + std::string(sweep_name(s.direction));
  return t;
}

// A machine's table: the ball centre's height above its surface, the stack's measure.
std::string height_text(const SetupSheet& sheet, const InstallationProgram& ip) {
  if (!ip.table_height_mm || !sheet.design.machine) return "";
  const Machine& m = *sheet.design.machine->machine;
  const int disc = m.innermost(AxisFrame::Side::kTable);
  return ", its centre " + mm(*ip.table_height_mm) + " mm above the surface of the " +
         std::string(1, m.rotary[static_cast<std::size_t>(disc)].letter) + " table";
}

// What the person does before this step, in words.
std::string instructions(const SetupSheet& sheet, int k) {
  const SetupStep& s = sheet.order.steps[k];
  const AxisFrame& axis = sheet.design.axis;
  const Installation& in = sheet.design.installations[s.installation];
  const InstallationProgram& ip = sheet.program.of(s.installation);
  std::string t;
  if (k == 0) {
    t = axis.table()
            ? "Place the cup" + cup_on(in) + " with the ball at " + sheet_ball_text(axis, in) +
                  " mm (table coordinates at " + std::string(1, axis.letter()) + " " +
                  mm(ip.placement_angle_deg) + " deg)" + height_text(sheet, ip) + "."
            : "Set the ball at " + sheet_ball_text(axis, in) + " mm (head coordinates).";
  } else if (s.moves_cup && axis.head()) {
    t = "Move the ball to " + sheet_ball_text(axis, in) + " mm (tool cup and holder).";
  } else if (s.moves_cup) {
    t = "Move the cup" + std::string(s.changes_stack ? "" : ", on the same stack,") + " to " +
        sheet_ball_text(axis, in) + " mm";
    if (axis.table() && s.changes_stack)
      t += in.cup_mm ? "; rebuild the stack: the cup" + cup_on(in)
           : !sheet.kit_stacks.empty()
               ? "; rebuild the stack: " + stack_text(axis, in, &sheet.kit_stacks[s.installation])
           : ip.table_height_mm ? "; rebuild the stack"
           : axis.shorthand().empty() && axis.letter() != 'C'
               ? "; rebuild the stack to the ball's height above the table"
               : "; rebuild the stack to H";
    t += height_text(sheet, ip) + ".";
  } else {
    t = axis.table() ? "Keep the cup." : "Keep the ball.";
  }
  if (ip.places_cup) {
    // As the program does it (program_io.cpp): the spindle's ball shows where the ball goes.
    t += axis.table()
             ? " The program stops with the spindle's ball (a setting ball in its cup) at " +
                   xyz(ip.placement_mm) + " mm, where the table's ball goes"
             : " The program stops with the pivot at " + xyz(ip.placement_mm) +
                   " mm, the spindle's ball (a setting ball in its cup) at the work frame's "
                   "origin, where the table's ball goes for the whole test";
    t += ": seat the table cup against it, lock its base, remove the setting ball; the program "
         "retracts along Z.";
  }
  t += s.changes_bar ? " Assemble the bar of " + bar_text(in) + "." : " Keep the bar.";
  t += " Mount it " + in.direction.label() + " (sign " + (in.sign > 0 ? "+1" : "-1") + ")";
  if (axis.table()) {
    const ProgramPosition& start = ip.sweeps.front().positions.front();
    const Eigen::Vector3d& f = start.linear_mm;
    t += " with the spindle's ball at " + xyz(f) + " mm";
    // Under TCPM the program names the same place in the workpiece frame once TCPM is on.
    if (sheet.program.options.tcpm && (start.tcp_mm - f).norm() > 5e-4)
      t += " (" + xyz(start.tcp_mm) +
           " mm in the workpiece frame, as the controller shows it once the program turns TCPM "
           "on)";
    t += ".";
    // The table's surface is the plane z = 0 of the work frame on a table turning about the
    // machine's Z (the shorthand "C", a primed C); another table's is the kit's to check.
    double lowest = f.z();
    for (const ProgramSweep& sw : ip.sweeps)
      for (const ProgramPosition& p : sw.positions) lowest = std::min(lowest, p.linear_mm.z());
    if (axis.machine_axis() == 2 && lowest < 0)
      t += " CHECK: the spindle's ball would go " + mm(-lowest) +
           " mm below the table surface; is the installation's sign right?";
  } else {
    t += " with the table's ball at " + xyz(-ip.sweeps.front().positions.front().linear_mm) +
         " mm from the pivot.";
  }
  t += " Sweep " + sweeps_text(ip) + ", " + std::to_string(ip.readings) + " readings.";
  return t;
}

// --- drawing --------------------------------------------------------------------------------

struct Panel {
  double x0, y0, size;               // where the panel sits in the picture [px]
  double cx = 0, cy = 0, scale = 1;  // the point at its centre [mm] and px per mm
  Panel(double x, double y, double s, const std::vector<std::pair<double, double>>& pts)
      : x0(x), y0(y), size(s) {
    double lo_x = 0, hi_x = 0, lo_y = 0, hi_y = 0;
    for (auto [px, py] : pts) {
      lo_x = std::min(lo_x, px), hi_x = std::max(hi_x, px);
      lo_y = std::min(lo_y, py), hi_y = std::max(hi_y, py);
    }
    cx = 0.5 * (lo_x + hi_x), cy = 0.5 * (lo_y + hi_y);
    const double span = std::max({hi_x - lo_x, hi_y - lo_y, 50.0});
    scale = 0.8 * size / span;
  }
  double X(double x) const { return x0 + 0.5 * size + (x - cx) * scale; }
  double Y(double y) const { return y0 + 0.5 * size - (y - cy) * scale; }
};

std::string sheet_number(double v) {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(1);
  s << v;
  return s.str();
}

void line(std::ostringstream& s, const Panel& p, double x1, double y1, double x2, double y2,
          const std::string& style) {
  s << "<line x1='" << sheet_number(p.X(x1)) << "' y1='" << sheet_number(p.Y(y1)) << "' x2='"
    << sheet_number(p.X(x2)) << "' y2='" << sheet_number(p.Y(y2)) << "' style='" << style << "'/>";
}
// A ball and its label: above right (the ball) or below left (the other ball), so that two
// balls drawn at one point keep both labels readable.
// A label that would leave its panel (about 6.5 px per character at this size) is set on the
// ball's other side.
void ball(std::ostringstream& s, const Panel& p, double x, double y, const std::string& fill,
          const std::string& label, bool below = false) {
  const double width = 6.5 * static_cast<double>(label.size());
  bool left = below;
  if (left && p.X(x) - 7 - width < p.x0 + 2) left = false;
  if (!left && p.X(x) + 7 + width > p.x0 + p.size - 2 && p.X(x) - 7 - width >= p.x0 + 2)
    left = true;
  s << "<circle cx='" << sheet_number(p.X(x)) << "' cy='" << sheet_number(p.Y(y))
    << "' r='5' fill='" << fill << "' stroke='#222'/><text x='"
    << sheet_number(p.X(x) + (left ? -7 : 7)) << "' y='" << sheet_number(p.Y(y) + (below ? 16 : -7))
    << "' font-size='11'" << (left ? " text-anchor='end'" : "") << ">" << html_escape(label)
    << "</text>";
}
void path(std::ostringstream& s, const Panel& p, double radius) {
  s << "<circle cx='" << sheet_number(p.X(0)) << "' cy='" << sheet_number(p.Y(0)) << "' r='"
    << sheet_number(radius * p.scale) << "' fill='none' stroke='#999' stroke-dasharray='3 3'/>";
}
void rect(std::ostringstream& s, const Panel& p, double x, double y, double w, double h,
          const std::string& fill) {
  s << "<rect x='" << sheet_number(p.X(x)) << "' y='" << sheet_number(p.Y(y + h)) << "' width='"
    << sheet_number(w * p.scale) << "' height='" << sheet_number(h * p.scale) << "' fill='" << fill
    << "' stroke='#555'/>";
}
// A block of width w standing on (x, y) and rising h along the unit vector n (a rotated rect).
void block(std::ostringstream& s, const Panel& p, const Eigen::Vector2d& foot,
           const Eigen::Vector2d& n, double w, double h, const std::string& fill) {
  const Eigen::Vector2d t(-n.y(), n.x());
  s << "<polygon points='";
  for (const Eigen::Vector2d& c :
       {Eigen::Vector2d(foot - 0.5 * w * t), Eigen::Vector2d(foot + 0.5 * w * t),
        Eigen::Vector2d(foot + 0.5 * w * t + h * n), Eigen::Vector2d(foot - 0.5 * w * t + h * n)})
    s << sheet_number(p.X(c.x())) << "," << sheet_number(p.Y(c.y())) << " ";
  s << "' fill='" << fill << "' stroke='#555'/>";
}
// "X", "-Y", ... for a vector along a machine axis; empty for another.
std::string machine_axis_name(const Eigen::Vector3d& v) {
  for (int i = 0; i < 3; ++i) {
    if (std::abs(std::abs(v[i]) - 1) > 1e-9) continue;
    return std::string(v[i] < 0 ? "-" : "") + static_cast<char>('X' + i);
  }
  return "";
}
// A caption within its panel: wrapped at spaces onto further lines (about 6.6 px per character
// at this size), so that two panels' captions never run into each other.
void caption(std::ostringstream& s, const Panel& p, const std::string& text) {
  const std::size_t per_line = static_cast<std::size_t>(std::max(10.0, (p.size - 12) / 6.6));
  std::vector<std::string> lines{""};
  std::istringstream words(text);
  std::string w;
  while (words >> w) {
    if (!lines.back().empty() && lines.back().size() + 1 + w.size() > per_line) lines.push_back("");
    lines.back() += (lines.back().empty() ? "" : " ") + w;
  }
  for (std::size_t i = 0; i < lines.size(); ++i) {
    s << "<text x='" << sheet_number(p.x0 + 6) << "' y='"
      << sheet_number(p.y0 + 14 + 14 * static_cast<double>(i)) << "' font-size='12'>"
      << html_escape(lines[i]) << "</text>";
  }
}

}  // namespace

std::string installation_drawing(const SetupSheet& sheet, int step) {
  const SetupStep& st = sheet.order.steps[step];
  const AxisFrame& axis = sheet.design.axis;
  const Installation& in = sheet.design.installations[st.installation];
  const InstallationProgram& ip = sheet.program.of(st.installation);
  const double a = ip.sweeps.front().positions.front().angle_deg;
  const double bar = ip.bar_mm;
  // Drawn in the axis' own frame: table, (L, D, H) = (reference, direction x reference,
  // direction), the C shorthand's X, Y, Z; head, (direction x reference, direction, reference),
  // the B shorthand's X, Y, Z.
  const Eigen::Vector3d d_x_r = axis.direction().cross(axis.reference());
  // A general-form table set up from a kit: the kit's table (its normal and surface) and the
  // cup and blocks under this installation's ball. A table whose normal is its axis is drawn
  // with the normal up (a primed table turned half a turn about its reference); a trunnion's
  // table is drawn along its axis, turned to the angle.
  const auto& table = sheet.kit_table;
  const std::optional<Stack>* stack =
      sheet.kit_stacks.empty() ? nullptr : &sheet.kit_stacks[st.installation];
  const bool across = table && table->carriage == TableCarriage::kAcrossAxis;
  const double flip = table && !across && table->normal.dot(axis.direction()) < 0 ? -1 : 1;
  Eigen::Matrix3d to_view;
  // A table is seen along its axis, from the side its normal faces (toward the viewer: w).
  // About a vertical axis the reference is to the right (the C shorthand's X right, Y up);
  // about another, machine Z is up as far as the view shows it (a trunnion's table at its zero
  // is level), so that the picture stands as the machine does.
  const Eigen::Vector3d w = flip * axis.direction();
  std::string view_axes;
  if (axis.table()) {
    Eigen::Vector3d right = axis.reference(), up = w.cross(right);
    const std::string r = machine_axis_name(right);
    if (std::abs(w.z()) < 0.9) {
      up = (Eigen::Vector3d::UnitZ() - w.z() * w).normalized();
      right = up.cross(w);
      const std::string r_turned = machine_axis_name(right);
      view_axes = " (" + (r_turned.empty() ? std::string() : r_turned + " right, ") +
                  (machine_axis_name(up) == "Z" ? "Z up" : "Z toward the top") + ")";
    } else if (!r.empty() && !machine_axis_name(up).empty()) {
      view_axes = " (" + r + " right, " + machine_axis_name(up) + " up)";
    }
    to_view << right.transpose(), up.transpose(), w.transpose();
  } else {
    // A spindle pointing down at angle 0 is drawn down: the view turned 180 deg about the axis.
    const double up = axis.reference().z() < 0 ? -1 : 1;
    to_view << up * d_x_r.transpose(), axis.direction().transpose(),
        up * axis.reference().transpose();
  }
  const bool shorthand = !axis.shorthand().empty();
  const std::string letter(1, axis.letter());
  const Eigen::Vector3d P_machine = ball_position_mm(axis, in, a);
  const Eigen::Vector3d P = (to_view * P_machine).array() + 0.0;
  const Eigen::Vector3d F =
      (to_view * (P_machine - in.sign * bar * direction_machine(axis, in, a))).array() + 0.0;
  std::ostringstream s;
  const double W = 640, H = 320;
  s << "<svg xmlns='http://www.w3.org/2000/svg' width='" << W << "' height='" << H
    << "' viewBox='0 0 " << W << " " << H << "' font-family='sans-serif'>";
  s << "<rect width='" << W << "' height='" << H << "' fill='white'/><g class='data'>";
  const std::string bar_style = "stroke:#1f77b4;stroke-width:3";
  const std::string axis_style = "stroke:#888;stroke-dasharray:4 3";
  if (axis.table()) {
    // From above: the axis, the paths of both balls (dashed), the balls and the bar.
    const double surface = table ? table->surface_mm : 0.0;
    const double R =
        std::max({P.head<2>().norm(), F.head<2>().norm(), across ? std::abs(surface) : 0.0, 50.0}) *
        1.1;
    const Panel top(0, 0, 320, {{-R, -R}, {R, R}});
    caption(s, top,
            (shorthand ? std::string("from above (X right, Y up), C ")
             : table && !across
                 ? "onto the table, its normal toward you" + view_axes + ", " + letter + " "
                 : "along " + letter + view_axes + ", " + letter + " ") +
                mm(a) + " deg; dashed: the paths" +
                (!across           ? ""
                 : stack && *stack ? "; the table and the ball's cup and blocks"
                                   : "; the table (no stack of the kit builds the ball's height)"));
    line(s, top, -R, 0, R, 0, axis_style);
    line(s, top, 0, -R, 0, R, axis_style);
    path(s, top, P.head<2>().norm());
    path(s, top, F.head<2>().norm());
    if (across) {
      // The trunnion's table turned to the angle: at least the chord of the panel's circle at
      // the surface, and under the ball's blocks; the cup on its blocks along the turned normal.
      const Eigen::Vector3d turned =
          to_view * (Eigen::AngleAxisd(a * M_PI / 180, axis.direction()) * table->normal);
      const Eigen::Vector2d n = turned.head<2>().normalized(), t(-n.y(), n.x());
      const double height = P.head<2>().dot(n) - surface;
      const Eigen::Vector2d foot = P.head<2>() - height * n;
      const double half =
          std::max(std::sqrt(std::max(R * R - surface * surface, 0.0)), std::abs(foot.dot(t)) + 30);
      line(s, top, surface * n.x() - half * t.x(), surface * n.y() - half * t.y(),
           surface * n.x() + half * t.x(), surface * n.y() + half * t.y(),
           "stroke:#333;stroke-width:2");
      if (stack && *stack) {
        double z = 0;
        for (double b : (*stack)->blocks_mm) {
          block(s, top, foot + z * n, n, 40, b, "#e0c080");
          z += b;
        }
        block(s, top, foot + z * n, n, 20, std::max(height - z, 0.0), "#bbbbbb");
      }
    }
    line(s, top, P.x(), P.y(), F.x(), F.y(), bar_style);
    ball(s, top, P.x(), P.y(), "#d62728", "ball " + in.id);
    ball(s, top, F.x(), F.y(), "#2ca02c", "spindle", true);
    // From the side, in the vertical plane through the axis and the ball (radial r, height z).
    const Eigen::Vector2d radial =
        P.head<2>().norm() > 1e-9
            ? Eigen::Vector2d(P.head<2>().normalized())
            : Eigen::Vector2d(std::cos(a * M_PI / 180), std::sin(a * M_PI / 180));
    const double pr = P.head<2>().dot(radial), fr = F.head<2>().dot(radial);
    // At least 200 mm across, so that a small set-up is not drawn larger than a big one.
    // The table surface under the ball, where this view shows it as a line: the C shorthand's
    // at 0, a general table's whose normal is its axis at its surface (from the kit; without
    // one a general design does not state its table, and its balls alone are drawn).
    const bool table_here = shorthand || (table && !across);
    const double table_z = shorthand ? 0.0 : surface;
    const double lo = std::min({pr, fr, 0.0}) - 30, hi = std::max({pr, fr, 0.0}) + 30,
                 top_z = std::max({P.z(), F.z(), 0.0, table_here ? table_z : 0.0}) + 20,
                 low_z = std::min(
                     {F.z(), 0.0, table_here ? table_z : 0.0, shorthand ? 0.0 : P.z() - 20});
    const double wide = std::max(0.0, 200 - (hi - lo)) / 2;
    const Panel side(320, 0, 320, {{lo - wide, low_z}, {hi + wide, std::max(top_z, low_z + 200)}});
    caption(s, side,
            shorthand    ? "from the side (radial right, Z up)"
            : table_here ? "across " + letter + " (radial right, the table's normal up)"
                         : "across " + letter + " (radial right, along " + letter + " up)");
    if (table_here) {
      line(s, side, side.cx - 0.5 * side.size / side.scale, table_z,
           side.cx + 0.5 * side.size / side.scale, table_z, "stroke:#333;stroke-width:2");
    }
    // The axis from the table (the C shorthand's origin) or, on another table, through the origin
    // and past both balls (a trunnion's may lie on either side of the origin along its axis).
    line(s, side, 0, shorthand ? 0.0 : std::min({0.0, P.z(), F.z()}) - 20, 0,
         std::max({P.z(), F.z(), shorthand ? P.z() : 0.0}) + 20, axis_style);
    const std::vector<double>* blocks = shorthand                       ? &in.blocks_mm
                                        : table_here && stack && *stack ? &(*stack)->blocks_mm
                                                                        : nullptr;
    if (blocks) {
      double z = table_z;
      for (double b : *blocks) {
        rect(s, side, pr - 20, z, 40, b, "#e0c080");
        z += b;
      }
      rect(s, side, pr - 10, z, 20, std::max(P.z() - z, 0.0), "#bbbbbb");
    }
    line(s, side, pr, P.z(), fr, F.z(), bar_style);
    ball(s, side, pr, P.z(), "#d62728", "ball");
    ball(s, side, fr, F.z(), "#2ca02c", "spindle", true);
  } else {
    // The swing plane X-Z: pivot, tool axis to the ball, the table's ball and the bar.
    const Panel plane(0, 0, 320, {{P.x(), P.z()}, {F.x(), F.z()}, {0, 0}});
    caption(s, plane,
            (shorthand ? std::string("swing plane (X right, Z up), B ")
                       : "swing plane (direction x spindle right, spindle at " + letter + "0 " +
                             (axis.reference().z() < 0 ? "down" : "up") + "), " + letter + " ") +
                mm(a) + " deg");
    line(s, plane, 0, 0, P.x(), P.z(), "stroke:#555;stroke-width:4");
    line(s, plane, P.x(), P.z(), F.x(), F.z(), bar_style);
    ball(s, plane, 0, 0, "#ffffff", "pivot");
    ball(s, plane, P.x(), P.z(), "#d62728", "ball " + in.id);
    ball(s, plane, F.x(), F.z(), "#2ca02c", "table ball", true);
    const Panel front(320, 0, 320, {{P.y(), P.z()}, {F.y(), F.z()}, {0, 0}});
    caption(s, front,
            shorthand ? "along X (Y right, Z up): the offset D"
                      : "across the swing plane (along the axis right): the offset H");
    line(s, front, 0, 0, P.y(), P.z(), "stroke:#555;stroke-width:4");
    line(s, front, P.y(), P.z(), F.y(), F.z(), bar_style);
    ball(s, front, 0, 0, "#ffffff", "pivot");
    ball(s, front, P.y(), P.z(), "#d62728", "ball");
    ball(s, front, F.y(), F.z(), "#2ca02c", "table ball", true);
  }
  s << "</g></svg>";
  return s.str();
}

void write_setup_sheet(ReportWriter& w, const SetupSheet& sheet, const std::string& kit_file,
                       int level) {
  const Design& d = sheet.design;
  const SetupOrder& o = sheet.order;
  const MeasurementProgram& pr = sheet.program;
  int positions = 0;
  for (const SetupStep& s : o.steps) positions = std::max(positions, s.position);
  if (level > 1) w.heading("Set-up sheet: " + d.name, level);
  std::string intro =
      "Axis " + std::string(d.axis.label()) + ", " + std::to_string(d.installations.size()) +
      " installations at " + std::to_string(positions) + " ball positions, " +
      std::to_string(d.angles_deg.size()) + " angles from " +
      mm(*std::min_element(d.angles_deg.begin(), d.angles_deg.end())) + " to " +
      mm(*std::max_element(d.angles_deg.begin(), d.angles_deg.end())) +
      " deg: " + std::to_string(pr.readings) + " readings. " + time_text(sheet, kit_file);
  w.paragraph(intro);
  if (d.partial_sweeps()) {
    // Installations read over part of the travel (e.g. the bar on one side of a trunnion's zero).
    std::string part;
    for (std::size_t i = 0; i < d.installations.size(); ++i) {
      const std::vector<double>& a = d.angles_of(static_cast<int>(i));
      if (a.size() == d.angles_deg.size()) continue;
      part += (part.empty() ? "" : "; ") + d.installations[i].id + ": " + std::to_string(a.size()) +
              " angles from " + mm(*std::min_element(a.begin(), a.end())) + " to " +
              mm(*std::max_element(a.begin(), a.end())) + " deg";
    }
    w.paragraph(
        "Installations read at part of the angles (their sweeps cover these alone): " + part + ".");
  }
  if (d.machine) {
    // The machine the axis belongs to: the other axes parked, the preset from its kinematics.
    const Machine& m = *d.machine->machine;
    const std::string parks = parked_text(*d.machine, 3);
    const std::vector<double> a = d.machine->park_angles();
    const Eigen::Vector3d o = d.machine->origin_mm();
    const std::string measured =
        "Machine " + m.name + " (controller " + controller_name(m.controller) + "): axis " +
        std::string(1, d.axis.letter()) + " is measured" +
        (parks.empty() ? "" : " with " + parks + " (parked: the program commands it)");
    const std::string park = mm(a[static_cast<std::size_t>(d.machine->axis)]);
    if (d.axis.head() && pr.preset_range) {
      // A head: the table ball is the work frame's origin, placed under the spindle ball.
      const MeasurementProgram::PresetRange& r = *pr.preset_range;
      std::string box;
      for (int i = 0; i < 3; ++i)
        box += std::string(i ? ", " : "") + "XYZ"[i] + " " + mm(r.min_mm(i)) + " to " +
               mm(r.max_mm(i));
      w.paragraph(
          measured +
          ". The work frame's origin (the preset) is the table ball's centre, its cup "
          "placed under the spindle ball with the axis at " +
          park +
          " deg: the head's errors are measured against the tool as it stands there. Place the "
          "table ball with its centre at " +
          box + " mm in the machine file's frame" +
          (r.table_radius_mm
               ? ", on the table (its surface at Z " + mm(*r.table_surface_z_mm + 0.0) +
                     " mm, within " + mm(*r.table_radius_mm) + " mm of its axis)"
               : std::string()) +
          " (the pivot at X " + mm(o.x()) + ", Y " + mm(o.y()) + ", Z " + mm(o.z()) +
          " mm with the linear axes at zero): there every pivot position and the clearance plane "
          "stay inside the linear travel. " +
          (r.lowest_z_mm < 0
               ? "The pivot and the spindle ball come down to " + mm(-r.lowest_z_mm) +
                     " mm below the table ball's centre: stand it at least that high above the "
                     "table, more by what the head reaches below its pivot."
               : std::string("The pivot and the spindle ball stay above the table ball's "
                             "centre.")));
    } else {
      w.paragraph(measured +
                  ". The work frame's origin (the preset) is the axis' nominal point X " +
                  mm(o.x()) + ", Y " + mm(o.y()) + ", Z " + mm(o.z()) +
                  " mm in the machine file's frame (machine coordinates where its origin is the "
                  "machine zero): set it from the controller's kinematics table, never "
                  "by teaching it on the real axis (the location errors are the real axis line "
                  "minus this one). Each cup is placed with the axis at " +
                  park + " deg, then turned.");
    }
  }
  w.paragraph(
      "The program (dbbkit program) reaches and leaves every installation from the "
      "clearance plane Z " +
      mm(pr.clearance_z_mm) +
      " mm of the work frame: sideways only there, along Z alone at the feed below it. "
      "Run it first as an air run (program --air-run): no bar, a stop at each "
      "installation and after the first step of each sweep, to see the rotary axis turn "
      "the right way and every clearance before a bar is mounted.");
  std::string order;
  for (const SetupStep& s : o.steps)
    order += (order.empty() ? "" : " ") + d.installations[s.installation].id;
  const std::string changes =
      d.axis.table()
          ? "the cup moves " + times(o.cup_moves) + ", the block stack is rebuilt " +
                times(o.stack_changes) + " and the bar reassembled " + times(o.bar_changes) +
                " (in the design's order: " + times(o.design_cup_moves) + ", " +
                times(o.design_stack_changes) + " and " + times(o.design_bar_changes) + ")"
          : "the ball moves " + times(o.cup_moves) + " and the bar is reassembled " +
                times(o.bar_changes) + " (in the design's order: " + times(o.design_cup_moves) +
                " and " + times(o.design_bar_changes) + ")";
  w.paragraph("Order: " + order + ". After the first set-up " + changes +
              ". The installations at one ball position follow each other, and the positions "
              "are ordered to " +
              (d.axis.table() ? "rebuild the block stack the fewest times, then to " : "") +
              "reassemble the bar the fewest times" +
              (o.exhaustive ? " (the least over every order of the positions; the design's own "
                              "order where none changes less)."
                            : " (greedily: too many positions to try every order)."));
  if (sheet.rounding) {
    const RoundedDesign& r = *sheet.rounding;
    std::string t = "Ball positions rounded to " + fmt_num(r.resolution_mm) +
                    " mm (the largest shift " + mm(r.largest_shift_mm) +
                    " mm). worst_std_um (k = 1): " + fmt_opt(r.worst_std_um) + " um as designed, " +
                    fmt_opt(r.rounded_worst_std_um) + " um as rounded" +
                    (r.worst_total_std_um || r.rounded_worst_total_std_um
                         ? "; with the declared set-up tolerances (worst_total_std_um): " +
                               fmt_opt(r.worst_total_std_um) + " um and " +
                               fmt_opt(r.rounded_worst_total_std_um) + " um."
                         : std::string(" (from the reading noise alone: the design declares no "
                                       "length offset or centring tolerance)."));
    if (!r.travel_checked) t += " The travel was not checked (give --kit).";
    w.paragraph(t);
  }
  if (sheet.travel_checked) {
    std::string t;
    if (sheet.outside_travel.empty()) {
      t = "Every following ball stays inside the kit's travel.";
    } else if (!sheet.outside_travel_as_given.empty()) {
      t = "OUTSIDE the kit's travel as designed (not from any rounding):";
      for (const auto& [id, v] : sheet.outside_travel_as_given)
        t += " " + id + " by " + mm(v) + " mm;";
      t += " this design cannot be measured with this kit: move these balls or choose another "
           "design.";
    } else {
      t = "OUTSIDE the kit's travel once rounded:";
      for (const auto& [id, v] : sheet.outside_travel) t += " " + id + " by " + mm(v) + " mm;";
      t += " choose a finer resolution or move these balls by hand.";
    }
    w.paragraph(t);
  }
  if (const std::string t = workspace_text(sheet); !t.empty()) w.paragraph(t);
  if (sheet.clearance_above_travel_mm && *sheet.clearance_above_travel_mm > 0)
    w.paragraph("OUTSIDE the kit's travel: the clearance plane Z " + mm(pr.clearance_z_mm) +
                " mm lies " + mm(*sheet.clearance_above_travel_mm) +
                " mm above the travel in z; give a lower --clearance-z-mm or a smaller "
                "--clearance-margin-mm, or choose lower balls.");
  std::vector<std::vector<std::string>> rows;
  for (size_t k = 0; k < o.steps.size(); ++k) {
    const SetupStep& s = o.steps[k];
    const Installation& in = d.installations[s.installation];
    const InstallationProgram& ip = pr.of(s.installation);
    // Table: the spindle ball (the commanded point); head: the table ball from the pivot, the
    // commanded pivot seen from the table ball at the work frame's origin.
    const Eigen::Vector3d first = ip.sweeps.front().positions.front().linear_mm;
    const Eigen::Vector3d follow = d.axis.table() ? first : Eigen::Vector3d(-first);
    std::vector<std::string> row = {
        std::to_string(k + 1),
        in.id,
        std::to_string(s.position),
        sheet_ball_text(d.axis, in),
        stack_text(d.axis, in,
                   sheet.kit_stacks.empty() ? nullptr : &sheet.kit_stacks[s.installation]),
        bar_text(in),
        in.direction.label() + (in.sign > 0 ? " +1" : " -1"),
        xyz(follow),
        sweeps_text(ip),
        std::to_string(ip.readings),
        fmt_rounded(ip.motion_time_s, 0)};
    if (!sheet.step_time_s.empty()) row.push_back(fmt_rounded(sheet.step_time_s[k], 0));
    rows.push_back(std::move(row));
  }
  std::vector<std::string> head = {
      "step",
      "installation",
      "position",
      "ball [mm]",
      "cup and blocks",
      "bar [mm]",
      "direction, sign",
      d.axis.table() ? "spindle ball at the first angle [mm]" : "table ball from the pivot [mm]",
      "sweep",
      "readings",
      "program's moves and dwells [s]"};
  if (!sheet.step_time_s.empty()) head.push_back("set-up and readings, the kit's model [s]");
  w.table(head, rows);
  for (size_t k = 0; k < o.steps.size(); ++k) {
    const Installation& in = d.installations[o.steps[k].installation];
    w.heading("Step " + std::to_string(k + 1) + ": installation " + in.id, std::max(2, level + 1));
    w.paragraph(instructions(sheet, static_cast<int>(k)));
    w.figure([&sheet, k] { return installation_drawing(sheet, static_cast<int>(k)); },
             "Installation " + in.id + " to scale at the first angle: the ball (red), the " +
                 (d.axis.table() ? std::string("spindle's ball") : "table's ball") +
                 " (green) and the bar (blue).");
  }
}

std::string setup_sheet_report(ReportFormat format, const RunContext& run, const SetupSheet& sheet,
                               const std::string& kit_file) {
  auto w = make_report_writer(format, "dbbkit set-up sheet: " + sheet.design.name);
  write_setup_sheet(*w, sheet, kit_file, 1);  // the page's title is the sheet's heading
  detail::conditions(*w, run, &sheet.design);
  return w->str();
}

std::string setup_sheet_summary(const SetupSheet& sheet) {
  std::ostringstream s;
  const Design& d = sheet.design;
  s << "set-up sheet of " << d.name << ": " << d.installations.size() << " installations, "
    << sheet.program.readings << " readings, the program's moves and dwells about "
    << fmt_rounded(sheet.program.motion_time_s / 60.0, 1) << " min";
  if (sheet.time)
    s << "; the kit's time model (set-ups and readings, as optimize plans) about "
      << fmt_rounded(sheet.time->total_s / 60.0, 1) << " min";
  s << "\norder:";
  for (const SetupStep& st : sheet.order.steps) s << " " << d.installations[st.installation].id;
  s << " (cup moved " << sheet.order.cup_moves << ", stack rebuilt " << sheet.order.stack_changes
    << ", bar reassembled " << sheet.order.bar_changes << " times; in the design's order "
    << sheet.order.design_cup_moves << ", " << sheet.order.design_stack_changes << ", "
    << sheet.order.design_bar_changes << ")\n";
  if (sheet.rounding) {
    s << "rounded to " << fmt_num(sheet.rounding->resolution_mm) << " mm: worst_std_um (k = 1) "
      << fmt_opt(sheet.rounding->worst_std_um) << " -> "
      << fmt_opt(sheet.rounding->rounded_worst_std_um) << " um";
    if (sheet.rounding->worst_total_std_um || sheet.rounding->rounded_worst_total_std_um)
      s << ", worst_total_std_um " << fmt_opt(sheet.rounding->worst_total_std_um) << " -> "
        << fmt_opt(sheet.rounding->rounded_worst_total_std_um) << " um";
    s << "\n";
  }
  if (sheet.clearance_above_travel_mm && *sheet.clearance_above_travel_mm > 0)
    s << "OUTSIDE the kit's travel: the clearance plane Z " << mm(sheet.program.clearance_z_mm)
      << " mm, " << mm(*sheet.clearance_above_travel_mm) << " mm above the travel\n";
  for (const auto& [id, c] : sheet.clashes)
    s << "CLASH " << id << ": " << c.what << " by " << mm(c.by_mm) << " mm\n";
  if (!sheet.outside_travel.empty()) {
    s << "OUTSIDE the kit's travel "
      << (sheet.outside_travel_as_given.empty() ? "once rounded" : "as designed") << ":";
    for (const auto& [id, v] : sheet.outside_travel) s << " " << id << " by " << mm(v) << " mm;";
    s << "\n";
  }
  return s.str();
}

}  // namespace dbbkit::io
