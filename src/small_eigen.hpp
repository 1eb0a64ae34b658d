#pragma once
// The symmetric eigen-decomposition of a small matrix (n <= kSmallEigenMax) in fixed storage:
// Householder reduction to tridiagonal form, then implicit symmetric QR steps with the
// Wilkinson shift (Golub and Van Loan, Matrix Computations, 4th ed., algorithms 8.3.1 and
// 8.3.2). It serves the many 5 x 5 and 6 x 6 blocks of a per-angle model, where a general
// solver's set-up costs more than the arithmetic. Tested against Eigen's
// SelfAdjointEigenSolver (small_eigen_test.cpp).

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <limits>

namespace dbbkit::detail {

constexpr int kSmallEigenMax = 8;

// A = Z diag(lambda) Z', lambda ascending; Z only when `vectors`. false when the QR steps did
// not converge within 30 n steps (the caller then takes a general solver). Only the lower
// triangle of A is read.
class SmallSymmetricEigen {
 public:
  bool compute(const Eigen::Ref<const Eigen::MatrixXd>& A, bool vectors) {
    n_ = static_cast<int>(A.rows());
    if (n_ > kSmallEigenMax || A.cols() != n_) return false;
    vectors_ = vectors;
    const int n = n_;
    // Scaled by a power of two (exact) to entries below 1 in magnitude: no square overflows.
    const int e = exponent_of_largest(A);
    for (int j = 0; j < n; ++j) {
      for (int i = j; i < n; ++i) a_[i][j] = a_[j][i] = std::ldexp(A(i, j), -e);
    }
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j < n; ++j) q_[i][j] = i == j ? 1.0 : 0.0;
    }
    tridiagonalise();
    if (!iterate()) return false;
    for (int i = 0; i < n; ++i) d_[i] = std::ldexp(d_[i], e);
    sort();
    return true;
  }

  // The binary exponent of the largest |A_ij| of the lower triangle (0 for zero, NaN or inf).
  static int exponent_of_largest(const Eigen::Ref<const Eigen::MatrixXd>& A) {
    double m = 0;
    for (Eigen::Index j = 0; j < A.cols(); ++j) {
      for (Eigen::Index i = j; i < A.rows(); ++i) m = std::max(m, std::abs(A(i, j)));
    }
    if (!(m > 0) || !std::isfinite(m)) return 0;
    int e = 0;
    std::frexp(m, &e);  // m = f 2^e, 0.5 <= f < 1
    return e;
  }

  int size() const { return n_; }
  double eigenvalue(int k) const { return d_[k]; }        // ascending
  double vector(int i, int k) const { return q_[i][k]; }  // component i of eigenvector k

 private:
  // A <- H A H with H = I - beta v v' zeroing column k below its subdiagonal; Q <- Q H.
  void tridiagonalise() {
    const int n = n_;
    for (int k = 0; k + 2 < n; ++k) {
      double tail = 0;  // the squared norm of the column below the subdiagonal
      for (int i = k + 2; i < n; ++i) tail += a_[i][k] * a_[i][k];
      if (tail == 0.0) continue;  // already tridiagonal in this column
      const double x0 = a_[k + 1][k];
      const double alpha = std::sqrt(x0 * x0 + tail);
      double v[kSmallEigenMax];
      const double v0 = x0 >= 0 ? x0 + alpha : x0 - alpha;  // no cancellation
      v[k + 1] = v0;
      for (int i = k + 2; i < n; ++i) v[i] = a_[i][k];
      const double beta = 2.0 / (v0 * v0 + tail);
      // p = beta A22 v, w = p - (beta p'v / 2) v, A22 <- A22 - v w' - w v'.
      double p[kSmallEigenMax];
      double pv = 0;
      for (int i = k + 1; i < n; ++i) {
        double s = 0;
        for (int j = k + 1; j < n; ++j) s += a_[i][j] * v[j];
        p[i] = beta * s;
        pv += p[i] * v[i];
      }
      const double half = 0.5 * beta * pv;
      for (int i = k + 1; i < n; ++i) p[i] -= half * v[i];
      for (int i = k + 1; i < n; ++i) {
        for (int j = k + 1; j <= i; ++j) {
          a_[i][j] -= v[i] * p[j] + p[i] * v[j];
          a_[j][i] = a_[i][j];
        }
      }
      const double sub = x0 >= 0 ? -alpha : alpha;  // H x = sub e1
      a_[k + 1][k] = a_[k][k + 1] = sub;
      for (int i = k + 2; i < n; ++i) a_[i][k] = a_[k][i] = 0.0;
      if (vectors_) {
        for (int r = 0; r < n; ++r) {
          double s = 0;
          for (int j = k + 1; j < n; ++j) s += q_[r][j] * v[j];
          s *= beta;
          for (int j = k + 1; j < n; ++j) q_[r][j] -= s * v[j];
        }
      }
    }
    for (int i = 0; i < n; ++i) d_[i] = a_[i][i];
    for (int i = 0; i + 1 < n; ++i) e_[i] = a_[i + 1][i];
  }

  // Implicit QR steps with the Wilkinson shift on the unreduced part [start, end], deflating
  // a subdiagonal at the rounding of its neighbours.
  bool iterate() {
    const int n = n_;
    constexpr double eps = std::numeric_limits<double>::epsilon();
    constexpr double tiny = std::numeric_limits<double>::min();
    int end = n - 1, steps = 0;
    while (end > 0) {
      for (int i = 0; i < end; ++i) {
        if (std::abs(e_[i]) <= eps * (std::abs(d_[i]) + std::abs(d_[i + 1])) ||
            std::abs(e_[i]) < tiny)
          e_[i] = 0.0;
      }
      while (end > 0 && e_[end - 1] == 0.0) --end;
      if (end == 0) break;
      int start = end - 1;
      while (start > 0 && e_[start - 1] != 0.0) --start;
      if (++steps > 30 * n) return false;
      step(start, end);
    }
    return true;
  }

  // One step on [start, end]: the rotation R = [c s; -s c] on rows and columns k, k+1 chases
  // the bulge down; T <- R T R', Q <- Q R'.
  void step(int start, int end) {
    const double delta = 0.5 * (d_[end - 1] - d_[end]);
    const double b = e_[end - 1];
    double mu = d_[end];
    if (delta == 0.0) {
      mu -= std::abs(b);
    } else {
      const double h = norm2(delta, b);
      mu -= b * b / (delta + (delta > 0 ? h : -h));
    }
    double x = d_[start] - mu, z = e_[start];
    for (int k = start; k < end; ++k) {
      const double r = norm2(x, z);
      const double c = r == 0.0 ? 1.0 : x / r;
      const double s = r == 0.0 ? 0.0 : z / r;
      if (k > start) e_[k - 1] = r;  // the bulge z at (k+1, k-1) is taken into (k, k-1)
      const double a = d_[k], bk = e_[k], cc = d_[k + 1];
      const double cs = c * s, c2 = c * c, s2 = s * s;
      d_[k] = c2 * a + 2.0 * cs * bk + s2 * cc;
      d_[k + 1] = s2 * a - 2.0 * cs * bk + c2 * cc;
      e_[k] = cs * (cc - a) + (c2 - s2) * bk;
      if (k + 1 < end) {
        z = s * e_[k + 1];
        e_[k + 1] *= c;
      }
      x = e_[k];
      if (vectors_) {
        for (int r2 = 0; r2 < n_; ++r2) {
          const double qk = q_[r2][k], qk1 = q_[r2][k + 1];
          q_[r2][k] = c * qk + s * qk1;
          q_[r2][k + 1] = -s * qk + c * qk1;
        }
      }
    }
  }

  // sqrt(x^2 + z^2), scaled only where the squares would leave the range of doubles (std::hypot
  // costs more than a whole step here).
  static double norm2(double x, double z) {
    const double m = std::max(std::abs(x), std::abs(z));
    if (m > 1e150 || (m < 1e-150 && m > 0)) {
      const double xs = x / m, zs = z / m;
      return m * std::sqrt(xs * xs + zs * zs);
    }
    return std::sqrt(x * x + z * z);
  }

  // Ascending, the vectors with their values (insertion sort: n is small).
  void sort() {
    for (int i = 1; i < n_; ++i) {
      for (int j = i; j > 0 && d_[j] < d_[j - 1]; --j) {
        std::swap(d_[j], d_[j - 1]);
        if (vectors_) {
          for (int r = 0; r < n_; ++r) std::swap(q_[r][j], q_[r][j - 1]);
        }
      }
    }
  }

  int n_ = 0;
  bool vectors_ = false;
  double a_[kSmallEigenMax][kSmallEigenMax];
  double q_[kSmallEigenMax][kSmallEigenMax];
  double d_[kSmallEigenMax];
  double e_[kSmallEigenMax];
};

// Whether A - shift I (n <= kSmallEigenMax, lower triangle read) is positive definite: its
// Cholesky factor exists with positive pivots, so every eigenvalue of A exceeds shift (to the
// factorisation's backward error, a few n eps |A|). false for a larger n.
inline bool positive_definite_shifted(const Eigen::Ref<const Eigen::MatrixXd>& A, double shift) {
  const int n = static_cast<int>(A.rows());
  if (n > kSmallEigenMax || A.cols() != n) return false;
  // Scaled by a power of two (exact) to entries of order 1: no product overflows.
  const int e = SmallSymmetricEigen::exponent_of_largest(A);
  const double scaled_shift = std::ldexp(shift, -e);
  double L[kSmallEigenMax][kSmallEigenMax];
  for (int j = 0; j < n; ++j) {
    double pivot = std::ldexp(A(j, j), -e) - scaled_shift;
    for (int k = 0; k < j; ++k) pivot -= L[j][k] * L[j][k];
    if (!(pivot > 0)) return false;  // also NaN
    const double ljj = std::sqrt(pivot);
    L[j][j] = ljj;
    for (int i = j + 1; i < n; ++i) {
      double v = std::ldexp(A(i, j), -e);
      for (int k = 0; k < j; ++k) v -= L[i][k] * L[j][k];
      L[i][j] = v / ljj;
    }
  }
  return true;
}

}  // namespace dbbkit::detail
