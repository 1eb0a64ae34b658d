#pragma once
// Model selection (model.md §6): which candidate effects to append to the axis
// errors' columns J, and with what evidence.
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
// wrong candidate early), and forward selection resumes. Then an added effect
// whose F-test of dropping it from the model as it stands gives p >= level is
// dropped (later effects can make an early one redundant), and forward selection
// resumes; a dropped effect cannot re-enter at once, since entry needs p < level / m.
//
// Candidates can be equivalent: each alone is identifiable, but each lies in the
// span of the model plus the other (a length offset of 1r or of 2r, when both
// radial readings measure the same combination: only their difference is
// determined). The choice is then fixed by a declared convention: the candidate
// of the latest installation in the design is chosen, the earlier installation
// being the reference (effects of the whole test count as earliest); the
// alternatives are reported, and the errors after are conditional on that
// convention.
//
// Scanned candidates (effects.hpp ScanFamily: a step at an unknown reading, a
// warm-up with an unknown time constant) take part in each step as one candidate
// each: the best alternative against the current model (residual_checks.hpp), with
// p the smallest over the m alternatives times m (Bonferroni over the scan), and a
// BIC that counts the position as one more parameter. So a step competes with the
// drift and centring that would otherwise explain it away.
//
// A single reading is a candidate as well (its indicator column, scanned over every
// reading): when a gross reading is the best candidate of a step and passes the
// step's test, selection stops (stop_at_gross_reading) rather than add effects that
// would explain part of it away; diagnose names it, and a re-fit without it is the
// user's explicit choice.
//
// Structures: an effect of the whole test (one drift on the test's clock, one
// reversal or length change common to every installation) and the same effect
// per installation are alternatives that need not be nested. After selection,
// each is compared with the other by BIC (the model with the one replaced by the
// other, every other added effect kept), and the alternative is reported with
// both BICs. Nothing is replaced after selection: the F-tests with the BIC
// condition decide what enters, and when one whole-test term fits better than
// the first per-installation term it enters first (the same columns' count, so
// the lower chi2 is the lower BIC).

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "dbbkit/effects.hpp"
#include "dbbkit/estimate.hpp"
#include "dbbkit/residual_checks.hpp"

namespace dbbkit {

struct SelectionOptions {
  double level = 0.01;  // family-wise significance level of each step
  int max_effects = 12;
  // Each reading on its own is a candidate too (a gross reading, residual_checks.hpp): when it
  // is the best candidate of a step and passes, selection stops there, so that no effect of
  // the library is added to explain it away. Removing it is the caller's explicit choice.
  bool stop_at_gross_reading = true;
  // For a series model, the errors' columns of a higher order (residual_checks.hpp
  // model_order_check, K+1..K+4, p times the orders tried) are a candidate too: when they are the
  // best candidate of a step and pass, selection stops there, so that no effect of the library
  // is added to explain part of a motion the model's order cannot follow. Needs the design.
  bool stop_at_model_order = true;
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
  // A scanned candidate: the alternatives tested (its p at entry was min p times this).
  int scanned = 0;
};

// Another explanation (chi2_other, whose parameters cost extra_cost more than the chosen
// model's in Akaike's units, parameter_cost) that the readings cannot reject beside the chosen
// one: the evidence ratio of the chosen model to it below 20 by the Akaike weights (Burnham and
// Anderson 2002), exp(dAIC / 2) < 20, with chi2 in units of the chosen model's residual
// variance chi2 / dof:
//   (chi2_other - chi2) / (chi2 / dof) + max(0, extra_cost) < 2 ln 20 (= 5.99).
// With as many parameters, a chi2 within about 2.4 residual standard deviations. Akaike's
// weights rather than the BIC that selection uses: the alternatives are for the coverage of
// the errors after (the attribution), where the BIC's ln n per parameter would dismiss a true
// effect of two columns beside one of one column that fits nearly as well.
inline bool fits_almost_as_well(double chi2_other, const Estimate& chosen, double extra_cost = 0) {
  if (chosen.dof <= 0 || !(chosen.chi2 > 0)) return false;
  const double scale = chosen.chi2 / chosen.dof;
  return (chi2_other - chosen.chi2) / scale + std::max(0.0, extra_cost) < 2.0 * std::log(20.0);
}

struct AddedEffect {
  EffectBlock block;
  std::vector<std::string> equivalent_to;  // labels of equivalent alternatives not chosen
  // Candidates that fit almost as well (fits_almost_as_well) when the effect was chosen or in
  // its place in the final model; the readings cannot tell them apart reliably (e.g. drift and
  // reversal of one installation measured ccw then cw).
  std::vector<std::string> close_alternatives;
  // The candidates that still fit almost as well in the effect's place in the final model (of
  // the pool, or a scanned step or warm-up at its best position), with their columns.
  std::vector<EffectBlock> close_in_final;
  std::vector<Determined> values;  // one per column, in block.parameters order
  EffectEvidence evidence;
};

// The last word on a candidate effect.
enum class CandidateState {
  kAdded,           // in the final model
  kNotSignificant,  // tested and not added (or exchanged out)
  kConfounded,      // its columns do not raise the rank by their number: its size cannot be told
  kNotApplicable,   // its kind does not apply to this design (e.g. a reversal with one sweep
                    // direction)
  kEquivalent,      // explains the data exactly as an added effect does; only their difference is
                    // determined
  kDetectable,  // a design's a-priori answer (effect_detectability): it would raise the rank by its
                // number
  kSetUp,  // a set-up effect whose tolerance the design declares: carried as identify carries it
           // (fitted with the errors where the readings tell it apart, else in the uncertainty),
           // not a finding
  kImplausible,  // significant, but at a size the readings could not hold: not a finding
};

// "added", "not significant", "confounded", "not applicable", "equivalent", "detectable",
// "declared set-up".
const char* candidate_state_name(CandidateState s);

// Why a candidate ended in its state; the figures it names are in CandidateStatus, and
// io::candidate_detail (io/diagnose_text.hpp) says it in words.
enum class CandidateReason {
  kNotTested,         // selection ended before testing it
  kNotApplicable,     // `applicability`: why its kind does not apply to these readings
  kRankShort,         // its `columns` column(s) raise the rank by `added_rank` (`with_added`:
                      // given the effects already added too)
  kNoDof,             // no residual degrees of freedom left to test it
  kTested,            // F, p
  kScanRankShort,     // a scanned candidate: no alternative raises the rank
  kScanTested,        // a scanned candidate: its best alternative `other`, F, p, times
                      // `scanned` alternatives = p_scan
  kAdded,             // at `step`: F, p < threshold, bic_change
  kScanAdded,         // at `step`: alternative `other`, F, p over `scanned` alternatives
                      // < threshold, bic_change with its position
  kEquivalent,        // explains the data exactly as the added `other`
  kReleased,          // equivalent to `other`, which left the model
  kExchangedOut,      // exchanged for `other`, which explains the data better
  kExchangedIn,       // exchanged in for `other`
  kDropped,           // no longer significant once `other` (a list) were in the model: F,
                      // p >= level
  kRankShortOfModel,  // a design's a-priori answer: raises the rank by `added_rank` of
                      // `columns`; `note`: the error model
  kFullRank,          // a design's a-priori answer: raises the rank by its number of columns
  kSetUpFitted,       // a declared set-up effect the readings tell from the errors: fitted with
                      // them
  kSetUpCarried,      // a declared set-up effect the readings cannot tell from the errors: its
                      // tolerance carried in their uncertainties
  kBeyondInstrument,  // fitted, it alone would move the bar by `implied_um` in these readings,
                      // beyond the instrument's range `level` (um): left out
  kBeyondDriftRate,   // fitted, a drift or warm-up of `implied_um_per_min`, faster than the
                      // design's max_drift_um_per_min `level`: left out
};

// The best candidate of a step, which did not pass: the threshold its p had to beat and its
// change of BIC (with_position: the position of a scanned candidate counted as a parameter).
struct StepMiss {
  int step = 0;
  double threshold = 0, bic_change = 0;
  bool with_position = false;
};

struct CandidateStatus {
  std::string label;
  CandidateState state = CandidateState::kNotSignificant;
  CandidateReason reason = CandidateReason::kNotTested;
  std::string other;  // the effect(s) or the alternative the reason names
  std::string note;   // kRankShortOfModel: the error model; kEquivalent: what the later one is
                      // ("the later installation", "the later channel", "the later
                      // sphere", "the component found first"; empty: the later installation)
  Applicability applicability;  // kNotApplicable
  int step = 0, columns = 0, added_rank = 0, scanned = 0;
  bool with_added = false;
  double F = 0, p = 0, p_scan = 0, threshold = 0, bic_change = 0, level = 0;
  double implied_um = 0;          // kBeyondInstrument
  double implied_um_per_min = 0;  // kBeyondDriftRate
  std::optional<StepMiss> missed;
};

// One whole-test effect against the same effect per installation (the structures
// paragraph above): the labels and parameters of each, their BIC, which was kept.
struct StructureComparison {
  std::string kind;                   // effect name, e.g. "drift"
  std::vector<std::string> chosen;    // labels in the final model
  std::vector<std::string> rejected;  // labels of the alternative
  double bic_chosen = 0, bic_rejected = 0;
};

// Added effects that other candidates together replace almost as well in the final model
// (fits_almost_as_well), where no swap of one candidate for one effect does: a warm-up of the
// whole test in place of a drift of the whole test and one installation's length offset, or a
// length offset in place of a warm-up and a step. One or two added effects out, one or two
// candidates in (not one for one: that is AddedEffect::close_in_final). Their parameters are
// compared by their cost (fits_almost_as_well): a substitution that only fits the noise better
// is not named.
struct Substitution {
  std::vector<std::string> replaced;  // labels of the added effects taken out
  std::vector<EffectBlock> by;        // the candidates in their place
  double chi2 = 0;                    // of the final model with the substitution
};

struct Selection {
  Estimate before, after;
  std::vector<AddedEffect> added;
  std::vector<Substitution> substitutions;
  std::vector<CandidateStatus> candidates;
  std::vector<StructureComparison> structures;
  Jacobian J_final;  // [J, added effects' columns]
  // Selection stopped at this step because a single reading was the best candidate
  // (stop_at_gross_reading): its row and test; -1 when it did not.
  int stopped_at_reading = -1;
  // Selection stopped at this step because a higher order of the error model was the best
  // candidate (stop_at_model_order): its check.
  std::optional<OrderCheck> stopped_at_order;
  int stopped_at_step = 0;
  ScanTest gross;
};

// Bayesian information criterion of an estimate: n ln(chi2 / n) + rank ln n.
double bic(const Estimate& e);

// The cost in Akaike's units of the parameters an effect takes from the readings: 2 per column,
// and for a scanned parameter (a step's position, a warm-up's time constant not linearised in a
// column of its own) chosen as the best of m alternatives, 2 ln m: the expected largest of m
// chi2 falls of one column each grows as 2 ln m, so that a scanned effect does not pass for an
// explanation by fitting the noise at its best position.
double parameter_cost(const EffectBlock& b, int scanned_alternatives);

Selection select_effects(const Jacobian& J, const Eigen::VectorXd& sigma_um,
                         const Eigen::VectorXd& y_um, const std::vector<EffectBlock>& pool,
                         const SelectionOptions& options = {});
// With scanned candidates; `design` and `readings` build their alternatives.
Selection select_effects(const Jacobian& J, const Eigen::VectorXd& sigma_um,
                         const Eigen::VectorXd& y_um, const std::vector<EffectBlock>& pool,
                         const std::vector<ScanFamily>& families, const Design& design,
                         const std::vector<Reading>& readings,
                         const SelectionOptions& options = {});

}  // namespace dbbkit
