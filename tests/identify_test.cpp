#include "dbbkit/identify.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "../src/wls_solver.hpp"
#include "dbbkit/io/result_io.hpp"
#include "dbbkit/simulate.hpp"
#include "dbbkit/uncertainty.hpp"
#include "test_util.hpp"

namespace dbbkit {
namespace {

using test::kPi;

// The paper's B head plus a third ball off the tool axis (model.md §4): radial and tangential.
Design b_head_with_offset() {
  Design d = test::paper_design('B');
  for (auto dir : {Direction::Kind::kRadial, Direction::Kind::kTangential}) {
    Installation in;
    in.id = dir == Direction::Kind::kRadial ? "3r" : "3t";
    in.L_mm = 150;
    in.D_mm = 60;
    in.direction = Direction::named(test::kAxisB, dir);
    if (dir == Direction::Kind::kRadial) in.sign = -1;  // the table ball beyond the tool tip
    d.installations.push_back(in);
  }
  return d;
}

// The same head turned into an A head in the general form: about +X, the spindle pointing down
// (-Z); the "B" shorthand's D (along its axis) is the general form's H.
Design a_head_with_offset() {
  Design d = b_head_with_offset();
  d.axis = AxisFrame::general('A', AxisFrame::Side::kHead, Eigen::Vector3d::UnitX(),
                              -Eigen::Vector3d::UnitZ(), false);
  for (Installation& in : d.installations) {
    std::swap(in.D_mm, in.H_mm);
    in.direction = Direction::named(d.axis, in.direction.kind);
  }
  validate_design(d);
  return d;
}

Truth random_model_truth(const Design& d, std::mt19937_64& rng) {
  std::normal_distribution<double> n01;
  Truth t;
  t.model = d.errors;
  if (d.errors.kind == ErrorModel::Kind::kPerAngle) {
    for (double a : d.angles_deg) {
      Vector6d e;
      for (int k = 0; k < 6; ++k) e(k) = (k < 3 ? 10.0 : 30.0) * n01(rng);
      test::add_truth_value(t, d.axis, a, e);
    }
  } else {
    const int m =
        d.errors.kind == ErrorModel::Kind::kFourier ? 2 * d.errors.order + 1 : d.errors.order + 1;
    for (int k = 0; k < 6; ++k) {
      for (int c = 0; c < m; ++c) t.coefficients[k].push_back((k < 3 ? 10.0 : 30.0) * n01(rng));
    }
    if (d.errors.kind == ErrorModel::Kind::kLegendre) {
      const auto [lo, hi] = std::minmax_element(d.angles_deg.begin(), d.angles_deg.end());
      t.range_deg = std::make_pair(*lo, *hi);
    }
  }
  return t;
}

// The first-order bias bound of a series model (the tiles of src/series_l1.cpp) against its
// definition on the dense gain: the largest t |c'G|_1 / u_c over the budget's values, named
// where a sequential scan of the values takes it (a later value must exceed by 1e-9).
TEST(Identify, SeriesBiasBoundIsTheLargestOverTheDenseGain) {
  Design d = test::paper_design('C');
  d.errors = {ErrorModel::Kind::kFourier, 16};  // blocks of >= 32 columns: the implicit gain
  d.angles_deg.clear();
  for (int i = 0; i < 75; ++i) d.angles_deg.push_back(360.0 * i / 75);  // 2 tiles and a tail
  std::mt19937_64 rng(5);
  const IdentifyResult r = identify(d, simulate(d, random_model_truth(d, rng), 3));
  ASSERT_FALSE(r.setup_included);
  ASSERT_TRUE(r.solver->J_theta_reading().series_l1());
  ASSERT_TRUE(r.first_order.computed);
  ASSERT_TRUE(r.first_order.bias_bound_std);
  ASSERT_EQ(r.budget.values.size(), 6u * 75u);
  const Eigen::MatrixXd CG = test::dense(budget_functions(r.param, r.budget)) *
                             test::dense(r.solver->J_theta_reading().sparse());
  double largest = -1;
  std::size_t place = 0;
  for (std::size_t v = 0; v < r.budget.values.size(); ++v) {
    const double ratio = r.first_order.largest_term_um *
                         CG.row(static_cast<Eigen::Index>(v)).lpNorm<1>() / r.budget.values[v].u_c;
    if (ratio > largest * (1.0 + 1e-9)) largest = ratio, place = v;
  }
  EXPECT_NEAR(*r.first_order.bias_bound_std, largest, 1e-9 * largest);
  EXPECT_EQ(r.first_order.bias_error, r.budget.values[place].error);
  EXPECT_EQ(r.first_order.bias_angle_deg, r.budget.values[place].angle_deg);
}

// model.md §4: both balls on the tool axis; the rotation about it, ex sin b + ez cos b, is
// unobservable at every angle; at b = 0 only ez is undetermined, at b = -90 only ex.
TEST(Identify, PaperBHeadHasRankFivePerAngleAndNamesTheToolAxis) {
  const Design d = test::paper_design('B');
  std::mt19937_64 rng(11);
  const IdentifyResult r = identify(d, simulate(d, random_model_truth(d, rng), 5));
  EXPECT_EQ(r.estimate.status, EstimateStatus::kRankDeficient);
  EXPECT_EQ(r.estimate.n_unknowns, 126);
  EXPECT_EQ(r.estimate.rank, 105);  // 5 per angle, 21 angles
  ASSERT_EQ(r.errors.size(), 21u);
  for (const ErrorsAtAngle& ea : r.errors) {
    for (int k : {0, 1, 2, 4})
      EXPECT_TRUE(ea.errors[k].determined) << ea.angle_deg << " " << kErrorNames[k];
    EXPECT_EQ(ea.errors[3].determined, ea.angle_deg == 0.0) << "ex at " << ea.angle_deg;
    EXPECT_EQ(ea.errors[5].determined, ea.angle_deg == -90.0) << "ez at " << ea.angle_deg;
  }
  ASSERT_EQ(r.unidentifiable.size(), 21u);
  for (const Unidentifiable& u : r.unidentifiable) {
    ASSERT_TRUE(u.angle_deg.has_value());
    const double b = *u.angle_deg * kPi / 180;
    double ex = 0, ez = 0;
    for (const auto& [name, c] : u.terms) {
      if (name == "ex")
        ex = c;
      else if (name == "ez")
        ez = c;
      else
        ADD_FAILURE() << "unexpected term " << name << " at " << *u.angle_deg;
    }
    // Parallel to (sin b, cos b) on (ex, ez).
    EXPECT_NEAR(std::abs(ex * std::cos(b) - ez * std::sin(b)), 0.0, 1e-9) << *u.angle_deg;
    EXPECT_NEAR(ex * ex + ez * ez, 1.0, 1e-9);
    ASSERT_TRUE(u.motion);
    EXPECT_TRUE(u.motion->tool_axis) << io::unidentifiable_interpretation(u);
  }
}

TEST(Identify, LateralOffsetBallRestoresFullRank) {
  const Design d = b_head_with_offset();
  std::mt19937_64 rng(12);
  const IdentifyResult r = identify(d, simulate(d, random_model_truth(d, rng), 6));
  EXPECT_EQ(r.estimate.status, EstimateStatus::kFullRank);
  EXPECT_EQ(r.estimate.rank, 126);
  EXPECT_TRUE(r.unidentifiable.empty());
}

TEST(Identify, NoiselessDataGiveTheTruthBack) {
  std::mt19937_64 rng(13);
  for (int config = 0; config < 3; ++config) {
    Design d = config == 1 ? b_head_with_offset() : test::paper_design('C');
    if (config == 2) d.errors = {ErrorModel::Kind::kFourier, 3};
    Truth t = random_model_truth(d, rng);
    t.noiseless = true;
    const IdentifyResult r = identify(d, simulate(d, t, 0));
    EXPECT_LT(r.estimate.rms_um, 1e-9);
    for (const ErrorsAtAngle& ea : r.errors) {
      const Vector6d truth = truth_errors(t, d.axis, ea.angle_deg);
      for (int k = 0; k < 6; ++k) {
        ASSERT_TRUE(ea.errors[k].determined);
        EXPECT_NEAR(ea.errors[k].value, truth(k), 1e-8)
            << config << " " << ea.angle_deg << " " << kErrorNames[k];
      }
    }
  }
}

TEST(Identify, MissingAngleLeavesItsErrorsUndetermined) {
  const Design d = test::paper_design('C');
  std::mt19937_64 rng(14);
  std::vector<Reading> readings = simulate(d, random_model_truth(d, rng), 7);
  std::erase_if(readings, [](const Reading& r) { return r.angle_deg == 40.0; });
  const IdentifyResult r = identify(d, readings);
  EXPECT_EQ(r.estimate.rank, 102);
  ASSERT_EQ(r.unidentifiable.size(), 6u);
  for (const ErrorsAtAngle& ea : r.errors) {
    for (int k = 0; k < 6; ++k) EXPECT_EQ(ea.errors[k].determined, ea.angle_deg != 40.0);
  }
  for (const Unidentifiable& u : r.unidentifiable) EXPECT_EQ(u.angle_deg.value_or(-1), 40.0);
}

// Property: simulate from random truths and seeds, identify; the truth lies within
// +-3 sigma for the binomial share of 99.73% of the determined values, the
// standardised errors have unit variance, and nothing undetermined has a number.
struct CoverageCase {
  const char* name;
  // 0 paper C, 1 paper B, 2 B with offset, 3 C Fourier 3, 4 B-offset Legendre 2, 5 the A axis
  // of an A/C trunnion (designs/a-trunnion.json), 6 the B head with offset turned into an A head
  int config;
  NoiseModel::Distribution noise;
};

class Coverage : public ::testing::TestWithParam<CoverageCase> {};

TEST_P(Coverage, TruthWithinThreeSigma) {
  const CoverageCase& c = GetParam();
  Design d = c.config == 0 || c.config == 3 ? test::paper_design('C')
             : c.config == 1                ? test::paper_design('B')
             : c.config == 5 ? io::read_design_file(test::source_path("designs/a-trunnion.json"))
             : c.config == 6 ? a_head_with_offset()
                             : b_head_with_offset();
  if (c.config == 3) d.errors = {ErrorModel::Kind::kFourier, 3};
  if (c.config == 4) d.errors = {ErrorModel::Kind::kLegendre, 2};
  if (c.noise == NoiseModel::Distribution::kNormal) {
    d.noise.distribution = NoiseModel::Distribution::kNormal;
    d.noise.std_um = 0.5;
  }
  std::mt19937_64 rng(1000 + c.config);
  const int draws = 200;
  double inside = 0, total = 0, z2 = 0, undetermined = 0;
  int blocks = 0;
  for (int i = 0; i < draws; ++i) {
    const Truth t = random_model_truth(d, rng);
    const IdentifyResult r = identify(d, simulate(d, t, 100 + i));
    for (const ErrorsAtAngle& ea : r.errors) {
      const Vector6d truth = truth_errors(t, d.axis, ea.angle_deg);
      for (int k = 0; k < 6; ++k) {
        const Determined& e = ea.errors[k];
        if (!e.determined) {
          ++undetermined;
          continue;
        }
        ASSERT_TRUE(std::isfinite(e.value) && std::isfinite(e.std) && e.std > 0);
        const double z = (e.value - truth(k)) / e.std;
        inside += std::abs(z) <= 3.0;
        z2 += z * z;
        ++total;
      }
    }
    // Independent blocks: stations of a per-angle model, whole data sets of a series.
    blocks += d.errors.kind == ErrorModel::Kind::kPerAngle ? static_cast<int>(r.errors.size()) : 1;
  }
  const double share = inside / total;
  EXPECT_GE(share, 0.98) << c.name;
  // Binomial tolerance on the share, counted over independent blocks (values within a block
  // correlate).
  EXPECT_TRUE(test::within_binomial(share * blocks, blocks, 0.9973, 4.0))
      << c.name << " share " << share;
  EXPECT_NEAR(z2 / total, 1.0, 0.1) << c.name;
  EXPECT_EQ(undetermined > 0, c.config == 1) << c.name;  // only the paper's B design loses rank
}

INSTANTIATE_TEST_SUITE_P(
    Designs, Coverage,
    ::testing::Values(CoverageCase{"paper_C_uniform", 0, NoiseModel::Distribution::kUniform},
                      CoverageCase{"paper_C_normal", 0, NoiseModel::Distribution::kNormal},
                      CoverageCase{"paper_B_uniform", 1, NoiseModel::Distribution::kUniform},
                      CoverageCase{"B_offset_normal", 2, NoiseModel::Distribution::kNormal},
                      CoverageCase{"C_fourier3_uniform", 3, NoiseModel::Distribution::kUniform},
                      CoverageCase{"B_legendre2_normal", 4, NoiseModel::Distribution::kNormal},
                      CoverageCase{"A_trunnion_uniform", 5, NoiseModel::Distribution::kUniform},
                      CoverageCase{"A_head_offset_normal", 6, NoiseModel::Distribution::kNormal}),
    [](const auto& info) { return std::string(info.param.name); });

}  // namespace
}  // namespace dbbkit
