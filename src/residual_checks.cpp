#include "dbbkit/residual_checks.hpp"

#include <Eigen/SVD>
#include <algorithm>
#include <boost/math/distributions/chi_squared.hpp>
#include <boost/math/distributions/fisher_f.hpp>
#include <cmath>
#include <set>

#include "dbbkit/linear_model.hpp"
#include "dbbkit/parameterisation.hpp"

namespace dbbkit {

namespace {

double f_upper(int q, int dof, double F) {
  if (!(F > 0) || q <= 0 || dof <= 0) return 1.0;
  return boost::math::cdf(boost::math::complement(boost::math::fisher_f(q, dof), F));
}

}  // namespace

ColumnTester::ColumnTester(const WlsSolver& solver, const Estimate& fit, const EstimateOptions& options)
    : solver_(solver), fit_(fit), options_(options), w_(solver.sigma_um().array().square().inverse()) {}

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
  t.p = std::isinf(t.F) ? 0.0 : f_upper(1, t.dof, t.F);
  return t;
}

ColumnTest ColumnTester::test(const Eigen::MatrixXd& X) const {
  if (X.cols() == 1) {
    const Eigen::VectorXd x = X.col(0);
    const Eigen::VectorXd Wx = w_.cwiseProduct(x);
    const double R2 = Wx.dot(x) - (solver_.J().transpose() * Wx).dot(solver_.gain() * x);
    return one_column(Wx.dot(fit_.residual_um), Wx.dot(x), R2);
  }
  ColumnTest t;
  t.q = static_cast<int>(X.cols());
  if (X.cols() == 0) return t;
  Eigen::MatrixXd R = unexplained(solver_, X);
  const Eigen::VectorXd norms = (solver_.sigma_um().cwiseInverse().asDiagonal() * X).colwise().norm().transpose();
  for (int j = 0; j < R.cols(); ++j) R.col(j) = norms(j) > 0 ? Eigen::VectorXd(R.col(j) / norms(j)) : Eigen::VectorXd::Zero(R.rows());
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
  t.p = std::isinf(t.F) ? 0.0 : f_upper(r, t.dof, t.F);
  return t;
}

ScanTest ColumnTester::scan_steps(const std::vector<int>& rows, int min_segment) const {
  ScanTest s;
  const int m = static_cast<int>(rows.size());
  min_segment = std::max(1, min_segment);
  if (m < 2 * min_segment) return s;
  const Eigen::MatrixXd& J = solver_.J();
  const Eigen::MatrixXd& G = solver_.gain();
  Eigen::VectorXd JWx = Eigen::VectorXd::Zero(J.cols()), Gx = Eigen::VectorXd::Zero(G.rows());
  double xWr = 0, xWx = 0;
  // The step at k covers rows[k..m-1]: sums from the end.
  for (int k = m - 1; k >= min_segment; --k) {
    const int i = rows[static_cast<std::size_t>(k)];
    xWr += w_(i) * fit_.residual_um(i);
    xWx += w_(i);
    JWx += w_(i) * J.row(i).transpose();
    Gx += G.col(i);
    if (m - k < min_segment) continue;
    const ColumnTest t = one_column(xWr, xWx, xWx - JWx.dot(Gx));
    if (t.added_rank == 0 || t.dof <= 0) continue;
    ++s.tested;
    if (s.best < 0 || t.p < s.test.p || (t.p == s.test.p && t.F > s.test.F)) s.best = k, s.test = t;
  }
  if (s.best >= 0) s.p_scan = std::min(1.0, s.tested * s.test.p);
  return s;
}

ScanTest ColumnTester::scan_readings(const std::vector<int>& rows) const {
  ScanTest s;
  const Eigen::MatrixXd& J = solver_.J();
  const Eigen::MatrixXd& G = solver_.gain();
  for (int i : rows) {
    const double h = J.row(i).dot(G.col(i));  // leverage
    const ColumnTest t = one_column(w_(i) * fit_.residual_um(i), w_(i), w_(i) * (1.0 - h));
    if (t.added_rank == 0 || t.dof <= 0) continue;
    ++s.tested;
    if (s.best < 0 || t.p < s.test.p || (t.p == s.test.p && t.F > s.test.F)) s.best = i, s.test = t;
  }
  if (s.best >= 0) s.p_scan = std::min(1.0, s.tested * s.test.p);
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

std::vector<ResidualFeature> residual_features(const Design& design, const std::vector<Reading>& readings,
                                               const Eigen::MatrixXd& J, const Eigen::VectorXd& sigma_um,
                                               const Eigen::VectorXd& y_um, const EstimateOptions& options) {
  std::vector<ResidualFeature> out;
  const WlsSolver solver(J, sigma_um, options);
  const Estimate fit = solver.solve(y_um);
  if (fit.dof <= 1) return out;
  const ColumnTester tester(solver, fit, options);
  const Eigen::Index n = static_cast<Eigen::Index>(readings.size());
  const auto index = design.installation_index();
  std::vector<std::vector<int>> rows(design.installations.size());
  for (std::size_t j = 0; j < readings.size(); ++j) rows[index.at(readings[j].installation)].push_back(static_cast<int>(j));
  auto add = [&](ResidualFeature f, const Eigen::MatrixXd& X) {
    f.test = tester.test(X);
    if (f.test.added_rank == 0 || f.test.dof <= 0) return;
    f.p = f.test.p;
    if (X.cols() == 1) f.value = f.test.value, f.std = f.test.std;
    out.push_back(f);
  };
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const std::vector<int>& r = rows[i];
    if (r.empty()) continue;
    const int inst = static_cast<int>(i);
    Eigen::MatrixXd x = Eigen::MatrixXd::Zero(n, 1);
    for (int j : r) x(j, 0) = 1.0;
    ResidualFeature mean;
    mean.kind = FeatureKind::kMean, mean.installation = inst;
    add(mean, x);
    if (design.axis == Axis::C) {
      std::vector<double> positions;
      for (int j : r) {
        bool seen = false;
        for (double a : positions) seen = seen || same_position(Axis::C, a, readings[j].angle_deg);
        if (!seen) positions.push_back(readings[j].angle_deg);
      }
      const int K = std::min(4, (static_cast<int>(positions.size()) - 1) / 2);
      for (int k = 1; k <= K; ++k) {
        Eigen::MatrixXd h = Eigen::MatrixXd::Zero(n, 2);
        for (int j : r) {
          const double a = k * readings[j].angle_deg * M_PI / 180.0;
          h(j, 0) = std::cos(a), h(j, 1) = std::sin(a);
        }
        ResidualFeature f;
        f.kind = FeatureKind::kHarmonic, f.installation = inst, f.harmonic = k;
        add(f, h);
        if (!out.empty() && out.back().kind == FeatureKind::kHarmonic && out.back().installation == inst &&
            out.back().harmonic == k) {
          // The amplitude of the harmonic in the residual, on the installation's readings.
          Eigen::MatrixXd A(static_cast<Eigen::Index>(r.size()), 2);
          Eigen::VectorXd e(static_cast<Eigen::Index>(r.size()));
          for (std::size_t j = 0; j < r.size(); ++j) A.row(static_cast<Eigen::Index>(j)) = h.row(r[j]), e(static_cast<Eigen::Index>(j)) = fit.residual_um(r[j]);
          const Eigen::Vector2d c = A.colPivHouseholderQr().solve(e);
          out.back().value = c.norm();
        }
      }
    }
    const bool timed = std::all_of(r.begin(), r.end(), [&](int j) { return readings[j].time_s.has_value(); });
    std::vector<int> ordered = r;
    if (timed) {
      double t0 = *readings[r[0]].time_s;
      for (int j : r) t0 = std::min(t0, *readings[j].time_s);
      Eigen::MatrixXd d = Eigen::MatrixXd::Zero(n, 1);
      for (int j : r) d(j, 0) = (*readings[j].time_s - t0) / 60.0;
      ResidualFeature f;
      f.kind = FeatureKind::kDrift, f.installation = inst;
      add(f, d);
      std::stable_sort(ordered.begin(), ordered.end(), [&](int a, int b) { return *readings[a].time_s < *readings[b].time_s; });
    }
    bool cw = false, ccw = false;
    Eigen::MatrixXd v = Eigen::MatrixXd::Zero(n, 1);
    for (int j : r) {
      if (!readings[j].sweep) continue;
      const bool is_cw = *readings[j].sweep == Sweep::CW;
      cw = cw || is_cw, ccw = ccw || !is_cw;
      v(j, 0) = is_cw ? 0.5 : -0.5;
    }
    if (cw && ccw) {
      ResidualFeature f;
      f.kind = FeatureKind::kReversal, f.installation = inst;
      add(f, v);
    }
    const ScanTest st = tester.scan_steps(ordered, 3);
    if (st.best >= 0) {
      ResidualFeature f;
      f.kind = FeatureKind::kStep, f.installation = inst, f.row = ordered[static_cast<std::size_t>(st.best)];
      f.reading = readings[f.row];
      f.test = st.test, f.tested = st.tested, f.p = st.p_scan, f.value = st.test.value, f.std = st.test.std;
      out.push_back(f);
    }
  }
  std::vector<int> all(readings.size());
  for (std::size_t j = 0; j < all.size(); ++j) all[j] = static_cast<int>(j);
  const ScanTest g = tester.scan_readings(all);
  if (g.best >= 0) {
    ResidualFeature f;
    f.kind = FeatureKind::kReading, f.installation = index.at(readings[g.best].installation), f.row = g.best;
    f.reading = readings[g.best];
    f.test = g.test, f.tested = g.tested, f.p = g.p_scan, f.value = g.test.value, f.std = g.test.std;
    out.push_back(f);
  }
  // Only a difference determined: one-column features of one kind that the most significant of
  // that kind makes confounded (a mean of 1r against that of 2r).
  for (FeatureKind kind : {FeatureKind::kMean, FeatureKind::kDrift, FeatureKind::kReversal}) {
    ResidualFeature* top = nullptr;
    for (ResidualFeature& f : out) {
      if (f.kind == kind && (!top || f.p < top->p || (f.p == top->p && f.test.F > top->test.F))) top = &f;
    }
    if (!top) continue;
    auto column = [&](const ResidualFeature& f) {
      Eigen::MatrixXd c = Eigen::MatrixXd::Zero(n, 1);
      double t0 = 0;
      if (kind == FeatureKind::kDrift) {
        t0 = *readings[rows[f.installation][0]].time_s;
        for (int j : rows[f.installation]) t0 = std::min(t0, *readings[j].time_s);
      }
      for (int j : rows[f.installation]) {
        c(j, 0) = kind == FeatureKind::kMean    ? 1.0
                  : kind == FeatureKind::kDrift ? (*readings[j].time_s - t0) / 60.0
                                                : (*readings[j].sweep == Sweep::CW ? 0.5 : -0.5);
      }
      return c;
    };
    Eigen::MatrixXd Jt(J.rows(), J.cols() + 1);
    Jt << J, column(*top);
    const WlsSolver with_top(Jt, sigma_um, options);
    for (const ResidualFeature& f : out) {
      if (f.kind != kind || &f == top) continue;
      if (added_rank(with_top, column(f), options) == 0) top->difference_with.push_back(f.installation);
    }
  }
  return out;
}

std::vector<GrossReading> gross_readings(const Eigen::MatrixXd& J, const Eigen::VectorXd& sigma_um,
                                         const Eigen::VectorXd& y_um, double level, int max_count,
                                         const EstimateOptions& options) {
  std::vector<GrossReading> out;
  Eigen::MatrixXd A = J;
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
    out.push_back(r);
    rows.erase(std::find(rows.begin(), rows.end(), g.best));
    A.conservativeResize(Eigen::NoChange, A.cols() + 1);
    A.col(A.cols() - 1).setZero();
    A(g.best, A.cols() - 1) = 1.0;
  }
  return out;
}

std::optional<OrderCheck> model_order_check(const Design& design, const std::vector<Reading>& readings,
                                            const Eigen::MatrixXd& J, const Eigen::VectorXd& sigma_um,
                                            const Eigen::VectorXd& y_um, const EstimateOptions& options) {
  const ErrorModel::Kind kind = design.errors.kind;
  if (kind == ErrorModel::Kind::PerAngle) return std::nullopt;
  std::vector<double> positions;
  for (const Reading& r : readings) {
    bool seen = false;
    for (double a : positions) seen = seen || same_position(design.axis, a, r.angle_deg);
    if (!seen) positions.push_back(r.angle_deg);
  }
  const int P = static_cast<int>(positions.size());
  const int K = design.errors.order;
  const int K_max = kind == ErrorModel::Kind::Fourier ? (P - 1) / 2 : P - 1;
  const WlsSolver solver(J, sigma_um, options);
  const Estimate fit = solver.solve(y_um);
  const ColumnTester tester(solver, fit, options);
  const double n = static_cast<double>(readings.size());
  OrderCheck best;
  best.order = K;
  double best_bic = 0;
  for (int k = K + 1; k <= std::min(K + 4, K_max); ++k) {
    Design higher = design;
    higher.errors.order = k;
    const Parameterisation param(higher);
    const LinearModel m = build_linear_model(higher, param, readings);
    const ColumnTest t = tester.test(m.J);
    if (t.added_rank == 0 || t.dof <= 0) continue;
    ++best.tried;
    const double chi2 = fit.chi2 - t.delta_chi2;
    const double b = n * std::log(std::max(chi2, 1e-300) / n) + (fit.rank + t.added_rank) * std::log(n);
    if (best.suggested == 0 || b < best_bic) {
      best_bic = b, best.suggested = k, best.test = t;
    }
  }
  if (best.tried == 0) return std::nullopt;
  best.p = std::min(1.0, best.tried * best.test.p);
  best.chi2_with = fit.chi2 - best.test.delta_chi2;
  best.dof_with = best.test.dof;
  if (best.dof_with > 0) {
    best.p_value_with = boost::math::cdf(boost::math::complement(boost::math::chi_squared(best.dof_with), best.chi2_with));
  }
  return best;
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
