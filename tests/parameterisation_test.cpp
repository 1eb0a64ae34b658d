#include "dbbkit/parameterisation.hpp"

#include <gtest/gtest.h>

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
  d.errors = {ErrorModel::Kind::Legendre, 2};
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
  d.errors = {ErrorModel::Kind::Fourier, 2};
  const Parameterisation p(d);
  EXPECT_EQ(p.n_parameters(), 30);
  EXPECT_EQ(p.parameter_name(5 * 5 + 4), "ez.sin2");
  // Row k of the map at an angle holds the basis in the block of error k.
  const Eigen::MatrixXd E = p.error_map_at_angle(40);
  EXPECT_TRUE(test::near(E.block(2, 10, 1, 5).transpose(), fourier_basis(2, 40), 0.0));
  EXPECT_DOUBLE_EQ(E.block(2, 0, 1, 10).cwiseAbs().sum(), 0.0);
}

}  // namespace
}  // namespace dbbkit
