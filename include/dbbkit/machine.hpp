#pragma once
// The machine as its controller's kinematic model has it (formats.md, "Machine file", format
// `dbbkit.machine/1`): the controller, the linear travel, and every rotary axis in chain order
// with its nominal line (direction and a point on it, machine frame, every axis at zero), its
// travel and where it stands while another axis is measured. A location error identified on a
// design that names its machine is the real axis line minus this nominal one, so a corrected
// machine file is what the controller should hold.
//
// The chain (product of rotations about nominal lines): a point fixed to the innermost body of a
// side (the table side: the workpiece; the head side: the spindle) moves with the angles as
//   x = T_1(a_1) T_2(a_2) ... x0,   T_k(a) x = p_k + R_k(a) (x - p_k),
// axis 1 the one nearest the machine's frame on that side, every line given at all angles 0.

#include <Eigen/Core>
#include <array>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "dbbkit/axis_frame.hpp"

namespace dbbkit {

enum class Controller { kHeidenhain, kSiemens, kFanuc, kLinuxCNC, kISG, kGeneric };
// "heidenhain", "siemens", ...; nullopt for another name.
std::optional<Controller> controller_named(const std::string& name);
const char* controller_name(Controller c);

// The largest angle between a machine file's direction and a machine axis for which it is taken
// as that axis (a controller's corrected vector) [rad].
inline constexpr double kNearAxis_rad = 1e-3;

struct RotaryAxisSpec {
  char letter = 'C';
  AxisFrame::Side side = AxisFrame::Side::kTable;
  Eigen::Vector3d direction = Eigen::Vector3d::UnitZ();  // unit, machine frame at zero
  // The controller's own vector where the file gives one within kNearAxis_rad of a machine axis
  // but not on it (a corrected kinematics): `direction` is then that machine axis (dbbkit's
  // frame, ISO names, the program's geometry: under TCPM the controller moves on its own
  // vector, the difference entering the readings to second order), this what compensation
  // corrects. Absent: the file's direction is `direction`.
  std::optional<Eigen::Vector3d> controller_direction;
  Eigen::Vector3d controllers_direction() const { return controller_direction.value_or(direction); }
  Eigen::Vector3d point_mm = Eigen::Vector3d::Zero();  // a point on the nominal line
  // The direction of a ball's L at angle 0 (perpendicular to direction): given, or the first of
  // +Z, +X (a table) or -Z, +X (a head: the spindle pointing down) perpendicular to direction.
  Eigen::Vector3d reference = Eigen::Vector3d::UnitX();
  int on = -1;  // the index of the axis that carries this one (same side), or -1: the frame
  bool full_turn = true;
  double travel_min_deg = -180, travel_max_deg = 180;
  double park_deg = 0;
  // A table's disc (optional): its diameter and the height of its surface along the axis,
  // measured as the point's coordinate along direction (the machine frame's, e.g. z).
  std::optional<double> table_diameter_mm, table_surface_mm;
};

// A box in the machine frame with every axis at zero, fixed to the body of turns_with (an axis'
// index; -1: the machine's frame).
struct WorkspaceSolid {
  std::string name;
  Eigen::Vector3d min_mm = Eigen::Vector3d::Zero(), max_mm = Eigen::Vector3d::Zero();
  int turns_with = -1;
};

struct Machine {
  std::string name, description;
  Controller controller = Controller::kGeneric;
  std::array<std::array<double, 2>, 3> linear_travel_mm{};
  std::vector<RotaryAxisSpec> rotary;
  std::vector<WorkspaceSolid> solids;

  // The index of the axis with this letter, or -1.
  int find(char letter) const;
  // The carriers of axis k, the one nearest the frame first (not k itself); chain_to: and k.
  std::vector<int> carriers(int k) const;
  std::vector<int> chain_to(int k) const;
  // The axis of `side` that carries no other (the table the workpiece stands on, the head the
  // spindle turns with), or -1.
  int innermost(AxisFrame::Side side) const;
  // Table axis k with a disc: its surface's centre (machine frame at zero), and where a point x
  // at `angles_deg` stands over it (its height above the surface, its distance from the axis,
  // and whether that is within the table's edge).
  Eigen::Vector3d table_centre_mm(int k) const;
  struct OnTable {
    double height_mm = 0, radius_mm = 0;
    bool inside_edge = false;
  };
  OnTable on_table(int k, const Eigen::Vector3d& x, const std::vector<double>& angles_deg) const;
  // The nominal pose of a point fixed to the body of axis k (after k's own rotation) at the
  // angles `angles_deg` (one per rotary axis, in the machine's order): T_c1 ... T_k x0.
  Eigen::Vector3d body_point_at(int k, const Eigen::Vector3d& x0,
                                const std::vector<double>& angles_deg) const;
  // The inverse: the point at zero that body_point_at takes to x.
  Eigen::Vector3d to_body(int k, const Eigen::Vector3d& x,
                          const std::vector<double>& angles_deg) const;
  // The same for a direction.
  Eigen::Vector3d body_direction_at(int k, const Eigen::Vector3d& v0,
                                    const std::vector<double>& angles_deg) const;
  // Every axis at its park angle, with the overrides given (letter -> angle).
  std::vector<double> park_angles(const std::map<char, double>& overrides = {}) const;
  // The frame of axis k as a design measures it: its carriers at `angles_deg` (its own angle
  // aside), its direction and reference turned with them; the origin is point_at(k, ...).
  AxisFrame axis_frame(int k, const std::vector<double>& angles_deg) const;
  Eigen::Vector3d point_at(int k, const std::vector<double>& angles_deg) const;
};

// Every key within its bounds, the chain consistent; throws InputError(source, key).
void validate_machine(const Machine& m, const std::string& source);

}  // namespace dbbkit
