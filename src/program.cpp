#include "dbbkit/program.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>

#include "dbbkit/error.hpp"
#include "dbbkit/instrument.hpp"
#include "dbbkit/kinematics.hpp"
#include "dbbkit/limits.hpp"
#include "dbbkit/setup_sheet.hpp"
#include "dbbkit/user_text.hpp"
#include "number_text.hpp"

namespace dbbkit {

namespace {

// The bar length along an interpolated sub-step is sampled at kPathSamples interior
// points: the change is a smooth bump (the sagitta of the ball's arc against the chord),
// largest near the middle, so 16 samples find its peak to well inside the tolerance.
constexpr int kPathSamples = 16;
// A step is split into at most this many sub-steps (a 0.001 mm tolerance on a 1 m radius
// over 360 deg needs about 1.5e4).
constexpr int kMaxSubsteps = 1000000;

// Largest | |P(a(t)) - F(t)| - bar | over the sub-step from angle a0 to a1, F interpolated
// linearly between the nominal following-ball positions at its ends. Under TCPM the controller
// interpolates the tool tip in the workpiece frame: on a table it holds the spindle ball still
// on the table (no change), on a head it moves the spindle ball along the chord about the table
// ball.
double substep_bar_change(const AxisFrame& axis, const Installation& inst, double bar, double a0,
                          double a1, bool tcpm) {
  if (tcpm) {
    if (axis.table()) return 0;
    const Eigen::Vector3d u0 = direction_machine(axis, inst, a0),
                          u1 = direction_machine(axis, inst, a1);
    double worst = 0;
    for (int k = 1; k <= kPathSamples; ++k) {
      const double t = static_cast<double>(k) / (kPathSamples + 1);
      worst = std::max(worst, std::abs(bar * (u0 + t * (u1 - u0)).norm() - bar));
    }
    return worst;
  }
  const Eigen::Vector3d P0 = ball_position_mm(axis, inst, a0),
                        P1 = ball_position_mm(axis, inst, a1);
  const Eigen::Vector3d F0 = P0 - inst.sign * bar * direction_machine(axis, inst, a0);
  const Eigen::Vector3d F1 = P1 - inst.sign * bar * direction_machine(axis, inst, a1);
  double worst = 0;
  for (int k = 1; k <= kPathSamples; ++k) {
    const double t = static_cast<double>(k) / (kPathSamples + 1);
    const Eigen::Vector3d P = ball_position_mm(axis, inst, a0 + t * (a1 - a0));
    const Eigen::Vector3d F = F0 + t * (F1 - F0);
    worst = std::max(worst, std::abs((P - F).norm() - bar));
  }
  return worst;
}

// Sub-steps of the step a0 -> a1 so that every one keeps the bar within the tolerance.
int substeps(const AxisFrame& axis, const Installation& inst, double bar, double a0, double a1,
             double tol, bool tcpm, double& largest_change) {
  const double whole = substep_bar_change(axis, inst, bar, a0, a1, tcpm);
  if (whole <= tol) {
    largest_change = std::max(largest_change, whole);
    return 1;
  }
  // The change falls as 1/n^2 with n sub-steps; start there and add until it holds.
  int n = std::max(2, static_cast<int>(std::ceil(std::sqrt(whole / tol))));
  for (; n <= kMaxSubsteps; ++n) {
    double worst = 0;
    for (int k = 0; k < n && worst <= tol; ++k) {
      worst = std::max(worst, substep_bar_change(axis, inst, bar, a0 + (a1 - a0) * k / n,
                                                 a0 + (a1 - a0) * (k + 1) / n, tcpm));
    }
    if (worst <= tol) {
      largest_change = std::max(largest_change, worst);
      return n;
    }
  }
  throw InputError("program", "path_tolerance_mm",
                   "a step of " + text::significant(a1 - a0, 6) + " deg needs more than " +
                       std::to_string(kMaxSubsteps) + " sub-steps to keep the bar within " +
                       text::significant(tol, 6) + " mm");
}

// The machine's options against the design: TCPM needs the controller's kinematics (a machine
// file); under TCPM the tool tip is the spindle ball, on the spindle's axis; without it the tool
// length acts along Z, so a head axis stands at 0 while a table axis is measured.
void check_machine_options(const Design& design, const ProgramOptions& o) {
  if (!design.machine) {
    if (o.tcpm)
      throw InputError("program", "tcpm",
                       "TCPM runs on the controller's kinematics: the design must name its "
                       "machine (\"machine\": \"m.json\", formats.md, \"Machine file\")");
    return;
  }
  const Machine& m = *design.machine->machine;
  const std::vector<double> park = design.machine->park_angles();
  if (o.tcpm && design.axis.head()) {
    // The spindle's axis with the axis under test at 0: the innermost head axis' reference (from
    // its pivot to the tool tip) turned by every head axis (machine frame).
    const int h = m.innermost(AxisFrame::Side::kHead);
    const std::vector<double> at_zero = design.machine->angles_at(0);
    const Eigen::Vector3d pivot = m.body_point_at(h, m.rotary[h].point_mm, at_zero);
    const Eigen::Vector3d tool = *head_tool_direction(design.axis, design.machine);
    const Eigen::Vector3d origin = m.point_at(design.machine->axis, at_zero);
    for (std::size_t i = 0; i < design.installations.size(); ++i) {
      const Installation& inst = design.installations[i];
      const Eigen::Vector3d v = origin + ball_body_mm(design.axis, inst) - pivot;
      if (v.cross(tool).norm() > 1e-6 || v.dot(tool) <= 0)
        throw InputError("program", "installations[" + std::to_string(i) + "].ball_mm",
                         "installation " + inst.id +
                             ": under TCPM the tool tip is the spindle ball, on the spindle's "
                             "axis beyond the pivot; this ball lies off it (measure it with TCPM "
                             "off)");
    }
  }
  if (design.axis.table()) {
    // The cups are placed with the table level: every table axis that tilts it (one not along Z)
    // and carries the table of the axis under test, or is that axis, stands at 0 then.
    std::vector<int> tilting = m.carriers(design.machine->axis);
    tilting.push_back(design.machine->axis);
    for (const int k : tilting) {
      const RotaryAxisSpec& r = m.rotary[static_cast<std::size_t>(k)];
      if (r.side != AxisFrame::Side::kTable ||
          r.direction.cross(Eigen::Vector3d::UnitZ()).norm() < 1e-9 ||
          park[static_cast<std::size_t>(k)] == 0)
        continue;
      throw InputError("program", "park_deg",
                       std::string("table axis ") + r.letter + " stands at " +
                           text::significant(park[static_cast<std::size_t>(k)], 6) +
                           " deg while the cups are placed: the table would be tilted; the cups "
                           "are placed on a level table (park " +
                           r.letter + " at 0)");
    }
  }
  if (o.tcpm) {
    // TCPM's workpiece frame is the controller's with every axis at 0: another table axis parked
    // away from 0 would turn it under the program's coordinates.
    for (std::size_t k = 0; k < m.rotary.size(); ++k) {
      if (static_cast<int>(k) != design.machine->axis &&
          m.rotary[k].side == AxisFrame::Side::kTable && park[k] != 0)
        throw InputError("program", "tcpm",
                         std::string("table axis ") + m.rotary[k].letter + " parks at " +
                             text::significant(park[k], 6) +
                             " deg: under TCPM the workpiece frame is the controller's with "
                             "every axis at 0; park it at 0, or run with TCPM off");
    }
  }
  if (!o.tcpm) {
    // Without TCPM the positions come from dbbkit's frame, the machine axes: a controller's
    // vector off them would be measured as an error of the axis it already corrects.
    for (const RotaryAxisSpec& r : m.rotary) {
      if (!r.controller_direction) continue;
      const double urad =
          1e6 * std::asin(std::min(1.0, r.controller_direction->cross(r.direction).norm()));
      throw InputError("program", "tcpm",
                       std::string("the machine file's direction of axis ") + r.letter + " is " +
                           text::significant(urad, 4) +
                           " urad off its machine axis (a corrected kinematics): without TCPM the "
                           "positions would be computed on the machine axis; run with TCPM on, "
                           "so that the controller moves on its own vector");
    }
  }
  if (!o.tcpm && design.axis.table()) {
    for (std::size_t k = 0; k < m.rotary.size(); ++k) {
      if (m.rotary[k].side == AxisFrame::Side::kHead && park[k] != 0)
        throw InputError("program", "tcpm",
                         std::string("head axis ") + m.rotary[k].letter + " parks at " +
                             text::significant(park[k], 6) +
                             " deg: without TCPM the tool length acts along Z, so the spindle "
                             "must stand at 0 (park it there, or run with TCPM on)");
    }
  }
}

// The highest point (work frame Z) of the table discs and the workspace solids that turn with
// the axis under test or carry it, over `angles`; -inf when there are none.
double machine_top_z(const Design& design, const std::vector<double>& angles) {
  const Machine& m = *design.machine->machine;
  const Eigen::Vector3d origin = design.machine->origin_mm();
  double top = -std::numeric_limits<double>::infinity();
  for (double angle : angles) {
    const std::vector<double> a = design.machine->angles_at(angle);
    for (std::size_t k = 0; k < m.rotary.size(); ++k) {
      const RotaryAxisSpec& r = m.rotary[k];
      if (!r.table_diameter_mm) continue;
      const Eigen::Vector3d c =
          m.body_point_at(static_cast<int>(k), m.table_centre_mm(static_cast<int>(k)), a);
      const Eigen::Vector3d n = m.body_direction_at(static_cast<int>(k), r.direction, a);
      const double rise = 0.5 * *r.table_diameter_mm * std::sqrt(std::max(0.0, 1 - n.z() * n.z()));
      top = std::max(top, c.z() + rise - origin.z());
    }
    for (const WorkspaceSolid& w : m.solids) {
      if (w.turns_with < 0) continue;  // fixed to the frame: what moves must stay clear of it
      for (int corner = 0; corner < 8; ++corner) {
        const Eigen::Vector3d x0((corner & 1) ? w.max_mm.x() : w.min_mm.x(),
                                 (corner & 2) ? w.max_mm.y() : w.min_mm.y(),
                                 (corner & 4) ? w.max_mm.z() : w.min_mm.z());
        const Eigen::Vector3d x = m.body_point_at(w.turns_with, x0, a);
        top = std::max(top, x.z() - origin.z());
      }
    }
  }
  return top;
}

// Every position and the arcs between them keep the spindle ball and the bar out of the table
// ball's cup and stand (below_cup_mm); throws InputError naming the installation's sign.
void check_cups(const Design& design, const MeasurementProgram& program) {
  const AxisFrame& axis = design.axis;
  if (axis.table() && !table_up(design.axis, design.machine, 0)) return;
  // On a table the bar and the table's normal turn together: one angle tells. On a head the
  // table stays and the bar turns: between two positions the axis turns, so each installation's
  // swept range is sampled at most this far apart, its positions exactly.
  constexpr double kSample_deg = 0.1;
  const std::optional<Eigen::Vector3d> head_up =
      axis.head() ? table_up(design.axis, design.machine, 0) : std::optional<Eigen::Vector3d>();
  for (const InstallationProgram& ip : program.installations) {
    const Installation& inst = design.installations[static_cast<std::size_t>(ip.installation)];
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (const ProgramSweep& sw : ip.sweeps) {
      for (const ProgramPosition& p : sw.positions) {
        lo = std::min(lo, p.angle_deg);
        hi = std::max(hi, p.angle_deg);
      }
    }
    if (!(lo <= hi)) continue;
    std::vector<double> angles;
    if (axis.table()) {
      angles.push_back(ip.sweeps.front().positions.front().angle_deg);
    } else {
      const int n = std::max(1, static_cast<int>(std::ceil((hi - lo) / kSample_deg)));
      for (int j = 0; j <= n; ++j) angles.push_back(lo + (hi - lo) * j / n);
      for (const ProgramSweep& sw : ip.sweeps)
        for (const ProgramPosition& p : sw.positions) angles.push_back(p.angle_deg);
    }
    double worst = 0, worst_angle = lo;
    bool other_side_dips = false;  // the other sign dips somewhere over the same angles too
    Eigen::Vector3d worst_v = Eigen::Vector3d::Zero(), worst_up = worst_v;
    for (const double a : angles) {
      // The spindle ball less the table ball: on a table, F - P = -s bar u; on a head, P - F.
      const Eigen::Vector3d u = direction_machine(axis, inst, a);
      const Eigen::Vector3d v = (axis.table() ? -1.0 : 1.0) * inst.sign * ip.bar_mm * u;
      const Eigen::Vector3d up = head_up ? *head_up : *table_up(design.axis, design.machine, a);
      const double by = below_cup_mm(v.dot(up), v.norm());
      if (by > worst) worst = by, worst_angle = a, worst_v = v, worst_up = up;
      if (below_cup_mm(-v.dot(up), v.norm()) > 1e-9) other_side_dips = true;
    }
    if (worst <= 1e-9) continue;
    constexpr double kDegree = 3.14159265358979323846 / 180.0;
    const double below = -worst_v.dot(worst_up);
    const double tilt = std::asin(std::clamp(below / worst_v.norm(), -1.0, 1.0)) / kDegree;
    throw InputError(
        "design", "installations[" + std::to_string(ip.installation) + "].sign",
        "installation " + inst.id + " at " + std::string(1, axis.letter()) +
            text::significant(std::round(worst_angle * 1e4) / 1e4, 7) +
            ": the spindle ball stands " + text::significant(below, 4) +
            " mm below the table ball's centre, the bar " + text::significant(tilt, 3) +
            " deg below the plane of its cup (at most " +
            text::significant(kMaxBarBelowCup_deg, 3) +
            " deg: beyond, the spindle ball and the bar are driven into the cup and "
            "its stand); " +
            (other_side_dips
                 ? std::string("neither side keeps the bar out of the cup over this "
                               "installation's angles: read it on each side of the angle "
                               "where the bar crosses the cup's plane as two installations "
                               "(each its own angles_deg and sign)")
                 : "put the table ball on the other side of the spindle ball "
                   "(sign " +
                       std::string(inst.sign > 0 ? "-1" : "+1") +
                       "; reading_sign says how the instrument counted)"));
  }
}

}  // namespace

void validate_program_options(const ProgramOptions& o, const std::string& source) {
  auto check = [&](bool ok, const char* key, const std::string& what) {
    if (!ok) throw InputError(source, key, what);
  };
  // Within [lo, hi], said with the key's own unit.
  auto within = [&](double x, double lo, double hi, const char* key, const std::string& what,
                    const std::string& unit) {
    check(std::isfinite(x) && x >= lo && x <= hi, key,
          what + " must be in [" + text::significant(lo, 6) + ", " + text::significant(hi, 6) +
              "] " + unit + ", got " + text::significant(x, 6));
  };
  within(o.dwell_s, limits::kMinDwell_s, limits::kMaxDwell_s, "dwell_s", "the dwell", "s");
  within(o.feed_mm_per_min, limits::kMinFeed_mm_per_min, limits::kMaxFeed_mm_per_min,
         "feed_mm_per_min", "the feed", "mm/min");
  within(o.path_tolerance_mm, limits::kMinPathTolerance_mm, limits::kMaxPathTolerance_mm,
         "path_tolerance_mm", "the path tolerance (a ballbar reads within about +-1 mm)", "mm");
  check(o.tool_number >= limits::kMinToolNumber && o.tool_number <= limits::kMaxToolNumber,
        "tool_number",
        "a tool number is " + std::to_string(limits::kMinToolNumber) + ".." +
            std::to_string(limits::kMaxToolNumber) + ", got " + std::to_string(o.tool_number));
  within(o.clearance_margin_mm, limits::kMinClearanceMargin_mm, limits::kMaxClearanceMargin_mm,
         "clearance_margin_mm", "the clearance margin", "mm");
  check(!o.clearance_z_mm || (std::isfinite(*o.clearance_z_mm) &&
                              std::abs(*o.clearance_z_mm) <= limits::kMaxLength_mm),
        "clearance_z_mm", "the clearance plane must be a Z within +-10000 mm");
  // Any other M-code (M3 starts the spindle, M8 the coolant) would be written where the cup sits
  // in the spindle: only the orientation code of the dialects written is taken.
  check(o.orient_code.empty() || o.orient_code == kOrientCode, "orient_code",
        quote_value(o.orient_code) +
            " is not the spindle orientation code of the dialects written (" + kOrientCode +
            "); give none to orient the spindle by hand");
}

Eigen::Vector3d commanded_point_mm(const AxisFrame& axis, const Installation& inst, double bar_mm,
                                   double angle_deg) {
  const Eigen::Vector3d F = ball_position_mm(axis, inst, angle_deg) -
                            inst.sign * bar_mm * direction_machine(axis, inst, angle_deg);
  if (axis.table()) return F;
  return -F;  // the pivot, with the table ball at the origin
}

Eigen::Vector3d tcp_point_mm(const AxisFrame& axis, const Installation& inst, double bar_mm,
                             double angle_deg) {
  // A table: F in the table's body frame (the same at every angle); a head: the spindle ball
  // P = F + s bar u with the table ball F at the origin.
  if (axis.table()) return commanded_point_mm(axis, inst, bar_mm, 0.0);
  return inst.sign * bar_mm * direction_machine(axis, inst, angle_deg);
}

const InstallationProgram& MeasurementProgram::of(int installation) const {
  for (const InstallationProgram& ip : installations) {
    if (ip.installation == installation) return ip;
  }
  throw std::out_of_range("MeasurementProgram::of: no installation " +
                          std::to_string(installation));
}

MeasurementProgram measurement_program(const Design& design, const ProgramOptions& options) {
  validate_design(design);
  require_ballbar(design, "design", "a measurement program");
  validate_program_options(options, "program");
  MeasurementProgram program;
  program.axis = design.axis;
  program.options = options;
  const std::vector<Sweep> sweeps = program_sweeps(options.sweeps);
  check_machine_options(design, options);
  program.machine = design.machine;
  // With a machine, the cups are placed with the axis at its park angle (the table level, the
  // spindle upright), then turned; without one, at each installation's first angle.
  const std::optional<double> park =
      design.machine ? std::optional<double>(design.machine->park_angles()[design.machine->axis])
                     : std::nullopt;

  std::size_t positions = 0;
  // The highest point anything reaches (work frame Z; the table surface (C) or the table ball
  // (B) at 0), for the clearance plane; for B the longest pivot-to-ball distance, so that the
  // head can turn at the plane with its ball above the table's (kHeadBallsAllowance_mm more).
  double highest = 0, reach = 0;
  // A head under TCPM: X Y Z command the spindle ball throughout, the plane included (the
  // pivot turns about it there): the highest point the spindle ball reaches.
  double highest_ball = 0;
  std::optional<Eigen::Vector3d> previous_ball;  // the body-frame ball of the installation before
  for (const SetupStep& step : setup_order(design, options.stack_coordinate).steps) {
    const int i = step.installation;
    const Installation& inst = design.installations[i];
    if (!inst.bar_mm) {
      throw InputError("design", "installations[" + std::to_string(i) + "].bar_mm",
                       "installation " + inst.id +
                           " has no bar length: the program cannot place the following ball");
    }
    InstallationProgram ip;
    ip.installation = i;
    ip.bar_mm = *inst.bar_mm;
    const double first = sweep_angles(design, i, sweeps.front()).front();
    const double placement_angle = park.value_or(first);
    const Eigen::Vector3d body = ball_body_mm(design.axis, inst);
    ip.fixed_ball_mm = design.axis.table() ? body : Eigen::Vector3d::Zero();
    // The table's cup is placed once per ball position (B: once, at the origin).
    ip.places_cup = design.axis.table()
                        ? !previous_ball || (*previous_ball - body).norm() > kAssemblyTolerance_mm
                        : !previous_ball;
    previous_ball = body;
    const Eigen::Vector3d P_first = ball_position_mm(design.axis, inst, placement_angle);
    ip.placement_angle_deg = placement_angle;
    ip.placement_mm = design.axis.table() ? P_first : Eigen::Vector3d(-P_first);
    if (design.machine && design.axis.table()) {
      const Machine& m = *design.machine->machine;
      const int disc = m.innermost(AxisFrame::Side::kTable);
      if (disc >= 0 && m.rotary[static_cast<std::size_t>(disc)].table_diameter_mm)
        ip.table_height_mm = m.on_table(disc, design.machine->origin_mm() + P_first,
                                        design.machine->angles_at(placement_angle))
                                 .height_mm;
    }
    if (design.axis.table()) {
      highest = std::max(highest, P_first.z());
    } else {
      reach = std::max(reach, body.norm());
    }
    Eigen::Vector3d last = commanded_point_mm(design.axis, inst, ip.bar_mm, first);
    // The descent to the first position and the retract after the last, along Z at the feed,
    // are counted once the clearance plane is known.
    for (const Sweep s : sweeps) {
      ProgramSweep ps;
      ps.direction = s;
      const std::vector<SweepReading> order = sweep_readings(design, i, s);
      auto add_to = [&](ProgramSweep& to, double a, bool reading) {
        if (++positions > kMaxProgramPositions) {
          throw InputError("program", "path_tolerance_mm",
                           "the program would command more than " +
                               std::to_string(kMaxProgramPositions) + " positions (installation " +
                               inst.id + " needs many sub-steps at a path tolerance of " +
                               text::significant(options.path_tolerance_mm, 6) +
                               " mm): take a larger path tolerance or fewer angles");
        }
        ProgramPosition p;
        p.angle_deg = a;
        p.linear_mm = commanded_point_mm(design.axis, inst, ip.bar_mm, a);
        p.tcp_mm = tcp_point_mm(design.axis, inst, ip.bar_mm, a);
        p.reading = reading;
        ip.motion_time_s += 60.0 * (p.linear_mm - last).norm() / options.feed_mm_per_min;
        if (reading) ip.motion_time_s += options.dwell_s;
        last = p.linear_mm;
        highest = std::max(highest, p.linear_mm.z());
        highest_ball = std::max(highest_ball, p.tcp_mm.z());
        to.positions.push_back(p);
      };
      auto add = [&](double a, bool reading) { add_to(ps, a, reading); };
      // From a0 to a1 along the arc, in sub-steps within the path tolerance (not read).
      auto along = [&](ProgramSweep& to, double a0, double a1) {
        const int n = substeps(design.axis, inst, ip.bar_mm, a0, a1, options.path_tolerance_mm,
                               options.tcpm, ip.largest_bar_change_mm);
        for (int j = 1; j < n; ++j) {
          const double a = a0 + (a1 - a0) * j / n;
          add_to(to, std::round(a / kProgramAngleResolution_deg) * kProgramAngleResolution_deg,
                 false);
        }
      };
      if (!ip.sweeps.empty()) {
        // A sweep that ended elsewhere (its return reading) goes back along the swept arc to
        // where this one starts: the program never jumps between two angles in one move.
        ProgramSweep& before = ip.sweeps.back();
        const double end = before.positions.back().angle_deg, start = order.front().angle_deg;
        if (end != start) {
          along(before, end, start);
          add_to(before, start, false);
        }
      }
      add(order.front().angle_deg, true);
      for (size_t k = 1; k < order.size(); ++k) {
        // The return reading retraces the sweep's arc back to its first angle (no new path).
        const double a0 = order[k - 1].angle_deg, a1 = order[k].angle_deg;
        along(ps, a0, a1);
        add(a1, true);
        ps.positions.back().return_reading = order[k].is_return;
      }
      ip.readings += static_cast<int>(order.size());
      ip.sweeps.push_back(std::move(ps));
    }
    highest = std::max(highest, ip.placement_mm.z());
    program.readings += ip.readings;
    program.installations.push_back(std::move(ip));
  }
  if (design.machine && design.axis.table()) {
    // The table's disc and the solids that turn with the axis rise as it turns: the plane clears
    // their highest point at every angle the program visits.
    std::vector<double> angles = design.angles_deg;
    angles.push_back(design.machine->park_angles()[design.machine->axis]);
    highest = std::max(highest, machine_top_z(design, angles));
  }
  // A plane given below the highest point plus the margin would send the sideways rapids
  // through the table, the balls or the bar: refused, naming the least it may be. A head turns
  // at the plane: its ball, at most the reach from the pivot, then stays the margin above the
  // table ball's centre (the highest point of a head's test below it), and every position below.
  program.head_reach_mm = reach;
  if (design.axis.head() && options.tcpm) {
    highest = std::max(highest_ball, kHeadBallsAllowance_mm);
    reach = 0;
  }
  const double lowest_plane = std::max(highest, reach > 0 ? reach + kHeadBallsAllowance_mm : 0.0) +
                              options.clearance_margin_mm;
  if (options.clearance_z_mm && *options.clearance_z_mm < lowest_plane) {
    throw InputError(
        option_name("--clearance-z-mm"), "",
        "Z " + text::significant(*options.clearance_z_mm, 6) +
            " mm is below the lowest safe clearance plane, Z " +
            text::significant(lowest_plane, 6) + " mm: the highest point the program reaches (Z " +
            text::significant(highest, 6) + " mm" +
            (reach > 0 ? ") or the longest pivot-to-ball distance and the balls' "
                         "allowance (" +
                             text::significant(reach, 6) + " + " +
                             text::significant(kHeadBallsAllowance_mm, 6) + " mm, whichever is more"
                       : std::string()) +
            ") plus " + option_name("--clearance-margin-mm") + " " +
            text::significant(options.clearance_margin_mm, 6) +
            " mm; every sideways rapid runs at this plane. Give at least Z " +
            text::significant(lowest_plane, 6) + " mm (or a smaller " +
            option_name("--clearance-margin-mm") + ", at least 1 mm)");
  }
  program.clearance_z_mm = options.clearance_z_mm.value_or(lowest_plane);
  // The descents and retracts along Z at the feed: to the first position and from the last,
  // and to the cup's placement and back.
  for (InstallationProgram& ip : program.installations) {
    const double zc = program.clearance_z_mm;
    const double start_z = ip.sweeps.front().positions.front().linear_mm.z();
    const double end_z = ip.sweeps.back().positions.back().linear_mm.z();
    double along_z = std::abs(zc - start_z) + std::abs(zc - end_z);
    if (ip.places_cup) along_z += 2 * std::abs(zc - ip.placement_mm.z());
    ip.motion_time_s += 60.0 * along_z / options.feed_mm_per_min;
    program.motion_time_s += ip.motion_time_s;
  }
  // On the C shorthand the work frame's origin is on the table surface: a spindle ball below it
  // would be driven into the table.
  if (design.axis.shorthand() == "C") {
    for (const InstallationProgram& ip : program.installations) {
      for (const ProgramSweep& sw : ip.sweeps) {
        for (const ProgramPosition& p : sw.positions) {
          if (p.linear_mm.z() >= 0) continue;
          const Installation& inst = design.installations[ip.installation];
          throw InputError("design", "installations[" + std::to_string(ip.installation) + "].sign",
                           "installation " + inst.id + ": the spindle ball at C" +
                               text::significant(p.angle_deg, 7) + " stands at Z " +
                               text::significant(p.linear_mm.z(), 7) +
                               " mm, below the table surface (Z 0): the following ball must be "
                               "on the other side of the table ball (sign " +
                               (inst.sign > 0 ? "-1" : "+1") +
                               "; reading_sign says how the instrument counted)");
        }
      }
    }
  }
  if (const std::string clash = machine_clash(design, program); !clash.empty())
    throw InputError("design", "machine",
                     "machine " + quote_value(design.machine->machine->name) + ": " + clash);
  check_cups(design, program);
  program.tool_direction = head_tool_direction(design.axis, design.machine);
  if (design.machine && design.axis.head())
    program.preset_range = head_preset_range(design, program);
  return program;
}

MeasurementProgram::PresetRange head_preset_range(const Design& design,
                                                  const MeasurementProgram& program) {
  const Machine& m = *design.machine->machine;
  // The commanded pivot positions (work frame) and the spindle balls they carry.
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  double lowest = std::numeric_limits<double>::infinity();
  auto take = [&](const Eigen::Vector3d& pivot) {
    lo = lo.cwiseMin(pivot);
    hi = hi.cwiseMax(pivot);
  };
  for (const InstallationProgram& ip : program.installations) {
    const Installation& inst = design.installations[static_cast<std::size_t>(ip.installation)];
    take(ip.placement_mm);
    for (const ProgramSweep& s : ip.sweeps) {
      for (const ProgramPosition& p : s.positions) {
        take(p.linear_mm);
        const Eigen::Vector3d ball = p.linear_mm + ball_position_mm(design.axis, inst, p.angle_deg);
        lowest = std::min({lowest, p.linear_mm.z(), ball.z()});
      }
    }
  }
  hi.z() = std::max(hi.z(), program.clearance_z_mm);  // the rapids at the plane
  if (program.options.tcpm) {
    // Under TCPM the plane's moves and turns command the spindle ball: the pivot stands anywhere
    // within the reach of it.
    const double reach = program.head_reach_mm;
    lo.head<2>().array() -= reach;
    hi.head<2>().array() += reach;
    hi.z() = std::max(hi.z(), program.clearance_z_mm + reach);
  }
  // The linear axes put the pivot at origin + their values: a preset q commands q + X.
  const Eigen::Vector3d zero = design.machine->origin_mm();
  MeasurementProgram::PresetRange r;
  r.lowest_z_mm = lowest;
  const char* names = "XYZ";
  for (int i = 0; i < 3; ++i) {
    const auto& t = m.linear_travel_mm[static_cast<std::size_t>(i)];
    r.min_mm(i) = t[0] + zero(i) - lo(i);
    r.max_mm(i) = t[1] + zero(i) - hi(i);
    if (r.min_mm(i) > r.max_mm(i))
      throw InputError("design", "machine",
                       "machine " + quote_value(m.name) + ": the head test's pivot spans " +
                           names[i] + " " + text::significant(lo(i) + 0.0, 7) + " to " +
                           text::significant(hi(i) + 0.0, 7) +
                           " mm of the work frame (the clearance plane included), " +
                           text::significant(hi(i) - lo(i), 7) + " mm, more than the " + names[i] +
                           " travel's " + text::significant(t[1] - t[0], 7) +
                           " mm: no place of the table ball keeps it inside the travel");
  }
  // The table the ball stands on, level (its axis along Z at the park angles): the pivot and
  // the spindle ball stay above its surface.
  const int disc = m.innermost(AxisFrame::Side::kTable);
  if (disc >= 0 && m.rotary[static_cast<std::size_t>(disc)].table_diameter_mm) {
    const std::vector<double> park = design.machine->park_angles();
    const AxisFrame f = m.axis_frame(disc, park);
    if (std::abs(std::abs(f.direction().z()) - 1) < 1e-12) {
      const Machine::OnTable at_zero = m.on_table(disc, Eigen::Vector3d::Zero(), park);
      r.table_surface_z_mm = -at_zero.height_mm * f.direction().z();
      r.table_radius_mm = 0.5 * *m.rotary[static_cast<std::size_t>(disc)].table_diameter_mm;
      r.min_mm.z() = std::max(r.min_mm.z(), *r.table_surface_z_mm - std::min(lowest, 0.0));
      if (r.min_mm.z() > r.max_mm.z())
        throw InputError(
            "design", "machine",
            "machine " + quote_value(m.name) + ": the pivot and the spindle ball come down to " +
                text::significant(-lowest, 7) + " mm below the table ball's centre, which " +
                "then stands at Z " + text::significant(r.min_mm.z(), 7) +
                " mm at least (the table's surface at Z " +
                text::significant(*r.table_surface_z_mm + 0.0, 7) +
                "), above the highest place the Z travel leaves it, Z " +
                text::significant(r.max_mm.z(), 7) +
                " mm: no place of the table ball keeps the test inside the travel");
    }
  }
  return r;
}

std::vector<Sweep> program_sweeps(ProgramOptions::Sweeps sweeps) {
  std::vector<Sweep> out;
  if (sweeps != ProgramOptions::Sweeps::kCW) out.push_back(Sweep::kCCW);
  if (sweeps != ProgramOptions::Sweeps::kCCW) out.push_back(Sweep::kCW);
  return out;
}

std::optional<ProgramOptions::Sweeps> program_sweeps_named(const std::string& name) {
  if (name == "ccw") return ProgramOptions::Sweeps::kCCW;
  if (name == "cw") return ProgramOptions::Sweeps::kCW;
  if (name == "both") return ProgramOptions::Sweeps::kBoth;
  return std::nullopt;
}

std::vector<double> sweep_angles(const Design& design, int installation, Sweep sweep) {
  std::vector<double> angles = design.angles_of(installation);
  std::sort(angles.begin(), angles.end());
  if (sweep == Sweep::kCW) std::reverse(angles.begin(), angles.end());
  return angles;
}

Sweep opposite(Sweep sweep) { return sweep == Sweep::kCW ? Sweep::kCCW : Sweep::kCW; }

std::vector<SweepReading> sweep_readings(const Design& design, int installation, Sweep sweep) {
  std::vector<SweepReading> out;
  for (const double a : sweep_angles(design, installation, sweep)) out.push_back({a, sweep, false});
  if (design.return_reading && out.size() > 1)
    out.push_back({out.front().angle_deg, opposite(sweep), true});
  return out;
}

}  // namespace dbbkit

namespace dbbkit {

std::string machine_clash(const Design& design, const MeasurementProgram& program) {
  if (!design.machine || !design.axis.table()) return "";
  const Machine& m = *design.machine->machine;
  const Eigen::Vector3d origin = design.machine->origin_mm();
  const char* names = "XYZ";
  auto beyond_travel = [&](const Eigen::Vector3d& x) -> std::string {
    for (int i = 0; i < 3; ++i) {
      const auto& t = m.linear_travel_mm[i];
      if (x(i) < t[0] - 1e-9 || x(i) > t[1] + 1e-9)
        return std::string(1, names[i]) + " " + text::significant(x(i), 7) +
               " mm (machine frame) lies beyond the travel [" + text::significant(t[0], 7) + ", " +
               text::significant(t[1], 7) + "] mm";
    }
    return "";
  };
  auto inside = [&](const Eigen::Vector3d& x, const std::vector<double>& a) -> std::string {
    for (const WorkspaceSolid& w : m.solids) {
      const Eigen::Vector3d x0 = w.turns_with < 0 ? x : m.to_body(w.turns_with, x, a);
      if ((x0.array() > w.min_mm.array()).all() && (x0.array() < w.max_mm.array()).all())
        return quote_value(w.name);
    }
    return "";
  };
  const double zc = origin.z() + program.clearance_z_mm;
  if (zc > m.linear_travel_mm[2][1])
    return "the clearance plane Z " + text::significant(program.clearance_z_mm, 7) +
           " mm (work frame; " + text::significant(zc, 7) +
           " mm in the machine frame) lies above the Z travel's end " +
           text::significant(m.linear_travel_mm[2][1], 7) + " mm";
  // The table the cups stand on: the innermost table axis' disc, at the placing angle.
  int disc = m.innermost(AxisFrame::Side::kTable);
  if (disc >= 0 && !m.rotary[disc].table_diameter_mm) disc = -1;
  for (const InstallationProgram& ip : program.installations) {
    const Installation& inst = design.installations[ip.installation];
    const std::string where = "installation " + inst.id;
    if (disc >= 0 && ip.places_cup) {
      const RotaryAxisSpec& r = m.rotary[disc];
      const Machine::OnTable t =
          m.on_table(disc, origin + ball_position_mm(design.axis, inst, ip.placement_angle_deg),
                     design.machine->angles_at(ip.placement_angle_deg));
      if (t.height_mm <= 0 || !t.inside_edge)
        return where + ": its table ball lies " +
               (t.height_mm <= 0
                    ? text::significant(-t.height_mm, 7) + " mm below the surface of"
                    : text::significant(t.radius_mm, 7) + " mm from the axis, beyond the edge of") +
               " the " + std::string(1, r.letter) + " table (diameter " +
               text::significant(*r.table_diameter_mm, 7) + " mm)";
    }
    if (const std::string t = beyond_travel(origin + ip.placement_mm); !t.empty())
      return where + ", placing its cup: the spindle ball's " + t;
    for (const ProgramSweep& s : ip.sweeps) {
      for (const ProgramPosition& p : s.positions) {
        const std::string at = where + " at " + std::string(1, design.axis.letter()) +
                               text::significant(p.angle_deg, 7);
        if (const std::string t = beyond_travel(origin + p.linear_mm); !t.empty())
          return at + ": the spindle ball's " + t;
        if (!p.reading) continue;
        const std::vector<double> a = design.machine->angles_at(p.angle_deg);
        const Eigen::Vector3d P = origin + ball_position_mm(design.axis, inst, p.angle_deg);
        const Eigen::Vector3d F = origin + p.linear_mm;
        if (disc >= 0) {
          // The spindle ball over the table's disc must stay above its surface.
          const Machine::OnTable t = m.on_table(disc, F, a);
          if (t.height_mm <= 0 && t.inside_edge)
            return at + ": the spindle ball lies " + text::significant(-t.height_mm, 7) +
                   " mm below the surface of the " + std::string(1, m.rotary[disc].letter) +
                   " table";
        }
        for (int k = 0; k <= 10; ++k) {
          const Eigen::Vector3d x = P + (F - P) * (k / 10.0);
          if (const std::string solid = inside(x, a); !solid.empty())
            return at + ": " +
                   (k == 0    ? std::string("the table ball")
                    : k == 10 ? std::string("the spindle ball")
                              : std::string("the bar")) +
                   " at " + text::significant(x.x(), 7) + ", " + text::significant(x.y(), 7) +
                   ", " + text::significant(x.z(), 7) + " mm (machine frame) lies inside " + solid;
        }
      }
    }
  }
  return "";
}

}  // namespace dbbkit
