#include "dbbkit/predict.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <boost/math/distributions/chi_squared.hpp>
#include <boost/math/distributions/fisher_f.hpp>
#include <boost/math/distributions/normal.hpp>
#include <boost/math/distributions/students_t.hpp>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <vector>

#include "dbbkit/iso230.hpp"
#include "dbbkit/kinematics.hpp"

namespace dbbkit {

PredictionCoverage prediction_coverage(double coverage_probability, std::optional<double> dof) {
  PredictionCoverage c;
  c.coverage_probability = coverage_probability;
  c.dof = dof;
  const double two_sided = 0.5 + coverage_probability / 2;
  if (dof) {
    c.k = boost::math::quantile(boost::math::students_t(*dof), two_sided);
    c.k_length = std::sqrt(
        3.0 * boost::math::quantile(boost::math::fisher_f(3.0, *dof), coverage_probability));
  } else {
    c.k = boost::math::quantile(boost::math::normal(), two_sided);
    c.k_length =
        std::sqrt(boost::math::quantile(boost::math::chi_squared(3.0), coverage_probability));
  }
  return c;
}

namespace {

// The directions of one octant of the unit sphere (Gauss-Legendre in cos(theta): the eigenvalues
// of the Jacobi matrix of the Legendre polynomials, weights from the eigenvectors' first entries;
// the midpoint rule in phi), as the squares of their components, with their weights.
struct OctantRule {
  std::vector<Eigen::Vector3d> w2;  // the squared components of each direction
  std::vector<double> weight;       // summing to 1
  explicit OctantRule(int n) {
    Eigen::MatrixXd T = Eigen::MatrixXd::Zero(n, n);
    for (int k = 1; k < n; ++k) T(k, k - 1) = T(k - 1, k) = k / std::sqrt(4.0 * k * k - 1);
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(T);
    constexpr double kHalfPi = 1.57079632679489661923;
    for (int i = 0; i < n; ++i) {
      const double c = 0.5 * (1 + eig.eigenvalues()(i)), s2 = 1 - c * c;
      const double v = eig.eigenvectors()(0, i);  // 2 v^2 on [-1, 1], halved on [0, 1]
      for (int j = 0; j < n; ++j) {
        const double phi = kHalfPi * (j + 0.5) / n;
        const double cp = std::cos(phi), sp = std::sin(phi);
        w2.emplace_back(s2 * cp * cp, s2 * sp * sp, c * c);
        weight.push_back(v * v / n);
      }
    }
  }
};

// P(x' x <= r2) for x = L^(1/2) z, z standard normal in three: with z = rho w (w uniform on the
// sphere, rho^2 chi-squared with 3 degrees of freedom, independent), the mean over w of
// F3(r2 / w' L w), F3(t) = erf(sqrt(t / 2)) - sqrt(2 t / pi) exp(-t / 2). The integrand is smooth
// on the sphere and symmetric in each coordinate's sign: one octant.
struct Cdf {
  double p = 0, dp = 0;  // the probability and its derivative in r2
};
Cdf length_cdf(const Eigen::Vector3d& l, double r2, const OctantRule& rule) {
  constexpr double kPi = 3.14159265358979323846;
  Cdf out;
  for (std::size_t k = 0; k < rule.weight.size(); ++k) {
    const double q = l.dot(rule.w2[k]);
    if (!(q > 0)) {
      out.p += rule.weight[k];
      continue;
    }
    const double t = r2 / q, e = std::exp(-t / 2), st = std::sqrt(t);
    out.p += rule.weight[k] * (std::erf(st / std::sqrt(2.0)) - std::sqrt(2 / kPi) * st * e);
    out.dp += rule.weight[k] * st * e / (std::sqrt(2 * kPi) * q);  // the chi-squared (3) density
  }
  return out;
}

}  // namespace

double length_uncertainty(const Eigen::Matrix3d& covariance, const PredictionCoverage& c) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(0.5 *
                                                           (covariance + covariance.transpose()));
  const Eigen::Vector3d l = eig.eigenvalues().cwiseMax(0.0);  // increasing
  if (!(l(2) > 0)) return 0.0;
  const double bound = c.k_length * std::sqrt(l(2));
  if (c.dof) return bound;  // the multivariate t: the sphere around its ellipsoid
  // The radius whose ball holds the Gaussian error with the coverage probability: between the
  // largest axis' own quantile and the bound, by bisection on the probability.
  static const OctantRule rule(24);
  // Newton's method on the probability in r2, kept within the bracket [lo, hi] (bisection
  // where a step leaves it), from the chi-squared of the same mean and variance.
  const double p = c.coverage_probability;
  double lo = c.k * c.k * l(2), hi = bound * bound;
  const double mean = l.sum(), square = l.squaredNorm();
  double r2 = std::clamp(
      square / mean * boost::math::quantile(boost::math::chi_squared(mean * mean / square), p), lo,
      hi);
  for (int it = 0; it < 50; ++it) {
    const Cdf f = length_cdf(l, r2, rule);
    const double g = f.p - p;
    if (std::abs(g) < 1e-10) break;
    (g < 0 ? lo : hi) = r2;
    double next = f.dp > 0 ? r2 - g / f.dp : 0.5 * (lo + hi);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    if (std::abs(next - r2) <= 1e-12 * r2) {
      r2 = next;
      break;
    }
    r2 = next;
  }
  return std::sqrt(r2);
}

Eigen::Matrix<double, 3, 6> point_jacobian(const Eigen::Vector3d& P_mm) {
  // 1e-3 e x P = -1e-3 [P]x e.
  Eigen::Matrix3d Px;
  Px << 0, -P_mm.z(), P_mm.y(), P_mm.z(), 0, -P_mm.x(), -P_mm.y(), P_mm.x(), 0;
  Eigen::Matrix<double, 3, 6> H;
  H.leftCols<3>().setIdentity();
  H.rightCols<3>() = -1e-3 * Px;
  return H;
}

std::optional<Eigen::Matrix<double, 5, 1>> location_values(const AxisErrors& axis) {
  Eigen::Matrix<double, 5, 1> l;
  for (int k = 0; k < 5; ++k) {
    const std::optional<double>& v = axis.location[static_cast<std::size_t>(k)];
    if (!v) return std::nullopt;
    l(k) = *v;
  }
  return l;
}

bool same_angle(const AxisFrame& axis, double a_deg, double b_deg) {
  // A full turn's angle 360 deg apart is the same position (the per-angle model's station).
  const double apart = a_deg - b_deg;
  return std::abs(axis.full_turn() ? std::remainder(apart, 360.0) : apart) <= 1e-9;
}

const AxisErrors::AtAngle* measured_at(const AxisErrors& axis, double angle_deg) {
  const auto at = std::find_if(
      axis.measured.begin(), axis.measured.end(),
      [&](const AxisErrors::AtAngle& a) { return same_angle(axis.axis, a.angle_deg, angle_deg); });
  return at == axis.measured.end() ? nullptr : &*at;
}

PointPrediction predict_point(const AxisErrors& axis, const Pose& pose,
                              const PredictionCoverage& coverage, bool location_only) {
  PointPrediction p;
  p.pose = pose;
  p.nominal_mm = axis_rotation(axis.axis, pose.angle_deg) * pose.point_mm;
  const std::optional<Eigen::Matrix<double, 5, 1>> determined = location_values(axis);
  if (!determined) {
    p.gap = PredictionGap::kLocationNotDetermined;
    return p;
  }
  const Eigen::Matrix<double, 5, 1>& l = *determined;
  const Eigen::Matrix<double, 6, 5> G = location_motion(axis.axis, pose.angle_deg);
  const Eigen::Matrix<double, 3, 6> H = point_jacobian(p.nominal_mm);
  const AxisErrors::AtAngle* at = measured_at(axis, pose.angle_deg);
  p.location_reason =
      location_only ? LocationReason::kAsked
      : std::any_of(axis.measured_without_covariance.begin(),
                    axis.measured_without_covariance.end(),
                    [&](double a) { return same_angle(axis.axis, a, pose.angle_deg); })
          ? LocationReason::kNoMotionCovariance
          : LocationReason::kNotMeasured;
  if (!location_only && at != nullptr) {
    p.basis = PredictionBasis::kMotions;
    Vector6d c;
    for (int k = 0; k < 6; ++k) c(k) = at->component[static_cast<std::size_t>(k)];
    const Vector6d q = G * l + c;
    p.error_um = displacement_um(q, p.nominal_mm);
    p.covariance = H * at->covariance * H.transpose();
    p.after_um = displacement_um(c, p.nominal_mm);
    p.after_covariance = p.covariance;
    p.U_um = p.after_U_um = length_uncertainty(p.covariance, coverage);
  } else {
    p.basis = PredictionBasis::kLocationOnly;
    const Eigen::Matrix<double, 3, 5> HG = H * G;
    p.error_um = displacement_um(G * l, p.nominal_mm);
    p.covariance = HG * axis.location_covariance * HG.transpose();
    p.after_um.setZero();
    p.after_covariance = p.covariance;
    p.U_um = p.after_U_um = length_uncertainty(p.covariance, coverage);
  }
  return p;
}

std::vector<Pose> envelope_poses(const AxisFrame& axis, const EnvelopeGrid& grid) {
  const Eigen::Vector3d w = axis.direction(), u = axis.reference(), v = w.cross(u);
  std::vector<Pose> out;
  for (const double a : grid.angles_deg) {
    for (const double r : grid.radii_mm) {
      for (const double h : grid.heights_mm) {
        const int n = r == 0 ? 1 : std::max(1, grid.around);
        for (int k = 0; k < n; ++k) {
          const double phi = 2.0 * std::numbers::pi * k / n;
          Pose p;
          p.angle_deg = a;
          // + 0.0: a coordinate that is a sum of zeros is +0, never -0.
          p.point_mm = (r * (std::cos(phi) * u + std::sin(phi) * v) + h * w).array() + 0.0;
          out.push_back(p);
        }
      }
    }
  }
  return out;
}

EnteringJudgement judge_entering(const AxisErrors& axis, const std::vector<Pose>& poses,
                                 const std::array<bool, 5>& candidate,
                                 const PredictionCoverage& coverage) {
  EnteringJudgement j;
  Eigen::Matrix<double, 5, 1> l;
  for (int q = 0; q < 5; ++q) l(q) = axis.location[static_cast<std::size_t>(q)].value();
  // Each pose's map from the location errors to its error, and that error's U.
  std::vector<Eigen::Matrix<double, 3, 5>> A(poses.size());
  std::vector<double> U(poses.size());
  for (std::size_t p = 0; p < poses.size(); ++p) {
    const Eigen::Vector3d nominal =
        axis_rotation(axis.axis, poses[p].angle_deg) * poses[p].point_mm;
    A[p] = point_jacobian(nominal) * location_motion(axis.axis, poses[p].angle_deg);
    U[p] = length_uncertainty(A[p] * axis.location_covariance * A[p].transpose(), coverage);
  }
  // The largest error left plus its U when the values of `mask` are entered, and where.
  auto bound = [&](unsigned mask, Pose* at) {
    Eigen::Matrix<double, 5, 1> left = l;
    for (int q = 0; q < 5; ++q)
      if (mask & (1u << q)) left(q) = 0;
    double top = -1;
    for (std::size_t p = 0; p < poses.size(); ++p) {
      const double b = (A[p] * left).norm() + U[p];
      if (b > top) {
        top = b;
        if (at) *at = poses[p];
      }
    }
    return top;
  };
  for (std::size_t p = 0; p < poses.size(); ++p) {
    const double e = (A[p] * l).norm();
    if (e > j.today_um) j.today_um = e, j.today_U_um = U[p], j.today_at = poses[p];
  }
  unsigned candidates = 0;
  for (int q = 0; q < 5; ++q)
    if (candidate[static_cast<std::size_t>(q)]) candidates |= 1u << q;
  // Every non-empty set of candidates (at most 31).
  auto size = [](unsigned mask) {
    int n = 0;
    for (; mask != 0; mask &= mask - 1) ++n;
    return n;
  };
  unsigned best = 0;
  j.best_bound_um = std::numeric_limits<double>::infinity();
  for (unsigned mask = 1; mask < 32; ++mask) {
    if ((mask & ~candidates) != 0) continue;
    const double b = bound(mask, nullptr);
    if (b < j.best_bound_um || (b == j.best_bound_um && size(mask) < size(best)))
      j.best_bound_um = b, best = mask;
  }
  const unsigned entered = best != 0 && j.best_bound_um < j.today_um ? best : 0u;
  for (int q = 0; q < 5; ++q) j.enter[static_cast<std::size_t>(q)] = (entered & (1u << q)) != 0;
  j.after_bound_um = bound(entered, &j.after_at);
  for (int q = 0; q < 5; ++q) {
    if (!candidate[static_cast<std::size_t>(q)]) continue;
    j.bound_without[static_cast<std::size_t>(q)] = bound(entered & ~(1u << q), nullptr);
    j.bound_with[static_cast<std::size_t>(q)] = bound(entered | (1u << q), nullptr);
  }
  return j;
}

std::optional<ChainOrder> chain_order(const ChainErrors& chain) {
  const int n = static_cast<int>(chain.axes.size());
  if (n == 0) return std::nullopt;
  std::vector<int> carried(static_cast<std::size_t>(n), 0);
  for (const ChainErrors::Axis& a : chain.axes) {
    if (a.on < -1 || a.on >= n) return std::nullopt;
    if (a.on >= 0) ++carried[static_cast<std::size_t>(a.on)];
  }
  ChainOrder order;
  for (int i = 0; i < n; ++i) {
    const ChainErrors::Axis& a = chain.axes[static_cast<std::size_t>(i)];
    if (carried[static_cast<std::size_t>(i)] > 1) return std::nullopt;  // a fork: two chains
    if (carried[static_cast<std::size_t>(i)] != 0) continue;
    std::vector<int>& side = a.table ? order.table : order.head;
    if (!side.empty()) return std::nullopt;  // two bodies of one side that carry nothing
    // From the innermost outwards; every link on the same side, at most n of them (no loop).
    for (int k = i; k >= 0; k = chain.axes[static_cast<std::size_t>(k)].on) {
      if (static_cast<int>(side.size()) == n ||
          chain.axes[static_cast<std::size_t>(k)].table != a.table)
        return std::nullopt;
      side.push_back(k);
    }
  }
  if (static_cast<int>(order.table.size() + order.head.size()) != n) return std::nullopt;
  return order;
}

namespace {

// A point at the pose with the location errors e (5 per axis, um and urad): each axis of one
// side turned about its real line, the innermost first.
Eigen::Vector3d chain_point_mm(const ChainErrors& chain, const std::vector<int>& side,
                               const Eigen::VectorXd& e, const ChainPose& pose,
                               const Eigen::Vector3d& point_mm) {
  Eigen::Vector3d x = point_mm;
  for (const int i : side) {
    const ChainErrors::Axis& a = chain.axes[static_cast<std::size_t>(i)];
    const Eigen::Index b = 5 * i;
    const Eigen::Vector3d p = a.point_mm + 1e-3 * (e(b) * a.vector[0] + e(b + 1) * a.vector[1]);
    const Eigen::Vector3d alpha = 1e-6 * (e(b + 2) * a.vector[2] + e(b + 3) * a.vector[3]);
    const Eigen::Vector3d d = (a.direction + alpha.cross(a.direction)).normalized();
    const double zero = 1e-6 * e(b + 4) * (a.vector[4].dot(a.direction) >= 0 ? 1.0 : -1.0);
    const double angle = pose.angles_deg[static_cast<std::size_t>(i)] * std::numbers::pi / 180;
    x = p + Eigen::AngleAxisd(angle + zero, d) * (x - p);
  }
  return x;
}

// What the prediction is of, at the location errors e (mm): one side, the point where its axes
// put it; a table and a head, the tool tip's place less the workpiece point's (the linear axes'
// move, the same for both, left out).
Eigen::Vector3d chain_place_mm(const ChainErrors& chain, const ChainOrder& order,
                               const Eigen::VectorXd& e, const ChainPose& pose) {
  if (!order.both())
    return chain_point_mm(chain, order.table.empty() ? order.head : order.table, e, pose,
                          pose.point_mm);
  return chain_point_mm(chain, order.head, e, pose, *pose.tool_mm) -
         chain_point_mm(chain, order.table, e, pose, pose.point_mm);
}

}  // namespace

ChainPointPrediction predict_chain_point(const ChainErrors& chain, const ChainOrder& order,
                                         const ChainPose& pose,
                                         const PredictionCoverage& coverage) {
  ChainPointPrediction r;
  r.pose = pose;
  const Eigen::Index m = 5 * static_cast<Eigen::Index>(chain.axes.size());
  Eigen::VectorXd e = Eigen::VectorXd::Zero(m);
  std::vector<bool> known(static_cast<std::size_t>(m));
  for (std::size_t i = 0; i < chain.axes.size(); ++i)
    for (std::size_t q = 0; q < 5; ++q) {
      known[5 * i + q] = chain.axes[i].location[q].has_value();
      e(static_cast<Eigen::Index>(5 * i + q)) = chain.axes[i].location[q].value_or(0.0);
    }
  if (order.both() != pose.tool_mm.has_value())
    throw std::invalid_argument(order.both() ? "a table and a head: the pose needs the tool tip"
                                             : "one side: the pose has no tool tip");
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(m);
  const std::vector<int>& work = order.table.empty() ? order.head : order.table;
  r.nominal_mm = chain_point_mm(chain, work, zero, pose, pose.point_mm);
  Eigen::Matrix<double, 3, Eigen::Dynamic> J(3, m);
  constexpr double h = 1e-3;
  for (Eigen::Index c = 0; c < m; ++c) {
    Eigen::VectorXd up = e, down = e;
    up(c) += h, down(c) -= h;
    J.col(c) = 1e3 *
               (chain_place_mm(chain, order, up, pose) - chain_place_mm(chain, order, down, pose)) /
               (2 * h);
    if (!known[static_cast<std::size_t>(c)] && J.col(c).norm() > 1e-9) r.determined = false;
  }
  if (!r.determined) return r;
  // Each side's displacement once; a table and a head: the tool tip's less the point's.
  const Eigen::Vector3d work_um =
      1e3 * (chain_point_mm(chain, work, e, pose, pose.point_mm) - r.nominal_mm);
  if (order.both()) {
    r.tool_um = 1e3 * (chain_point_mm(chain, order.head, e, pose, *pose.tool_mm) -
                       chain_point_mm(chain, order.head, zero, pose, *pose.tool_mm));
    r.workpiece_um = work_um;
    r.error_um = *r.tool_um - work_um;
  } else {
    r.error_um = work_um;
  }
  r.covariance = J * chain.covariance * J.transpose();
  r.U_um = length_uncertainty(r.covariance, coverage);
  return r;
}

}  // namespace dbbkit
