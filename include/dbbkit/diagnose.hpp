#pragma once
// Closing the loop (model.md §6): find what the model does not explain, trace
// it to an effect of the library, add the effect, report before and after.
//
// Forward selection: at each step every candidate effect not yet in the model
// is appended to J. A candidate whose columns do not raise the rank by their
// number is confounded with the model (axis errors + effects already added) and
// is not added: its size cannot be told from the data. For the others, the
// nested F-test
//   F = ((chi2_cur - chi2_try) / q) / (chi2_try / (n - rank_try))
// gives p = P(F_{q, n - rank_try} >= F). The best candidate is added when
//   p < level / m   (Bonferroni over the m candidates tested at that step)
// and the Bayesian information criterion n ln(chi2/n) + rank ln n decreases.
// Selection stops when no candidate passes; then an exchange pass replaces an
// added effect by another candidate when that lowers chi2 (noise can favour a
// wrong candidate early), and forward selection resumes.
//
// Candidates can be equivalent: each alone is identifiable, but each lies in the
// span of the model plus the other (a length offset of 1r or of 2r, when both
// radial readings measure the same combination: only their difference is
// determined). The choice is then fixed by a declared convention: the candidate
// of the latest installation in the design is chosen, the earlier installation
// being the reference (shared effects count as earliest); the alternatives are
// reported, and the errors after are conditional on that convention.

#include <optional>
#include <string>
#include <vector>

#include "dbbkit/effects.hpp"
#include "dbbkit/estimate.hpp"
#include "dbbkit/identify.hpp"
#include "dbbkit/observability.hpp"
#include "dbbkit/setup.hpp"

namespace dbbkit {

struct DiagnoseOptions {
  double level = 0.01;  // family-wise significance level of each step
  int max_effects = 12;
  EstimateOptions estimate;
};

// F, p, chi2 and BIC change: the test of dropping the effect from the final
// model; step, p_threshold and n_tested: the selection step that added it.
struct EffectEvidence {
  int step = 0;
  double F = 0;
  int q = 0;    // columns added
  int dof = 0;  // n - rank after
  double p_value = 1;
  double p_threshold = 0;  // level / candidates tested at that step
  int n_tested = 0;
  double bic_change = 0;
  double chi2_before = 0, chi2_after = 0;
};

struct AddedEffect {
  EffectBlock block;
  std::vector<std::string> equivalent_to;  // labels of equivalent alternatives not chosen
  // Candidates that fit almost as well when the effect was chosen:
  //   chi2_other - chi2_chosen < 4 chi2_chosen / dof  (within two residual standard deviations);
  // the readings cannot tell them apart reliably (e.g. drift and reversal of one installation
  // measured ccw then cw).
  std::vector<std::string> close_alternatives;
  std::vector<Determined> values;  // one per column, in block.parameters order
  EffectEvidence evidence;
};

// The last word on every candidate: "added", "not significant", "confounded", "not applicable".
struct CandidateStatus {
  std::string label;
  std::string status;
  std::string detail;
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
  std::string dominant;  // the largest feature, in words
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

struct DiagnoseResult {
  double level = 0.01;
  Estimate before, after;
  std::vector<ErrorsAtAngle> errors_before, errors_after;
  std::vector<Unidentifiable> unidentifiable_after;
  std::vector<AddedEffect> added;
  std::vector<CandidateStatus> candidates;
  ResidualSignature signature_before, signature_after;
  bool significant_before = false, significant_after = false;
  std::optional<double> p_lower_after;  // P(chi2_dof <= chi2 after): small when the residual is too small
  std::vector<SetupRisk> setup_risks;  // most dangerous first (smallest threshold)
  std::string verdict;
};

ResidualSignature residual_signature(const Design& design, const std::vector<Reading>& readings,
                                     const Eigen::VectorXd& residual_um);

DiagnoseResult diagnose(const Design& design, const std::vector<Reading>& readings,
                        const DiagnoseOptions& options = {});

// Which effects of the library a design (with its error model) can tell from the
// axis errors, one at a time: "detectable", "confounded" or "not applicable".
std::vector<CandidateStatus> effect_detectability(const Design& design, const std::vector<Reading>& readings);

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
