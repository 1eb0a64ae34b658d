#include "dbbkit/observability.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <array>
#include <cmath>
#include <limits>

#include "dbbkit/effects.hpp"
#include "dbbkit/instrument.hpp"
#include "dbbkit/kinematics.hpp"
#include "dbbkit/linear_model.hpp"
#include "dbbkit/parameterisation.hpp"
#include "dbbkit/warnings.hpp"
#include "factorised.hpp"
#include "setup_solver.hpp"
#include "small_eigen.hpp"
#include "tolerances.hpp"
#include "wls_solver.hpp"

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
    c.D_logdet = 2.0 * est.singular_values.head(p).array().log().sum() +
                 2.0 * est.column_scale.array().log().sum();
    double trace = 0;
    for (int j = 0; j < p; ++j) trace += est.covariance.coeff(j, j);
    c.A_trace = trace;
    // M = J' W J is block-diagonal over the solver's blocks: its smallest eigenvalue is the
    // smallest of the blocks'. A block with M_b - (1 - kTieRelative) e I positive definite (e the
    // smallest so far) lowers it by less than the tie width, and its eigenvalues are not
    // computed: a symmetric design's stations have the same eigenvalues to rounding.
    const Eigen::VectorXd w = solver.sigma_um().cwiseAbs2().cwiseInverse();
    std::optional<double> e_min;
    std::vector<int> local(static_cast<std::size_t>(p), -1);
    // A station's block in fixed storage, a larger one (or one whose steps did not converge)
    // by Eigen's solver; storage kept from block to block.
    detail::SmallSymmetricEigen small_eig;
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig;
    Eigen::MatrixXd M;
    for (const WlsSolver::Block& b : solver.blocks()) {
      const int m = static_cast<int>(b.cols.size());
      for (int a = 0; a < m; ++a) local[static_cast<std::size_t>(b.cols[a])] = a;
      M.setZero(m, m);
      for (int i : b.rows) {
        for (Jacobian::InnerIterator x(solver.J(), i); x; ++x) {
          for (Jacobian::InnerIterator y(solver.J(), i); y; ++y) {
            M(local[x.col()], local[y.col()]) += w(i) * x.value() * y.value();
          }
        }
      }
      if (m > 1 && e_min && *e_min > 0 &&
          detail::positive_definite_shifted(M, (1.0 - tol::kTieRelative) * *e_min))
        continue;
      double e = M(0, 0);
      if (m > 1 && small_eig.compute(M, false)) {
        e = small_eig.eigenvalue(0);
      } else if (m > 1) {
        e = eig.compute(M, Eigen::EigenvaluesOnly).eigenvalues()(0);
      }
      e_min = e_min ? std::min(*e_min, e) : e;
    }
    if (e_min) c.E_min_eigenvalue = *e_min;
  }
  // Hat matrix H = J G (similar to the whitened one, same diagonal): h_i = J_i . G_{:,i}.
  Eigen::VectorXd h = Eigen::VectorXd::Zero(solver.J().rows());  // n >= 1 past the early return
  for (Eigen::Index i = 0; i < h.size(); ++i) h(i) = solver.leverage(i);
  c.G_max_leverage = h.maxCoeff();
  return c;
}

namespace {

// The largest standard uncertainty over the values offered, angular errors in um
// at the reference length; worst_std_um only when no value was undetermined. Its place is
// the first value offered within tol::kTieRelative of the largest (PlaceOfLargest).
class WorstTracker {
 public:
  explicit WorstTracker(double reference_length_mm)
      : scale2_(1e-6 * reference_length_mm * reference_length_mm) {}
  // Compared as squares [um^2]; one square root at the end.
  void add(double angle_deg, int error, double variance) {
    const double u2 = std::max(0.0, variance) * (error < 3 ? 1.0 : scale2_);
    worst2_ = std::max(worst2_, u2);
    if (place_.offer(u2)) {
      wc_.at_angle_deg = angle_deg;
      wc_.at_error = error;
    }
  }
  void undetermined() { ++wc_.n_undetermined; }
  WorstCase result() {
    if (worst2_ >= 0) wc_.worst_determined_std_um = std::sqrt(worst2_);
    if (worst2_ >= 0 && wc_.n_undetermined == 0) wc_.worst_std_um = std::sqrt(worst2_);
    return wc_;
  }

 private:
  double scale2_;  // (1e-3 reference length)^2: an angular error's variance [urad^2] in um^2
  double worst2_ = -1;
  PlaceOfLargest place_;
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
  if (!(c.minCoeff() > tol::kMinColumnScale * c.maxCoeff())) return std::nullopt;
  const Eigen::VectorXd ci = c.cwiseInverse();
  const Eigen::MatrixXd Ms = ci.asDiagonal() * M * ci.asDiagonal();
  const Eigen::LLT<Eigen::MatrixXd> llt(Ms);
  if (llt.info() != Eigen::Success) return std::nullopt;
  const Eigen::MatrixXd C = llt.solve(Eigen::MatrixXd::Identity(p, p));
  if (!(p * C.trace() <= tol::kFastSeriesCondition)) return std::nullopt;
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
// The lower triangle (k <= j) of the information w sum_i r_i r_i' of body-frame rows r_i, each
// entry the products of body_information (w r_j) r_k in the same order.
struct LowerInformation {
  double M[6][6];
  LowerInformation() {
    for (int j = 0; j < 6; ++j) {
      for (int k = 0; k <= j; ++k) M[j][k] = 0;
    }
  }
  template <typename Row>
  void add(double w, const Row& r) {
    for (int j = 0; j < 6; ++j) {
      const double wr = w * r(j);
      for (int k = 0; k <= j; ++k) M[j][k] += wr * r(k);
    }
  }
};

// Mb: the body information's lower triangle (k <= j), the only part read.
std::optional<Eigen::Matrix<double, 6, 6>> per_angle_body_covariance(const Design& design,
                                                                     const double (&Mb)[6][6]) {
  if (design.installations.empty() || design.errors.kind != ErrorModel::Kind::kPerAngle)
    return std::nullopt;
  // Scale the translation and the rotation block each by one number, a scaling that
  // commutes with T: with A = S Mb S, every angle's equilibrated Jacobian has
  // cond <= sqrt(6) cond(J S) (van der Sluis) and cond(J S)^2 = cond(A) <= trace A trace A^-1.
  double ct = 0, cr = 0;
  for (int j = 0; j < 3; ++j) ct += Mb[j][j] / 3, cr += Mb[j + 3][j + 3] / 3;
  if (!(ct > 0) || !(cr > 0)) return std::nullopt;
  const double sc[6] = {1 / std::sqrt(ct), 1 / std::sqrt(ct), 1 / std::sqrt(ct),
                        1 / std::sqrt(cr), 1 / std::sqrt(cr), 1 / std::sqrt(cr)};
  double A[6][6], Ai[6][6];  // inverse6 reads the lower triangle of A
  double trace_A = 0, trace_Ai = 0;
  for (int j = 0; j < 6; ++j) {
    for (int k = 0; k <= j; ++k) A[j][k] = sc[j] * Mb[j][k] * sc[k];
    trace_A += A[j][j];
  }
  if (!inverse6(A, Ai)) return std::nullopt;
  for (int j = 0; j < 6; ++j) trace_Ai += Ai[j][j];
  if (!(std::sqrt(6.0 * trace_A * trace_Ai) <= tol::kFastPerAngleCondition)) return std::nullopt;
  Eigen::Matrix<double, 6, 6> C;
  for (int j = 0; j < 6; ++j) {
    for (int k = 0; k < 6; ++k) C(j, k) = sc[j] * Ai[j][k] * sc[k];
  }
  return C;
}
std::optional<Eigen::Matrix<double, 6, 6>> per_angle_body_covariance(const Design& design) {
  if (design.installations.empty() || design.errors.kind != ErrorModel::Kind::kPerAngle)
    return std::nullopt;
  LowerInformation Mb;
  const double w = 1.0 / (design.noise.sigma_um() * design.noise.sigma_um());
  for (const Installation& in : design.installations) {
    Eigen::Matrix<double, 6, 1> r;
    r.head<3>() = in.direction.body;
    r.tail<3>() = 1e-3 * ball_body_mm(design.axis, in).cross(in.direction.body);
    Mb.add(w, r);
  }
  return per_angle_body_covariance(design, Mb.M);
}

// An orthonormal basis U (m x (m - 6)) of the complement of the range of A (m x 6, full
// rank, m > 6): the last m - 6 columns of Q in A = Q R, by Householder reflections
// H_k = I - beta_k v_k v_k' (Q = H_0 ... H_5 applied to the last unit vectors). Accurate
// to rounding whatever the conditioning of A, unlike I - A (A'A)^-1 A'.
Eigen::MatrixXd orthonormal_complement(Eigen::Matrix<double, Eigen::Dynamic, 6> A) {
  const Eigen::Index m = A.rows();
  double beta[6];
  for (int k = 0; k < 6; ++k) {
    auto x = A.col(k).tail(m - k);
    const double norm = x.norm();
    const double alpha = x(0) > 0 ? -norm : norm;
    x(0) -= alpha;  // v_k, kept in the column
    const double vv = x.squaredNorm();
    beta[k] = vv > 0 ? 2.0 / vv : 0.0;
    for (int j = k + 1; j < 6; ++j)
      A.col(j).tail(m - k) -= (beta[k] * x.dot(A.col(j).tail(m - k))) * x;
  }
  Eigen::MatrixXd U = Eigen::MatrixXd::Zero(m, m - 6);
  for (Eigen::Index r = 0; r < m - 6; ++r) U(6 + r, r) = 1.0;
  for (int k = 5; k >= 0; --k) {
    const auto v = A.col(k).tail(m - k);
    for (Eigen::Index r = 0; r < m - 6; ++r)
      U.col(r).tail(m - k) -= (beta[k] * v.dot(U.col(r).tail(m - k))) * v;
  }
  return U;
}

// A small symmetric positive definite S (r x r, lower triangle used) overwritten by its
// Cholesky factor L (S = L L'; false when a pivot is not positive); then L^-1 B and L^-T B
// for a row-major right-hand side of 18 columns, a row of B at a time (contiguous axpy;
// Eigen's blocked triangular solvers pay their set-up at these sizes).
using Rhs18 = Eigen::Matrix<double, Eigen::Dynamic, 18, Eigen::RowMajor>;
bool small_cholesky(Eigen::MatrixXd& S) {
  const Eigen::LLT<Eigen::Ref<Eigen::MatrixXd>> llt(S);  // in place: the lower triangle becomes L
  return llt.info() == Eigen::Success;
}
void forward_solve(const Eigen::MatrixXd& L, Rhs18& B) {
  const Eigen::Index q = L.rows();
  double* b = B.data();
  for (Eigen::Index k = 0; k < q; ++k) {
    double* bk = b + 18 * k;
    const double inv = 1.0 / L(k, k);
    for (int c = 0; c < 18; ++c) bk[c] *= inv;
    const double* lk = L.data() + k * q;
    for (Eigen::Index i = k + 1; i < q; ++i) {
      double* bi = b + 18 * i;
      for (int c = 0; c < 18; ++c) bi[c] -= lk[i] * bk[c];
    }
  }
}
void backward_solve(const Eigen::MatrixXd& L, Rhs18& B) {
  const Eigen::Index q = L.rows();
  double* b = B.data();
  for (Eigen::Index k = q - 1; k >= 0; --k) {
    double* bk = b + 18 * k;
    const double inv = 1.0 / L(k, k);
    for (int c = 0; c < 18; ++c) bk[c] *= inv;
    for (Eigen::Index i = 0; i < k; ++i) {  // L'(i, k) = L(k, i)
      double* bi = b + 18 * i;
      const double l = L(k, i);
      for (int c = 0; c < 18; ++c) bi[c] -= l * bk[c];
    }
  }
}
// For b = 0 (translation) and 1 (rotation): the Gram matrix sum_j f_j f_j' of the 9
// columns 6h + 3b + e (h, e = 0..2) of A, row by row (9 x 9, [3h + e][3l + e']).
void block_grams(const Rhs18& A, std::array<Eigen::Matrix<double, 9, 9>, 2>& out) {
  out[0].setZero();
  out[1].setZero();
  for (Eigen::Index j = 0; j < A.rows(); ++j) {
    const double* a = A.data() + 18 * j;
    for (int b = 0; b < 2; ++b) {
      Eigen::Matrix<double, 9, 1> x;
      for (int h = 0; h < 3; ++h) {
        for (int e = 0; e < 3; ++e) x(3 * h + e) = a[6 * h + 3 * b + e];
      }
      out[b].noalias() += x * x.transpose();
    }
  }
}

// What the closed forms of a per-angle design with set-up columns (fast_worst_total,
// fast_setup_information) start from: the stations, how often each is met and its
// harmonics phi = (1, cos g, sin g) with Phi = sum over the readings of phi phi'; the
// rotation as R(g) = A0 + cos g A1 + sin g A2 (a rotation about a fixed axis); the
// body-frame rows Jb and the weight w of the one noise.
struct PerAngleHarmonics {
  const AngleStations& st;
  int m = 0, n_st = 0;
  double w = 0;
  const std::vector<int>& count;  // st.count
  std::vector<Eigen::Vector3d> phi;
  Eigen::Matrix3d Phi = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d A0, A1, A2;
  Eigen::Matrix<double, Eigen::Dynamic, 6> Jb;

  // stations: the design's (AngleStations::serves).
  PerAngleHarmonics(const Design& design, const AngleStations& stations)
      : st(stations),
        m(static_cast<int>(design.installations.size())),
        n_st(stations.n_stations()),
        w(1.0 / (design.noise.sigma_um() * design.noise.sigma_um())),
        count(stations.count),
        phi(n_st),
        Jb(m, 6) {
    for (int k = 0; k < n_st; ++k) {
      phi[k] = Eigen::Vector3d(1.0, stations.cos[k], stations.sin[k]);
      Phi.noalias() += count[k] * phi[k] * phi[k].transpose();
    }
    const RotationHarmonics& h = rotation_harmonics(design.axis);
    A0 = h.A0;
    A1 = h.A1;
    A2 = h.A2;
    for (int i = 0; i < m; ++i)
      Jb.row(i) = J_reading_error(design.axis, design.installations[i], 0.0);
  }

  // The centring row of installation i as harmonics: C = [A0 c, A1 c, A2 c] (component k,
  // harmonic h), c its row at angle 0 (effects.hpp), so its value at g is C phi(g).
  Eigen::Matrix3d centring_harmonics(const Design& design, int i) const {
    const Eigen::Vector3d c = centring_row(design.axis, design.installations[i], 0.0);
    Eigen::Matrix3d C;
    C << A0 * c, A1 * c, A2 * c;
    return C;
  }
};

// The variances of the six errors at angle g of T Cb T' (T = diag(R, R), R = A0 + cos g A1 +
// sin g A2): row k of R is sum_h phi_h a_hk (a_hk the row k of A_h, phi = (1, cos g, sin g)),
// so the variance of error k is phi' Q_k phi, Q_k(h, l) = a_hk' C a_lk (C its 3 x 3 block
// of Cb). coef[u][e]: the coefficient of monomial u of (1, c, s, c^2, c s, s^2) for error e.
void rotated_variance_coefficients(const Eigen::Matrix<double, 6, 6>& Cb, const AxisFrame& axis,
                                   double (&coef)[6][6]) {
  const RotationHarmonics& rh = rotation_harmonics(axis);
  const Eigen::Matrix3d* A[3] = {&rh.A0, &rh.A1, &rh.A2};
  for (int e = 0; e < 6; ++e) {
    const Eigen::Matrix3d C = Cb.block<3, 3>(3 * (e / 3), 3 * (e / 3));
    Eigen::Vector3d a[3], Ca[3];
    for (int h = 0; h < 3; ++h) a[h] = A[h]->row(e % 3).transpose(), Ca[h] = C * a[h];
    Eigen::Matrix3d Q;
    for (int h = 0; h < 3; ++h) {
      for (int l = 0; l < 3; ++l) Q(h, l) = a[h].dot(Ca[l]);
    }
    coef[0][e] = Q(0, 0);
    coef[1][e] = Q(0, 1) + Q(1, 0);
    coef[2][e] = Q(0, 2) + Q(2, 0);
    coef[3][e] = Q(1, 1);
    coef[4][e] = Q(1, 2) + Q(2, 1);
    coef[5][e] = Q(2, 2);
  }
}

// The stations given when they serve the design, else its own (formed in own).
const AngleStations& stations_of(const Design& design, const AngleStations* given,
                                 std::optional<AngleStations>& own) {
  if (given && given->serves(design)) return *given;
  return own.emplace(design.axis, design.angles_deg);
}

}  // namespace

AngleStations::AngleStations(const AxisFrame& axis_, const std::vector<double>& angles)
    : axis(axis_), angles_deg(angles) {
  Design d;
  d.axis = axis;
  d.angles_deg = angles;
  d.errors.kind = ErrorModel::Kind::kPerAngle;
  const Parameterisation param(d);
  count.assign(param.n_stations(), 0);
  for (int k : param.design_stations()) ++count[k];
  station_deg.resize(param.n_stations());
  sin.resize(param.n_stations());
  cos.resize(param.n_stations());
  for (int k = 0; k < param.n_stations(); ++k) {
    station_deg[k] = param.station_angle_deg(k);
    sincos_deg(station_deg[k], sin[k], cos[k]);
  }
}

bool AngleStations::serves(const Design& design) const {
  return design.axis.same_as(axis) && design.angles_deg == angles_deg;
}

std::optional<WorstCase> fast_worst_case(const Design& design, double reference_length_mm,
                                         const AngleStations* stations) {
  // A return reading reads one angle twice: the closed forms take one reading per angle, of
  // every installation, each along a direction that turns with the axis.
  if (design.return_reading || design.partial_sweeps() || !design.directions_turn())
    return std::nullopt;
  if (design.installations.empty()) return std::nullopt;
  // Declared set-up tolerances change the estimate (setup.hpp): fast_worst_total answers.
  if (design.setup_nuisance_declared()) return std::nullopt;
  if (design.errors.kind != ErrorModel::Kind::kPerAngle)
    return fast_worst_case_series(design, reference_length_mm);
  const std::optional<Eigen::Matrix<double, 6, 6>> Cb = per_angle_body_covariance(design);
  if (!Cb) return std::nullopt;
  std::optional<AngleStations> own;
  const AngleStations& at = stations_of(design, stations, own);
  double coef[6][6];  // [monomial][error], formed once for every station
  rotated_variance_coefficients(*Cb, design.axis, coef);
  WorstTracker worst(reference_length_mm);
  for (int st = 0; st < at.n_stations(); ++st) {
    const double c = at.cos[st], s = at.sin[st];
    const double mono[6] = {1.0, c, s, c * c, c * s, s * s};
    double v[6];
    for (int e = 0; e < 6; ++e) v[e] = coef[0][e];
    for (int u = 1; u < 6; ++u) {
      for (int e = 0; e < 6; ++e) v[e] += coef[u][e] * mono[u];
    }
    const double inv_n = 1.0 / at.count[st];
    for (int e = 0; e < 6; ++e) worst.add(at.station_deg[st], e, v[e] * inv_n);
  }
  return worst.result();
}

std::optional<TotalWorstCase> fast_worst_total(const Design& design, double reference_length_mm,
                                               bool with_noise_part,
                                               const AngleStations* stations) {
  // A return reading reads one angle twice: the closed forms take one reading per angle, of
  // every installation, each along a direction that turns with the axis.
  if (design.return_reading || design.partial_sweeps() || !design.directions_turn())
    return std::nullopt;
  if (!design.setup_nuisance_declared()) {
    const std::optional<WorstCase> w = fast_worst_case(design, reference_length_mm, stations);
    if (!w) return std::nullopt;
    return TotalWorstCase{*w, *w};
  }
  // setup.hpp's quantities for a per-angle model whose every installation is read at every
  // angle, in closed form over the angles and in the space of the installations.
  //
  // Angles. The rows of J at angle g are the body-frame rows turned, J_g = Jb T(g)' with
  // T = diag(R, R) (per_angle_body_covariance). A set-up row of installation i is
  // (1, R(g) c_i), c_i = -s_i u_i its centring row at angle 0 (effects.hpp), and with
  // R(g) = A0 + cos g A1 + sin g A2 (a rotation about a fixed axis) every set-up column is
  // phi(g)' x_j on its installation's reading, phi = (1, cos g, sin g), x_j its three
  // harmonic coefficients. At a station met n times:
  //   C0 = T Cb T' / n,   K = C0 n J_g' W X_g = T sum_h phi_h K_h,   K_h = G X_h,   G = Cb Jb' W
  //   R_g = X_g - J_g K = sum_h phi_h (I - Jb G) X_h,   R'R = sum_hl Phi_hl X_h' W N X_l
  // with Phi = sum_stations n phi phi' and N = I - Jb G = U U' (equal weights make Jb G the
  // orthogonal projector; U (m x (m - 6)) the orthonormal complement of the range of Jb).
  //
  // Installations. Only the amplitudes eta_i = sum_{j of i} x_j theta_j reach the readings,
  // with prior covariance Pi_i = sum_{j of i} u_j^2 x_j x_j' (3 x 3). With Phi = Lp Lp',
  // R'R = V'V for V = sqrt(w) (U' (x) Lp') applied to the amplitudes: rank r = 3 (m - 6),
  // whatever the number of columns. Woodbury, S^-1 = (P^-1 + V'V)^-1 = P - P V' A^-1 V P
  // with A = I + V P V' (r x r, eigenvalues >= 1), B = V P K' (r x 18):
  //   K S^-1 K' = K P K' - B' A^-1 B = K P K' - F'F,          F = L^-1 B,  A = L L'
  //   its noise part K S^-1 R'R S^-1 K' = Z'Z,  Z = V S^-1 K' = A^-1 B = L^-T F
  // and entry by entry, over the installations i (g_i the column i of G):
  //   (K_h P K_l')(e, e') = sum_i Pi_i(h, l) g_i(e) g_i(e')
  //   B[(rho, k), (h, e)] = sqrt(w) sum_i U(i, rho) g_i(e) (Lp' Pi_i)(k, h)
  //   A[(rho, k), (rho', k')] = delta + w sum_i U(i, rho) U(i, rho') (Lp' Pi_i Lp)(k, k').
  // So for error e at station s: total = diag T (Cb / n + sum_hl phi_h phi_l (K_h P K_l' -
  // F_h'F_l)) T' and noise part = diag T (Cb / n + sum_hl phi_h phi_l Z_h'Z_l) T'.
  // K P K' - F'F is a difference: a prior far larger than what the readings leave sends
  // the design to the general path (below). Tested against dense_worst_total, whose
  // set-up columns are J_reading_effect's at every angle.
  if (design.installations.empty() || design.errors.kind != ErrorModel::Kind::kPerAngle)
    return std::nullopt;
  std::optional<AngleStations> own;
  const PerAngleHarmonics h(design, stations_of(design, stations, own));
  // body_information from the body-frame rows (the same products: the sign squares away).
  LowerInformation Mb;
  for (int i = 0; i < h.m; ++i) Mb.add(h.w, h.Jb.row(i));
  const std::optional<Eigen::Matrix<double, 6, 6>> Cb = per_angle_body_covariance(design, Mb.M);
  if (!Cb) return std::nullopt;
  const int m = h.m, n_st = h.n_st;
  const double w = h.w;
  const std::vector<int>& count = h.count;
  const Eigen::Matrix<double, Eigen::Dynamic, 6>& Jb = h.Jb;
  // Per installation, Pi_i: the length offset's x = (1, 0, 0), the centring's three
  // components x = ((A0 c)_k, (A1 c)_k, (A2 c)_k), so sum_k x x' = C'C with C = [A0 c, A1 c, A2 c].
  std::vector<Eigen::Matrix3d> Pi(m);
  for (int i = 0; i < m; ++i) {
    const SetupUncertainty u = design.setup_of(i);
    Pi[i].setZero();
    Pi[i](0, 0) = u.length_offset_um * u.length_offset_um * kLengthOffsetRow * kLengthOffsetRow;
    if (u.centring_um > 0) {
      const Eigen::Matrix3d C = h.centring_harmonics(design, i);
      Pi[i].noalias() += (u.centring_um * u.centring_um) * C.transpose() * C;
    }
  }
  const Eigen::Matrix<double, 6, Eigen::Dynamic> G = w * (*Cb) * Jb.transpose();
  // K P K' by blocks: for b = 0 (translation), 1 (rotation), [3h + e][3l + e'].
  std::array<Eigen::Matrix<double, 9, 9>, 2> kpk, ff, zz;
  for (int b = 0; b < 2; ++b) {
    kpk[b].setZero();
    ff[b].setZero();
    zz[b].setZero();
    for (int i = 0; i < m; ++i) {
      const Eigen::Matrix3d gg = G.block<3, 1>(3 * b, i) * G.block<3, 1>(3 * b, i).transpose();
      for (int h = 0; h < 3; ++h) {
        for (int l = 0; l < 3; ++l) kpk[b].block<3, 3>(3 * h, 3 * l) += Pi[i](h, l) * gg;
      }
    }
  }
  if (m > 6) {
    const Eigen::LDLT<Eigen::Matrix3d> ldlt(h.Phi);
    // Lp = P' L sqrt(D); D >= 0 up to rounding (Phi is singular below 3 distinct angles).
    const Eigen::Matrix3d Lp = ldlt.transpositionsP().transpose() *
                               Eigen::Matrix3d(ldlt.matrixL()) *
                               ldlt.vectorD().cwiseMax(0.0).cwiseSqrt().asDiagonal();
    const Eigen::MatrixXd U = orthonormal_complement(Jb);
    const int r = 3 * (m - 6);
    Eigen::MatrixXd A = Eigen::MatrixXd::Identity(r, r);
    Rhs18 B = Rhs18::Zero(r, 18);
    const double sw = std::sqrt(w);
    for (int i = 0; i < m; ++i) {
      const Eigen::Matrix3d M = Lp.transpose() * Pi[i];  // (k, h)
      const Eigen::Matrix3d MM = M * Lp;                 // (k, k')
      Eigen::Matrix<double, 3, 18, Eigen::RowMajor> mg;  // (k, 6h + e) = M(k, h) g_i(e)
      for (int h = 0; h < 3; ++h) mg.middleCols<6>(6 * h) = M.col(h) * G.col(i).transpose();
      for (int rho = 0; rho < m - 6; ++rho) {
        const double ui = U(i, rho);
        B.middleRows<3>(3 * rho) += (sw * ui) * mg;
        for (int rho2 = 0; rho2 <= rho; ++rho2)
          A.block<3, 3>(3 * rho, 3 * rho2) += (w * ui * U(i, rho2)) * MM;
      }
    }
    if (!small_cholesky(A)) return std::nullopt;  // not seen (A >= I): the general path answers
    forward_solve(A, B);
    block_grams(B, ff);
    if (with_noise_part) {
      backward_solve(A, B);
      block_grams(B, zz);
    }
  }
  // The 3 x 3 blocks of the sums over (h, l), symmetrised over (h, l) and (l, h).
  const int pairs[6][2] = {{0, 0}, {0, 1}, {0, 2}, {1, 1}, {1, 2}, {2, 2}};
  std::array<std::array<Eigen::Matrix3d, 2>, 6> Ht, Hn;
  double prior_bound[2] = {0, 0};  // bounds the prior's term K P K' at any station, per block
  for (int k = 0; k < 6; ++k) {
    const int h = pairs[k][0], l = pairs[k][1];
    for (int b = 0; b < 2; ++b) {
      Eigen::Matrix3d pk = kpk[b].block<3, 3>(3 * h, 3 * l);
      Ht[k][b] = kpk[b].block<3, 3>(3 * h, 3 * l) - ff[b].block<3, 3>(3 * h, 3 * l);
      Hn[k][b] = zz[b].block<3, 3>(3 * h, 3 * l);
      if (h != l) {
        pk += kpk[b].block<3, 3>(3 * l, 3 * h);
        Ht[k][b] += kpk[b].block<3, 3>(3 * l, 3 * h) - ff[b].block<3, 3>(3 * l, 3 * h);
        Hn[k][b] += zz[b].block<3, 3>(3 * l, 3 * h);
      }
      prior_bound[b] += 3 * pk.cwiseAbs().maxCoeff();
    }
  }
  // mono_of(idx): the monomial of the product phi_idx[0] phi_idx[1] ..., (1, c, s) = phi_0..2.
  const auto monomial = [](int i, int j) { return (i + j) * (i + j + 1) / 2 + j; };  // c^i s^j
  const auto mono_of = [&](std::initializer_list<int> idx) {
    int i = 0, j = 0;
    for (int a : idx) i += a == 1, j += a == 2;
    return monomial(i, j);
  };
  int mono4[3][3][6];  // (alpha, beta, pair k) -> monomial
  for (int al = 0; al < 3; ++al) {
    for (int be = 0; be < 3; ++be) {
      for (int k = 0; k < 6; ++k) mono4[al][be][k] = mono_of({al, be, pairs[k][0], pairs[k][1]});
    }
  }
  const Eigen::Matrix3d* A[3] = {&h.A0, &h.A1, &h.A2};
  // Coefficients [monomial][error], so that a station's six values are one vector sum.
  // C0's (monomials of degree <= 2, the same order): rotated_variance_coefficients.
  double coef_t[15][6] = {}, coef_n[15][6] = {}, coef_c[6][6];
  rotated_variance_coefficients(*Cb, design.axis, coef_c);
  for (int e = 0; e < 6; ++e) {
    const int b = e / 3, row = e % 3;
    Eigen::Vector3d a[3];
    for (int al = 0; al < 3; ++al) a[al] = A[al]->row(row).transpose();
    for (int k = 0; k < 6; ++k) {
      for (int be = 0; be < 3; ++be) {
        const Eigen::Vector3d ht = Ht[k][b] * a[be];
        for (int al = 0; al < 3; ++al) coef_t[mono4[al][be][k]][e] += a[al].dot(ht);
        if (!with_noise_part) continue;
        const Eigen::Vector3d hs = Hn[k][b] * a[be];
        for (int al = 0; al < 3; ++al) coef_n[mono4[al][be][k]][e] += a[al].dot(hs);
      }
    }
  }
  WorstTracker noise(reference_length_mm), total(reference_length_mm);
  double largest_total[2] = {0, 0};
  for (int st = 0; st < n_st; ++st) {
    const double c = h.phi[st](1), s = h.phi[st](2);
    double mono[15];
    mono[0] = 1.0;
    for (int d = 1; d <= 4;
         ++d) {  // degree d from degree d - 1: c times each, then s times the last
      for (int j = 0; j < d; ++j) mono[monomial(d - j, j)] = c * mono[monomial(d - 1 - j, j)];
      mono[monomial(0, d)] = s * mono[monomial(0, d - 1)];
    }
    const double inv_n = 1.0 / count[st];
    double t[6] = {}, own[6] = {}, nz[6] = {};
    for (int u = 0; u < 15; ++u) {
      for (int e = 0; e < 6; ++e) t[e] += coef_t[u][e] * mono[u];
    }
    for (int u = 0; u < 6; ++u) {
      for (int e = 0; e < 6; ++e) own[e] += coef_c[u][e] * mono[u];
    }
    const double angle = h.st.station_deg[st];
    for (int e = 0; e < 6; ++e) {
      largest_total[e / 3] = std::max(largest_total[e / 3], inv_n * own[e] + t[e]);
      total.add(angle, e, inv_n * own[e] + t[e]);
    }
    if (!with_noise_part) continue;
    for (int u = 0; u < 15; ++u) {
      for (int e = 0; e < 6; ++e) nz[e] += coef_n[u][e] * mono[u];
    }
    for (int e = 0; e < 6; ++e) noise.add(angle, e, inv_n * own[e] + nz[e]);
  }
  // The total is C0 + (K P K' - F'F): rounding of the prior's term, below about 1e-16
  // prior_bound, is kept below 1e-9 of the worst total of its block (translations, rotations).
  for (int b = 0; b < 2; ++b) {
    if (!(prior_bound[b] <= 1e7 * largest_total[b])) return std::nullopt;
  }
  if (!with_noise_part) return TotalWorstCase{std::nullopt, total.result()};
  return TotalWorstCase{noise.result(), total.result()};
}

std::optional<SetupInformation> fast_setup_information(const Design& design,
                                                       const AngleStations* stations) {
  // A return reading reads one angle twice: the closed forms take one reading per angle, of
  // every installation, each along a direction that turns with the axis.
  if (design.return_reading || design.partial_sweeps() || !design.directions_turn())
    return std::nullopt;
  // fast_worst_total's notation. An effect of installation i has the columns phi(g)' x_k on
  // that installation's readings (x_k the harmonic coefficients of its column k, X = [x_k]),
  // and R'R = sum_hl Phi_hl X_h' W N X_l reduces to w N_ii X' Phi X: the axis errors take the
  // share h_i of it at every angle, whatever the angle. Its columns' own norms^2 are the
  // diagonal of w X' Phi X, so added_rank's test is on the eigenvalues of N_ii D^-1/2 X' Phi X
  // D^-1/2 (D that diagonal): every one above min_relative_singular_value.
  if (!per_angle_body_covariance(design)) return std::nullopt;
  std::optional<AngleStations> own;
  const PerAngleHarmonics h(design, stations_of(design, stations, own));
  const int m = h.m, n_st = h.n_st;
  Eigen::VectorXd share = Eigen::VectorXd::Zero(m);  // N_ii
  if (m > 6) share = orthonormal_complement(h.Jb).rowwise().squaredNorm();
  const double tol = EstimateOptions{}.min_relative_singular_value;
  SetupInformation out;
  out.n_readings = m * static_cast<int>(design.angles_deg.size());
  out.rank = 6 * n_st;
  for (int i = 0; i < m; ++i) {
    const SetupUncertainty u = design.setup_of(i);
    for (EffectKind kind : {EffectKind::kLengthOffset, EffectKind::kCentring}) {
      const double std_um = kind == EffectKind::kLengthOffset ? u.length_offset_um : u.centring_um;
      if (!(std_um > 0)) continue;
      Eigen::Matrix3d X = Eigen::Matrix3d::Zero();  // (harmonic, column)
      int q_full = 1;
      if (kind == EffectKind::kLengthOffset) {
        X(0, 0) = kLengthOffsetRow;
      } else {
        X = h.centring_harmonics(design, i).transpose();
        q_full = 3;
      }
      // The columns a reading sees (effect_block's rule, tol::kSeenValue).
      std::vector<int> seen;
      for (int k = 0; k < q_full; ++k) {
        double largest = 0;
        for (int st = 0; st < n_st; ++st)
          largest = std::max(largest, std::abs(h.phi[st].dot(X.col(k))));
        if (largest > tol::kSeenValue) seen.push_back(k);
      }
      if (seen.empty())
        continue;  // changes no reading: not an effect of this design (setup_effects)
      // At most 3 x 3: fixed-capacity matrices, no allocation.
      using Small = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, 3, 3>;
      const int q = static_cast<int>(seen.size());
      Small Xs(3, q);
      for (int k = 0; k < q; ++k) Xs.col(k) = X.col(seen[k]);
      const Small G = h.w * Xs.transpose() * h.Phi * Xs;  // the columns' Gram (q x q)
      const Eigen::Matrix<double, Eigen::Dynamic, 1, 0, 3, 1> d =
          G.diagonal().cwiseSqrt().cwiseInverse();
      const Small normalised = share(i) * d.asDiagonal() * G * d.asDiagonal();
      SetupEffectInformation info;
      info.kind = kind;
      info.installation = i;
      info.declared_std_um = std_um;
      info.q = q;
      info.detectable = Eigen::SelfAdjointEigenSolver<Small>(normalised, Eigen::EigenvaluesOnly)
                            .eigenvalues()(0) > tol;
      if (info.detectable) {
        const Small information = share(i) * G;
        info.min_information =
            std::max(0.0, Eigen::SelfAdjointEigenSolver<Small>(information, Eigen::EigenvaluesOnly)
                              .eigenvalues()(0));
      }
      out.effects.push_back(info);
    }
  }
  return out;
}

SetupInformation design_setup_information(const Design& design) {
  if (std::optional<SetupInformation> f = fast_setup_information(design)) return *f;
  return dense_setup_information(design);
}

TotalWorstCase design_worst_total(const Design& design, double reference_length_mm) {
  if (std::optional<TotalWorstCase> t = fast_worst_total(design, reference_length_mm)) return *t;
  return dense_worst_total(design, reference_length_mm);
}

TotalWorstCase dense_worst_total(const Design& design, double reference_length_mm) {
  const Parameterisation param(design);
  const LinearModel model = design_model(design, param);
  const WlsSolver solver(model);
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
  return *design_worst_total(design, reference_length_mm).noise;
}

Evaluation evaluate_design(const Design& design, double reference_length_mm,
                           const EstimateOptions& options, const DetectionSettings& detection,
                           const std::optional<DriftOptions>& drift) {
  const Parameterisation param(design);
  const LinearModel model = design_model(design, param);
  const WlsSolver solver(model, options);
  Evaluation ev;
  ev.prior = solver.a_priori();
  ev.reference_length_mm = reference_length_mm;
  ev.instrument = design.instrument;
  ev.indices = observability_indices(ev.prior.singular_values, ev.prior.rank, ev.prior.n_unknowns,
                                     ev.prior.n_readings);
  ev.criteria = design_criteria(solver);
  ev.prior.theta = Eigen::VectorXd::Zero(ev.prior.n_unknowns);
  ev.unidentifiable = describe_null_space(design, param, ev.prior);
  ev.detection = detection;

  // Every per-installation set-up effect is checked; those with a declared tolerance
  // (and only those: SetupSolver passes over the others) enter the estimate.
  const std::vector<SetupEffect> all = setup_effects(design, model, false);
  const SetupSolver setup(solver, all);
  const EffectColumns columns = effect_columns(solver, all);
  const DeterminedFunctions functions = determined_functions(param, solver.a_priori());
  ev.setup_checks =
      check_setup_effects(param, setup, all, columns, functions, detection, reference_length_mm);
  ErrorParts parts = error_parts(param, setup);
  ev.errors = std::move(parts.noise);
  if (setup.any()) {
    ev.setup_included = true;
    ev.setup_errors = std::move(parts.setup);
    ev.total_errors = std::move(parts.total);
    ev.worst_total = worst_case(ev.total_errors, reference_length_mm);
  }
  ev.worst = worst_case(ev.errors, reference_length_mm);
  if (auto w = setup_undeclared_warning(
          hidden_setup_effects(param, solver, all, columns, functions, reference_length_mm),
          reference_length_mm, design.instrument))
    ev.warnings.push_back(*w);
  // A drift over the test's nominal clock: a ball bar program's (a probe's file has no times).
  if (!drift || !instrument_info(design.instrument).has_clock) return ev;
  ev.drift = check_drift_effects(design, param, model, setup, functions, detection,
                                 reference_length_mm, drift->clock);
  if (drift->with_return && !design.return_reading && design.angles_deg.size() > 1) {
    Design with_return = design;
    with_return.return_reading = true;
    ev.drift_with_return =
        design_drift_checks(with_return, reference_length_mm, detection, drift->clock);
  }
  return ev;
}

DriftChecks design_drift_checks(const Design& design, double reference_length_mm,
                                const DetectionSettings& detection, const TestClock& clock) {
  const Parameterisation param(design);
  const LinearModel model = design_model(design, param);
  const WlsSolver solver(model);
  const SetupSolver setup(solver, setup_effects(design, model, true));
  return check_drift_effects(design, param, model, setup,
                             determined_functions(param, solver.a_priori()), detection,
                             reference_length_mm, clock);
}

std::optional<WorstCase> typical_setup_worst(const Design& design, double reference_length_mm) {
  // A typical ball bar set-up: its length offset and centring.
  if (design.setup_nuisance_declared() || !design.directions_turn()) return std::nullopt;
  Design typical = design;
  typical.setup_std.length_offset_um = kTypicalLengthOffsetStd_um;
  typical.setup_std.centring_um = kTypicalCentringStd_um;
  const std::optional<WorstCase> w =
      evaluate_design(typical, reference_length_mm, {}, {}, std::nullopt).worst_total;
  if (!w || !w->worst_determined_std_um) return std::nullopt;
  return w;
}

std::vector<SweepPoint> sweep_design(const Design& design,
                                     const std::vector<SweepVariable>& variables,
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
        if (in.probe_channel()) {  // a probe's channel: its sphere moves
          Sphere& s = d.spheres[static_cast<std::size_t>(in.sphere)];
          (variables[i].coord == 0 ? s.L_mm : variables[i].coord == 1 ? s.D_mm : s.H_mm) = x;
        }
      }
    }
    validate_design(d, "--sweep");
    const Evaluation ev = evaluate_design(d, reference_length_mm, {}, {}, std::nullopt);
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

int best_sweep_point(const std::vector<SweepPoint>& map) {
  int best = -1;
  for (std::size_t i = 0; i < map.size(); ++i) {
    const std::optional<double>& w = map[i].worst_std_um;
    if (w && (best < 0 || *w < *map[static_cast<std::size_t>(best)].worst_std_um))
      best = static_cast<int>(i);
  }
  return best;
}

}  // namespace dbbkit
