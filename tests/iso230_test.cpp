// ISO 230-7 location errors and component error motions, checked against the exact
// two-ball geometry of a real axis: displaced by o, tilted by alpha, its zero at c0, with
// constant parts and component motions added, readings simulated exactly (not by the
// first-order model the mapping rests on), identified, then mapped.

#include "dbbkit/iso230.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <boost/math/distributions/normal.hpp>
#include <cmath>
#include <cstdio>
#include <random>

#include "dbbkit/identify.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/result_io.hpp"
#include "dbbkit/kinematics.hpp"
#include "dbbkit/simulate.hpp"
#include "test_util.hpp"

namespace dbbkit {
namespace {

struct AxisTruth {
  Eigen::Vector3d o = Eigen::Vector3d::Zero();      // um, perpendicular to the axis
  Eigen::Vector3d alpha = Eigen::Vector3d::Zero();  // urad, perpendicular to the axis
  double c0 = 0;                                    // urad
  Vector6d constant = Vector6d::Zero();             // d0 (um), e0 (urad, perpendicular to the axis)
  double component_um = 0, component_urad = 0;      // amplitudes of the component motions
  std::array<double, 24> phases{};
};

// The component motions of the truth at angles g (deg): harmonics 2 and 3 of every error;
// for C also the once-per-turn term turning against the axis (u cos g + v sin g,
// v cos g - u sin g for the two perpendicular errors of a block). Neither is a location
// pattern over a whole turn. Over B's part of a turn they are not orthogonal to the
// location patterns: there their least-squares part on the constants and the location
// patterns (the docs' derivation: d0 + (I - R) o, e0 + c0 a + (I - R) alpha) is removed,
// as the axis average line is the least-squares line (ISO 230-7).
std::vector<Vector6d> component_motions(const AxisFrame& axis, const AxisTruth& t,
                                        const std::vector<double>& g_deg) {
  const int n = static_cast<int>(g_deg.size());
  std::vector<Vector6d> out(n, Vector6d::Zero());
  for (int i = 0; i < n; ++i) {
    const double g = g_deg[i] * M_PI / 180.0;
    for (int k = 0; k < 6; ++k) {
      const double amp = k < 3 ? t.component_um : t.component_urad;
      out[i](k) += amp * (std::cos(2 * g + t.phases[k]) + 0.5 * std::sin(3 * g + t.phases[6 + k]));
    }
    if (axis == test::kAxisC) {
      for (int b = 0; b < 2; ++b) {
        const double amp = b == 0 ? t.component_um : t.component_urad;
        const double u = amp * std::cos(t.phases[12 + b]), v = amp * std::sin(t.phases[12 + b]);
        out[i](3 * b) += u * std::cos(g) + v * std::sin(g);
        out[i](3 * b + 1) += v * std::cos(g) - u * std::sin(g);
      }
    }
  }
  if (axis == test::kAxisB) {
    for (int b = 0; b < 2; ++b) {
      Eigen::MatrixXd X = Eigen::MatrixXd::Zero(3 * n, 5);
      Eigen::VectorXd y(3 * n);
      for (int i = 0; i < n; ++i) {
        const Eigen::Matrix3d IR =
            Eigen::Matrix3d::Identity() - axis_rotation(test::kAxisB, g_deg[i]);
        for (int k = 0; k < 3; ++k) {
          const int r = 3 * i + k;
          if (b == 0) {
            X(r, k) = 1;  // d0
          } else {
            X(r, 0) = k == 0;  // e0 about x
            X(r, 1) = k == 2;  // e0 about z
            X(r, 2) = k == 1;  // c0 about the axis y
          }
          X(r, 3) = IR(k, 0);  // o or alpha along x
          X(r, 4) = IR(k, 2);  // along z
          y(r) = out[i](3 * b + k);
        }
      }
      const Eigen::VectorXd fit = X * X.colPivHouseholderQr().solve(y);
      for (int i = 0; i < n; ++i) {
        for (int k = 0; k < 3; ++k) out[i](3 * b + k) -= fit(3 * i + k);
      }
    }
  }
  return out;
}

// The error motion (d [um], e [urad] as the XYZ angles of exact_reading_um) of the real
// axis at commanded angle g: P = o + Q (P0 - o), Q the rotation by g + c0 about the
// tilted axis, against the nominal R(g) P0: R_err = Q R', d_err = (I - Q) o. Then the
// constant parts and the component motions.
Vector6d error_motion(const AxisFrame& axis, const AxisTruth& t, double g_deg,
                      const Vector6d& component) {
  const Eigen::Vector3d a =
      axis == test::kAxisC ? Eigen::Vector3d::UnitZ() : Eigen::Vector3d::UnitY();
  const Eigen::Vector3d alpha = 1e-6 * t.alpha;
  const Eigen::Matrix3d tilt =
      alpha.norm() > 0 ? Eigen::AngleAxisd(alpha.norm(), alpha.normalized()).toRotationMatrix()
                       : Eigen::Matrix3d::Identity();
  const Eigen::Vector3d n = tilt * a;
  const double g = g_deg * M_PI / 180.0;
  const Eigen::Matrix3d Q = Eigen::AngleAxisd(g + 1e-6 * t.c0, n).toRotationMatrix();
  const Eigen::Matrix3d R = axis_rotation(axis, g_deg);
  const Eigen::Matrix3d Rerr = Q * R.transpose();
  // Rerr = Rx(ex) Ry(ey) Rz(ez) (exact_reading_um's order), solved for the small angles.
  const Eigen::Vector3d e(std::atan2(-Rerr(1, 2), Rerr(2, 2)), std::asin(Rerr(0, 2)),
                          std::atan2(-Rerr(0, 1), Rerr(0, 0)));
  Vector6d out;
  out.head<3>() = (Eigen::Matrix3d::Identity() - Q) * t.o;
  out.tail<3>() = 1e6 * e;
  return out + t.constant + component;
}

AxisTruth random_truth(const AxisFrame& axis, std::mt19937_64& rng, bool components) {
  std::uniform_real_distribution<double> u(-1, 1), phase(0, 2 * M_PI);
  AxisTruth t;
  const int p1 = 0, p2 = axis == test::kAxisC ? 1 : 2, ax = axis == test::kAxisC ? 2 : 1;
  t.o(p1) = 20 * u(rng);
  t.o(p2) = 20 * u(rng);
  t.alpha(p1) = 50 * u(rng);
  t.alpha(p2) = 50 * u(rng);
  t.c0 = 30 * u(rng);
  for (int k = 0; k < 3; ++k) t.constant(k) = 5 * u(rng);
  t.constant(3 + p1) = 10 * u(rng);
  t.constant(3 + p2) = 10 * u(rng);
  (void)ax;
  if (components) {
    t.component_um = 2 + 2 * u(rng);
    t.component_urad = 10 + 5 * u(rng);
  }
  for (double& p : t.phases) p = phase(rng);
  return t;
}

// The measured positions of d (360 is the position 0).
std::vector<double> positions(const Design& d) {
  std::vector<double> g;
  for (double a : d.angles_deg) g.push_back(d.axis == test::kAxisC ? std::fmod(a, 360.0) : a);
  return g;
}

Truth exact_truth(const Design& d, const AxisTruth& at) {
  Truth t;
  t.model = {ErrorModel::Kind::kPerAngle, 0};
  const std::vector<double> g = positions(d);
  const std::vector<Vector6d> comp = component_motions(d.axis, at, g);
  for (size_t i = 0; i < g.size(); ++i)
    test::add_truth_value(t, d.axis, d.angles_deg[i], error_motion(d.axis, at, g[i], comp[i]));
  t.exact = true;
  t.bar_mm = 150;
  return t;
}

std::array<double, 5> location_of(const AxisFrame& axis, const AxisTruth& t) {
  const int p1 = 0, p2 = axis == test::kAxisC ? 1 : 2;
  return {t.o(p1), t.o(p2), t.alpha(p1), t.alpha(p2), t.c0};
}

// Over `cases` random axes on design d: the share of location errors whose interval
// value +- 3 u holds the truth, and of component motions (zero for a pure location error)
// likewise; both asserted >= 0.99. With component motions, on the first `range_cases`
// axes, the share of error motion values whose interval holds the true range (asserted
// >= the coverage probability 0.95: the interval's coverage is at least that). Also a
// noise-free case: first order only.
void check_recovery(const Design& d, int cases, bool components, std::uint64_t seed,
                    int range_cases = 0) {
  std::mt19937_64 rng(seed);
  const Parameterisation param(d);
  int held = 0, held1 = 0, checked = 0, comp_held = 0, comp_checked = 0, range_held = 0,
      range_checked = 0;
  double worst_noise_free = 0, width = 0;
  IdentifyOptions no_ranges;
  no_ranges.iso_motion.enabled = false;
  IsoMotionOptions ranges;
  ranges.enabled = false;
  std::vector<double> g;  // the stations' angles (C: 360 is the station 0)
  for (int st = 0; st < param.n_stations(); ++st) g.push_back(param.station_angle_deg(st));
  for (int c = 0; c < cases; ++c) {
    const AxisTruth at = random_truth(d.axis, rng, components);
    const Truth truth = exact_truth(d, at);
    const std::vector<Vector6d> comp = component_motions(d.axis, at, g);
    const IdentifyResult r = identify(d, simulate(d, truth, 500 + c), no_ranges);
    ranges.enabled = c < range_cases;
    ranges.seed = 100 + c;
    const IsoResult iso = iso230_quantities(d, r.param, r.estimate, 1.0, ranges);
    ASSERT_TRUE(iso.gaps.empty()) << io::iso_gaps_note(iso);
    const std::array<double, 5> want = location_of(d.axis, at);
    for (int j = 0; j < 5; ++j) {
      ASSERT_TRUE(iso.location[j].value.determined) << iso.location[j].name;
      ++checked;
      held += std::abs(iso.location[j].value.value - want[j]) <= 3 * iso.location[j].value.std;
      held1 += std::abs(iso.location[j].value.value - want[j]) <= iso.location[j].value.std;
    }
    ASSERT_EQ(iso.components.size(), g.size());
    for (size_t i = 0; i < g.size(); ++i) {
      for (int e = 0; e < 6; ++e) {
        const Determined& m = iso.components[i].motions[e];
        if (!m.determined) continue;
        ++comp_checked;
        comp_held += std::abs(m.value - comp[i](e)) <= 3 * m.std;
      }
    }
    for (int e = 0; e < 6 && ranges.enabled; ++e) {
      const IsoMotionValue& v = iso.motion_values.values[e];
      ASSERT_TRUE(v.computed) << v.component << ": " << static_cast<int>(v.gap);
      double lo = comp[0](e), hi = comp[0](e);
      for (const Vector6d& x : comp) {
        lo = std::min(lo, x(e));
        hi = std::max(hi, x(e));
      }
      ++range_checked;
      range_held += v.low <= hi - lo && hi - lo <= v.high;
      width += v.U / v.value;
    }
    if (c == 0) {  // the same axis without noise: the mapping is exact to first order
      Truth quiet = truth;
      quiet.noiseless = true;
      const IdentifyResult q = identify(d, simulate(d, quiet, 1), no_ranges);
      const IsoResult qi = iso230_quantities(d, q.param, q.estimate, 1.0, IsoMotionOptions{false});
      for (int j = 0; j < 5; ++j)
        worst_noise_free =
            std::max(worst_noise_free, std::abs(qi.location[j].value.value - want[j]));
    }
  }
  std::printf(
      "%s design %s, %d axes%s: %d of %d location errors within 3 u (%d within 1 u); component "
      "motions "
      "within 3 u: %d of %d; error motion values held by their interval: %d of %d (U / value %.2f "
      "on "
      "average); noise-free: largest difference %.2e (um, urad)\n",
      d.axis == test::kAxisC ? "C" : "B", d.name.c_str(), cases,
      components ? " with component motions" : "", held, checked, held1, comp_held, comp_checked,
      range_held, range_checked, range_checked ? width / range_checked : 0.0, worst_noise_free);
  // The uncertainty is the right size, not only large enough: about 68 % within 1 u.
  EXPECT_NEAR(static_cast<double>(held1) / checked, 0.6827, 0.09) << held1 << " of " << checked;
  EXPECT_GE(held, 0.99 * checked) << held << " of " << checked;
  EXPECT_GE(comp_held, 0.99 * comp_checked) << comp_held << " of " << comp_checked;
  EXPECT_GE(range_held, 0.95 * range_checked) << range_held << " of " << range_checked;
  EXPECT_LT(worst_noise_free, 0.02);
}

TEST(Iso230, LocationErrorsOfARealCAxisComeBackWithinTheirUncertainty) {
  check_recovery(test::paper_design('C'), 100, true, 11, 40);
  check_recovery(test::paper_design('C'), 60, false, 12);
}

TEST(Iso230, LocationErrorsOfARealBAxisComeBackWithinTheirUncertainty) {
  // The optimised B design with its off-axis position (every error determined), over its
  // part of a turn: location errors, constant parts and component motions, then pure
  // location errors and constant parts.
  // The readings are simulated without set-up errors, so the design's declared set-up
  // tolerances are left out: the intervals checked are the noise's (68 % within 1 u).
  Design b = io::read_design_file(test::source_path("designs/b-head-kit-optimized.json"));
  b.setup_std = {};
  check_recovery(b, 100, true, 14, 40);
  check_recovery(b, 60, false, 13);
}

// An upper bound on U that needs no correlation: range(eps) <= 2 max_i |eps_i|, and
// P(max_i |eps_i| > t) <= sum_i P(|eps_i| > t) (Bonferroni), so with t solving
// sum_i 2 (1 - Phi(t / u_i)) = 1 - p, the p-quantile of range(eps) is at most 2 t. Checked
// with the components' own stated u on a design without and one with declared set-up
// tolerances (the low-rank part of the covariance).
TEST(Iso230, ErrorMotionValueUIsBoundedByTheComponentsUncertainties) {
  for (const char* file :
       {"designs/paper-c-turntable.json", "designs/c-turntable-kit-optimized-with-setup.json"}) {
    const Design d = io::read_design_file(test::source_path(file));
    const Truth truth = exact_truth(d, AxisTruth{});
    const IdentifyResult r = identify(d, simulate(d, truth, 21));
    ASSERT_EQ(std::string(file).find("with-setup") != std::string::npos, r.setup_included) << file;
    for (int e = 0; e < 6; ++e) {
      const IsoMotionValue& v = r.iso.motion_values.values[e];
      ASSERT_TRUE(v.computed) << file << " " << v.component << ": " << static_cast<int>(v.gap);
      std::vector<double> u;
      for (const IsoComponentsAtAngle& a : r.iso.components) u.push_back(a.motions[e].std);
      const boost::math::normal n01;
      auto tail = [&](double t) {
        double s = 0;
        for (double ui : u) s += 2 * boost::math::cdf(boost::math::complement(n01, t / ui));
        return s;
      };
      double lo = 0, hi = 100 * *std::max_element(u.begin(), u.end());
      for (int it = 0; it < 200; ++it) {
        const double mid = 0.5 * (lo + hi);
        (tail(mid) > 1 - r.iso.motion_values.coverage_probability ? lo : hi) = mid;
      }
      EXPECT_LE(v.U, 2 * hi) << file << " " << v.component;
      EXPECT_GT(v.U, 0.0) << file << " " << v.component;
    }
  }
}

TEST(Iso230, NamesAndUndeterminedBlocks) {
  const Design c = test::paper_design('C');
  const Truth t = exact_truth(c, AxisTruth{});
  const IdentifyResult r = identify(c, simulate(c, t, 3));
  const IsoResult iso = iso230_quantities(c, r.param, r.estimate);
  ASSERT_EQ(iso.location.size(), 5u);
  const char* names[] = {"X0C", "Y0C", "A0C", "B0C", "C0C"};
  for (int j = 0; j < 5; ++j) EXPECT_EQ(iso.location[j].name, names[j]);
  EXPECT_EQ(iso.component_names[5], "ECC");
  EXPECT_EQ(iso.constants[4].name, "constant part of ey");
  // The paper's B design reads on the tool axis only: the rotations about x and z are not
  // determined at most angles, and the block says so instead of printing a number.
  const Design b = test::paper_design('B');
  const IdentifyResult rb = identify(b, simulate(b, exact_truth(b, AxisTruth{}), 3));
  const IsoResult ib = iso230_quantities(b, rb.param, rb.estimate);
  EXPECT_EQ(ib.location[0].name, "X0B");
  EXPECT_EQ(ib.location[4].name, "B0B");
  EXPECT_FALSE(ib.location[2].value.determined);
  ASSERT_FALSE(ib.gaps.empty());
  EXPECT_EQ(ib.gaps.back().block, 1);
  EXPECT_LT(ib.gaps.back().rank, 5);
  EXPECT_NE(io::iso_gaps_note(ib).find("rotations"), std::string::npos) << io::iso_gaps_note(ib);
}

}  // namespace
}  // namespace dbbkit
