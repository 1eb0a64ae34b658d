#pragma once
// The bilinear form of two functions on one dense block B of a covariance,
//   v = sum over x of a_x (sum over y of B(i_x, j_y) b_y),
// with each sum taken in its order: the inner sums of all x formed together, a column of B at
// a time (contiguous reads of the column-major block). Every inner sum is the same sum in the
// same order as one formed alone, so the result does not depend on which path formed it
// (Estimate::base_variance, the ISO 230 components' covariance).
//
// A function whose places in the block run consecutively (a series error's coefficients)
// takes the path without an index per element: the same operations in the same order, read
// contiguously (the compiler vectorises the inner loop across x).

#include <Eigen/Core>
#include <cstddef>
#include <vector>

namespace dbbkit::detail {

// The first place when places[0..n) are consecutive, else -1 (also for n == 0).
template <class Index>
Eigen::Index consecutive_start(const Index* places, std::size_t n) {
  if (n == 0) return -1;
  const Eigen::Index first = static_cast<Eigen::Index>(places[0]);
  for (std::size_t k = 1; k < n; ++k) {
    if (static_cast<Eigen::Index>(places[k]) != first + static_cast<Eigen::Index>(k)) return -1;
  }
  return first;
}

// `row` is work storage (resized here). ia / jb: the places of a and b in B; ia_start /
// jb_start: consecutive_start of them (-1 when not consecutive).
template <class IndexA, class IndexB>
double block_form(const Eigen::MatrixXd& B, const double* a, const IndexA* ia,
                  Eigen::Index ia_start, std::size_t na, const double* b, const IndexB* jb,
                  std::size_t nb, std::vector<double>& row) {
  row.assign(na, 0.0);
  double* r = row.data();
  for (std::size_t y = 0; y < nb; ++y) {
    const double* col = B.col(static_cast<Eigen::Index>(jb[y])).data();
    const double by = b[y];
    if (ia_start >= 0) {
      const double* c = col + ia_start;
      for (std::size_t x = 0; x < na; ++x) r[x] += c[x] * by;
    } else {
      for (std::size_t x = 0; x < na; ++x) r[x] += col[static_cast<Eigen::Index>(ia[x])] * by;
    }
  }
  double v = 0;
  for (std::size_t x = 0; x < na; ++x) v += a[x] * r[x];
  return v;
}

}  // namespace dbbkit::detail
