#pragma once
// The rotary axis under test as data (architecture.md, "axis_frame"): its letter, the side it
// carries (the table: the linear axes carry the following ball; the head: they carry the
// pivot), its direction (a positive angle turns the body by the right-hand rule about it), its
// reference (the direction of L at angle 0; on a head, from the pivot to the tool tip) and its
// travel (a full turn or an arc). The mathematics is written once in this frame; a C
// turntable and a B swinging head are two instances (formats.md, "General axis form"):
//   "C" = {C, table, direction +Z, reference +X},
//   "B" = {B, head, direction +Y, reference +Z}, its D (along Y) this form's H.
// A ball's body coordinates (L, D, H) are P0 = L e_L + D e_D + H e_H (the body frame is the
// machine frame at angle 0): e_L = reference, e_D = direction x reference, e_H = direction; the
// "B" shorthand keeps its own D along the axis (e_D = direction) and has no H.

#include <Eigen/Core>
#include <array>
#include <string>

namespace dbbkit {

// The rotation about the axis as harmonics of the angle: R(g) = A0 + cos g A1 + sin g A2,
// A0 = (R(0) + R(180)) / 2, A1 = (R(0) - R(180)) / 2, A2 = R(90) - A0.
struct RotationHarmonics {
  Eigen::Matrix3d A0, A1, A2;
};

class AxisFrame {
 public:
  enum class Side { kTable, kHead };

  // The shorthands "C" and "B".
  static AxisFrame c_turntable();
  static AxisFrame b_head();
  // The general form. `direction` and `reference` must be unit vectors, perpendicular to
  // each other (validate_axis_frame says which is not); an arc's travel is
  // [travel_min_deg, travel_max_deg].
  static AxisFrame general(char letter, Side side, const Eigen::Vector3d& direction,
                           const Eigen::Vector3d& reference, bool full_turn,
                           double travel_min_deg = -180, double travel_max_deg = 180);
  AxisFrame() : AxisFrame(c_turntable()) {}

  char letter() const { return letter_; }
  Side side() const { return side_; }
  bool table() const { return side_ == Side::kTable; }
  bool head() const { return side_ == Side::kHead; }
  const Eigen::Vector3d& direction() const { return direction_; }
  const Eigen::Vector3d& reference() const { return reference_; }
  // A full turn (0 and 360 are one position; a Fourier series fits) or an arc (a Legendre
  // series over the measured range).
  bool full_turn() const { return full_turn_; }
  double travel_min_deg() const { return travel_min_deg_; }
  double travel_max_deg() const { return travel_max_deg_; }
  // "C" or "B" when the design named a shorthand, else empty (the general form).
  const std::string& shorthand() const { return shorthand_; }
  // Whether a ball's H is a coordinate of this frame (the "B" shorthand has none).
  bool has_H() const { return has_H_; }

  // The ball's body coordinates' directions.
  const Eigen::Vector3d& e_L() const { return e_L_; }
  const Eigen::Vector3d& e_D() const { return e_D_; }
  const Eigen::Vector3d& e_H() const { return e_H_; }
  Eigen::Vector3d body_point(double L, double D, double H) const;
  // The named reading directions: radial = reference, tangential = direction x reference,
  // axial = direction (0, 1, 2).
  Eigen::Vector3d named_direction(int kind) const;

  // The rotation about the axis by angle_deg (exact at multiples of 90 deg; for an axis along
  // a machine axis every other entry is exactly 0 or +-1).
  Eigen::Matrix3d rotation(double angle_deg) const;
  const RotationHarmonics& harmonics() const { return harmonics_; }

  // The letter with what distinguishes the frame, for messages and reports: "C", "B",
  // "A (table, about +X)", "C (table, about -Z)".
  std::string label() const;
  // The index 0, 1, 2 of the machine axis the direction lies along (+-), or -1.
  int machine_axis() const;

  // The same axis: letter, side, direction, reference, travel (the shorthand aside).
  bool same_as(const AxisFrame& other) const;
  // The same axis whatever its form: letter, side, direction, reference and travel (a result's
  // quantities are the axis', not the ball coordinates' of its form).
  bool same_axis(const AxisFrame& other) const;

 private:
  explicit AxisFrame(int) {}  // unformed, for general()
  char letter_ = 'C';
  Side side_ = Side::kTable;
  Eigen::Vector3d direction_, reference_, e_L_, e_D_, e_H_;
  bool full_turn_ = true;
  double travel_min_deg_ = -180, travel_max_deg_ = 180;
  std::string shorthand_;
  bool has_H_ = true;
  RotationHarmonics harmonics_;
  void form_harmonics();
};

// A direction as the person at the machine names it: "+Z", "-X" along a machine axis, else
// "[x, y, z]" to 6 significant digits.
std::string direction_text(const Eigen::Vector3d& v);

// The largest |v| - 1 of a unit vector and |d . r| of perpendicular ones the frame accepts.
inline constexpr double kFrameTolerance = 1e-9;

// A unit vector within kFrameTolerance (rad) of a machine axis is that axis, exactly (its names,
// its letter and its rotations are then the machine axis'); any other is returned as it is.
Eigen::Vector3d snapped_to_machine_axis(const Eigen::Vector3d& v);

// How two frames differ, each as "<property> <a's> against <b's>" joined by "; " (letter,
// side, direction, reference, travel, form), or empty when they are the same axis. Without
// `travel` the travel is not compared (the same line, whatever angles it may reach).
std::string axis_difference(const AxisFrame& a, const AxisFrame& b, bool travel = true);

// What is wrong with a general frame's vectors (not unit, not perpendicular), or empty.
std::string axis_frame_problem(const Eigen::Vector3d& direction, const Eigen::Vector3d& reference);

}  // namespace dbbkit
