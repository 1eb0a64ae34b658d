#include "dbbkit/linear_model.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <string>
#include <unordered_map>

#include "dbbkit/error.hpp"
#include "dbbkit/kinematics.hpp"
#include "dbbkit/limits.hpp"

namespace dbbkit {

namespace {

struct RowSpec {
  int installation;
  double angle_deg;
  double y_um;
};

LinearModel assemble(const Design& design, const Parameterisation& param,
                     const std::vector<RowSpec>& rows) {
  const int n = static_cast<int>(rows.size());
  const int p = param.n_parameters();
  const bool per_angle = param.model().kind == ErrorModel::Kind::kPerAngle;
  // A series model is one dense block (every reading sees every coefficient of the six
  // errors): its factorisation holds n x p and p x p matrices. A per-angle model is one
  // small block per station, linear in the readings whatever their number.
  const double dense_bytes =
      per_angle ? 0.0 : 8.0 * (4.0 * n * p + 3.0 * static_cast<double>(p) * p);
  if (dense_bytes > limits::kMaxDenseBytes) {
    const double per_angle_count = p > 0 && design.angles_deg.size() > 0
                                       ? static_cast<double>(design.angles_deg.size()) *
                                             std::sqrt(limits::kMaxDenseBytes / dense_bytes)
                                       : 0;
    throw InputError(design.name.empty() ? "design" : design.name, "angles_deg",
                     std::to_string(n) + " readings of " + std::to_string(p) + " unknowns need " +
                         std::to_string(static_cast<long long>(dense_bytes / (1 << 20))) +
                         " MiB in the dense solver of a series model, beyond its " +
                         std::to_string(static_cast<long long>(limits::kMaxDenseBytes) >> 20) +
                         " MiB limit (docs/formats.md, \"Limits\"): about " +
                         std::to_string(static_cast<long>(per_angle_count)) +
                         " angles fit for this design");
  }
  LinearModel m;
  m.y_um.resize(n);
  m.sigma_um = Eigen::VectorXd::Constant(n, design.noise.sigma_um());
  m.row_installation.reserve(static_cast<std::size_t>(n));
  m.row_station.reserve(static_cast<std::size_t>(n));
  m.row_angle_deg.reserve(static_cast<std::size_t>(n));
  // A series: the basis once per distinct angle, the rows factored (SeriesRows).
  std::shared_ptr<SeriesRows> series = per_angle ? nullptr : std::make_shared<SeriesRows>();
  std::vector<Eigen::VectorXd> basis;
  std::unordered_map<double, int> basis_of;
  if (!per_angle) {
    series->per_error = param.coefficients_per_error();
    series->parity = basis_parity(param.model());
    series->g.resize(n, 6);
    series->angle.reserve(static_cast<std::size_t>(n));
  }
  Eigen::VectorXi per_row(n);
  std::vector<RowVector6d> gs(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    const RowSpec& r = rows[i];
    const Installation& inst = design.installations[r.installation];
    const RowVector6d& g = gs[static_cast<std::size_t>(i)] =
        J_reading_error(design.axis, inst, r.angle_deg);
    const int station = param.station_of(r.angle_deg);
    if (per_angle) {
      if (station < 0) param.error_functions_at_angle(r.angle_deg);  // throws: no errors there
      per_row(i) = static_cast<int>((g.array() != 0.0).count());
    } else {
      const auto [it, added] = basis_of.try_emplace(r.angle_deg, static_cast<int>(basis.size()));
      if (added) basis.push_back(param.series_basis(r.angle_deg));
      series->angle.push_back(it->second);
      series->g.row(i) = g;
      per_row(i) =
          static_cast<int>((g.array() != 0.0).count() * (basis[it->second].array() != 0.0).count());
    }
    m.y_um(i) = r.y_um;
    m.row_installation.push_back(r.installation);
    m.row_station.push_back(station);
    m.row_angle_deg.push_back(r.angle_deg);
  }
  // The rows in column order, each entry g(k) phi_a (a series) or g(k) (per angle) as the
  // error functions' product gives it, written in order into the compressed storage (an
  // entry is written, then kept if it is not zero: a product can underflow). per_row bounds
  // the entries kept, so a write lands at most one past them.
  m.J.resize(n, p);
  m.J.resizeNonZeros(per_row.cast<Eigen::Index>().sum() + 1);
  int* const outer = m.J.outerIndexPtr();
  int* const inner = m.J.innerIndexPtr();
  double* const value = m.J.valuePtr();
  int at = 0;
  for (int i = 0; i < n; ++i) {
    outer[i] = at;
    const RowVector6d& g = gs[static_cast<std::size_t>(i)];
    if (per_angle) {
      for (int k = 0; k < 6; ++k) {
        inner[at] = 6 * m.row_station[i] + k;
        value[at] = g(k);
        at += g(k) != 0.0;
      }
      continue;
    }
    const Eigen::VectorXd& f = basis[static_cast<std::size_t>(series->angle[i])];
    const int per = series->per_error;
    for (int k = 0; k < 6; ++k) {
      const double gk = g(k);
      if (gk == 0.0) continue;
      for (int a = 0; a < per; ++a) {
        const double v = f(a) * gk;
        inner[at] = k * per + a;
        value[at] = v;
        at += v != 0.0;
      }
    }
  }
  outer[n] = at;
  m.J.resizeNonZeros(at);
  if (!per_angle) {
    series->basis.resize(static_cast<Eigen::Index>(basis.size()), series->per_error);
    for (std::size_t b = 0; b < basis.size(); ++b)
      series->basis.row(static_cast<Eigen::Index>(b)) = basis[b].transpose();
    m.series = std::move(series);
  }
  return m;
}

}  // namespace

LinearModel build_linear_model(const Design& design, const Parameterisation& param,
                               const std::vector<Reading>& readings) {
  std::vector<RowSpec> rows;
  rows.reserve(readings.size());
  const auto index = design.installation_index();
  for (const Reading& r : readings) {
    // The bar's length change: the reading as the instrument counted it, times its count.
    const int i = index.at(r.installation);
    const double count = design.installations[static_cast<std::size_t>(i)].reading_sign;
    rows.push_back({i, r.angle_deg, count == 1 ? r.reading_um : count * r.reading_um});
  }
  return assemble(design, param, rows);
}

LinearModel design_model(const Design& design, const Parameterisation& param) {
  // One row per reading the design takes (nominal_readings: with each sweep's return reading).
  std::vector<RowSpec> rows;
  const std::vector<Reading> readings = nominal_readings(design);
  rows.reserve(readings.size());
  int k = 0;  // nominal_readings gives the installations in design order
  for (const Reading& r : readings) {
    while (design.installations[static_cast<std::size_t>(k)].id != r.installation) ++k;
    rows.push_back({k, r.angle_deg, 0.0});
  }
  return assemble(design, param, rows);
}

Jacobian append_columns(const Jacobian& J, const Eigen::MatrixXd& X) {
  Jacobian out(J.rows(), J.cols() + X.cols());
  Eigen::VectorXi per_row(J.rows());
  for (Eigen::Index i = 0; i < J.rows(); ++i) {
    per_row(i) = static_cast<int>(J.row(i).nonZeros() + (X.row(i).array() != 0.0).count());
  }
  out.reserve(per_row.cast<Eigen::Index>().sum());
  for (Eigen::Index i = 0; i < J.rows(); ++i) {  // appended in order, compressed
    out.startVec(i);
    for (Jacobian::InnerIterator it(J, i); it; ++it) out.insertBack(i, it.col()) = it.value();
    for (Eigen::Index c = 0; c < X.cols(); ++c) {
      if (X(i, c) != 0.0) out.insertBack(i, J.cols() + c) = X(i, c);
    }
  }
  out.finalize();
  return out;
}

std::vector<SetupInput> setup_inputs(const Design& design) {
  std::vector<SetupInput> out;
  for (size_t i = 0; i < design.installations.size(); ++i) {
    const SetupUncertainty s = design.setup_of(static_cast<int>(i));
    const double u[3] = {s.L_mm, s.D_mm, s.H_mm};
    for (int c = 0; c < 3; ++c) {
      if (u[c] > 0) out.push_back({static_cast<int>(i), c, u[c]});
    }
  }
  return out;
}

Eigen::MatrixXd J_reading_setup(const Design& design, const Parameterisation& param,
                                const LinearModel& model, const std::vector<SetupInput>& inputs,
                                const Eigen::VectorXd& theta) {
  const int n = static_cast<int>(model.J.rows());
  Eigen::MatrixXd D = Eigen::MatrixXd::Zero(n, static_cast<int>(inputs.size()));
  for (size_t j = 0; j < inputs.size(); ++j) {
    const SetupInput& in = inputs[j];
    const Installation& base = design.installations[in.installation];
    Installation moved = base;
    (in.coord == 0 ? moved.L_mm : in.coord == 1 ? moved.D_mm : moved.H_mm) += 1.0;
    for (int i = 0; i < n; ++i) {
      if (model.row_installation[i] != in.installation) continue;
      const double a = model.row_angle_deg[i];
      // The row is us . d + 1e-3 (P x us) . e with us = s u the unit vector from the following
      // ball to the ball. Moving the ball by dP (per mm of the input: the ball position is
      // linear in L, D, H) moves the lever arm, and, the following ball staying on its
      // programmed path, turns the bar: d(us) = (I - us us') dP / bar.
      const Eigen::Vector3d P = ball_position_mm(design.axis, base, a);
      const Eigen::Vector3d dP = ball_position_mm(design.axis, moved, a) - P;
      const Eigen::Vector3d us = base.sign * direction_machine(design.axis, base, a);
      const Eigen::Vector3d dus = base.bar_mm
                                      ? Eigen::Vector3d((dP - us * us.dot(dP)) / *base.bar_mm)
                                      : Eigen::Vector3d::Zero();
      RowVector6d d_row;
      d_row.head<3>() = dus.transpose();
      d_row.tail<3>() = 1e-3 * (dP.cross(us) + P.cross(dus)).transpose();
      D(i, static_cast<int>(j)) = d_row * param.errors_at_angle(a, theta);
    }
  }
  return D;
}

}  // namespace dbbkit
