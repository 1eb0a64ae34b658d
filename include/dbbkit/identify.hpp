#pragma once
// Identification of the six error motions from DBB readings: the linear model,
// the weighted least-squares estimate, the errors at each measured position
// with their standard uncertainties, and a description of what the data cannot
// determine (model.md §4 "known defect", §7).

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "dbbkit/design.hpp"
#include "dbbkit/estimate.hpp"
#include "dbbkit/measurement.hpp"
#include "dbbkit/linear_model.hpp"
#include "dbbkit/parameterisation.hpp"
#include "dbbkit/uncertainty.hpp"

namespace dbbkit {

// The six errors at one position; an error the data cannot determine has determined = false.
struct ErrorsAtAngle {
  double angle_deg = 0.0;
  int station = 0;
  std::array<Determined, 6> errors;  // dx, dy, dz [um], ex, ey, ez [urad]
};

// One direction of theta that no reading sees: theta and theta + t * direction
// give the same readings for any t, so the combination sum_i c_i theta_i
// (with c the unit direction) is not determined.
struct Unidentifiable {
  std::vector<std::pair<std::string, double>> terms;  // parameter name, coefficient
  std::optional<double> angle_deg;  // set when confined to one position (per_angle)
  std::string expression;           // e.g. "0.7071 ex - 0.7071 ez"
  std::string interpretation;       // the rigid motion it stands for, when per_angle
};

struct IdentifyOptions {
  EstimateOptions estimate;
  BudgetOptions budget;
};

// `errors` carry the combined standard uncertainty of the budget as their std.
struct IdentifyResult {
  Parameterisation param;
  LinearModel model;
  WlsSolver solver;
  Estimate estimate;
  Budget budget;
  std::vector<ErrorsAtAngle> errors;
  std::vector<Unidentifiable> unidentifiable;
};

// The errors at every station of the parameterisation from an estimate (whose
// unknowns may extend beyond the axis errors, e.g. by effects appended to J).
std::vector<ErrorsAtAngle> errors_at_stations(const Parameterisation& param, const Estimate& est);

// Named, localised description of the null space of an estimate.
std::vector<Unidentifiable> describe_null_space(const Design& design, const Parameterisation& param,
                                                const Estimate& est);

// Readings must have been validated against the design (validate_readings).
IdentifyResult identify(const Design& design, const std::vector<Reading>& readings,
                        const IdentifyOptions& options = {});

}  // namespace dbbkit
