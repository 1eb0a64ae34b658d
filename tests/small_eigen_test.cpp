#include "../src/small_eigen.hpp"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

namespace dbbkit::detail {
namespace {

// The matrices a per-angle model's blocks and their neighbours give: random symmetric
// (indefinite), Gram matrices of tall blocks, rank-deficient ones, repeated eigenvalues, an
// almost diagonal one, zero, and scales near the ends of the double range.
std::vector<Eigen::MatrixXd> test_matrices() {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> N;
  auto random = [&](int r, int c) {
    Eigen::MatrixXd A(r, c);
    for (Eigen::Index j = 0; j < c; ++j)
      for (Eigen::Index i = 0; i < r; ++i) A(i, j) = N(rng);
    return A;
  };
  std::vector<Eigen::MatrixXd> out;
  for (int n = 1; n <= kSmallEigenMax; ++n) {
    for (int t = 0; t < 40; ++t) {
      const Eigen::MatrixXd B = random(n, n);
      out.push_back(B + B.transpose());
      const Eigen::MatrixXd T = random(n + 1 + t % 4, n);
      out.push_back(T.transpose() * T);
    }
    const Eigen::MatrixXd low = random(n, std::max(1, n / 2));
    out.push_back(low * low.transpose());  // rank n / 2
    const Eigen::HouseholderQR<Eigen::MatrixXd> qr(random(n, n));
    const Eigen::MatrixXd Q = qr.householderQ();
    Eigen::VectorXd repeated(n);
    for (int i = 0; i < n; ++i) repeated(i) = 1.0 + i / 2;  // 1, 1, 2, 2, ...
    out.push_back(Q * repeated.asDiagonal() * Q.transpose());
    Eigen::MatrixXd almost = 3.0 * Eigen::MatrixXd::Identity(n, n);
    if (n > 1) almost(0, n - 1) = almost(n - 1, 0) = 1e-20;
    out.push_back(almost);
    out.push_back(Eigen::MatrixXd::Zero(n, n));
    const Eigen::MatrixXd G = random(n + 2, n);
    out.push_back(1e250 * (G.transpose() * G));
    out.push_back(1e-250 * (G.transpose() * G));
  }
  return out;
}

// Against Eigen's SelfAdjointEigenSolver: the same eigenvalues, and vectors that are
// orthonormal and reproduce A, each to a few units of rounding of |A|.
TEST(SmallEigen, AgreesWithEigensSolverAndReproducesTheMatrix) {
  int checked = 0;
  for (const Eigen::MatrixXd& A : test_matrices()) {
    const int n = static_cast<int>(A.rows());
    SmallSymmetricEigen e;
    ASSERT_TRUE(e.compute(A, true)) << A;
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> ref(A);
    Eigen::VectorXd lambda(n);
    Eigen::MatrixXd Z(n, n);
    for (int k = 0; k < n; ++k) {
      lambda(k) = e.eigenvalue(k);
      for (int i = 0; i < n; ++i) Z(i, k) = e.vector(i, k);
    }
    // |A| as its largest entry times n (A.norm() would overflow at 1e250).
    const double scale = std::max(n * A.cwiseAbs().maxCoeff(), std::numeric_limits<double>::min());
    constexpr double tol = 1e-13;
    for (int k = 1; k < n; ++k) EXPECT_LE(lambda(k - 1), lambda(k));  // ascending
    EXPECT_LE((lambda - ref.eigenvalues()).cwiseAbs().maxCoeff(), tol * scale) << A;
    EXPECT_LE((Z * (lambda / scale).asDiagonal() * Z.transpose() - A / scale).cwiseAbs().maxCoeff(),
              tol)
        << A;
    EXPECT_LE((Z.transpose() * Z - Eigen::MatrixXd::Identity(n, n)).norm(), tol) << A;
    // Without vectors: the same arithmetic on the tridiagonal, so the same values exactly.
    SmallSymmetricEigen values_only;
    ASSERT_TRUE(values_only.compute(A, false));
    for (int k = 0; k < n; ++k) EXPECT_EQ(values_only.eigenvalue(k), lambda(k));
    ++checked;
  }
  EXPECT_GT(checked, 600);
}

// Only the lower triangle is read (the factorisation forms only that of a Gram matrix).
TEST(SmallEigen, ReadsTheLowerTriangleOnly) {
  Eigen::MatrixXd A(3, 3);
  A << 4, 0, 0, 1, 3, 0, 0.5, 0.25, 2;
  const Eigen::MatrixXd full = A.selfadjointView<Eigen::Lower>();
  SmallSymmetricEigen lower, symmetric;
  ASSERT_TRUE(lower.compute(A, false));
  ASSERT_TRUE(symmetric.compute(full, false));
  for (int k = 0; k < 3; ++k) EXPECT_EQ(lower.eigenvalue(k), symmetric.eigenvalue(k));
}

// Outside its range it declines, and the caller takes Eigen's solver: larger than
// kSmallEigenMax, not square, or steps that never converge (a NaN never deflates).
TEST(SmallEigen, DeclinesWhatItCannotDecompose) {
  SmallSymmetricEigen e;
  EXPECT_FALSE(e.compute(Eigen::MatrixXd::Identity(kSmallEigenMax + 1, kSmallEigenMax + 1), true));
  EXPECT_FALSE(e.compute(Eigen::MatrixXd::Identity(3, 2), true));
  Eigen::MatrixXd nan = Eigen::MatrixXd::Identity(4, 4);
  nan(2, 1) = nan(1, 2) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(e.compute(nan, false));
}

// A - shift I is positive definite exactly when shift lies below the smallest eigenvalue
// (here away from it by 1e-6 relative, far beyond the factorisation's rounding).
TEST(SmallEigen, ShiftedPositiveDefinitenessBracketsTheSmallestEigenvalue) {
  int checked = 0;
  for (const Eigen::MatrixXd& A : test_matrices()) {
    const double lambda_min = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(A).eigenvalues()(0);
    const double largest = A.cwiseAbs().maxCoeff();
    if (!(largest > 0)) continue;
    const double margin = 1e-6 * A.rows() * largest;
    EXPECT_TRUE(positive_definite_shifted(A, lambda_min - margin)) << A;
    EXPECT_FALSE(positive_definite_shifted(A, lambda_min + margin)) << A;
    ++checked;
  }
  EXPECT_GT(checked, 600);
  EXPECT_FALSE(positive_definite_shifted(Eigen::MatrixXd::Identity(9, 9), 0.0));  // too large
  Eigen::MatrixXd nan = Eigen::MatrixXd::Identity(2, 2);
  nan(1, 1) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(positive_definite_shifted(nan, 0.0));
}

}  // namespace
}  // namespace dbbkit::detail
