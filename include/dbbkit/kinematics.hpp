#pragma once
// Ball position, reading direction and the sensitivity of one DBB reading to
// the six error motions of the rotary axis (model.md §1-4).
//
// Error motion vector e6 = (dx, dy, dz [um], ex, ey, ez [urad]) of the moving
// body at one angle, expressed in the machine frame. To first order a point P
// of the moving body moves by dP[um] = 1e-3 * (e x P[mm]) + d   (model.md §1).

#include <Eigen/Core>
#include <array>

#include "dbbkit/design.hpp"

namespace dbbkit {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using RowVector6d = Eigen::Matrix<double, 1, 6>;

inline constexpr std::array<const char*, 6> kErrorNames = {"dx", "dy", "dz", "ex", "ey", "ez"};
inline constexpr std::array<const char*, 6> kErrorUnits = {"um",   "um",   "um",
                                                           "urad", "urad", "urad"};

// sin and cos of an angle in degrees, exact (0, +-1) at multiples of 90 deg,
// so that a lever arm times cos(90 deg) is 0 and not 6e-17.
void sincos_deg(double angle_deg, double& s, double& c);

// Rotation of the axis at `angle_deg` (AxisFrame::rotation): Rz for C, Ry for B.
Eigen::Matrix3d axis_rotation(const AxisFrame& axis, double angle_deg);

// The rotation about the axis as harmonics of the angle (formed once per frame).
const RotationHarmonics& rotation_harmonics(const AxisFrame& axis);

// Ball position in the body frame (= machine frame at angle 0), AxisFrame::body_point:
// C: (L, D, H) (model.md §3); B: (0, D, L), so that P(b) = (L sin b, D, L cos b) (§4).
Eigen::Vector3d ball_body_mm(const AxisFrame& axis, const Installation& inst);

// Nominal ball position and unit reading direction in the machine frame at an angle (a probe
// channel's direction is fixed in the machine frame: instrument.hpp).
Eigen::Vector3d ball_position_mm(const AxisFrame& axis, const Installation& inst, double angle_deg);
Eigen::Vector3d direction_machine(const AxisFrame& axis, const Installation& inst,
                                  double angle_deg);

// The rotation of the exact transform of the error motions, Rx(ex) Ry(ey) Rz(ez) (e6 in urad):
// the one the exact readings (below, instrument.hpp) turn the body by.
Eigen::Matrix3d error_rotation(const Vector6d& e6);

// First-order displacement of a point of the moving body [um].
Eigen::Vector3d displacement_um(const Vector6d& e6, const Eigen::Vector3d& P_mm);

// d(reading [um]) / d(e6): reading = s u.dP = s u.d + 1e-3 s (P x u).e   (model.md §2).
RowVector6d J_reading_error(const AxisFrame& axis, const Installation& inst, double angle_deg);

// The reading computed through the exact homogeneous transform
// E = Trans(d) Rx(ex) Ry(ey) Rz(ez) applied to the ball, with the following ball
// at F = P - s * bar * u on the nominal path: reading = |E P - F| - |P - F| [um].
// No small-angle approximation; used to check J_reading_error.
double exact_reading_um(const AxisFrame& axis, const Installation& inst, double angle_deg,
                        const Vector6d& e6, double bar_mm);

// The set-up of one installation as it really is, against the design.
struct SetupError {
  double length_offset_um = 0;  // zero (length) error of the bar as mounted
  Eigen::Vector3d centring_um =
      Eigen::Vector3d::Zero();  // offset of the following ball's path centre, machine frame
  Eigen::Vector3d ball_mm =
      Eigen::Vector3d::Zero();  // ball as placed minus as designed: (dL, dD, dH)
};

// The exact two-ball reading with a real set-up, no linearisation anywhere:
//   B0 = ball_body(L + dL, D + dD, H + dH)     the ball as placed (body frame),
//   P  = Trans(d) Rx(ex) Ry(ey) Rz(ez) R(angle) B0   where it really is,
//   F  = R(angle) ball_body(L, D, H) - s bar u + c   the following ball, on the nominal
//        path the machine was programmed for, shifted by the centring c,
//   reading = |P - F| - bar + length_offset   [um].
// With a zero set-up and zero errors it reads 0 exactly.
double exact_setup_reading_um(const AxisFrame& axis, const Installation& inst, double angle_deg,
                              const Vector6d& e6, double bar_mm, const SetupError& setup);

}  // namespace dbbkit
