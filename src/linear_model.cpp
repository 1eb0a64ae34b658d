#include "dbbkit/linear_model.hpp"

#include "dbbkit/kinematics.hpp"

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
  LinearModel m;
  m.J = Eigen::MatrixXd::Zero(n, p);
  m.y_um.resize(n);
  m.sigma_um = Eigen::VectorXd::Constant(n, design.noise.sigma_um());
  const bool per_angle = param.model().kind == ErrorModel::Kind::PerAngle;
  for (int i = 0; i < n; ++i) {
    const RowSpec& r = rows[i];
    const Installation& inst = design.installations[r.installation];
    const RowVector6d g = J_reading_error(design.axis, inst, r.angle_deg);
    const int station = param.station_of(r.angle_deg);
    if (per_angle) {
      m.J.block<1, 6>(i, 6 * station) = g;  // block-diagonal: the errors at this station only
    } else {
      m.J.row(i) = g * param.error_map_at_angle(r.angle_deg);
    }
    m.y_um(i) = r.y_um;
    m.row_installation.push_back(r.installation);
    m.row_station.push_back(station);
    m.row_angle_deg.push_back(r.angle_deg);
  }
  return m;
}

}  // namespace

LinearModel build_linear_model(const Design& design, const Parameterisation& param,
                               const std::vector<Reading>& readings) {
  std::vector<RowSpec> rows;
  rows.reserve(readings.size());
  for (const Reading& r : readings) {
    rows.push_back({design.find_installation(r.installation), r.angle_deg, r.reading_um});
  }
  return assemble(design, param, rows);
}

LinearModel design_model(const Design& design, const Parameterisation& param) {
  std::vector<RowSpec> rows;
  for (size_t k = 0; k < design.installations.size(); ++k) {
    for (double a : design.angles_deg) rows.push_back({static_cast<int>(k), a, 0.0});
  }
  return assemble(design, param, rows);
}

}  // namespace dbbkit
