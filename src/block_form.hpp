#pragma once
// The bilinear form of two functions on one dense block B of a covariance,
//   v = sum over x of a_x (sum over y of B(i_x, j_y) b_y),
// with each sum taken in its order: the inner sums of all x formed together, a column of B at
// a time (contiguous reads of the column-major block). Every inner sum is the same sum in the
// same order as one formed alone, so the result does not depend on which path formed it
// (Estimate::base_variance, the ISO 230 components' covariance).
//
// When a's places ascend within a short span (a series error's coefficients, some of them
// zero at an angle and left out) the inner sums run over the whole span, read contiguously
// without an index per element (the compiler vectorises them). A place of the span that a
// does not have gets an inner sum of its own, which a_x = 0 then drops: the outer sum gains
// only zero terms, and as it starts at +0 each leaves it unchanged bit for bit (B finite).
// The result is that of the sums over a's own places.

#include <Eigen/Core>
#include <cstddef>
#include <vector>

namespace dbbkit::detail {

// `work` is storage reused from call to call (resized here).
template <class IndexA, class IndexB>
double block_form(const Eigen::MatrixXd& B, const double* a, const IndexA* ia, std::size_t na,
                  const double* b, const IndexB* jb, std::size_t nb, std::vector<double>& work) {
  if (na == 0) return 0.0;
  const auto first = static_cast<Eigen::Index>(ia[0]);
  bool ascending = true;
  for (std::size_t x = 1; x < na && ascending; ++x) ascending = ia[x] > ia[x - 1];
  const Eigen::Index span = static_cast<Eigen::Index>(ia[na - 1]) - first + 1;
  if (ascending && span <= 2 * static_cast<Eigen::Index>(na)) {
    const auto len = static_cast<std::size_t>(span);
    work.assign(2 * len, 0.0);
    double* dense = work.data();  // a over the span
    double* r = work.data() + len;
    for (std::size_t x = 0; x < na; ++x)
      dense[static_cast<std::size_t>(static_cast<Eigen::Index>(ia[x]) - first)] = a[x];
    // Four columns a pass (each sum still adds them in their order): a quarter of the
    // sums' loads and stores.
    std::size_t y = 0;
    for (; y + 4 <= nb; y += 4) {
      const double* c0 = B.col(static_cast<Eigen::Index>(jb[y])).data() + first;
      const double* c1 = B.col(static_cast<Eigen::Index>(jb[y + 1])).data() + first;
      const double* c2 = B.col(static_cast<Eigen::Index>(jb[y + 2])).data() + first;
      const double* c3 = B.col(static_cast<Eigen::Index>(jb[y + 3])).data() + first;
      const double b0 = b[y], b1 = b[y + 1], b2 = b[y + 2], b3 = b[y + 3];
      for (std::size_t x = 0; x < len; ++x) {
        double s = r[x];
        s += c0[x] * b0;
        s += c1[x] * b1;
        s += c2[x] * b2;
        s += c3[x] * b3;
        r[x] = s;
      }
    }
    for (; y < nb; ++y) {
      const double* c = B.col(static_cast<Eigen::Index>(jb[y])).data() + first;
      const double by = b[y];
      for (std::size_t x = 0; x < len; ++x) r[x] += c[x] * by;
    }
    double v = 0;
    for (std::size_t x = 0; x < len; ++x) v += dense[x] * r[x];
    return v;
  }
  work.assign(na, 0.0);
  double* r = work.data();
  for (std::size_t y = 0; y < nb; ++y) {
    const double* col = B.col(static_cast<Eigen::Index>(jb[y])).data();
    const double by = b[y];
    for (std::size_t x = 0; x < na; ++x) r[x] += col[static_cast<Eigen::Index>(ia[x])] * by;
  }
  double v = 0;
  for (std::size_t x = 0; x < na; ++x) v += a[x] * r[x];
  return v;
}

}  // namespace dbbkit::detail
