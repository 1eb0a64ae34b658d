#pragma once
// Tolerance helpers and small fixtures shared by the tests.

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <Eigen/SparseCore>
#include <array>
#include <cmath>
#include <random>
#include <string>

#include "dbbkit/design.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/iso230.hpp"
#include "dbbkit/kit.hpp"
#include "dbbkit/linear_model.hpp"
#include "dbbkit/parameterisation.hpp"
#include "dbbkit/simulate.hpp"

namespace dbbkit {
// Two frames are the same axis (AxisFrame::same_as): the tests compare frames as values.
inline bool operator==(const AxisFrame& a, const AxisFrame& b) { return a.same_as(b); }
inline bool operator!=(const AxisFrame& a, const AxisFrame& b) { return !a.same_as(b); }
}  // namespace dbbkit

namespace dbbkit::test {

// The two shorthands' frames.
inline const AxisFrame kAxisC = AxisFrame::c_turntable();
inline const AxisFrame kAxisB = AxisFrame::b_head();

constexpr double kPi = 3.14159265358979323846;
constexpr double kBar = 150.0;  // mm, a bar length where the design gives none

// A real axis line, for readings and points computed without dbbkit's first-order algebra: a
// point on it, its direction, and the zero-position error (the axis stands at commanded + zero).
struct RealLine {
  Eigen::Vector3d point = Eigen::Vector3d::Zero();  // mm
  Eigen::Vector3d direction = Eigen::Vector3d::UnitZ();
  double zero_rad = 0;
};

// x turned by the commanded angle about the real line.
inline Eigen::Vector3d turn(const RealLine& l, double deg, const Eigen::Vector3d& x) {
  return l.point + Eigen::AngleAxisd(deg * kPi / 180 + l.zero_rad, l.direction) * (x - l.point);
}

// The line the five location errors (the axis' ISO order: two positions um, two orientations and
// the zero urad) describe, from the nominal line through the origin.
inline RealLine line_of(const AxisFrame& axis, const std::array<double, 5>& l) {
  const IsoFrame f = iso_frame(axis);
  RealLine r;
  r.point = 1e-3 * (l[0] * f.p1 + l[1] * f.p2);
  const Eigen::Vector3d alpha = 1e-6 * (l[2] * f.p1 + l[3] * f.p2);
  r.direction = Eigen::AngleAxisd(alpha.norm(), alpha.norm() > 0 ? alpha.normalized()
                                                                 : Eigen::Vector3d::UnitX()) *
                axis.direction();
  // The zero position is a rotation about the positive machine axis q.
  r.zero_rad = 1e-6 * l[4] * f.q.dot(axis.direction());
  return r;
}

// |a - b| <= abs_tol + rel_tol * max(|a|, |b|), elementwise.
inline ::testing::AssertionResult near(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b,
                                       double abs_tol, double rel_tol = 0.0) {
  if (a.rows() != b.rows() || a.cols() != b.cols()) {
    return ::testing::AssertionFailure() << "shapes differ: " << a.rows() << "x" << a.cols()
                                         << " vs " << b.rows() << "x" << b.cols();
  }
  for (Eigen::Index i = 0; i < a.rows(); ++i) {
    for (Eigen::Index j = 0; j < a.cols(); ++j) {
      const double tol = abs_tol + rel_tol * std::max(std::abs(a(i, j)), std::abs(b(i, j)));
      if (!(std::abs(a(i, j) - b(i, j)) <= tol)) {
        return ::testing::AssertionFailure()
               << "(" << i << "," << j << "): " << a(i, j) << " vs " << b(i, j) << " differ by "
               << std::abs(a(i, j) - b(i, j)) << " > " << tol;
      }
    }
  }
  return ::testing::AssertionSuccess();
}

// A Jacobian against central differences (manif's JacobianTester in spirit): f maps
// R^n to R^m, J is its analytic m x n Jacobian at x. Column j of the difference quotient
// is D_j = (f(x + h e_j) - f(x - h e_j)) / 2h, whose error is O(h^2) times the third
// derivative; it passes when
//   |J_ij - D_ij| <= abs_tol + rel_tol max(|J_ij|, |D_ij|)   for every i, j,
// and names the first entry that does not.
template <typename F>
::testing::AssertionResult jacobian_matches(const F& f, const Eigen::VectorXd& x,
                                            const Eigen::MatrixXd& J, double h, double abs_tol,
                                            double rel_tol = 0.0) {
  const Eigen::VectorXd f0 = f(x);
  if (J.rows() != f0.size() || J.cols() != x.size()) {
    return ::testing::AssertionFailure() << "J is " << J.rows() << "x" << J.cols() << ", f maps "
                                         << x.size() << " to " << f0.size();
  }
  Eigen::MatrixXd D(J.rows(), J.cols());
  for (Eigen::Index j = 0; j < x.size(); ++j) {
    Eigen::VectorXd xp = x, xm = x;
    xp(j) += h;
    xm(j) -= h;
    D.col(j) = (f(xp) - f(xm)) / (2.0 * h);
  }
  return near(J, D, abs_tol, rel_tol);
}

// A sparse (or any) matrix as a dense one, for comparisons.
template <typename D>
Eigen::MatrixXd dense(const Eigen::EigenBase<D>& x) {
  return Eigen::MatrixXd(x.derived());
}

// A dense Jacobian as the library stores it (its exact zeros left out).
inline Jacobian sparse(const Eigen::MatrixXd& J) { return Jacobian(J.sparseView()); }

// Adds the errors of one angle to a per-angle truth; an angle at the position of one
// already given (C: 360 repeats 0) takes that one's values, as the axis is one body.
inline void add_truth_value(Truth& t, const AxisFrame& axis, double angle_deg, const Vector6d& e) {
  for (const auto& [a, v] : t.per_angle) {
    if (same_position(axis, a, angle_deg)) {
      t.per_angle.emplace_back(angle_deg, v);
      return;
    }
  }
  t.per_angle.emplace_back(angle_deg, e);
}

// A small C kit whose travel binds: x, y within +-220 mm, so a tangential bar of 100 mm allows
// L <= sqrt(220^2 - 100^2) = 196 mm of the 250 the table offers (a 150 mm block sets the
// heights apart, so that the radii limit the worst case).
inline Kit small_c_kit() {
  Kit k;
  k.name = "small-c";
  k.axis = kAxisC;
  k.pattern = *builtin_pattern("three_position", kAxisC);
  k.reference_length_mm = 100;
  k.L_mm = {20, 250};
  k.D_mm = {0, 0};
  k.H_base_mm = 45;
  k.blocks_mm = {150};
  k.max_stack = 1;
  k.bars_mm = {100, 150};
  k.travel_mm = {Interval{-220, 220}, Interval{-220, 220}, Interval{-50, 400}};
  k.min_separation_mm = 30;
  k.angle_range_deg = {0, 360};
  k.angle_steps_deg = {30};
  k.time_per_reading_s = 3;
  k.time_per_installation_s = 240;
  validate_kit(k);
  return k;
}

// A small B kit: L along the tool axis 100..260 mm and a holder that offsets the
// ball up to 150 mm along the swing axis; the following ball of an offset ball
// sits at the same y, and y travel stops at +-100 mm: the travel limits the offset.
inline Kit small_b_kit() {
  Kit k;
  k.name = "small-b";
  k.axis = kAxisB;
  k.pattern = *builtin_pattern("three_position", kAxisB);
  k.reference_length_mm = 100;
  k.L_mm = {100, 260};
  k.D_mm = {0, 150};
  k.bars_mm = {100, 150};
  k.travel_mm = {Interval{-260, 260}, Interval{-100, 100}, Interval{-150, 260}};
  k.min_separation_mm = 30;
  k.angle_range_deg = {-100, 0};
  k.angle_steps_deg = {20};
  k.time_per_reading_s = 3;
  k.time_per_installation_s = 240;
  validate_kit(k);
  return k;
}

inline std::string source_path(const std::string& relative) {
  return std::string(DBBKIT_SOURCE_DIR) + "/" + relative;
}

// The paper's C design and its data.
inline const std::string kDesignC = source_path("designs/paper-c-turntable.json");
inline const std::string kDesignB = source_path("designs/paper-b-head.json");
inline const std::string kDataC = source_path("tests/data/paper/paper_c_turntable.csv");

inline Design paper_design(char axis) {
  return io::read_design_file(
      source_path(axis == 'C' ? "designs/paper-c-turntable.json" : "designs/paper-b-head.json"));
}

// Two-sided binomial acceptance band: the number of successes in n trials of
// probability p lies within p n +- z sqrt(n p (1 - p)).
inline bool within_binomial(double successes, double n, double p, double z) {
  return std::abs(successes - p * n) <= z * std::sqrt(n * p * (1 - p));
}

// The paper's C installations with 150 mm bars and a Fourier order-2 error model,
// swept ccw, cw, ccw, 10 s per reading (tests/data/c_fourier2_bar150.json): the
// redundancy diagnosis needs.
inline Design fourier_design() {
  return io::read_design_file(source_path("tests/data/c_fourier2_bar150.json"));
}

// Random order-2 Fourier errors for it (10 um, 30 urad) with that schedule.
inline Truth random_fourier_truth(const Design& d, std::mt19937_64& rng) {
  std::normal_distribution<double> n01;
  Truth t;
  t.model = d.errors;
  for (int k = 0; k < 6; ++k) {
    for (int c = 0; c < 5; ++c) t.coefficients[k].push_back((k < 3 ? 10.0 : 30.0) * n01(rng));
  }
  t.schedule = Schedule{10, 240, {Sweep::kCCW, Sweep::kCW, Sweep::kCCW}};
  return t;
}

}  // namespace dbbkit::test
