#pragma once
// The stacked linear model y = J theta + v (architecture.md): one row per
// reading, theta the unknowns of a Parameterisation, v the instrument noise
// with standard deviation sigma per row (uncorrelated).

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <vector>

#include "dbbkit/design.hpp"
#include "dbbkit/measurement.hpp"
#include "dbbkit/parameterisation.hpp"

namespace dbbkit {

// The Jacobian of the readings: one row per reading, stored by rows. A per-angle model
// has six entries a row (its station's errors), a series model one per coefficient.
using Jacobian = Eigen::SparseMatrix<double, Eigen::RowMajor>;

struct LinearModel {
  Jacobian J;                // [um per unit of theta], n_readings x n_parameters
  Eigen::VectorXd y_um;      // readings (zero for a design model)
  Eigen::VectorXd sigma_um;  // standard deviation of each reading
  std::vector<int> row_installation;
  std::vector<int> row_station;
  std::vector<double> row_angle_deg;
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

// d(readings)/d(input) [um/mm] at the errors theta: column j is the change of the
// model readings J theta per mm of set-up input j. Exact: a row is linear in the ball position.
Eigen::MatrixXd setup_sensitivity(const Design& design, const Parameterisation& param,
                                  const LinearModel& model, const std::vector<SetupInput>& inputs,
                                  const Eigen::VectorXd& theta);

}  // namespace dbbkit
