#include "dbbkit/io/machine_io.hpp"

#include <cmath>

#include "dbbkit/error.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/json_reader.hpp"
#include "dbbkit/user_text.hpp"
#include "design_reader.hpp"
#include "object_reader.hpp"

namespace dbbkit::io {

using nlohmann::json;

namespace {

// The direction of L at angle 0 when the file gives none: the first of +Z, +X (a table: its
// normal at zero) or -Z, +X (a head: the spindle pointing down) perpendicular to the axis.
std::optional<Eigen::Vector3d> default_reference(const RotaryAxisSpec& r) {
  const Eigen::Vector3d first = r.side == AxisFrame::Side::kTable
                                    ? Eigen::Vector3d::UnitZ()
                                    : Eigen::Vector3d(-Eigen::Vector3d::UnitZ());
  for (const Eigen::Vector3d& c : {first, Eigen::Vector3d(Eigen::Vector3d::UnitX())})
    if (std::abs(c.dot(r.direction)) <= kFrameTolerance) return c;
  return std::nullopt;
}

int letter_index(const std::vector<RotaryAxisSpec>& axes, const std::string& letter) {
  for (std::size_t k = 0; k < axes.size(); ++k)
    if (letter.size() == 1 && axes[k].letter == letter[0]) return static_cast<int>(k);
  return -1;
}

}  // namespace

Machine machine_from_json(const json& j, const std::string& source) {
  ObjectReader top(j, source, "");
  top.allow(
      {"format", "name", "description", "controller", "linear_travel_mm", "rotary", "workspace"});
  Machine m;
  const std::string format = top.string("format");
  if (format != kMachineFormat)
    top.fail("format",
             "expected \"" + std::string(kMachineFormat) + "\", found " + quote_value(format));
  // The name is what results and chain match a machine by: required, never empty.
  m.name = top.string("name");
  if (m.name.empty()) top.fail("name", "empty: results and chain know the machine by its name");
  m.description = top.optional_string("description").value_or("");
  const std::string controller = top.string("controller");
  const auto c = controller_named(controller);
  if (!c)
    top.fail("controller", quote_value(controller) +
                               " (expected heidenhain, siemens, fanuc, linuxcnc, isg or generic)");
  m.controller = *c;
  {
    ObjectReader t = top.object("linear_travel_mm");
    t.allow({"x", "y", "z"});
    const char* names[] = {"x", "y", "z"};
    for (int i = 0; i < 3; ++i) {
      const std::vector<double> x =
          read_numbers(t.required(names[i]), source, t.key_path(names[i]));
      if (x.size() != 2) t.fail(names[i], "expected [min, max] in mm");
      m.linear_travel_mm[i] = {x[0], x[1]};
    }
    t.finish();
  }
  const json& rotary = top.required("rotary");
  if (!rotary.is_array() || rotary.empty())
    top.fail("rotary", "expected a list of the rotary axes, in chain order");
  if (rotary.size() > 3) top.fail("rotary", "at most three rotary axes (A, B, C)");
  for (std::size_t k = 0; k < rotary.size(); ++k) {
    ObjectReader a(rotary[k], source, "rotary[" + std::to_string(k) + "]");
    a.allow({"letter", "side", "on", "direction", "point_mm", "reference", "travel_deg", "park_deg",
             "table"});
    RotaryAxisSpec r;
    const std::string letter = a.string("letter");
    if (letter != "A" && letter != "B" && letter != "C")
      a.fail("letter", quote_value(letter) + " is not a rotary axis' letter (A, B or C)");
    r.letter = letter[0];
    const std::string side = a.string("side");
    if (side != "table" && side != "head")
      a.fail("side", quote_value(side) + " (expected \"table\" or \"head\")");
    r.side = side == "table" ? AxisFrame::Side::kTable : AxisFrame::Side::kHead;
    if (const auto on = a.optional_string("on")) {
      r.on = letter_index(m.rotary, *on);
      if (r.on < 0)
        a.fail("on", quote_value(*on) +
                         " is not an axis given before this one (the carrier comes first)");
    }
    r.direction = read_vector3(a, "direction");
    // A unit vector to 1e-6 (a controller's vector written to 9 decimals), made one exactly.
    if (!r.direction.allFinite() || std::abs(r.direction.norm() - 1) > 1e-6)
      a.fail("direction", "expected a unit vector [x, y, z]");
    r.direction.normalize();
    // Within kFrameTolerance of a machine axis it is that axis, exactly (as a design's); within
    // kNearAxis_rad, a controller's corrected vector: dbbkit's frame is the axis, the vector is
    // kept for compensation.
    r.direction = snapped_to_machine_axis(r.direction);
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d e = Eigen::Vector3d::Unit(k);
      const double sin_angle = r.direction.cross(e).norm();
      if (sin_angle > 0 && sin_angle <= kNearAxis_rad && r.direction(k) != 0) {
        r.controller_direction = r.direction.normalized();
        r.direction = r.direction(k) > 0 ? e : Eigen::Vector3d(-e);
      }
    }
    r.point_mm = read_vector3(a, "point_mm");
    if (a.has("reference")) {
      r.reference = read_vector3(a, "reference");
    } else if (const auto ref = default_reference(r)) {
      r.reference = *ref;
    } else {
      a.fail("reference",
             "missing: neither the default (+Z or +X on a table, -Z or +X on a head) is "
             "perpendicular to this axis; give the direction of L at angle 0");
    }
    const Travel travel = read_travel(a, "travel_deg", true);
    r.full_turn = travel.full_turn, r.travel_min_deg = travel.min_deg,
    r.travel_max_deg = travel.max_deg;
    r.park_deg = a.number("park_deg");
    if (const json* tj = a.optional("table")) {
      if (r.side != AxisFrame::Side::kTable)
        a.fail("table", "a head carries no table; give the table on its table axis");
      ObjectReader t(*tj, source, a.key_path("table"));
      t.allow({"diameter_mm", "surface_mm"});
      r.table_diameter_mm = t.number("diameter_mm");
      r.table_surface_mm = t.number("surface_mm");
      t.finish();
    }
    a.finish();
    m.rotary.push_back(r);
  }
  if (const json* wj = top.optional("workspace")) {
    ObjectReader w(*wj, source, "workspace");
    const json& solids = w.required("solids");
    if (!solids.is_array()) w.fail("solids", "expected a list of boxes");
    if (solids.size() > 1000) w.fail("solids", "at most 1000 solids");
    for (std::size_t s = 0; s < solids.size(); ++s) {
      ObjectReader b(solids[s], source, w.key_path("solids") + "[" + std::to_string(s) + "]");
      b.allow({"name", "box_mm", "turns_with"});
      WorkspaceSolid solid;
      solid.name = b.string("name");
      const json& box = b.required("box_mm");
      if (!box.is_array() || box.size() != 2)
        b.fail("box_mm", "expected [[xmin, ymin, zmin], [xmax, ymax, zmax]]");
      for (int e = 0; e < 2; ++e) {
        const std::vector<double> x =
            read_numbers(box[e], source, b.key_path("box_mm") + "[" + std::to_string(e) + "]");
        if (x.size() != 3) b.fail("box_mm", "expected [[xmin, ymin, zmin], [xmax, ymax, zmax]]");
        (e == 0 ? solid.min_mm : solid.max_mm) = Eigen::Vector3d(x[0], x[1], x[2]);
      }
      if (const auto t = b.optional_string("turns_with")) {
        solid.turns_with = letter_index(m.rotary, *t);
        if (solid.turns_with < 0)
          b.fail("turns_with", quote_value(*t) + " is not a rotary axis of this machine");
      }
      b.finish();
      m.solids.push_back(solid);
    }
    w.finish();
  }
  top.finish();
  validate_machine(m, source);
  return m;
}

Machine read_machine_file(const std::string& path) {
  return machine_from_json(parse_json(read_json_file(path), path), path);
}

json machine_to_json(const Machine& m) {
  auto vec = [](const Eigen::Vector3d& v) { return json::array({v.x(), v.y(), v.z()}); };
  json j;
  j["format"] = kMachineFormat;
  if (!m.name.empty()) j["name"] = m.name;
  if (!m.description.empty()) j["description"] = m.description;
  j["controller"] = controller_name(m.controller);
  j["linear_travel_mm"] = {
      {"x", m.linear_travel_mm[0]}, {"y", m.linear_travel_mm[1]}, {"z", m.linear_travel_mm[2]}};
  json axes = json::array();
  for (const RotaryAxisSpec& r : m.rotary) {
    json a = {{"letter", std::string(1, r.letter)},
              {"side", r.side == AxisFrame::Side::kTable ? "table" : "head"},
              {"direction", vec(r.controllers_direction())},
              {"point_mm", vec(r.point_mm)},
              {"reference", vec(r.reference)},
              {"park_deg", r.park_deg}};
    if (r.on >= 0) a["on"] = std::string(1, m.rotary[r.on].letter);
    a["travel_deg"] =
        r.full_turn ? json("full_turn") : json::array({r.travel_min_deg, r.travel_max_deg});
    if (r.table_diameter_mm)
      a["table"] = {{"diameter_mm", *r.table_diameter_mm}, {"surface_mm", *r.table_surface_mm}};
    axes.push_back(a);
  }
  j["rotary"] = axes;
  if (!m.solids.empty()) {
    json solids = json::array();
    for (const WorkspaceSolid& s : m.solids) {
      json b = {{"name", s.name}, {"box_mm", {vec(s.min_mm), vec(s.max_mm)}}};
      if (s.turns_with >= 0) b["turns_with"] = std::string(1, m.rotary[s.turns_with].letter);
      solids.push_back(b);
    }
    j["workspace"] = {{"solids", solids}};
  }
  return j;
}

}  // namespace dbbkit::io
