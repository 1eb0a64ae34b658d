#pragma once
// Internal: the rows of a FunctionRows matrix grouped by their support (the columns of their
// nonzero entries), for products that take a group's rows through one dense product on that
// support (Gain::left_l1, SetupSolver::left_gain_l1).

#include <map>
#include <vector>

#include "dbbkit/estimate.hpp"
#include "setup_solver.hpp"

namespace dbbkit::detail {

// support -> the rows with that support, each list ascending; a zero row has the empty support.
inline std::map<std::vector<Eigen::Index>, std::vector<Eigen::Index>> rows_by_support(
    const FunctionRows& C) {
  std::map<std::vector<Eigen::Index>, std::vector<Eigen::Index>> groups;
  for (Eigen::Index i = 0; i < C.rows(); ++i) {
    std::vector<Eigen::Index> support;
    for (FunctionRows::InnerIterator it(C, i); it; ++it) {
      if (it.value() != 0.0) support.push_back(it.col());
    }
    groups[support].push_back(i);
  }
  return groups;
}

}  // namespace dbbkit::detail
