#pragma once
// The measurement as the machine runs it: for each installation the rotary-axis
// positions and the linear-axis positions that keep the following ball on its nominal
// path (README, "Conventions": F = P - s bar u), indexed: move, dwell for the reading.
//
// What the linear axes command (one work offset for the whole test, and the controlled point):
//   C turntable: the centre of the spindle's ball, in a work frame with its origin on
//     the C axis at the table surface (the frame of model.md §3). Commanded = F(angle).
//   B swinging head: the pivot (the intersection of the B swing axis with the spindle
//     axis), in a work frame whose origin is the centre of the table's ball: its cup stays
//     where it is placed for the whole test, and the pivot is commanded to -F(angle) (both
//     balls keep their relative positions of model.md §4).
// Each installation is approached from the clearance plane: retract along Z alone, turn the
// rotary axis, move sideways there (rapid), descend along Z alone at the feed; the same on
// leaving. The table's cup is placed with the spindle's ball standing where the table ball
// goes.
// The rotary axis is commanded to the angle itself: +angle turns the moving body by the
// right-hand rule about +Z (C) or +Y (B).
//
// Between two positions a control interpolates the rotary and the linear axes linearly
// (no tool-centre-point control), so the following ball leaves the nominal path: the bar
// length changes by up to the sagitta. Each step is split into equal sub-steps until the
// bar length along the interpolated path stays within path_tolerance_mm of the bar.

#include <Eigen/Core>
#include <optional>
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

// The tool number of the ballbar's spindle cup when none is given.
inline constexpr int kDefaultBallbarTool = 99;

// A head turning at the clearance plane: the room its ball keeps above the table ball's centre
// besides the margin [mm]: two balls' radii (12.7 mm balls) and the table cup's rim above its
// ball's centre.
inline constexpr double kHeadBallsAllowance_mm = 25.0;

struct ProgramOptions {
  // The ball coordinate (0: L, 2: H) a table's cushion blocks set, when known (from a kit: its
  // table's normal); absent: H on the "C" shorthand, and on a table in the general form both L
  // and H (the design does not state its table's normal, so a stack is the same only where
  // neither changes). It orders the installations (setup_order).
  std::optional<int> stack_coordinate;
  // The sweeps of each installation: ccw = increasing angle (the design's order), cw =
  // decreasing; both = ccw then cw (the reverse sweep lets diagnose see a reversal error).
  enum class Sweeps { kCCW, kCW, kBoth };
  Sweeps sweeps = Sweeps::kCCW;
  double dwell_s = 2.0;             // at each reading position
  double feed_mm_per_min = 500.0;   // of the linear axes between positions
  double path_tolerance_mm = 0.05;  // largest bar-length change between positions
  // The tool whose length reaches the controlled point: the ballbar's spindle cup, its length
  // measured to the ball centre (C); the pivot (B). ISO: T<n> M06 and G43 H<n>; Heidenhain:
  // TOOL CALL <n> Z. 1..9999.
  int tool_number = kDefaultBallbarTool;
  // The clearance plane (work frame Z) every sideways rapid runs at; absent: the highest point
  // any commanded position, table ball or placement reaches, plus the margin (a head: that or
  // the longest pivot-to-ball distance plus kHeadBallsAllowance_mm, whichever is more, so that
  // the head can turn there with its ball above the table ball).
  std::optional<double> clearance_z_mm;
  double clearance_margin_mm = 50;
  // The same moves with no bar: a stop at each installation and after the first step of each
  // sweep, saying what to watch (the sense of the rotary axis, the clearance).
  bool air_run = false;
  // The M-code that orients (and, where the control has it, locks) the spindle; empty: none.
  std::string orient_code = "M19";
  // Tool-centre-point control during the sweeps (a design that names its machine): the program
  // writes the ball centre in the workpiece frame and the controller moves the linear axes from
  // its own kinematics (Heidenhain FUNCTION TCPM, ISO G43.4, Sinumerik TRAORI). Off: the linear
  // positions come from the machine file's nominal axis points. Approaches, placements and
  // retracts run without it either way.
  bool tcpm = false;
};
// The spindle orientation code of every dialect written; the only one orient_code takes.
inline constexpr const char* kOrientCode = "M19";

// The sweeps the program runs for `sweeps`, in order, and a name (ccw, cw, both) as one; nullopt
// for another name. The one definition readings matches a trace's dwells against.
std::vector<Sweep> program_sweeps(ProgramOptions::Sweeps sweeps);
std::optional<ProgramOptions::Sweeps> program_sweeps_named(const std::string& name);
// The angles of one sweep of an installation (design index) in the order the program visits
// them: its angles (Design::angles_of) sorted, increasing for ccw, decreasing for cw.
std::vector<double> sweep_angles(const Design& design, int installation, Sweep sweep);
// The readings of one sweep in the order they are taken: its angles (sweep_angles), each read
// with the axis moving in the sweep's direction, and with design.return_reading the first angle
// once more at the end, reached by turning back along the arc (approached moving the other way,
// so it carries the opposite sweep: a reversal error shows in it as in that sweep's readings).
// The one definition program, simulate and readings follow.
struct SweepReading {
  double angle_deg = 0;
  Sweep approach = Sweep::kCCW;
  bool is_return = false;
};
std::vector<SweepReading> sweep_readings(const Design& design, int installation, Sweep sweep);
Sweep opposite(Sweep sweep);

// The limits of the options; throws InputError(source, key) outside them:
//   0 < dwell_s <= 600, 0 < feed_mm_per_min <= 60000, 1e-4 <= path_tolerance_mm <= 1,
//   1 <= tool_number <= 9999, 1 <= clearance_margin_mm <= 1000, |clearance_z_mm| <= 10000,
//   orient_code empty or kOrientCode.
void validate_program_options(const ProgramOptions& options, const std::string& source);

struct ProgramPosition {
  double angle_deg = 0;
  Eigen::Vector3d linear_mm = Eigen::Vector3d::Zero();  // commanded X, Y, Z (no TCPM)
  // The ball centre in the workpiece frame, what X Y Z command under TCPM: a table, the spindle
  // ball in the table's body frame (the same at every angle); a head, the spindle ball with the
  // table ball at the origin.
  Eigen::Vector3d tcp_mm = Eigen::Vector3d::Zero();
  bool reading = false;  // a design angle: dwell and read; false: an intermediate position
  // The sweep's return reading (sweep_readings): its first angle read again, approached the
  // other way.
  bool return_reading = false;
};

struct ProgramSweep {
  Sweep direction = Sweep::kCCW;
  std::vector<ProgramPosition> positions;  // the first is the sweep's start, a reading
};

struct InstallationProgram {
  int installation = 0;  // index into the design
  double bar_mm = 0;
  // B: the table ball's centre in the work frame (the origin, for every installation); C: the
  // ball on the table at angle 0 (its cup position, table coordinates L, D, H).
  Eigen::Vector3d fixed_ball_mm = Eigen::Vector3d::Zero();
  // The table's cup is placed here (the first installation at its ball position): the
  // controlled point stands at placement_mm, where the spindle's ball is at the table ball's
  // centre, at the start angle; the operator seats the cup against it.
  bool places_cup = false;
  Eigen::Vector3d placement_mm = Eigen::Vector3d::Zero();
  std::vector<ProgramSweep> sweeps;
  // The angle of the axis under test while the cup is placed: the start angle, or (a design that
  // names its machine, a table) the axis' park angle, the table level.
  double placement_angle_deg = 0;
  // A machine design's table ball: its centre's height above the surface of the machine's
  // table disc where the cup is placed [mm] (absent without a machine or a disc).
  std::optional<double> table_height_mm;
  double largest_bar_change_mm = 0;  // along the interpolated path, over every sub-step
  int readings = 0;
  double motion_time_s = 0;  // its moves at the feed and its dwells (no set-up)
};

struct MeasurementProgram {
  AxisFrame axis;
  ProgramOptions options;
  // In the order of the set-up sheet (setup_order): the installations at one ball position
  // together, the stack rebuilt and the bar reassembled the fewest times.
  std::vector<InstallationProgram> installations;
  // The program of installation i of the design.
  const InstallationProgram& of(int installation) const;
  int readings = 0;
  // The moves at the feed (the sweeps, every descent and retract) plus the dwells; rapids and
  // set-ups not included.
  double motion_time_s = 0;
  // The plane (work frame Z) every sideways rapid runs at (options.clearance_z_mm when given).
  double clearance_z_mm = 0;
  // A design that names its machine: the machine, the axes' park angles and the preset (the
  // axis' nominal point in the machine frame, the work frame's origin).
  std::optional<DesignMachine> machine;
  // A head: the longest distance from the pivot to a spindle ball [mm].
  double head_reach_mm = 0;
  // A head's test on a machine: the work frame's origin is the table ball's centre, placed by the
  // operator. Where it may stand (machine file's frame, mm) for every commanded pivot position
  // and the clearance plane to stay inside the linear travel (the pivot at the axis' nominal
  // point with the linear axes at zero), and how far the pivot or the spindle ball comes below
  // it (work frame Z, the lowest of either; the table ball's least height above the table).
  struct PresetRange {
    Eigen::Vector3d min_mm = Eigen::Vector3d::Zero(), max_mm = Eigen::Vector3d::Zero();
    double lowest_z_mm = 0;
    // The machine's table (its innermost table axis' disc, level at the park angles): its
    // surface's Z and radius (machine file's frame); min_mm.z keeps the pivot and the spindle
    // ball above that surface.
    std::optional<double> table_surface_z_mm, table_radius_mm;
  };
  std::optional<PresetRange> preset_range;
  // A head: the spindle's direction with the axis under test at 0 (from the pivot to the tool
  // tip, work frame): the machine's innermost head axis' reference turned by its head axes; without
  // a machine the design's reference, except on a head about Z, whose design does not say.
  std::optional<Eigen::Vector3d> tool_direction;
};

// A head's test on a machine (design.machine, a head axis): where the table ball's centre may
// stand (MeasurementProgram::preset_range); throws InputError(design, machine) when nowhere.
MeasurementProgram::PresetRange head_preset_range(const Design& design,
                                                  const MeasurementProgram& program);

// A design that names its machine: what the program's moves meet. The first problem as text
// (the installation, the angle, the point, the solid or the travel), or empty: a ball, the bar
// or the spindle ball inside a workspace solid; a commanded position or the clearance plane
// beyond the linear travel.
std::string machine_clash(const Design& design, const MeasurementProgram& program);

// The point the linear axes command at an angle (see the header): a table, F(angle); a head,
// -F(angle) (the pivot, with the table ball at the work frame's origin). A spindle pointing
// down is the frame's reference [0, 0, -1].
Eigen::Vector3d commanded_point_mm(const AxisFrame& axis, const Installation& inst, double bar_mm,
                                   double angle_deg);

// The program of a design. Every installation needs bar_mm: without it the following
// ball cannot be placed (InputError naming installations[i].bar_mm).
MeasurementProgram measurement_program(const Design& design, const ProgramOptions& options);

}  // namespace dbbkit
