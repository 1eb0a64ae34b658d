#pragma once
// An identify or diagnose result read back (the JSON `--out` writes, formats.md) for what
// follows it: `compare` of two results and `compensation` for a controller. Only the keys
// these need are read; each is checked, and a missing or malformed one is an InputError naming
// the file and the key.

#include <algorithm>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "dbbkit/axis_frame.hpp"

namespace dbbkit::io {

// One ISO 230 quantity as written: a value and its standard uncertainty (k = 1), absent where
// the data do not determine it.
struct ResultQuantity {
  std::string name, unit;  // "X0C", "um"
  std::optional<double> value, std;
};

// The component error motions (EXC .. ECC) at one angle.
struct ResultComponents {
  double angle_deg = 0;
  std::vector<ResultQuantity> motions;  // in ISO 230-1's order (translations, then rotations)
  // iso230.motion_covariance at this angle: the joint covariance of the six error motions less
  // their constant parts (dx..ez; um, urad). Absent in a result of an earlier version and where
  // the result states none.
  std::optional<Eigen::Matrix<double, 6, 6>> motion_covariance;
  // ... errors_matrix: the covariance of the six error motions themselves (constant parts
  // included); absent in a result of an earlier version.
  std::optional<Eigen::Matrix<double, 6, 6>> errors_covariance;
  // All six motions determined (the angles motion_covariance is stated at).
  bool all_determined() const {
    return motions.size() == 6 &&
           std::all_of(motions.begin(), motions.end(),
                       [](const ResultQuantity& q) { return q.value.has_value(); });
  }
};

// An error motion value (ISO 230-7 range of a component) and its expanded uncertainty.
struct ResultMotionValue {
  std::string component, name, unit;
  std::optional<double> value, U;
};

// The errors dx..ez at one angle.
struct ResultErrors {
  double angle_deg = 0;
  std::array<std::optional<double>, 6> value, std;
};

struct ResultFile {
  std::string source;       // the file
  std::string format;       // dbbkit.identify/1 or dbbkit.diagnose/1
  std::string design_name;  // as written
  std::string data_source;  // inputs.data: the readings' file (empty when not written)
  AxisFrame axis;           // from design.axis_frame (or the shorthand label)
  std::string errors_model;
  std::vector<ResultQuantity> location, constants;
  std::vector<ResultComponents> components;
  std::vector<ResultMotionValue> motion_values;
  double motion_coverage = 0.95;
  std::vector<ResultErrors> errors;
  bool setup_included = false;  // the design's set-up tolerances are in the uncertainties
  std::string uncertainty_note;
  std::vector<std::string> warnings;  // the texts of the result's warnings, as written
  // Their kinds (residual, first_order, setup_undeclared, noise_scale), in the same order;
  // empty where a warning gives none.
  std::vector<std::string> warning_kinds;
  // iso230.location_covariance, in the order of `location` (absent in a result of an earlier
  // version; rows of an undetermined one 0).
  std::optional<Eigen::Matrix<double, 5, 5>> location_covariance;
  // iso230.motion_covariance.independent_between_angles (false where absent).
  bool independent_between_angles = false;
  // The smallest effective degrees of freedom of the budget's values (Type A); absent where none
  // is stated (Type B: the declared noise).
  std::optional<double> dof;
  // design.machine: the machine the axis was measured on (formats.md, "Machine file").
  struct Machine {
    std::string name, file, controller;
    char axis = 'C';
    std::map<char, double> park_deg;  // the other axes
    Eigen::Vector3d origin_mm = Eigen::Vector3d::Zero();
  };
  std::optional<Machine> machine;
};

// Reads an identify or diagnose result (a diagnose result must carry its iso230 block).
ResultFile read_result_file(const std::string& path);
ResultFile result_from_text(const std::string& text, const std::string& source);

}  // namespace dbbkit::io
