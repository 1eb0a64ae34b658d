#pragma once
// The measurement as the machine runs it: for each installation the rotary-axis
// positions and the linear-axis positions that keep the following ball on its nominal
// path (README, "Conventions": F = P - s bar u), indexed: move, dwell for the reading.
//
// What the linear axes command (the work offset and the controlled point):
//   C turntable: the centre of the spindle's ball, in a work frame with its origin on
//     the C axis at the table surface (the frame of model.md §3). Commanded = F(angle).
//   B swinging head: the pivot (the intersection of the B swing axis with the spindle
//     axis), in a work frame whose origin is where the pivot stands at the first angle
//     of the installation, so that the table's ball sits at T = F(first angle) and the
//     pivot is commanded to T - F(angle) (both balls keep their relative positions of
//     model.md §4).
// The rotary axis is commanded to the angle itself: +angle turns the moving body by the
// right-hand rule about +Z (C) or +Y (B).
//
// Between two positions a control interpolates the rotary and the linear axes linearly
// (no tool-centre-point control), so the following ball leaves the nominal path: the bar
// length changes by up to the sagitta. Each step is split into equal sub-steps until the
// bar length along the interpolated path stays within path_tolerance_mm of the bar.

#include <Eigen/Core>
#include <string>
#include <vector>

#include "dbbkit/design.hpp"
#include "dbbkit/measurement.hpp"

namespace dbbkit {

// Intermediate angles are multiples of this (a program writes angles with 4 decimals; a
// design's own angles are kept as given). Positions are computed at the rounded angle.
inline constexpr double kProgramAngleResolution_deg = 1e-4;

// The most positions (program lines of moves) one program may hold: about 10 MB of text, far
// beyond a real test (the paper's C design: 133 positions at the default tolerance; a 0.5 deg
// design of 7 installations about 5,000). A program that would be longer is refused, naming
// the path tolerance.
inline constexpr std::size_t kMaxProgramPositions = 200000;

struct ProgramOptions {
  // The sweeps of each installation: ccw = increasing angle (the design's order), cw =
  // decreasing; both = ccw then cw (the reverse sweep lets diagnose see a reversal error).
  enum class Sweeps { kCCW, kCW, kBoth };
  Sweeps sweeps = Sweeps::kCCW;
  double dwell_s = 2.0;             // at each reading position
  double feed_mm_per_min = 500.0;   // of the linear axes between positions
  double path_tolerance_mm = 0.05;  // largest bar-length change between positions
  // B only. The frame of model.md §4 has the ball at +L along Z from the pivot at B0. On a
  // machine whose tool points to -Z (the usual vertical head), true writes the commanded
  // points turned by 180 deg about Y (x -> -x, z -> -z): a rotation about the swing axis,
  // so B and every relative position are unchanged.
  bool tool_down = false;
};

// The limits of the options; throws InputError(source, key) outside them:
//   0 < dwell_s <= 600, 0 < feed_mm_per_min <= 60000, 1e-4 <= path_tolerance_mm <= 1.
void validate_program_options(const ProgramOptions& options, const std::string& source);

struct ProgramPosition {
  double angle_deg = 0;
  Eigen::Vector3d linear_mm = Eigen::Vector3d::Zero();  // commanded X, Y, Z
  bool reading = false;  // a design angle: dwell and read; false: an intermediate position
};

struct ProgramSweep {
  Sweep direction = Sweep::kCCW;
  std::vector<ProgramPosition> positions;  // the first is the sweep's start, a reading
};

struct InstallationProgram {
  int installation = 0;  // index into the design
  double bar_mm = 0;
  // B: the table ball's centre in the work frame (= F at the first angle); C: the ball on
  // the table at angle 0 (its cup position, table coordinates L, D, H).
  Eigen::Vector3d fixed_ball_mm = Eigen::Vector3d::Zero();
  std::vector<ProgramSweep> sweeps;
  double largest_bar_change_mm = 0;  // along the interpolated path, over every sub-step
  int readings = 0;
  double motion_time_s = 0;  // its moves at the feed and its dwells (no set-up)
};

struct MeasurementProgram {
  Axis axis = Axis::kC;
  ProgramOptions options;
  std::vector<InstallationProgram> installations;  // in the design's order
  int readings = 0;
  double motion_time_s = 0;  // linear moves at the feed plus the dwells (no set-up time)
};

// The point the linear axes command at an angle (see the header): C, F(angle); B,
// F(first angle) - F(angle) with `first_angle_deg` the installation's first position,
// turned by 180 deg about Y when `tool_down`.
Eigen::Vector3d commanded_point_mm(Axis axis, const Installation& inst, double bar_mm,
                                   double angle_deg, double first_angle_deg,
                                   bool tool_down = false);

// The program of a design. Every installation needs bar_mm: without it the following
// ball cannot be placed (InputError naming installations[i].bar_mm).
MeasurementProgram measurement_program(const Design& design, const ProgramOptions& options);

}  // namespace dbbkit
