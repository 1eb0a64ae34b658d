#pragma once
// Synthetic readings from a declared truth: the errors of the axis (per angle
// or as a series), the instrument noise and a seed. Readings follow the
// first-order model of model.md §2, reading = s u.dP + noise, or, with
// geometry "exact", the exact two-ball geometry with a real set-up
// (exact_setup_reading_um): so that a test of the model is not checked by the
// model it tests.

#include <array>
#include <cstdint>
#include <optional>
#include <utility>
#include <vector>

#include "dbbkit/design.hpp"
#include "dbbkit/effects.hpp"
#include "dbbkit/kinematics.hpp"
#include "dbbkit/measurement.hpp"

namespace dbbkit {

// An effect hidden in simulated readings: the reading changes by J_reading_effect . value.
struct TruthEffect {
  EffectCandidate effect;
  std::string installation;  // id, empty for a shared effect (resolved against the design)
  Eigen::VectorXd value;     // full length, in effect_parameter_names order
};

// When readings are taken: installations one after another, each swept through
// the design's angles once per entry of `sweeps` (ccw in design order, cw reversed); written in
// design order, the installations timed in the order a program runs them (run_rank).
struct Schedule {
  double per_reading_s = 3;
  double per_installation_s = 240;
  std::vector<Sweep> sweeps = {Sweep::kCCW};
};

// Format `dbbkit.truth/1` (README).
struct Truth {
  ErrorModel model;                                    // per_angle, fourier (C) or legendre (B)
  std::vector<std::pair<double, Vector6d>> per_angle;  // angle_deg, (dx..ez)
  std::array<std::vector<double>, 6> coefficients;     // series: per error, in basis order
  std::optional<std::pair<double, double>> range_deg;  // legendre: the range x in [-1, 1] maps to
  std::optional<NoiseModel> noise;                     // absent: the design's noise
  bool noiseless = false;                              // noise "none"
  int repeats = 1;                                     // readings per installation and angle
  std::optional<std::uint64_t> seed;
  std::vector<TruthEffect> effects;
  std::optional<Schedule> schedule;  // absent: no time_s and no sweep in the readings
  // The axis' location errors by their ISO 230-1 names (um, urad), added to the errors as
  // the real axis adds them to first order (iso230.md): d += (I - R) o, e += (I - R) alpha +
  // c0 q. errors_given false: no "errors" in the file, the errors are the location's alone.
  std::vector<std::pair<std::string, double>> location;
  bool errors_given = true;

  // Exact two-ball geometry (exact_setup_reading_um) instead of the first-order rows.
  bool exact = false;
  std::optional<double> bar_mm;  // exact: bar of the installations without bar_mm in the design
  // Set-up errors (exact geometry only): drawn per installation from normal
  // distributions of these standard uncertainties, or given per installation id.
  struct SetupDraw {
    double length_offset_um = 0;
    double centring_um = 0;  // per machine axis of the following ball's path centre
    Eigen::Vector3d ball_mm = Eigen::Vector3d::Zero();  // L, D, H
  } setup_draw;
  std::vector<std::pair<std::string, SetupError>> setup_given;
};

// The set-up error of every installation of a simulation (design order): given,
// or drawn from setup_draw with a generator of its own seeded by `seed` (the noise
// draws do not depend on it). Zero for a first-order truth.
std::vector<SetupError> simulated_setup_errors(const Design& design, const Truth& truth,
                                               std::uint64_t seed);

// The true errors at an angle. Throws InputError when a per-angle truth has no
// value at that position.
Vector6d truth_errors(const Truth& truth, const AxisFrame& axis, double angle_deg,
                      const std::string& source = "truth");

// Checks a truth against a design (every position covered, coefficients of the right length).
void validate_truth(const Truth& truth, const Design& design, const std::string& source = "truth");

// One reading per installation, design angle and repeat, in design order.
std::vector<Reading> simulate(const Design& design, const Truth& truth, std::uint64_t seed);

}  // namespace dbbkit
