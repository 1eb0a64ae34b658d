#pragma once
// The set-up errors' solver and what is computed with it: internal to the library (the installed
// setup.hpp states the model; IdentifyResult and the commands reach it through identify and
// evaluate).

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <optional>
#include <string>
#include <vector>

#include "dbbkit/setup.hpp"
#include "dbbkit/uncertainty.hpp"

namespace dbbkit {

class WlsSolver;

class SetupSolver {
 public:
  // `base` must outlive the solver.
  SetupSolver(const WlsSolver& base, const std::vector<SetupEffect>& declared);

  int n_columns() const { return static_cast<int>(prior_std_.size()); }
  bool any() const { return n_columns() > 0; }
  // Everything that does not depend on the readings: rank and null space of J,
  // covariance = the total (in low-rank form, Estimate::covariance_K/S).
  const Estimate& a_priori() const { return prior_; }
  // theta_hat, residual, chi2 (with the prior term) and p-value.
  Estimate solve(const Eigen::VectorXd& y_um) const;
  // beta_hat for the readings, and its posterior covariance S^-1.
  Eigen::VectorXd beta(const Eigen::VectorXd& y_um) const;
  const Eigen::MatrixXd& beta_covariance() const { return S_inv_; }
  // Column j: which effect (index into the effects given), which of its parameters, and its kind.
  const std::vector<std::pair<int, int>>& column_of() const { return column_of_; }
  EffectKind column_kind(int j) const { return column_kind_[j]; }
  double column_prior_std(int j) const { return prior_std_(j); }

  // G M: the estimate's response to readings M (n x m), e.g. the columns of an effect.
  Eigen::MatrixXd gain_times(const Eigen::MatrixXd& M) const;
  // C G: the map from readings to the functions C theta (rows of C), without forming G:
  //   C G = C G0 - T W^1/2 + (T W^1/2 J) G0,  T = C K S^-1 R'.
  Eigen::MatrixXd left_gain(const FunctionRows& C) const;
  // The same map applied to readings V (n x m) without forming it (C G is values x readings,
  // dense with a set-up part):
  //   C G V = C (G0 V) - L R' W^1/2 (V - J G0 V),  L = C K S^-1 = left_gain_setup(C),
  // formed once for many V; memory that of G0 V (unknowns x m).
  Eigen::MatrixXd left_gain_setup(const FunctionRows& C) const;
  Eigen::MatrixXd left_gain_times(const FunctionRows& C, const Eigen::MatrixXd& L,
                                  const Eigen::MatrixXd& V) const;
  // The 1-norm of every row of left_gain(C), without forming it: each row is c'G0 from the
  // rows of G0 that c touches (rows of C with one support in one product), plus (K'c)' D
  // with D = S^-1 R' W^1/2 (J G0 - I) formed once (memory: the readings times the unknowns
  // and the set-up columns, and 256 rows of C at a time, not rows(C) x readings).
  Eigen::VectorXd left_gain_l1(const FunctionRows& C) const;
  // C G X diag(u): the change of C theta_hat per standard-normal draw of every set-up
  // column (beta = u z): C K S^-1 diag(1 / u).
  Eigen::MatrixXd setup_draw_map(const FunctionRows& C) const;
  // N = R' W^1/2 (q x n), the map from readings to the set-up part of the gain, so that
  //   C G v = C G0 v - L N v,  L = left_gain_setup(C):
  // R = W^1/2 (I - J G0) X = (I - H) W^1/2 X with H = W^1/2 J G0 W^-1/2 the orthogonal
  // projector onto the whitened model's range (G0 is J's weighted least-squares gain, its
  // pseudo-inverse where J loses rank), so R' W^1/2 (I - J G0) = R' (I - H) W^1/2 = R' W^1/2:
  // the reading's part the model explains need not be taken out. The whole set-up correction
  // of C G v costs q (n + values) multiply-adds a vector, beside C G0's sparse product.
  Eigen::MatrixXd setup_noise_map() const;

  // Variances of c.theta_hat: noise part, set-up part, and the set-up part split per column.
  struct Parts {
    double noise = 0, setup = 0;
    Eigen::VectorXd setup_by_column;
  };
  Parts parts(const Estimate::Function& c) const;
  template <typename D>
  Parts parts(const Eigen::MatrixBase<D>& c) const {
    return parts(Estimate::Function(c.sparseView()));
  }
  // The joint form of parts() for the functions C theta (C: p x m, one function per
  // column): the m x m covariances of their noise parts and of their set-up parts;
  // the diagonals are parts().noise and parts().setup of every column.
  struct JointParts {
    Eigen::MatrixXd noise, setup;
  };
  JointParts joint_parts(const Eigen::SparseMatrix<double>& C) const;

  const WlsSolver& base() const { return *base_; }

 private:
  const WlsSolver* base_;
  Eigen::VectorXd prior_std_;
  std::vector<std::pair<int, int>> column_of_;
  std::vector<EffectKind> column_kind_;
  Eigen::MatrixXd X_, R_, K_, S_inv_, RtR_;
  Estimate prior_;
};

// The errors at every station with the noise part, the set-up part and the total
// (std only; with no declared tolerance the set-up part is 0 and total = noise).
struct ErrorParts {
  std::vector<ErrorsAtAngle> noise, setup, total;
};
ErrorParts error_parts(const Parameterisation& param, const SetupSolver& solver);

// The effects' columns side by side (X, in the order of the effects) and what the base model
// makes of them: G0 X, the base estimate per um of each column, and R = W^1/2 (X - J G0 X), what
// it leaves of them, whitened. One product each with the base's factorisation, shared by the
// checks of the effects and the search for hidden ones (hidden_setup_effects, warnings.hpp).
struct EffectColumns {
  Eigen::MatrixXd X, G0X, R;
};
EffectColumns effect_columns(const WlsSolver& base, const std::vector<SetupEffect>& effects);

std::vector<SetupEffectCheck> check_setup_effects(const Parameterisation& param,
                                                  const SetupSolver& solver,
                                                  const std::vector<SetupEffect>& effects,
                                                  const DetectionSettings& settings,
                                                  double reference_length_mm);
// The same with the effects' columns formed (effect_columns(solver.base(), effects)) and the
// determined functions of the solver's a-priori estimate (determined_functions).
std::vector<SetupEffectCheck> check_setup_effects(const Parameterisation& param,
                                                  const SetupSolver& solver,
                                                  const std::vector<SetupEffect>& effects,
                                                  const EffectColumns& columns,
                                                  const DeterminedFunctions& functions,
                                                  const DetectionSettings& settings,
                                                  double reference_length_mm);

// Empty effects when the design's test has one time only.
DriftChecks check_drift_effects(const Design& design, const Parameterisation& param,
                                const LinearModel& model, const SetupSolver& solver,
                                const DeterminedFunctions& functions,
                                const DetectionSettings& settings, double reference_length_mm,
                                const TestClock& clock = {});

// Its bias bound (bias_bound_std and where) for the values of a budget of the estimate of `solver`.
void bound_first_order_bias(FirstOrderCheck& check, const SetupSolver& solver,
                            const Parameterisation& param, const Budget& budget);

}  // namespace dbbkit
