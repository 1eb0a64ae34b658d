#include "dbbkit/kinematics.hpp"

#include <Eigen/Geometry>
#include <cmath>

namespace dbbkit {

namespace {
constexpr double kPi = 3.14159265358979323846;
double rad(double deg) { return deg * kPi / 180.0; }
}  // namespace

void sincos_deg(double angle_deg, double& s, double& c) {
  // fmod is exact and returns an angle already in [0, 360) unchanged: skipped for those.
  double a = angle_deg >= 0.0 && angle_deg < 360.0 ? angle_deg : std::fmod(angle_deg, 360.0);
  if (a < 0) a += 360.0;
  // The nearest quadrant, a half to the even one: the angles a and 360 - a then take the
  // quadrants q and 4 - q and opposite remainders r, so that sin is odd and cos even to the bit
  // (the reflection the series' bias bound pairs angles by: series_l1.cpp).
  const double x = a / 90.0;
  double q = std::round(x);
  if (std::abs(q - x) == 0.5) q = 2.0 * std::round(0.5 * x);
  const int quadrant = static_cast<int>(q) % 4;
  const double r = rad(a - 90.0 * q);  // |r| <= 45 deg
  const double sr = r == 0 ? 0.0 : std::sin(r), cr = r == 0 ? 1.0 : std::cos(r);
  switch (quadrant) {
    case 0:
      s = sr, c = cr;
      break;
    case 1:
      s = cr, c = -sr;
      break;
    case 2:
      s = -sr, c = -cr;
      break;
    default:
      s = -cr, c = sr;
      break;
  }
}

Eigen::Matrix3d axis_rotation(const AxisFrame& axis, double angle_deg) {
  return axis.rotation(angle_deg);
}

const RotationHarmonics& rotation_harmonics(const AxisFrame& axis) { return axis.harmonics(); }

Eigen::Vector3d ball_body_mm(const AxisFrame& axis, const Installation& inst) {
  return axis.body_point(inst.L_mm, inst.D_mm, inst.H_mm);
}

Eigen::Vector3d ball_position_mm(const AxisFrame& axis, const Installation& inst,
                                 double angle_deg) {
  return axis_rotation(axis, angle_deg) * ball_body_mm(axis, inst);
}

Eigen::Vector3d direction_machine(const AxisFrame& axis, const Installation& inst,
                                  double angle_deg) {
  if (inst.probe_channel()) return inst.direction.body;  // fixed in the machine frame
  return axis_rotation(axis, angle_deg) * inst.direction.body;
}

Eigen::Matrix3d error_rotation(const Vector6d& e6) {
  return (Eigen::AngleAxisd(1e-6 * e6(3), Eigen::Vector3d::UnitX()) *
          Eigen::AngleAxisd(1e-6 * e6(4), Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(1e-6 * e6(5), Eigen::Vector3d::UnitZ()))
      .toRotationMatrix();
}

Eigen::Vector3d displacement_um(const Vector6d& e6, const Eigen::Vector3d& P_mm) {
  return 1e-3 * e6.tail<3>().cross(P_mm) + e6.head<3>();
}

RowVector6d J_reading_error(const AxisFrame& axis, const Installation& inst, double angle_deg) {
  const Eigen::Matrix3d R = axis_rotation(axis, angle_deg);
  const Eigen::Vector3d P = R * ball_body_mm(axis, inst);
  const Eigen::Vector3d u =
      inst.probe_channel() ? inst.direction.body : Eigen::Vector3d(R * inst.direction.body);
  RowVector6d row;
  // u.(e x P) = e.(P x u)
  row.head<3>() = inst.sign * u.transpose();
  row.tail<3>() = 1e-3 * inst.sign * P.cross(u).transpose();
  return row;
}

double exact_reading_um(const AxisFrame& axis, const Installation& inst, double angle_deg,
                        const Vector6d& e6, double bar_mm) {
  const Eigen::Vector3d P = ball_position_mm(axis, inst, angle_deg);
  const Eigen::Vector3d u = direction_machine(axis, inst, angle_deg);
  const Eigen::Vector3d F = P - inst.sign * bar_mm * u;
  const Eigen::Matrix3d R = error_rotation(e6);
  const Eigen::Vector3d P_actual = R * P + 1e-3 * e6.head<3>();
  return 1e3 * ((P_actual - F).norm() - (P - F).norm());
}

double exact_setup_reading_um(const AxisFrame& axis, const Installation& inst, double angle_deg,
                              const Vector6d& e6, double bar_mm, const SetupError& setup) {
  Installation placed = inst;
  placed.L_mm += setup.ball_mm(0);
  placed.D_mm += setup.ball_mm(1);
  if (axis.has_H()) placed.H_mm += setup.ball_mm(2);
  const Eigen::Vector3d P_nominal = ball_position_mm(axis, inst, angle_deg);
  const Eigen::Vector3d u = direction_machine(axis, inst, angle_deg);
  const Eigen::Vector3d F = P_nominal - inst.sign * bar_mm * u + 1e-3 * setup.centring_um;
  const Eigen::Matrix3d R = error_rotation(e6);
  const Eigen::Vector3d P = R * ball_position_mm(axis, placed, angle_deg) + 1e-3 * e6.head<3>();
  return 1e3 * ((P - F).norm() - bar_mm) + setup.length_offset_um;
}

}  // namespace dbbkit
