#pragma once
// What a design can tell before any reading is taken (model.md §7): rank,
// singular values and condition number of the equilibrated Jacobian, the
// observability indices O1..O5, the D/A/E/G criteria on M = J' Sigma^-1 J, the
// a-priori standard uncertainty of every error at every angle and the worst case.

#include <Eigen/Core>
#include <optional>
#include <vector>

#include "dbbkit/design.hpp"
#include "dbbkit/estimate.hpp"
#include "dbbkit/identify.hpp"
#include "dbbkit/setup.hpp"
#include "dbbkit/warning.hpp"

namespace dbbkit {

// On the singular values s_1 >= ... >= s_p of Js = Sigma^-1/2 J S (S: unit-norm
// columns), with p unknowns and n readings; a missing or sub-rank singular value counts as 0:
//   O1 = (s_1 s_2 ... s_p)^(1/p) / sqrt(n)    Borm & Menq (1991)
//   O2 = s_p / s_1                            Driels & Pathre (1990), inverse condition number
//   O3 = s_p                                  Nahvi & Hollerbach (1996), minimum singular value
//   O4 = s_p^2 / s_1                          Nahvi & Hollerbach (1996), noise amplification index
//   O5 = 1 / (1/s_1 + ... + 1/s_p)            Sun & Hollerbach (2008)
struct ObservabilityIndices {
  double O1 = 0, O2 = 0, O3 = 0, O4 = 0, O5 = 0;
};
ObservabilityIndices observability_indices(const Eigen::VectorXd& singular_values, int rank,
                                           int n_unknowns, int n_readings);

// Criteria on M = J' Sigma^-1 J in the units of theta (um, urad: they mix units,
// so compare them only between designs with the same parameterisation):
//   D = log det M, A = trace M^-1 (absent when M is singular), E = smallest
//   eigenvalue of M (0 when singular; to 1e-9 relative where the solver's blocks tie, as
//   the stations of a symmetric design do), G = largest leverage h_ii of a reading
//   (diagonal of the hat matrix; rank / n on average).
struct DesignCriteria {
  std::optional<double> D_logdet;
  std::optional<double> A_trace;
  double E_min_eigenvalue = 0;
  double G_max_leverage = 0;
};

// Largest standard uncertainty over all angles and all six errors, angular
// errors converted to um at the reference length: u[um] = 1e-3 * L_ref[mm] * u[urad].
struct WorstCase {
  std::optional<double> worst_std_um;  // absent when any error at any angle is not determined
  std::optional<double> worst_determined_std_um;  // over the determined ones
  int n_undetermined = 0;
  double at_angle_deg = 0;
  int at_error = -1;  // 0..5
};
WorstCase worst_case(const std::vector<ErrorsAtAngle>& errors, double reference_length_mm);

// The stations of a design's angles (as Parameterisation finds them), how often each is
// read, and their sines and cosines (sincos_deg). A search forms them once for its
// candidates, which share their angles; the fast paths below form their own for a design
// whose axis or angles differ.
struct AngleStations {
  AngleStations(const AxisFrame& axis, const std::vector<double>& angles_deg);
  bool serves(const Design& design) const;  // the same axis and the same angles, in order
  AxisFrame axis;
  std::vector<double> angles_deg;
  std::vector<double> station_deg, sin, cos;
  std::vector<int> count;
  int n_stations() const { return static_cast<int>(station_deg.size()); }
};

// The worst case of a design without assembling the stacked model. Every
// installation is read at every angle, so each angle's information is the
// body-frame information turned by the axis rotation: for a per-angle model one
// 6 x 6 Cholesky inverse serves every angle; for a series model the p x p
// information is summed from 6 x 6 blocks and inverted once. Used only when the
// design is far from rank loss (a bound on the equilibrated condition number
// <= 1e5, against the rank tolerance of 1e9); otherwise it is absent and
// evaluate_design answers. Same numbers as evaluate_design's worst case up to
// rounding (tested).
std::optional<WorstCase> fast_worst_case(const Design& design, double reference_length_mm,
                                         const AngleStations* stations = nullptr);

// The worst case of the noise part and of the total (noise and declared set-up,
// setup.hpp) of a design, without the rest of evaluate_design; without declared
// length offset or centring tolerances the total is the noise-only worst case.
// The noise part is absent only where it was not asked for (fast_worst_total).
struct TotalWorstCase {
  std::optional<WorstCase> noise;
  WorstCase total;
};
// fast_worst_total when it applies, else dense_worst_total.
TotalWorstCase design_worst_total(const Design& design, double reference_length_mm);
// The same through the stacked model and SetupSolver (the reference of the fast path).
TotalWorstCase dense_worst_total(const Design& design, double reference_length_mm);
// The same without the stacked model, for a per-angle model far from rank loss (as
// fast_worst_case): the rows turn with the angle as harmonics of order 1, so every
// station's variances are polynomials in (cos, sin) whose coefficients come from one
// r x r Cholesky in the space of the installations, r = 3 (m - 6) (Woodbury; the
// mathematics in observability.cpp). Absent where fast_worst_case would be (series
// model, near rank loss) and for a prior so large that rounding would show; without
// declared tolerances the total is fast_worst_case's. Without with_noise_part the noise
// part is not formed (the search scores the total alone).
std::optional<TotalWorstCase> fast_worst_total(const Design& design, double reference_length_mm,
                                               bool with_noise_part = true,
                                               const AngleStations* stations = nullptr);

// setup.hpp's SetupInformation of the declared set-up effects without the stacked model,
// where fast_worst_total's closed form applies (a per-angle model far from rank loss):
// the residual of an effect of installation i keeps the share N_ii = 1 - h_i (h_i the
// leverage of its body-frame row) at every angle, so r^2 is the smallest eigenvalue of
// w N_ii X' Phi X (X its harmonic coefficients, Phi = sum over the readings of phi phi').
std::optional<SetupInformation> fast_setup_information(const Design& design,
                                                       const AngleStations* stations = nullptr);
// fast_setup_information when it applies, else dense_setup_information.
SetupInformation design_setup_information(const Design& design);

// fast_worst_case when it applies (no declared set-up tolerances), else the worst
// case of evaluate_design (computed alone, design_worst_total).
WorstCase design_worst_case(const Design& design, double reference_length_mm);

struct Evaluation {
  Estimate prior;  // rank, singular values, condition number, covariance (of J alone)
  ObservabilityIndices indices;
  DesignCriteria criteria;
  // std only (the value is not meaningful without data): the reading-noise part of
  // the estimate's uncertainty (with declared set-up tolerances, that of the
  // estimate which carries them, setup.hpp).
  std::vector<ErrorsAtAngle> errors;
  std::vector<Unidentifiable> unidentifiable;
  WorstCase worst;  // of the noise part
  double reference_length_mm = 0;
  // The design's instrument (its set-up effects' names in the text).
  InstrumentKind instrument = InstrumentKind::kBallbar;

  // Set-up (setup.hpp). setup_included: the design declares length offset or
  // centring tolerances, and setup_errors / total_errors / worst_total hold the
  // set-up part and the total (noise and set-up) of every error. setup_checks:
  // every per-installation length offset and centring, declared or not, with
  // whether the design can detect it, its detection limit and the bias it causes.
  bool setup_included = false;
  std::vector<ErrorsAtAngle> setup_errors, total_errors;
  std::optional<WorstCase> worst_total;
  std::vector<SetupEffectCheck> setup_checks;
  // What makes the stated uncertainties unreliable (warnings.hpp: setup_undeclared).
  std::vector<Warning> warnings;
  DetectionSettings detection;
  // A design that declares no length offset or centring tolerance: the worst total standard
  // uncertainty it would have with typical ones (kTypicalSetupStd), the size of what the
  // noise-only figure leaves out (assess_design; absent otherwise).
  std::optional<WorstCase> worst_total_typical;
  // A drift or warm-up over the whole test (setup.hpp, DriftCheck) on the nominal clock;
  // drift_with_return: the same for the design with return readings, when it has none.
  DriftChecks drift;
  std::optional<DriftChecks> drift_with_return;
};

// The drift checks of a design alone (what evaluate_design gives as Evaluation::drift).
DriftChecks design_drift_checks(const Design& design, double reference_length_mm,
                                const DetectionSettings& detection = {},
                                const TestClock& clock = {});

// Typical set-up tolerances (standard uncertainties) of a ball bar installation: the length
// offset of a bar zeroed in its calibrator and its balls seated, the centring of a cup set
// against the spindle's ball by hand.
inline constexpr double kTypicalLengthOffsetStd_um = 1;
inline constexpr double kTypicalCentringStd_um = 5;
// The worst total standard uncertainty of `design` with the typical tolerances in place of
// its own; absent when it declares length offset or centring tolerances (its own figure then
// holds) or the figure is not determined.
std::optional<WorstCase> typical_setup_worst(const Design& design, double reference_length_mm);

// What evaluate_design says of a drift over the whole test: on which clock, and whether also for
// the design with return readings (when it has none).
struct DriftOptions {
  TestClock clock;
  bool with_return = true;
};

// The design as it would be measured: one reading per installation and angle.
// `detection`: the test the set-up detection limits refer to (diagnose's level, and
// the number of candidates it tests at once). `drift`: nullopt leaves Evaluation::drift empty
// (where no one reads it: a map's grid points, a candidate's score; each check factorises the
// model again).
Evaluation evaluate_design(const Design& design, double reference_length_mm,
                           const EstimateOptions& options = {},
                           const DetectionSettings& detection = {},
                           const std::optional<DriftOptions>& drift = DriftOptions{});

// A design map: one set-up coordinate (0 = L, 1 = D, 2 = H) of some installations
// set to each of a list of values.
struct SweepVariable {
  std::string name;  // as given, e.g. "L2"
  int coord = 0;
  std::vector<int> installations;
  std::vector<double> values;
};

struct SweepPoint {
  std::vector<double> values;  // one per variable
  int rank = 0;
  int n_unknowns = 0;
  std::optional<double> condition_number, worst_std_um, worst_determined_std_um;
};

// Every combination of the variables' values (first variable slowest). Throws
// InputError when a combination makes an invalid design.
std::vector<SweepPoint> sweep_design(const Design& design,
                                     const std::vector<SweepVariable>& variables,
                                     double reference_length_mm);

// The point of a design map with the smallest worst_std_um (the first of equals), or -1 when
// no point determines every error.
int best_sweep_point(const std::vector<SweepPoint>& map);

}  // namespace dbbkit
