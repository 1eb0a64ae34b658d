#include "dbbkit/estimate.hpp"

#include <Eigen/SVD>
#include <boost/math/distributions/chi_squared.hpp>
#include <cmath>

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

  // JacobiSVD, not BDCSVD: Eigen 3.4.0's divide-and-conquer SVD fails (an index
  // assertion in debug builds, NaNs in release builds) on some rank-deficient
  // matrices such as the B head augmented with centring columns.
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(Js, Eigen::ComputeThinU | Eigen::ComputeFullV);
  est.singular_values = svd.singularValues();
  const double s_max = est.singular_values.size() > 0 ? est.singular_values(0) : 0.0;
  int rank = 0;
  while (rank < est.singular_values.size() &&
         est.singular_values(rank) > options.min_relative_singular_value * s_max) {
    ++rank;
  }
  est.rank = rank;
  if (rank > 0) est.condition_number = s_max / est.singular_values(rank - 1);

  const Eigen::MatrixXd V = svd.matrixV();
  const Eigen::MatrixXd Vr = V.leftCols(rank);
  const Eigen::VectorXd inv_s = est.singular_values.head(rank).cwiseInverse();
  const Eigen::VectorXd unscale = est.column_scale.cwiseInverse();
  // theta = S Vr Sr^-1 Ur' W^1/2 y
  gain_ = unscale.asDiagonal() * (Vr * inv_s.asDiagonal() * svd.matrixU().leftCols(rank).transpose()) *
          w.asDiagonal();
  const Eigen::MatrixXd cov_scaled = Vr * inv_s.cwiseAbs2().asDiagonal() * Vr.transpose();
  est.covariance = unscale.asDiagonal() * cov_scaled * unscale.asDiagonal();
  est.null_space_scaled = V.rightCols(p - rank);
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

bool Estimate::determined(const Eigen::VectorXd& c) const {
  if (status == EstimateStatus::kNoReadings) return false;
  const Eigen::VectorXd w = c.cwiseQuotient(column_scale);
  const double norm = w.norm();
  if (norm == 0.0) return true;  // the zero function is known exactly
  if (null_space_scaled.cols() == 0) return true;
  return (null_space_scaled.transpose() * w).norm() <= estimable_tolerance * norm;
}

Determined Estimate::evaluate(const Eigen::VectorXd& c) const {
  Determined d;
  if (!determined(c)) return d;
  d.determined = true;
  d.value = c.dot(theta);
  d.std = std::sqrt(std::max(0.0, c.dot(covariance * c)));
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
