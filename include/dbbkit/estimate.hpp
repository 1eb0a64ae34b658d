#pragma once
// Weighted least squares on the stacked model y = J theta + v (model.md §7):
//   theta_hat = (J' W J)^+ J' W y,  Cov(theta_hat) = (J' W J)^+,  W = Sigma^-1,
// solved by SVD of the column-equilibrated whitened Jacobian
//   Js = Sigma^-1/2 J S,  S = diag(1 / |column j of Sigma^-1/2 J|),
// never by inverting J'J. Rank loss is a status: only linear functions of theta
// that the data determine get a value and a standard uncertainty.

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "dbbkit/linear_model.hpp"

namespace dbbkit {

struct EstimateOptions {
  // Singular value i of Js counts toward the rank when
  //   sigma_i > min_relative_singular_value * sigma_max.
  double min_relative_singular_value = 1e-9;
  // A function c.theta is determined when, with w = S^-1 c its coefficients on
  // the scaled unknowns and N an orthonormal basis of the null space of Js,
  //   |N' w| <= estimable_tolerance * |w|.
  double estimable_tolerance = 1e-7;
  // Column j of Sigma^-1/2 J is treated as zero when
  //   |column j| <= negligible_column * max_k |column k|.
  double negligible_column = 1e-12;
  // An independent block of at least normal_equations_min_columns columns and as many rows
  // (a series model) is factorised through its normal equations: the eigen-decomposition of
  // Js_b' Js_b instead of an SVD of the tall block, and the gain from the covariance
  // (G = (Js_b' Js_b)^-1 Js_b', no U). Taken only when the block's condition number kappa
  // (from those eigenvalues) satisfies
  //   kappa^2 * rows * epsilon <= normal_equations_tolerance,
  // a bound on the relative error the squaring adds to the covariance, and when every
  // singular value counts toward the rank; otherwise (and with a tolerance of 0) the SVD.
  // A block of at most normal_equations_max_small_columns columns (a station of a per-angle
  // model: six) takes the same path under the same bound: its SVD costs more than the rest of
  // its factorisation.
  double normal_equations_tolerance = 1e-6;
  int normal_equations_min_columns = 32;
  int normal_equations_max_small_columns = 6;
  // Border columns. In an independent block of more than border_min_columns columns, a
  // column with more than border_nonzeros_factor times the block's median count of nonzeros
  // (and more than border_min_nonzeros) is a border column: an effect of the whole test or
  // of one installation, seen at every station, that would join every station's small block
  // into one. When at most border_max_columns such columns leave only blocks of at most
  // border_min_columns / 2 columns, the model is solved bordered (WlsSolver): the small
  // blocks alone, and the border through the part of it they cannot reproduce,
  //   R = Sigma^-1/2 (X - J0 G0 X),
  // whose column-normalised Gram matrix counts an eigenvalue toward the rank when
  //   sqrt(lambda) > sqrt(min_relative_singular_value)
  // (the rule of added_rank). Otherwise the block is factorised whole.
  int border_min_columns = 512;
  double border_nonzeros_factor = 16;
  int border_min_nonzeros = 64;
  int border_max_columns = 512;
};

enum class EstimateStatus { kFullRank, kRankDeficient, kNoReadings };

const char* status_name(EstimateStatus status);

// A linear function of theta: its value and standard uncertainty when the data
// determine it; otherwise `determined` is false and both are absent.
struct Determined {
  bool determined = false;
  double value = 0.0;
  double std = 0.0;
};

struct Estimate {
  EstimateStatus status = EstimateStatus::kNoReadings;
  int n_readings = 0;
  int n_unknowns = 0;
  int rank = 0;

  Eigen::VectorXd theta;  // minimum-norm solution (in the scaled unknowns)
  // Pseudo-inverse covariance, meaningful only for determined functions: block-diagonal
  // over the independent blocks of the model (one 6 x 6 block per station of a per-angle
  // model), stored sparse.
  Eigen::SparseMatrix<double> covariance;
  // The same covariance as dense blocks, one per independent block of the model (in its
  // columns' order), with each unknown's block (-1: none) and place in it: what a function's
  // variance reads (base_variance, covariance_at), without searching the sparse matrix.
  std::vector<Eigen::MatrixXd> covariance_blocks;
  std::vector<int> covariance_block_of, covariance_local;
  // A low-rank term of the covariance, K S K' (p x q, q x q; empty when absent): the
  // set-up effects a prior makes part of the model (setup.hpp). The covariance of a
  // function is c'(covariance + K S K')c.
  Eigen::MatrixXd covariance_K, covariance_S;
  Eigen::VectorXd column_scale;            // |column j of Sigma^-1/2 J|, 1 for a negligible column
  Eigen::VectorXd singular_values;         // of Js, descending
  std::optional<double> condition_number;  // sigma_max / sigma_rank of Js
  // Orthonormal basis of the null space of Js (p x (p - rank)); each column lies in one
  // independent block. Stored by rows, so that a function's projection reads only the rows
  // of its support.
  Eigen::SparseMatrix<double, Eigen::RowMajor> null_space_scaled;

  Eigen::VectorXd residual_um;    // y - J theta
  double rms_um = 0.0;            // sqrt(mean(residual^2))
  double chi2 = 0.0;              // sum (residual / sigma)^2
  int dof = 0;                    // n_readings - rank
  std::optional<double> p_value;  // P(chi2_dof >= chi2); absent when dof = 0

  double estimable_tolerance = 0.0;
  // Blocks factorised through the normal equations (EstimateOptions).
  int normal_equation_blocks = 0;

  // A linear function c.theta (c in theta units), sparse: values at one angle touch few
  // unknowns. A dense c is taken through its nonzeros.
  using Function = Eigen::SparseVector<double>;
  // The function c.theta.
  Determined evaluate(const Function& c) const;
  template <typename D>
  Determined evaluate(const Eigen::MatrixBase<D>& c) const {
    return evaluate(Function(c.sparseView()));
  }
  // The two terms of its variance, on the support of c: c' covariance c, and K'c (empty
  // without the low-rank term).
  double base_variance(const Function& c) const;
  // Entry (a, b) of `covariance`.
  double covariance_at(Eigen::Index a, Eigen::Index b) const;
  Eigen::VectorXd low_rank_coordinates(const Function& c) const;
  bool determined(const Function& c) const;
  template <typename D>
  bool determined(const Eigen::MatrixBase<D>& c) const {
    return determined(Function(c.sparseView()));
  }
  // A basis of the undetermined directions of theta (columns, theta units), as
  // sparse as row reduction makes it, each normalised to unit length with its
  // largest coefficient positive: theta and theta + t * column give the same readings.
  Eigen::MatrixXd null_directions() const;
};

// Linear functions of theta, one a row (values x unknowns), stored sparse: a budget's values,
// the rows of a left gain.
using FunctionRows = Eigen::SparseMatrix<double, Eigen::RowMajor>;

// The factorisation of a model's Jacobian, reused for any number of reading vectors: internal
// to the library (src/wls_solver.hpp), named here for the functions that take one.
class WlsSolver;

Estimate estimate_wls(const LinearModel& model, const EstimateOptions& options = {});

// The tails of the chi-squared distribution with dof degrees of freedom at chi2:
// P(X >= chi2) and P(X <= chi2). A residual of exactly (or next to) zero on many degrees of
// freedom (readings a model reproduces exactly) is 1 and 0, where the incomplete gamma
// function would overflow.
double chi2_upper_tail(int dof, double chi2);
double chi2_lower_tail(int dof, double chi2);

// Bayesian information criterion of a least-squares fit of n readings with `parameters`
// determined: n ln(chi2 / n) + parameters ln n (chi2 floored at 1e-300).
double bic(double n, double chi2, int parameters);

}  // namespace dbbkit
