#pragma once
// Closing the loop (model.md §6): find what the model does not explain, trace
// it to an effect of the library, add the effect, report before and after. Which
// effects are added, and the evidence for each, is model selection
// (selection.hpp); diagnose describes the residual before and after, the set-up
// effects the final model cannot see; io/diagnose_text.hpp gives the verdict in words.

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "dbbkit/effects.hpp"
#include "dbbkit/estimate.hpp"
#include "dbbkit/identify.hpp"
#include "dbbkit/observability.hpp"
#include "dbbkit/residual_checks.hpp"
#include "dbbkit/selection.hpp"
#include "dbbkit/setup.hpp"

namespace dbbkit {

struct DiagnoseOptions {
  double level = 0.01;  // family-wise significance level of each step
  int max_effects = 12;
  // Refit without the gross readings found (at most max_gross, in passes until none is
  // found): the user's explicit choice, reported in the result and the verdict.
  bool exclude_gross = false;
  int max_gross = 10;
  EstimateOptions estimate;
  // The corrected errors' ISO 230-7 error motion values (a Monte Carlo, iso230.hpp).
  IsoMotionOptions iso_motion;
};

// The size of a library effect that diagnose's first step would find with the given power
// (setup.hpp's detection limit: the F-test at level / candidates tested, least favourable
// direction), with the declared noise.
struct DetectionLimit {
  std::string label;
  std::string unit;
  std::optional<double> limit;  // absent without degrees of freedom
  // The limit's own reach in these readings (effect_reach_um) where it lies beyond the
  // instrument's range: the readings could not hold an effect that large, so this design cannot
  // see the effect at all.
  std::optional<double> beyond_instrument_um;
  // Likewise a drift or warm-up limit faster than the design's max_drift_um_per_min: its rate
  // (um/min; a warm-up's at its start, drift_rate_um_per_min).
  std::optional<double> beyond_drift_rate_um_per_min;
  bool unseeable() const { return beyond_instrument_um || beyond_drift_rate_um_per_min; }
};

struct ResidualSignature {
  struct Installation {
    std::string id;
    double L_mm = 0, D_mm = 0, H_mm = 0;  // the ball, so that dependence on radius and height shows
    int n = 0;
    double mean_um = 0, rms_um = 0;
    std::vector<double> harmonic_um;  // amplitude of k = 1, 2, ... per turn (axis C)
    std::optional<double> slope_um_per_min;
    std::optional<double> cw_minus_ccw_um;
  };
  std::vector<Installation> installations;
  std::optional<ResidualFeature> dominant;  // the most significant feature (smallest p)
};

// A set-up effect (per-installation length offset or centring, not added) that the
// final model cannot detect, and what it does to the errors after: the error it moves
// most relative to that error's stated standard uncertainty u, by b per um of the
// effect (the largest over the effect's directions). threshold_um = u / b: the size
// at which it moves the error by u. With a declared tolerance, at_declared = its
// standard uncertainty times b, and exceeds when that is more than u.
struct SetupRisk {
  std::string label;
  int error = 0;
  double angle_deg = 0;
  double bias_per_um = 0;  // error unit per um
  double stated_std = 0;   // error unit
  double threshold_um = 0;
  double declared_std_um = 0;  // 0: none declared
  std::optional<double> at_declared;
  bool exceeds = false;
};

// An added effect that one or more candidates still fit almost as well in the final model
// (fits_almost_as_well, as close_alternatives), or a substitution (selection.hpp): the errors
// refitted with each alternative in its place. largest_change[k]: the largest change of error k
// (dx..ez) over the positions and the alternatives; at each position the change enters the
// error's standard uncertainty, so that the errors hold whichever is true: as a rectangular
// half-width, change / sqrt(3), for alternatives that fit almost as well, whole for the
// convention (alternatives that fit exactly as well). Several attributions combine in
// quadrature.
struct Attribution {
  std::string effect;                      // an added effect, or "a + b" for a substitution's
  std::vector<std::string> alternatives;   // labels, or "c + d" for a substitution's
  std::array<double, 6> largest_change{};  // um, urad
  // The effects were chosen by convention among equivalent ones (AddedEffect::equivalent_to):
  // `effect` lists them all, each alternative is one combination of their equivalents, and the
  // readings fit every combination exactly as well.
  bool convention = false;
  std::size_t untried = 0;  // combinations beyond the first 256 (convention), left out
  // The largest change of each ISO quantity of the corrected errors (location errors, constant
  // parts, component error motions, in IsoResult's order; 0 where not determined).
  std::vector<double> iso_change;
};

// Why forward selection stopped before no candidate passed (selection.hpp).
enum class SelectionStop {
  kNone,
  kGrossReading,  // one reading alone was the best candidate of a step
  kModelOrder,    // a higher order of the series error model was the best candidate
};
// "none", "gross reading", "model order".
const char* selection_stop_name(SelectionStop s);

struct DiagnoseResult {
  double level = 0.01;
  Estimate before, after;
  std::vector<ErrorsAtAngle> errors_before, errors_after;  // errors_after: with attributions' share
  std::vector<Attribution> attributions;
  std::vector<Unidentifiable> unidentifiable_after;
  std::vector<AddedEffect> added;
  std::vector<Substitution> substitutions;  // added effects that other candidates together replace
  std::vector<CandidateStatus> candidates;
  std::vector<StructureComparison> structures;  // whole-test against per-installation terms
  ResidualSignature signature_before, signature_after;
  bool significant_before = false, significant_after = false;
  std::optional<double>
      p_lower_after;  // P(chi2_dof <= chi2 after): small when the residual is too small
  std::vector<SetupRisk> setup_risks;  // most dangerous first (smallest threshold)
  // Checks of the residual outside the library (residual_checks.hpp), on the final model.
  std::vector<ResidualFeature> features_before,
      features_after;               // features_before: on the axis errors alone
  std::vector<GrossReading> gross;  // rows index the readings fitted
  int stopped_at_step = 0;          // selection stopped at this step (0: it did not), for
  SelectionStop stopped_because = SelectionStop::kNone;  // this reason
  std::optional<OrderCheck> order;                       // series models
  std::optional<NoiseScale> noise;                       // when the residual after is significant
  bool noise_larger_than_declared = false;  // significant after, no feature or check explains it
  std::vector<DetectionLimit> detection_limits;  // when nothing was added
  // Readings left out by exclude_gross: indices into the readings given, and their tests.
  std::vector<int> excluded_rows;
  std::vector<GrossReading> excluded;  // rows index the readings given
  // Gross readings exclude_gross left in: the data cannot tell which of several readings is
  // the gross one (GrossReading::indistinguishable), so excluding one would be a guess.
  std::vector<GrossReading> not_excluded;  // rows index the readings given
  // The smallest p of the features after times their number, at most 1 (Bonferroni): below
  // the level, some feature explains the residual left.
  double features_p_all = 1;
  // Per error (dx..ez), the largest |after - before| over the positions where both are
  // determined; absent where none is.
  std::array<std::optional<double>, 6> largest_change_of_errors;
  // The corrected errors in ISO 230 terms (iso230.hpp): location errors, constant parts and
  // component error motions of the final model, each with the attributions' share in its
  // standard uncertainty as the errors have it; the error motion values from the final model's
  // covariance (the attributions' share not in them).
  IsoResult iso_after;
  // What makes the corrected errors' uncertainties unreliable (warnings.hpp): the residual
  // after the effects found still contradicting the declared noise.
  std::vector<Warning> warnings;
  // The design's instrument (its set-up effects' names in the text).
  InstrumentKind instrument = InstrumentKind::kBallbar;
};

ResidualSignature residual_signature(const Design& design, const std::vector<Reading>& readings,
                                     const Eigen::VectorXd& residual_um);

DiagnoseResult diagnose(const Design& design, const std::vector<Reading>& readings,
                        const DiagnoseOptions& options = {});

// Which effects of the library a design (with its error model) can tell from the
// axis errors, one at a time: "detectable", "confounded" or "not applicable".
std::vector<CandidateStatus> effect_detectability(const Design& design,
                                                  const std::vector<Reading>& readings);

// The test set-up detection limits refer to (setup.hpp): diagnose's first step, at its
// level over the candidates it would test at once (the detectable ones of `candidates`,
// effect_detectability on the readings the limits are for).
DetectionSettings diagnose_detection_settings(const std::vector<CandidateStatus>& candidates,
                                              const DiagnoseOptions& options = {});

// What `evaluate` reports of a design before measuring: which library effects it can
// tell from the axis errors on the readings it would take (effect_detectability), and
// evaluate_design with the set-up detection limits referred to diagnose's test on them.
struct DesignAssessment {
  Evaluation evaluation;
  std::vector<CandidateStatus> effects;
};
DesignAssessment assess_design(const Design& design, double reference_length_mm);

}  // namespace dbbkit
