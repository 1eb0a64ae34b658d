#include "dbbkit/parameterisation.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "dbbkit/kinematics.hpp"
#include "test_util.hpp"

namespace dbbkit {
namespace {

TEST(Parameterisation, TurntableFullTurnIsOneStation) {
  const Design d = test::paper_design('C');
  const Parameterisation p(d);
  EXPECT_EQ(p.n_stations(), 18);  // 0..360 step 20: 19 angles, 360 repeats 0
  EXPECT_EQ(p.n_parameters(), 108);
  EXPECT_EQ(p.station_of(360.0), 0);
  EXPECT_EQ(p.station_of(0.0), 0);
  EXPECT_EQ(p.station_of(-20.0), p.station_of(340.0));
  EXPECT_EQ(p.station_of(25.0), -1);
  EXPECT_EQ(p.parameter_name(6 * 2 + 5), "ez@40");
}

TEST(Parameterisation, SwingingHeadStationsAreDistinct) {
  const Parameterisation p(test::paper_design('B'));
  EXPECT_EQ(p.n_stations(), 21);
  EXPECT_EQ(p.station_of(-100.0), 0);
  EXPECT_EQ(p.station_of(260.0), -1);  // no wrap-around for a swinging head
}

TEST(Parameterisation, PerAngleMapSelectsTheStationsColumns) {
  const Parameterisation p(test::paper_design('C'));
  const Eigen::MatrixXd E = p.error_map(3);
  EXPECT_TRUE(test::near(E.middleCols(18, 6), Eigen::MatrixXd::Identity(6, 6), 0.0));
  EXPECT_DOUBLE_EQ(E.cwiseAbs().sum(), 6.0);
}

TEST(Parameterisation, LegendreBasisHandValues) {
  // P2 = (3x^2 - 1)/2, P3 = (5x^3 - 3x)/2.
  for (double x : {-1.0, -0.3, 0.0, 0.5, 1.0}) {
    const Eigen::VectorXd f = legendre_basis(3, x);
    EXPECT_DOUBLE_EQ(f(0), 1.0);
    EXPECT_DOUBLE_EQ(f(1), x);
    EXPECT_NEAR(f(2), (3 * x * x - 1) / 2, 1e-15);
    EXPECT_NEAR(f(3), (5 * x * x * x - 3 * x) / 2, 1e-15);
  }
  Design d = test::paper_design('B');
  d.errors = {ErrorModel::Kind::kLegendre, 2};
  const Parameterisation p(d);
  EXPECT_EQ(p.n_parameters(), 18);
  EXPECT_TRUE(test::near(p.series_basis(-100), legendre_basis(2, -1), 1e-15));
  EXPECT_TRUE(test::near(p.series_basis(-50), legendre_basis(2, 0), 1e-15));
  EXPECT_TRUE(test::near(p.series_basis(0), legendre_basis(2, 1), 1e-15));
  EXPECT_EQ(p.parameter_name(17), "ez.P2");
}

TEST(Parameterisation, FourierBasisHandValues) {
  const Eigen::VectorXd f = fourier_basis(2, 90.0);
  Eigen::VectorXd expected(5);
  expected << 1, 0, 1, -1, 0;  // 1, cos 90, sin 90, cos 180, sin 180
  EXPECT_TRUE(test::near(f, expected, 0.0));
  Design d = test::paper_design('C');
  d.errors = {ErrorModel::Kind::kFourier, 2};
  const Parameterisation p(d);
  EXPECT_EQ(p.n_parameters(), 30);
  EXPECT_EQ(p.parameter_name(5 * 5 + 4), "ez.sin2");
  // Row k of the map at an angle holds the basis in the block of error k.
  const Eigen::MatrixXd E = p.error_map_at_angle(40);
  EXPECT_TRUE(test::near(E.block(2, 10, 1, 5).transpose(), fourier_basis(2, 40), 0.0));
  EXPECT_DOUBLE_EQ(E.block(2, 0, 1, 10).cwiseAbs().sum(), 0.0);
}

// The series written out by hand from each parameter's name (dx.c0, dx.cos2, ey.sin3, ez.P2):
// the error map at an angle is the derivative of those six sums with respect to theta.
TEST(Parameterisation, ErrorMapIsTheDerivativeOfTheSeriesWrittenOut) {
  const double pi = std::acos(-1.0);
  for (char which : {'C', 'B'}) {
    Design d = test::paper_design(which);
    d.errors = {which == 'C' ? ErrorModel::Kind::kFourier : ErrorModel::Kind::kLegendre, 3};
    const Parameterisation p(d);
    auto hand_basis = [&](int j, double angle_deg) {
      const std::string name = p.parameter_name(j);
      const std::string term = name.substr(name.find('.') + 1);
      if (term == "c0") return 1.0;
      const double g = angle_deg * pi / 180.0;
      if (term.rfind("cos", 0) == 0) return std::cos(std::stoi(term.substr(3)) * g);
      if (term.rfind("sin", 0) == 0) return std::sin(std::stoi(term.substr(3)) * g);
      const double x =
          2 * (angle_deg - p.range_min_deg()) / (p.range_max_deg() - p.range_min_deg()) - 1;
      switch (std::stoi(term.substr(1))) {
        case 0:
          return 1.0;
        case 1:
          return x;
        case 2:
          return (3 * x * x - 1) / 2;
        default:
          return (5 * x * x * x - 3 * x) / 2;
      }
    };
    auto error_of = [&](int j) {
      const std::string name = p.parameter_name(j);
      const std::string error = name.substr(0, name.find('.'));
      for (int k = 0; k < 6; ++k) {
        if (error == kErrorNames[k]) return k;
      }
      ADD_FAILURE() << "unknown error in " << name;
      return 0;
    };
    for (double a : {-100.0, -37.5, 0.0, 12.0, 90.0, 200.0}) {
      if (which == 'B' && (a < p.range_min_deg() || a > p.range_max_deg())) continue;
      auto errors = [&](const Eigen::VectorXd& theta) {
        Eigen::VectorXd e = Eigen::VectorXd::Zero(6);
        for (int j = 0; j < p.n_parameters(); ++j) e(error_of(j)) += theta(j) * hand_basis(j, a);
        return e;
      };
      EXPECT_TRUE(test::jacobian_matches(errors, Eigen::VectorXd::Zero(p.n_parameters()),
                                         p.error_map_at_angle(a), 1.0, 1e-12))
          << which << " at " << a << " deg";
    }
  }
}

}  // namespace
}  // namespace dbbkit
