#include "dbbkit/residual_checks.hpp"

#include <Eigen/QR>
#include <Eigen/SVD>
#include <algorithm>
#include <boost/math/distributions/chi_squared.hpp>
#include <boost/math/distributions/fisher_f.hpp>
#include <cmath>
#include <limits>

#include "column_tester.hpp"
#include "dbbkit/effects.hpp"
#include "dbbkit/linear_model.hpp"
#include "dbbkit/parameterisation.hpp"
#include "wls_solver.hpp"

namespace dbbkit {

double f_test_p(int q, int dof, double F) {
  if (!(F > 0) || q <= 0 || dof <= 0) return 1.0;
  return boost::math::cdf(boost::math::complement(boost::math::fisher_f(q, dof), F));
}

namespace {

// The distinct positions of the readings `rows` (all when null).
// Sorted (on a full turn an angle taken into [0, 360)), a position is new when it is not the
// same as the one before it; on a full turn the last and the first may be one across 0/360.
int distinct_positions(const AxisFrame& axis, const std::vector<Reading>& readings,
                       const std::vector<int>* rows) {
  const std::size_t n = rows ? rows->size() : readings.size();
  std::vector<double> angles;
  angles.reserve(n);
  for (std::size_t j = 0; j < n; ++j) {
    double a = readings[rows ? static_cast<std::size_t>((*rows)[j]) : j].angle_deg;
    if (axis.full_turn()) {
      a = std::fmod(a, 360.0);
      if (a < 0) a += 360.0;
    }
    angles.push_back(a);
  }
  std::sort(angles.begin(), angles.end());
  int count = 0;
  for (std::size_t j = 0; j < angles.size(); ++j)
    count += j == 0 || !same_position(axis, angles[j - 1], angles[j]);
  if (axis.full_turn() && count > 1 && same_position(axis, angles.front(), angles.back())) --count;
  return count;
}

}  // namespace

std::vector<double> residual_harmonics(const std::vector<Reading>& readings,
                                       const std::vector<int>& rows,
                                       const Eigen::VectorXd& residual_um) {
  std::vector<double> amplitude;
  const int K =
      std::min(4, (distinct_positions(AxisFrame::c_turntable(), readings, &rows) - 1) / 2);
  if (K < 1) return amplitude;
  const Eigen::Index n = static_cast<Eigen::Index>(rows.size());
  Eigen::MatrixXd A(n, 2 * K + 1);
  Eigen::VectorXd e(n);
  for (Eigen::Index j = 0; j < n; ++j) {
    const std::size_t row = static_cast<std::size_t>(rows[static_cast<std::size_t>(j)]);
    A.row(j) = fourier_basis(K, readings[row].angle_deg).transpose();
    e(j) = residual_um(static_cast<Eigen::Index>(row));
  }
  const Eigen::VectorXd coef = A.colPivHouseholderQr().solve(e);
  for (int k = 1; k <= K; ++k) amplitude.push_back(std::hypot(coef(2 * k - 1), coef(2 * k)));
  return amplitude;
}

ColumnTester::ColumnTester(const WlsSolver& solver, const Estimate& fit,
                           const EstimateOptions& options)
    : solver_(solver),
      fit_(fit),
      options_(options),
      w_(solver.sigma_um().array().square().inverse()) {}

ColumnTest ColumnTester::one_column(double xWr, double xWx, double R2) const {
  ColumnTest t;
  t.q = 1;
  // |R| / |W^1/2 x| above sqrt(min_relative_singular_value), as added_rank counts a column.
  if (!(xWx > 0) || !(R2 > options_.min_relative_singular_value * xWx)) return t;
  t.added_rank = 1;
  t.dof = fit_.dof - 1;
  t.delta_chi2 = std::min(xWr * xWr / R2, fit_.chi2);
  t.value = xWr / R2;
  t.std = 1.0 / std::sqrt(R2);
  if (t.dof <= 0) return t;
  const double rest = fit_.chi2 - t.delta_chi2;
  t.F = rest > 0 ? t.delta_chi2 / (rest / t.dof) : std::numeric_limits<double>::infinity();
  t.p = std::isinf(t.F) ? 0.0 : f_test_p(1, t.dof, t.F);
  return t;
}

ColumnTest ColumnTester::test(const Eigen::MatrixXd& X) const {
  if (X.cols() == 1) {
    const Eigen::VectorXd x = X.col(0);
    const Eigen::VectorXd Wx = w_.cwiseProduct(x);
    const double R2 = Wx.dot(x) - (solver_.J().transpose() * Wx).dot(solver_.J_theta_reading() * x);
    return one_column(Wx.dot(fit_.residual_um), Wx.dot(x), R2);
  }
  ColumnTest t;
  t.q = static_cast<int>(X.cols());
  if (X.cols() == 0) return t;
  Eigen::MatrixXd R = unexplained(solver_, X);
  const Eigen::VectorXd norms =
      (solver_.sigma_um().cwiseInverse().asDiagonal() * X).colwise().norm().transpose();
  for (int j = 0; j < R.cols(); ++j)
    R.col(j) =
        norms(j) > 0 ? Eigen::VectorXd(R.col(j) / norms(j)) : Eigen::VectorXd::Zero(R.rows());
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(R, Eigen::ComputeThinU);
  const double tol = std::sqrt(options_.min_relative_singular_value);
  int r = 0;
  for (int k = 0; k < svd.singularValues().size(); ++k) r += svd.singularValues()(k) > tol;
  t.added_rank = r;
  if (r == 0) return t;
  const Eigen::VectorXd e = fit_.residual_um.cwiseQuotient(solver_.sigma_um());
  t.delta_chi2 = std::min((svd.matrixU().leftCols(r).transpose() * e).squaredNorm(), fit_.chi2);
  t.dof = fit_.dof - r;
  if (t.dof <= 0) return t;
  const double rest = fit_.chi2 - t.delta_chi2;
  t.F = rest > 0 ? (t.delta_chi2 / r) / (rest / t.dof) : std::numeric_limits<double>::infinity();
  t.p = std::isinf(t.F) ? 0.0 : f_test_p(r, t.dof, t.F);
  return t;
}

ScanTest ColumnTester::scan_steps(const std::vector<int>& rows, int min_segment) const {
  ScanTest s;
  const int m = static_cast<int>(rows.size());
  min_segment = std::max(1, min_segment);
  if (m < 2 * min_segment) return s;
  const Jacobian& J = solver_.J();
  const WlsSolver::Gain& G = solver_.J_theta_reading();
  Eigen::VectorXd JWx = Eigen::VectorXd::Zero(J.cols()), Gx = Eigen::VectorXd::Zero(G.rows());
  // With a low-rank part U V: x'W J G x = JWx.(G0 x) + (U'J'W x).(V x), both q-vectors
  // summed reading by reading (J U formed once).
  const int q = static_cast<int>(G.U().cols());
  const Eigen::MatrixXd JU = q > 0 ? Eigen::MatrixXd(J * G.U()) : Eigen::MatrixXd();
  Eigen::VectorXd UJWx = Eigen::VectorXd::Zero(q), Vx = Eigen::VectorXd::Zero(q);
  double xWr = 0, xWx = 0;
  // The step at k covers rows[k..m-1]: sums from the end.
  for (int k = m - 1; k >= min_segment; --k) {
    const int i = rows[static_cast<std::size_t>(k)];
    xWr += w_(i) * fit_.residual_um(i);
    xWx += w_(i);
    JWx += w_(i) * J.row(i).transpose();
    Gx += G.sparse().col(i);
    if (q > 0) {
      UJWx += w_(i) * JU.row(i).transpose();
      Vx += G.V().col(i);
    }
    if (m - k < min_segment) continue;
    s.consider(k, one_column(xWr, xWx, xWx - JWx.dot(Gx) - (q > 0 ? UJWx.dot(Vx) : 0.0)));
  }
  return s;
}

ScanTest ColumnTester::scan_readings(const std::vector<int>& rows) const {
  ScanTest s;
  std::vector<std::pair<int, ColumnTest>> tested;
  for (int i : rows) {
    const double h = solver_.leverage(i);
    const ColumnTest t = one_column(w_(i) * fit_.residual_um(i), w_(i), w_(i) * (1.0 - h));
    s.consider(i, t);
    if (t.added_rank > 0 && t.dof > 0) tested.emplace_back(i, t);
  }
  if (s.best < 0) return s;
  // Ties: readings of the same F whose unexplained indicator is parallel to the best's. With
  // M = I - J G the residual maker, the whitened unexplained parts of e_i and e_j correlate
  // as sqrt(w_i / w_j) M_ij / sqrt((1 - h_i)(1 - h_j)) (the whitened M is symmetric).
  const int b = s.best;
  const Jacobian& J = solver_.J();
  const double hb = solver_.leverage(b);
  for (const auto& [j, t] : tested) {
    if (j == b || std::abs(t.F - s.test.F) > 1e-6 * s.test.F) continue;
    const Eigen::VectorXd g = solver_.J_theta_reading().col(j);
    double Jg = 0;
    for (Jacobian::InnerIterator x(J, b); x; ++x) Jg += x.value() * g(x.col());
    const double hj = solver_.leverage(j);
    const double corr =
        std::sqrt(w_(b) / w_(j)) * (-Jg) / std::sqrt(std::max(0.0, (1.0 - hb) * (1.0 - hj)));
    if (std::abs(corr) >= 1.0 - kIndistinguishable) {
      s.ties.push_back(j);
      s.tie_values.push_back(t.value);
    }
  }
  return s;
}

const char* feature_kind_name(FeatureKind k) {
  switch (k) {
    case FeatureKind::kMean:
      return "mean";
    case FeatureKind::kHarmonic:
      return "harmonic";
    case FeatureKind::kDrift:
      return "drift";
    case FeatureKind::kReversal:
      return "cw_minus_ccw";
    case FeatureKind::kStep:
      return "step";
    case FeatureKind::kReading:
      return "reading";
  }
  return "unknown";
}

std::vector<ResidualFeature> residual_features(const Design& design,
                                               const std::vector<Reading>& readings,
                                               const WlsSolver& solver, const Estimate& fit,
                                               const EstimateOptions& options) {
  std::vector<ResidualFeature> out;
  if (fit.dof <= 1) return out;
  const ColumnTester tester(solver, fit, options);
  const Eigen::Index n = static_cast<Eigen::Index>(readings.size());
  const auto index = design.installation_index();
  std::vector<std::vector<int>> rows(design.installations.size());
  for (std::size_t j = 0; j < readings.size(); ++j)
    rows[index.at(readings[j].installation)].push_back(static_cast<int>(j));
  auto timed = [&](int inst) {
    return std::all_of(rows[inst].begin(), rows[inst].end(),
                       [&](int j) { return readings[j].time_s.has_value(); });
  };
  // The column of a one-column feature of an installation; empty when its readings cannot show it
  // (a drift needs every time, cw - ccw both sweeps).
  auto column = [&](FeatureKind kind, int inst) {
    const std::vector<int>& r = rows[inst];
    Eigen::MatrixXd c = Eigen::MatrixXd::Zero(n, 1);
    if (kind == FeatureKind::kMean) {
      for (int j : r) c(j, 0) = 1.0;
    } else if (kind == FeatureKind::kDrift) {
      if (!timed(inst)) return Eigen::MatrixXd();
      double t0 = *readings[r[0]].time_s;
      for (int j : r) t0 = std::min(t0, *readings[j].time_s);
      for (int j : r) c(j, 0) = (*readings[j].time_s - t0) / 60.0;
    } else {
      bool cw = false, ccw = false;
      for (int j : r) {
        if (!readings[j].sweep) continue;
        const bool is_cw = *readings[j].sweep == Sweep::kCW;
        cw = cw || is_cw, ccw = ccw || !is_cw;
        c(j, 0) = is_cw ? 0.5 : -0.5;
      }
      if (!(cw && ccw)) return Eigen::MatrixXd();
    }
    return c;
  };
  auto feature = [](FeatureKind kind, int installation, int harmonic = 0) {
    ResidualFeature f;
    f.kind = kind, f.installation = installation, f.harmonic = harmonic;
    return f;
  };
  auto add = [&](ResidualFeature f, const Eigen::MatrixXd& X) {
    if (X.cols() == 0) return;
    f.test = tester.test(X);
    if (f.test.added_rank == 0 || f.test.dof <= 0) return;
    f.p = f.test.p;
    if (X.cols() == 1) f.value = f.test.value, f.std = f.test.std;
    out.push_back(f);
  };
  auto add_scan = [&](ResidualFeature f, const ScanTest& st, int row) {
    if (st.best < 0) return;
    f.row = row;
    f.reading = readings[static_cast<std::size_t>(row)];
    f.test = st.test, f.tested = st.tested, f.p = st.p_scan, f.value = st.test.value,
    f.std = st.test.std;
    if (f.kind == FeatureKind::kReading) {
      f.indistinguishable = st.ties;
      f.indistinguishable_values = st.tie_values;
    }
    out.push_back(f);
  };
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const std::vector<int>& r = rows[i];
    if (r.empty()) continue;
    const int inst = static_cast<int>(i);
    add(feature(FeatureKind::kMean, inst), column(FeatureKind::kMean, inst));
    if (design.axis.full_turn()) {
      const std::vector<double> amplitude = residual_harmonics(readings, r, fit.residual_um);
      for (int k = 1; k <= static_cast<int>(amplitude.size()); ++k) {
        Eigen::MatrixXd h = Eigen::MatrixXd::Zero(n, 2);
        for (int j : r) {
          const double a = k * readings[j].angle_deg * M_PI / 180.0;
          h(j, 0) = std::cos(a), h(j, 1) = std::sin(a);
        }
        const std::size_t before = out.size();
        add(feature(FeatureKind::kHarmonic, inst, k), h);
        if (out.size() > before) out.back().value = amplitude[static_cast<std::size_t>(k - 1)];
      }
    }
    add(feature(FeatureKind::kDrift, inst), column(FeatureKind::kDrift, inst));
    add(feature(FeatureKind::kReversal, inst), column(FeatureKind::kReversal, inst));
    std::vector<int> ordered = r;
    if (timed(inst)) {
      std::stable_sort(ordered.begin(), ordered.end(),
                       [&](int a, int b) { return *readings[a].time_s < *readings[b].time_s; });
    }
    const ScanTest st = tester.scan_steps(ordered, kStepMinSegment);
    add_scan(feature(FeatureKind::kStep, inst), st,
             st.best >= 0 ? ordered[static_cast<std::size_t>(st.best)] : -1);
  }
  std::vector<int> all(readings.size());
  for (std::size_t j = 0; j < all.size(); ++j) all[j] = static_cast<int>(j);
  const ScanTest g = tester.scan_readings(all);
  if (g.best >= 0)
    add_scan(feature(FeatureKind::kReading, index.at(readings[g.best].installation)), g, g.best);
  // Only a difference determined: one-column features of one kind that the most significant of
  // that kind makes confounded (a mean of 1r against that of 2r).
  for (FeatureKind kind : {FeatureKind::kMean, FeatureKind::kDrift, FeatureKind::kReversal}) {
    ResidualFeature* top = nullptr;
    for (ResidualFeature& f : out) {
      if (f.kind == kind && (!top || more_significant(f.p, f.test.F, top->p, top->test.F)))
        top = &f;
    }
    if (!top) continue;
    const WlsSolver with_top(append_columns(solver.J(), column(kind, top->installation)),
                             solver.sigma_um(), options);
    for (const ResidualFeature& f : out) {
      if (f.kind != kind || &f == top) continue;
      if (added_rank(with_top, column(kind, f.installation), options) == 0)
        top->difference_with.push_back(f.installation);
    }
  }
  mark_implausible(design, readings, out);
  return out;
}

void mark_implausible(const Design& design, const std::vector<Reading>& readings,
                      std::vector<ResidualFeature>& features) {
  const double range_um = 1e3 * design.instrument_range_mm;
  // The minutes a feature's readings span: its installation's, or the test's (installation -1).
  const std::size_t n = design.installations.size();
  std::vector<double> t0(n, std::numeric_limits<double>::infinity()), t1(n, -t0[0]);
  for (const Reading& r : readings) {
    const int i = design.find_installation(r.installation);
    if (!r.time_s || i < 0) continue;
    t0[static_cast<std::size_t>(i)] = std::min(t0[static_cast<std::size_t>(i)], *r.time_s);
    t1[static_cast<std::size_t>(i)] = std::max(t1[static_cast<std::size_t>(i)], *r.time_s);
  }
  auto span_min = [&](int installation) {
    if (installation < 0 || static_cast<std::size_t>(installation) >= n)
      return test_minutes(readings);
    const std::size_t i = static_cast<std::size_t>(installation);
    return t1[i] > t0[i] ? (t1[i] - t0[i]) / 60.0 : 0.0;
  };
  for (ResidualFeature& f : features) {
    // What the feature alone would move the bar by in these readings (as effect_reach_um): a
    // drift over the span of its readings, any other its size.
    const double size = f.kind == FeatureKind::kDrift ? std::abs(f.value) * span_min(f.installation)
                                                      : std::abs(f.value);
    if (size > range_um) f.beyond_instrument_um = size;
    if (f.kind == FeatureKind::kDrift && std::abs(f.value) > design.max_drift_um_per_min)
      f.beyond_drift_rate_um_per_min = std::abs(f.value);
  }
}

std::vector<GrossReading> gross_readings(const Jacobian& J, const Eigen::VectorXd& sigma_um,
                                         const Eigen::VectorXd& y_um, double level, int max_count,
                                         const EstimateOptions& options) {
  std::vector<GrossReading> out;
  Jacobian A = J;
  std::vector<int> rows(static_cast<std::size_t>(y_um.size()));
  for (std::size_t j = 0; j < rows.size(); ++j) rows[j] = static_cast<int>(j);
  while (static_cast<int>(out.size()) < max_count) {
    const WlsSolver solver(A, sigma_um, options);
    const Estimate fit = solver.solve(y_um);
    const ScanTest g = ColumnTester(solver, fit, options).scan_readings(rows);
    if (g.best < 0 || !(g.p_scan < level)) break;
    GrossReading r;
    r.row = g.best;
    r.residual_um = fit.residual_um(g.best);
    r.value_um = g.test.value;
    r.std_um = g.test.std;
    r.t = std::copysign(std::sqrt(g.test.F), g.test.value);
    r.p = g.test.p;
    r.p_scan = g.p_scan;
    r.tested = g.tested;
    r.indistinguishable = g.ties;
    r.alternative_values_um = g.tie_values;
    out.push_back(r);
    rows.erase(std::find(rows.begin(), rows.end(), g.best));
    Eigen::MatrixXd unit = Eigen::MatrixXd::Zero(A.rows(), 1);
    unit(g.best, 0) = 1.0;
    A = append_columns(A, unit);
  }
  return out;
}

std::vector<std::pair<int, Eigen::MatrixXd>> higher_order_columns(
    const Design& design, const std::vector<Reading>& readings) {
  std::vector<std::pair<int, Eigen::MatrixXd>> out;
  const ErrorModel::Kind kind = design.errors.kind;
  if (kind == ErrorModel::Kind::kPerAngle) return out;
  const int P = distinct_positions(design.axis, readings, nullptr);
  const int K = design.errors.order;
  const int K_max = kind == ErrorModel::Kind::kFourier ? (P - 1) / 2 : P - 1;
  for (int k = K + 1; k <= std::min(K + 4, K_max); ++k) {
    Design higher = design;
    higher.errors.order = k;
    const Parameterisation param(higher);
    out.emplace_back(k, Eigen::MatrixXd(build_linear_model(higher, param, readings).J));
  }
  return out;
}

std::optional<OrderCheck> model_order_check(
    int order, const std::vector<std::pair<int, Eigen::MatrixXd>>& higher,
    const ColumnTester& tester, const Estimate& fit) {
  const double n = static_cast<double>(fit.n_readings);
  OrderCheck best;
  best.order = order;
  double best_bic = 0;
  for (const auto& [k, J] : higher) {
    const ColumnTest t = tester.test(J);
    if (t.added_rank == 0 || t.dof <= 0) continue;
    ++best.tried;
    const double chi2 = fit.chi2 - t.delta_chi2;
    const double b = bic(n, chi2, fit.rank + t.added_rank);
    if (best.suggested == 0 || b < best_bic) {
      best_bic = b, best.suggested = k, best.test = t;
    }
  }
  if (best.tried == 0) return std::nullopt;
  best.p = std::min(1.0, best.tried * best.test.p);
  best.chi2_with = fit.chi2 - best.test.delta_chi2;
  best.dof_with = best.test.dof;
  if (best.dof_with > 0) {
    best.p_value_with = chi2_upper_tail(best.dof_with, best.chi2_with);
  }
  return best;
}

std::optional<OrderCheck> model_order_check(const Design& design,
                                            const std::vector<Reading>& readings,
                                            const WlsSolver& solver, const Estimate& fit,
                                            const EstimateOptions& options) {
  const auto higher = higher_order_columns(design, readings);
  if (higher.empty()) return std::nullopt;
  return model_order_check(design.errors.order, higher, ColumnTester(solver, fit, options), fit);
}

NoiseScale noise_scale(double chi2, int dof) {
  NoiseScale s;
  if (dof <= 0) return s;
  const boost::math::chi_squared d(dof);
  s.ratio = std::sqrt(chi2 / dof);
  s.low = std::sqrt(chi2 / boost::math::quantile(d, 0.975));
  s.high = std::sqrt(chi2 / boost::math::quantile(d, 0.025));
  return s;
}

}  // namespace dbbkit
