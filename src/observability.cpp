#include "dbbkit/observability.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <cmath>
#include <limits>

#include "dbbkit/kinematics.hpp"
#include "dbbkit/linear_model.hpp"
#include "dbbkit/parameterisation.hpp"

namespace dbbkit {

ObservabilityIndices observability_indices(const Eigen::VectorXd& s, int rank, int p, int n) {
  ObservabilityIndices o;
  if (p == 0 || n == 0 || rank < p) return o;  // a zero singular value makes every index 0
  double log_sum = 0, inv_sum = 0;
  for (int i = 0; i < p; ++i) {
    log_sum += std::log(s(i));
    inv_sum += 1.0 / s(i);
  }
  const double s1 = s(0), sp = s(p - 1);
  o.O1 = std::exp(log_sum / p) / std::sqrt(static_cast<double>(n));
  o.O2 = sp / s1;
  o.O3 = sp;
  o.O4 = sp * sp / s1;
  o.O5 = 1.0 / inv_sum;
  return o;
}

DesignCriteria design_criteria(const WlsSolver& solver) {
  DesignCriteria c;
  const Estimate& est = solver.a_priori();
  if (est.status == EstimateStatus::kNoReadings) return c;
  const int p = est.n_unknowns;
  if (est.rank == p) {
    // M = diag(c) Js' Js diag(c): log det M = 2 sum log s_i + 2 sum log c_j.
    c.D_logdet = 2.0 * est.singular_values.head(p).array().log().sum() + 2.0 * est.column_scale.array().log().sum();
    c.A_trace = est.covariance.trace();
    const Eigen::MatrixXd M =
        solver.J().transpose() * solver.sigma_um().cwiseAbs2().cwiseInverse().asDiagonal() * solver.J();
    c.E_min_eigenvalue = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(M, Eigen::EigenvaluesOnly).eigenvalues()(0);
  }
  // Hat matrix H = J G (similar to the whitened one, same diagonal).
  c.G_max_leverage = (solver.J() * solver.gain()).diagonal().maxCoeff();
  return c;
}

namespace {

// The largest standard uncertainty over the values offered, angular errors in um
// at the reference length; worst_std_um only when no value was undetermined.
class WorstTracker {
 public:
  explicit WorstTracker(double reference_length_mm) : ref_(reference_length_mm) {}
  void add(double angle_deg, int error, double variance) {
    const double sd = std::sqrt(std::max(0.0, variance));
    const double u = error < 3 ? sd : 1e-3 * ref_ * sd;
    if (u > worst_) {
      worst_ = u;
      wc_.at_angle_deg = angle_deg;
      wc_.at_error = error;
    }
  }
  void undetermined() { ++wc_.n_undetermined; }
  WorstCase result() {
    if (worst_ >= 0) wc_.worst_determined_std_um = worst_;
    if (worst_ >= 0 && wc_.n_undetermined == 0) wc_.worst_std_um = worst_;
    return wc_;
  }

 private:
  double ref_;
  double worst_ = -1;
  WorstCase wc_;
};

}  // namespace

WorstCase worst_case(const std::vector<ErrorsAtAngle>& errors, double reference_length_mm) {
  WorstTracker worst(reference_length_mm);
  for (const ErrorsAtAngle& ea : errors) {
    for (int k = 0; k < 6; ++k) {
      if (ea.errors[k].determined) {
        worst.add(ea.angle_deg, k, ea.errors[k].std * ea.errors[k].std);
      } else {
        worst.undetermined();
      }
    }
  }
  return worst.result();
}

namespace {

// Inverse of a symmetric positive definite 6 x 6 matrix by Cholesky
// (M = L L', M^-1 = L^-T L^-1); false when a pivot is not positive.
bool inverse6(const double (&M)[6][6], double (&inv)[6][6]) {
  double L[6][6] = {}, X[6][6] = {};
  for (int j = 0; j < 6; ++j) {
    double d = M[j][j];
    for (int k = 0; k < j; ++k) d -= L[j][k] * L[j][k];
    if (!(d > 0)) return false;
    L[j][j] = std::sqrt(d);
    for (int i = j + 1; i < 6; ++i) {
      double v = M[i][j];
      for (int k = 0; k < j; ++k) v -= L[i][k] * L[j][k];
      L[i][j] = v / L[j][j];
    }
  }
  for (int j = 0; j < 6; ++j) {
    X[j][j] = 1.0 / L[j][j];
    for (int i = j + 1; i < 6; ++i) {
      double v = 0;
      for (int k = j; k < i; ++k) v += L[i][k] * X[k][j];
      X[i][j] = -v / L[i][i];
    }
  }
  for (int j = 0; j < 6; ++j) {
    for (int k = 0; k <= j; ++k) {
      double v = 0;
      for (int i = j; i < 6; ++i) v += X[i][j] * X[i][k];
      inv[j][k] = inv[k][j] = v;
    }
  }
  return true;
}

// The body-frame information of one reading of every installation, 6 x 6 (the sign squares away).
Eigen::Matrix<double, 6, 6> body_information(const Design& design) {
  Eigen::Matrix<double, 6, 6> Mb = Eigen::Matrix<double, 6, 6>::Zero();
  const double w = 1.0 / (design.noise.sigma_um() * design.noise.sigma_um());
  for (const Installation& in : design.installations) {
    Eigen::Matrix<double, 6, 1> r;
    r.head<3>() = in.direction.body;
    r.tail<3>() = 1e-3 * ball_body_mm(design.axis, in).cross(in.direction.body);
    Mb.noalias() += w * r * r.transpose();
  }
  return Mb;
}

// A series model: theta holds, error by error, the coefficients of the basis f(g); a reading's
// row is kron(r(g), f(g)), so an angle adds kron(Q(g), f f') with Q(g) = T Mb T' to the
// information M (p x p). M is equilibrated to unit diagonal (Ms, the scaling of the general
// solver), and used only when cond(Ms) <= p trace(Ms^-1) <= 1e10.
std::optional<WorstCase> fast_worst_case_series(const Design& design, double reference_length_mm) {
  const Parameterisation param(design);
  const int nb = param.coefficients_per_error(), p = param.n_parameters();
  const Eigen::Matrix<double, 6, 6> Mb = body_information(design);
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(p, p);
  for (double a : design.angles_deg) {
    Eigen::Matrix<double, 6, 6> T = Eigen::Matrix<double, 6, 6>::Zero();
    const Eigen::Matrix3d R = axis_rotation(design.axis, a);
    T.topLeftCorner<3, 3>() = R;
    T.bottomRightCorner<3, 3>() = R;
    const Eigen::Matrix<double, 6, 6> Q = T * Mb * T.transpose();
    const Eigen::VectorXd f = param.series_basis(a);
    const Eigen::MatrixXd ff = f * f.transpose();
    for (int k = 0; k < 6; ++k) {
      for (int l = 0; l < 6; ++l) M.block(k * nb, l * nb, nb, nb) += Q(k, l) * ff;
    }
  }
  const Eigen::VectorXd c = M.diagonal().cwiseSqrt();
  if (!(c.minCoeff() > 1e-12 * c.maxCoeff())) return std::nullopt;
  const Eigen::VectorXd ci = c.cwiseInverse();
  const Eigen::MatrixXd Ms = ci.asDiagonal() * M * ci.asDiagonal();
  const Eigen::LLT<Eigen::MatrixXd> llt(Ms);
  if (llt.info() != Eigen::Success) return std::nullopt;
  const Eigen::MatrixXd C = llt.solve(Eigen::MatrixXd::Identity(p, p));
  if (!(p * C.trace() <= 1e10)) return std::nullopt;
  WorstTracker worst(reference_length_mm);
  for (int st = 0; st < param.n_stations(); ++st) {
    const Eigen::VectorXd f = param.series_basis(param.station_angle_deg(st));
    for (int k = 0; k < 6; ++k) {
      const Eigen::VectorXd g = f.cwiseProduct(ci.segment(k * nb, nb));
      worst.add(param.station_angle_deg(st), k, g.dot(C.block(k * nb, k * nb, nb, nb) * g));
    }
  }
  return worst.result();
}

}  // namespace

namespace {

// Mb^-1, the covariance of the six errors at an angle met once, for a per-angle model
// whose every installation is read at every angle: the row of a reading at angle g is
// the body-frame row turned by T = diag(R(g), R(g)): s (R u, 1e-3 R P x R u) = s (R u,
// 1e-3 R (P x u)). So the information of one angle is T Mb T' with Mb the body-frame
// information, and a station met n times has the covariance T Mb^-1 T' / n: one 6 x 6
// inverse serves every angle. Absent when the design is near rank loss (below).
std::optional<Eigen::Matrix<double, 6, 6>> per_angle_body_covariance(const Design& design) {
  if (design.installations.empty() || design.errors.kind != ErrorModel::Kind::PerAngle) return std::nullopt;
  const Eigen::Matrix<double, 6, 6> Mbm = body_information(design);
  double Mb[6][6];
  for (int j = 0; j < 6; ++j) {
    for (int k = 0; k < 6; ++k) Mb[j][k] = Mbm(j, k);
  }
  // Scale the translation and the rotation block each by one number, a scaling that
  // commutes with T: with A = S Mb S, every angle's equilibrated Jacobian has
  // cond <= sqrt(6) cond(J S) (van der Sluis) and cond(J S)^2 = cond(A) <= trace A trace A^-1.
  double ct = 0, cr = 0;
  for (int j = 0; j < 3; ++j) ct += Mb[j][j] / 3, cr += Mb[j + 3][j + 3] / 3;
  if (!(ct > 0) || !(cr > 0)) return std::nullopt;
  const double sc[6] = {1 / std::sqrt(ct), 1 / std::sqrt(ct), 1 / std::sqrt(ct),
                        1 / std::sqrt(cr), 1 / std::sqrt(cr), 1 / std::sqrt(cr)};
  double A[6][6], Ai[6][6];
  double trace_A = 0, trace_Ai = 0;
  for (int j = 0; j < 6; ++j) {
    for (int k = 0; k < 6; ++k) A[j][k] = sc[j] * Mb[j][k] * sc[k];
    trace_A += A[j][j];
  }
  if (!inverse6(A, Ai)) return std::nullopt;
  for (int j = 0; j < 6; ++j) trace_Ai += Ai[j][j];
  if (!(std::sqrt(6.0 * trace_A * trace_Ai) <= 1e5)) return std::nullopt;  // cond(Js) <= 1e5 << 1e9
  Eigen::Matrix<double, 6, 6> C;
  for (int j = 0; j < 6; ++j) {
    for (int k = 0; k < 6; ++k) C(j, k) = sc[j] * Ai[j][k] * sc[k];
  }
  return C;
}

Eigen::Matrix<double, 6, 6> turned(Axis axis, double angle_deg, const Eigen::Matrix<double, 6, 6>& Cb) {
  Eigen::Matrix<double, 6, 6> T = Eigen::Matrix<double, 6, 6>::Zero();
  const Eigen::Matrix3d R = axis_rotation(axis, angle_deg);
  T.topLeftCorner<3, 3>() = R;
  T.bottomRightCorner<3, 3>() = R;
  return T * Cb * T.transpose();
}

}  // namespace

std::optional<WorstCase> fast_worst_case(const Design& design, double reference_length_mm) {
  if (design.installations.empty()) return std::nullopt;
  // Declared set-up tolerances change the estimate (setup.hpp): fast_worst_total answers.
  if (design.setup_nuisance_declared()) return std::nullopt;
  if (design.errors.kind != ErrorModel::Kind::PerAngle) return fast_worst_case_series(design, reference_length_mm);
  const std::optional<Eigen::Matrix<double, 6, 6>> Cb = per_angle_body_covariance(design);
  if (!Cb) return std::nullopt;
  const Eigen::Matrix3d Ct = Cb->topLeftCorner<3, 3>(), Cr = Cb->bottomRightCorner<3, 3>();
  const Parameterisation param(design);
  std::vector<int> count(param.n_stations(), 0);
  for (double a : design.angles_deg) ++count[param.station_of(a)];
  WorstTracker worst(reference_length_mm);
  for (int st = 0; st < param.n_stations(); ++st) {
    const Eigen::Matrix3d R = axis_rotation(design.axis, param.station_angle_deg(st));
    const Eigen::Vector3d vt = (R * Ct * R.transpose()).diagonal(), vr = (R * Cr * R.transpose()).diagonal();
    for (int k = 0; k < 6; ++k) worst.add(param.station_angle_deg(st), k, (k < 3 ? vt(k) : vr(k - 3)) / count[st]);
  }
  return worst.result();
}

std::optional<TotalWorstCase> fast_worst_total(const Design& design, double reference_length_mm) {
  if (!design.setup_nuisance_declared()) {
    const std::optional<WorstCase> w = fast_worst_case(design, reference_length_mm);
    if (!w) return std::nullopt;
    return TotalWorstCase{*w, *w};
  }
  // setup.hpp's quantities angle by angle. For a per-angle model the gain of J alone is
  // block-diagonal: the estimate at station s is C0_s J_s' W y_s with C0_s = T Mb^-1 T' / n_s
  // and J_s the rows of the angles of s. With B_s = J_s' W X_s (6 x q):
  //   K_s = C0_s B_s                        (the rows of K for station s)
  //   R'R = sum_a (X_a - J_a K_s)' W (X_a - J_a K_s)
  //   S = R'R + P^-1                        (q x q, the only coupling of the angles)
  // and for error k at station s, with V_s = S^-1 K_s' (q x 6):
  //   total = C0_s(k,k) + K_s(k,:) V_s(:,k),  set-up part = sum_j V_s(j,k)^2 / u_j^2,
  //   noise = total - set-up part           (K S^-1 R'R S^-1 K' = K S^-1 K' - K S^-1 P^-1 S^-1 K').
  // The columns are the effect library's (effect_row); a column touches one installation,
  // so B_s is summed reading by reading. Tested against dense_worst_total.
  const std::optional<Eigen::Matrix<double, 6, 6>> Cb = per_angle_body_covariance(design);
  if (!Cb) return std::nullopt;
  const Parameterisation param(design);
  const int m = static_cast<int>(design.installations.size());
  const int n_angles = static_cast<int>(design.angles_deg.size());
  const double w = 1.0 / (design.noise.sigma_um() * design.noise.sigma_um());
  // J rows and the set-up rows of every reading, angle-major: the effect library's own
  // rows (effect_row), a 1-vector for the length offset, 3 components for the centring.
  std::vector<RowVector6d> rows(static_cast<size_t>(n_angles) * m);
  std::vector<Eigen::Vector4d> setup_rows(static_cast<size_t>(n_angles) * m);  // offset, cx, cy, cz
  const double no_start = std::numeric_limits<double>::quiet_NaN();  // neither effect uses the time
  for (int a = 0; a < n_angles; ++a) {
    const Reading reading{"", design.angles_deg[a], 0.0, std::nullopt, std::nullopt, std::nullopt, 0};
    for (int i = 0; i < m; ++i) {
      rows[a * m + i] = J_reading_error(design.axis, design.installations[i], design.angles_deg[a]);
      setup_rows[a * m + i] << effect_row(design, reading, i, no_start, {EffectKind::LengthOffset, i}),
          effect_row(design, reading, i, no_start, {EffectKind::Centring, i});
    }
  }
  // The declared columns; a centring component that changes no reading is dropped (as
  // effect_block drops it).
  struct Column {
    int installation;
    int row_entry;  // into setup_rows: 0 length offset, 1..3 centring x, y, z
    double precision;
  };
  std::vector<Column> cols;
  for (int i = 0; i < m; ++i) {
    const SetupUncertainty u = design.setup_of(i);
    if (u.length_offset_um > 0) cols.push_back({i, 0, 1.0 / (u.length_offset_um * u.length_offset_um)});
    if (!(u.centring_um > 0)) continue;
    for (int c = 1; c <= 3; ++c) {
      double largest = 0;
      for (int a = 0; a < n_angles; ++a) largest = std::max(largest, std::abs(setup_rows[a * m + i](c)));
      if (largest > 1e-12) cols.push_back({i, c, 1.0 / (u.centring_um * u.centring_um)});
    }
  }
  const int q = static_cast<int>(cols.size());
  // X_a: each column is nonzero on one reading of the angle, that of its installation.
  Eigen::MatrixXd x(n_angles, q);
  for (int a = 0; a < n_angles; ++a) {
    for (int j = 0; j < q; ++j) x(a, j) = setup_rows[a * m + cols[j].installation](cols[j].row_entry);
  }
  const int n_st = param.n_stations();
  std::vector<int> station(n_angles), count(n_st, 0);
  std::vector<Eigen::Matrix<double, 6, Eigen::Dynamic>> B(n_st, Eigen::Matrix<double, 6, Eigen::Dynamic>::Zero(6, q));
  for (int a = 0; a < n_angles; ++a) {
    station[a] = param.station_of(design.angles_deg[a]);
    ++count[station[a]];
    for (int j = 0; j < q; ++j) B[station[a]].col(j) += (w * x(a, j)) * rows[a * m + cols[j].installation].transpose();
  }
  std::vector<Eigen::Matrix<double, 6, 6>> C0(n_st);
  std::vector<Eigen::Matrix<double, 6, Eigen::Dynamic>> K(n_st);
  for (int st = 0; st < n_st; ++st) {
    C0[st] = turned(design.axis, param.station_angle_deg(st), *Cb) / count[st];
    K[st] = C0[st] * B[st];
  }
  // R'R from R itself, angle by angle (X'WX - sum B'C0B is cheaper but loses the
  // digits of the effects the design barely sees).
  Eigen::MatrixXd RtR = Eigen::MatrixXd::Zero(q, q);
  Eigen::MatrixXd Ra(m, q);
  Eigen::Matrix<double, Eigen::Dynamic, 6> Ja(m, 6);
  for (int a = 0; a < n_angles; ++a) {
    for (int i = 0; i < m; ++i) Ja.row(i) = rows[a * m + i];
    Ra.noalias() = -Ja * K[station[a]];
    for (int j = 0; j < q; ++j) Ra(cols[j].installation, j) += x(a, j);
    RtR.noalias() += w * Ra.transpose() * Ra;
  }
  Eigen::MatrixXd S = RtR;
  for (int j = 0; j < q; ++j) S(j, j) += cols[j].precision;
  const Eigen::LLT<Eigen::MatrixXd> llt(S);
  if (llt.info() != Eigen::Success) return std::nullopt;  // rounding spoilt S (not seen): the general path answers
  WorstTracker noise(reference_length_mm), total(reference_length_mm);
  Eigen::VectorXd p(q);
  for (int j = 0; j < q; ++j) p(j) = cols[j].precision;
  for (int st = 0; st < n_st; ++st) {
    const Eigen::Matrix<double, Eigen::Dynamic, 6> V = llt.solve(K[st].transpose());
    const double angle = param.station_angle_deg(st);
    for (int k = 0; k < 6; ++k) {
      const double t = C0[st](k, k) + K[st].row(k).dot(V.col(k));
      total.add(angle, k, t);
      noise.add(angle, k, t - V.col(k).cwiseAbs2().dot(p));
    }
  }
  return TotalWorstCase{noise.result(), total.result()};
}

TotalWorstCase design_worst_total(const Design& design, double reference_length_mm) {
  if (std::optional<TotalWorstCase> t = fast_worst_total(design, reference_length_mm)) return *t;
  return dense_worst_total(design, reference_length_mm);
}

TotalWorstCase dense_worst_total(const Design& design, double reference_length_mm) {
  const Parameterisation param(design);
  const LinearModel model = design_model(design, param);
  const WlsSolver solver(model.J, model.sigma_um);
  const SetupSolver setup(solver, setup_effects(design, model, true));
  TotalWorstCase out;
  const ErrorParts parts = error_parts(param, setup);  // without declared tolerances: total = noise
  out.noise = worst_case(parts.noise, reference_length_mm);
  out.total = worst_case(parts.total, reference_length_mm);
  return out;
}

WorstCase design_worst_case(const Design& design, double reference_length_mm) {
  if (std::optional<WorstCase> w = fast_worst_case(design, reference_length_mm)) return *w;
  // The worst case alone: without the indices, criteria and set-up checks of evaluate_design.
  return design_worst_total(design, reference_length_mm).noise;
}

Evaluation evaluate_design(const Design& design, double reference_length_mm, const EstimateOptions& options,
                           const DetectionSettings& detection) {
  const Parameterisation param(design);
  const LinearModel model = design_model(design, param);
  const WlsSolver solver(model.J, model.sigma_um, options);
  Evaluation ev;
  ev.prior = solver.a_priori();
  ev.reference_length_mm = reference_length_mm;
  ev.indices = observability_indices(ev.prior.singular_values, ev.prior.rank, ev.prior.n_unknowns, ev.prior.n_readings);
  ev.criteria = design_criteria(solver);
  ev.prior.theta = Eigen::VectorXd::Zero(ev.prior.n_unknowns);
  ev.unidentifiable = describe_null_space(design, param, ev.prior);
  ev.detection = detection;

  // Every per-installation set-up effect is checked; those with a declared tolerance
  // (and only those: SetupSolver passes over the others) enter the estimate.
  const std::vector<SetupEffect> all = setup_effects(design, model, false);
  const SetupSolver setup(solver, all);
  ev.setup_checks = check_setup_effects(param, setup, all, detection, reference_length_mm);
  ErrorParts parts = error_parts(param, setup);
  ev.errors = std::move(parts.noise);
  if (setup.any()) {
    ev.setup_included = true;
    ev.setup_errors = std::move(parts.setup);
    ev.total_errors = std::move(parts.total);
    ev.worst_total = worst_case(ev.total_errors, reference_length_mm);
    ev.setup_note = "the uncertainties include the declared length offset and centring tolerances (total = noise and "
                    "set-up); the ball placement (L, D, H) is propagated at the identified errors by identify";
  } else {
    ev.setup_note = "set-up uncertainty is not included: the design declares no length offset or centring tolerance "
                    "(setup_std)";
  }
  ev.worst = worst_case(ev.errors, reference_length_mm);
  return ev;
}

std::vector<SweepPoint> sweep_design(const Design& design, const std::vector<SweepVariable>& variables,
                                     double reference_length_mm) {
  std::vector<SweepPoint> out;
  std::vector<size_t> index(variables.size(), 0);
  for (const SweepVariable& v : variables) {
    if (v.values.empty()) return out;
  }
  while (true) {
    Design d = design;
    SweepPoint p;
    for (size_t i = 0; i < variables.size(); ++i) {
      const double x = variables[i].values[index[i]];
      p.values.push_back(x);
      for (int inst : variables[i].installations) {
        Installation& in = d.installations[inst];
        (variables[i].coord == 0 ? in.L_mm : variables[i].coord == 1 ? in.D_mm : in.H_mm) = x;
      }
    }
    validate_design(d, "--sweep");
    const Evaluation ev = evaluate_design(d, reference_length_mm);
    p.rank = ev.prior.rank;
    p.n_unknowns = ev.prior.n_unknowns;
    p.condition_number = ev.prior.condition_number;
    p.worst_std_um = ev.worst.worst_std_um;
    p.worst_determined_std_um = ev.worst.worst_determined_std_um;
    out.push_back(p);
    int i = static_cast<int>(variables.size()) - 1;
    while (i >= 0 && ++index[i] == variables[i].values.size()) index[i--] = 0;
    if (i < 0) break;
  }
  return out;
}

}  // namespace dbbkit
