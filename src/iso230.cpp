#include "dbbkit/iso230.hpp"

#include <Eigen/QR>
#include <cmath>

#include "dbbkit/identify.hpp"
#include "dbbkit/kinematics.hpp"

namespace dbbkit {

namespace {

const char* kErrorLabel[6] = {"dx", "dy", "dz", "ex", "ey", "ez"};

// One block (translations or rotations): the rows of the determined values and the
// five unknowns' columns at each.
struct Row {
  int station = 0, error = 0;
  Eigen::VectorXd c;             // the value's function of theta
  Eigen::Matrix<double, 1, 5> x;  // its row of the location model
};

// The row of the location model for component k of block b (0: d0 and o, 1: e0, c0 and
// alpha) at an angle whose I - R is IR; ia, ip1, ip2 index the axis and its two normals.
Eigen::Matrix<double, 1, 5> location_row(int b, int k, const Eigen::Matrix3d& IR, int ia, int ip1, int ip2) {
  Eigen::Matrix<double, 1, 5> x = Eigen::Matrix<double, 1, 5>::Zero();
  if (b == 0) {  // d0 (x, y, z), then o along p1 and p2
    x(k) = 1.0;
  } else {  // e0 along p1 and p2, c0 along a, then alpha along p1 and p2
    if (k == ip1) x(0) = 1.0;
    if (k == ip2) x(1) = 1.0;
    if (k == ia) x(2) = 1.0;
  }
  x(3) = IR(k, ip1);
  x(4) = IR(k, ip2);
  return x;
}

}  // namespace

IsoResult iso230_quantities(const Design& design, const Parameterisation& param, const Estimate& est,
                            double uncertainty_scale) {
  IsoResult out;
  const bool c_axis = design.axis == Axis::C;
  // The nominal axis a and the two directions p1, p2 perpendicular to it (machine frame).
  const int ia = c_axis ? 2 : 1, ip1 = 0, ip2 = c_axis ? 1 : 2;
  const std::string s = c_axis ? "C" : "B";
  const std::array<std::string, 5> location_names = {
      "X" + std::string("O") + s, (c_axis ? "YO" : "ZO") + s, "AO" + s, (c_axis ? "BO" : "CO") + s, s + "0" + s};
  out.component_names = {"EX" + s, "EY" + s, "EZ" + s, "EA" + s, "EB" + s, "EC" + s};

  auto scaled = [&](Determined d) {
    d.std *= uncertainty_scale;
    return d;
  };
  std::vector<IsoQuantity> location(5), constants(5);
  std::vector<std::string> notes;
  // The functions of every block's fitted quantities, for the components.
  std::array<Eigen::MatrixXd, 2> Q;  // p x 5 per block
  std::array<bool, 2> fitted = {false, false};
  for (int b = 0; b < 2; ++b) {
    std::vector<Row> rows;
    for (int st = 0; st < param.n_stations(); ++st) {
      const Eigen::MatrixXd C = error_functions(param, st, est.n_unknowns);
      const Eigen::Matrix3d R = axis_rotation(design.axis, param.station_angle_deg(st));
      const Eigen::Matrix3d IR = Eigen::Matrix3d::Identity() - R;
      for (int k = 0; k < 3; ++k) {
        const Eigen::VectorXd c = C.col(3 * b + k);
        if (!est.determined(c)) continue;
        Row r;
        r.station = st;
        r.error = 3 * b + k;
        r.c = c;
        r.x = location_row(b, k, IR, ia, ip1, ip2);
        rows.push_back(r);
      }
    }
    const int m = static_cast<int>(rows.size());
    Eigen::MatrixXd X(m, 5);
    for (int i = 0; i < m; ++i) X.row(i) = rows[i].x;
    const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(X);
    if (m < 5 || qr.rank() < 5) {
      notes.push_back(std::string(b == 0 ? "translations" : "rotations") + ": the determined values (" +
                      std::to_string(m) + ") do not determine the location errors and constant parts (rank " +
                      std::to_string(m == 0 ? 0 : static_cast<int>(qr.rank())) + " of 5)");
      continue;
    }
    // H = (X'X)^-1 X' (least squares); the fitted quantity j is sum_i H(j, i) c_i.
    const Eigen::MatrixXd H = qr.solve(Eigen::MatrixXd::Identity(m, m));
    Q[b] = Eigen::MatrixXd::Zero(est.n_unknowns, 5);
    for (int i = 0; i < m; ++i) Q[b] += rows[i].c * H.col(i).transpose();
    fitted[b] = true;
  }
  // Their covariance, once per block: Sigma Q and Q' (Sigma + K S K') Q (p x 5 and 5 x 5),
  // so that a component c - Q x costs the support of c, not p^2.
  std::array<Eigen::MatrixXd, 2> SQ, KQ;
  std::array<Eigen::Matrix<double, 5, 5>, 2> QSQ;
  std::array<Eigen::Matrix<double, 5, 1>, 2> Qtheta;
  const bool low_rank = est.covariance_K.cols() > 0;
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
  auto quantity = [&](int b, int j) {
    Determined d;
    if (!fitted[b] || !est.determined(Q[b].col(j))) return d;
    d.determined = true;
    d.value = Qtheta[b](j);
    d.std = std::sqrt(std::max(0.0, QSQ[b](j, j)));
    return scaled(d);
  };
  out.location = {{location_names[0], um, quantity(0, 3)},
                  {location_names[1], um, quantity(0, 4)},
                  {location_names[2], urad, quantity(1, 3)},
                  {location_names[3], urad, quantity(1, 4)},
                  {location_names[4], urad, quantity(1, 2)}};
  out.constants = {{"constant part of dx", um, quantity(0, 0)},
                   {"constant part of dy", um, quantity(0, 1)},
                   {"constant part of dz", um, quantity(0, 2)},
                   {std::string("constant part of ") + kErrorLabel[3 + ip1], urad, quantity(1, 0)},
                   {std::string("constant part of ") + kErrorLabel[3 + ip2], urad, quantity(1, 1)}};
  // Components: each value less its fitted location and constant part.
  for (int st = 0; st < param.n_stations(); ++st) {
    IsoComponentsAtAngle at;
    at.station = st;
    at.angle_deg = param.station_angle_deg(st);
    const Eigen::MatrixXd C = error_functions(param, st, est.n_unknowns);
    const Eigen::Matrix3d IR = Eigen::Matrix3d::Identity() - axis_rotation(design.axis, at.angle_deg);
    for (int e = 0; e < 6; ++e) {
      const int b = e / 3, k = e % 3;
      const Eigen::VectorXd c = C.col(e);
      if (!fitted[b] || !est.determined(c)) continue;
      const Eigen::Matrix<double, 5, 1> x = location_row(b, k, IR, ia, ip1, ip2).transpose();
      // var(c - Q x) = var(c) - 2 cov(c, Q x) + x' QSQ x, cov(c, Q x) on the support of c.
      Determined d = est.evaluate(c);
      Eigen::Matrix<double, 1, 5> cSQ = Eigen::Matrix<double, 1, 5>::Zero();
      for (Eigen::Index a = 0; a < c.size(); ++a) {
        if (c(a) != 0.0) cSQ += c(a) * SQ[b].row(a);
      }
      double cross = cSQ * x;
      if (low_rank) cross += (est.low_rank_coordinates(c).transpose() * est.covariance_S * KQ[b] * x)(0);
      const double var = d.std * d.std - 2 * cross + x.dot(QSQ[b] * x);
      d.value -= Qtheta[b].dot(x);
      d.std = std::sqrt(std::max(0.0, var));
      at.motions[e] = scaled(d);
    }
    out.components.push_back(at);
  }
  for (const std::string& n : notes) out.note += (out.note.empty() ? "" : "; ") + n;
  return out;
}

}  // namespace dbbkit
