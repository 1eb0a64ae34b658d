#pragma once
// What the user owns and the machine allows (format `dbbkit.kit/1`, formats.md):
// the ranges where a ball can be placed, the cushion blocks, the bars, the
// travel of the following ball, the angle steps and the time model. `optimize`
// searches inside a kit.

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

struct Kit {
  enum class Pattern { ThreePosition };

  std::string name;
  Axis axis = Axis::C;
  Pattern pattern = Pattern::ThreePosition;
  NoiseModel noise;
  ErrorModel errors;
  double reference_length_mm = 0;
  // Set-up tolerances of every installation of the designs (design.hpp); with a length
  // offset or centring declared, the default criterion is worst_total_std_um.
  SetupUncertainty setup_std;
  Interval L_mm;
  Interval D_mm;                  // {0, 0}: no lateral offset
  double H_base_mm = 0;           // C: height of the ball cup standing on the table
  std::vector<double> blocks_mm;  // C: the cushion blocks owned, one entry per block
  int max_stack = 0;              // C: at most this many blocks under one cup
  std::vector<double> bars_mm;    // bar lengths that can be assembled
  std::array<Interval, 3> travel_mm;  // x, y, z of the following ball, machine frame of model.md
  double min_separation_mm = 0;
  Interval angle_range_deg;
  std::vector<double> angle_steps_deg;
  double time_per_reading_s = 0;
  double time_per_installation_s = 0;
  std::optional<double> time_budget_s;  // absent: no limit
};

const char* pattern_name(Kit::Pattern pattern);

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

// The measured angles for one step: range.min, range.min + step, ..., range.max.
std::vector<double> kit_angles(const Kit& kit, double step_deg);

// installations x time_per_installation + readings x time_per_reading, one
// reading per installation and angle.
double design_time_s(const Kit& kit, const Design& design);

// The following ball sits at F = P - s bar u (README, "Conventions") and, as the
// axis turns, sweeps an arc from the first to the last measured angle. Its
// coordinates are sinusoids of the angle, so the extent over the whole arc is
// exact (end points and stationary points). Returns the largest excursion
// outside travel_mm in mm (<= 0: inside everywhere).
double travel_violation_mm(const Kit& kit, Axis axis, const Installation& inst, const std::vector<double>& angles_deg);

// Chooses the bar and the sign of an installation: the shortest bar, sign +1
// before -1, that keeps the following ball inside the travel. When none does,
// the choice with the smallest excursion is set. Returns the excursion (<= 0: fits).
double fit_bar(const Kit& kit, Axis axis, Installation& inst, const std::vector<double>& angles_deg);

}  // namespace dbbkit
