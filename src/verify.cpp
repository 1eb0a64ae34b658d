#include "dbbkit/verify.hpp"

#include <Eigen/Cholesky>
#include <Eigen/QR>
#include <algorithm>
#include <boost/math/distributions/chi_squared.hpp>
#include <cmath>
#include <map>
#include <numeric>
#include <optional>

#include "dbbkit/iso230.hpp"
#include "dbbkit/kinematics.hpp"
#include "dbbkit/linear_model.hpp"
#include "dbbkit/parameterisation.hpp"
#include "dbbkit/setup.hpp"

namespace dbbkit {

namespace {

// The generalised least-squares fit of whitened columns to a whitened residual: the part of
// |r|^2 the columns leave, and their coefficients with their covariance (independent columns).
struct ColumnFit {
  double left = 0;
  Eigen::VectorXd coefficients;
  Eigen::MatrixXd covariance;
};
ColumnFit fit_columns(const Eigen::MatrixXd& W, const Eigen::VectorXd& r) {
  ColumnFit f;
  if (W.cols() == 0) {
    f.left = r.squaredNorm();
    return f;
  }
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(W);
  const Eigen::MatrixXd R =
      qr.matrixQR().topRows(W.cols()).triangularView<Eigen::Upper>().toDenseMatrix();
  const Eigen::VectorXd qtr = (qr.householderQ().transpose() * r).head(W.cols());
  f.coefficients = R.triangularView<Eigen::Upper>().solve(qtr);
  const Eigen::MatrixXd Rinv =
      R.triangularView<Eigen::Upper>().solve(Eigen::MatrixXd::Identity(W.cols(), W.cols()));
  f.covariance = Rinv * Rinv.transpose();
  f.left = std::max(0.0, r.squaredNorm() - qtr.squaredNorm());
  return f;
}

// The columns of W (whitened) that are independent, in their order: a column within 1e-9 of the
// span of those before it (relative to its own length) is left out.
std::vector<int> independent_columns(const Eigen::MatrixXd& W) {
  std::vector<int> keep;
  Eigen::MatrixXd Q(W.rows(), 0);
  for (Eigen::Index c = 0; c < W.cols(); ++c) {
    const double length = W.col(c).norm();
    if (!(length > 0)) continue;
    Eigen::VectorXd v = W.col(c);
    for (int pass = 0; pass < 2; ++pass) v -= Q * (Q.transpose() * v);  // twice: Gram-Schmidt
    if (v.norm() <= 1e-9 * length) continue;
    Q.conservativeResize(Eigen::NoChange, Q.cols() + 1);
    Q.col(Q.cols() - 1) = v.normalized();
    keep.push_back(static_cast<int>(c));
  }
  return keep;
}

Eigen::MatrixXd columns(const Eigen::MatrixXd& M, const std::vector<int>& which) {
  Eigen::MatrixXd out(M.rows(), static_cast<Eigen::Index>(which.size()));
  for (std::size_t k = 0; k < which.size(); ++k)
    out.col(static_cast<Eigen::Index>(k)) = M.col(which[k]);
  return out;
}

// The test's rows as the result predicts them (the head of verify.hpp): each reading's
// prediction g m, the location errors' columns A = g G, the constant parts' N = g E, and the
// residual's covariance V when the result explains the test. Counts the angles into `v`.
// `before_run`: the prediction itself, nothing fitted, the test run on the result's preset (the
// motions' constant parts, where the readings' zero was taken, the result's): at a measured angle
// the motions themselves, m (AtAngle::errors, with their covariance D: needing no independence
// between angles), elsewhere G l + E k (the location errors' and the constant parts' estimates,
// taken as independent of each other); only V's diagonal and each angle's block are meant.
struct HeldOutRows {
  LinearModel model;
  Eigen::MatrixXd A, N, V;
  Eigen::VectorXd predicted;
  std::vector<int> station;
  std::vector<bool> measured;  // at the station: the result's motions predict it
  // Each row's count (the installation's reading_sign): the instrument reads count x the bar's
  // length change, the rows' unit.
  std::vector<double> count;
};

std::optional<HeldOutRows> held_out_rows(const AxisErrors& axis, const Design& design_in,
                                         const std::vector<Reading>& readings,
                                         const VerifyOptions& options, bool before_run,
                                         Verification& v) {
  const std::optional<Eigen::Matrix<double, 5, 1>> determined = location_values(axis);
  if (!determined) {
    v.gap = VerifyGap::kLocationNotDetermined;
    return std::nullopt;
  }
  const Eigen::Matrix<double, 5, 1>& l = *determined;

  // The test's rows as a per-angle model: its stations, each reading's sensitivity to the six
  // motions at its angle, its noise.
  Design design = design_in;
  design.errors = ErrorModel{};
  const Parameterisation param(design);
  HeldOutRows h{build_linear_model(design, param, readings), {}, {}, {}, {}, {}, {}, {}};
  const LinearModel& model = h.model;
  const Eigen::Index n = model.J.rows();
  const int stations = param.n_stations();
  std::vector<bool> present(static_cast<std::size_t>(stations), false);  // an angle read
  for (const Reading& r : readings)
    present[static_cast<std::size_t>(param.station_of(r.angle_deg))] = true;
  v.angles = static_cast<int>(std::count(present.begin(), present.end(), true));
  v.noise_std_um = design.noise.sigma_um();

  // The motions at each station as the result predicts them, and where it measured them.
  std::vector<Vector6d> motion(static_cast<std::size_t>(stations));
  std::vector<const AxisErrors::AtAngle*> at(static_cast<std::size_t>(stations), nullptr);
  std::vector<Eigen::Matrix<double, 6, 5>> G(static_cast<std::size_t>(stations));
  for (int s = 0; s < stations; ++s) {
    const auto k = static_cast<std::size_t>(s);
    const double angle = param.station_angle_deg(s);
    G[k] = location_motion(axis.axis, angle);
    if (!options.location_only) at[k] = measured_at(axis, angle);
    if (at[k] != nullptr && before_run && !(at[k]->errors && at[k]->errors_covariance)) {
      at[k] = nullptr;  // the motions themselves or their covariance not stated
      v.angles_without_covariance += present[k];
    }
    if (at[k] != nullptr && !before_run &&
        !(at[k]->errors_covariance && axis.independent_between_angles)) {
      at[k] = nullptr;
      v.angles_motions_correlated += present[k];
    }
    if (at[k] == nullptr && !options.location_only &&
        std::any_of(axis.measured_without_covariance.begin(),
                    axis.measured_without_covariance.end(),
                    [&](double a) { return same_angle(axis.axis, a, angle); }))
      v.angles_without_covariance += present[k];
    motion[k] = G[k] * l;
    if (at[k] != nullptr && before_run) {
      motion[k] = *at[k]->errors;
    } else if (at[k] != nullptr) {
      for (int c = 0; c < 6; ++c) motion[k](c) += at[k]->component[static_cast<std::size_t>(c)];
    } else {
      v.angles_location_only += present[k];
    }
    h.measured.push_back(at[k] != nullptr);
  }

  // Rows: g (n x 6), the location errors' A = g G, the constant parts' N = g E.
  const IsoFrame frame = iso_frame(axis.axis);
  Eigen::Matrix<double, 6, 5> E = Eigen::Matrix<double, 6, 5>::Zero();
  E.topLeftCorner<3, 3>().setIdentity();
  E.block<3, 1>(3, 3) = frame.p1;
  E.block<3, 1>(3, 4) = frame.p2;
  if (before_run && axis.constants)  // the result's preset: its constant parts at every angle
    for (int s = 0; s < stations; ++s)
      if (at[static_cast<std::size_t>(s)] == nullptr)
        motion[static_cast<std::size_t>(s)] += E * *axis.constants;
  const auto index = design.installation_index();
  Eigen::MatrixXd g(n, 6);
  h.A.resize(n, 5);
  h.N.resize(n, 5);
  h.station.resize(static_cast<std::size_t>(n));
  h.count.resize(static_cast<std::size_t>(n));
  h.predicted.resize(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const Reading& r = readings[static_cast<std::size_t>(i)];
    const Installation& inst =
        design.installations[static_cast<std::size_t>(index.at(r.installation))];
    const int s = param.station_of(r.angle_deg);
    h.station[static_cast<std::size_t>(i)] = s;
    h.count[static_cast<std::size_t>(i)] = inst.reading_sign;
    g.row(i) = J_reading_error(design.axis, inst, r.angle_deg);
    h.A.row(i) = g.row(i) * G[static_cast<std::size_t>(s)];
    h.N.row(i) = g.row(i) * E;
    h.predicted(i) = g.row(i).dot(motion[static_cast<std::size_t>(s)]);
  }

  // The residual's covariance when the result explains the test.
  Eigen::MatrixXd& V = h.V;
  V = model.sigma_um.array().square().matrix().asDiagonal();
  std::vector<std::vector<Eigen::Index>> rows_at(static_cast<std::size_t>(stations));
  for (Eigen::Index i = 0; i < n; ++i)
    rows_at[static_cast<std::size_t>(h.station[static_cast<std::size_t>(i)])].push_back(i);
  std::vector<Eigen::Index> location_rows;
  for (int s = 0; s < stations; ++s) {
    const auto k = static_cast<std::size_t>(s);
    if (at[k] == nullptr) {
      location_rows.insert(location_rows.end(), rows_at[k].begin(), rows_at[k].end());
      continue;
    }
    const Eigen::Matrix<double, 6, 6>& D = *at[k]->errors_covariance;
    for (const Eigen::Index i : rows_at[k])
      for (const Eigen::Index j : rows_at[k]) V(i, j) += g.row(i) * D * g.row(j).transpose();
  }
  for (const Eigen::Index i : location_rows)
    for (const Eigen::Index j : location_rows)
      V(i, j) += h.A.row(i) * axis.location_covariance * h.A.row(j).transpose();
  if (before_run && axis.constants) {
    const Eigen::Matrix<double, 5, 5> K = axis.constants_std.array().square().matrix().asDiagonal();
    for (const Eigen::Index i : location_rows)
      for (const Eigen::Index j : location_rows) V(i, j) += h.N.row(i) * K * h.N.row(j).transpose();
  }
  // Each declared set-up effect and placement moves its own installation's readings alone: its
  // outer product on those rows (553 installations of 9 readings: 45,000 products per effect
  // instead of the whole n x n).
  auto add_outer = [&V, n](const auto& column, double var) {
    std::vector<Eigen::Index> rows;
    for (Eigen::Index i = 0; i < n; ++i)
      if (column(i) != 0) rows.push_back(i);
    for (const Eigen::Index i : rows)
      for (const Eigen::Index j : rows) V(i, j) += var * column(i) * column(j);
  };
  for (const SetupEffect& e : setup_effects(design, model, true))
    for (Eigen::Index c = 0; c < e.J_reading_effect.cols(); ++c)
      add_outer(e.J_reading_effect.col(c), e.std_um * e.std_um);
  const std::vector<SetupInput> inputs = setup_inputs(design);
  if (!inputs.empty()) {
    Eigen::VectorXd theta = Eigen::VectorXd::Zero(param.n_parameters());
    for (int j = 0; j < param.n_parameters(); ++j)
      theta(j) =
          motion[static_cast<std::size_t>(param.parameter_station(j))](param.parameter_error(j));
    const Eigen::MatrixXd D = J_reading_setup(design, param, model, inputs, theta);
    for (std::size_t k = 0; k < inputs.size(); ++k)
      add_outer(D.col(static_cast<Eigen::Index>(k)), inputs[k].std_mm * inputs[k].std_mm);
  }
  return h;
}

}  // namespace

PredictedTest predict_test_readings(const AxisErrors& axis, const Design& design,
                                    const VerifyOptions& options) {
  PredictedTest p;
  p.coverage_probability = options.coverage_probability;
  const std::vector<Reading> readings = nominal_readings(design);
  Verification counts;
  const std::optional<HeldOutRows> h = held_out_rows(axis, design, readings, options, true, counts);
  p.gap = counts.gap;
  if (!h) return p;
  p.angles = counts.angles;
  p.angles_location_only = counts.angles_location_only;
  p.angles_motions_correlated = counts.angles_motions_correlated;
  p.angles_without_covariance = counts.angles_without_covariance;
  p.noise_std_um = counts.noise_std_um;
  std::map<std::string, std::size_t> taken;  // readings of each installation so far
  for (Eigen::Index i = 0; i < h->predicted.size(); ++i) {
    PredictedReading r;
    r.reading = readings[static_cast<std::size_t>(i)];
    // nominal_readings: each installation's angles, then its return reading where it has one.
    r.is_return = ++taken[r.reading.installation] >
                  design.angles_of(design.find_installation(r.reading.installation)).size();
    r.basis = h->measured[static_cast<std::size_t>(h->station[static_cast<std::size_t>(i)])]
                  ? PredictionBasis::kMotions
                  : PredictionBasis::kLocationOnly;
    r.predicted_um = h->count[static_cast<std::size_t>(i)] * h->predicted(i);
    r.std_um = std::sqrt(std::max(h->V(i, i), 0.0));
    p.readings.push_back(r);
  }
  return p;
}

Verification verify_readings(const AxisErrors& axis, const Design& design,
                             const std::vector<Reading>& readings, const VerifyOptions& options) {
  Verification v;
  v.coverage_probability = options.coverage_probability;
  v.readings = static_cast<int>(readings.size());
  std::optional<HeldOutRows> rows = held_out_rows(axis, design, readings, options, false, v);
  if (!rows) return v;
  const LinearModel& model = rows->model;
  const Eigen::Index n = model.J.rows();
  const Eigen::MatrixXd &A = rows->A, &N = rows->N, &V = rows->V;
  const Eigen::VectorXd& predicted = rows->predicted;
  const Eigen::VectorXd residual = model.y_um - predicted;

  // Whitened: V = L L'.
  const Eigen::LLT<Eigen::MatrixXd> llt(V);
  {  // Beyond double precision (a noise of 1e-4 um beside a set-up of 100 mm): no number stated.
    const Eigen::VectorXd d = llt.matrixL().toDenseMatrix().diagonal();
    if (llt.info() != Eigen::Success || !(d.minCoeff() > 1e-7 * d.maxCoeff())) {
      v.gap = VerifyGap::kIllConditioned;
      return v;
    }
  }
  auto whiten = [&](const Eigen::MatrixXd& M) { return Eigen::MatrixXd(llt.matrixL().solve(M)); };
  const Eigen::VectorXd wr = whiten(residual);
  const Eigen::MatrixXd wN_all = whiten(N);
  const std::vector<int> kept = independent_columns(wN_all);
  const Eigen::MatrixXd wN = columns(wN_all, kept), Nk = columns(N, kept);
  v.nuisance = static_cast<int>(kept.size());
  v.dof = static_cast<int>(n) - v.nuisance;
  if (v.dof < 1) {
    v.gap = VerifyGap::kNoRedundancy;
    return v;
  }
  const ColumnFit fit = fit_columns(wN, wr);
  v.chi2 = fit.left;
  // The statistic's distribution: chi-squared (dof) for normal reading noise. Uniform noise has
  // the same variance and lighter tails (excess kurtosis -6/5): the statistic's mean is the same,
  // its variance 2 dof + kappa sum_i sigma_i^4 A_ii^2, A = V^-1 - V^-1 N (N'V^-1 N)^-1 N'V^-1
  // the statistic's matrix (r'A r); taken as c chi-squared (nu) with that mean and variance
  // (Satterthwaite): c = var / (2 dof), nu = 2 dof^2 / var.
  double scale = 1, nu = v.dof;
  if (design.noise.distribution == NoiseModel::Distribution::kUniform) {
    constexpr double kUniformExcessKurtosis = -1.2;
    const Eigen::MatrixXd Linv =
        llt.matrixL().solve(Eigen::MatrixXd::Identity(n, n));  // L^-1, lower triangular
    Eigen::MatrixXd Z;  // the whitened nuisance's orthonormal basis' rows, times L^-1
    if (wN.cols() > 0) {
      const Eigen::HouseholderQR<Eigen::MatrixXd> qr(wN);
      const Eigen::MatrixXd Q = qr.householderQ() * Eigen::MatrixXd::Identity(n, wN.cols());
      Z = Q.transpose() * Linv;
    }
    double sum = 0;
    for (Eigen::Index i = 0; i < n; ++i) {
      double a = Linv.col(i).squaredNorm();
      if (Z.size() > 0) a -= Z.col(i).squaredNorm();
      const double s2 = model.sigma_um(i) * model.sigma_um(i);
      sum += s2 * s2 * a * a;
    }
    // Each A_ii sigma_i^2 lies in [0, 1] and they add up to at most dof: var >= 0.8 dof.
    const double var = std::max(2.0 * v.dof + kUniformExcessKurtosis * sum, 0.8 * v.dof);
    scale = var / (2.0 * v.dof);
    nu = 2.0 * v.dof * v.dof / var;
  }
  v.statistic_scale = scale;
  v.statistic_dof = nu;
  const boost::math::chi_squared chi(nu);
  v.threshold = scale * boost::math::quantile(chi, options.coverage_probability);
  v.p_value = boost::math::cdf(boost::math::complement(chi, v.chi2 / scale));
  v.pass = v.chi2 <= v.threshold;

  // Each reading after the constant parts, with the standard deviation of that difference.
  const Eigen::VectorXd constant =
      Nk.cols() > 0 ? Eigen::VectorXd(Nk * fit.coefficients) : Eigen::VectorXd::Zero(n);
  const Eigen::MatrixXd NC = Nk.cols() > 0 ? Eigen::MatrixXd(Nk * fit.covariance) : Nk;
  for (Eigen::Index i = 0; i < n; ++i) {
    VerifiedReading c;
    c.index = static_cast<std::size_t>(i);
    c.basis = rows->measured[static_cast<std::size_t>(rows->station[static_cast<std::size_t>(i)])]
                  ? PredictionBasis::kMotions
                  : PredictionBasis::kLocationOnly;
    const double count = rows->count[static_cast<std::size_t>(i)];  // as the instrument reads
    c.read_um = count * model.y_um(i);
    c.predicted_um = count * (predicted(i) + constant(i));
    c.residual_um = c.read_um - c.predicted_um;
    const double var = V(i, i) - (Nk.cols() > 0 ? NC.row(i).dot(Nk.row(i)) : 0.0);
    c.std_um = std::sqrt(std::max(var, 0.0));
    c.normalized = c.std_um > 0 ? c.residual_um / c.std_um : 0.0;
    v.readings_checked.push_back(c);
  }
  std::vector<std::size_t> order(v.readings_checked.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return std::abs(v.readings_checked[a].normalized) > std::abs(v.readings_checked[b].normalized);
  });
  order.resize(std::min<std::size_t>(order.size(), 5));
  v.worst = order;

  // Each location error let free beside the constant parts.
  if (v.dof >= 2) {
    // One degree of freedom fewer, the statistic's scale kept.
    const boost::math::chi_squared one_fewer(std::max(nu * (v.dof - 1) / v.dof, 1e-3));
    const double with_threshold =
        scale * boost::math::quantile(one_fewer, options.coverage_probability);
    const Eigen::MatrixXd wA = whiten(A);
    for (int q = 0; q < 5; ++q) {
      Eigen::MatrixXd W(n, wN.cols() + 1);
      W << wN, wA.col(q);
      if (independent_columns(W).size() != static_cast<std::size_t>(W.cols())) continue;
      const ColumnFit f = fit_columns(W, wr);
      VerifyExplanation x;
      x.location = q;
      x.change = f.coefficients(W.cols() - 1);
      x.change_std = std::sqrt(f.covariance(W.cols() - 1, W.cols() - 1));
      x.chi2 = f.left;
      x.passes_with = f.left <= with_threshold;
      v.explanations.push_back(x);
    }
    std::stable_sort(
        v.explanations.begin(), v.explanations.end(),
        [](const VerifyExplanation& a, const VerifyExplanation& b) { return a.chi2 < b.chi2; });
  }
  return v;
}

}  // namespace dbbkit
