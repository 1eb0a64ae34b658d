#include "dbbkit/io/kit_io.hpp"

#include <cctype>
#include <filesystem>

#include "../number_text.hpp"
#include "dbbkit/error.hpp"
#include "dbbkit/instrument.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/json_reader.hpp"
#include "dbbkit/limits.hpp"
#include "dbbkit/user_text.hpp"
#include "design_reader.hpp"
#include "object_reader.hpp"
#include "result_blocks.hpp"

namespace dbbkit::io {

using nlohmann::json;

namespace {

Interval read_min_max(ObjectReader r) {
  Interval i;
  i.min = r.number("min");
  i.max = r.number("max");
  r.finish();
  return i;
}

// [a, b]: a list of exactly two numbers.
Interval read_pair(const json& v, const std::string& source, const std::string& path) {
  if (!v.is_array() || v.size() != 2) throw InputError(source, path, "expected [min, max]");
  return {as_number(v[0], source, path + "[0]"), as_number(v[1], source, path + "[1]")};
}

bool read_flag(ObjectReader& r, const std::string& key, bool fallback) {
  const json* v = r.optional(key);
  if (!v) return fallback;
  if (!v->is_boolean()) r.fail(key, "expected true or false");
  return v->get<bool>();
}

// A coordinate: a number (fixed, mm) or the name of a variable; absent = fixed 0.
PatternCoordinate read_coordinate(ObjectReader& r, const std::string& key) {
  const json* v = r.optional(key);
  if (!v) return {};
  if (v->is_string()) {
    const std::string name = as_string(*v, r.source(), r.key_path(key));
    if (name.empty()) r.fail(key, "a variable needs a name");
    // A variable names a design's coordinate in messages and results: letters, digits, _.
    for (char c : name) {
      if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_')
        r.fail(key, "the variable " + quote_value(name) + " holds letters, digits and _ only");
    }
    if (name.size() > 32) r.fail(key, "the variable " + quote_value(name) + " is longer than 32");
    return {name, 0};
  }
  return {"", as_number(*v, r.source(), r.key_path(key))};
}

PatternPosition read_position(ObjectReader r, InstrumentKind instrument) {
  PatternPosition p;
  p.id = r.string("id");
  p.L = read_coordinate(r, "L");
  p.D = read_coordinate(r, "D");
  p.H = read_coordinate(r, "H");
  if (instrument == InstrumentKind::kProbe) {
    // A position is a sphere, probed in x, y and z.
    if (r.has("directions"))
      r.fail("directions",
             "a probe kit's position is a sphere, probed in x, y and z: no directions");
    if (r.has("needs_offset"))
      r.fail("needs_offset", "is a head's ball bar pattern's: a probe kit has no head");
    if (r.has("separated"))
      r.fail("separated",
             "every sphere's stand stands apart in a probe kit (min_separation_mm, in the "
             "table's plane): no separated");
    p.optional = read_flag(r, "optional", false);
    r.finish();
    return p;
  }
  const json& dirs = r.required("directions");
  if (!dirs.is_array())
    r.fail("directions", "expected a list of \"radial\", \"tangential\", \"axial\"");
  for (size_t i = 0; i < dirs.size(); ++i) {
    const std::string path = r.key_path("directions") + "[" + std::to_string(i) + "]";
    const std::string d = as_string(dirs[i], r.source(), path);
    if (d == "radial") {
      p.directions.push_back(Direction::Kind::kRadial);
    } else if (d == "tangential") {
      p.directions.push_back(Direction::Kind::kTangential);
    } else if (d == "axial") {
      p.directions.push_back(Direction::Kind::kAxial);
    } else {
      throw InputError(
          r.source(), path,
          "unknown direction " + quote_value(d) + " (expected radial, tangential or axial)");
    }
  }
  p.separated = read_flag(r, "separated", true);
  p.optional = read_flag(r, "optional", false);
  p.needs_offset = read_flag(r, "needs_offset", false);
  r.finish();
  return p;
}

// "pattern": a built-in name, or {name, extends, positions, distinct}.
Pattern read_pattern(ObjectReader& top, const AxisFrame& axis, TableCarriage carriage,
                     InstrumentKind instrument) {
  const std::string& source = top.source();
  const bool probe = instrument == InstrumentKind::kProbe;
  auto named = [&](const std::string& name, const std::string& key) {
    if (std::optional<Pattern> p = builtin_pattern(name, axis, carriage, instrument)) return *p;
    if (probe)
      throw InputError(source, key,
                       "unknown pattern " + quote_value(name) +
                           " for a probe kit (expected \"spheres\" or a pattern object)");
    if (name == "free") {
      throw InputError(
          source, key,
          "\"free\" is not supported by this version of dbbkit: write the pattern as data, e.g. "
          "{\"extends\": \"three_position\", \"positions\": [...optional positions...]} (README, "
          "Kit file)");
    }
    throw InputError(
        source, key,
        "unknown pattern " + quote_value(name) +
            (name == "spheres" ? " for a ball bar kit (\"spheres\" is a touch probe kit's: add "
                                 "\"instrument\": {\"kind\": \"probe\", \"approach_mm\": ...})"
                               : " (expected \"three_position\" or a pattern object)"));
  };
  // A probe kit's pattern defaults to its spheres.
  if (probe && !top.has("pattern")) return named("spheres", "pattern");
  const json& v = top.required("pattern");
  if (v.is_string()) return named(v.get<std::string>(), "pattern");
  ObjectReader r = top.object("pattern");
  Pattern p;
  if (r.has("extends")) {
    p = named(r.string("extends"), r.key_path("extends"));
    p.builtin = false;
    p.interchangeable = false;  // the positions added differ from the built-in ones
    p.inherited_positions = static_cast<int>(p.positions.size());
  }
  p.name = r.optional_string("name").value_or(p.name.empty() ? "custom" : p.name + "+");
  if (const json* positions = r.optional("positions")) {
    if (!positions->is_array()) r.fail("positions", "expected a list of positions");
    for (size_t i = 0; i < positions->size(); ++i) {
      p.positions.push_back(
          read_position(ObjectReader((*positions)[i], source,
                                     r.key_path("positions") + "[" + std::to_string(i) + "]"),
                        instrument));
    }
  }
  if (const json* distinct = r.optional("distinct")) {
    if (!distinct->is_array()) r.fail("distinct", "expected a list of lists of height variables");
    for (size_t g = 0; g < distinct->size(); ++g) {
      const std::string path = r.key_path("distinct") + "[" + std::to_string(g) + "]";
      if (!(*distinct)[g].is_array())
        throw InputError(source, path, "expected a list of height variables");
      std::vector<std::string> group;
      for (size_t i = 0; i < (*distinct)[g].size(); ++i) {
        group.push_back(as_string((*distinct)[g][i], source, path + "[" + std::to_string(i) + "]"));
      }
      p.distinct.push_back(std::move(group));
    }
  }
  r.finish();
  return p;
}

}  // namespace

Kit kit_from_json(const json& j, const std::string& source, const std::string& base_dir) {
  ObjectReader top(j, source, "");
  Kit k;
  const std::string format = top.string("format");
  if (format != kKitFormat)
    top.fail("format", "expected \"" + std::string(kKitFormat) + "\", found \"" + format + "\"");
  k.name = top.optional_string("name").value_or("");
  top.optional_string("description");
  if (const json* ij = top.optional("instrument")) {
    ObjectReader in(*ij, source, "instrument");
    const std::string kind = in.string("kind");
    const std::optional<InstrumentKind> named = instrument_named(kind);
    if (!named)
      in.fail("kind",
              quote_value(kind) + " is no instrument (expected " + instrument_names() + ")");
    k.instrument = *named;
    if (k.instrument == InstrumentKind::kProbe) {
      k.probe.approach_mm = in.number("approach_mm");
      k.probe.max_stem_tilt_deg = in.optional_number("max_stem_tilt_deg");
    }
    in.finish();
  }
  const bool probe = k.instrument == InstrumentKind::kProbe;
  if (probe && top.has("machine"))
    top.fail("machine",
             "a probe kit states its axis and travel_mm (the probe's checks on a machine file's "
             "solids are a ball bar's program's): write the axis and the travel");
  if (top.has("machine")) {
    k.machine = read_design_machine(top, base_dir);
    if (k.machine->park_overrides.count(k.machine->letter()))
      top.fail("park_deg", std::string("names the axis under test, ") + k.machine->letter() +
                               ": a kit parks the other axes (the search places the cups with "
                               "the axis under test at its machine file's park angle)");
    k.axis = k.machine->machine->axis_frame(k.machine->axis, k.machine->park_angles());
  } else {
    if (top.has("park_deg"))
      top.fail("park_deg", "park angles belong to a kit that names its machine");
    k.axis = read_axis(top);
  }
  // A table's blocks raise the ball along the table's normal: on the "C" shorthand the axis
  // (+Z), with the frame's origin on the surface; in the general form the kit states both, or
  // its machine's table does.
  const bool general = k.axis.shorthand().empty();
  if (k.axis.table() && k.machine) {
    if (top.has("table"))
      top.fail("table",
               "comes from the machine file (its table's disc: diameter_mm, surface_mm): a kit "
               "that names its machine states no table of its own");
    const Machine& m = *k.machine->machine;
    const int t = m.innermost(AxisFrame::Side::kTable);
    const RotaryAxisSpec& r = m.rotary[static_cast<std::size_t>(t)];
    if (!r.table_surface_mm || !r.table_diameter_mm)
      top.fail("machine", "machine " + quote_value(m.name) + ": its table axis " +
                              std::string(1, r.letter) +
                              " states no table (table: diameter_mm, surface_mm): the kit's "
                              "cups and blocks stand on it");
    // The table's normal and its surface's centre with the axis under test at 0 (the others
    // parked), in the kit's frame (its origin the axis' nominal point there).
    const std::vector<double> at_zero = k.machine->angles_at(0);
    const Eigen::Vector3d n =
        m.body_direction_at(t, r.direction.z() < 0 ? -r.direction : r.direction, at_zero);
    const Eigen::Vector3d centre =
        m.body_point_at(t, m.table_centre_mm(t), at_zero) - m.point_at(k.machine->axis, at_zero);
    k.table_normal = snapped_to_machine_axis(n);
    k.table_surface_mm = k.table_normal.dot(centre);
  } else if (k.axis.table() && general) {
    if (!top.has("table"))
      top.fail("table",
               "required for a table in the general form: {\"normal\": [x, y, z], "
               "\"surface_mm\": s}, the table's normal at angle 0 and its surface's distance "
               "from the frame's origin along it (cushion blocks raise the ball along the normal: "
               "along the axis on a C or B table, across it on a trunnion)");
    ObjectReader t = top.object("table");
    const std::vector<double> n = read_numbers(t.required("normal"), source, t.key_path("normal"));
    if (n.size() != 3) t.fail("normal", "expected a vector [x, y, z]");
    k.table_normal = Eigen::Vector3d(n[0], n[1], n[2]);
    k.table_surface_mm = t.number("surface_mm");
    t.finish();
  } else if (top.has("table") && !k.machine) {
    top.fail("table", k.axis.table()
                          ? "the shorthand \"C\" has its table's normal along +Z and its origin on "
                            "the surface: write the axis in the general form to state another"
                          : "a table's normal and surface are a table axis': axis " +
                                k.axis.label() + " carries the head");
  }
  if (k.axis.table() && !general && !k.machine) k.table_normal = k.axis.direction();
  if (probe) {
    if (const auto p = probe_kit_axis_problem(k.axis)) top.fail("instrument.kind", *p);
  }
  const TableCarriage carriage = table_carriage(k);
  k.pattern = read_pattern(top, k.axis, carriage, k.instrument);
  if (const json* n = top.optional("noise"))
    k.noise = *read_noise(ObjectReader(*n, source, "noise"), false);
  if (const json* e = top.optional("errors"))
    k.errors = read_error_model(ObjectReader(*e, source, "errors"));
  const std::optional<double> reference_length_mm = top.optional_number("reference_length_mm");
  if (const json* u = top.optional("setup_std")) {
    k.setup_std = read_setup_override(ObjectReader(*u, source, "setup_std")).over({});
    validate_setup_uncertainty(k.setup_std, k.axis, source, "setup_std");
    if (const auto p = setup_tolerance_problem(k.setup_std, k.instrument))
      top.fail("setup_std", *p);
  }
  k.require_setup_detection = read_flag(top, "require_setup_detection", false);
  if (k.require_setup_detection && !k.setup_std.nuisance()) {
    top.fail("require_setup_detection", std::string("needs ") +
                                            instrument_info(k.instrument).setup_tolerance_phrase +
                                            " declared in setup_std");
  }
  if (probe && top.has("return_reading"))
    top.fail("return_reading",
             "a return reading is a ball bar sweep's; a probe's repeats are rows of its file");
  if (probe && top.has("require_drift_detection_um"))
    top.fail("require_drift_detection_um",
             "a probe's file has no time column: dbbkit tells no drift from a probe's readings");
  k.return_reading = read_flag(top, "return_reading", false);
  k.require_drift_detection_um = top.optional_number("require_drift_detection_um");
  if (k.require_drift_detection_um &&
      !(*k.require_drift_detection_um >= limits::kMinRequiredDrift_um &&
        *k.require_drift_detection_um <= limits::kMaxRequiredDrift_um))
    top.fail("require_drift_detection_um", "must be a drift over the whole test in um, at least " +
                                               text::significant(limits::kMinRequiredDrift_um, 6) +
                                               " and at most " +
                                               text::significant(limits::kMaxRequiredDrift_um, 6));
  if (carriage == TableCarriage::kAcrossAxis) {
    if (top.has("L_mm"))
      top.fail("L_mm",
               "on a trunnion (the table's normal across the axis) a ball's distance from the "
               "axis line is the table's surface plus its cup and blocks (table.surface_mm, "
               "H_mm); the cup slides across the table (D_mm) and along the axis (axial_mm)");
  } else {
    k.L_mm = read_min_max(top.object("L_mm"));
  }
  if (top.has("D_mm")) k.D_mm = read_min_max(top.object("D_mm"));
  if (top.has("axial_mm")) {
    // Along the axis: a general head's holder offset, a trunnion's slide.
    if (!general || (k.axis.table() && carriage == TableCarriage::kAlongAxis))
      top.fail("axial_mm", k.axis.table()
                               ? "a table whose normal is its axis raises the ball along the axis "
                                 "with cushion blocks (H_mm): no continuous range along the axis"
                               : "the shorthand \"B\" offsets the ball along the axis by D_mm");
    k.axial_mm = read_min_max(top.object("axial_mm"));
  }
  if (k.axis.table()) {
    ObjectReader h = top.object("H_mm");
    k.H_base_mm = h.number("base");
    k.blocks_mm = read_numbers(h.required("blocks"), source, h.key_path("blocks"));
    k.max_stack = h.integer("max_stack");
    h.finish();
  } else if (top.has("H_mm")) {
    top.fail("H_mm", "cushion blocks and a cup height are a table's: axis " + k.axis.label() +
                         " carries the head");
  }
  if (probe) {
    for (const char* key : {"bars", "bars_mm"})
      if (top.has(key)) top.fail(key, "a probe kit has no bars: the probe touches the spheres");
  } else {
    if (top.has("bars") && top.has("bars_mm"))
      top.fail("bars", "give the bars either as sold (bars) or as assembled (bars_mm), not both");
    if (top.has("bars")) {
      ObjectReader b = top.object("bars");
      BarSet set;
      set.base_mm = b.number("base_mm");
      if (const json* e = b.optional("extensions_mm"))
        set.extensions_mm = read_numbers(*e, source, b.key_path("extensions_mm"));
      if (b.has("max_extensions")) set.max_extensions = b.integer("max_extensions");
      b.finish();
      k.bar_set = set;
      // Checked before the 2^n assemblies are enumerated.
      if (static_cast<int>(set.extensions_mm.size()) > kMaxBarExtensions)
        throw InputError(source, "bars.extensions_mm",
                         "more than " + std::to_string(kMaxBarExtensions) + " extensions");
      k.bars_mm = assembled_bars(set);
    } else {
      const json& bars = top.required("bars_mm");
      // Checked before a number is read: the search tries each bar for each installation.
      if (bars.is_array() && bars.size() > static_cast<std::size_t>(kMaxBars))
        top.fail("bars_mm", std::to_string(bars.size()) + " bars: more than the " +
                                std::to_string(kMaxBars) + " a kit may hold");
      k.bars_mm = read_numbers(bars, source, top.key_path("bars_mm"));
    }
  }
  k.resolution_mm = top.optional_number("resolution_mm");
  if (k.machine && k.axis.table()) {
    // The spindle ball's travel is the machine's linear travel, in the kit's frame.
    if (top.has("travel_mm"))
      top.fail("travel_mm",
               "comes from the machine file (linear_travel_mm): a table axis' kit that names its "
               "machine states no travel of its own");
    const Eigen::Vector3d origin = k.machine->origin_mm();
    const auto& lt = k.machine->machine->linear_travel_mm;
    for (int i = 0; i < 3; ++i)
      k.travel_mm[static_cast<std::size_t>(i)] =
          Interval{lt[static_cast<std::size_t>(i)][0] - origin(i),
                   lt[static_cast<std::size_t>(i)][1] - origin(i)};
  } else {
    ObjectReader t = top.object("travel_mm");
    const char* names[] = {"x", "y", "z"};
    for (int i = 0; i < 3; ++i)
      k.travel_mm[i] = read_pair(t.required(names[i]), source, t.key_path(names[i]));
    t.finish();
  }
  k.min_separation_mm = top.optional_number("min_separation_mm").value_or(0.0);
  {
    ObjectReader a = top.object("angles_deg");
    k.angle_range_deg = read_pair(a.required("range"), source, a.key_path("range"));
    k.angle_steps_deg = read_numbers(a.required("steps"), source, a.key_path("steps"));
    k.angle_max_step_deg = a.optional_number("max_step");
    a.finish();
  }
  {
    ObjectReader t = top.object("time_s");
    k.time_per_reading_s = t.number("per_reading");
    if (probe && t.has("per_installation"))
      t.fail("per_installation",
             "a probe has no installations: per_position is a sphere set up, per_reading a "
             "sphere probed at one angle");
    k.time_per_installation_s = probe ? 0.0 : t.number("per_installation");
    // A probe's sphere set-up is its one set-up time: stated, never taken as 0.
    k.time_per_position_s =
        probe ? t.number("per_position") : t.optional_number("per_position").value_or(0.0);
    k.time_budget_s = t.optional_number("budget");
    t.finish();
  }
  if (const json* wj = top.optional("workspace")) {
    ObjectReader w(*wj, source, "workspace");
    if (probe && general)
      top.fail("workspace",
               "a probe kit checks the table's outline on the shorthand \"C\" only: the "
               "sphere's stand on a table in the general form is not checked (leave workspace "
               "out)");
    if (probe && w.has("spindle"))
      w.fail("spindle",
             "the probe's approach is checked by instrument.approach_mm: a spindle's nose is a "
             "ball bar kit's");
    if (probe && w.has("clearance_mm"))
      w.fail("clearance_mm",
             "is the spindle's clearance from the table, a ball bar kit's: a probe kit checks "
             "the approach (instrument.approach_mm) and the stands (footprint_mm)");
    Workspace ws;
    if (k.axis.table()) {
      if (const json* tj = w.optional("table")) {
        ObjectReader t(*tj, source, w.key_path("table"));
        if (t.has("diameter_mm") && (t.has("x_mm") || t.has("y_mm")))
          t.fail("diameter_mm",
                 "give the table as a circle (diameter_mm) or a rectangle (x_mm "
                 "and y_mm), not both");
        ws.table_diameter_mm = t.optional_number("diameter_mm");
        if (!ws.table_diameter_mm) {
          ws.table_x_mm = read_pair(t.required("x_mm"), source, t.key_path("x_mm"));
          ws.table_y_mm = read_pair(t.required("y_mm"), source, t.key_path("y_mm"));
        }
        t.finish();
      }
      ws.footprint_mm = w.optional_number("footprint_mm").value_or(0.0);
      if (w.has("table_ball_height_mm"))
        w.fail("table_ball_height_mm",
               "is a head's: on a table the ball's height is H_mm (the cup and its blocks)");
    } else {
      if (w.has("table"))
        w.fail("table",
               "the table of a head machine does not turn: give table_ball_height_mm "
               "(the table ball's centre above its surface)");
      if (w.has("footprint_mm"))
        w.fail("footprint_mm", "is a table's: the head's table ball stays where it is placed");
      ws.table_ball_height_mm = w.number("table_ball_height_mm");
    }
    if (const json* sj = w.optional("spindle")) {
      ObjectReader t(*sj, source, w.key_path("spindle"));
      ws.spindle_diameter_mm = t.number("diameter_mm");
      ws.ball_to_nose_mm = t.number("ball_to_nose_mm");
      t.finish();
    }
    if (const auto c = w.optional_number("clearance_mm")) ws.clearance_mm = *c;
    w.finish();
    k.workspace = ws;
  }
  if (k.machine && k.axis.table()) {
    // The table's outline: the machine's disc, unless the kit's workspace states one.
    const Machine& m = *k.machine->machine;
    const RotaryAxisSpec& r =
        m.rotary[static_cast<std::size_t>(m.innermost(AxisFrame::Side::kTable))];
    if (!k.workspace) k.workspace = Workspace{};
    if (!k.workspace->table_diameter_mm && !k.workspace->table_x_mm)
      k.workspace->table_diameter_mm = r.table_diameter_mm;
  }
  if (reference_length_mm) {
    k.reference_length_mm = *reference_length_mm;
  } else if (k.axis.table() && k.workspace && k.workspace->table_diameter_mm) {
    k.reference_length_mm = 0.5 * *k.workspace->table_diameter_mm;
    k.reference_length_basis = Kit::ReferenceLengthBasis::kTableRadius;
  } else if (k.axis.table() && k.workspace && k.workspace->table_x_mm) {
    const Interval& x = *k.workspace->table_x_mm;
    const Interval& y = *k.workspace->table_y_mm;
    k.reference_length_mm = std::hypot(std::max(std::abs(x.min), std::abs(x.max)),
                                       std::max(std::abs(y.min), std::abs(y.max)));
    k.reference_length_basis = Kit::ReferenceLengthBasis::kTableCorner;
  } else if (!k.axis.table() && k.L_mm.max > 0) {
    k.reference_length_mm = k.L_mm.max;
    k.reference_length_basis = Kit::ReferenceLengthBasis::kToolReach;
  } else {
    top.fail("reference_length_mm",
             k.axis.table()
                 ? "is needed: the lever arm that weighs an angular error in um, where the "
                   "machine cuts (absent, the table's radius: give workspace.table)"
                 : "is needed: the lever arm that weighs an angular error in um, where the "
                   "machine cuts (absent, the farthest ball position along the tool, L_mm.max, "
                   "which is 0 here)");
  }
  top.finish();
  validate_kit(k, source);
  if (k.require_drift_detection_um && !(k.time_per_reading_s > 0) &&
      !(k.time_per_installation_s > 0))
    top.fail("require_drift_detection_um",
             "a drift over the test needs the test's clock: time_s.per_reading or "
             "time_s.per_installation above 0 s");
  return k;
}

Kit kit_from_text(const std::string& text, const std::string& source, const std::string& base_dir) {
  return kit_from_json(parse_json(text, source), source, base_dir);
}

Kit read_kit_file(const std::string& path) {
  return kit_from_text(read_json_file(path), path,
                       std::filesystem::path(path).parent_path().string());
}

}  // namespace dbbkit::io
