#include "dbbkit/estimate.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <Eigen/SVD>
#include <algorithm>
#include <array>
#include <atomic>
#include <boost/math/distributions/chi_squared.hpp>
#include <cmath>
#include <functional>
#include <limits>
#include <optional>
#include <stdexcept>
#include <utility>
#include <vector>

#include "block_form.hpp"
#include "cost_counters.hpp"
#include "series_l1.hpp"
#include "small_eigen.hpp"
#include "spd_inverse.hpp"
#include "wls_solver.hpp"

namespace dbbkit {

namespace {

// An entry of a null vector is structure when |entry| > kStructuralZero max|entry|; below,
// it is the rounding of a zero.
constexpr double kStructuralZero = 1e-9;

}  // namespace

const char* status_name(EstimateStatus status) {
  switch (status) {
    case EstimateStatus::kFullRank:
      return "full_rank";
    case EstimateStatus::kRankDeficient:
      return "rank_deficient";
    case EstimateStatus::kNoReadings:
      return "no_readings";
  }
  return "";
}

namespace {

// The connected components of the columns of A, linked through the rows they share
// (union-find over the nonzeros, either storage order): the component of each column,
// numbered in the order of each component's first column, and their count.
template <typename Sparse>
std::pair<std::vector<int>, int> column_components(const Sparse& A) {
  const int cols = static_cast<int>(A.cols());
  std::vector<int> parent(cols), owner(static_cast<std::size_t>(A.rows()), -1);
  for (int j = 0; j < cols; ++j) parent[j] = j;
  auto root = [&](int j) {
    while (parent[j] != j) j = parent[j] = parent[parent[j]];
    return j;
  };
  for (Eigen::Index outer = 0; outer < A.outerSize(); ++outer) {
    for (typename Sparse::InnerIterator it(A, outer); it; ++it) {
      const int j = static_cast<int>(it.col());
      int& first = owner[static_cast<std::size_t>(it.row())];
      if (first < 0) {
        first = j;
      } else {
        parent[root(j)] = root(first);
      }
    }
  }
  std::vector<int> component(cols, -1), number(cols, -1);
  int count = 0;
  for (int j = 0; j < cols; ++j) {
    int& c = number[root(j)];
    if (c < 0) c = count++;
    component[j] = c;
  }
  return {component, count};
}

// Js without the entries of the columns flagged.
Jacobian without_columns(const Jacobian& Js, const std::vector<char>& drop) {
  Jacobian out = Js;
  for (Eigen::Index i = 0; i < out.outerSize(); ++i) {
    for (Jacobian::InnerIterator it(out, i); it; ++it) {
      if (drop[static_cast<std::size_t>(it.col())]) it.valueRef() = 0.0;
    }
  }
  out.prune(0.0);
  return out;
}

// The border columns of Js (EstimateOptions), ascending, and Js without them; none (and no
// matrix) when the blocks are to be factorised whole.
struct Border {
  std::vector<int> columns;
  Jacobian rest;
};
Border border_columns(const Jacobian& Js, const EstimateOptions& o) {
  const int p = static_cast<int>(Js.cols());
  if (o.border_min_columns <= 0 || p <= o.border_min_columns) return {};
  const auto [component, count] = column_components(Js);
  std::vector<std::vector<int>> members(static_cast<std::size_t>(count));
  for (int j = 0; j < p; ++j) members[static_cast<std::size_t>(component[j])].push_back(j);
  std::vector<int> nonzeros(static_cast<std::size_t>(p), 0);
  for (Eigen::Index i = 0; i < Js.outerSize(); ++i) {
    for (Jacobian::InnerIterator it(Js, i); it; ++it)
      ++nonzeros[static_cast<std::size_t>(it.col())];
  }
  std::vector<int> border;
  for (const std::vector<int>& cols : members) {
    if (static_cast<int>(cols.size()) <= o.border_min_columns) continue;
    std::vector<int> counts;
    counts.reserve(cols.size());
    for (int j : cols) counts.push_back(nonzeros[static_cast<std::size_t>(j)]);
    std::nth_element(counts.begin(),
                     counts.begin() + static_cast<std::ptrdiff_t>(counts.size() / 2), counts.end());
    const double median = counts[counts.size() / 2];
    const double threshold =
        std::max(static_cast<double>(o.border_min_nonzeros), o.border_nonzeros_factor * median);
    for (int j : cols) {
      if (nonzeros[static_cast<std::size_t>(j)] > threshold) border.push_back(j);
    }
  }
  if (border.empty() || static_cast<int>(border.size()) > o.border_max_columns) return {};
  std::vector<char> drop(static_cast<std::size_t>(p), 0);
  for (int j : border) drop[static_cast<std::size_t>(j)] = 1;
  Jacobian rest = without_columns(Js, drop);
  const auto [component_of, rest_count] = column_components(rest);
  std::vector<int> size(static_cast<std::size_t>(rest_count), 0);
  for (int j = 0; j < p; ++j) {
    if (!drop[static_cast<std::size_t>(j)]) ++size[static_cast<std::size_t>(component_of[j])];
  }
  if (*std::max_element(size.begin(), size.end()) > o.border_min_columns / 2) return {};
  std::sort(border.begin(), border.end());
  return {std::move(border), std::move(rest)};
}

}  // namespace

// The sparse arguments' storage swapped in (a SparseMatrix's move would copy).
Gain::Gain(Sparse sparse, Eigen::MatrixXd U, Eigen::MatrixXd V)
    : U_(std::move(U)), V_(std::move(V)) {
  sparse_.swap(sparse);
}

Gain::Gain(Sparse sparse, Sparse covariance, std::shared_ptr<const Jacobian> J,
           Eigen::VectorXd weight, std::shared_ptr<const SeriesRows> series)
    : J_(std::move(J)), weight_(std::move(weight)), series_(std::move(series)) {
  sparse_.swap(sparse);
  cov_.swap(covariance);
}

Gain& Gain::operator=(Gain&& other) noexcept {
  sparse_.swap(other.sparse_);
  U_ = std::move(other.U_);
  V_ = std::move(other.V_);
  cov_.swap(other.cov_);
  J_ = std::move(other.J_);
  weight_ = std::move(other.weight_);
  series_ = std::move(other.series_);
  formed_ = std::move(other.formed_);
  return *this;
}

const Gain::Sparse& Gain::sparse() const {
  if (!implicit()) return sparse_;
  std::shared_ptr<const Sparse> formed = std::atomic_load(&formed_);
  if (!formed) {
    // Cov J' W: the blocks' covariance times their rows (two threads may both form it; one
    // copy is kept).
    const Eigen::MatrixXd CJ = Eigen::MatrixXd(cov_) * (J_->transpose() * weight_.asDiagonal());
    auto g = std::make_shared<Sparse>(sparse_ + Sparse(CJ.sparseView(1.0, 0.0)));
    std::atomic_store(&formed_, std::shared_ptr<const Sparse>(g));
    formed = std::atomic_load(&formed_);
  }
  return *formed;
}

Eigen::MatrixXd Gain::operator*(const Eigen::MatrixXd& M) const {
  cost::detail::counters().gain_columns += M.cols();
  // The sparse part column by column of M, passing over M's zeros (a set-up effect's columns
  // are zero outside its installation's readings); the order of the sums is the product's.
  Eigen::MatrixXd out = Eigen::MatrixXd::Zero(sparse_.rows(), M.cols());
  for (Eigen::Index j = 0; j < M.cols(); ++j) {
    for (Eigen::Index r = 0; r < M.rows(); ++r) {
      const double m = M(r, j);
      if (m == 0.0) continue;
      for (Sparse::InnerIterator it(sparse_, r); it; ++it) out(it.row(), j) += it.value() * m;
    }
  }
  if (series_) {
    out.noalias() += cov_ * detail::series_transpose_times(*series_, weight_.asDiagonal() * M);
  } else if (implicit()) {
    out.noalias() += cov_ * (J_->transpose() * (weight_.asDiagonal() * M));
  }
  if (low_rank()) out.noalias() += U_ * (V_ * M);
  return out;
}

double Gain::product_cost() const {
  double cost = static_cast<double>(sparse_.nonZeros()) + static_cast<double>(U_.size()) +
                static_cast<double>(V_.size());
  if (implicit()) cost += static_cast<double>(cov_.nonZeros()) + 2.0 * J_->nonZeros();
  return cost;
}

Eigen::VectorXd Gain::operator*(const Eigen::VectorXd& y) const {
  ++cost::detail::counters().gain_columns;
  Eigen::VectorXd out = sparse_ * y;
  if (implicit()) out.noalias() += cov_ * (J_->transpose() * weight_.cwiseProduct(y));
  if (low_rank()) out.noalias() += U_ * (V_ * y);
  return out;
}

FunctionRows Gain::left(const FunctionRows& C) const {
  cost::detail::counters().gain_columns += C.rows();
  FunctionRows out = C * sparse_;
  if (implicit()) {
    const FunctionRows CC = C * cov_;
    const Jacobian JW = weight_.asDiagonal() * (*J_);
    out = out + FunctionRows(CC * JW.transpose());
  }
  if (low_rank()) {
    const Eigen::MatrixXd dense = (C * U_) * V_;
    out = out + FunctionRows(dense.sparseView(1.0, 0.0));
  }
  return out;
}

Eigen::MatrixXd Gain::left(const Eigen::MatrixXd& M) const {
  cost::detail::counters().gain_columns += M.rows();
  Eigen::MatrixXd out = M * sparse_;
  if (implicit()) out.noalias() += ((M * cov_) * J_->transpose()) * weight_.asDiagonal();
  if (low_rank()) out.noalias() += (M * U_) * V_;
  return out;
}

Eigen::VectorXd Gain::col(Eigen::Index i) const {
  Eigen::VectorXd out = sparse_.col(i);
  if (implicit()) out.noalias() += cov_ * (weight_(i) * Eigen::VectorXd(J_->row(i).transpose()));
  if (low_rank()) out.noalias() += U_ * V_.col(i);
  return out;
}

double Gain::leverage(const Jacobian& J, Eigen::Index i) const {
  double h = 0;
  for (Jacobian::InnerIterator x(J, i); x; ++x) {
    double g = sparse_.coeff(x.col(), i);
    if (low_rank()) g += U_.row(x.col()).dot(V_.col(i));
    h += x.value() * g;
  }
  if (implicit()) {  // w_i J_i Cov J_i'
    const Eigen::VectorXd row = J_->row(i).transpose();
    h += weight_(i) * row.dot(cov_ * row);
  }
  return h;
}

double WlsSolver::leverage(Eigen::Index i) const { return gain_.leverage(*J_, i); }

WlsSolver::WlsSolver(const Eigen::MatrixXd& J, const Eigen::VectorXd& sigma_um,
                     const EstimateOptions& options)
    : WlsSolver(Jacobian(J.sparseView()), sigma_um, options) {}

namespace {

std::shared_ptr<const Jacobian> compressed(const Jacobian& J) {
  auto c = std::make_shared<Jacobian>(J);
  c->makeCompressed();
  return c;
}

// The covariance (theta units) from its dense blocks, one per independent block of the model
// (zero where the block has no rank): the sparse matrix, and each unknown's block and place.
void set_covariance(Estimate& est, const std::vector<WlsSolver::Block>& blocks,
                    std::vector<Eigen::MatrixXd> dense, int p) {
  est.covariance_block_of.assign(static_cast<std::size_t>(p), -1);
  est.covariance_local.assign(static_cast<std::size_t>(p), -1);
  Eigen::Index nonzeros = 0;
  for (std::size_t b = 0; b < blocks.size(); ++b) {
    const std::vector<int>& cols = blocks[b].cols;
    for (std::size_t x = 0; x < cols.size(); ++x) {
      est.covariance_block_of[static_cast<std::size_t>(cols[x])] = static_cast<int>(b);
      est.covariance_local[static_cast<std::size_t>(cols[x])] = static_cast<int>(x);
    }
    nonzeros += (dense[b].array() != 0.0).count();
  }
  // Column by column, rows ascending (a block's columns are ascending): no sort.
  est.covariance.resize(p, p);
  est.covariance.reserve(nonzeros);
  for (int j = 0; j < p; ++j) {
    est.covariance.startVec(j);
    const int b = est.covariance_block_of[static_cast<std::size_t>(j)];
    if (b < 0) continue;
    const std::vector<int>& cols = blocks[static_cast<std::size_t>(b)].cols;
    const Eigen::Index y = est.covariance_local[static_cast<std::size_t>(j)];
    for (std::size_t x = 0; x < cols.size(); ++x) {
      const double v = dense[static_cast<std::size_t>(b)](static_cast<Eigen::Index>(x), y);
      if (v != 0.0) est.covariance.insertBack(cols[x], j) = v;
    }
  }
  est.covariance.finalize();
  est.covariance_blocks = std::move(dense);
}

}  // namespace

WlsSolver::WlsSolver(const Jacobian& J, const Eigen::VectorXd& sigma_um,
                     const EstimateOptions& options)
    : J_(compressed(J)), sigma_(sigma_um) {
  ++cost::detail::counters().factorisations;
  factorise(options);
}

WlsSolver::WlsSolver(const LinearModel& model, const EstimateOptions& options)
    : J_(compressed(model.J)), sigma_(model.sigma_um) {
  ++cost::detail::counters().factorisations;
  if (model.series && factorise_series(model.series, options)) return;
  factorise(options);
}

void WlsSolver::factorise(const EstimateOptions& options) {
  const Jacobian& J = *J_;
  const Eigen::VectorXd& sigma_um = sigma_;
  Estimate& est = prior_;
  const int n = static_cast<int>(J.rows());
  const int p = static_cast<int>(J.cols());
  est.n_readings = n;
  est.n_unknowns = p;
  est.estimable_tolerance = options.estimable_tolerance;
  est.covariance.resize(p, p);
  est.null_space_scaled.resize(p, 0);
  gain_ = Gain(Gain::Sparse(p, n), Eigen::MatrixXd(), Eigen::MatrixXd());
  if (n == 0) {
    est.status = EstimateStatus::kNoReadings;
    return;
  }

  const Eigen::VectorXd w = sigma_um.cwiseInverse();
  Jacobian Js = w.asDiagonal() * J;
  est.column_scale = Eigen::VectorXd::Zero(p);
  for (int i = 0; i < n; ++i) {
    for (Jacobian::InnerIterator it(Js, i); it; ++it)
      est.column_scale(it.col()) += it.value() * it.value();
  }
  est.column_scale = est.column_scale.cwiseSqrt();
  // A column with |c_j| <= negligible_column * max_k |c_k| is rounding (e.g. a
  // lever arm times cos(90 deg) = 6e-17): scaling it to unit norm would turn
  // noise into information, so it is set to zero and the unknown is not seen.
  const double max_column = p > 0 ? est.column_scale.maxCoeff() : 0.0;
  std::vector<char> negligible(p, 0);
  for (int j = 0; j < p; ++j) {
    if (est.column_scale(j) <= options.negligible_column * max_column ||
        est.column_scale(j) == 0.0) {
      est.column_scale(j) = 1.0;
      negligible[j] = 1;
    }
  }
  const Eigen::VectorXd unscale = est.column_scale.cwiseInverse();
  for (int i = 0; i < n; ++i) {
    for (Jacobian::InnerIterator it(Js, i); it; ++it) {
      it.valueRef() = negligible[it.col()] ? 0.0 : it.value() * unscale(it.col());
    }
  }
  Js.prune(0.0);

  // Independent blocks: columns linked through the rows they share (union-find).
  // A per-angle model splits into one small block per station; each block is
  // factorised alone and the pieces are assembled, with the rank tolerance taken
  // against the largest singular value of the whole matrix.
  // Border columns (EstimateOptions) are set aside: the blocks are those of the rest (Jb).
  Border border = border_columns(Js, options);
  border_ = std::move(border.columns);
  std::vector<char> is_border(static_cast<std::size_t>(p), 0);
  for (int j : border_) is_border[static_cast<std::size_t>(j)] = 1;
  const Jacobian& Jblocks = border_.empty() ? Js : border.rest;
  const auto [component_of_col, n_components] = column_components(Jblocks);
  std::vector<int> block_of_col(static_cast<std::size_t>(p), -1),
      number(static_cast<std::size_t>(n_components), -1);
  int n_blocks = 0;
  for (int j = 0; j < p; ++j) {
    if (is_border[static_cast<std::size_t>(j)]) continue;
    int& b = number[static_cast<std::size_t>(component_of_col[j])];
    if (b < 0) b = n_blocks++;
    block_of_col[static_cast<std::size_t>(j)] = b;
  }
  blocks_.assign(n_blocks, Block{});
  std::vector<int> local(p, -1);  // position of column j within its block
  for (int j = 0; j < p; ++j) {
    if (is_border[static_cast<std::size_t>(j)]) continue;
    std::vector<int>& c = blocks_[block_of_col[j]].cols;
    local[j] = static_cast<int>(c.size());
    c.push_back(j);
  }
  for (int i = 0; i < n; ++i) {
    const Jacobian::InnerIterator first(Jblocks, i);  // a row with no entry belongs to no block
    if (first) blocks_[block_of_col[first.col()]].rows.push_back(i);
  }

  // JacobiSVD, not BDCSVD: Eigen 3.4.0's divide-and-conquer SVD fails (an index
  // assertion in debug builds, NaNs in release builds) on some rank-deficient
  // matrices such as the B head augmented with centring columns.
  // A block through its normal equations (EstimateOptions::normal_equations_tolerance):
  // V and s from the eigen-decomposition of sub' sub, no U (the gain comes from the
  // covariance); `sub` kept for it.
  struct BlockSvd {
    Eigen::MatrixXd U, V;
    Eigen::VectorXd s;
    bool normal = false;
    Eigen::MatrixXd sub;
  };
  auto block_matrix = [&](int b) {
    const Block& blk = blocks_[b];
    Eigen::MatrixXd sub = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(blk.rows.size()),
                                                static_cast<Eigen::Index>(blk.cols.size()));
    for (std::size_t r = 0; r < blk.rows.size(); ++r) {
      for (Jacobian::InnerIterator it(Jblocks, blk.rows[r]); it; ++it)
        sub(static_cast<Eigen::Index>(r), local[it.col()]) = it.value();
    }
    return sub;
  };
  auto block_svd = [](const Eigen::MatrixXd& sub) {
    Eigen::JacobiSVD<Eigen::MatrixXd> svd(sub, Eigen::ComputeThinU | Eigen::ComputeFullV);
    return BlockSvd{svd.matrixU(), svd.matrixV(), svd.singularValues(), false, {}};
  };
  // The normal equations when the condition bound holds (`sub` then moves into the
  // result); nullopt otherwise, `sub` untouched.
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig;  // its storage kept from block to block
  detail::SmallSymmetricEigen small_eig;
  Eigen::MatrixXd gram;
  Eigen::VectorXd lambda;
  auto block_normal = [&](Eigen::MatrixXd& sub) -> std::optional<BlockSvd> {
    const Eigen::Index c = sub.cols();
    if (!(options.normal_equations_tolerance > 0) ||
        (c < options.normal_equations_min_columns &&
         c > options.normal_equations_max_small_columns) ||
        sub.rows() < c) {
      return std::nullopt;
    }
    BlockSvd d;
    if (c == 1) {  // one column: its norm, no decomposition
      const double norm2 = sub.col(0).squaredNorm();
      if (!(norm2 > 0)) return std::nullopt;
      d.s = Eigen::VectorXd::Constant(1, std::sqrt(norm2));
      d.V = Eigen::MatrixXd::Identity(1, 1);
    } else {
      gram.setZero(c, c);  // its storage kept from block to block
      gram.selfadjointView<Eigen::Lower>().rankUpdate(sub.transpose());
      // A station's block (at most kSmallEigenMax columns) in fixed storage; a series' block,
      // or a small one whose steps did not converge, by Eigen's solver.
      const bool small = c <= detail::kSmallEigenMax && small_eig.compute(gram, true);
      if (small) {
        lambda.resize(c);
        for (Eigen::Index k = 0; k < c; ++k) lambda(k) = small_eig.eigenvalue(static_cast<int>(k));
      } else {
        gram = gram.selfadjointView<Eigen::Lower>();
        eig.compute(gram);
        if (eig.info() != Eigen::Success) return std::nullopt;
        lambda = eig.eigenvalues();
      }
      // lambda ascending
      const double kappa2 = lambda(c - 1) / lambda(0);
      const double bound =
          kappa2 * static_cast<double>(sub.rows()) * std::numeric_limits<double>::epsilon();
      if (!(lambda(0) > 0) || !(bound <= options.normal_equations_tolerance)) return std::nullopt;
      d.s = lambda.reverse().cwiseSqrt();
      if (small) {
        d.V.resize(c, c);
        for (Eigen::Index k = 0; k < c; ++k) {
          for (Eigen::Index i = 0; i < c; ++i)
            d.V(i, k) = small_eig.vector(static_cast<int>(i), static_cast<int>(c - 1 - k));
        }
      } else {
        d.V = eig.eigenvectors().rowwise().reverse();
      }
    }
    d.normal = true;
    d.sub = std::move(sub);
    return d;
  };
  std::vector<BlockSvd> svds(n_blocks);
  double s_max = 0;
  for (int b = 0; b < n_blocks; ++b) {
    Eigen::MatrixXd sub = block_matrix(b);
    if (sub.rows() == 0) {
      svds[b].V = Eigen::MatrixXd::Identity(sub.cols(), sub.cols());
      svds[b].U = Eigen::MatrixXd(0, 0);
      svds[b].s = Eigen::VectorXd(0);
      continue;
    }
    std::optional<BlockSvd> normal = block_normal(sub);
    svds[b] = normal ? std::move(*normal) : block_svd(sub);
    if (svds[b].s.size() > 0) s_max = std::max(s_max, svds[b].s(0));
  }
  // The normal equations resolve no singular value near the rank tolerance: a block with
  // one below it (against the largest of the whole matrix) is factorised by SVD after all.
  for (int b = 0; b < n_blocks; ++b) {
    if (svds[b].normal && !(svds[b].s.minCoeff() > options.min_relative_singular_value * s_max)) {
      svds[b] = block_svd(svds[b].sub);
    }
    est.normal_equation_blocks += svds[b].normal;
  }

  std::vector<Eigen::Triplet<double>> null_entries;
  std::vector<Eigen::MatrixXd> block_gain(static_cast<std::size_t>(n_blocks));  // its cols x rows
  std::vector<Eigen::MatrixXd> covariance_blocks(static_cast<std::size_t>(n_blocks));
  for (int b = 0; b < n_blocks; ++b) {
    const Eigen::Index c = static_cast<Eigen::Index>(blocks_[b].cols.size());
    covariance_blocks[static_cast<std::size_t>(b)] = Eigen::MatrixXd::Zero(c, c);
  }
  std::vector<double> all_s;
  all_s.reserve(static_cast<std::size_t>(p));
  int rank = 0, n_null = 0;
  double s_min_kept = 0;
  Eigen::MatrixXd c, g;  // a block's covariance and gain, scaled; storage kept from block to block
  Eigen::VectorXd inv_s, u;
  for (int b = 0; b < n_blocks; ++b) {
    const BlockSvd& d = svds[b];
    const Block& blk = blocks_[b];
    int r = 0;
    while (r < d.s.size() && d.s(r) > options.min_relative_singular_value * s_max) ++r;
    for (int k = 0; k < d.s.size(); ++k) all_s.push_back(d.s(k));
    if (r > 0) s_min_kept = s_min_kept == 0 ? d.s(r - 1) : std::min(s_min_kept, d.s(r - 1));
    rank += r;
    if (r > 0) {
      const auto Vr = d.V.leftCols(r);
      inv_s = d.s.head(r).cwiseInverse();
      c.noalias() = Vr * inv_s.cwiseAbs2().asDiagonal() * Vr.transpose();
      if (d.normal) {  // scaled, whitened
        g.noalias() = c * d.sub.transpose();
      } else {
        g.noalias() = Vr * inv_s.asDiagonal() * d.U.leftCols(r).transpose();
      }
      u.resize(static_cast<Eigen::Index>(blk.cols.size()));
      for (std::size_t a = 0; a < blk.cols.size(); ++a)
        u(static_cast<Eigen::Index>(a)) = unscale(blk.cols[a]);
      covariance_blocks[static_cast<std::size_t>(b)] = u.asDiagonal() * c * u.asDiagonal();
      Eigen::MatrixXd& gb = block_gain[static_cast<std::size_t>(b)];  // original units
      gb.resize(g.rows(), g.cols());
      for (Eigen::Index rr = 0; rr < g.cols(); ++rr) {
        for (Eigen::Index a = 0; a < g.rows(); ++a)
          gb(a, rr) = unscale(blk.cols[static_cast<std::size_t>(a)]) * g(a, rr) *
                      w(blk.rows[static_cast<std::size_t>(rr)]);
      }
    }
    for (int k = r; k < d.V.cols(); ++k, ++n_null) {
      for (std::size_t a = 0; a < blk.cols.size(); ++a) {
        const double v = d.V(static_cast<Eigen::Index>(a), k);
        if (v != 0.0) null_entries.emplace_back(blk.cols[a], n_null, v);
      }
    }
  }
  // The gain column by column (a reading's column holds its block's rows, ascending): no sort.
  std::vector<int> block_of_row(static_cast<std::size_t>(n), -1),
      place_in_block(static_cast<std::size_t>(n));
  Eigen::Index gain_nonzeros = 0;
  for (int b = 0; b < n_blocks; ++b) {
    const std::vector<int>& rows = blocks_[b].rows;
    if (block_gain[static_cast<std::size_t>(b)].size() == 0) continue;
    for (std::size_t rr = 0; rr < rows.size(); ++rr) {
      block_of_row[static_cast<std::size_t>(rows[rr])] = b;
      place_in_block[static_cast<std::size_t>(rows[rr])] = static_cast<int>(rr);
    }
    gain_nonzeros += (block_gain[static_cast<std::size_t>(b)].array() != 0.0).count();
  }
  Gain::Sparse G0(p, n);
  G0.reserve(gain_nonzeros);
  for (int i = 0; i < n; ++i) {
    G0.startVec(i);
    const int b = block_of_row[static_cast<std::size_t>(i)];
    if (b < 0) continue;
    const Eigen::MatrixXd& gb = block_gain[static_cast<std::size_t>(b)];
    const std::vector<int>& cols = blocks_[b].cols;
    const Eigen::Index rr = place_in_block[static_cast<std::size_t>(i)];
    for (std::size_t a = 0; a < cols.size(); ++a) {
      const double v = gb(static_cast<Eigen::Index>(a), rr);
      if (v != 0.0) G0.insertBack(cols[a], i) = v;
    }
  }
  G0.finalize();
  set_covariance(est, blocks_, std::move(covariance_blocks), p);
  if (border_.empty()) {
    gain_ = Gain(std::move(G0), Eigen::MatrixXd(), Eigen::MatrixXd());
  } else {
    // The border X (n x q, original units) through what the blocks cannot reproduce:
    //   K = G0 X,  R = W^1/2 (X - J0 K),  S = R'R,
    //   beta = S^+ R' W^1/2 y,  theta0 = G0 (y - X beta),
    // so G = G0 + U V with U = [-K; I] (the border's rows), V = S^+ R' W^1/2, and the
    // covariance is that of the blocks plus U S^+ U'. S^+ from the eigen-decomposition of
    // D S D, D = diag(1 / |W^1/2 X_j|), on the eigenvalues above min_relative_singular_value.
    const int q = static_cast<int>(border_.size());
    std::vector<int> position(static_cast<std::size_t>(p), -1);
    for (int k = 0; k < q; ++k) position[static_cast<std::size_t>(border_[k])] = k;
    Eigen::MatrixXd X = Eigen::MatrixXd::Zero(n, q);
    for (int i = 0; i < n; ++i) {
      for (Jacobian::InnerIterator it(J, i); it; ++it) {
        const int k = position[static_cast<std::size_t>(it.col())];
        if (k >= 0) X(i, k) = it.value();
      }
    }
    const Eigen::MatrixXd K = G0 * X;  // zero in the border's rows
    const Eigen::MatrixXd R = w.asDiagonal() * (X - J * K);
    Eigen::VectorXd d(q);
    for (int k = 0; k < q; ++k) d(k) = 1.0 / est.column_scale(border_[k]);
    const Eigen::MatrixXd Sn = d.asDiagonal() * (R.transpose() * R) * d.asDiagonal();
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(Sn);
    const Eigen::VectorXd& lambda = eig.eigenvalues();  // ascending
    Eigen::MatrixXd S_plus = Eigen::MatrixXd::Zero(q, q);
    std::vector<Eigen::VectorXd> border_null;
    for (int k = 0; k < q; ++k) {
      const Eigen::VectorXd z = eig.eigenvectors().col(k);
      all_s.push_back(std::sqrt(std::max(0.0, lambda(k))));
      if (lambda(k) > options.min_relative_singular_value) {
        S_plus.noalias() += (d.asDiagonal() * z) * (d.asDiagonal() * z).transpose() / lambda(k);
        ++rank;
        continue;
      }
      // theta0 = -K v, beta = v with v = D z, in the scaled unknowns; orthogonal to the
      // blocks' null space (K's columns lie in the row space of the blocks).
      const Eigen::VectorXd v = d.asDiagonal() * z;
      Eigen::VectorXd u = -(K * v);
      for (int k2 = 0; k2 < q; ++k2) u(border_[k2]) = v(k2);
      u = est.column_scale.cwiseProduct(u);
      for (const Eigen::VectorXd& b : border_null) u -= b.dot(u) * b;
      if (!(u.norm() > 0)) continue;
      border_null.push_back(u / u.norm());
    }
    for (const Eigen::VectorXd& b : border_null) {
      for (int j = 0; j < p; ++j) {
        if (b(j) != 0.0) null_entries.emplace_back(j, n_null, b(j));
      }
      ++n_null;
    }
    Eigen::MatrixXd U = -K;
    for (int k = 0; k < q; ++k) U(border_[k], k) = 1.0;
    Eigen::MatrixXd V = S_plus * R.transpose() * w.asDiagonal();
    est.covariance_K = U;
    est.covariance_S = S_plus;
    gain_ = Gain(std::move(G0), std::move(U), std::move(V));
  }
  est.null_space_scaled.resize(p, n_null);
  est.null_space_scaled.setFromTriplets(null_entries.begin(), null_entries.end());
  std::sort(all_s.begin(), all_s.end(), std::greater<double>());
  est.singular_values =
      Eigen::Map<Eigen::VectorXd>(all_s.data(), static_cast<Eigen::Index>(all_s.size()));
  est.rank = rank;
  if (rank > 0 && border_.empty()) est.condition_number = s_max / s_min_kept;
  est.dof = n - rank;

  if (rank == p) {
    est.status = EstimateStatus::kFullRank;
  } else {
    est.status = EstimateStatus::kRankDeficient;
  }
}

bool WlsSolver::factorise_series(const std::shared_ptr<const SeriesRows>& series_rows,
                                 const EstimateOptions& options) {
  const SeriesRows& series = *series_rows;
  const Jacobian& J = *J_;
  const int n = static_cast<int>(J.rows());
  const int p = static_cast<int>(J.cols());
  const int m = series.per_error;
  const Eigen::Index na = series.basis.rows();
  if (n == 0 || m <= 0 || p != 6 * m || series.g.rows() != n || series.basis.cols() != m ||
      static_cast<int>(series.angle.size()) != n || !(options.normal_equations_tolerance > 0) ||
      (options.border_min_columns > 0 && p > options.border_min_columns)) {
    return false;
  }
  // The information J' W J summed per angle: A(a) = sum over its readings of w g g' (6 x 6),
  // and block (k, l) of J' W J is Phi' diag(A_kl) Phi (Phi: angles x m).
  const Eigen::VectorXd weight = sigma_.cwiseAbs2().cwiseInverse();
  std::vector<Eigen::Matrix<double, 6, 6>> A(static_cast<std::size_t>(na),
                                             Eigen::Matrix<double, 6, 6>::Zero());
  for (int i = 0; i < n; ++i) {
    const Eigen::Matrix<double, 1, 6> g = series.g.row(i);
    A[static_cast<std::size_t>(series.angle[i])].noalias() += weight(i) * g.transpose() * g;
  }
  const Eigen::MatrixXd& Phi = series.basis;
  Eigen::MatrixXd M(p, p);
  // With the basis' parity (series_l1.hpp) each block, symmetric, is its even-even, odd-odd
  // and even-odd parts, and an angle a and its reflection a' (phi(a') = phi(a) with the odd
  // functions negated) add up as one angle weighted A(a) + A(a') in the first two and
  // A(a) - A(a') in the third: the products over the pairs, not the angles.
  const detail::Reflection reflection = detail::reflection_pairs(series);
  if (!reflection.odd.empty()) {
    const std::vector<int>&even = reflection.even, &odd = reflection.odd;
    const Eigen::Index np = static_cast<Eigen::Index>(reflection.pairs.size());
    const Eigen::Index me = static_cast<Eigen::Index>(even.size()),
                       mo = static_cast<Eigen::Index>(odd.size());
    Eigen::MatrixXd PE(np, me), PO(np, mo), EE, OO, EO;
    for (Eigen::Index q = 0; q < np; ++q) {
      const Eigen::Index a = reflection.pairs[static_cast<std::size_t>(q)].first;
      for (Eigen::Index i = 0; i < me; ++i) PE(q, i) = Phi(a, even[static_cast<std::size_t>(i)]);
      for (Eigen::Index i = 0; i < mo; ++i) PO(q, i) = Phi(a, odd[static_cast<std::size_t>(i)]);
    }
    Eigen::VectorXd plus(np), minus(np);
    for (int k = 0; k < 6; ++k) {
      for (int l = k; l < 6; ++l) {
        for (Eigen::Index q = 0; q < np; ++q) {
          const auto [a, b] = reflection.pairs[static_cast<std::size_t>(q)];
          const double da = A[static_cast<std::size_t>(a)](k, l),
                       db = b >= 0 ? A[static_cast<std::size_t>(b)](k, l) : 0.0;
          plus(q) = da + db;
          minus(q) = da - db;
        }
        EE.noalias() = PE.transpose() * (plus.asDiagonal() * PE);
        OO.noalias() = PO.transpose() * (plus.asDiagonal() * PO);
        EO.noalias() = PE.transpose() * (minus.asDiagonal() * PO);
        auto block = M.block(k * m, l * m, m, m);
        for (Eigen::Index j = 0; j < me; ++j) {
          const int fj = even[static_cast<std::size_t>(j)];
          for (Eigen::Index i = 0; i < me; ++i)
            block(even[static_cast<std::size_t>(i)], fj) = EE(i, j);
          for (Eigen::Index i = 0; i < mo; ++i) {
            block(odd[static_cast<std::size_t>(i)], fj) = EO(j, i);
            block(fj, odd[static_cast<std::size_t>(i)]) = EO(j, i);
          }
        }
        for (Eigen::Index j = 0; j < mo; ++j) {
          for (Eigen::Index i = 0; i < mo; ++i)
            block(odd[static_cast<std::size_t>(i)], odd[static_cast<std::size_t>(j)]) = OO(i, j);
        }
        if (l != k) M.block(l * m, k * m, m, m) = block.transpose();
      }
    }
  } else {
    Eigen::VectorXd d(na);
    for (int k = 0; k < 6; ++k) {
      for (int l = k; l < 6; ++l) {
        for (Eigen::Index a = 0; a < na; ++a) d(a) = A[static_cast<std::size_t>(a)](k, l);
        M.block(k * m, l * m, m, m).noalias() = Phi.transpose() * (d.asDiagonal() * Phi);
        if (l != k) M.block(l * m, k * m, m, m) = M.block(k * m, l * m, m, m).transpose();
      }
    }
  }
  // Column scaling: |column j of W^1/2 J| = sqrt(M_jj); a negligible column goes the general way.
  Estimate est;
  est.n_readings = n;
  est.n_unknowns = p;
  est.estimable_tolerance = options.estimable_tolerance;
  est.column_scale = M.diagonal().cwiseMax(0.0).cwiseSqrt();
  const double max_column = est.column_scale.maxCoeff();
  for (int j = 0; j < p; ++j) {
    if (!(est.column_scale(j) > options.negligible_column * max_column)) return false;
  }
  const Eigen::VectorXd unscale = est.column_scale.cwiseInverse();
  // Independent blocks, as the general path finds them from J's rows: at one angle the
  // errors its readings share form groups, and each group times the basis functions not
  // zero there is linked; the groups of all angles joined (union-find over the columns).
  std::vector<int> parent(static_cast<std::size_t>(p));
  for (int j = 0; j < p; ++j) parent[static_cast<std::size_t>(j)] = j;
  auto root = [&](int j) {
    while (parent[static_cast<std::size_t>(j)] != j)
      j = parent[static_cast<std::size_t>(j)] =
          parent[static_cast<std::size_t>(parent[static_cast<std::size_t>(j)])];
    return j;
  };
  {
    std::vector<std::array<int, 6>> error_group(static_cast<std::size_t>(na));
    std::vector<std::array<char, 6>> seen(static_cast<std::size_t>(na));
    for (Eigen::Index a = 0; a < na; ++a) {
      for (int k = 0; k < 6; ++k) error_group[static_cast<std::size_t>(a)][k] = k;
      seen[static_cast<std::size_t>(a)].fill(0);
    }
    auto group_root = [](std::array<int, 6>& g, int k) {
      while (g[k] != k) k = g[k];
      return k;
    };
    for (int i = 0; i < n; ++i) {
      std::array<int, 6>& g = error_group[static_cast<std::size_t>(series.angle[i])];
      std::array<char, 6>& sn = seen[static_cast<std::size_t>(series.angle[i])];
      int first = -1;
      for (int k = 0; k < 6; ++k) {
        if (series.g(i, k) == 0.0) continue;
        sn[k] = 1;
        if (first < 0) {
          first = k;
        } else {
          g[group_root(g, k)] = group_root(g, first);
        }
      }
    }
    for (Eigen::Index a = 0; a < na; ++a) {
      std::array<int, 6>& g = error_group[static_cast<std::size_t>(a)];
      const std::array<char, 6>& sn = seen[static_cast<std::size_t>(a)];
      int first_basis = -1;
      for (int b = 0; b < m; ++b) {
        if (Phi(a, b) != 0.0) {
          first_basis = b;
          break;
        }
      }
      if (first_basis < 0) continue;
      for (int k = 0; k < 6; ++k) {
        if (!sn[k]) continue;
        const int anchor = root(group_root(g, k) * m + first_basis);
        for (int b = 0; b < m; ++b) {
          if (Phi(a, b) != 0.0) parent[static_cast<std::size_t>(root(k * m + b))] = anchor;
        }
      }
    }
  }
  std::vector<int> block_of_col(static_cast<std::size_t>(p), -1),
      number(static_cast<std::size_t>(p), -1);
  std::vector<Block> blocks;
  std::vector<int> local(static_cast<std::size_t>(p), -1);
  for (int j = 0; j < p; ++j) {
    int& b = number[static_cast<std::size_t>(root(j))];
    if (b < 0) {
      b = static_cast<int>(blocks.size());
      blocks.emplace_back();
    }
    block_of_col[static_cast<std::size_t>(j)] = b;
    local[static_cast<std::size_t>(j)] =
        static_cast<int>(blocks[static_cast<std::size_t>(b)].cols.size());
    blocks[static_cast<std::size_t>(b)].cols.push_back(j);
  }
  for (int i = 0; i < n; ++i) {
    const Jacobian::InnerIterator first(J, i);
    if (first)
      blocks[static_cast<std::size_t>(block_of_col[static_cast<std::size_t>(first.col())])]
          .rows.push_back(i);
  }
  // Each block through its normal equations: its eigenvalues for the condition bound and the
  // rank, then the inverse from a Cholesky factorisation. A block that is small, short,
  // rank deficient or too ill-conditioned for the bound goes the general way (SVD, null space).
  std::vector<Eigen::MatrixXd> inverse(blocks.size());
  std::vector<double> all_s;
  all_s.reserve(static_cast<std::size_t>(p));
  double s_max = 0, s_min = std::numeric_limits<double>::infinity();
  for (std::size_t b = 0; b < blocks.size(); ++b) {
    const Block& blk = blocks[b];
    const Eigen::Index c = static_cast<Eigen::Index>(blk.cols.size());
    if (c < options.normal_equations_min_columns ||
        static_cast<Eigen::Index>(blk.rows.size()) < c) {
      return false;
    }
    Eigen::MatrixXd sub(c, c);
    for (Eigen::Index x = 0; x < c; ++x) {
      for (Eigen::Index y = 0; y < c; ++y) {
        const int jx = blk.cols[static_cast<std::size_t>(x)],
                  jy = blk.cols[static_cast<std::size_t>(y)];
        sub(x, y) = unscale(jx) * M(jx, jy) * unscale(jy);
      }
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(sub, Eigen::EigenvaluesOnly);
    if (eig.info() != Eigen::Success) return false;
    const Eigen::VectorXd& lambda = eig.eigenvalues();  // ascending
    const double bound = lambda(c - 1) / lambda(0) * static_cast<double>(blk.rows.size()) *
                         std::numeric_limits<double>::epsilon();
    if (!(lambda(0) > 0) || !(bound <= options.normal_equations_tolerance)) return false;
    const Eigen::LLT<Eigen::MatrixXd> llt(sub);
    if (llt.info() != Eigen::Success) return false;
    inverse[b] = detail::inverse_from_cholesky(llt.matrixLLT());  // symmetric as formed
    for (Eigen::Index k = 0; k < c; ++k) all_s.push_back(std::sqrt(lambda(k)));
    s_max = std::max(s_max, std::sqrt(lambda(c - 1)));
    s_min = std::min(s_min, std::sqrt(lambda(0)));
  }
  if (!(s_min > options.min_relative_singular_value * s_max)) return false;  // rank deficient

  for (std::size_t b = 0; b < blocks.size(); ++b)
    inverse[b] =
        unscale(blocks[b].cols).asDiagonal() * inverse[b] * unscale(blocks[b].cols).asDiagonal();
  set_covariance(est, blocks, std::move(inverse), p);
  est.null_space_scaled.resize(p, 0);
  std::sort(all_s.begin(), all_s.end(), std::greater<double>());
  est.singular_values =
      Eigen::Map<Eigen::VectorXd>(all_s.data(), static_cast<Eigen::Index>(all_s.size()));
  est.rank = p;
  est.condition_number = s_max / s_min;
  est.dof = n - p;
  est.status = EstimateStatus::kFullRank;
  est.normal_equation_blocks = static_cast<int>(blocks.size());
  gain_ = Gain(Gain::Sparse(p, n), est.covariance, J_, weight, series_rows);
  blocks_ = std::move(blocks);
  border_.clear();
  prior_ = std::move(est);
  return true;
}

Estimate WlsSolver::solve(const Eigen::VectorXd& y_um) const {
  ++cost::detail::counters().solves;
  Estimate est = prior_;
  if (est.status == EstimateStatus::kNoReadings) return est;
  const int n = est.n_readings;
  est.theta = gain_ * y_um;
  est.residual_um = y_um - *J_ * est.theta;
  est.rms_um = std::sqrt(est.residual_um.squaredNorm() / n);
  est.chi2 = est.residual_um.cwiseQuotient(sigma_).squaredNorm();
  if (est.dof > 0) est.p_value = chi2_upper_tail(est.dof, est.chi2);
  return est;
}

Estimate estimate_wls(const LinearModel& model, const EstimateOptions& options) {
  return WlsSolver(model.J, model.sigma_um, options).solve(model.y_um);
}

Eigen::MatrixXd unexplained(const WlsSolver& solver, const Eigen::MatrixXd& M,
                            const Eigen::MatrixXd& GM) {
  cost::detail::counters().unexplained_columns += M.cols();
  const Jacobian& J = solver.J();
  const Eigen::VectorXd& sigma = solver.sigma_um();
  if (const SeriesRows* s = solver.J_theta_reading().series()) {
    // J GM through the rows' factors (a series' J has few rows' worth of distinct values).
    return sigma.cwiseInverse().asDiagonal() * (M - detail::series_times(*s, GM));
  }
  // W^1/2 (M - J GM) in one pass, row by row (J's few nonzeros in a row reach into each of
  // GM's columns), without the product's and the difference's temporaries.
  Eigen::MatrixXd R(M.rows(), M.cols());
  for (Eigen::Index i = 0; i < J.rows(); ++i) {
    const double w = 1.0 / sigma(i);
    for (Eigen::Index t = 0; t < M.cols(); ++t) {
      const double* g = GM.col(t).data();
      double jg = 0;
      for (Jacobian::InnerIterator it(J, i); it; ++it) jg += it.value() * g[it.col()];
      R(i, t) = w * (M(i, t) - jg);
    }
  }
  return R;
}

Eigen::MatrixXd unexplained(const WlsSolver& solver, const Eigen::MatrixXd& M) {
  return unexplained(solver, M, solver.J_theta_reading() * M);
}

double chi2_upper_tail(int dof, double chi2) {
  if (!(chi2 > 0)) return 1.0;
  try {
    return boost::math::cdf(boost::math::complement(boost::math::chi_squared(dof), chi2));
  } catch (const std::overflow_error&) {
    return chi2 < dof ? 1.0 : 0.0;  // only next to zero (far in the lower tail) does Boost overflow
  }
}

double chi2_lower_tail(int dof, double chi2) {
  if (!(chi2 > 0)) return 0.0;
  try {
    return boost::math::cdf(boost::math::chi_squared(dof), chi2);
  } catch (const std::overflow_error&) {
    return chi2 < dof ? 0.0 : 1.0;
  }
}

double bic(double n, double chi2, int parameters) {
  return n * std::log(std::max(chi2, 1e-300) / n) + parameters * std::log(n);
}

Eigen::MatrixXd triangular_factor(const Eigen::MatrixXd& A) {
  const Eigen::Index q = A.cols();
  if (A.rows() <= q) return A;
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(A);
  return qr.matrixQR().topRows(q).triangularView<Eigen::Upper>();
}

int added_rank(const WlsSolver& solver, const Eigen::MatrixXd& X, const EstimateOptions& options) {
  if (X.cols() == 0 || X.rows() == 0) return 0;
  const Eigen::VectorXd norms =
      (solver.sigma_um().cwiseInverse().asDiagonal() * X).colwise().norm().transpose();
  return added_rank(unexplained(solver, X), norms, options);
}

Eigen::MatrixXd scaled_factor(const Eigen::MatrixXd& R, const Eigen::VectorXd& whitened_norms) {
  // Scaling the columns commutes with the triangular factor: R D = Q (T D).
  Eigen::MatrixXd T = triangular_factor(R);
  for (Eigen::Index j = 0; j < T.cols(); ++j) {
    if (whitened_norms(j) > 0) {
      T.col(j) /= whitened_norms(j);
    } else {
      T.col(j).setZero();
    }
  }
  return T;
}

int rank_above_threshold(const Eigen::VectorXd& singular_values, const EstimateOptions& options) {
  const double tol = std::sqrt(options.min_relative_singular_value);
  int r = 0;
  for (Eigen::Index k = 0; k < singular_values.size(); ++k) r += singular_values(k) > tol;
  return r;
}

int added_rank(const Eigen::MatrixXd& unexplained_part, const Eigen::VectorXd& norms,
               const EstimateOptions& options) {
  if (unexplained_part.cols() == 0 || unexplained_part.rows() == 0) return 0;
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(scaled_factor(unexplained_part, norms));
  return rank_above_threshold(svd.singularValues(), options);
}

bool Estimate::determined(const Function& c) const {
  if (status == EstimateStatus::kNoReadings) return false;
  if (null_space_scaled.cols() == 0) return true;  // full rank: every function
  double norm2 = 0;
  for (Function::InnerIterator it(c); it; ++it)
    norm2 += std::pow(it.value() / column_scale(it.index()), 2);
  if (norm2 == 0.0) return true;  // the zero function is known exactly
  // N'w on the null vectors the support touches (each lies in one block).
  std::vector<std::pair<Eigen::Index, double>> terms;
  for (Function::InnerIterator ct(c); ct; ++ct) {
    const double wj = ct.value() / column_scale(ct.index());
    for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator it(null_space_scaled,
                                                                        ct.index());
         it; ++it) {
      terms.emplace_back(it.col(), wj * it.value());
    }
  }
  std::sort(terms.begin(), terms.end(),
            [](const auto& a, const auto& b) { return a.first < b.first; });
  double proj2 = 0;
  for (std::size_t t = 0; t < terms.size();) {
    double v = 0;
    const Eigen::Index k = terms[t].first;
    for (; t < terms.size() && terms[t].first == k; ++t) v += terms[t].second;
    proj2 += v * v;
  }
  return std::sqrt(proj2) <= estimable_tolerance * std::sqrt(norm2);
}

double Estimate::covariance_at(Eigen::Index a, Eigen::Index b) const {
  if (covariance_block_of.empty()) return covariance.coeff(a, b);
  const int ba = covariance_block_of[static_cast<std::size_t>(a)];
  if (ba < 0 || ba != covariance_block_of[static_cast<std::size_t>(b)]) return 0.0;
  return covariance_blocks[static_cast<std::size_t>(ba)](
      covariance_local[static_cast<std::size_t>(a)], covariance_local[static_cast<std::size_t>(b)]);
}

double Estimate::base_variance(const Function& c) const {
  if (!covariance_block_of.empty()) {
    // On the support's blocks: var = sum over a of c_a (sum over b of B(a, b) c_b), a and b
    // entries of one block, each sum in c's order. The inner sums of all a are formed together,
    // a column of B at a time (contiguous reads of the column-major block); each is the same
    // sum in the same order as one formed alone (detail::block_form, which takes a support
    // in one block).
    const std::size_t nz = static_cast<std::size_t>(c.nonZeros());
    const int* index = c.innerIndexPtr();
    const int block = nz > 0 ? covariance_block_of[static_cast<std::size_t>(index[0])] : -1;
    bool one_block = block >= 0;
    std::vector<int> places(nz);
    std::vector<double> work;
    for (std::size_t k = 0; k < nz && one_block; ++k) {
      const auto j = static_cast<std::size_t>(index[k]);
      one_block = covariance_block_of[j] == block;
      places[k] = covariance_local[j];
    }
    if (one_block) {
      return detail::block_form(covariance_blocks[static_cast<std::size_t>(block)], c.valuePtr(),
                                places.data(), nz, c.valuePtr(), places.data(), nz, work);
    }
    struct Entry {
      int block;
      Eigen::Index local;
      double value;
    };
    std::vector<Entry> e;
    e.reserve(static_cast<std::size_t>(c.nonZeros()));
    for (Function::InnerIterator a(c); a; ++a) {
      e.push_back({covariance_block_of[static_cast<std::size_t>(a.index())],
                   covariance_local[static_cast<std::size_t>(a.index())], a.value()});
    }
    std::vector<double> row(e.size(), 0.0);
    for (const Entry& b : e) {
      if (b.block < 0) continue;
      const double* col = covariance_blocks[static_cast<std::size_t>(b.block)].col(b.local).data();
      for (std::size_t a = 0; a < e.size(); ++a) {
        if (e[a].block == b.block) row[a] += col[e[a].local] * b.value;
      }
    }
    double var = 0;
    for (std::size_t a = 0; a < e.size(); ++a) {
      if (e[a].block >= 0) var += e[a].value * row[a];
    }
    return var;
  }
  double var = 0;
  for (Function::InnerIterator a(c); a; ++a) {
    for (Function::InnerIterator b(c); b; ++b)
      var += a.value() * covariance.coeff(a.index(), b.index()) * b.value();
  }
  return var;
}

Eigen::VectorXd Estimate::low_rank_coordinates(const Function& c) const {
  Eigen::VectorXd kc = Eigen::VectorXd::Zero(covariance_K.cols());
  if (covariance_K.cols() == 0) return kc;
  for (Function::InnerIterator a(c); a; ++a)
    kc += a.value() * covariance_K.row(a.index()).transpose();
  return kc;
}

Determined Estimate::evaluate(const Function& c) const {
  Determined d;
  if (!determined(c)) return d;
  ++cost::detail::counters().variances;
  d.determined = true;
  if (theta.size() > 0) {
    for (Function::InnerIterator a(c); a; ++a) d.value += a.value() * theta(a.index());
  }
  double var = base_variance(c);
  if (covariance_K.cols() > 0) {
    const Eigen::VectorXd kc = low_rank_coordinates(c);
    var += kc.dot(covariance_S * kc);
  }
  d.std = std::sqrt(std::max(0.0, var));
  return d;
}

Eigen::MatrixXd Estimate::null_directions() const {
  // Row-reduce N' (in theta units) with partial pivoting; the reduced echelon
  // form of a subspace is unique, so directions confined to one station come
  // out confined to it. The null vectors fall into groups that share no unknown (one
  // group per block of the model); the reduced form of the whole is that of each group,
  // its rows ordered by their pivots, so each group is reduced alone on its support.
  const int k = static_cast<int>(null_space_scaled.cols());
  const int p = static_cast<int>(null_space_scaled.rows());
  if (k == 0) return Eigen::MatrixXd(p, 0);
  const Eigen::SparseMatrix<double> N =
      column_scale.cwiseInverse().asDiagonal() * null_space_scaled;
  const double scale = N.coeffs().size() > 0 ? N.coeffs().cwiseAbs().maxCoeff() : 0.0;
  const double tiny = kStructuralZero * scale;
  // Groups of null vectors linked through the unknowns they share.
  const auto [group_of, n_groups] = column_components(N);
  std::vector<std::vector<int>> groups(static_cast<std::size_t>(n_groups));
  for (int i = 0; i < k; ++i) groups[static_cast<std::size_t>(group_of[i])].push_back(i);
  std::vector<std::pair<int, Eigen::VectorXd>>
      reduced;  // (pivot, direction), sorted by pivot at the end
  reduced.reserve(static_cast<std::size_t>(k));
  for (const std::vector<int>& members : groups) {
    std::vector<int> support;
    for (int i : members) {
      for (Eigen::SparseMatrix<double>::InnerIterator it(N, i); it; ++it)
        support.push_back(static_cast<int>(it.row()));
    }
    std::sort(support.begin(), support.end());
    support.erase(std::unique(support.begin(), support.end()), support.end());
    const int rows = static_cast<int>(members.size()), cols = static_cast<int>(support.size());
    Eigen::MatrixXd R = Eigen::MatrixXd::Zero(rows, cols);
    for (int r = 0; r < rows; ++r) {
      for (Eigen::SparseMatrix<double>::InnerIterator it(N, members[r]); it; ++it) {
        const int c = static_cast<int>(
            std::lower_bound(support.begin(), support.end(), static_cast<int>(it.row())) -
            support.begin());
        R(r, c) = it.value();
      }
    }
    std::vector<int> pivot_of_row(rows, -1);
    int row = 0;
    for (int col = 0; col < cols && row < rows; ++col) {
      Eigen::Index piv;
      const double best = R.col(col).segment(row, rows - row).cwiseAbs().maxCoeff(&piv);
      if (best <= tiny) continue;
      R.row(row).swap(R.row(row + static_cast<int>(piv)));
      const double pivot = R(row, col);  // a copy: R(row, col) changes while the row is divided
      R.row(row) /= pivot;
      for (int i = 0; i < rows; ++i) {
        const double factor = R(i, col);
        if (i != row && factor != 0.0) R.row(i) -= factor * R.row(row);
      }
      pivot_of_row[row] = support[col];
      ++row;
    }
    for (int i = 0; i < rows; ++i) {
      Eigen::VectorXd v = Eigen::VectorXd::Zero(p);
      for (int c = 0; c < cols; ++c) {
        if (std::abs(R(i, c)) > tiny) v(support[c]) = R(i, c);
      }
      v.normalize();
      Eigen::Index big;
      v.cwiseAbs().maxCoeff(&big);
      if (v(big) < 0) v = -v;
      reduced.emplace_back(pivot_of_row[i] < 0 ? p : pivot_of_row[i], std::move(v));
    }
  }
  std::stable_sort(reduced.begin(), reduced.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  Eigen::MatrixXd out(p, k);
  for (int i = 0; i < k; ++i) out.col(i) = reduced[static_cast<std::size_t>(i)].second;
  return out;
}

}  // namespace dbbkit
