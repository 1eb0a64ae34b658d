#pragma once
// A held-out check (formats.md, "Predicting the tool tip, and verifying on a held-out test"): does
// one axis' identified errors explain the readings of another test of the same axis, one they
// were not fitted to?
//
// The test's readings y (its design's rows, the bar's length change) are predicted from the
// result as a point is (predict.hpp): at the reading's angle the error motions less their
// constant parts, m(gamma) = G(gamma) l + c(gamma) where the result measured the angle, the
// location errors' part G l elsewhere (the component motions there unknown: in the residual).
// The reading is g m, g the reading's sensitivity to the six motions (J_reading_error). What the
// test sets up anew, the constant parts of its motions (where each reading's zero was taken: d0,
// and e0 perpendicular to the axis, iso230.hpp), are nuisance columns N = g E, fitted to the
// test and taken out.
//
// At a measured angle G l + c is the result's estimate of the motions there less its constant
// parts, m^(gamma) - E k^: the error of k^ lies along N and is taken out with the test's own
// constants, so that what is left has the covariance D_gamma of the motions' estimate itself
// (IsoComponentsAtAngle::errors_covariance); where the result states that the estimates at two
// angles are independent (a per-angle model without a shared set-up effect), the residual
// r = y - g m has, when the result is right, exactly (once N is taken out) the covariance
//   V = sigma^2 I                          the test's reading noise (its design's)
//     + blockdiag_gamma(g D_gamma g')      the motions' estimate at a measured angle
//     + A C A' (angles not measured)       the location errors' estimate, A = g G
//     + X P X' + D Cs D'                   the test's declared set-up: length offsets and
//                                          centring (setup.hpp), the ball as placed
//                                          (J_reading_setup at the predicted motions).
// A result whose estimates are correlated between angles (a series, a shared set-up effect)
// predicts every reading from its location errors alone (said so). Between the location errors'
// estimate and a measured angle's motions the covariance (about 1 / angles of D) is neglected,
// where a test mixes the two. The statistic is the
// generalised least-squares residual after N,
//   chi2 = r' V^-1 r - r' V^-1 N (N' V^-1 N)^-1 N' V^-1 r,
// chi-squared with n - rank(N) degrees of freedom when the result explains the test and the
// noise is normal: it passes where chi2 is at most the quantile of the coverage probability
// (p = P(chi2_dof > chi2) at least 1 - coverage). Where the test's design declares uniform noise
// (its variance the same, its tails lighter: excess kurtosis -6/5), the statistic's variance is
// 2 dof + kappa sum_i sigma_i^4 A_ii^2 (A the statistic's matrix, r'A r), and it is taken as a
// scaled chi-squared of that mean and variance (Satterthwaite). Each reading's residual after N, e
// = r - N b, with its standard deviation (diag(V - N (N' V^-1 N)^-1 N')), points to where a fail
// sits; and each location error, let free (its column A_j beside N), says how much of the fail a
// change of its value would explain.

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "dbbkit/design.hpp"
#include "dbbkit/measurement.hpp"
#include "dbbkit/predict.hpp"

namespace dbbkit {

struct VerifyOptions {
  double coverage_probability = 0.95;
  bool location_only = false;  // the location errors alone at every angle
};

struct VerifiedReading {
  std::size_t index = 0;  // in the readings given
  PredictionBasis basis = PredictionBasis::kLocationOnly;
  double read_um = 0;       // as the instrument read it (the measurement file's value)
  double predicted_um = 0;  // from the result, with the test's constant parts as fitted, the same
  double residual_um = 0;   // read - predicted
  double std_um = 0;        // of the residual, when the result explains the test
  double normalized = 0;    // residual / std
};

// A location error let free: the change of its value the test asks for and what is left.
struct VerifyExplanation {
  int location = 0;          // in the order of IsoNames::location
  double change = 0;         // um or urad, added to the result's value
  double change_std = 0;     // its standard uncertainty (k = 1)
  double chi2 = 0;           // the statistic with it free (one degree of freedom fewer)
  bool passes_with = false;  // chi2 within the quantile of dof - 1
};

enum class VerifyGap {
  kNone,
  kLocationNotDetermined,  // the result does not determine every location error
  kNoRedundancy,           // the constant parts take up every reading (dof 0)
  kIllConditioned,         // the residual's covariance is beyond double precision
};

struct Verification {
  VerifyGap gap = VerifyGap::kNone;
  int readings = 0;
  // The distinct angles the test's readings hold; of them, those the location errors alone
  // predict (not measured by the result, or asked for), and of these, those the result measured
  // but whose motions' estimates it states no independent covariance for (a series model, a
  // set-up effect shared by the angles, or a result of an earlier version), and those whose
  // motions it states with no covariance at all (AxisErrors::measured_without_covariance: an
  // earlier version, or diagnose's shares).
  int angles = 0, angles_location_only = 0, angles_motions_correlated = 0;
  int angles_without_covariance = 0;
  int nuisance = 0;  // rank of N
  int dof = 0;
  double noise_std_um = 0;  // the test's reading noise (its design's)
  double coverage_probability = 0.95;
  double chi2 = 0, threshold = 0, p_value = 0;
  // The statistic taken as scale x chi-squared (statistic_dof): 1 and dof for normal noise; for
  // the design's uniform noise, the mean and variance of its lighter tails (verify_readings).
  double statistic_scale = 1, statistic_dof = 0;
  bool pass = false;
  std::vector<VerifiedReading> readings_checked;  // in the order given
  std::vector<std::size_t> worst;  // indexes into readings_checked, the largest |normalized| first
  std::vector<VerifyExplanation> explanations;  // the smallest chi2 first
};

// A test's readings predicted before it is run: each of its design's readings (its nominal
// readings, measurement.hpp) as the result predicts it, g m, with the test's own constant parts
// at zero (its cups and its readings' zero where the design has them; verify fits them), and the
// standard deviation of the reading about that prediction when the result is right: the test's
// reading noise, the result's uncertainty and the test's declared set-up (V's diagonal above, but
// at a measured angle with the covariance of the motions less their constant parts,
// AtAngle::covariance: nothing of the prediction is fitted, so a series result predicts its
// measured angles' motions too, as predict does a point).
struct PredictedReading {
  Reading reading;         // installation, angle (its value unused)
  bool is_return = false;  // the sweep's return reading (the design's return_reading)
  PredictionBasis basis = PredictionBasis::kLocationOnly;
  double predicted_um = 0;  // as the instrument will read it (its count: reading_sign)
  double std_um = 0;        // of the reading about it (k = 1)
};

struct PredictedTest {
  VerifyGap gap = VerifyGap::kNone;  // kLocationNotDetermined only
  int angles = 0, angles_location_only = 0, angles_motions_correlated = 0;  // as Verification's
  int angles_without_covariance = 0;
  double noise_std_um = 0;
  double coverage_probability = 0.95;
  std::vector<PredictedReading> readings;  // in the design's order
};

PredictedTest predict_test_readings(const AxisErrors& axis, const Design& design,
                                    const VerifyOptions& options = {});

// Every reading must belong to the design (validate_readings) and the design be of the same axis
// as `axis` (InputError from the caller otherwise).
Verification verify_readings(const AxisErrors& axis, const Design& design,
                             const std::vector<Reading>& readings,
                             const VerifyOptions& options = {});

}  // namespace dbbkit
