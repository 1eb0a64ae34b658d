#include "dbbkit/setup.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <boost/math/distributions/chi_squared.hpp>
#include <boost/math/distributions/fisher_f.hpp>
#include <boost/math/distributions/non_central_f.hpp>
#include <boost/math/tools/toms748_solve.hpp>
#include <cmath>
#include <map>
#include <mutex>
#include <stdexcept>
#include <tuple>
#include <utility>

#include "cost_counters.hpp"
#include "dbbkit/instrument.hpp"
#include "dbbkit/kinematics.hpp"
#include "dbbkit/setup_sheet.hpp"
#include "function_rows.hpp"
#include "setup_solver.hpp"
#include "tolerances.hpp"
#include "wls_solver.hpp"

namespace dbbkit {

namespace {

// The noncentrality for a power is bracketed until hi - lo <= kBisection hi.
constexpr double kBisection = 1e-9;
// A set-up effect moves no error when its largest bias b (error unit per um) <= kNoBias.
constexpr double kNoBias = 1e-12;
// The first-order model is in doubt (FirstOrderCheck::warn) when the largest second-order
// term of a reading > kFirstOrderWarning sigma of the reading noise.
constexpr double kFirstOrderWarning = 0.25;

}  // namespace

std::vector<SetupEffect> setup_effects(const Design& design, const LinearModel& model,
                                       bool only_declared) {
  // The model's rows as readings, so that the columns are the effect library's own (effect_block).
  std::vector<Reading> rows;
  rows.reserve(model.row_installation.size());
  for (std::size_t r = 0; r < model.row_installation.size(); ++r) {
    Reading row;
    row.installation = design.installations[model.row_installation[r]].id;
    row.angle_deg = model.row_angle_deg[r];
    rows.push_back(std::move(row));
  }
  return setup_effects(design, rows, only_declared);
}

double setup_std_um(const SetupUncertainty& u, EffectKind kind) {
  const auto member = effect_info(kind).setup_std;
  return member ? u.*member : 0.0;
}

std::vector<SetupEffect> setup_effects(const Design& design, const std::vector<Reading>& rows,
                                       bool only_declared) {
  std::vector<SetupEffect> out;
  const ReadingLayout layout(design, rows);
  // The instrument's set-up effects (EffectInfo::setup): a ball bar's length offset and
  // centring, a probe's trigger offset and sphere placement.
  std::vector<EffectKind> kinds;
  for (EffectKind k : effect_kinds())
    if (effect_info(k).setup && effect_fits_instrument(k, design.instrument)) kinds.push_back(k);
  for (int i = 0; i < static_cast<int>(design.installations.size()); ++i) {
    const SetupUncertainty u = design.setup_of(i);
    for (EffectKind kind : kinds) {
      // A sphere's effect once, on its first channel.
      if (effect_info(kind).per_sphere && design.installations[i].coordinate != 0) continue;
      const double std_um = setup_std_um(u, kind);
      if (only_declared && !(std_um > 0)) continue;
      EffectBlock block = effect_block(design, rows, layout, {kind, i});
      if (!block.applicability.applicable()) continue;  // changes no reading of these rows
      out.push_back({kind, i, std::move(block.label), std::move(block.parameters),
                     std::move(block.J_reading_effect), std_um});
    }
  }
  return out;
}

SetupSolver::SetupSolver(const WlsSolver& base, const std::vector<SetupEffect>& declared)
    : base_(&base) {
  prior_ = base.a_priori();
  const int n = static_cast<int>(base.J().rows());
  int q = 0;
  for (const SetupEffect& e : declared) {
    if (e.std_um > 0) q += static_cast<int>(e.J_reading_effect.cols());
  }
  X_.resize(n, q);
  prior_std_.resize(q);
  int j = 0;
  for (std::size_t k = 0; k < declared.size(); ++k) {
    const SetupEffect& e = declared[k];
    if (!(e.std_um > 0)) continue;
    for (int c = 0; c < e.J_reading_effect.cols(); ++c, ++j) {
      X_.col(j) = e.J_reading_effect.col(c);
      prior_std_(j) = e.std_um;
      column_of_.emplace_back(static_cast<int>(k), c);
      column_kind_.push_back(e.kind);
    }
  }
  if (q == 0 || n == 0) return;
  // The covariance's low-rank term is the set-up part's alone: a base solved with border
  // columns (which has its own) is not combined with set-up effects.
  if (base.J_theta_reading().low_rank())
    throw std::logic_error("SetupSolver: a base solved with border columns");
  ++cost::detail::counters().factorisations;
  K_ = base.J_theta_reading() * X_;
  R_ = unexplained(base, X_, K_);
  RtR_ = R_.transpose() * R_;
  Eigen::MatrixXd S = RtR_;
  S.diagonal() += prior_std_.cwiseAbs2().cwiseInverse();
  // S is symmetric positive definite (P^-1 > 0): LDLT is exact enough and cheap (q x q).
  S_inv_ = S.ldlt().solve(Eigen::MatrixXd::Identity(q, q));
  S_inv_ = 0.5 * (S_inv_ + S_inv_.transpose());
  prior_.covariance_K = K_;
  prior_.covariance_S = S_inv_;
}

Eigen::VectorXd SetupSolver::beta(const Eigen::VectorXd& y_um) const {
  if (!any()) return Eigen::VectorXd(0);
  return S_inv_ * (R_.transpose() * unexplained(*base_, y_um));
}

Estimate SetupSolver::solve(const Eigen::VectorXd& y_um) const {
  if (!any()) return base_->solve(y_um);
  ++cost::detail::counters().solves;
  Estimate est = prior_;
  if (est.status == EstimateStatus::kNoReadings) return est;
  const Eigen::VectorXd b = beta(y_um);
  est.theta = base_->J_theta_reading() * Eigen::VectorXd(y_um - X_ * b);
  est.residual_um = y_um - base_->J() * est.theta - X_ * b;
  est.rms_um = std::sqrt(est.residual_um.squaredNorm() / est.n_readings);
  est.chi2 = est.residual_um.cwiseQuotient(base_->sigma_um()).squaredNorm() +
             b.cwiseQuotient(prior_std_).squaredNorm();
  if (est.dof > 0) est.p_value = chi2_upper_tail(est.dof, est.chi2);
  return est;
}

Eigen::MatrixXd SetupSolver::gain_times(const Eigen::MatrixXd& M) const {
  Eigen::MatrixXd GM = base_->J_theta_reading() * M;
  if (!any()) return GM;
  GM -= K_ * (S_inv_ * (R_.transpose() * unexplained(*base_, M, GM)));
  return GM;
}

Eigen::MatrixXd SetupSolver::left_gain(const FunctionRows& C) const {
  Eigen::MatrixXd A = base_->J_theta_reading().left(C);
  if (!any()) return A;
  const Eigen::VectorXd w = base_->sigma_um().cwiseInverse();
  const Eigen::MatrixXd TW = ((C * K_) * S_inv_ * R_.transpose()) * w.asDiagonal();  // n_out x n
  A -= TW;
  A += base_->J_theta_reading().left(Eigen::MatrixXd(TW * base_->J()));
  return A;
}

Eigen::MatrixXd SetupSolver::left_gain_setup(const FunctionRows& C) const {
  if (!any()) return Eigen::MatrixXd::Zero(C.rows(), 0);
  return (C * K_) * S_inv_;
}

Eigen::MatrixXd SetupSolver::left_gain_times(const FunctionRows& C, const Eigen::MatrixXd& L,
                                             const Eigen::MatrixXd& V) const {
  const Eigen::MatrixXd GV = base_->J_theta_reading() * V;
  Eigen::MatrixXd out = C * GV;
  if (any()) out.noalias() -= L * (R_.transpose() * unexplained(*base_, V, GV));
  return out;
}

Eigen::VectorXd SetupSolver::left_gain_l1(const FunctionRows& C) const {
  if (!any() && base_->J_theta_reading().series_l1()) return base_->J_theta_reading().left_l1(C);
  cost::detail::counters().l1_rows += C.rows();
  const Eigen::SparseMatrix<double, Eigen::RowMajor> G0 =
      base_->J_theta_reading().sparse();  // row j of G0 contiguous
  const Eigen::Index n = G0.cols();
  Eigen::MatrixXd Dt;  // D', n x q
  if (any()) {
    const Eigen::VectorXd w = base_->sigma_um().cwiseInverse();
    const Eigen::MatrixXd M = (S_inv_ * R_.transpose()) * w.asDiagonal();  // S^-1 R' W^1/2, q x n
    Dt = (base_->J_theta_reading().left(Eigen::MatrixXd(M * base_->J())) - M).transpose();
  }
  // Rows with the same support (a series: one error's coefficients; per angle: one station)
  // go together through one dense product on that support and the readings its rows of G0
  // touch, at most kChunk rows at a time, formed transposed so that each row's values are
  // contiguous; with a set-up part, (K'c)' D adds a value at every reading.
  const auto groups = detail::rows_by_support(C);
  constexpr std::size_t kChunk = 256;
  Eigen::VectorXd out = Eigen::VectorXd::Zero(C.rows());
  std::vector<Eigen::Index> touched;  // the readings the support's rows of G0 touch
  std::vector<Eigen::Index> at(static_cast<std::size_t>(n), -1);  // a reading's place among them
  for (const auto& [support, rows] : groups) {
    const Eigen::Index k = static_cast<Eigen::Index>(support.size());
    for (Eigen::Index j = 0; j < k; ++j) {
      for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator it(G0, support[j]); it;
           ++it) {
        if (at[it.col()] < 0)
          at[it.col()] = static_cast<Eigen::Index>(touched.size()), touched.push_back(it.col());
      }
    }
    const Eigen::Index nt = static_cast<Eigen::Index>(touched.size());
    Eigen::MatrixXd GsT =
        Eigen::MatrixXd::Zero(nt, k);  // (the rows of G0 on the support)', touched readings
    for (Eigen::Index j = 0; j < k; ++j) {
      for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator it(G0, support[j]); it;
           ++it) {
        GsT(at[it.col()], j) = it.value();
      }
    }
    for (std::size_t first = 0; first < rows.size(); first += kChunk) {
      const Eigen::Index m = static_cast<Eigen::Index>(std::min(kChunk, rows.size() - first));
      Eigen::MatrixXd CsT(k, m);
      for (Eigen::Index r = 0; r < m; ++r) {
        for (Eigen::Index j = 0; j < k; ++j) CsT(j, r) = C.coeff(rows[first + r], support[j]);
      }
      // Column r: row r of C G0 on the touched readings (+ (K'c)' D on all of them).
      Eigen::MatrixXd At = GsT * CsT;
      if (any()) {
        Eigen::MatrixXd KC(K_.cols(), m);
        for (Eigen::Index r = 0; r < m; ++r) {
          KC.col(r).setZero();
          for (FunctionRows::InnerIterator it(C, rows[first + r]); it; ++it)
            KC.col(r) += it.value() * K_.row(it.col()).transpose();
        }
        Eigen::MatrixXd full = Dt * KC;
        for (Eigen::Index t = 0; t < nt; ++t)
          full.row(touched[static_cast<std::size_t>(t)]) += At.row(t);
        At = std::move(full);
      }
      for (Eigen::Index r = 0; r < m; ++r) out(rows[first + r]) = At.col(r).lpNorm<1>();
    }
    for (Eigen::Index t : touched) at[t] = -1;
    touched.clear();
  }
  return out;
}

Eigen::MatrixXd SetupSolver::setup_draw_map(const FunctionRows& C) const {
  if (!any()) return Eigen::MatrixXd::Zero(C.rows(), 0);
  return (C * K_) * S_inv_ * prior_std_.cwiseInverse().asDiagonal();
}

Eigen::MatrixXd SetupSolver::setup_noise_map() const {
  if (!any()) return Eigen::MatrixXd::Zero(0, base_->J().rows());
  return R_.transpose() * base_->sigma_um().cwiseInverse().asDiagonal();
}

SetupSolver::Parts SetupSolver::parts(const Estimate::Function& c) const {
  Parts p;
  p.noise = std::max(0.0, prior_.base_variance(c));  // c'C0c
  p.setup_by_column = Eigen::VectorXd::Zero(n_columns());
  if (!any()) return p;
  const Eigen::VectorXd v =
      S_inv_ * prior_.low_rank_coordinates(c);  // S^-1 K'c (prior_.covariance_K = K)
  p.noise += v.dot(RtR_ * v);
  // set-up part per column: (S^-1 K'c)_j^2 / P_jj
  p.setup_by_column = v.cwiseQuotient(prior_std_).cwiseAbs2();
  p.setup = p.setup_by_column.sum();
  return p;
}

SetupSolver::JointParts SetupSolver::joint_parts(const Eigen::SparseMatrix<double>& C) const {
  JointParts p;
  p.noise =
      Eigen::MatrixXd(Eigen::SparseMatrix<double>(C.transpose() * prior_.covariance) * C);  // C'C0C
  if (!any()) {
    p.setup = Eigen::MatrixXd::Zero(C.cols(), C.cols());
    return p;
  }
  const Eigen::MatrixXd V = S_inv_ * (prior_.covariance_K.transpose() * C);  // S^-1 K'C, q x m
  p.noise += V.transpose() * RtR_ * V;
  const Eigen::MatrixXd Vp = prior_std_.cwiseInverse().asDiagonal() * V;  // P^-1/2 S^-1 K'C
  p.setup = Vp.transpose() * Vp;
  return p;
}

ErrorParts error_parts(const Parameterisation& param, const SetupSolver& solver) {
  ErrorParts out;
  const Estimate& est = solver.a_priori();
  out.noise.reserve(static_cast<std::size_t>(param.n_stations()));
  out.setup.reserve(static_cast<std::size_t>(param.n_stations()));
  out.total.reserve(static_cast<std::size_t>(param.n_stations()));
  for (int s = 0; s < param.n_stations(); ++s) {
    ErrorsAtAngle noise, setup, total;
    noise.station = setup.station = total.station = s;
    noise.angle_deg = setup.angle_deg = total.angle_deg = param.station_angle_deg(s);
    const Eigen::SparseMatrix<double> C = error_functions(param, s, est.n_unknowns);
    for (int k = 0; k < 6; ++k) {
      const Estimate::Function c = C.col(k);
      if (!est.determined(c)) continue;
      const SetupSolver::Parts p = solver.parts(c);
      noise.errors[k] = {true, 0.0, std::sqrt(p.noise)};
      setup.errors[k] = {true, 0.0, std::sqrt(p.setup)};
      total.errors[k] = {true, 0.0, std::sqrt(p.noise + p.setup)};
    }
    out.noise.push_back(noise);
    out.setup.push_back(setup);
    out.total.push_back(total);
  }
  return out;
}

namespace {

double find_noncentrality(int q, int dof, double alpha, double power) {
  namespace bm = boost::math;
  // In double precision throughout (Boost's default promotes to long double, six to twelve
  // times slower here, for digits far below the bisection's tolerance).
  using Policy = bm::policies::policy<bm::policies::promote_double<false>>;
  const double f_crit =
      bm::quantile(bm::complement(bm::fisher_f_distribution<double, Policy>(q, dof), alpha));
  auto power_at = [&](double lambda) {
    if (lambda <= 0) return alpha;
    return bm::cdf(
        bm::complement(bm::non_central_f_distribution<double, Policy>(q, dof, lambda), f_crit));
  };
  double lo = 0, hi = 1;
  double f_hi = power_at(hi) - power;
  while (f_hi < 0 && hi < 1e8) lo = hi, hi *= 2, f_hi = power_at(hi) - power;
  if (f_hi < 0) return hi;
  // The power rises with the noncentrality: the root in [lo, hi] by TOMS 748 (Alefeld, Potra
  // and Shi), to the same relative width as the bisection it replaces, in a few evaluations
  // of the noncentral F instead of about 35; the upper end, where the power is reached.
  const double f_lo = power_at(lo) - power;
  if (!(f_lo < 0)) return lo;
  std::uintmax_t iterations = 200;
  const auto bracket = bm::tools::toms748_solve(
      [&](double lambda) { return power_at(lambda) - power; }, lo, hi, f_lo, f_hi,
      [](double a, double b) { return std::abs(b - a) <= kBisection * std::max(a, b); },
      iterations);
  return bracket.second;
}

// Roots kept for the process: a search or a series of evaluations asks for the same few
// (q, dof, alpha, power) again and again. At most this many are kept.
constexpr std::size_t kNoncentralityCache = 4096;

}  // namespace

double noncentrality_for_power(int q, int dof, double alpha, double power) {
  using Key = std::tuple<int, int, double, double>;
  static std::mutex mutex;
  static std::map<Key, double> cache;
  if (!std::isfinite(alpha) || !std::isfinite(power))
    return find_noncentrality(q, dof, alpha, power);
  const Key key{q, dof, alpha, power};  // finite: the map's order is strict
  {
    const std::lock_guard<std::mutex> lock(mutex);
    const auto it = cache.find(key);
    if (it != cache.end()) return it->second;
  }
  const double lambda = find_noncentrality(q, dof, alpha, power);  // a pure function of the key
  const std::lock_guard<std::mutex> lock(mutex);
  if (cache.size() < kNoncentralityCache) cache.emplace(key, lambda);
  return lambda;
}

std::optional<double> detection_limit_um(int q, bool detectable, double min_information, int dof,
                                         const DetectionSettings& settings) {
  if (!detectable || q <= 0 || dof <= 0 || !(min_information > 0)) return std::nullopt;
  const double alpha = settings.level / std::max(1, settings.n_tests);
  return std::sqrt(noncentrality_for_power(q, dof, alpha, settings.power) / min_information);
}

namespace {

// One set-up effect's R_e = unexplained(base, X_e) (whitened), factorised once: its triangular
// factor T (the singular values of R_e), the whitened column norms |W X_e_j| and added_rank's
// scaled factor T D with its SVD (the rank it counts, and the directions beyond it).
struct EffectFactor {
  Eigen::MatrixXd T;
  Eigen::VectorXd norms;
  Eigen::JacobiSVD<Eigen::MatrixXd> scaled;
  int seen = 0;  // added_rank
};

EffectFactor effect_factor(const Eigen::VectorXd& w, const SetupEffect& e,
                           const Eigen::Ref<const Eigen::MatrixXd>& Re, bool with_directions) {
  EffectFactor f;
  f.T = triangular_factor(Re);  // one QR
  f.norms = (w.asDiagonal() * e.J_reading_effect).colwise().norm().transpose();
  if (f.T.cols() == 0 || f.T.rows() == 0) return f;
  f.scaled.compute(scaled_factor(f.T, f.norms), with_directions ? Eigen::ComputeFullV : 0);
  f.seen = rank_above_threshold(f.scaled.singularValues());
  return f;
}

// Its smallest singular value squared and whether added_rank sees all its columns.
SetupEffectInformation effect_information(const SetupEffect& e, const EffectFactor& f) {
  SetupEffectInformation info;
  info.kind = e.kind;
  info.installation = e.installation;
  info.declared_std_um = e.std_um;
  info.q = static_cast<int>(e.J_reading_effect.cols());
  info.detectable = f.seen == info.q;
  if (info.detectable) {
    const double r = Eigen::JacobiSVD<Eigen::MatrixXd>(f.T).singularValues()(info.q - 1);
    info.min_information = r * r;
  }
  return info;
}

// The directions of an effect's parameters that R_e leaves at zero where it sees some (none where
// it sees none: then no direction is singled out), by added_rank's rule: the right singular
// vectors v of the scaled factor T D beyond its added rank; a parameter direction D^-1 v, unit,
// its largest component positive. `f` was formed with its directions.
std::vector<std::vector<double>> hidden_directions(const EffectFactor& f) {
  std::vector<std::vector<double>> out;
  if (f.seen == 0) return out;  // none seen: every direction is the axis errors', none to name
  for (Eigen::Index k = f.seen; k < f.T.cols(); ++k) {
    Eigen::VectorXd v = f.scaled.matrixV().col(k);
    for (Eigen::Index j = 0; j < v.size(); ++j)
      if (f.norms(j) > 0) v(j) /= f.norms(j);
    v.normalize();
    Eigen::Index largest = 0;
    v.cwiseAbs().maxCoeff(&largest);
    if (v(largest) < 0) v = -v;
    out.emplace_back(v.data(), v.data() + v.size());
  }
  return out;
}

}  // namespace

SetupInformation dense_setup_information(const Design& design) {
  const Parameterisation param(design);
  const LinearModel model = design_model(design, param);
  const WlsSolver base(model.J, model.sigma_um);
  SetupInformation out;
  out.n_readings = base.a_priori().n_readings;
  out.rank = base.a_priori().rank;
  const Eigen::VectorXd w = base.sigma_um().cwiseInverse();
  for (const SetupEffect& e : setup_effects(design, model, true))
    out.effects.push_back(
        effect_information(e, effect_factor(w, e, unexplained(base, e.J_reading_effect), false)));
  return out;
}

EffectColumns effect_columns(const WlsSolver& base, const std::vector<SetupEffect>& effects) {
  EffectColumns out;
  Eigen::Index n_columns = 0;
  for (const SetupEffect& e : effects) n_columns += e.J_reading_effect.cols();
  out.X.resize(base.J().rows(), n_columns);
  n_columns = 0;
  for (const SetupEffect& e : effects) {
    out.X.middleCols(n_columns, e.J_reading_effect.cols()) = e.J_reading_effect;
    n_columns += e.J_reading_effect.cols();
  }
  out.G0X = base.J_theta_reading() * out.X;
  out.R = unexplained(base, out.X, out.G0X);
  return out;
}

DeterminedFunctions determined_functions(const Parameterisation& param, const Estimate& est) {
  DeterminedFunctions out;
  out.functions.reserve(6 * static_cast<std::size_t>(param.n_stations()));
  for (int s = 0; s < param.n_stations(); ++s) {
    const Eigen::SparseMatrix<double> C = error_functions(param, s, est.n_unknowns);
    for (int k = 0; k < 6; ++k) {
      const Estimate::Function c = C.col(k);
      if (!est.determined(c)) continue;
      const std::size_t first = out.nonzeros.size();
      for (Estimate::Function::InnerIterator it(c); it; ++it)
        out.nonzeros.emplace_back(it.index(), it.value());
      out.functions.push_back({s, k, first, out.nonzeros.size()});
    }
  }
  return out;
}

std::vector<SetupEffectCheck> check_setup_effects(const Parameterisation& param,
                                                  const SetupSolver& solver,
                                                  const std::vector<SetupEffect>& effects,
                                                  const DetectionSettings& settings,
                                                  double reference_length_mm) {
  return check_setup_effects(param, solver, effects, effect_columns(solver.base(), effects),
                             determined_functions(param, solver.a_priori()), settings,
                             reference_length_mm);
}

std::vector<SetupEffectCheck> check_setup_effects(
    const Parameterisation& param, const SetupSolver& solver,
    const std::vector<SetupEffect>& effects, const EffectColumns& columns,
    const DeterminedFunctions& fns, const DetectionSettings& settings, double reference_length_mm) {
  std::vector<SetupEffectCheck> out;
  const WlsSolver& base = solver.base();
  const Estimate& est = solver.a_priori();
  const Eigen::VectorXd w = base.sigma_um().cwiseInverse();
  out.reserve(effects.size());
  // Every effect's columns side by side: the base's gain times them and their unexplained part
  // (columns), and with declared set-up tolerances the full gain times them, in one product.
  const Eigen::MatrixXd& G0X = columns.G0X;
  const Eigen::MatrixXd& R = columns.R;
  const Eigen::MatrixXd GX_all = solver.any() ? solver.gain_times(columns.X) : Eigen::MatrixXd();
  Eigen::Index column = 0;  // the effect's first column in X
  for (const SetupEffect& e : effects) {
    SetupEffectCheck ch;
    ch.label = e.label;
    ch.installation = e.installation;
    ch.kind = e.kind;
    ch.declared_std_um = e.std_um;
    const Eigen::Index q = e.J_reading_effect.cols();
    // The directions beyond the rank are wanted only for an effect seen in part.
    const EffectFactor factor = effect_factor(w, e, R.middleCols(column, q), q > 1);
    const SetupEffectInformation info = effect_information(e, factor);
    ch.detectable = info.detectable;
    ch.parameters = e.parameters;
    if (!info.detectable && q > 1) ch.hidden_directions = hidden_directions(factor);
    // The noncentrality for the power depends on (q, dof) alone, and is kept
    // (noncentrality_for_power): the effects of every installation share a few.
    ch.detection_limit_um = detection_limit_um(info.q, info.detectable, info.min_information,
                                               est.n_readings - est.rank - info.q, settings);
    const auto GX =  // p x q: the estimate per um of the effect
        (solver.any() ? GX_all : G0X).middleCols(column, q);
    column += q;
    double best = -1;
    PlaceOfLargest place;  // the largest bias's error and angle, ties to the first
    for (const DeterminedFunctions::Function& f : fns.functions) {
      // |c' GX|, summed over c's nonzeros in their order.
      double b2 = 0;
      for (Eigen::Index k = 0; k < q; ++k) {
        const double cg = fns.dot(f, GX, k);
        b2 += cg * cg;
      }
      const double b = std::sqrt(b2);
      const double b_um = f.error >= 3 ? 1e-3 * reference_length_mm * b : b;
      best = std::max(best, b_um);
      if (place.offer(b_um)) {
        ch.bias_per_um = b;
        ch.bias_um_per_um = b_um;
        ch.bias_error = f.error;
        ch.bias_angle_deg = param.station_angle_deg(f.station);
      }
    }
    if (best <= kNoBias) {
      ch.bias_per_um.reset();
      ch.bias_um_per_um.reset();
      ch.bias_error = -1;
    }
    out.push_back(std::move(ch));
  }
  return out;
}

FirstOrderCheck first_order_check(const Design& design, const Parameterisation& param,
                                  const Eigen::VectorXd& theta) {
  FirstOrderCheck fc;
  fc.instrument = design.instrument;
  fc.noise_sigma_um = design.noise.sigma_um();
  for (const Installation& in : design.installations) {
    if (!in.bar_mm && !in.probe_channel()) {
      fc.without_bar = in.id;
      return fc;
    }
  }
  fc.computed = true;
  // The errors at each design angle, once for every installation.
  std::vector<Eigen::Matrix<double, 6, 1>> errors;
  errors.reserve(design.angles_deg.size());
  for (double a : design.angles_deg) errors.push_back(param.errors_at_angle(a, theta));
  const bool partial = design.partial_sweeps();
  for (int i = 0; i < static_cast<int>(design.installations.size()); ++i) {
    const Installation& in = design.installations[i];
    const SetupUncertainty u = design.setup_of(i);
    // 3 standard uncertainties of the ball placement [um] and of the centring (each component)
    // [um]: bounds on their perpendicular parts, added to the errors' relative displacement.
    const double placement_um =
        3e3 * std::sqrt(u.L_mm * u.L_mm + u.D_mm * u.D_mm + u.H_mm * u.H_mm);
    const double centring_um = 3.0 * u.centring_um * std::sqrt(3.0);
    std::vector<double> own = partial ? in.angles_deg : std::vector<double>{};
    std::sort(own.begin(), own.end());
    for (std::size_t ia = 0; ia < design.angles_deg.size(); ++ia) {
      const double a = design.angles_deg[ia];
      if (!own.empty() && angle_index(own, a) < 0) continue;  // not read at this angle
      const Eigen::Vector3d P = ball_position_mm(design.axis, in, a);
      const Eigen::Vector3d dir = direction_machine(design.axis, in, a);
      const Eigen::Matrix<double, 6, 1>& e6 = errors[ia];
      double term = 0;
      if (in.probe_channel()) {
        // A probe's reading is the sphere's displacement itself: its second-order part is the
        // exact transform's less the row's, at the identified errors.
        term = std::abs(exact_probe_reading_um(design.axis, in, a, e6, {}) -
                        J_reading_error(design.axis, in, a) * e6);
      } else {
        const Eigen::Vector3d dP = e6.head<3>() + 1e-3 * e6.tail<3>().cross(P);  // um
        const double perp = (dP - dP.dot(dir) * dir).norm() + placement_um + centring_um;
        term = perp * perp / (2.0 * *in.bar_mm * 1e3);
      }
      if (term > fc.largest_term_um) {
        fc.largest_term_um = term;
        fc.installation = in.id;
        fc.angle_deg = a;
      }
    }
  }
  fc.threshold_um = kFirstOrderWarning * fc.noise_sigma_um;
  fc.warn = fc.largest_term_um > fc.threshold_um;
  return fc;
}

void bound_first_order_bias(FirstOrderCheck& check, const SetupSolver& solver,
                            const Parameterisation& param, const Budget& budget) {
  if (!check.computed || budget.values.empty()) return;
  const Eigen::VectorXd l1 =
      solver.left_gain_l1(budget_functions(param, budget));  // |c'G|_1 per value
  PlaceOfLargest place;  // the bound is the largest ratio; its place ties to the first value
  for (std::size_t v = 0; v < budget.values.size(); ++v) {
    const ValueBudget& vb = budget.values[v];
    if (!(vb.u_c > 0)) continue;
    const double ratio = check.largest_term_um * l1(static_cast<Eigen::Index>(v)) / vb.u_c;
    if (ratio >= 0 && (!check.bias_bound_std || ratio > *check.bias_bound_std))
      check.bias_bound_std = ratio;
    if (place.offer(ratio)) {
      check.bias_error = vb.error;
      check.bias_angle_deg = vb.angle_deg;
    }
  }
}

std::vector<double> design_row_times(const Design& design, const TestClock& clock) {
  const std::size_t n = design.installations.size();
  // Each installation's time (its set-up and its readings), in the program's order.
  std::vector<double> duration(n);
  for (std::size_t k = 0; k < n; ++k)
    duration[k] = design.readings_per_sweep(static_cast<int>(k)) * clock.per_reading_s +
                  clock.per_installation_s;
  const std::vector<double> start = run_starts(design, duration);
  std::vector<double> out;
  for (std::size_t k = 0; k < n; ++k) {
    const std::vector<double>& angles = design.angles_of(static_cast<int>(k));
    std::vector<double> sorted = angles;
    std::sort(sorted.begin(), sorted.end());
    for (const double a : angles) {  // design_model's order, read in sweep order
      const auto at = std::lower_bound(sorted.begin(), sorted.end(), a) - sorted.begin();
      out.push_back(start[k] + static_cast<double>(at) * clock.per_reading_s);
    }
    if (design.readings_per_sweep(static_cast<int>(k)) > static_cast<int>(angles.size()))
      out.push_back(start[k] + static_cast<double>(sorted.size()) * clock.per_reading_s);
  }
  return out;
}

DriftChecks check_drift_effects(const Design& design, const Parameterisation& param,
                                const LinearModel& model, const SetupSolver& solver,
                                const DeterminedFunctions& functions,
                                const DetectionSettings& settings, double reference_length_mm,
                                const TestClock& clock) {
  DriftChecks out;
  out.clock = clock;
  const std::vector<double> t = design_row_times(design, clock);
  if (t.empty() || static_cast<Eigen::Index>(t.size()) != model.J.rows()) return out;
  const double T = *std::max_element(t.begin(), t.end());
  if (!(T > 0)) return out;
  out.test_min = T / 60.0;
  const Eigen::Index n = model.J.rows();
  // Detection as diagnose tests with declared set-up tolerances: against the axis errors and
  // the declared set-up effects held to their tolerances, i.e. the readings' model with one
  // pseudo-reading per set-up column (its value 0, its standard uncertainty the tolerance).
  // A drift that the set-up could take only far beyond its tolerance is thus seen.
  const std::vector<SetupEffect> declared = setup_effects(design, model, true);
  Eigen::Index q = 0;
  for (const SetupEffect& e : declared) q += e.J_reading_effect.cols();
  const Eigen::Index p = model.J.cols();
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(n + q, p + q);
  Eigen::VectorXd sigma(n + q);
  A.topLeftCorner(n, p) = Eigen::MatrixXd(model.J);
  sigma.head(n) = model.sigma_um;
  q = 0;
  for (const SetupEffect& e : declared) {
    for (Eigen::Index c = 0; c < e.J_reading_effect.cols(); ++c, ++q) {
      A.block(0, p + q, n, 1) = e.J_reading_effect.col(c);
      A(n + q, p + q) = 1.0;
      sigma(n + q) = e.std_um;
    }
  }
  const std::optional<WlsSolver> held =
      q > 0 ? std::optional<WlsSolver>(std::in_place, A, sigma) : std::nullopt;
  const WlsSolver& against = held ? *held : solver.base();
  out.rank = solver.a_priori().rank;
  out.n_unknowns = solver.a_priori().n_unknowns;
  // The held model determines every set-up column beside J's rank; one that does not (J near
  // rank loss, decided otherwise in the larger factorisation) would count what it loses as
  // the drift's: no detection is stated then.
  const bool consistent = against.a_priori().rank == out.rank + static_cast<int>(q);
  const int dof = solver.a_priori().n_readings - solver.a_priori().rank - 1;
  const Eigen::VectorXd w = model.sigma_um.cwiseInverse();
  const double tau = out.test_min / 4.0;
  for (const EffectKind kind : {EffectKind::kDrift, EffectKind::kThermal}) {
    SetupEffect e;
    e.kind = kind;
    e.installation = -1;
    e.parameters = {"value"};
    e.J_reading_effect.resize(n, 1);
    const double end = 1.0 - std::exp(-out.test_min / tau);
    for (Eigen::Index i = 0; i < n; ++i) {
      const double m = t[static_cast<std::size_t>(i)] / 60.0;
      e.J_reading_effect(i, 0) =
          kind == EffectKind::kDrift ? m / out.test_min : (1.0 - std::exp(-m / tau)) / end;
    }
    EffectCandidate c{kind, -1};
    if (kind == EffectKind::kThermal) c.tau_min = tau;
    e.label = c.label(design);
    const SetupEffectCheck bias =
        check_setup_effects(param, solver, {e}, effect_columns(solver.base(), {e}), functions,
                            settings, reference_length_mm)[0];
    DriftCheck d;
    d.label = e.label;
    d.kind = kind;
    d.tau_min = c.tau_min;
    d.bias_per_um = bias.bias_per_um;
    d.bias_um_per_um = bias.bias_um_per_um;
    d.bias_error = bias.bias_error;
    d.bias_angle_deg = bias.bias_angle_deg;
    Eigen::MatrixXd x = Eigen::MatrixXd::Zero(n + q, 1);
    x.topRows(n) = e.J_reading_effect;
    const Eigen::MatrixXd R = unexplained(against, held ? x : e.J_reading_effect);
    const Eigen::VectorXd norms =
        (w.asDiagonal() * e.J_reading_effect).colwise().norm().transpose();
    d.detectable = consistent && added_rank(R, norms) == 1;
    d.detection_limit_um = detection_limit_um(1, d.detectable, R.squaredNorm(), dof, settings);
    out.effects.push_back(std::move(d));
  }
  return out;
}

}  // namespace dbbkit
