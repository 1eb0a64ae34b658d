#include "dbbkit/estimate.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <boost/math/distributions/chi_squared.hpp>
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <optional>
#include <vector>

namespace dbbkit {

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

WlsSolver::WlsSolver(const Eigen::MatrixXd& J, const Eigen::VectorXd& sigma_um, const EstimateOptions& options)
    : J_(J), sigma_(sigma_um) {
  Estimate& est = prior_;
  const int n = static_cast<int>(J.rows());
  const int p = static_cast<int>(J.cols());
  est.n_readings = n;
  est.n_unknowns = p;
  est.estimable_tolerance = options.estimable_tolerance;
  if (n == 0) {
    est.status = EstimateStatus::kNoReadings;
    est.message = "no readings: nothing can be estimated";
    gain_ = Eigen::MatrixXd::Zero(p, 0);
    return;
  }

  const Eigen::VectorXd w = sigma_um.cwiseInverse();
  Eigen::MatrixXd Js = w.asDiagonal() * J;
  est.column_scale = Js.colwise().norm().transpose();
  // A column with |c_j| <= negligible_column * max_k |c_k| is rounding (e.g. a
  // lever arm times cos(90 deg) = 6e-17): scaling it to unit norm would turn
  // noise into information, so it is set to zero and the unknown is not seen.
  const double max_column = p > 0 ? est.column_scale.maxCoeff() : 0.0;
  for (int j = 0; j < p; ++j) {
    if (est.column_scale(j) <= options.negligible_column * max_column || est.column_scale(j) == 0.0) {
      est.column_scale(j) = 1.0;
      Js.col(j).setZero();
    }
  }
  Js = Js * est.column_scale.cwiseInverse().asDiagonal();

  // Independent blocks: columns linked through the rows they share (union-find).
  // A per-angle model splits into one small block per station; each block is
  // factorised alone and the pieces are assembled, with the rank tolerance taken
  // against the largest singular value of the whole matrix.
  std::vector<int> parent(p);
  for (int j = 0; j < p; ++j) parent[j] = j;
  auto root = [&](int j) {
    while (parent[j] != j) j = parent[j] = parent[parent[j]];
    return j;
  };
  std::vector<int> row_block(n, -1);
  for (int i = 0; i < n; ++i) {
    int first = -1;
    for (int j = 0; j < p; ++j) {
      if (Js(i, j) == 0.0) continue;
      if (first < 0) {
        first = j;
      } else {
        parent[root(j)] = root(first);
      }
    }
    row_block[i] = first;
  }
  std::vector<int> block_of_col(p, -1), block_ids;
  for (int j = 0; j < p; ++j) {
    const int r = root(j);
    if (block_of_col[r] < 0) {
      block_of_col[r] = static_cast<int>(block_ids.size());
      block_ids.push_back(r);
    }
    block_of_col[j] = block_of_col[r];
  }
  const int n_blocks = static_cast<int>(block_ids.size());
  std::vector<std::vector<int>> cols(n_blocks), rows(n_blocks);
  for (int j = 0; j < p; ++j) cols[block_of_col[j]].push_back(j);
  for (int i = 0; i < n; ++i) {
    if (row_block[i] >= 0) rows[block_of_col[row_block[i]]].push_back(i);
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
    Eigen::MatrixXd sub(rows[b].size(), cols[b].size());
    for (std::size_t r = 0; r < rows[b].size(); ++r) {
      for (std::size_t c = 0; c < cols[b].size(); ++c) sub(r, c) = Js(rows[b][r], cols[b][c]);
    }
    return sub;
  };
  auto block_svd = [](const Eigen::MatrixXd& sub) {
    Eigen::JacobiSVD<Eigen::MatrixXd> svd(sub, Eigen::ComputeThinU | Eigen::ComputeFullV);
    return BlockSvd{svd.matrixU(), svd.matrixV(), svd.singularValues(), false, {}};
  };
  // The normal equations when the condition bound holds (`sub` then moves into the
  // result); nullopt otherwise, `sub` untouched.
  auto block_normal = [&](Eigen::MatrixXd& sub) -> std::optional<BlockSvd> {
    const Eigen::Index c = sub.cols();
    if (!(options.normal_equations_tolerance > 0) || c < options.normal_equations_min_columns || sub.rows() < c) {
      return std::nullopt;
    }
    Eigen::MatrixXd gram = Eigen::MatrixXd::Zero(c, c);
    gram.selfadjointView<Eigen::Lower>().rankUpdate(sub.transpose());
    gram = gram.selfadjointView<Eigen::Lower>();
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(gram);
    if (eig.info() != Eigen::Success) return std::nullopt;
    const Eigen::VectorXd& lambda = eig.eigenvalues();  // ascending
    const double kappa2 = lambda(c - 1) / lambda(0);
    const double bound = kappa2 * static_cast<double>(sub.rows()) * std::numeric_limits<double>::epsilon();
    if (!(lambda(0) > 0) || !(bound <= options.normal_equations_tolerance)) return std::nullopt;
    BlockSvd d;
    d.s = lambda.reverse().cwiseSqrt();
    d.V = eig.eigenvectors().rowwise().reverse();
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

  const Eigen::VectorXd unscale = est.column_scale.cwiseInverse();
  gain_ = Eigen::MatrixXd::Zero(p, n);
  Eigen::MatrixXd cov_scaled = Eigen::MatrixXd::Zero(p, p);
  std::vector<Eigen::VectorXd> null_vectors;
  std::vector<double> all_s;
  int rank = 0;
  double s_min_kept = 0;
  for (int b = 0; b < n_blocks; ++b) {
    const BlockSvd& d = svds[b];
    int r = 0;
    while (r < d.s.size() && d.s(r) > options.min_relative_singular_value * s_max) ++r;
    for (int k = 0; k < d.s.size(); ++k) all_s.push_back(d.s(k));
    if (r > 0) s_min_kept = s_min_kept == 0 ? d.s(r - 1) : std::min(s_min_kept, d.s(r - 1));
    rank += r;
    const Eigen::MatrixXd Vr = d.V.leftCols(r);
    const Eigen::VectorXd inv_s = d.s.head(r).cwiseInverse();
    const Eigen::MatrixXd c = Vr * inv_s.cwiseAbs2().asDiagonal() * Vr.transpose();
    const Eigen::MatrixXd g = d.normal ? Eigen::MatrixXd(c * d.sub.transpose())  // scaled, whitened
                                       : Eigen::MatrixXd(Vr * inv_s.asDiagonal() * d.U.leftCols(r).transpose());
    for (std::size_t a = 0; a < cols[b].size(); ++a) {
      const int ja = cols[b][a];
      for (std::size_t rr = 0; rr < rows[b].size(); ++rr) {
        gain_(ja, rows[b][rr]) = unscale(ja) * g(a, rr) * w(rows[b][rr]);
      }
      for (std::size_t c2 = 0; c2 < cols[b].size(); ++c2) cov_scaled(ja, cols[b][c2]) = c(a, c2);
    }
    for (int k = r; k < d.V.cols(); ++k) {
      Eigen::VectorXd v = Eigen::VectorXd::Zero(p);
      for (std::size_t a = 0; a < cols[b].size(); ++a) v(cols[b][a]) = d.V(a, k);
      null_vectors.push_back(v);
    }
  }
  std::sort(all_s.begin(), all_s.end(), std::greater<double>());
  est.singular_values = Eigen::Map<Eigen::VectorXd>(all_s.data(), static_cast<Eigen::Index>(all_s.size()));
  est.rank = rank;
  if (rank > 0) est.condition_number = s_max / s_min_kept;
  est.covariance = unscale.asDiagonal() * cov_scaled * unscale.asDiagonal();
  est.null_space_scaled.resize(p, static_cast<Eigen::Index>(null_vectors.size()));
  for (std::size_t k = 0; k < null_vectors.size(); ++k) est.null_space_scaled.col(static_cast<Eigen::Index>(k)) = null_vectors[k];
  est.dof = n - rank;

  if (rank == p) {
    est.status = EstimateStatus::kFullRank;
    est.message = "full rank: " + std::to_string(p) + " unknowns from " + std::to_string(n) + " readings";
  } else {
    est.status = EstimateStatus::kRankDeficient;
    est.message = "rank " + std::to_string(rank) + " of " + std::to_string(p) + ": " +
                  std::to_string(p - rank) + " combination(s) of the unknowns are not determined by the data";
  }
}

Estimate WlsSolver::solve(const Eigen::VectorXd& y_um) const {
  Estimate est = prior_;
  if (est.status == EstimateStatus::kNoReadings) return est;
  const int n = est.n_readings;
  est.theta = gain_ * y_um;
  est.residual_um = y_um - J_ * est.theta;
  est.rms_um = std::sqrt(est.residual_um.squaredNorm() / n);
  est.chi2 = est.residual_um.cwiseQuotient(sigma_).squaredNorm();
  if (est.dof > 0) {
    boost::math::chi_squared dist(est.dof);
    est.p_value = boost::math::cdf(boost::math::complement(dist, est.chi2));
  }
  return est;
}

Estimate estimate_wls(const LinearModel& model, const EstimateOptions& options) {
  return WlsSolver(model.J, model.sigma_um, options).solve(model.y_um);
}

Eigen::MatrixXd unexplained(const WlsSolver& solver, const Eigen::MatrixXd& M, const Eigen::MatrixXd& GM) {
  return solver.sigma_um().cwiseInverse().asDiagonal() * (M - solver.J() * GM);
}

Eigen::MatrixXd unexplained(const WlsSolver& solver, const Eigen::MatrixXd& M) {
  return unexplained(solver, M, solver.gain() * M);
}

double bic(double n, double chi2, int parameters) {
  return n * std::log(std::max(chi2, 1e-300) / n) + parameters * std::log(n);
}

int added_rank(const WlsSolver& solver, const Eigen::MatrixXd& X, const EstimateOptions& options) {
  if (X.cols() == 0 || X.rows() == 0) return 0;
  const Eigen::VectorXd norms = (solver.sigma_um().cwiseInverse().asDiagonal() * X).colwise().norm().transpose();
  return added_rank(unexplained(solver, X), norms, options);
}

int added_rank(const Eigen::MatrixXd& unexplained_part, const Eigen::VectorXd& norms, const EstimateOptions& options) {
  const int q = static_cast<int>(unexplained_part.cols());
  if (q == 0 || unexplained_part.rows() == 0) return 0;
  Eigen::MatrixXd R = unexplained_part;
  for (int j = 0; j < q; ++j) {
    if (norms(j) > 0) {
      R.col(j) /= norms(j);
    } else {
      R.col(j).setZero();
    }
  }
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(R);
  const double tol = std::sqrt(options.min_relative_singular_value);
  int r = 0;
  for (int k = 0; k < svd.singularValues().size(); ++k) r += svd.singularValues()(k) > tol;
  return r;
}

namespace {
// The nonzero entries of c: values at one angle touch few unknowns.
std::vector<int> support(const Eigen::VectorXd& c) {
  std::vector<int> idx;
  for (int j = 0; j < c.size(); ++j) {
    if (c(j) != 0.0) idx.push_back(j);
  }
  return idx;
}
}  // namespace

bool Estimate::determined(const Eigen::VectorXd& c) const {
  if (status == EstimateStatus::kNoReadings) return false;
  const std::vector<int> idx = support(c);
  double norm2 = 0;
  for (int j : idx) norm2 += std::pow(c(j) / column_scale(j), 2);
  if (norm2 == 0.0) return true;  // the zero function is known exactly
  if (null_space_scaled.cols() == 0) return true;
  Eigen::VectorXd proj = Eigen::VectorXd::Zero(null_space_scaled.cols());
  for (int j : idx) proj += (c(j) / column_scale(j)) * null_space_scaled.row(j).transpose();
  return proj.norm() <= estimable_tolerance * std::sqrt(norm2);
}

double Estimate::base_variance(const Eigen::VectorXd& c) const {
  const std::vector<int> idx = support(c);
  double var = 0;
  for (int a : idx) {
    for (int b : idx) var += c(a) * covariance(a, b) * c(b);
  }
  return var;
}

Eigen::VectorXd Estimate::low_rank_coordinates(const Eigen::VectorXd& c) const {
  Eigen::VectorXd kc = Eigen::VectorXd::Zero(covariance_K.cols());
  if (covariance_K.cols() == 0) return kc;
  for (int a : support(c)) kc += c(a) * covariance_K.row(a).transpose();
  return kc;
}

Determined Estimate::evaluate(const Eigen::VectorXd& c) const {
  Determined d;
  if (!determined(c)) return d;
  d.determined = true;
  if (theta.size() > 0) {
    for (int a : support(c)) d.value += c(a) * theta(a);
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
  // out confined to it.
  Eigen::MatrixXd R = (column_scale.cwiseInverse().asDiagonal() * null_space_scaled).transpose();
  const int k = static_cast<int>(R.rows());
  const int p = static_cast<int>(R.cols());
  if (k == 0) return Eigen::MatrixXd(p, 0);
  const double scale = R.cwiseAbs().maxCoeff();
  const double tiny = 1e-9 * scale;  // |entry| <= 1e-9 * max|entry| is rounding, not structure
  int row = 0;
  for (int col = 0; col < p && row < k; ++col) {
    Eigen::Index piv;
    const double best = R.col(col).segment(row, k - row).cwiseAbs().maxCoeff(&piv);
    if (best <= tiny) continue;
    R.row(row).swap(R.row(row + static_cast<int>(piv)));
    const double pivot = R(row, col);  // a copy: R(row, col) changes while the row is divided
    R.row(row) /= pivot;
    for (int i = 0; i < k; ++i) {
      const double factor = R(i, col);
      if (i != row && factor != 0.0) R.row(i) -= factor * R.row(row);
    }
    ++row;
  }
  Eigen::MatrixXd out(p, k);
  for (int i = 0; i < k; ++i) {
    Eigen::VectorXd v = R.row(i).transpose();
    for (int j = 0; j < p; ++j) {
      if (std::abs(v(j)) <= tiny) v(j) = 0.0;
    }
    v.normalize();
    Eigen::Index big;
    v.cwiseAbs().maxCoeff(&big);
    if (v(big) < 0) v = -v;
    out.col(i) = v;
  }
  return out;
}

}  // namespace dbbkit
