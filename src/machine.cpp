#include "dbbkit/machine.hpp"

#include <cmath>

#include "dbbkit/error.hpp"
#include "dbbkit/limits.hpp"
#include "dbbkit/user_text.hpp"
#include "number_text.hpp"

namespace dbbkit {

namespace {

// The rotation of axis k by angle a about its nominal direction (exact at multiples of 90 deg
// for an axis along a machine axis: AxisFrame::rotation).
Eigen::Matrix3d rotation_of(const RotaryAxisSpec& r, double angle_deg) {
  return AxisFrame::general(r.letter, r.side, r.direction, r.reference, true).rotation(angle_deg);
}

bool finite3(const Eigen::Vector3d& v) { return v.allFinite(); }

}  // namespace

std::optional<Controller> controller_named(const std::string& name) {
  if (name == "heidenhain") return Controller::kHeidenhain;
  if (name == "siemens") return Controller::kSiemens;
  if (name == "fanuc") return Controller::kFanuc;
  if (name == "linuxcnc") return Controller::kLinuxCNC;
  if (name == "isg") return Controller::kISG;
  if (name == "generic") return Controller::kGeneric;
  return std::nullopt;
}

const char* controller_name(Controller c) {
  switch (c) {
    case Controller::kHeidenhain:
      return "heidenhain";
    case Controller::kSiemens:
      return "siemens";
    case Controller::kFanuc:
      return "fanuc";
    case Controller::kLinuxCNC:
      return "linuxcnc";
    case Controller::kISG:
      return "isg";
    case Controller::kGeneric:
      break;
  }
  return "generic";
}

int Machine::find(char letter) const {
  for (std::size_t k = 0; k < rotary.size(); ++k)
    if (rotary[k].letter == letter) return static_cast<int>(k);
  return -1;
}

std::vector<int> Machine::carriers(int k) const {
  std::vector<int> chain;
  for (int c = rotary[k].on; c >= 0; c = rotary[c].on) chain.insert(chain.begin(), c);
  return chain;
}

int Machine::innermost(AxisFrame::Side side) const {
  int last = -1;
  for (std::size_t k = 0; k < rotary.size(); ++k) {
    if (rotary[k].side != side) continue;
    bool carries = false;
    for (const RotaryAxisSpec& r : rotary) carries |= r.on == static_cast<int>(k);
    if (!carries) last = static_cast<int>(k);
  }
  return last;
}

Eigen::Vector3d Machine::table_centre_mm(int k) const {
  const RotaryAxisSpec& r = rotary[k];
  return r.point_mm + (*r.table_surface_mm - r.point_mm.dot(r.direction)) * r.direction;
}

Machine::OnTable Machine::on_table(int k, const Eigen::Vector3d& x,
                                   const std::vector<double>& angles_deg) const {
  const RotaryAxisSpec& r = rotary[k];
  const Eigen::Vector3d v = to_body(k, x, angles_deg) - r.point_mm;
  OnTable t;
  t.height_mm = (r.point_mm + v).dot(r.direction) - *r.table_surface_mm;
  t.radius_mm = (v - v.dot(r.direction) * r.direction).norm();
  t.inside_edge = t.radius_mm <= 0.5 * *r.table_diameter_mm;
  return t;
}

std::vector<int> Machine::chain_to(int k) const {
  std::vector<int> chain = carriers(k);
  chain.push_back(k);
  return chain;
}

Eigen::Vector3d Machine::body_point_at(int k, const Eigen::Vector3d& x0,
                                       const std::vector<double>& angles_deg) const {
  // T_1 ... T_k x0: apply the innermost first.
  Eigen::Vector3d x = x0;
  const std::vector<int> chain = chain_to(k);
  for (auto it = chain.rbegin(); it != chain.rend(); ++it) {
    const RotaryAxisSpec& r = rotary[*it];
    x = r.point_mm + rotation_of(r, angles_deg[*it]) * (x - r.point_mm);
  }
  return x;
}

Eigen::Vector3d Machine::to_body(int k, const Eigen::Vector3d& x_at,
                                 const std::vector<double>& angles_deg) const {
  Eigen::Vector3d x = x_at;
  for (const int c : chain_to(k)) {
    const RotaryAxisSpec& r = rotary[c];
    x = r.point_mm + rotation_of(r, angles_deg[c]).transpose() * (x - r.point_mm);
  }
  return x;
}

Eigen::Vector3d Machine::body_direction_at(int k, const Eigen::Vector3d& v0,
                                           const std::vector<double>& angles_deg) const {
  Eigen::Vector3d v = v0;
  const std::vector<int> chain = chain_to(k);
  for (auto it = chain.rbegin(); it != chain.rend(); ++it)
    v = rotation_of(rotary[*it], angles_deg[*it]) * v;
  return v;
}

std::vector<double> Machine::park_angles(const std::map<char, double>& overrides) const {
  std::vector<double> a;
  for (const RotaryAxisSpec& r : rotary) {
    const auto it = overrides.find(r.letter);
    a.push_back(it == overrides.end() ? r.park_deg : it->second);
  }
  return a;
}

Eigen::Vector3d Machine::point_at(int k, const std::vector<double>& angles_deg) const {
  const int c = rotary[k].on;
  return c < 0 ? rotary[k].point_mm : body_point_at(c, rotary[k].point_mm, angles_deg);
}

AxisFrame Machine::axis_frame(int k, const std::vector<double>& angles_deg) const {
  const RotaryAxisSpec& r = rotary[k];
  const int c = r.on;
  const Eigen::Vector3d d = c < 0 ? r.direction : body_direction_at(c, r.direction, angles_deg);
  const Eigen::Vector3d ref = c < 0 ? r.reference : body_direction_at(c, r.reference, angles_deg);
  // A carrier turned by a multiple of 90 deg leaves a machine axis a machine axis: snap the
  // round-off so that the frame keeps its ISO names.
  return AxisFrame::general(r.letter, r.side, snapped_to_machine_axis(d),
                            snapped_to_machine_axis(ref), r.full_turn, r.travel_min_deg,
                            r.travel_max_deg);
}

void validate_machine(const Machine& m, const std::string& source) {
  auto fail = [&](const std::string& key, const std::string& what) {
    throw InputError(source, key, what);
  };
  if (const auto p = text_problem(m.name, limits::kMaxNameBytes)) fail("name", *p);
  if (const auto p = text_problem(m.description, limits::kMaxTextBytes)) fail("description", *p);
  const char* names[] = {"x", "y", "z"};
  for (int i = 0; i < 3; ++i) {
    const auto& t = m.linear_travel_mm[i];
    if (!(std::isfinite(t[0]) && std::isfinite(t[1]) && t[0] < t[1] &&
          std::abs(t[0]) <= limits::kMaxLength_mm && std::abs(t[1]) <= limits::kMaxLength_mm))
      fail(std::string("linear_travel_mm.") + names[i],
           "expected [min, max] with min < max, within +-10000 mm");
  }
  if (m.rotary.empty()) fail("rotary", "a machine has at least one rotary axis");
  if (m.rotary.size() > 3) fail("rotary", "at most three rotary axes (A, B, C)");
  for (std::size_t k = 0; k < m.rotary.size(); ++k) {
    const RotaryAxisSpec& r = m.rotary[k];
    const std::string at = "rotary[" + std::to_string(k) + "]";
    if (r.letter != 'A' && r.letter != 'B' && r.letter != 'C')
      fail(at + ".letter", "a rotary axis is A, B or C");
    for (std::size_t j = 0; j < k; ++j)
      if (m.rotary[j].letter == r.letter)
        fail(at + ".letter", std::string("axis ") + r.letter + " is given twice");
    if (!finite3(r.direction) || std::abs(r.direction.norm() - 1) > kFrameTolerance)
      fail(at + ".direction", "expected a unit vector [x, y, z]");
    if (!finite3(r.point_mm) || r.point_mm.cwiseAbs().maxCoeff() > limits::kMaxLength_mm)
      fail(at + ".point_mm", "expected [x, y, z] in mm within +-10000 mm");
    if (const std::string p = axis_frame_problem(r.direction, r.reference); !p.empty())
      fail(at + (p.rfind("direction", 0) == 0 ? ".direction" : ".reference"), p);
    // ISO 841: an axis along X is A, along Y B, along Z C.
    for (int i = 0; i < 3; ++i) {
      if (std::abs(r.direction(i)) == 1.0 && r.letter != "ABC"[i])
        fail(at + ".letter", std::string("an axis along ") + "XYZ"[i] + " is " + "ABC"[i] +
                                 " (ISO 841), not " + r.letter);
    }
    if (r.on >= static_cast<int>(k))
      fail(at + ".on", "the carrier comes before the axis it carries");
    if (r.on >= 0 && m.rotary[r.on].side != r.side)
      fail(at + ".on", std::string("axis ") + r.letter + " is on the " +
                           (r.side == AxisFrame::Side::kTable ? "table" : "head") +
                           " side; it cannot be carried by " + m.rotary[r.on].letter +
                           " on the other");
    if (!r.full_turn) {
      if (!(std::isfinite(r.travel_min_deg) && std::isfinite(r.travel_max_deg) &&
            r.travel_min_deg < r.travel_max_deg && r.travel_min_deg >= -360 &&
            r.travel_max_deg <= 360 && r.travel_max_deg - r.travel_min_deg <= 360))
        fail(at + ".travel_deg", "expected [min, max], min < max, within -360..360, one turn");
    }
    if (!std::isfinite(r.park_deg) ||
        (!r.full_turn && (r.park_deg < r.travel_min_deg || r.park_deg > r.travel_max_deg)) ||
        std::abs(r.park_deg) > 360)
      fail(at + ".park_deg",
           text::significant(r.park_deg, 7) +
               " deg: the park angle must lie in the axis' travel (" +
               (r.full_turn ? std::string("a full turn, within +-360 deg")
                            : text::significant(r.travel_min_deg, 7) + " to " +
                                  text::significant(r.travel_max_deg, 7) + " deg") +
               ")");
    if (r.table_diameter_mm && !(std::isfinite(*r.table_diameter_mm) && *r.table_diameter_mm > 0 &&
                                 *r.table_diameter_mm <= 2 * limits::kMaxLength_mm))
      fail(at + ".table.diameter_mm", "expected a diameter in (0, 20000] mm");
    if (r.table_surface_mm && !(std::isfinite(*r.table_surface_mm) &&
                                std::abs(*r.table_surface_mm) <= limits::kMaxLength_mm))
      fail(at + ".table.surface_mm", "expected a height within +-10000 mm");
  }
  // One axis per side stands on the frame; another of that side is carried ("on").
  for (std::size_t k = 0; k < m.rotary.size(); ++k) {
    for (std::size_t j = 0; j < k; ++j) {
      if (m.rotary[k].on < 0 && m.rotary[j].on < 0 && m.rotary[j].side == m.rotary[k].side)
        fail("rotary[" + std::to_string(k) + "].on",
             std::string("missing: axis ") + m.rotary[j].letter + " already stands on the " +
                 (m.rotary[k].side == AxisFrame::Side::kTable ? "table" : "head") +
                 " side's frame; name the axis that carries " + m.rotary[k].letter);
    }
  }
  for (std::size_t s = 0; s < m.solids.size(); ++s) {
    const WorkspaceSolid& w = m.solids[s];
    const std::string at = "workspace.solids[" + std::to_string(s) + "]";
    if (const auto p = text_problem(w.name, limits::kMaxNameBytes)) fail(at + ".name", *p);
    if (!(finite3(w.min_mm) && finite3(w.max_mm) && (w.min_mm.array() < w.max_mm.array()).all() &&
          w.min_mm.cwiseAbs().maxCoeff() <= limits::kMaxLength_mm &&
          w.max_mm.cwiseAbs().maxCoeff() <= limits::kMaxLength_mm))
      fail(at + ".box_mm",
           "expected [[xmin, ymin, zmin], [xmax, ymax, zmax]], each min below its max");
    if (w.turns_with >= static_cast<int>(m.rotary.size()))
      fail(at + ".turns_with", "not an axis of the machine");
  }
}

}  // namespace dbbkit
