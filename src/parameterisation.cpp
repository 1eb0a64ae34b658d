#include "dbbkit/parameterisation.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <utility>
#include <vector>

#include "dbbkit/error.hpp"
#include "dbbkit/kinematics.hpp"

namespace dbbkit {

bool same_position(const AxisFrame& axis, double a_deg, double b_deg) {
  double diff = std::abs(a_deg - b_deg);
  if (axis.full_turn()) {
    if (!(diff < 360.0)) diff = std::fmod(diff, 360.0);  // fmod leaves [0, 360) unchanged
    diff = std::min(diff, 360.0 - diff);
  }
  return diff < kAngleTolerance_deg;
}

int coefficients_per_error(const ErrorModel& model) {
  switch (model.kind) {
    case ErrorModel::Kind::kFourier:
      return 2 * model.order + 1;
    case ErrorModel::Kind::kLegendre:
      return model.order + 1;
    case ErrorModel::Kind::kPerAngle:
      break;
  }
  return 1;
}

std::vector<int> basis_parity(const ErrorModel& model) {
  std::vector<int> parity;
  if (model.kind == ErrorModel::Kind::kPerAngle) return parity;
  parity.resize(static_cast<std::size_t>(coefficients_per_error(model)));
  for (std::size_t j = 0; j < parity.size(); ++j) {
    // Fourier: 1, then cos k g (even) and sin k g (odd) in turn; Legendre: P_j has j's parity.
    parity[j] = model.kind == ErrorModel::Kind::kFourier ? (j > 0 && j % 2 == 0 ? -1 : 1)
                                                         : (j % 2 == 0 ? 1 : -1);
  }
  return parity;
}

namespace {

std::string format_angle(double a) {
  std::ostringstream s;
  s << a;
  return s.str();
}
}  // namespace

Parameterisation::Parameterisation(const Design& design)
    : axis_(design.axis), model_(design.errors) {
  design_stations_.reserve(design.angles_deg.size());
  for (double a : design.angles_deg) {
    int s = station_of(a);
    if (s < 0) {
      const double k = key_of(a);
      s = static_cast<int>(station_deg_.size());
      index_.insert(std::lower_bound(index_.begin(), index_.end(), std::pair<double, int>(k, -1)),
                    {k, s});
      station_deg_.push_back(a);
    }
    design_stations_.push_back(s);
  }
  lo_deg_ = *std::min_element(design.angles_deg.begin(), design.angles_deg.end());
  hi_deg_ = *std::max_element(design.angles_deg.begin(), design.angles_deg.end());
  per_error_ = dbbkit::coefficients_per_error(model_);
  n_parameters_ = model_.kind == ErrorModel::Kind::kPerAngle ? 6 * n_stations() : 6 * per_error_;
  if (model_.kind != ErrorModel::Kind::kPerAngle) {
    station_basis_.resize(n_stations(), per_error_);
    for (int st = 0; st < n_stations(); ++st)
      station_basis_.row(st) = formed_basis(station_deg_[static_cast<std::size_t>(st)]).transpose();
  }
}

double Parameterisation::key_of(double angle_deg) const {
  if (!axis_.full_turn()) return angle_deg;
  double k = angle_deg >= 0.0 && angle_deg < 360.0 ? angle_deg : std::fmod(angle_deg, 360.0);
  if (k < 0) k += 360.0;
  return k;
}

int Parameterisation::station_of(double angle_deg) const {
  // The stations whose key lies within the tolerance (for C also across 0/360),
  // checked with same_position; the first station wins, as in a linear scan.
  const double k = key_of(angle_deg);
  int found = -1;
  auto scan = [&](double lo, double hi) {
    for (auto it = std::lower_bound(index_.begin(), index_.end(), std::pair<double, int>(lo, -1));
         it != index_.end() && it->first <= hi; ++it) {
      if ((found < 0 || it->second < found) &&
          same_position(axis_, station_deg_[it->second], angle_deg)) {
        found = it->second;
      }
    }
  };
  const double tol = 2 * kAngleTolerance_deg;
  scan(k - tol, k + tol);
  if (axis_.full_turn()) {
    if (k < tol) scan(360.0 + k - tol, 360.0 + tol);
    if (k > 360.0 - tol) scan(-tol, k - 360.0 + tol);
  }
  return found;
}

Eigen::VectorXd fourier_basis(int order, double angle_deg) {
  Eigen::VectorXd f(2 * order + 1);
  f(0) = 1.0;
  for (int k = 1; k <= order; ++k) sincos_deg(k * angle_deg, f(2 * k), f(2 * k - 1));
  return f;
}

Eigen::VectorXd legendre_basis(int order, double x) {
  Eigen::VectorXd f(order + 1);
  f(0) = 1.0;
  if (order > 0) f(1) = x;
  // Bonnet: (k+1) P_{k+1} = (2k+1) x P_k - k P_{k-1}
  for (int k = 1; k < order; ++k)
    f(k + 1) = ((2.0 * k + 1.0) * x * f(k) - k * f(k - 1)) / (k + 1.0);
  return f;
}

Eigen::VectorXd Parameterisation::series_basis(double angle_deg) const {
  if (station_basis_.rows() > 0) {
    const int st = station_of(angle_deg);
    if (st >= 0 && station_deg_[static_cast<std::size_t>(st)] == angle_deg)
      return station_basis_.row(st).transpose();
  }
  return formed_basis(angle_deg);
}

Eigen::VectorXd Parameterisation::formed_basis(double angle_deg) const {
  switch (model_.kind) {
    case ErrorModel::Kind::kFourier:
      return fourier_basis(model_.order, angle_deg);
    case ErrorModel::Kind::kLegendre:
      return legendre_basis(
          model_.order,
          hi_deg_ > lo_deg_ ? 2.0 * (angle_deg - lo_deg_) / (hi_deg_ - lo_deg_) - 1.0 : 0.0);
    case ErrorModel::Kind::kPerAngle:
      break;
  }
  return Eigen::VectorXd::Ones(1);
}

Eigen::SparseMatrix<double> Parameterisation::error_functions(int station,
                                                              Eigen::Index rows) const {
  if (model_.kind != ErrorModel::Kind::kPerAngle)
    return series_error_functions(station_basis_.row(station).data(), rows);
  // Column by column, in order: no sort, no search.
  Eigen::SparseMatrix<double> E(std::max<Eigen::Index>(rows, n_parameters_), 6);
  E.reserve(6);
  for (int k = 0; k < 6; ++k) {
    E.startVec(k);
    E.insertBack(6 * station + k, k) = 1.0;
  }
  E.finalize();
  return E;
}

Eigen::SparseMatrix<double> Parameterisation::error_functions_at_angle(double angle_deg,
                                                                       Eigen::Index rows) const {
  if (model_.kind == ErrorModel::Kind::kPerAngle) {
    const int s = station_of(angle_deg);
    if (s < 0) {
      throw InputError("parameterisation", "angle " + format_angle(angle_deg),
                       "a per-angle model has no errors between its measured positions");
    }
    return error_functions(s, rows);
  }
  const Eigen::VectorXd f = series_basis(angle_deg);
  return series_error_functions(f.data(), rows);
}

Eigen::SparseMatrix<double> Parameterisation::series_error_functions(const double* f,
                                                                     Eigen::Index rows) const {
  // The basis' nonzeros once, then each error's column written straight into the compressed
  // storage (the same entries, in order).
  std::vector<std::pair<int, double>> nonzero;
  nonzero.reserve(static_cast<std::size_t>(per_error_));
  for (int j = 0; j < per_error_; ++j) {
    if (f[j] != 0.0) nonzero.emplace_back(j, f[j]);
  }
  const int nz = static_cast<int>(nonzero.size());
  Eigen::SparseMatrix<double> E(std::max<Eigen::Index>(rows, n_parameters_), 6);
  E.resizeNonZeros(6 * nz);
  int* outer = E.outerIndexPtr();
  int* inner = E.innerIndexPtr();
  double* value = E.valuePtr();
  for (int k = 0; k < 6; ++k) {
    outer[k] = k * nz;
    for (int t = 0; t < nz; ++t) {
      inner[k * nz + t] = k * per_error_ + nonzero[static_cast<std::size_t>(t)].first;
      value[k * nz + t] = nonzero[static_cast<std::size_t>(t)].second;
    }
  }
  outer[6] = 6 * nz;
  return E;
}

Eigen::MatrixXd Parameterisation::error_map(int station) const {
  return Eigen::MatrixXd(error_functions(station).transpose());
}

Eigen::MatrixXd Parameterisation::error_map_at_angle(double angle_deg) const {
  return Eigen::MatrixXd(error_functions_at_angle(angle_deg).transpose());
}

Eigen::Matrix<double, 6, 1> Parameterisation::errors_at_angle(double angle_deg,
                                                              const Eigen::VectorXd& theta) const {
  if (model_.kind == ErrorModel::Kind::kPerAngle)
    return error_functions_at_angle(angle_deg).transpose() * theta;
  // The basis functions once for the six errors, each summed in the order of its coefficients
  // (the product with error_functions_at_angle, without forming it).
  const Eigen::VectorXd f = series_basis(angle_deg);
  Eigen::Matrix<double, 6, 1> e = Eigen::Matrix<double, 6, 1>::Zero();
  for (int k = 0; k < 6; ++k) {
    for (int j = 0; j < per_error_; ++j) {
      if (f(j) != 0.0) e(k) += f(j) * theta(k * per_error_ + j);
    }
  }
  return e;
}

void Parameterisation::append_unknowns(const std::vector<std::string>& names) {
  extra_names_.insert(extra_names_.end(), names.begin(), names.end());
  n_parameters_ += static_cast<int>(names.size());
}

int Parameterisation::parameter_error(int j) const {
  if (j >= n_axis_parameters()) return -1;
  return model_.kind == ErrorModel::Kind::kPerAngle ? j % 6 : j / per_error_;
}

int Parameterisation::parameter_station(int j) const {
  if (j >= n_axis_parameters()) return -1;
  return model_.kind == ErrorModel::Kind::kPerAngle ? j / 6 : -1;
}

std::string Parameterisation::parameter_name(int j) const {
  if (j >= n_axis_parameters())
    return extra_names_[static_cast<std::size_t>(j - n_axis_parameters())];
  const std::string error = kErrorNames[parameter_error(j)];
  if (model_.kind == ErrorModel::Kind::kPerAngle) {
    return error + "@" + format_angle(station_deg_[parameter_station(j)]);
  }
  const int c = j % per_error_;
  if (model_.kind == ErrorModel::Kind::kFourier) {
    if (c == 0) return error + ".c0";
    return error + ((c % 2) ? ".cos" : ".sin") + std::to_string((c + 1) / 2);
  }
  return error + ".P" + std::to_string(c);
}

}  // namespace dbbkit
