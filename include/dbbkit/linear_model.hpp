#pragma once
// The stacked linear model y = J theta + v (architecture.md): one row per
// reading, theta the unknowns of a Parameterisation, v the instrument noise
// with standard deviation sigma per row (uncorrelated).

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <memory>
#include <utility>
#include <vector>

#include "dbbkit/design.hpp"
#include "dbbkit/measurement.hpp"
#include "dbbkit/parameterisation.hpp"

namespace dbbkit {

// The Jacobian of the readings: one row per reading, stored by rows. A per-angle model
// has six entries a row (its station's errors), a series model one per coefficient.
using Jacobian = Eigen::SparseMatrix<double, Eigen::RowMajor>;

// A series model's rows factor through the six errors at the reading's angle:
//   J(i, k m + a) = g_i(k) phi_a(angle_i),
// g_i the reading's sensitivities to the six errors (J_reading_error) and phi the m basis
// functions of one error at its angle. The solver sums the information from 6 x 6 blocks per
// angle times the basis' outer products instead of the n x p rows (WlsSolver).
struct SeriesRows {
  int per_error = 0;                                            // m
  Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::RowMajor> g;  // n x 6
  std::vector<int> angle;                                       // row -> row of basis
  Eigen::MatrixXd basis;                                        // distinct angles x m
  std::vector<int> parity;  // each basis function's, under the basis' reflection (basis_parity)
};

struct LinearModel {
  Jacobian J;                // [um per unit of theta], n_readings x n_parameters
  Eigen::VectorXd y_um;      // readings (zero for a design model)
  Eigen::VectorXd sigma_um;  // standard deviation of each reading
  std::vector<int> row_installation;
  std::vector<int> row_station;
  std::vector<double> row_angle_deg;
  // A series model's factored rows (built with J; absent for a per-angle model). Whoever
  // changes J drops it.
  std::shared_ptr<const SeriesRows> series;

  LinearModel() = default;
  LinearModel(const LinearModel&) = default;
  LinearModel& operator=(const LinearModel&) = default;
  // A move takes J's storage: Eigen 3.4's SparseMatrix has no move of its own and would copy.
  LinearModel(LinearModel&& other) noexcept { *this = std::move(other); }
  LinearModel& operator=(LinearModel&& other) noexcept {
    J.swap(other.J);
    y_um = std::move(other.y_um);
    sigma_um = std::move(other.sigma_um);
    row_installation = std::move(other.row_installation);
    row_station = std::move(other.row_station);
    row_angle_deg = std::move(other.row_angle_deg);
    series = std::move(other.series);
    return *this;
  }
};

// [J X]: the columns of X (n x q, dense) after those of J; exact zeros of X are left out.
Jacobian append_columns(const Jacobian& J, const Eigen::MatrixXd& X);

// Rows for the given readings (validated against the design beforehand).
LinearModel build_linear_model(const Design& design, const Parameterisation& param,
                               const std::vector<Reading>& readings);

// Rows the design would measure: one per installation and design angle, y = 0.
LinearModel design_model(const Design& design, const Parameterisation& param);

// One set-up input: coordinate `coord` (0 = L, 1 = D, 2 = H) of one installation.
struct SetupInput {
  int installation = 0;
  int coord = 0;
  double std_mm = 0;
};

// The set-up inputs with a declared uncertainty (design.setup_std), in installation order.
std::vector<SetupInput> setup_inputs(const Design& design);

// d(readings)/d(input) [um/mm] at the errors theta: column j is the derivative of the model
// readings J theta with respect to set-up input j (the ball's L, D or H). The ball moves the
// lever arm of the rotations and, the following ball staying on its programmed path, turns
// the bar by dP_perp / bar, which changes the reading of every error; an installation without
// bar_mm has no known bar, and only the lever arm is counted for it.
Eigen::MatrixXd J_reading_setup(const Design& design, const Parameterisation& param,
                                const LinearModel& model, const std::vector<SetupInput>& inputs,
                                const Eigen::VectorXd& theta);

}  // namespace dbbkit
