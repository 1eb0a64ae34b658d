#pragma once
// Propagation of distributions after JCGM 101, as a check of the linear (GUM)
// result. The measurement is replayed at the identified errors theta_hat:
//   y* = J theta_hat + D dq + v,   values* = C G y*
// with v drawn from the declared reading noise (rectangular or normal; with a
// Type A budget, normal scaled by sqrt(nu / chi2_nu), which gives Student t
// marginals), dq the set-up inputs drawn N(0, u), G the identification's gain.
// The number of trials is adaptive (JCGM 101 §7.9): batches of M trials until
// twice the standard deviation of the batch estimates of the mean, the standard
// uncertainty and both interval endpoints is below the numerical tolerance
// delta = 1/2 10^l of every value, where u = c 10^l with n_dig significant digits in c.
// Validation (JCGM 101 §8): d_low = |y - U - y_low|, d_high = |y + U - y_high|; the
// linear result is validated when both are <= delta.

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "dbbkit/design.hpp"
#include "dbbkit/estimate.hpp"
#include "dbbkit/linear_model.hpp"
#include "dbbkit/parameterisation.hpp"
#include "dbbkit/uncertainty.hpp"

namespace dbbkit {

struct MonteCarloOptions {
  std::uint64_t seed = 1;
  int threads = 1;             // 0: all hardware threads
  long batch_trials = 10000;   // M of JCGM 101 §7.9.4 (>= 100 / (1 - p))
  long max_trials = 2000000;   // the adaptive procedure stops here, not converged
  bool adaptive = true;        // false: exactly max_trials trials
  int significant_digits = 2;  // n_dig of the numerical tolerance
  // The trials of one batch are kept (4 bytes per value and trial), never more: the
  // interval endpoints over all trials come from histograms around them (monte_carlo.cpp),
  // so memory does not grow with max_trials. A batch whose batch_trials x values x 4
  // exceeds this is refused before it starts, naming the largest batch that fits (an
  // InputError, key "batch_trials").
  std::size_t max_sample_bytes = std::size_t{1} << 30;
  // With set-up tolerances the map from readings to values, C G, is dense (values x
  // readings). Up to this size it is formed once; beyond it each batch applies it as a
  // product (SetupSolver::left_gain_times), so its memory stays linear in the design. The
  // results agree to rounding (MonteCarlo.FactoredSetupGainAgreesWithTheFormedOne).
  std::size_t max_dense_gain_bytes = std::size_t{256} << 20;
  // Called after each batch with the trials so far (from the calling thread).
  std::function<void(long trials)> progress;
};

struct MonteCarloValue {
  int station = 0;
  double angle_deg = 0;
  int error = 0;
  double mean = 0, std = 0, low = 0, high = 0;  // probabilistically symmetric interval
  double linear_value = 0, linear_u = 0, linear_U = 0;
  double delta = 0;  // numerical tolerance of linear_u
  double d_low = 0, d_high = 0;
  bool validated = false;
  // The interval to report: the linear one when validated, else the Monte Carlo one.
  double interval_low() const { return validated ? linear_value - linear_U : low; }
  double interval_high() const { return validated ? linear_value + linear_U : high; }
};

struct MonteCarloResult {
  long trials = 0;
  bool converged = false;  // the adaptive procedure met its tolerance
  int threads = 1;
  std::uint64_t seed = 0;
  double coverage_probability = 0.95;
  int significant_digits = 2;
  int n_validated = 0;
  int refinement_passes = 0;  // replays of the trials to place an interval endpoint finely enough
  std::vector<MonteCarloValue> values;  // in the order of budget.values (empty: nothing to draw)
  bool adaptive = false;                // the number of trials was adaptive
  int unplaced_endpoints = 0;  // interval endpoints not placed within a tenth of the tolerance
};

// Numerical tolerance of a standard uncertainty u with n_dig significant digits: 1/2 10^l.
double numerical_tolerance(double u, int significant_digits);

// The design as it would be measured, replayed at zero errors with the declared noise (Type B):
// checks the linear a-priori uncertainties of `evaluate`.
MonteCarloResult monte_carlo_a_priori(const Design& design, double coverage_probability,
                                      const MonteCarloOptions& options);

}  // namespace dbbkit
