#include "dbbkit/program.hpp"

#include <algorithm>
#include <cmath>

#include "dbbkit/error.hpp"
#include "dbbkit/kinematics.hpp"
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
double substep_bar_change(Axis axis, const Installation& inst, double bar, double a0, double a1) {
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
int substeps(Axis axis, const Installation& inst, double bar, double a0, double a1, double tol,
             double& largest_change) {
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
}

Eigen::Vector3d commanded_point_mm(Axis axis, const Installation& inst, double bar_mm,
                                   double angle_deg, double first_angle_deg, bool tool_down) {
  auto following = [&](double a) {
    return Eigen::Vector3d(ball_position_mm(axis, inst, a) -
                           inst.sign * bar_mm * direction_machine(axis, inst, a));
  };
  if (axis == Axis::kC) return following(angle_deg);
  Eigen::Vector3d q = following(first_angle_deg) - following(angle_deg);
  if (tool_down) q = Eigen::Vector3d(-q.x(), q.y(), -q.z());
  return q;
}

MeasurementProgram measurement_program(const Design& design, const ProgramOptions& options) {
  validate_design(design);
  validate_program_options(options, "program");
  MeasurementProgram program;
  program.axis = design.axis;
  program.options = options;
  std::vector<double> angles = design.angles_deg;
  std::sort(angles.begin(), angles.end());
  std::vector<Sweep> sweeps;
  if (options.sweeps != ProgramOptions::Sweeps::kCW) sweeps.push_back(Sweep::kCCW);
  if (options.sweeps != ProgramOptions::Sweeps::kCCW) sweeps.push_back(Sweep::kCW);
  const bool tool_down = design.axis == Axis::kB && options.tool_down;
  const double first = sweeps.front() == Sweep::kCCW ? angles.front() : angles.back();

  std::size_t positions = 0;
  for (int i = 0; i < static_cast<int>(design.installations.size()); ++i) {
    const Installation& inst = design.installations[i];
    if (!inst.bar_mm) {
      throw InputError("design", "installations[" + std::to_string(i) + "].bar_mm",
                       "installation " + inst.id +
                           " has no bar length: the program cannot place the following ball");
    }
    InstallationProgram ip;
    ip.installation = i;
    ip.bar_mm = *inst.bar_mm;
    ip.fixed_ball_mm =
        design.axis == Axis::kC
            ? ball_body_mm(design.axis, inst)
            : Eigen::Vector3d(ball_position_mm(design.axis, inst, first) -
                              inst.sign * ip.bar_mm * direction_machine(design.axis, inst, first));
    if (tool_down)
      ip.fixed_ball_mm =
          Eigen::Vector3d(-ip.fixed_ball_mm.x(), ip.fixed_ball_mm.y(), -ip.fixed_ball_mm.z());
    Eigen::Vector3d last =
        commanded_point_mm(design.axis, inst, ip.bar_mm, first, first, tool_down);
    for (const Sweep s : sweeps) {
      ProgramSweep ps;
      ps.direction = s;
      std::vector<double> order = angles;
      if (s == Sweep::kCW) std::reverse(order.begin(), order.end());
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
        p.linear_mm = commanded_point_mm(design.axis, inst, ip.bar_mm, a, first, tool_down);
        p.reading = reading;
        ip.motion_time_s += 60.0 * (p.linear_mm - last).norm() / options.feed_mm_per_min;
        if (reading) ip.motion_time_s += options.dwell_s;
        last = p.linear_mm;
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
    program.readings += ip.readings;
    program.motion_time_s += ip.motion_time_s;
    program.installations.push_back(std::move(ip));
  }
  return program;
}

}  // namespace dbbkit
