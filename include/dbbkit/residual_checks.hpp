#pragma once
// Tests of a fitted model's residual against what the model cannot express
// (model.md §6): extra columns, a step at an unknown reading, a gross reading.
//
// Every test is the nested F-test of appending columns X (n x q) to the model J
// of a WLS fit, computed without refactorising [J X] (Frisch-Waugh-Lovell): with
// G the solver's gain, W = Sigma^-1 and r = y - J theta the residual,
//   R = W^1/2 (X - J G X)                 the part of X the model cannot reproduce,
//   delta_chi2 = |P_R W^1/2 r|^2          the fall of chi2 when X is appended,
//   F = (delta_chi2 / q') / ((chi2 - delta_chi2) / (dof - q')),  q' = rank R,
//   p = P(F(q', dof - q') >= F).
// The F-test refers the fall to the residual's own scatter, so it holds whether or
// not the declared noise is right. For one column x,
//   |R|^2 = x'Wx - (J'Wx) . (Gx),  R'W^1/2 r = x'W r,
// and the column's coefficient is x'Wr / |R|^2 with standard uncertainty 1 / |R|
// (from the declared noise).
//
// A scan over alternatives (a step between any two consecutive readings of an
// installation; each reading on its own, for a gross reading) takes the best, and
// its p-value is the smallest p over the m alternatives tested times m
// (Bonferroni): the chance that noise alone produces a scan as extreme is at
// most that. For steps and single readings |R|^2 and x'Wr come from running sums
// of the rows of W J and the columns of G, O(p) per alternative.

#include <Eigen/Core>
#include <optional>
#include <vector>

#include "dbbkit/design.hpp"
#include "dbbkit/estimate.hpp"
#include "dbbkit/measurement.hpp"

namespace dbbkit {

struct ColumnTest {
  int q = 0;           // columns given
  int added_rank = 0;  // q' = the rank they add (0: the model reproduces them; nothing to test)
  double delta_chi2 = 0;
  int dof = 0;  // dof of the model with them appended
  double F = 0;
  double p = 1;
  double value = 0,
         std = 0;  // one column only: its coefficient and standard uncertainty (declared noise)
};

// P(F(q, dof) >= F); 1 when F <= 0 or there is nothing to test.
double f_test_p(int q, int dof, double F);

// The order of significance: the smaller p; where p ties (both below the smallest double, or
// within a relative kSignificanceTie), the larger F; where F ties too, neither. A scan keeps the
// first of tied alternatives: equivalent features (a step in one installation and the opposite
// step in another whose difference alone the data determine) tie exactly but for rounding.
constexpr double kSignificanceTie = 1e-9;
// Two readings' indicator columns are indistinguishable when the correlation of their
// unexplained parts is at least 1 - kIndistinguishable in size (rounding of the projection
// leaves them 1e-12 apart; distinct ones of a real design are farther than 1e-3).
constexpr double kIndistinguishable = 1e-6;
inline bool more_significant(double p_a, double F_a, double p_b, double F_b) {
  if (p_a < p_b * (1.0 - kSignificanceTie)) return true;
  if (!(p_a <= p_b * (1.0 + kSignificanceTie))) return false;  // clearly less significant, or NaN
  return F_a > F_b * (1.0 + kSignificanceTie);
}

struct ScanTest {
  int best = -1;    // the alternative chosen (steps: index in `rows` of the first reading after the
                    // step; readings: the row); -1 when none could be tested
  int tested = 0;   // alternatives tested (m)
  ColumnTest test;  // of the best alternative
  double p_scan = 1;  // min(1, m p): the scan's p-value
  // Readings (scan_readings) that the data cannot tell from the best: their indicator columns'
  // unexplained parts are parallel to its own (|correlation| >= 1 - kIndistinguishable), so
  // each explains the residual exactly as the best does (one residual degree of freedom at a
  // station). Which of them is the gross one is not known.
  std::vector<int> ties;
  std::vector<double> tie_values;  // each tie's own offset (its indicator's coefficient)

  // Counts alternative `alt` when it can be tested (it adds rank and leaves degrees of freedom),
  // and keeps it when it is the most significant so far.
  void consider(int alt, const ColumnTest& t) {
    if (t.added_rank == 0 || t.dof <= 0) return;
    ++tested;
    if (best < 0 || more_significant(t.p, t.F, test.p, test.F)) best = alt, test = t;
    p_scan = tested * test.p < 1.0 ? tested * test.p : 1.0;
  }
};

// ---------------------------------------------------------------------------
// The checks diagnose runs on a fitted model (J: the axis errors and the effects
// added; y the readings). Each is a stated test at diagnose's level.

// A feature of the residual, tested against the model by the F-test above
// (standardised by its own uncertainty, not by raw size):
//   kMean          the installation's readings all offset (indicator column)
//   kHarmonic      k per turn in the installation (cos and sin on its readings, axis C)
//   kDrift         (t - t0) / 60 on the installation's readings
//   kReversal      +-1/2 on its cw / ccw readings (value = cw - ccw)
//   kStep          a step scanned over the installation's readings (p over the positions)
//   kReading       one reading on its own, scanned over all readings (a gross reading)
enum class FeatureKind { kMean, kHarmonic, kDrift, kReversal, kStep, kReading };
const char* feature_kind_name(
    FeatureKind k);  // "mean", "harmonic", "drift", "cw_minus_ccw", "step", "reading"

struct ResidualFeature {
  FeatureKind kind = FeatureKind::kMean;
  int installation = -1;           // -1: all (kReading)
  int harmonic = 0;                // kHarmonic
  int row = -1;                    // kStep: the first reading after the step; kReading: the reading
  std::optional<Reading> reading;  // that reading
  double value = 0, std = 0;  // one column: coefficient (um, um/min) and its standard uncertainty;
                              // kHarmonic: the amplitude (um), std 0
  ColumnTest test;
  int tested = 1;  // alternatives scanned (kStep, kReading), else 1
  double p = 1;    // the test's p, times `tested` for a scan
  // Installations whose feature of the same kind this one makes confounded: only the
  // difference is determined (a mean of 1r against 2r when the model holds their sum).
  std::vector<int> difference_with;
  // kReading: the readings the data cannot tell from `row` (ScanTest::ties), and the offset
  // each would have.
  std::vector<int> indistinguishable;
  std::vector<double> indistinguishable_values;
  // What no machine or bar can have: the feature alone would move the bar by this much in these
  // readings (um; a drift over the span of its readings: its installation's, or the test's for
  // one of the whole test), beyond the instrument's range (design.instrument_range_mm). Such
  // a feature stands for something the model lacks, not for itself: never the most significant
  // feature, never a finding.
  std::optional<double> beyond_instrument_um;
  // Likewise a drift faster than the design's max_drift_um_per_min: its rate (um/min).
  std::optional<double> beyond_drift_rate_um_per_min;
  bool implausible() const { return beyond_instrument_um || beyond_drift_rate_um_per_min; }
};

// The amplitudes sqrt(a_k^2 + b_k^2) of the harmonics k = 1..K of a turntable's residual on the
// readings `rows` (least squares of mean + a_k cos k g + b_k sin k g jointly), K = min(4,
// (P - 1) / 2) for P distinct positions; empty when K < 1. Both the residual signature and the
// harmonic features of residual_features state these.
std::vector<double> residual_harmonics(const std::vector<Reading>& readings,
                                       const std::vector<int>& rows,
                                       const Eigen::VectorXd& residual_um);

// Marks each feature no machine or bar can have: beyond the instrument's range
// (ResidualFeature::beyond_instrument_um) or a drift beyond the design's max_drift_um_per_min.
void mark_implausible(const Design& design, const std::vector<Reading>& readings,
                      std::vector<ResidualFeature>& features);

// Gross readings, one at a time: the reading whose indicator column gives the smallest
// scan p (the externally studentised residual, Bonferroni over the readings) is flagged
// when that p is below `level`; its column is appended and the next is sought, at most
// max_count. The residual is the fitted model's at the reading when it was flagged.
struct GrossReading {
  int row = -1;
  // The readings the data cannot tell from it (ScanTest::ties): any of them may be the gross
  // one, so none is named alone and none is excluded.
  std::vector<int> indistinguishable;
  std::optional<Reading> reading;     // filled by the caller that has the readings (diagnose)
  std::vector<Reading> alternatives;  // the readings of `indistinguishable`, likewise
  std::vector<double> alternative_values_um;  // the offset each of them would have
  double residual_um = 0;
  double value_um = 0,
         std_um = 0;  // its offset from the rest (the indicator's coefficient) and uncertainty
  double t = 0;       // externally studentised residual (signed)
  double p = 1;       // single-reading p
  double p_scan = 1;
  int tested = 0;
};
std::vector<GrossReading> gross_readings(const Jacobian& J, const Eigen::VectorXd& sigma_um,
                                         const Eigen::VectorXd& y_um, double level, int max_count,
                                         const EstimateOptions& options = {});

// The errors' columns of each order K' = K+1 .. K+4 that the positions allow (2K'+1 <= P for
// Fourier, K'+1 <= P for Legendre), each the whole J of that order, with K'; empty for a
// per-angle model. The order check (diagnose) tests the part the model of order K does not span.
std::vector<std::pair<int, Eigen::MatrixXd>> higher_order_columns(
    const Design& design, const std::vector<Reading>& readings);

// The model's order (Fourier or Legendre errors): the errors' columns of order K' = K+1 ..
// K+4 (as far as the positions allow: 2K'+1 for Fourier, K'+1 for Legendre) appended to J
// (the fitted model's, which holds those of order K and the effects added); the K' of lowest BIC is
// suggested when its F-test p times the orders tried is below the level. The fit with it: chi2 and
// dof.
struct OrderCheck {
  int order = 0;      // the design's
  int suggested = 0;  // K' of lowest BIC
  int tried = 0;
  ColumnTest test;  // of K' against K
  double p = 1;     // test.p times tried
  double chi2_with = 0;
  int dof_with = 0;
  std::optional<double> p_value_with;  // P(chi2_dof >= chi2) with K'
};

// The scale of the noise: the readings scatter k = sqrt(chi2 / dof) times the declared
// noise, with the 95 % interval [sqrt(chi2 / q_0.975), sqrt(chi2 / q_0.025)] (q the
// chi-squared quantiles with dof degrees of freedom).
struct NoiseScale {
  double ratio = 1, low = 1, high = 1;
};
NoiseScale noise_scale(double chi2, int dof);

}  // namespace dbbkit
