#pragma once
// Maps the unknown vector theta to the six errors at an angle (model.md §5):
//   per_angle: six free unknowns at every measured position ("station");
//   fourier K (axis C): each error = c0 + sum_k (a_k cos k g + b_k sin k g), k = 1..K;
//   legendre K (axis B): each error = sum_k c_k P_k(x), x = 2 (b - b_min)/(b_max - b_min) - 1.
// Stations are the distinct positions of the design; for C, angles equal
// modulo 360 deg are one station (360 repeats 0).

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <string>
#include <vector>

#include "dbbkit/design.hpp"

namespace dbbkit {

// Two angles are the same position of the axis: |a - b| < kAngleTolerance_deg,
// for C modulo 360 deg.
bool same_position(const AxisFrame& axis, double a_deg, double b_deg);

// Series coefficients per error: Fourier 2K + 1, Legendre K + 1, per_angle 1.
int coefficients_per_error(const ErrorModel& model);

// Basis functions of a series, shared by the parameterisation and the simulator:
// Fourier (1, cos g, sin g, ..., cos K g, sin K g) of the angle in degrees, and
// Legendre P_0..P_K at x in [-1, 1].
Eigen::VectorXd fourier_basis(int order, double angle_deg);
Eigen::VectorXd legendre_basis(int order, double x);
// Each basis function's parity under the basis' reflection (Fourier: g -> -g, the sines odd;
// Legendre: x -> -x, odd degrees odd): +1 even, -1 odd; empty for per angle.
std::vector<int> basis_parity(const ErrorModel& model);

class Parameterisation {
 public:
  explicit Parameterisation(const Design& design);

  const ErrorModel& model() const { return model_; }
  const AxisFrame& axis() const { return axis_; }
  // The unknowns: the axis errors' parameters, then any appended (append_unknowns).
  int n_parameters() const { return n_parameters_; }
  int n_axis_parameters() const { return n_parameters_ - static_cast<int>(extra_names_.size()); }
  // Unknowns after the axis errors' (effects fitted with them, identify's IdentifyOptions::
  // effects), read by no error: every error function has zeros in their rows.
  void append_unknowns(const std::vector<std::string>& names);
  int n_stations() const { return static_cast<int>(station_deg_.size()); }
  double station_angle_deg(int station) const { return station_deg_[station]; }
  // The station of an angle, or -1 when the angle is no position of the design.
  int station_of(double angle_deg) const;
  // The station of each of the design's angles, in its order (found once, on construction).
  const std::vector<int>& design_stations() const { return design_stations_; }

  // The six errors at a station as functions of theta, sparse (n_parameters x 6, column k
  // is error k, on the coefficients it reads: its station's one for a per-angle model), and
  // at any angle for a series (per_angle: the angle must be a station). With rows >
  // n_parameters, the matrix has that many rows (unknowns after theta's, such as set-up
  // columns, read by no error).
  Eigen::SparseMatrix<double> error_functions(int station, Eigen::Index rows = 0) const;
  Eigen::SparseMatrix<double> error_functions_at_angle(double angle_deg,
                                                       Eigen::Index rows = 0) const;
  // The same as a dense map: e6 = E theta (6 x n_parameters).
  Eigen::MatrixXd error_map(int station) const;
  Eigen::MatrixXd error_map_at_angle(double angle_deg) const;
  // The six errors at an angle, e6 = E theta.
  Eigen::Matrix<double, 6, 1> errors_at_angle(double angle_deg, const Eigen::VectorXd& theta) const;

  // Parameter j: which error (0..5 = dx..ez), which station (per_angle; else -1), name; an
  // appended unknown: error and station -1, its name.
  int parameter_error(int j) const;
  int parameter_station(int j) const;
  std::string parameter_name(int j) const;
  // Number of series coefficients per error (per_angle: 1).
  int coefficients_per_error() const { return per_error_; }
  // Legendre: the range the polynomials are defined on.
  double range_min_deg() const { return lo_deg_; }
  double range_max_deg() const { return hi_deg_; }

  // The basis functions of one error at an angle (size coefficients_per_error()).
  Eigen::VectorXd series_basis(double angle_deg) const;

 private:
  AxisFrame axis_;
  ErrorModel model_;
  std::vector<double> station_deg_;
  std::vector<int> design_stations_;
  std::vector<std::pair<double, int>>
      index_;                             // (angle key, station), sorted: station_of in O(log n)
  double key_of(double angle_deg) const;  // C: angle modulo 360 in [0, 360); B: the angle
  int per_error_ = 1;
  int n_parameters_ = 0;
  std::vector<std::string> extra_names_;
  double lo_deg_ = 0, hi_deg_ = 0;
  // A series: series_basis at each station, formed once (row s; empty for per angle);
  // series_basis of a station's own angle reads it.
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> station_basis_;
  Eigen::VectorXd formed_basis(double angle_deg) const;
  // A series' six error functions from the basis f (coefficients_per_error() values).
  Eigen::SparseMatrix<double> series_error_functions(const double* f, Eigen::Index rows) const;
};

}  // namespace dbbkit
