#pragma once
// The inverse of a symmetric positive definite matrix from its Cholesky factor L (A = L L'),
// as LAPACK's potri: X = L^-1 in place (trtri), then A^-1 = X' X (lauum), each by halves,
// the off-diagonal blocks by Eigen's triangular products; n^3 / 3 multiply-adds, where two
// triangular solves against the identity take n^3.

#include <Eigen/Core>

namespace dbbkit::detail {

namespace spd_inverse_impl {

constexpr Eigen::Index kSmall = 24;  // below: the loops themselves

// X = L^-1 in place (lower triangle; the upper is not read).
inline void lower_inverse(Eigen::Ref<Eigen::MatrixXd> L) {
  const Eigen::Index n = L.rows();
  if (n <= kSmall) {
    for (Eigen::Index j = 0; j < n; ++j) {
      L(j, j) = 1.0 / L(j, j);
      for (Eigen::Index i = j + 1; i < n; ++i) {
        double s = 0;
        for (Eigen::Index k = j; k < i; ++k) s += L(i, k) * L(k, j);
        L(i, j) = -s / L(i, i);
      }
    }
    return;
  }
  const Eigen::Index n1 = n / 2, n2 = n - n1;
  auto L11 = L.topLeftCorner(n1, n1);
  auto L21 = L.bottomLeftCorner(n2, n1);
  auto L22 = L.bottomRightCorner(n2, n2);
  // [L11 0; L21 L22]^-1 = [L11^-1 0; -L22^-1 L21 L11^-1 L22^-1].
  L11.triangularView<Eigen::Lower>().solveInPlace<Eigen::OnTheRight>(L21);
  L22.triangularView<Eigen::Lower>().solveInPlace(L21);
  L21 = -L21;
  lower_inverse(L11);
  lower_inverse(L22);
}

// A = X' X in place of the lower triangle of X (lower triangular); the upper is not written.
inline void lower_gram(Eigen::Ref<Eigen::MatrixXd> X) {
  const Eigen::Index n = X.rows();
  if (n <= kSmall) {
    for (Eigen::Index j = 0; j < n; ++j) {
      for (Eigen::Index i = j; i < n; ++i) {  // row i >= j; X(k, i) zero for k < i
        double s = 0;
        for (Eigen::Index k = i; k < n; ++k) s += X(k, i) * X(k, j);
        X(i, j) = s;  // read later only at rows >= i + 1 of column j, and column i
      }
    }
    return;
  }
  const Eigen::Index n1 = n / 2, n2 = n - n1;
  auto X11 = X.topLeftCorner(n1, n1);
  auto X21 = X.bottomLeftCorner(n2, n1);
  auto X22 = X.bottomRightCorner(n2, n2);
  // [X11 0; X21 X22]' [X11 0; X21 X22] = [X11'X11 + X21'X21, X21'X22; X22'X21, X22'X22].
  lower_gram(X11);
  X11.selfadjointView<Eigen::Lower>().rankUpdate(X21.transpose());
  X21 = X22.transpose().triangularView<Eigen::Upper>() * X21;
  lower_gram(X22);
}

}  // namespace spd_inverse_impl

// A^-1 (symmetric, both triangles) from the Cholesky factor L of A (lower, n x n).
inline Eigen::MatrixXd inverse_from_cholesky(const Eigen::MatrixXd& L) {
  Eigen::MatrixXd X = L.triangularView<Eigen::Lower>();
  spd_inverse_impl::lower_inverse(X);
  spd_inverse_impl::lower_gram(X);
  X.triangularView<Eigen::StrictlyUpper>() = X.transpose();
  return X;
}

}  // namespace dbbkit::detail
