#pragma once
// The residual's tests on a factorised model (ColumnTester) and the checks that run them: internal
// to the library (the installed residual_checks.hpp states the tests and their results; diagnose
// runs them).

#include <Eigen/Core>
#include <optional>
#include <utility>
#include <vector>

#include "dbbkit/residual_checks.hpp"

namespace dbbkit {

class WlsSolver;

class ColumnTester {
 public:
  // `fit` = solver.solve(y) for the readings y.
  ColumnTester(const WlsSolver& solver, const Estimate& fit, const EstimateOptions& options = {});

  ColumnTest test(const Eigen::MatrixXd& X) const;

  // Steps between consecutive readings of `rows` (one installation, in time order), with at
  // least min_segment readings on each side.
  ScanTest scan_steps(const std::vector<int>& rows, int min_segment) const;

  // Each reading of `rows` alone (its indicator column): the externally studentised residual,
  // t^2 = F(1, dof - 1).
  ScanTest scan_readings(const std::vector<int>& rows) const;

 private:
  // The one-column test from x'Wr, x'Wx and |R|^2.
  ColumnTest one_column(double xWr, double xWx, double R2) const;

  const WlsSolver& solver_;
  const Estimate& fit_;
  EstimateOptions options_;
  Eigen::VectorXd w_;  // 1 / sigma^2
};

// Every feature of every installation, against the model of `solver` fitted to the readings
// (`fit` = solver.solve(y)); `readings` as validated against `design`.
std::vector<ResidualFeature> residual_features(const Design& design,
                                               const std::vector<Reading>& readings,
                                               const WlsSolver& solver, const Estimate& fit,
                                               const EstimateOptions& options = {});

std::optional<OrderCheck> model_order_check(const Design& design,
                                            const std::vector<Reading>& readings,
                                            const WlsSolver& solver, const Estimate& fit,
                                            const EstimateOptions& options = {});
// The same on columns already built (higher_order_columns), tested against the model `tester`
// holds, whose fit is `fit`; `order` the design's.
std::optional<OrderCheck> model_order_check(
    int order, const std::vector<std::pair<int, Eigen::MatrixXd>>& higher,
    const ColumnTester& tester, const Estimate& fit);

}  // namespace dbbkit
