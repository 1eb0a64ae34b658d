#include "dbbkit/program.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <stdexcept>

#include "dbbkit/error.hpp"
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
// linearly between the nominal following-ball positions at its ends.
double substep_bar_change(const AxisFrame& axis, const Installation& inst, double bar, double a0,
                          double a1) {
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
             double tol, double& largest_change) {
  const double whole = substep_bar_change(axis, inst, bar, a0, a1);
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
                                                 a0 + (a1 - a0) * (k + 1) / n));
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

}  // namespace

void validate_program_options(const ProgramOptions& o, const std::string& source) {
  auto check = [&](bool ok, const char* key, const std::string& what) {
    if (!ok) throw InputError(source, key, what);
  };
  check(std::isfinite(o.dwell_s) && o.dwell_s > 0 && o.dwell_s <= 600, "dwell_s",
        "the dwell must be in (0, 600] s, got " + text::significant(o.dwell_s, 6));
  check(std::isfinite(o.feed_mm_per_min) && o.feed_mm_per_min > 0 && o.feed_mm_per_min <= 60000,
        "feed_mm_per_min",
        "the feed must be in (0, 60000] mm/min, got " + text::significant(o.feed_mm_per_min, 6));
  check(
      std::isfinite(o.path_tolerance_mm) && o.path_tolerance_mm >= 1e-4 && o.path_tolerance_mm <= 1,
      "path_tolerance_mm",
      "the path tolerance must be in [0.0001, 1] mm (a ballbar reads within about +-1 mm), got " +
          text::significant(o.path_tolerance_mm, 6));
  check(o.tool_number >= 1 && o.tool_number <= 9999, "tool_number",
        "a tool number is 1..9999, got " + std::to_string(o.tool_number));
  check(std::isfinite(o.clearance_margin_mm) && o.clearance_margin_mm >= 1 &&
            o.clearance_margin_mm <= 1000,
        "clearance_margin_mm",
        "the clearance margin must be in [1, 1000] mm, got " +
            text::significant(o.clearance_margin_mm, 6));
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

const InstallationProgram& MeasurementProgram::of(int installation) const {
  for (const InstallationProgram& ip : installations) {
    if (ip.installation == installation) return ip;
  }
  throw std::out_of_range("MeasurementProgram::of: no installation " +
                          std::to_string(installation));
}

MeasurementProgram measurement_program(const Design& design, const ProgramOptions& options) {
  validate_design(design);
  validate_program_options(options, "program");
  MeasurementProgram program;
  program.axis = design.axis;
  program.options = options;
  const std::vector<Sweep> sweeps = program_sweeps(options.sweeps);
  const double first = sweep_angles(design, sweeps.front()).front();

  std::size_t positions = 0;
  // The highest point anything reaches (work frame Z; the table surface (C) or the table ball
  // (B) at 0), for the clearance plane; for B the longest pivot-to-ball distance, so that the
  // head can turn at the plane with its ball above the table's.
  double highest = 0, reach = 0;
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
    const Eigen::Vector3d body = ball_body_mm(design.axis, inst);
    ip.fixed_ball_mm = design.axis.table() ? body : Eigen::Vector3d::Zero();
    // The table's cup is placed once per ball position (B: once, at the origin).
    ip.places_cup = design.axis.table()
                        ? !previous_ball || (*previous_ball - body).norm() > kAssemblyTolerance_mm
                        : !previous_ball;
    previous_ball = body;
    const Eigen::Vector3d P_first = ball_position_mm(design.axis, inst, first);
    ip.placement_mm = design.axis.table() ? P_first : Eigen::Vector3d(-P_first);
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
      const std::vector<double> order = sweep_angles(design, s);
      auto add = [&](double a, bool reading) {
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
        p.reading = reading;
        ip.motion_time_s += 60.0 * (p.linear_mm - last).norm() / options.feed_mm_per_min;
        if (reading) ip.motion_time_s += options.dwell_s;
        last = p.linear_mm;
        highest = std::max(highest, p.linear_mm.z());
        ps.positions.push_back(p);
      };
      add(order.front(), true);
      for (size_t k = 1; k < order.size(); ++k) {
        const double a0 = order[k - 1], a1 = order[k];
        const int n = substeps(design.axis, inst, ip.bar_mm, a0, a1, options.path_tolerance_mm,
                               ip.largest_bar_change_mm);
        for (int j = 1; j < n; ++j) {
          const double a = a0 + (a1 - a0) * j / n;
          add(std::round(a / kProgramAngleResolution_deg) * kProgramAngleResolution_deg, false);
        }
        add(a1, true);
      }
      ip.readings += static_cast<int>(order.size());
      ip.sweeps.push_back(std::move(ps));
    }
    highest = std::max(highest, ip.placement_mm.z());
    program.readings += ip.readings;
    program.installations.push_back(std::move(ip));
  }
  // A plane given below the highest point plus the margin would send the sideways rapids
  // through the table, the balls or the bar: refused, naming the least it may be.
  const double lowest_plane = highest + reach + options.clearance_margin_mm;
  if (options.clearance_z_mm && *options.clearance_z_mm < lowest_plane) {
    throw InputError(option_name("--clearance-z-mm"), "",
                     "Z " + text::significant(*options.clearance_z_mm, 6) +
                         " mm is below the lowest safe clearance plane, Z " +
                         text::significant(lowest_plane, 6) +
                         " mm: the highest point the program reaches (Z " +
                         text::significant(highest, 6) + " mm" +
                         (reach > 0 ? ", plus the longest pivot-to-ball distance " +
                                          text::significant(reach, 6) + " mm"
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
  return program;
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

std::vector<double> sweep_angles(const Design& design, Sweep sweep) {
  std::vector<double> angles = design.angles_deg;
  std::sort(angles.begin(), angles.end());
  if (sweep == Sweep::kCW) std::reverse(angles.begin(), angles.end());
  return angles;
}

}  // namespace dbbkit
