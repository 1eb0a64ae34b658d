#pragma once
// A design as a person sets it up at the machine: the installations in the order that changes
// the block stack, then the bar, the fewest times; and the design with its ball positions
// rounded to what can be set, checked and scored again.

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "dbbkit/design.hpp"
#include "dbbkit/kit.hpp"
#include "dbbkit/program.hpp"

namespace dbbkit {

struct SetupStep {
  int installation = 0;        // index into the design
  int position = 0;            // its ball position: 1, 2, ..., one more each time the cup moves
  bool moves_cup = false;      // the cup is placed at a new position (the first step included)
  bool changes_stack = false;  // C: the block stack under the cup is built anew
  bool changes_bar = false;    // the bar is assembled anew (the first step included)
};

struct SetupOrder {
  std::vector<SetupStep> steps;
  // Changes after the first set-up, in this order and in the design's order.
  int cup_moves = 0, stack_changes = 0, bar_changes = 0;
  int design_cup_moves = 0, design_stack_changes = 0, design_bar_changes = 0;
  // The order is the minimum over every order of the positions (false: more than
  // kMaxExactPositions positions, ordered greedily).
  bool exhaustive = true;
};

inline constexpr int kMaxExactPositions = 14;

// The installations at one ball position follow each other, those with the same bar together;
// which bar comes first and which last at a position is chosen with the order of the
// positions. The order minimises the stack changes first, then the bar changes: exactly, by
// dynamic programming over the subsets of positions and the (first, last) bar at each (at
// most kMaxExactPositions positions and 2^20 states, 16 MB), else greedily from the design's first
// position. The design's own order is kept when it changes no more (stack,
// then bar, then cup moves); its steps then number a position again when the cup comes back
// to it. Two stacks are the same when their cup and blocks are (or,
// without them in the design, the ball coordinate the stack sets is: stack_coordinate, see
// ProgramOptions); two bars when their lengths and parts are.
SetupOrder setup_order(const Design& design, std::optional<int> stack_coordinate = std::nullopt);
// The order a program of the design (written without a kit) runs its installations in: per
// installation (design index), its place in that order, 0 first. The test's clock follows it
// (design_row_times, simulate's schedule).
std::vector<int> run_rank(const Design& design);
// When each installation starts (design index), the installations run in run_rank's order, each
// taking duration_s[i] (its set-up and its readings): rank x the time where every installation
// takes as long as the others (the same numbers as before installations read parts of the
// design's angles), else the sum of those run before it.
std::vector<double> run_starts(const Design& design, const std::vector<double>& duration_s);

// The design with L, D (and H without a block stack given) rounded to multiples of
// resolution_mm, and what that changed.
struct RoundedDesign {
  Design design;
  double resolution_mm = 0;
  double largest_shift_mm = 0;  // over every coordinate of every installation
  // worst_std_um of the design as given and as rounded (absent: not every error determined).
  std::optional<double> worst_std_um, rounded_worst_std_um;
  // With declared length offset or centring tolerances: worst_total_std_um (noise and set-up),
  // as given and as rounded (absent: none declared, or not every error determined).
  std::optional<double> worst_total_std_um, rounded_worst_total_std_um;
  // With a kit: the installations whose following ball leaves the travel once rounded,
  // and by how much [mm].
  std::vector<std::pair<std::string, double>> outside_travel;
  bool travel_checked = false;
};

// Rounds and scores again (with the design's reference length; InputError without one) and,
// with a kit, checks the following ball of every rounded installation against its travel.
// resolution_mm in [0.001, 10].
RoundedDesign round_design(const Design& design, double resolution_mm, const Kit* kit);

// Everything a set-up sheet states: the design as it is set up (rounded when asked), the
// order, the measurement as programmed (the following ball at the first angle, the moves and
// dwells of each installation) and, with a kit, each step's set-up time: per_position when
// the cup moves, per_installation always.
struct SetupSheet {
  Design design;
  SetupOrder order;
  MeasurementProgram program;
  std::optional<RoundedDesign> rounding;
  // With a kit, the one time model (design_time, what optimize plans with): per step its
  // set-up and its readings at the kit's per_reading, and the total. Without a kit,
  // setup_time_s is empty and total_time_s the program's moves and dwells.
  std::vector<double> setup_time_s;  // per step: per_position when the cup moves + per_installation
  std::vector<double> step_time_s;   // per step: its set-up plus its readings x per_reading
  std::optional<TimeEstimate> time;  // with a kit
  // A table in the general form with a kit: per design installation, the kit's cup and blocks
  // that put its ball at its height above the table (none: no stack of the kit does). A
  // general-form design does not state them (stack_mm is the "C" shorthand's).
  std::vector<std::optional<Stack>> kit_stacks;
  // With kit_stacks: the kit's table (its normal at angle 0, machine frame, its surface's
  // distance from the frame's origin along it, and how it carries the ball), which the drawings
  // show under the stacks.
  struct KitTable {
    Eigen::Vector3d normal;
    double surface_mm = 0;
    TableCarriage carriage = TableCarriage::kAlongAxis;
  };
  std::optional<KitTable> kit_table;
  double total_time_s = 0;
  // With a kit: what was checked (a workspace's clearances where it states one; always the bar
  // above the table ball's cup and, on a table, the spindle ball above a cup's height) and every
  // clash of the set-up design's installations, by installation id.
  std::vector<std::string> workspace_checks;  // workspace_checks(kit)
  bool workspace_stated = false;              // the kit has a workspace
  std::vector<std::pair<std::string, Clash>> clashes;
  // With a kit, on a table axis: how far the program's clearance plane (where the spindle ball
  // travels sideways) lies above the kit's travel in z (<= 0: inside). Absent on a head, whose
  // commanded point is the pivot, not the following ball.
  std::optional<double> clearance_above_travel_mm;
  // Nothing the kit can check fails: no travel left, no clash, the clearance plane in travel.
  bool fits_kit() const {
    return outside_travel.empty() && clashes.empty() &&
           (!clearance_above_travel_mm || *clearance_above_travel_mm <= 0);
  }
  // With a kit: the installations whose following ball leaves its travel, and by how much
  // [mm], as set up (rounded when asked) and as the design gives them (then the rounding is
  // not the cause).
  bool travel_checked = false;
  std::vector<std::pair<std::string, double>> outside_travel, outside_travel_as_given;
};

SetupSheet make_setup_sheet(const Design& design, const ProgramOptions& program,
                            std::optional<double> resolution_mm, const Kit* kit);

}  // namespace dbbkit
