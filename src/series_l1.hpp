#pragma once
// Internal: what Gain::left_l1 of a series (series_l1.cpp) does with the readings' angles.

#include <utility>
#include <vector>

#include "dbbkit/linear_model.hpp"

namespace dbbkit::detail {

// The basis functions by parity (SeriesRows::parity: even, odd; both empty without one) and
// the readings' angles paired with their reflections: (angle, the angle whose basis row is
// its row with the odd functions negated, value for value (a zero's sign aside), or -1),
// every angle once, in order of the first. No pairs without odd functions.
struct Reflection {
  std::vector<int> even, odd;
  std::vector<std::pair<Eigen::Index, Eigen::Index>> pairs;
};
Reflection reflection_pairs(const SeriesRows& s);

// Whether the bias bound's tiles pair the angles with their reflections (the even and odd
// basis functions summed apart, half the products): the basis has odd functions and at most
// a quarter more slots than angles are needed.
bool series_angles_paired(const SeriesRows& s);

// J M and J' M through the rows' factors, J(i, k m + a) = g_i(k) phi_a(angle_i) (M: p x c with
// p = 6 m, or n x c): the errors at each distinct angle, then each reading's six of them, in
// place of a pass over J's n x p nonzeros per column. J' M passes over M's zeros.
Eigen::MatrixXd series_times(const SeriesRows& s, const Eigen::MatrixXd& M);
Eigen::MatrixXd series_transpose_times(const SeriesRows& s, const Eigen::MatrixXd& M);

}  // namespace dbbkit::detail
