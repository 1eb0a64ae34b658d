#pragma once
// The weighted least-squares solver behind estimate_wls (estimate.hpp): the factorisation of a
// model's Jacobian and its gain, and the rank and unexplained part of extra columns. Internal to
// the library: not installed (docs/architecture.md, "Where things live").

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <memory>
#include <vector>

#include "dbbkit/estimate.hpp"
#include "dbbkit/linear_model.hpp"

namespace dbbkit {

// The gain G (p x n): theta_hat = G y. Sparse, one piece per independent block, plus a
// low-rank part U V (p x q times q x n) for a model solved with border columns; the
// products below never form G densely. The blocks factorised through their normal
// equations from a series model's factored rows (WlsSolver) keep their part of G implicit,
// G = Cov J' W with W = Sigma^-1: nothing p x n is formed unless sparse() asks for it.
class Gain {
 public:
  using Sparse = Eigen::SparseMatrix<double>;  // by columns
  Gain() = default;
  Gain(Sparse sparse, Eigen::MatrixXd U, Eigen::MatrixXd V);
  // The implicit part Cov J' diag(weight) beside the explicit one.
  Gain(Sparse sparse, Sparse covariance, std::shared_ptr<const Jacobian> J, Eigen::VectorXd weight,
       std::shared_ptr<const SeriesRows> series = nullptr);
  Gain(const Gain&) = default;
  Gain& operator=(const Gain&) = default;
  // A move takes the sparse matrices' storage (Eigen 3.4's SparseMatrix would copy).
  Gain(Gain&& other) noexcept { *this = std::move(other); }
  Gain& operator=(Gain&& other) noexcept;

  Eigen::Index rows() const { return sparse_.rows(); }
  Eigen::Index cols() const { return sparse_.cols(); }
  // G formed, as a sparse matrix (formed on the first call when G has an implicit part).
  const Sparse& sparse() const;
  const Eigen::MatrixXd& U() const { return U_; }
  const Eigen::MatrixXd& V() const { return V_; }
  bool low_rank() const { return U_.cols() > 0; }
  bool implicit() const { return J_ != nullptr; }
  // The multiply-adds of G v for one vector v: the sparse part's nonzeros, the implicit
  // part's covariance and two passes over J, the low-rank factors.
  double product_cost() const;

  // G M and G y.
  Eigen::MatrixXd operator*(const Eigen::MatrixXd& M) const;
  Eigen::VectorXd operator*(const Eigen::VectorXd& y) const;
  // C G for functions C (rows): sparse without a low-rank part, else with its dense rows.
  FunctionRows left(const FunctionRows& C) const;
  // M G for a dense M (rows x p).
  Eigen::MatrixXd left(const Eigen::MatrixXd& M) const;
  // Column i of G: the estimate's response to reading i (dense, p).
  Eigen::VectorXd col(Eigen::Index i) const;
  // J_i G e_i for row i of J (the leverage of reading i).
  double leverage(const Jacobian& J, Eigen::Index i) const;
  // |row r of C G|_1 for each function r, when G is wholly implicit with a series' factored
  // rows (series_l1()); nothing n x p or values x n is formed: with z = Cov c, the row's
  // entry at reading i is w_i sum_k g_i(k) phi(angle_i)' z_k. The errors' values at the
  // readings' angles (a budget's) share the products phi(a)' Cov_ke phi(b) of each pair of
  // angles, formed once for both (src/series_l1.cpp).
  bool series_l1() const { return series_ != nullptr && sparse_.nonZeros() == 0 && !low_rank(); }
  Eigen::VectorXd left_l1(const FunctionRows& C) const;
  // The series' factored rows of J, when the implicit part has them (null otherwise).
  const SeriesRows* series() const { return series_.get(); }

 private:
  Sparse sparse_;
  Eigen::MatrixXd U_, V_;
  Sparse cov_;  // the implicit part's covariance (theta units), zero elsewhere
  std::shared_ptr<const Jacobian> J_;
  Eigen::VectorXd weight_;                        // 1 / sigma^2 per reading
  std::shared_ptr<const SeriesRows> series_;      // the rows J_ factors into, when known
  mutable std::shared_ptr<const Sparse> formed_;  // sparse() of an implicit gain
};

// The factorisation of a design's Jacobian, done once and reused for any
// number of reading vectors (Monte Carlo, coverage studies, a-priori evaluation).
//
// The columns fall into independent blocks (linked through the rows they share); each
// block is factorised alone, so that a per-angle model, one block of six columns per
// station, costs time and memory linear in its readings: the Jacobian, the gain and the
// covariance are stored sparse, block by block. Border columns (EstimateOptions) that would
// join the stations' blocks into one are eliminated instead (Frisch-Waugh-Lovell): the
// blocks are factorised without them, and the border enters the gain and the covariance as
// a low-rank term (Gain, Estimate::covariance_K/S). Then the estimate of a determined
// function is that of the whole block; an undetermined combination involving a border
// column is minimum-norm in the blocks' unknowns only; the condition number is absent (the
// singular values are the blocks' and those of the border's unexplained part).
class WlsSolver {
 public:
  using Gain = dbbkit::Gain;

  WlsSolver(const Jacobian& J, const Eigen::VectorXd& sigma_um,
            const EstimateOptions& options = {});
  // A model with a series' factored rows (LinearModel::series): when every independent block
  // is full rank and takes the normal equations (EstimateOptions), the information is summed
  // from the rows' 6 x 6 blocks per angle times the basis' outer products, each block's
  // covariance comes from a Cholesky factorisation after its eigenvalues (the condition
  // bound), and the gain stays implicit. Otherwise, as from J alone.
  explicit WlsSolver(const LinearModel& model, const EstimateOptions& options = {});
  // A dense Jacobian (its exact zeros are the structure).
  WlsSolver(const Eigen::MatrixXd& J, const Eigen::VectorXd& sigma_um,
            const EstimateOptions& options = {});

  // Everything that does not depend on the readings (theta and residual empty).
  const Estimate& a_priori() const { return prior_; }
  // theta_hat = J_theta_reading() * y: the p x n map from readings to the minimum-norm estimate.
  const Gain& J_theta_reading() const { return gain_; }
  // The border columns (ascending; empty when the model is solved block by block alone).
  const std::vector<int>& border() const { return border_; }
  // h_i = J_i G e_i: the leverage of reading i.
  const Jacobian& J() const { return *J_; }
  const Eigen::VectorXd& sigma_um() const { return sigma_; }

  double leverage(Eigen::Index i) const;

  // One independent block: its columns and its rows, ascending (border columns in none).
  struct Block {
    std::vector<int> cols, rows;
  };
  const std::vector<Block>& blocks() const { return blocks_; }

  Estimate solve(const Eigen::VectorXd& y_um) const;

 private:
  void factorise(const EstimateOptions& options);
  bool factorise_series(const std::shared_ptr<const SeriesRows>& series,
                        const EstimateOptions& options);

  std::shared_ptr<const Jacobian> J_;
  Eigen::VectorXd sigma_;
  Estimate prior_;
  Gain gain_;
  std::vector<Block> blocks_;
  std::vector<int> border_;
};

// The rank that extra columns X (n x q, um per unit) add to the model of `solver`,
// without factorising [J X] (Frisch-Waugh-Lovell): with G the solver's gain, J G is
// the projector onto what J can reproduce, so the new directions are those of
//   R = Sigma^-1/2 (X - J G X),
// each column divided by |Sigma^-1/2 X_j| (a column the model reproduces exactly has
// |R_j| at rounding level). A singular value s of R counts when
//   s > sqrt(min_relative_singular_value),
// i.e. when more than 1e-4.5 of the column (in norm) is out of reach of J: the square
// root because R is a difference of two nearly equal vectors, whose rounding error is
// of the order of sqrt(eps)-relative for a J of condition number up to 1e8. The work
// is that of G X: linear in the readings for a per-angle model, where the factorised
// [J X] couples every station into one block.
int added_rank(const WlsSolver& solver, const Eigen::MatrixXd& X,
               const EstimateOptions& options = {});

// R = Sigma^-1/2 (M - J G M): the whitened part of readings M (n x m) that the model of
// `solver` cannot reproduce. `GM` = solver.J_theta_reading() * M when the caller has it already.
Eigen::MatrixXd unexplained(const WlsSolver& solver, const Eigen::MatrixXd& M);
Eigen::MatrixXd unexplained(const WlsSolver& solver, const Eigen::MatrixXd& M,
                            const Eigen::MatrixXd& GM);

// T with T'T = A'A and so the singular values of A: for A of more rows than columns the
// upper triangle of its Householder QR (cols x cols), otherwise A itself. The SVD of a tall,
// narrow A (a set-up effect's unexplained part: readings x at most 3) is that of T, without
// the QR that an SVD of A would form anyway and without U.
Eigen::MatrixXd triangular_factor(const Eigen::MatrixXd& A);

// added_rank from R = unexplained(solver, X) already formed (or its triangular_factor), with the
// whitened column norms |Sigma^-1/2 X_j| (the same rule).
int added_rank(const Eigen::MatrixXd& R, const Eigen::VectorXd& whitened_norms,
               const EstimateOptions& options = {});

// added_rank's matrix: triangular_factor(R) with column j divided by whitened_norms(j) (zeroed
// where that norm is zero), the columns of unit whitened norm whose singular values it counts.
Eigen::MatrixXd scaled_factor(const Eigen::MatrixXd& R, const Eigen::VectorXd& whitened_norms);

// How many of the singular values of a scaled_factor added_rank counts:
// those above sqrt(min_relative_singular_value).
int rank_above_threshold(const Eigen::VectorXd& singular_values,
                         const EstimateOptions& options = {});

}  // namespace dbbkit
