#include "dbbkit/iso230.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <map>

#include "block_form.hpp"
#include "dbbkit/identify.hpp"
#include "dbbkit/kinematics.hpp"
#include "dbbkit/linear_model.hpp"
#include "dbbkit/monte_carlo.hpp"
#include "random.hpp"

namespace dbbkit {

namespace {

// The rank of the covariance of an error motion's values: eigenvalues lambda_i >
// kCovarianceRank max lambda count; the rest is rounding of a zero.
constexpr double kCovarianceRank = 1e-12;
// A location error's or constant's function Q'c whose norm is below kInexpressible times its
// block's is identically zero in the error model (rounding of a zero): the model cannot express
// it. The functions of a model that does are of the order of the angles' I - R, far above.
constexpr double kInexpressible = 1e-9;

}  // namespace

namespace {

// One block (translations or rotations): the rows of the determined values and the
// five unknowns' columns at each.
struct Row {
  int station = 0, error = 0;     // the value's function of theta: its station's column `error`
  Eigen::Matrix<double, 1, 5> x;  // its row of the location model
};

// The row of the location model for component k of block b (0: d0 and o, 1: e0, c0 and
// alpha) at an angle whose I - R is IR; ia, ip1, ip2 index the axis and its two normals.
Eigen::Matrix<double, 1, 5> location_row(int b, int k, const Eigen::Matrix3d& IR,
                                         const IsoFrame& f) {
  Eigen::Matrix<double, 1, 5> x = Eigen::Matrix<double, 1, 5>::Zero();
  if (b == 0) {  // d0 (x, y, z), then o along p1 and p2
    x(k) = 1.0;
  } else {  // e0 along p1 and p2, c0 about q, then alpha along p1 and p2
    x(0) = f.p1(k);
    x(1) = f.p2(k);
    x(2) = f.q(k);
  }
  if (f.aligned) {  // the machine axes' columns of I - R as they are
    x(3) = IR(k, f.ip1);
    x(4) = IR(k, f.ip2);
  } else {
    x(3) = IR.row(k).dot(f.p1);
    x(4) = IR.row(k).dot(f.p2);
  }
  return x;
}

// The names of the error motion values of the six components (translations dx, dy, dz, then
// rotations): radial, axial along the axis, tilt, and the angular positioning about it.
std::array<std::string, 6> motion_value_names(const IsoFrame& f) {
  std::array<std::string, 6> names;
  for (int e = 0; e < 6; ++e) {
    const int k = e % 3;
    const std::string axis(1, "XYZ"[k]);
    if (!f.aligned) {
      names[e] =
          std::string(e < 3 ? "error motion value along " : "error motion value about ") + axis;
    } else if (e < 3) {
      names[e] = k == f.ia ? "axial error motion value" : "radial error motion value, " + axis;
    } else {
      names[e] = k == f.ia ? "range of the angular positioning error motion"
                           : "tilt error motion value, about " + axis;
    }
  }
  return names;
}

// One component's values at its angles: the estimate and a factor L of their covariance
// (Cov = L L'), L with as many columns as the covariance has positive eigenvalues.
struct ComponentDraw {
  Eigen::VectorXd value;
  Eigen::MatrixXd L;
};

double range_of(const Eigen::Ref<const Eigen::VectorXd>& v) { return v.maxCoeff() - v.minCoeff(); }

// The p-quantile of range(eps) of every component by adaptive Monte Carlo (iso230.hpp);
// one trial draws every component's errors, each component's quantile is its own output.
void range_monte_carlo(const std::vector<ComponentDraw>& draws,
                       std::vector<IsoMotionValue*> outputs, const IsoMotionOptions& o,
                       IsoMotionValues& res) {
  const int n_out = static_cast<int>(draws.size());
  if (n_out == 0) return;
  const long M = std::max(1000L, o.batch_trials);
  const long max_trials = std::max(M, o.max_trials);
  const double p = o.coverage_probability;
  // The p-quantile of x (reordered): the order statistic of rank floor(p m + 1/2) (JCGM 101 §7.7).
  auto quantile = [p](std::vector<float>& x) {
    const long m = static_cast<long>(x.size());
    const long r = std::min(m - 1, static_cast<long>(std::floor(p * m + 0.5)));
    std::nth_element(x.begin(), x.begin() + r, x.end());
    return static_cast<double>(x[r]);
  };
  std::vector<std::vector<float>> trials(n_out);
  std::vector<std::vector<double>> history(n_out);
  detail::Xoshiro256pp rng(detail::splitmix64(o.seed));
  const detail::NormalZiggurat n01;
  const detail::ChiSquared chi2(o.dof.value_or(1.0));
  long total = 0;
  Eigen::MatrixXd Z, V;
  Eigen::VectorXd scale(M);
  while (total < max_trials) {
    const long batch = std::min(M, max_trials - total);
    for (long t = 0; t < batch; ++t) scale(t) = o.dof ? std::sqrt(*o.dof / chi2(rng)) : 1.0;
    for (int v = 0; v < n_out; ++v) {
      const ComponentDraw& d = draws[v];
      Z.resize(d.L.cols(), batch);
      detail::Xoshiro256pp local = rng;  // a local copy stays in registers while Z is written
      for (Eigen::Index k = 0; k < Z.size(); ++k) Z.data()[k] = n01(local);
      rng = local;
      V.noalias() = d.L * Z;
      std::vector<float> x(static_cast<std::size_t>(batch));
      for (long t = 0; t < batch; ++t) x[t] = static_cast<float>(scale(t) * range_of(V.col(t)));
      trials[v].insert(trials[v].end(), x.begin(), x.end());
      history[v].push_back(quantile(x));
    }
    total += batch;
    const long h = static_cast<long>(history[0].size());
    if (h < 2) continue;
    bool stable = true;
    for (int v = 0; v < n_out && stable; ++v) {
      const detail::BatchSpread q = detail::batch_spread(history[v], [](double x) { return x; });
      stable = q.spread <= numerical_tolerance(q.mean, o.significant_digits);
    }
    if (stable) {
      res.converged = true;
      break;
    }
  }
  res.trials = total;
  for (int v = 0; v < n_out; ++v) {
    IsoMotionValue& out = *outputs[v];
    out.U = quantile(trials[v]);
    out.low = std::max(0.0, out.value - out.U);
    out.high = out.value + out.U;
  }
}

}  // namespace

Eigen::Matrix<double, 6, 5> location_motion(const AxisFrame& axis, double angle_deg) {
  const IsoFrame f = iso_frame(axis);
  const Eigen::Matrix3d IR = Eigen::Matrix3d::Identity() - axis_rotation(axis, angle_deg);
  Eigen::Matrix<double, 6, 5> G = Eigen::Matrix<double, 6, 5>::Zero();
  for (int e = 0; e < 6; ++e) {
    const int b = e / 3, k = e % 3;
    const Eigen::Matrix<double, 1, 5> x = location_row(b, k, IR, f);
    if (b == 0) {  // o along p1 and p2: the first two location errors
      G(e, 0) = x(3);
      G(e, 1) = x(4);
    } else {  // alpha along p1 and p2, then c0 about q
      G(e, 2) = x(3);
      G(e, 3) = x(4);
      G(e, 4) = x(2);
    }
  }
  return G;
}

IsoFrame iso_frame(const AxisFrame& axis) {
  IsoFrame f;
  f.ia = axis.machine_axis();
  f.aligned = f.ia >= 0;
  if (f.aligned) {
    // The two other machine axes in order, the axis' own machine axis positive (ISO 230-1:
    // location errors are components along and rotations about the machine axes).
    f.ip1 = f.ia == 0 ? 1 : 0;
    f.ip2 = f.ia == 2 ? 1 : 2;
    f.p1 = Eigen::Vector3d::Unit(f.ip1);
    f.p2 = Eigen::Vector3d::Unit(f.ip2);
    f.q = Eigen::Vector3d::Unit(f.ia);
  } else {
    // A nutating axis: its own frame, u = reference, v = direction x reference.
    f.p1 = axis.reference();
    f.p2 = axis.direction().cross(axis.reference());
    f.q = axis.direction();
  }
  return f;
}

IsoNames iso230_names(const AxisFrame& axis) {
  const IsoFrame f = iso_frame(axis);
  const std::string s(1, axis.letter());
  const char* kPosition = "XYZ";
  const char* kRotation = "ABC";
  IsoNames names;
  if (f.aligned) {
    names.location = {std::string(1, kPosition[f.ip1]) + "0" + s,
                      std::string(1, kPosition[f.ip2]) + "0" + s,
                      std::string(1, kRotation[f.ip1]) + "0" + s,
                      std::string(1, kRotation[f.ip2]) + "0" + s, s + "0" + s};
  } else {
    names.location = {"U0" + s, "V0" + s, "AU0" + s, "AV0" + s, s + "0" + s};
  }
  names.components = {"EX" + s, "EY" + s, "EZ" + s, "EA" + s, "EB" + s, "EC" + s};
  const std::string c = "constant part of ";
  names.constants = {c + "dx", c + "dy", c + "dz",
                     f.aligned ? c + kErrorNames[3 + f.ip1] : c + "e along u",
                     f.aligned ? c + kErrorNames[3 + f.ip2] : c + "e along v"};
  return names;
}

IsoResult iso230_quantities(const Design& design, const Parameterisation& param,
                            const Estimate& est, double uncertainty_scale,
                            const IsoMotionOptions& motion) {
  IsoResult out;
  // The nominal axis q and the two directions p1, p2 perpendicular to it (machine frame).
  const IsoFrame frame = iso_frame(design.axis);
  const IsoNames names = iso230_names(design.axis);
  const std::array<std::string, 5>& location_names = names.location;
  out.component_names = names.components;

  auto scaled = [&](Determined d) {
    d.std *= uncertainty_scale;
    return d;
  };
  std::vector<IsoQuantity> location(5), constants(5);
  // The functions of every block's fitted quantities, for the components.
  std::array<Eigen::MatrixXd, 2> Q;  // p x 5 per block
  std::array<bool, 2> fitted = {false, false};
  // The error functions of every station, formed once for both blocks and the components.
  std::vector<Eigen::SparseMatrix<double>> functions;
  functions.reserve(static_cast<std::size_t>(param.n_stations()));
  for (int st = 0; st < param.n_stations(); ++st)
    functions.push_back(error_functions(param, st, est.n_unknowns));
  // Whether column e of a station's functions is determined: Estimate::determined, whose
  // answer for readings without a null space (every function) is given without forming it.
  const bool all_determined =
      est.status != EstimateStatus::kNoReadings && est.null_space_scaled.cols() == 0;
  auto determined = [&](const Eigen::SparseMatrix<double>& C, int e) {
    return all_determined || est.determined(Estimate::Function(C.col(e)));
  };
  for (int b = 0; b < 2; ++b) {
    std::vector<Row> rows;
    for (int st = 0; st < param.n_stations(); ++st) {
      const Eigen::SparseMatrix<double>& C = functions[static_cast<std::size_t>(st)];
      const Eigen::Matrix3d R = axis_rotation(design.axis, param.station_angle_deg(st));
      const Eigen::Matrix3d IR = Eigen::Matrix3d::Identity() - R;
      for (int k = 0; k < 3; ++k) {
        if (!determined(C, 3 * b + k)) continue;
        Row r;
        r.station = st;
        r.error = 3 * b + k;
        r.x = location_row(b, k, IR, frame);
        rows.push_back(r);
      }
    }
    const int m = static_cast<int>(rows.size());
    Eigen::MatrixXd X(m, 5);
    for (int i = 0; i < m; ++i) X.row(i) = rows[i].x;
    const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(X);
    if (m < 5 || qr.rank() < 5) {
      out.gaps.push_back({b, m, m == 0 ? 0 : static_cast<int>(qr.rank())});
      continue;
    }
    // H = (X'X)^-1 X' (least squares); the fitted quantity j is sum_i H(j, i) c_i.
    // From the QR (X P = Q R): (X'X)^-1 = P R^-1 R^-T P', so H costs 5 x m, not m x m.
    const Eigen::Matrix<double, 5, 5> Rinv =
        Eigen::Matrix<double, 5, 5>(
            qr.matrixR().topLeftCorner(5, 5).template triangularView<Eigen::Upper>())
            .inverse();
    const Eigen::Matrix<double, 5, 5> XtX_inv =
        qr.colsPermutation() * (Rinv * Rinv.transpose()) * qr.colsPermutation().transpose();
    const Eigen::MatrixXd H = XtX_inv * X.transpose();
    Q[b] = Eigen::MatrixXd::Zero(est.n_unknowns, 5);
    for (int i = 0; i < m; ++i) {
      for (Eigen::SparseMatrix<double>::InnerIterator it(
               functions[static_cast<std::size_t>(rows[i].station)], rows[i].error);
           it; ++it)
        Q[b].row(it.row()) += it.value() * H.col(i).transpose();
    }
    fitted[b] = true;
  }
  // Their covariance, once per block: Sigma Q and Q' (Sigma + K S K') Q (p x 5 and 5 x 5),
  // so that a component c - Q x costs the support of c, not p^2.
  std::array<Eigen::MatrixXd, 2> SQ, KQ;
  std::array<Eigen::Matrix<double, 5, 5>, 2> QSQ;
  std::array<Eigen::Matrix<double, 5, 1>, 2> Qtheta;
  const bool low_rank = est.covariance_K.cols() > 0;
  // Independent between angles: a per-angle model without a set-up effect, each block of the
  // covariance within one station.
  out.independent_between_angles = [&] {
    if (param.model().kind != ErrorModel::Kind::kPerAngle || low_rank ||
        !setup_inputs(design).empty() ||
        est.covariance_block_of.size() != static_cast<std::size_t>(est.n_unknowns))
      return false;
    std::map<int, int> station_of_block;
    for (int j = 0; j < est.n_unknowns; ++j) {
      const int block = est.covariance_block_of[static_cast<std::size_t>(j)];
      if (block < 0) continue;
      const auto [it, fresh] = station_of_block.emplace(block, param.parameter_station(j));
      if (!fresh && it->second != param.parameter_station(j)) return false;
    }
    return true;
  }();
  for (int b = 0; b < 2; ++b) {
    if (!fitted[b]) continue;
    SQ[b] = est.covariance * Q[b];
    QSQ[b] = Q[b].transpose() * SQ[b];
    if (low_rank) {
      KQ[b] = est.covariance_K.transpose() * Q[b];
      QSQ[b] += KQ[b].transpose() * est.covariance_S * KQ[b];
    }
    Qtheta[b] = Q[b].transpose() * est.theta;
  }
  // The quantities, in their order of report.
  const std::string um = "um", urad = "urad";
  // A quantity the error model cannot express is no measurement: a model constant over the angle
  // (a series of order 0) holds no location error, whose functions are then identically zero
  // (the fit gives 0 +- 0 by construction). Not determined, as a missing combination is.
  auto expressible = [&](int b, int j) {
    return Q[b].col(j).norm() > kInexpressible * std::max(Q[b].norm(), 1e-300);
  };
  auto quantity = [&](int b, int j) {
    Determined d;
    if (!fitted[b] || !expressible(b, j) || !est.determined(Q[b].col(j))) return d;
    d.determined = true;
    d.value = Qtheta[b](j);
    d.std = std::sqrt(std::max(0.0, QSQ[b](j, j)));
    return scaled(d);
  };
  // Each location error's block and column of Q, in the order of report.
  const std::array<std::pair<int, int>, 5> location_at = {{{0, 3}, {0, 4}, {1, 3}, {1, 4}, {1, 2}}};
  // The location errors' joint covariance: within a block Q' (Sigma + K S K') Q, across the
  // blocks the same form with the other block's columns.
  {
    for (int i = 0; i < 5; ++i) {
      for (int j = 0; j < 5; ++j) {
        const auto [bi, ci] = location_at[static_cast<std::size_t>(i)];
        const auto [bj, cj] = location_at[static_cast<std::size_t>(j)];
        if (!fitted[bi] || !fitted[bj] || !est.determined(Q[bi].col(ci)) ||
            !est.determined(Q[bj].col(cj)))
          continue;
        double v = Q[bi].col(ci).dot(SQ[bj].col(cj));
        if (low_rank) v += KQ[bi].col(ci).dot(est.covariance_S * KQ[bj].col(cj));
        out.location_covariance(i, j) = v * uncertainty_scale * uncertainty_scale;
      }
    }
    // Symmetric to the bit (the two orders of a cross term round differently).
    const Eigen::Matrix<double, 5, 5> c = out.location_covariance;
    out.location_covariance = 0.5 * (c + c.transpose());
  }
  for (int i = 0; i < 5; ++i) {
    const auto [b, j] = location_at[static_cast<std::size_t>(i)];
    if (fitted[b] && !expressible(b, j))
      out.not_in_model.push_back(location_names[static_cast<std::size_t>(i)]);
  }
  out.location = {{location_names[0], um, quantity(0, 3)},
                  {location_names[1], um, quantity(0, 4)},
                  {location_names[2], urad, quantity(1, 3)},
                  {location_names[3], urad, quantity(1, 4)},
                  {location_names[4], urad, quantity(1, 2)}};
  out.constants = {{names.constants[0], um, quantity(0, 0)},
                   {names.constants[1], um, quantity(0, 1)},
                   {names.constants[2], um, quantity(0, 2)},
                   {names.constants[3], urad, quantity(1, 0)},
                   {names.constants[4], urad, quantity(1, 1)}};
  // Components: each value c'theta less its fitted location and constant part x'Q'theta.
  // A component's term: c on its support, x, c' Sigma Q and K'c; the covariance of two
  // components of block b (the variance when they are one),
  //   (c_i - Q x_i)' (Sigma + K S K') (c_j - Q x_j)
  //     = c_i' Sigma c_j - c_i' Sigma Q x_j - x_i' Q' Sigma c_j + x_i' QSQ x_j
  //       + (K'c_i)' S (K'c_j) - (K'c_i)' S KQ x_j - x_i' KQ' S (K'c_j),
  // with QSQ = Q' (Sigma + K S K') Q; c_i' Sigma c_j costs the two supports, not p^2.
  struct Term {
    int b = 0;
    std::vector<Eigen::Index> index;  // the nonzeros of c: their unknowns
    std::vector<double> coef;         // and coefficients
    int block = -1;                   // all of c in one block of the covariance: its number
    std::vector<Eigen::Index> local;  // and each nonzero's place in it
    Eigen::Matrix<double, 1, 5> x, cSQ;
    Eigen::Matrix<double, 1, 5> cSQ_other;  // c' Sigma Q of the other block (motion_covariance)
    Eigen::VectorXd Kc;                     // K'c; empty without a low-rank part
  };
  std::vector<double> row;  // the covariance's inner sums, one per nonzero of i
  // c_i' Sigma c_j on the two supports.
  auto base = [&](const Term& i, const Term& j) {
    double v = 0;
    if (i.block >= 0 && i.block == j.block) {  // on the dense block, no search
      // v = sum over x of c_x (sum over y of B(x, y) c_y), each sum in its order: the same
      // bits as Estimate::base_variance.
      v = detail::block_form(est.covariance_blocks[static_cast<std::size_t>(i.block)],
                             i.coef.data(), i.local.data(), i.coef.size(), j.coef.data(),
                             j.local.data(), j.coef.size(), row);
    } else {
      for (std::size_t x = 0; x < i.coef.size(); ++x) {
        for (std::size_t y = 0; y < j.coef.size(); ++y)
          v += i.coef[x] * est.covariance_at(i.index[x], j.index[y]) * j.coef[y];
      }
    }
    return v;
  };
  auto covariance = [&](const Term& i, const Term& j) {
    double v = base(i, j);
    v += -i.cSQ.dot(j.x) - j.cSQ.dot(i.x) + (i.x * QSQ[i.b] * j.x.transpose())(0);
    if (low_rank) {
      v += i.Kc.dot(est.covariance_S * j.Kc) -
           i.Kc.dot(est.covariance_S * (KQ[i.b] * j.x.transpose())) -
           j.Kc.dot(est.covariance_S * (KQ[i.b] * i.x.transpose()));
    }
    return v * uncertainty_scale * uncertainty_scale;
  };
  // The motions less their constant parts (motion_covariance): the rows of the constant parts
  // alone, a block's fitted quantities across the blocks.
  const bool with_covariance = motion.covariance && fitted[0] && fitted[1];
  Eigen::Matrix<double, 5, 5> QSQ01 = Eigen::Matrix<double, 5, 5>::Zero();
  bool constants_determined = with_covariance;
  if (with_covariance) {
    QSQ01 = Q[0].transpose() * SQ[1];
    if (low_rank) QSQ01 += KQ[0].transpose() * est.covariance_S * KQ[1];
    for (int j = 0; j < 3; ++j) constants_determined &= est.determined(Q[0].col(j));
    for (int j = 0; j < 2; ++j) constants_determined &= est.determined(Q[1].col(j));
  }
  auto constant_row = [](const Term& t) {
    Eigen::Matrix<double, 1, 5> x = t.x;
    x.tail(t.b == 0 ? 2 : 3).setZero();
    return x;
  };
  auto motion_cov = [&](const Term& i, const Term& j) {
    const Eigen::Matrix<double, 1, 5> xi = constant_row(i), xj = constant_row(j);
    const Eigen::Matrix<double, 1, 5>& iSQj = i.b == j.b ? i.cSQ : i.cSQ_other;
    const Eigen::Matrix<double, 1, 5>& jSQi = i.b == j.b ? j.cSQ : j.cSQ_other;
    const Eigen::Matrix<double, 5, 5> M =
        i.b == j.b ? QSQ[i.b] : (i.b == 0 ? QSQ01 : Eigen::Matrix<double, 5, 5>(QSQ01.transpose()));
    double v = base(i, j) - iSQj.dot(xj) - jSQi.dot(xi) + (xi * M * xj.transpose())(0);
    if (low_rank) {  // M holds the low-rank part of Q' (...) Q already
      v += i.Kc.dot(est.covariance_S * j.Kc) -
           i.Kc.dot(est.covariance_S * (KQ[j.b] * xj.transpose())) -
           j.Kc.dot(est.covariance_S * (KQ[i.b] * xi.transpose()));
    }
    return v * uncertainty_scale * uncertainty_scale;
  };
  std::vector<std::array<Term, 6>> terms;  // per station, for the error motion values
  for (int st = 0; st < param.n_stations(); ++st) {
    IsoComponentsAtAngle at;
    at.station = st;
    at.angle_deg = param.station_angle_deg(st);
    const Eigen::SparseMatrix<double>& C = functions[static_cast<std::size_t>(st)];
    const Eigen::Matrix3d IR =
        Eigen::Matrix3d::Identity() - axis_rotation(design.axis, at.angle_deg);
    std::array<Term, 6> station_terms;
    for (int e = 0; e < 6; ++e) {
      const int b = e / 3, k = e % 3;
      if (!fitted[b] || !determined(C, e)) continue;
      Term& t = station_terms[e];
      t.b = b;
      t.x = location_row(b, k, IR, frame);
      t.cSQ.setZero();
      t.cSQ_other.setZero();
      double value = 0;
      const auto nonzeros = static_cast<std::size_t>(C.col(e).nonZeros());
      t.index.reserve(nonzeros);
      t.coef.reserve(nonzeros);
      t.local.reserve(nonzeros);
      for (Eigen::SparseMatrix<double>::InnerIterator it(C, e); it; ++it) {
        const Eigen::Index a = it.row();
        if (it.value() == 0.0) continue;
        t.index.push_back(a);
        t.coef.push_back(it.value());
        t.cSQ += it.value() * SQ[b].row(a);
        if (with_covariance) t.cSQ_other += it.value() * SQ[1 - b].row(a);
        value += it.value() * est.theta(a);
      }
      if (!est.covariance_block_of.empty() && !t.index.empty()) {
        t.block = est.covariance_block_of[static_cast<std::size_t>(t.index.front())];
        for (const Eigen::Index a : t.index) {
          if (est.covariance_block_of[static_cast<std::size_t>(a)] != t.block) t.block = -1;
          t.local.push_back(est.covariance_local[static_cast<std::size_t>(a)]);
        }
      }
      if (low_rank) t.Kc = est.low_rank_coordinates(Estimate::Function(C.col(e)));
      Determined d;
      d.determined = true;
      d.value = value - Qtheta[b].dot(t.x);
      d.std = std::sqrt(std::max(0.0, covariance(t, t)));
      at.motions[e] = d;
    }
    if (constants_determined && std::all_of(at.motions.begin(), at.motions.end(),
                                            [](const Determined& d) { return d.determined; })) {
      Eigen::Matrix<double, 6, 6> c;
      for (int i = 0; i < 6; ++i)
        for (int j = 0; j <= i; ++j)
          c(i, j) = c(j, i) = motion_cov(station_terms[i], station_terms[j]);
      at.motion_covariance = c;
      for (int i = 0; i < 6; ++i)
        for (int j = 0; j <= i; ++j) {
          const Term &a = station_terms[i], &b = station_terms[j];
          const double v = base(a, b) + (low_rank ? a.Kc.dot(est.covariance_S * b.Kc) : 0.0);
          c(i, j) = c(j, i) = v * uncertainty_scale * uncertainty_scale;
        }
      at.errors_covariance = c;
    }
    out.components.push_back(at);
    if (motion.enabled) terms.push_back(std::move(station_terms));
  }
  if (motion.enabled) {
    // The error motion values: per component, the joint covariance of its values at the
    // angles where it is determined (the same covariance as each value's own uncertainty).
    IsoMotionValues& mv = out.motion_values;
    mv.seed = motion.seed;
    mv.coverage_probability = motion.coverage_probability;
    const std::array<std::string, 6> value_names = motion_value_names(frame);
    std::vector<ComponentDraw> draws;
    std::vector<int> drawn;
    mv.values.resize(6);
    for (int e = 0; e < 6; ++e) {
      IsoMotionValue& v = mv.values[e];
      v.name = value_names[e];
      v.component = out.component_names[e];
      v.unit = e < 3 ? um : urad;
      const int b = e / 3;
      std::vector<int> at;
      for (const IsoComponentsAtAngle& a : out.components) {
        if (a.motions[e].determined) at.push_back(a.station);
      }
      const int n_at = static_cast<int>(at.size());
      v.angles = n_at;
      if (!fitted[b]) {
        v.gap = IsoMotionGap::kLocationNotDetermined;
        continue;
      }
      if (n_at < 2 || n_at < static_cast<int>(out.components.size())) {
        v.gap = IsoMotionGap::kNotEveryAngle;
        v.measured = static_cast<int>(out.components.size());
        continue;
      }
      if (n_at > motion.max_angles) {
        v.gap = IsoMotionGap::kTooManyAngles;
        v.max_angles = motion.max_angles;
        continue;
      }
      ComponentDraw d;
      d.value.resize(n_at);
      Eigen::MatrixXd cov(n_at, n_at);
      for (int i = 0; i < n_at; ++i) {
        d.value(i) = out.components[at[i]].motions[e].value;
        for (int j = 0; j <= i; ++j)
          cov(i, j) = cov(j, i) = covariance(terms[at[i]][e], terms[at[j]][e]);
      }
      const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(cov);
      const double top = std::max(0.0, eig.eigenvalues().maxCoeff());
      int r = 0;
      for (Eigen::Index i = 0; i < n_at; ++i) r += eig.eigenvalues()(i) > kCovarianceRank * top;
      d.L = eig.eigenvectors().rightCols(r) * eig.eigenvalues().tail(r).cwiseSqrt().asDiagonal();
      v.computed = true;
      v.value =
          range_of(d.value);  // before the draw: range_monte_carlo sets U and the interval from it
      draws.push_back(std::move(d));
      drawn.push_back(e);
    }
    std::vector<IsoMotionValue*> outputs;
    for (int e : drawn) outputs.push_back(&mv.values[e]);
    range_monte_carlo(draws, outputs, motion, mv);
    mv.dof = motion.dof;
  }
  return out;
}

}  // namespace dbbkit
