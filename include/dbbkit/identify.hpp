#pragma once
// Identification of the six error motions from DBB readings: the linear model,
// the weighted least-squares estimate, the errors at each measured position
// with their standard uncertainties, and a description of what the data cannot
// determine (model.md §4 "known defect", §7).

#include <array>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "dbbkit/design.hpp"
#include "dbbkit/effects.hpp"
#include "dbbkit/estimate.hpp"
#include "dbbkit/iso230.hpp"
#include "dbbkit/linear_model.hpp"
#include "dbbkit/measurement.hpp"
#include "dbbkit/monte_carlo.hpp"
#include "dbbkit/parameterisation.hpp"
#include "dbbkit/uncertainty.hpp"
#include "dbbkit/warning.hpp"

namespace dbbkit {

// The six errors at one position; an error the data cannot determine has determined = false.
struct ErrorsAtAngle {
  double angle_deg = 0.0;
  int station = 0;
  std::array<Determined, 6> errors;  // dx, dy, dz [um], ex, ey, ez [urad]
};

// The six errors at one position with their expanded uncertainties U (same units).
struct ExpandedValue {
  bool determined = false;
  double value = 0.0;
  double U = 0.0;
};
struct ExpandedErrorsAtAngle {
  double angle_deg = 0.0;
  int station = 0;
  std::array<ExpandedValue, 6> errors;
};
// U = k u for every determined value (an a-priori expansion, a_priori_expansion()).
std::vector<ExpandedErrorsAtAngle> expanded_errors(const std::vector<ErrorsAtAngle>& errors,
                                                   double k);
// U of each determined value from its budget (Budget::values); a determined value without a
// budget entry is a logic_error.
std::vector<ExpandedErrorsAtAngle> expanded_errors(const std::vector<ErrorsAtAngle>& errors,
                                                   const Budget& budget);

// One direction of theta that no reading sees: theta and theta + t * direction
// give the same readings for any t, so the combination sum_i c_i theta_i
// (with c the unit direction) is not determined.
// A null direction confined to one position is a small rigid motion (d, e) of the moving
// body: a translation along `direction` (e = 0), or a rotation or screw motion about the line
// through `point_mm` along `direction` (machine frame). tool_axis: that line is the B head's
// tool axis; on_all_balls: every ball (a probe's: every sphere's centre) of the design lies on it
// (no reading sees the motion), otherwise it moves the balls only across their reading directions.
struct RigidMotion {
  enum class Kind { kTranslation, kRotation, kScrew };
  Kind kind = Kind::kTranslation;
  Eigen::Vector3d direction = Eigen::Vector3d::Zero();
  Eigen::Vector3d point_mm = Eigen::Vector3d::Zero();
  bool tool_axis = false;
  bool on_all_balls = false;
  InstrumentKind instrument = InstrumentKind::kBallbar;  // whose points: balls or spheres' centres
};

struct Unidentifiable {
  std::vector<std::pair<std::string, double>> terms;  // parameter name, coefficient
  std::optional<double> angle_deg;    // set when confined to one position (per_angle)
  std::optional<RigidMotion> motion;  // the rigid motion it stands for, when per_angle
};

struct IdentifyOptions {
  EstimateOptions estimate;
  BudgetOptions budget;
  // The ISO 230-7 error motion values (iso230.hpp; a Monte Carlo); their coverage
  // probability and, with a Type A budget, degrees of freedom follow the budget.
  IsoMotionOptions iso_motion;
  // Effects fitted with the axis errors as free unknowns (a model fixed once, e.g. the effects
  // diagnose added, effect_from_label); `effects_source` names them in messages.
  std::vector<EffectCandidate> effects;
  std::string effects_source = "--effects";
};

// An effect fitted with the axis errors (IdentifyOptions::effects): its parameters' values and
// standard uncertainties (the reading noise, with the Type A factor when the budget has one,
// and the declared set-up tolerances).
struct FittedEffect {
  std::string label, unit;
  std::vector<std::string> parameters;
  std::vector<Determined> values;
  // Candidates of the library that fit exactly as well in its place (the same column space with
  // the axis errors and the other effects): the values are conditional on the choice of this
  // one. largest_change: of any error at any angle should one of them take its place (um, urad).
  std::vector<std::string> equivalent_to;
  std::array<double, 6> largest_change{};
};

// A set-up effect estimated with its prior (setup.hpp): the posterior value and
// standard uncertainty beside the declared one. A posterior equal to the prior
// means the readings say nothing of it.
struct SetupEstimate {
  std::string label;      // "centring[3r]"
  std::string parameter;  // "value", "cx", ...
  double value_um = 0, std_um = 0, declared_std_um = 0;
};

// The first-order validity check of the reading model: the largest second-order
// term |D_perp|^2 / (2 bar) of any reading, with D_perp the relative displacement of
// the two balls perpendicular to the bar from the identified errors plus the set-up
// at 3 standard uncertainties (ball placement L/D/H and centring).
// A probe's term is its exact reading (the sphere's centre turned by the exact transform) less
// the row's at the identified errors.
struct FirstOrderCheck {
  InstrumentKind instrument = InstrumentKind::kBallbar;  // whose term (InstrumentInfo)
  bool computed = false;
  std::string without_bar;  // not computed: the first installation without bar_mm
  double largest_term_um = 0;
  std::string installation;
  double angle_deg = 0;
  double noise_sigma_um = 0;
  double threshold_um = 0;  // kFirstOrderWarning sigma
  bool warn = false;        // largest_term > threshold_um
  // A bound on the bias of every identified error, should every reading carry the
  // largest term t: |c'G delta| <= t |c'G|_1 (G the estimate's gain), as a multiple of
  // the error's standard uncertainty, the largest over the errors and where.
  std::optional<double> bias_bound_std;
  int bias_error = -1;
  double bias_angle_deg = 0;
};

// `errors` carry the combined standard uncertainty of the budget as their std.
struct IdentifyResult {
  Parameterisation param;
  LinearModel model;
  // The model's factorisation (internal, src/wls_solver.hpp), shared by copies of the result.
  std::shared_ptr<const WlsSolver> solver;
  Estimate estimate;
  Budget budget;
  std::vector<ErrorsAtAngle> errors;
  std::vector<Unidentifiable> unidentifiable;
  // Set-up: whether declared length offset and centring tolerances are part of the
  // model (then `estimate` is that of setup.hpp), and the estimated effects;
  // placement_declared: some installation declares ball placement (L, D, H) tolerances.
  bool setup_included = false;
  bool placement_declared = false;
  std::vector<SetupEstimate> setup_estimates;
  FirstOrderCheck first_order;
  // ISO 230-7 location errors, constant parts and component error motions (iso230.hpp).
  IsoResult iso;
  // The effects fitted with the axis errors (IdentifyOptions::effects), in their order.
  std::vector<FittedEffect> effects;
  // What makes the stated uncertainties unreliable here (warnings.hpp); empty: nothing.
  std::vector<Warning> warnings;
  // The design's instrument (its set-up effects' names in the text).
  InstrumentKind instrument = InstrumentKind::kBallbar;
};

// The six functions c.theta that are the errors dx..ez at `station`: column k is
// error k over n_unknowns >= param.n_parameters() unknowns (those beyond the axis
// errors, e.g. effects appended to J, get 0).
// Stored sparse: a per-angle model's have one entry each.
Eigen::SparseMatrix<double> error_functions(const Parameterisation& param, int station,
                                            Eigen::Index n_unknowns);

// The errors at every station of the parameterisation from an estimate (whose
// unknowns may extend beyond the axis errors, e.g. by effects appended to J).
std::vector<ErrorsAtAngle> errors_at_stations(const Parameterisation& param, const Estimate& est);

// Named, localised description of the null space of an estimate.
std::vector<Unidentifiable> describe_null_space(const Design& design, const Parameterisation& param,
                                                const Estimate& est);

// Readings must have been validated against the design (validate_readings).
// `options` with each reading's Type A (Reading::u_a_um, u_a_dof) as BudgetOptions'
// per-reading repeatability, as `option` asks (the caller's name of it). Throws
// InputError(source, the reading) when one has none (`source`: the readings' file), and
// InputError(option) when options.type_a is set too.
BudgetOptions with_reading_type_a(BudgetOptions options, const std::vector<Reading>& readings,
                                  const std::string& source, const std::string& option);

IdentifyResult identify(const Design& design, const std::vector<Reading>& readings,
                        const IdentifyOptions& options = {});

// The joint covariance of the identified values (uncertainty.hpp budget_covariance), in the
// order of result.budget.values; the set-up solver is rebuilt when the set-up is included.
Eigen::MatrixXd budget_covariance(const Design& design, const IdentifyResult& result);

// The JCGM 101 check of an identification's budget (monte_carlo.hpp), with the set-up
// solver of its declared tolerances rebuilt when the set-up is included.
MonteCarloResult monte_carlo(const Design& design, const IdentifyResult& result,
                             const MonteCarloOptions& options);

}  // namespace dbbkit
