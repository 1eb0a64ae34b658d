#pragma once
// Set-up errors as nuisance effects of the one linear model.
//
// The declared length offset and centring tolerances of each installation
// (design.hpp, SetupUncertainty) become columns X (n x q) of the effect library
// (effects.hpp: length_offset 1, centring -s u.c per component) with a zero-mean
// prior beta ~ N(0, P), P = diag(u_j^2):
//   y = J theta + X beta + v,   v ~ N(0, Sigma),  W = Sigma^-1.
// The estimate is generalised least squares with V = Sigma + X P X', i.e. the
// augmented problem [J X; 0 P^-1/2] theta, beta = [y; 0], solved without forming it
// through the q x q Schur complement. With G0 and C0 the gain and covariance of the
// weighted least squares of J alone (WlsSolver; block-diagonal for a per-angle model):
//   R = W^1/2 (X - J G0 X)      n x q: the part of X the axis errors cannot reproduce
//   K = G0 X                    p x q: how X moves the estimate of J alone
//   S = R'R + P^-1              q x q: Schur complement of the augmented normal equations
//   beta_hat  = S^-1 R' W^1/2 (y - J G0 y)
//   theta_hat = G0 (y - X beta_hat) = G y,   G = G0 - K S^-1 R' W^1/2 (I - J G0)
// For a function c.theta the data determine, the error of c.theta_hat is c'G (X beta + v):
//   noise part    c'G Sigma G'c = c'C0 c + c'K S^-1 R'R S^-1 K'c
//   set-up part   c'G X P X'G'c = c'K S^-1 P^-1 S^-1 K'c      (G X = K S^-1 P^-1)
//   total         c'C0 c + c'K S^-1 K'c  = c'(J' V^-1 J)^+ c
// (the cross terms vanish because (I - J G0) J C0 = 0; setup.cpp). What the design's
// redundancy sees (R_j != 0) is estimated and shrinks below its prior; what it cannot
// see (R_j = 0) stays at its declared size: S_jj = 1 / u_j^2 and the set-up part is
// u_j^2 (c'K_j)^2. The null space of theta is that of J (a prior on beta adds no
// information on theta), so determinability is unchanged.
//   chi2 = |W^1/2 (y - J theta_hat - X beta_hat)|^2 + beta_hat' P^-1 beta_hat,
// chi-squared with n - rank(J) degrees of freedom when the model holds; the
// posterior covariance of beta is S^-1.
// With no tolerance declared q = 0 and everything reduces to the weighted least
// squares of J alone.

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "dbbkit/design.hpp"
#include "dbbkit/effects.hpp"
#include "dbbkit/estimate.hpp"
#include "dbbkit/identify.hpp"
#include "dbbkit/linear_model.hpp"
#include "dbbkit/parameterisation.hpp"

namespace dbbkit {

// One set-up effect of one installation (length_offset or centring), with the
// columns it has on the model's rows (all-zero components dropped).
struct SetupEffect {
  EffectKind kind = EffectKind::kLengthOffset;
  int installation = 0;
  std::string label;                    // "centring[3r]"
  std::vector<std::string> parameters;  // "value" or "cx", "cy", "cz"
  Eigen::MatrixXd J_reading_effect;     // n x parameters [um per um]
  double std_um = 0;  // declared standard uncertainty per column (0: none declared)
};

// The declared standard uncertainty of a set-up effect of `kind` (EffectInfo::setup) [um]; 0 for
// none and for any other kind.
double setup_std_um(const SetupUncertainty& u, EffectKind kind);

// Every per-installation length offset and centring the rows can show; with
// only_declared, only those with a declared tolerance.
std::vector<SetupEffect> setup_effects(const Design& design, const LinearModel& model,
                                       bool only_declared);
// The same on the rows given (installation and angle of each; the values are not used).
std::vector<SetupEffect> setup_effects(const Design& design, const std::vector<Reading>& rows,
                                       bool only_declared);

// What the design can tell of one set-up effect, on its own against the axis errors.
//   detectable: every direction of the effect changes what the axis errors leave
//   (added_rank). Detection limit: with r the smallest singular value of
//   R_e = W^1/2 (X_e - J G0 X_e) (whitened readings per um, the least favourable
//   direction of a multi-column effect), an effect of size a gives the nested F test
//   of diagnose the noncentrality lambda = (a r)^2 with q_e and n - rank - q_e degrees
//   of freedom; the limit is the a at which the test at level alpha has power 0.9.
//   Bias: the largest |c'G X_e v| over unit directions v (the norm of c'G X_e), over
//   every determined error at every station, per um of the effect.
struct SetupEffectCheck {
  std::string label;
  int installation = 0;
  EffectKind kind = EffectKind::kLengthOffset;
  double declared_std_um = 0;  // 0: none declared
  bool detectable = false;
  std::optional<double> detection_limit_um;  // absent when not detectable or no degrees of freedom
  // An effect of several parameters that is not detectable as a whole: the directions of its
  // parameters (unit vectors, in the order of `parameters`) that the axis errors take, none seen
  // by the readings. Each parameter alone may still be told from the axis errors (diagnose's
  // candidates, effect_detectability, take them one at a time): a sphere's placement across the
  // plane of three spheres is a rotation about the line through the other two. Empty when
  // detectable, for an effect of one parameter, and where the readings see no direction of it.
  std::vector<std::string> parameters;  // the effect's (SetupEffect::parameters)
  std::vector<std::vector<double>> hidden_directions;
  // Largest bias per um of the effect (absent when it moves no determined error).
  std::optional<double> bias_per_um;     // in the error's unit (um or urad) per um
  std::optional<double> bias_um_per_um;  // the same at the reference length, um per um
  int bias_error = -1;
  double bias_angle_deg = 0;
};

struct DetectionSettings {
  double level = 0.01;  // diagnose's family-wise level
  int n_tests = 1;      // candidates tested at once (Bonferroni: alpha = level / n_tests)
  double power = 0.9;
};

// The noncentrality at which an F(q, dof) test at level alpha has the given power.
double noncentrality_for_power(int q, int dof, double alpha, double power);

// What the readings keep of one set-up effect once the axis errors have taken their
// share: r^2 = the smallest eigenvalue of R_e'R_e (whitened readings^2 per um^2, the
// least favourable direction), q_e its directions the readings see, and whether every
// direction is told from the axis errors (added_rank). Of a design's declared effects,
// with the readings and the rank of the axis errors' model (the F test's degrees of
// freedom are n - rank - q_e).
struct SetupEffectInformation {
  EffectKind kind = EffectKind::kLengthOffset;
  int installation = 0;
  double declared_std_um = 0;
  int q = 0;
  bool detectable = false;
  double min_information = 0;  // r^2
};
struct SetupInformation {
  int n_readings = 0, rank = 0;
  std::vector<SetupEffectInformation> effects;
};
// The same, through the stacked model (the fast path is observability.hpp's).
SetupInformation dense_setup_information(const Design& design);
// The detection limit of an effect [um]: sqrt(lambda) / r with lambda the noncentrality
// at which the F(q_e, dof) test at level / n_tests has the power (SetupEffectCheck);
// absent when not detectable or without degrees of freedom.
std::optional<double> detection_limit_um(int q, bool detectable, double min_information, int dof,
                                         const DetectionSettings& settings);

// The determined error functions of an estimate, station by station in the order of the
// errors: each one's nonzeros [first, last) in one array.
struct DeterminedFunctions {
  struct Function {
    int station, error;
    std::size_t first, last;
  };
  std::vector<Function> functions;
  std::vector<std::pair<Eigen::Index, double>> nonzeros;
  // c' M.col(k) of function f.
  template <typename M>
  double dot(const Function& f, const Eigen::MatrixBase<M>& m, Eigen::Index k) const {
    double s = 0;
    for (std::size_t t = f.first; t < f.last; ++t)
      s += nonzeros[t].second * m(nonzeros[t].first, k);
    return s;
  }
};
DeterminedFunctions determined_functions(const Parameterisation& param, const Estimate& est);

// A drift or warm-up over the whole test, seen from a design before it is measured: the test's
// clock (design_row_times) puts the installations in the program's order (run_rank), one sweep each
// as the design reads it (sweep_readings: increasing angle, then the return reading), per_reading_s
// apart, per_installation_s between installations (simulate's schedule, the kit's time_s).
struct TestClock {
  double per_reading_s = 3;
  double per_installation_s = 240;
};
// Per row of design_model(design), its time from the test's first reading [s].
std::vector<double> design_row_times(const Design& design, const TestClock& clock);

// A test-wide drift (a bar or machine growing at a constant rate) or warm-up (1 - exp(-t / tau),
// tau a quarter of the test), scaled per um over the test: 1 um from the first reading to the
// last. Detection is against the axis errors and the declared set-up effects (as diagnose fits
// them), the limit in um over the test; the bias is the estimate's (with the declared set-up),
// as for SetupEffectCheck.
struct DriftCheck {
  std::string label;  // "drift[all]", "thermal[all](tau=10.4min)"
  EffectKind kind = EffectKind::kDrift;
  double tau_min = 0;  // thermal only
  bool detectable = false;
  std::optional<double> detection_limit_um;  // um over the test
  std::optional<double> bias_per_um;         // error unit per um over the test
  std::optional<double> bias_um_per_um;      // at the reference length
  int bias_error = -1;
  double bias_angle_deg = 0;
};
struct DriftChecks {
  TestClock clock;
  double test_min = 0;  // first reading to last
  int rank = 0;         // of the axis errors' model (near rank loss, a drift seems detectable)
  int n_unknowns = 0;   // of that model
  std::vector<DriftCheck> effects;
};

// The first-order validity check (FirstOrderCheck, identify.hpp) at the errors theta.
FirstOrderCheck first_order_check(const Design& design, const Parameterisation& param,
                                  const Eigen::VectorXd& theta);

}  // namespace dbbkit
