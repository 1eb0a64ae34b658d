#pragma once
// What the user owns and the machine allows (format `dbbkit.kit/1`, formats.md):
// the ranges where a ball can be placed, the cushion blocks, the bars, the
// travel of the following ball, the angle steps and the time model. `optimize`
// searches inside a kit.

#include <Eigen/Core>
#include <array>
#include <optional>
#include <string>
#include <vector>

#include "dbbkit/design.hpp"

namespace dbbkit {

struct Interval {
  double min = 0, max = 0;
  bool contains(double x) const { return x >= min && x <= max; }
  double width() const { return max - min; }
};

// A pattern is data (formats.md "Kit file"): a list of ball positions, each with its
// coordinates (a variable of the search or a fixed value) and the installations read
// there. A new pattern is a kit entry, not a new branch of the search.
//   L and D variables are continuous, over the kit's L_mm and D_mm; the same name at
//   two positions ties them. H variables (C) are discrete: a height of block_stacks.
//   Optional positions are added in the order listed: the search tries the required
//   ones plus the first 0, 1, ... of the optional ones (what each extra position buys
//   is the Pareto front of the result).
struct PatternCoordinate {
  std::string variable;  // empty: fixed at value
  double value = 0;      // mm
  bool is_variable() const { return !variable.empty(); }
};

struct PatternPosition {
  std::string id;  // installation ids: id + r, t or a (radial, tangential, axial)
  PatternCoordinate L, D, H;
  std::vector<Direction::Kind> directions;
  bool separated = true;      // at least min_separation_mm from the other separated positions
  bool optional = false;      // the search may leave it out
  bool needs_offset = false;  // offered only when the kit's D_mm allows an offset (D != 0)
};

struct Pattern {
  std::string name;
  std::vector<PatternPosition> positions;
  std::vector<std::vector<std::string>>
      distinct;          // groups of H variables that must take different heights
  bool builtin = false;  // a named pattern of dbbkit (written by name)
  // Its positions differ by their names alone (a probe's spheres): a choice of heights and its
  // relabelling are one measurement, and the search takes the heights in ascending order only.
  bool interchangeable = false;
  int inherited_positions = 0;  // the first positions come from the built-in pattern it extends
};

// How a kit's table carries a ball (table side): cushion blocks raise it along the table's
// normal. kAlongAxis: the normal is the axis' direction (+-), as on a C table or a machining
// centre's B table: the heights are the ball's H. kAcrossAxis: the normal is the reference
// (+-), across the axis, as on a trunnion: the heights are the ball's L (its distance from the
// axis line), and the ball slides along the axis (H) and across the table (D).
enum class TableCarriage { kAlongAxis, kAcrossAxis };

// The built-in patterns by name ("three_position"; a probe kit's "spheres": s1 required, s2 and
// s3 optional, each at its own L, D and height); absent for an unknown name or one of the other
// instrument. A head's
// pattern offsets its third ball along D on the "B" shorthand (its D lies along the axis) and
// along H (the axis) on a head in the general form.
std::optional<Pattern> builtin_pattern(const std::string& name, const AxisFrame& axis,
                                       TableCarriage carriage = TableCarriage::kAlongAxis,
                                       InstrumentKind instrument = InstrumentKind::kBallbar);

// Bars as sold: a base bar and extensions screwed onto it, each extension used at most once
// (a QC20-W: a 100 mm base with 50, 150 and 300 mm extensions).
struct BarSet {
  double base_mm = 0;
  std::vector<double> extensions_mm;
  std::optional<int> max_extensions;  // at most this many on one bar (absent: all of them)
};
// At most this many extensions in a bar set (2^n assemblies are enumerated, and the search
// tries each for each installation it places).
inline constexpr int kMaxBarExtensions = 8;
// At most this many bars in a kit (bars_mm): as many as the extensions of a set assemble.
inline constexpr int kMaxBars = 1 << kMaxBarExtensions;

// Where the set-up lives (optional in a kit; without it the table, the cup's footprint and
// the spindle are not checked, and every output says so). Lengths in mm.
//   Table side (C): the table's outline in table coordinates at angle 0 (x along L, y along
//     D; its surface is H = 0): a circle of table_diameter_mm about the axis, or the
//     rectangle table_x_mm x table_y_mm. footprint_mm: the diameter of the circle about a
//     ball position that its cup and blocks cover.
//   Head side (B): table_ball_height_mm, the table ball's centre above the table surface
//     (the table itself does not move, and the cup's place on it is the work offset). The
//     spindle at the axis' zero points at the table: the table's normal is -reference.
//   Both: the spindle nose as a cylinder of spindle_diameter_mm about the tool line, from
//     ball_to_nose_mm beyond the spindle ball's centre (towards the spindle) upwards;
//     clearance_mm: the least gap kept between them and the table, a cup or a ball.
struct Workspace {
  std::optional<double> table_diameter_mm;
  std::optional<Interval> table_x_mm, table_y_mm;
  double footprint_mm = 0;
  std::optional<double> table_ball_height_mm;
  double spindle_diameter_mm = 0;
  double ball_to_nose_mm = 0;
  double clearance_mm = 10;
};

// A touch probe's kit (kit key `instrument`, formats.md "A second instrument"): spheres on the
// table instead of balls and bars. Each sphere is probed at every angle from +-x, +-y and from
// above; the probe's tip centre starts each touch approach_mm from the sphere's centre (the
// sphere's radius, the tip's and the travel before the touch), so the sphere's centre plus and
// minus approach_mm along x and y, and plus it along z, must stay inside travel_mm at every
// angle. On a table whose normal tilts (a trunnion), the sphere's stem tilts with it: beyond
// max_stem_tilt_deg from the vertical (+z) the stem shadows the probing (absent: not checked).
struct ProbeKit {
  double approach_mm = 0;
  std::optional<double> max_stem_tilt_deg;
};

struct Kit {
  std::string name;
  AxisFrame axis;
  // Ball bar (bars, cups, blocks) or touch probe (spheres on stands of the same blocks; no bars,
  // no installations: time_s.per_position is a sphere set up, per_reading a sphere probed once).
  InstrumentKind instrument = InstrumentKind::kBallbar;
  ProbeKit probe;
  // A kit that names its machine and the axis under test (formats.md, "Kit file"): the frame,
  // a table's normal and surface and its disc come from the machine file, and every design the
  // search scores names the machine and must be one its program takes (the linear travel, the
  // table, the workspace's solids such as a cradle's cheeks).
  std::optional<DesignMachine> machine;
  // Table side: the table's normal (machine frame, angle 0; `table.normal`, the axis'
  // direction on the shorthand "C") and its surface's distance from the frame's origin along
  // it (`table.surface_mm`; 0 on a table whose origin lies on its surface, as the "C"
  // shorthand's). A ball's height above the table is its cup plus blocks.
  Eigen::Vector3d table_normal = Eigen::Vector3d::UnitZ();
  double table_surface_mm = 0;
  Pattern pattern;
  NoiseModel noise;
  ErrorModel errors;
  // The lever arm that weighs an angular error in um (the search's criterion and every worst
  // case): where the machine cuts. Stated (`reference_length_mm`) or, absent, the table's
  // radius (its workspace's table; a rectangle: its farthest corner) on a table axis, the
  // farthest ball position from the pivot along the tool (L_mm.max) on a head.
  double reference_length_mm = 0;
  enum class ReferenceLengthBasis { kStated, kTableRadius, kTableCorner, kToolReach };
  ReferenceLengthBasis reference_length_basis = ReferenceLengthBasis::kStated;
  // Set-up tolerances of every installation of the designs (design.hpp); with a length
  // offset or centring declared, the default criterion is worst_total_std_um.
  SetupUncertainty setup_std;
  // Every declared set-up effect must be one diagnose detects at its declared standard
  // uncertainty (detection limit <= declared size, setup.hpp): designs that leave one
  // below its limit are infeasible for the search.
  bool require_setup_detection = false;
  // Every design reads each sweep's first angle again at its end (design.hpp, return_reading).
  bool return_reading = false;
  // A drift over the whole test of this size [um, from the first reading to the last] must be
  // one diagnose detects (its detection limit at most this, setup.hpp DriftCheck, on the kit's
  // clock: time_s.per_reading and per_installation): designs that leave it below its limit are
  // infeasible for the search.
  std::optional<double> require_drift_detection_um;
  Interval L_mm;  // unused on a trunnion (its L is the table's heights)
  Interval D_mm;  // {0, 0}: no lateral offset
  // The range of H where it is continuous (`axial_mm`; general form only): a head's holder
  // offset along the axis, the cup's place along a trunnion's axis. {0, 0}: none.
  Interval axial_mm;
  double H_base_mm = 0;           // C: height of the ball cup standing on the table
  std::vector<double> blocks_mm;  // C: the cushion blocks owned, one entry per block
  int max_stack = 0;              // C: at most this many blocks under one cup
  std::vector<double> bars_mm;    // bar lengths that can be assembled
  std::optional<BarSet> bar_set;  // how they are assembled (absent: each bar is one part)
  // The search's ball positions (L, D) are rounded to multiples of this before the best is
  // written, and the rounded design is checked and scored again (absent: not rounded).
  std::optional<double> resolution_mm;
  std::array<Interval, 3> travel_mm;  // x, y, z of the following ball, machine frame of model.md
  double min_separation_mm = 0;
  Interval angle_range_deg;
  std::vector<double> angle_steps_deg;
  // The coarsest step the user accepts (the resolution the error motions are needed at): steps
  // above it are not tried. Absent: every step is; for per-angle errors the search then
  // prefers the coarsest, the shortest measurement.
  std::optional<double> angle_max_step_deg;
  double time_per_reading_s = 0;
  double time_per_installation_s = 0;  // each installation: the bar mounted in one direction
  // Each ball position set up (the cup and its blocks placed; installations at one position
  // share it). 0 when the kit does not give it: per_installation then covers both.
  double time_per_position_s = 0;
  std::optional<double> time_budget_s;  // absent: no limit
  std::optional<Workspace> workspace;   // absent: not checked (only the travel is)
};

// Where the kit's reference length comes from, as a phrase ("the kit's reference_length_mm",
// "the table's radius (workspace.table.diameter_mm / 2)", ...).
std::string reference_length_basis_text(const Kit& kit);

// How the kit's table carries a ball (kAlongAxis on a head, where no table turns).
TableCarriage table_carriage(const Kit& kit);
// The frame coordinate (0: L, 1: D, 2: H) the table's heights lie along; -1 on a head.
int height_coordinate(const Kit& kit);
// A pattern position's coordinate along the table's normal (its height variable or value).
const PatternCoordinate& height_of(const Kit& kit, const PatternPosition& position);
// A pattern position's coordinate 0, 1, 2 (L, D, H).
const PatternCoordinate& coordinate_of(const PatternPosition& position, int coordinate);
// The ball's coordinate along the table's normal for a height above the table (a cup on
// blocks): (surface + height) times the normal's sign along that coordinate.
double height_to_coordinate(const Kit& kit, double height_mm);
// Whether a design of the kit states its cup and blocks (stack_mm): on the "C" shorthand, whose
// H is their height. A design in the general form does not state its table's normal, so its
// stack is said in words (and found again from a kit by stack_at).
bool stack_is_H(const Kit& kit);
// The continuous range of a coordinate 0, 1, 2 (L_mm, D_mm, axial_mm; empty on a table's
// height coordinate, whose values are discrete).
Interval coordinate_range(const Kit& kit, int coordinate);

// The installation id of a direction at a position: id + "r", "t" or "a".
std::string installation_id(const PatternPosition& position, Direction::Kind kind);
// The kit allows a ball off the tool line of a head (D_mm, or axial_mm in the general form).
bool allows_offset(const Kit& kit);
// The optional positions the kit offers (needs_offset ones dropped when D_mm is {0, 0}), in order.
std::vector<int> offered_optional_positions(const Kit& kit);
// The most installations a design of the kit can have.
int max_installations(const Kit& kit);

// Why a probe kit cannot be on this axis (a head: the kit places spheres on a table), or none.
std::optional<std::string> probe_kit_axis_problem(const AxisFrame& axis);

// Throws InputError with `source` and the key of the first problem.
void validate_kit(const Kit& kit, const std::string& source = "kit");

// A height the cup can stand at: the base plus a stack of blocks.
struct Stack {
  double height_mm = 0;
  std::vector<double> blocks_mm;  // empty: the cup on the table
};
// Every distinct height from at most max_stack of the blocks (each block used
// once), ascending; for one height the stack with the fewest blocks.
std::vector<Stack> block_stacks(const Kit& kit);
// The stack of `stacks` whose height is height_mm (within kAssemblyTolerance_mm), or none.
std::optional<Stack> stack_of_height(const std::vector<Stack>& stacks, double height_mm);
// The kit's stack that puts the installation's ball at its height above the table (table side;
// stack_of_height of block_stacks(kit)), or none.
std::optional<Stack> stack_at(const Kit& kit, const Installation& in);
// The installation's ball height above the kit's table (table side): along its normal, less the
// surface.
double height_above_table(const Kit& kit, const Installation& in);

// The measured angles for one step: range.min, range.min + step, ..., range.max.
std::vector<double> kit_angles(const Kit& kit, double step_deg);

// Every length base + a subset of the extensions gives, ascending, each once.
std::vector<double> assembled_bars(const BarSet& set);
// The parts of a bar of the kit: with a bar set, the base and the fewest extensions that
// make `length_mm` (|sum - length| <= kAssemblyTolerance_mm); otherwise the bar itself.
// Empty when the kit has no such bar.
std::vector<double> bar_parts(const Kit& kit, double length_mm);

// The distinct ball positions of a design (installations whose ball is at the same L, D, H
// within kAssemblyTolerance_mm share one): each is one set-up of the cup.
int ball_positions(const Design& design);

// The one time model of a measurement (formats.md, kit file "time_s"): what optimize plans
// with, the set-up sheet and the program state. Set-ups: positions x per_position +
// installations x per_installation; readings: readings x per_reading (the moves between
// angles and the dwells), one reading per installation, angle and sweep (optimize plans one
// sweep; a program of both sweeps reads each angle twice).
struct TimeEstimate {
  int positions = 0, installations = 0, readings = 0;
  double setups_s = 0;    // the cup placed and the bar mounted
  double readings_s = 0;  // the moves and dwells of the sweeps
  double total_s = 0;
};
TimeEstimate design_time(const Kit& kit, const Design& design, int sweeps = 1);
// design_time(kit, design).total_s.
double design_time_s(const Kit& kit, const Design& design);

// The following ball sits at F = P - s bar u (README, "Conventions") and, as the
// axis turns, sweeps an arc from the first to the last measured angle. Its
// coordinates are sinusoids of the angle, so the extent over the whole arc is
// exact (end points and stationary points). Returns the largest excursion
// outside travel_mm in mm (<= 0: inside everywhere).
double travel_violation_mm(const Kit& kit, const AxisFrame& axis, const Installation& inst,
                           const std::vector<double>& angles_deg);

// What a set-up touches that it must not (mm by which it does; <= 0: clear), over the arc of
// the measured angles, each a check of the kit's workspace:
//   "the cup and blocks overhang the table"      (table side, with a table outline)
//   "the spindle ball is below a cup's height"    (table: H_base above the table surface,
//        on C always)
//   "the spindle ball nears the table"            (head, with a workspace: clearance_mm)
//   "the spindle nose reaches the table cup"      (table side, with a spindle)
//   "the spindle nose reaches the table"          (with a spindle)
struct Clash {
  std::string what;
  double by_mm = 0;
};
// The worst of each kind whose by_mm exceeds tolerance_mm, in the order above; empty: clear.
std::vector<Clash> installation_clashes(const Kit& kit, const AxisFrame& axis,
                                        const Installation& inst,
                                        const std::vector<double>& angles_deg,
                                        double tolerance_mm = 0);
// The checks installation_clashes makes with this kit (the `what` of each, without "the ..."
// clash wording: "the cup's footprint on the table", ...), in the order above.
std::vector<std::string> workspace_checks(const Kit& kit);
// The largest by_mm of every check (-infinity when none applies): <= 0 clear.
double workspace_violation_mm(const Kit& kit, const AxisFrame& axis, const Installation& inst,
                              const std::vector<double>& angles_deg);

// Chooses the bar and the sign of an installation: the shortest bar, sign +1
// before -1, that keeps the following ball inside the travel and the set-up clear of the
// workspace (installation_clashes). When none does, the choice with the smallest excursion
// is set. Returns the excursion (<= 0: fits).
double fit_bar(const Kit& kit, const AxisFrame& axis, Installation& inst,
               const std::vector<double>& angles_deg);
// fit_bar for every installation of the design (its axis and angles, the arc formed once);
// returns the largest excursion (-infinity without installations).
double fit_bars(const Kit& kit, Design& design);

// A probe kit's checks of one sphere over the arc of the measured angles (ProbeKit), mm by
// which each is broken (<= 0: clear), the worst of each kind whose by_mm exceeds tolerance_mm:
//   "the probe's approach leaves the travel"   (centre +-approach_mm along x, y; + along z)
//   "the sphere's stem tilts too far"          (by_mm: the tilt's excess in deg, as mm)
//   "the sphere's stand overhangs the table"   (C shorthand, with a table outline)
std::vector<Clash> sphere_clashes(const Kit& kit, const AxisFrame& axis, const Sphere& sphere,
                                  const std::vector<double>& angles_deg, double tolerance_mm = 0);
// The largest by_mm of the checks of every sphere of a probe design (-infinity without
// spheres): <= 0 clear. The probe's fit_bars.
double fit_spheres(const Kit& kit, const Design& design);

}  // namespace dbbkit
