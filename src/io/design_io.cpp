#include "dbbkit/io/design_io.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>

#include "../number_text.hpp"
#include "../tolerances.hpp"
#include "dbbkit/error.hpp"
#include "dbbkit/instrument.hpp"
#include "dbbkit/io/machine_io.hpp"
#include "dbbkit/io/text.hpp"
#include "dbbkit/user_text.hpp"
#include "design_reader.hpp"
#include "object_reader.hpp"
#include "result_blocks.hpp"

namespace dbbkit::io {

using nlohmann::json;

namespace {

// Largest number of angles a grid may have (a typo such as step 0.0001 must not exhaust memory).
constexpr double kMaxAngles = 100000;

std::vector<double> read_angles(ObjectReader& top) {
  const json& v = top.required("angles_deg");
  const std::string path = top.key_path("angles_deg");
  std::vector<double> angles;
  if (v.is_array()) {
    for (size_t i = 0; i < v.size(); ++i) {
      angles.push_back(as_number(v[i], top.source(), path + "[" + std::to_string(i) + "]"));
    }
    if (angles.empty()) throw InputError(top.source(), path, "the list of angles is empty");
    return angles;
  }
  ObjectReader grid(v, top.source(), path);
  grid.allow({"start", "stop", "step"});
  const double start = grid.number("start"), stop = grid.number("stop"), step = grid.number("step");
  grid.finish();
  if (step == 0.0) grid.fail("step", "must not be 0");
  const double n = (stop - start) / step;
  if (n < -tol::kWholeSteps) grid.fail("step", "goes away from stop (the sign of step is wrong)");
  if (std::abs(n - std::round(n)) > tol::kWholeSteps * std::max(1.0, std::abs(n))) {
    grid.fail("stop", "is not start + k * step for a whole k");
  }
  if (n + 1 > kMaxAngles) grid.fail("step", "gives more than 100000 angles");
  const long count = std::lround(n) + 1;
  for (long i = 0; i < count; ++i) angles.push_back(start + static_cast<double>(i) * step);
  return angles;
}

Direction read_direction(const json& v, const AxisFrame& axis, const std::string& source,
                         const std::string& path) {
  if (v.is_string()) {
    const std::string s = v.get<std::string>();
    if (s == "radial") return Direction::named(axis, Direction::Kind::kRadial);
    if (s == "tangential") return Direction::named(axis, Direction::Kind::kTangential);
    if (s == "axial") return Direction::named(axis, Direction::Kind::kAxial);
    throw InputError(source, path,
                     "unknown direction " + quote_value(s) +
                         " (expected radial, tangential, axial or a unit vector [x, y, z])");
  }
  if (v.is_array() && v.size() == 3) {
    Eigen::Vector3d u;
    for (int i = 0; i < 3; ++i)
      u(i) = as_number(v[i], source, path + "[" + std::to_string(i) + "]");
    if (std::abs(u.norm() - 1.0) > tol::kUnitVectorTolerance) {
      throw InputError(
          source, path,
          "an explicit direction must be a unit vector (|v| = " + std::to_string(u.norm()) + ")");
    }
    return Direction::vector(u);
  }
  throw InputError(source, path, "expected radial, tangential, axial or a unit vector [x, y, z]");
}

}  // namespace

std::optional<NoiseModel> read_noise(ObjectReader noise, bool allow_none) {
  noise.allow({"distribution", "accuracy_um", "std_um"});
  const std::optional<std::string> given = noise.optional_string("distribution");
  const std::string dist = given.value_or("uniform");
  NoiseModel m;
  if (dist == "uniform") {
    m.distribution = NoiseModel::Distribution::kUniform;
    // Each distribution has its own key: the one of the other is no typo to guess at.
    if (noise.has("std_um")) {
      noise.fail("std_um",
                 "std_um belongs to the normal distribution (its standard deviation); the "
                 "uniform distribution" +
                     std::string(given ? "" : " (the default without \"distribution\")") +
                     " is declared by its half-width accuracy_um: give accuracy_um, or "
                     "\"distribution\": \"normal\" with std_um");
    }
    m.half_width_um = noise.number("accuracy_um");
    if (!(m.half_width_um > 0))
      noise.fail("accuracy_um",
                 "must be a positive number of um, got " + fmt_num(m.half_width_um, 6));
  } else if (dist == "normal") {
    m.distribution = NoiseModel::Distribution::kNormal;
    if (noise.has("accuracy_um")) {
      noise.fail("accuracy_um",
                 "accuracy_um belongs to the uniform distribution (its half-width); the normal "
                 "distribution is declared by its standard deviation std_um: give std_um, or "
                 "\"distribution\": \"uniform\" with accuracy_um");
    }
    m.std_um = noise.number("std_um");
    if (!(m.std_um > 0))
      noise.fail("std_um", "must be a positive number of um, got " + fmt_num(m.std_um, 6));
  } else if (dist == "none" && allow_none) {
    noise.finish();
    return std::nullopt;
  } else {
    noise.fail("distribution", "unknown distribution " + quote_value(dist) +
                                   " (expected uniform or normal" +
                                   std::string(allow_none ? " or none)" : ")"));
  }
  noise.finish();
  return m;
}

Eigen::Vector3d read_vector3(ObjectReader& r, const std::string& key) {
  const std::vector<double> x = read_numbers(r.required(key), r.source(), r.key_path(key));
  if (x.size() != 3) r.fail(key, "expected a vector [x, y, z]");
  return {x[0], x[1], x[2]};
}

Travel read_travel(ObjectReader& a, const std::string& key, bool full_turn_default) {
  Travel travel;
  travel.full_turn = full_turn_default;
  const json* t = a.optional(key);
  if (!t) return travel;
  if (t->is_string() && t->get<std::string>() == "full_turn") {
    travel.full_turn = true;
    return travel;
  }
  if (t->is_string())
    a.fail(key, quote_value(t->get<std::string>()) +
                    ": expected \"full_turn\" or an arc [min, max] in degrees");
  const std::vector<double> x = read_numbers(*t, a.source(), a.key_path(key));
  if (x.size() != 2) a.fail(key, "expected \"full_turn\" or an arc [min, max] in degrees");
  if (!(x[0] < x[1]))
    a.fail(key, "min " + text::significant(x[0], 12) + " must be below max " +
                    text::significant(x[1], 12));
  if (x[0] < -360 || x[1] > 360) a.fail(key, "the ends must lie within -360..360 deg");
  if (x[1] - x[0] > 360)
    a.fail(key, "an arc of at most one turn (360 deg); a whole turn is \"full_turn\"");
  travel.full_turn = false, travel.min_deg = x[0], travel.max_deg = x[1];
  return travel;
}

AxisFrame read_axis(ObjectReader& top) {
  const json& v = top.required("axis");
  if (v.is_string()) {
    const std::string axis = v.get<std::string>();
    if (axis == "B") return AxisFrame::b_head();
    if (axis != "C") {
      top.fail("axis", "unknown axis " + quote_value(axis) +
                           " (expected \"C\", \"B\" or the general form {letter, side, "
                           "direction, reference}; another letter names an axis of the "
                           "design's machine, which the design names with \"machine\")");
    }
    return AxisFrame::c_turntable();
  }
  // The general form (formats.md, "General axis form").
  ObjectReader a(v, top.source(), "axis");
  const std::string letter = a.string("letter");
  if (letter != "A" && letter != "B" && letter != "C")
    a.fail("letter", quote_value(letter) + " is not a rotary axis' letter (A, B or C)");
  const std::string side = a.string("side");
  const char* kMachineAxes = "XYZ";
  if (side != "table" && side != "head")
    a.fail("side", quote_value(side) + " (expected \"table\" or \"head\")");
  Eigen::Vector3d direction = read_vector3(a, "direction"),
                  reference = read_vector3(a, "reference");
  if (const std::string p = axis_frame_problem(direction, reference); !p.empty())
    a.fail(p.rfind("direction", 0) == 0 ? "direction" : "reference", p);
  // A vector within kFrameTolerance (rad) of a machine axis is that axis, exactly: its names,
  // its letter and its rotations are then the machine axis', not a nutating axis' at 1e-9.
  direction = snapped_to_machine_axis(direction);
  reference = snapped_to_machine_axis(reference);
  // ISO 841: the rotary axis about X is A, about Y is B, about Z is C (a primed axis turns the
  // other way about the same line); an axis along none of them (nutating) takes any letter.
  for (int k = 0; k < 3; ++k) {
    if (std::abs(direction(k)) == 1.0 && letter[0] != "ABC"[k]) {  // along it (snapped above)
      a.fail("letter", "an axis along " + std::string(direction(k) > 0 ? "+" : "-") +
                           kMachineAxes[k] + " is " + std::string(1, "ABC"[k]) +
                           " (ISO 841), not " + quote_value(letter) +
                           ": its location errors would be named after the other axis");
    }
  }
  const bool table = side == "table";
  const Travel travel = read_travel(a, "travel_deg", table);
  a.finish();
  return AxisFrame::general(letter[0], table ? AxisFrame::Side::kTable : AxisFrame::Side::kHead,
                            direction, reference, travel.full_turn, travel.min_deg, travel.max_deg);
}

json axis_to_json(const AxisFrame& axis) {
  if (!axis.shorthand().empty()) return axis.shorthand();
  json j = {{"letter", std::string(1, axis.letter())},
            {"side", axis.table() ? "table" : "head"},
            {"direction", {axis.direction().x(), axis.direction().y(), axis.direction().z()}},
            {"reference", {axis.reference().x(), axis.reference().y(), axis.reference().z()}}};
  if (axis.full_turn() != axis.table() || !axis.full_turn()) {
    j["travel_deg"] = axis.full_turn()
                          ? json("full_turn")
                          : json::array({axis.travel_min_deg(), axis.travel_max_deg()});
  }
  return j;
}

json axis_frame_to_json(const AxisFrame& axis) {
  auto vec = [](const Eigen::Vector3d& v) { return json::array({v.x(), v.y(), v.z()}); };
  json j = {{"letter", std::string(1, axis.letter())},
            {"side", axis.table() ? "table" : "head"},
            {"direction", vec(axis.direction())},
            {"reference", vec(axis.reference())},
            {"travel_deg", axis.full_turn()
                               ? json("full_turn")
                               : json::array({axis.travel_min_deg(), axis.travel_max_deg()})},
            {"shorthand", axis.shorthand().empty() ? json(nullptr) : json(axis.shorthand())}};
  j["ball_axes"] = {{"L", vec(axis.e_L())},
                    {"D", vec(axis.e_D())},
                    {"H", axis.has_H() ? vec(axis.e_H()) : json(nullptr)}};
  return j;
}

ErrorModel read_error_model(ObjectReader errors) {
  ErrorModel m;
  const std::string model = errors.string("model");
  if (model == "per_angle") {
    m.kind = ErrorModel::Kind::kPerAngle;
    if (errors.has("order")) errors.fail("order", "a per_angle model has no order");
  } else if (model == "fourier" || model == "legendre") {
    m.kind = model == "fourier" ? ErrorModel::Kind::kFourier : ErrorModel::Kind::kLegendre;
    m.order = errors.integer("order");
    if (m.order < 0) errors.fail("order", "must be >= 0");
  } else {
    errors.fail("model", "unknown model " + quote_value(model) +
                             " (expected per_angle, fourier or legendre)");
  }
  errors.finish();
  return m;
}

// {"length_offset_um", "centring_um", "L_mm", "D_mm", "H_mm"}: each optional.
SetupOverride read_setup_override(ObjectReader r) {
  SetupOverride o;
  o.length_offset_um = r.optional_number("length_offset_um");
  o.centring_um = r.optional_number("centring_um");
  o.L_mm = r.optional_number("L_mm");
  o.D_mm = r.optional_number("D_mm");
  o.H_mm = r.optional_number("H_mm");
  o.trigger_offset_um = r.optional_number("trigger_offset_um");
  o.placement_um = r.optional_number("placement_um");
  r.finish();
  return o;
}

json setup_to_json(const SetupUncertainty& u, const AxisFrame& axis) {
  if (u.trigger_offset_um > 0 || u.placement_um > 0)  // a probe's
    return {{"trigger_offset_um", u.trigger_offset_um}, {"placement_um", u.placement_um}};
  json j = {{"length_offset_um", u.length_offset_um},
            {"centring_um", u.centring_um},
            {"L_mm", u.L_mm},
            {"D_mm", u.D_mm}};
  if (axis.has_H()) j["H_mm"] = u.H_mm;
  return j;
}

json setup_override_to_json(const SetupOverride& o) {
  json j = json::object();
  for (const auto& [key, v] : {std::pair{"length_offset_um", &o.length_offset_um},
                               {"centring_um", &o.centring_um},
                               {"L_mm", &o.L_mm},
                               {"D_mm", &o.D_mm},
                               {"H_mm", &o.H_mm},
                               {"trigger_offset_um", &o.trigger_offset_um},
                               {"placement_um", &o.placement_um}}) {
    if (*v) j[key] = **v;
  }
  return j;
}

json noise_to_json(const NoiseModel& noise) {
  if (noise.distribution == NoiseModel::Distribution::kUniform) {
    return {{"distribution", "uniform"}, {"accuracy_um", noise.half_width_um}};
  }
  return {{"distribution", "normal"}, {"std_um", noise.std_um}};
}

DesignMachine read_design_machine(ObjectReader& top, const std::string& base_dir) {
  DesignMachine dm;
  dm.file = top.string("machine");
  if (dm.file.empty()) top.fail("machine", "empty: the path of a machine file");
  if (dm.file.find('\0') != std::string::npos) top.fail("machine", "a path holds no NUL byte");
  std::filesystem::path path(dm.file);
  if (path.is_relative() && !base_dir.empty()) path = std::filesystem::path(base_dir) / path;
  dm.machine = std::make_shared<const Machine>(read_machine_file(path.string()));
  const Machine& m = *dm.machine;
  std::string letters;
  for (const RotaryAxisSpec& r : m.rotary)
    letters += (letters.empty() ? "" : ", ") + std::string(1, r.letter);
  const json& a = top.required("axis");
  if (!a.is_string())
    top.fail("axis", "with a machine, the letter of the axis under test (" + letters + ")");
  const std::string letter = a.get<std::string>();
  dm.axis = letter.size() == 1 ? m.find(letter[0]) : -1;
  if (dm.axis < 0)
    top.fail("axis", quote_value(letter) + " is not an axis of machine " + quote_value(m.name) +
                         " (its axes: " + letters + ")");
  if (const json* pj = top.optional("park_deg")) {
    ObjectReader park(*pj, top.source(), "park_deg");
    for (auto it = pj->begin(); it != pj->end(); ++it) {
      const int k = it.key().size() == 1 ? m.find(it.key()[0]) : -1;
      if (k < 0)
        park.fail(it.key(),
                  "not an axis of machine " + quote_value(m.name) + " (its axes: " + letters + ")");
      const double v = park.number(it.key());
      const RotaryAxisSpec& r = m.rotary[k];
      if (!(std::abs(v) <= 360) || (!r.full_turn && (v < r.travel_min_deg || v > r.travel_max_deg)))
        park.fail(it.key(), "the park angle " + text::significant(v, 12) +
                                " deg lies outside the axis' travel");
      dm.park_overrides[r.letter] = v;
    }
  }
  return dm;
}

namespace {

// A ball's (or a sphere's) body coordinates, ball_mm: L, D (default 0) and H (required on a
// table, default 0 on a head, refused on the swinging head B).
void read_ball(ObjectReader& in, const AxisFrame& axis, double& L, double& D, double& H) {
  ObjectReader ball = in.object("ball_mm");
  ball.allow({"L", "D", "H"});
  L = ball.number("L");
  D = ball.optional_number("D").value_or(0.0);
  if (axis.table()) {
    H = ball.number("H");
  } else if (axis.has_H()) {
    H = ball.optional_number("H").value_or(0.0);
  } else if (ball.has("H")) {
    ball.fail("H", "H is not used for the swinging head B (ball at (L sin b, D, L cos b))");
  }
  ball.finish();
}

// A ball bar's design's installations (formats.md, "Design file"): each with its id, its ball,
// the bar's direction and sign, its bar, its cup's stack, its own set-up tolerances and angles.
void read_installations(ObjectReader& top, Design& d) {
  if (top.has("spheres"))
    top.fail("spheres",
             "spheres are a touch probe's (\"instrument\": {\"kind\": \"probe\"}); a ball bar's "
             "design gives installations");
  const json& list = top.required("installations");
  if (!list.is_array()) top.fail("installations", "expected a list of installations");
  for (size_t i = 0; i < list.size(); ++i) {
    const std::string path = "installations[" + std::to_string(i) + "]";
    ObjectReader in(list[i], top.source(), path);
    Installation inst;
    inst.id = in.string("id");
    read_ball(in, d.axis, inst.L_mm, inst.D_mm, inst.H_mm);
    inst.direction =
        read_direction(in.required("direction"), d.axis, top.source(), path + ".direction");
    inst.sign = in.optional_integer("sign").value_or(1);
    inst.reading_sign = in.optional_integer("reading_sign").value_or(1);
    if (inst.reading_sign != 1 && inst.reading_sign != -1)
      in.fail("reading_sign", "must be +1 or -1, got " + std::to_string(inst.reading_sign));
    if (inst.sign != 1 && inst.sign != -1)
      in.fail("sign", "must be +1 or -1, got " + std::to_string(inst.sign));
    inst.bar_mm = in.optional_number("bar_mm");
    inst.description = in.optional_string("description").value_or("");
    if (const json* parts = in.optional("bar_parts_mm"))
      inst.bar_parts_mm = read_numbers(*parts, top.source(), path + ".bar_parts_mm");
    if (const json* st = in.optional("stack_mm")) {
      if (!d.axis.table())
        in.fail("stack_mm", "a cup on cushion blocks stands on a table: axis " + d.axis.label() +
                                " carries the head");
      if (d.axis.shorthand().empty())
        in.fail("stack_mm",
                "the cup and blocks add up to H, along the axis, as on the C turntable whose "
                "table's normal is its axis; on axis " +
                    d.axis.label() +
                    " their direction is the table's normal, which the design does not state: "
                    "give the ball's L, D and H alone");
      ObjectReader stack(*st, top.source(), path + ".stack_mm");
      inst.cup_mm = stack.number("cup");
      if (const json* b = stack.optional("blocks"))
        inst.blocks_mm = read_numbers(*b, top.source(), stack.key_path("blocks"));
      stack.finish();
    }
    if (const json* u = in.optional("setup_std"))
      inst.setup_std = read_setup_override(ObjectReader(*u, top.source(), path + ".setup_std"));
    if (in.has("angles_deg")) inst.angles_deg = read_angles(in);
    in.finish();
    d.installations.push_back(inst);
  }
}

// A probe design's spheres (formats.md, "A second instrument"): each with its id, its centre in
// the body frame (ball_mm, as a ball bar's ball) and a description; their channels become the
// design's installations.
void read_spheres(ObjectReader& top, Design& d) {
  if (top.has("installations"))
    top.fail("installations",
             "a probe's design gives spheres (its readings are their centres), not a ball bar's "
             "installations");
  const json& list = top.required("spheres");
  if (!list.is_array() || list.empty())
    top.fail("spheres", "expected a list of spheres, at least one");
  for (size_t i = 0; i < list.size(); ++i) {
    const std::string path = "spheres[" + std::to_string(i) + "]";
    ObjectReader in(list[i], top.source(), path);
    Sphere sp;
    sp.id = in.string("id");
    read_ball(in, d.axis, sp.L_mm, sp.D_mm, sp.H_mm);
    sp.description = in.optional_string("description").value_or("");
    in.finish();
    d.spheres.push_back(sp);
  }
  d.installations = probe_channels(d.axis, d.spheres);
}

// A ball's or sphere's centre as a design writes it: L, D where not 0, H on a table or where not 0.
json ball_json(const AxisFrame& axis, double L_mm, double D_mm, double H_mm) {
  json ball = {{"L", L_mm}};
  if (D_mm != 0.0) ball["D"] = D_mm;
  if (axis.table() || (axis.has_H() && H_mm != 0.0)) ball["H"] = H_mm;
  return ball;
}

void write_installations(json& j, const Design& d) {
  json list = json::array();
  for (const Installation& in : d.installations) {
    json i;
    i["id"] = in.id;
    i["ball_mm"] = ball_json(d.axis, in.L_mm, in.D_mm, in.H_mm);
    if (in.direction.kind == Direction::Kind::kVector) {
      i["direction"] = {in.direction.body.x(), in.direction.body.y(), in.direction.body.z()};
    } else {
      i["direction"] = in.direction.label();
    }
    if (in.sign != 1) i["sign"] = in.sign;
    if (in.reading_sign != 1) i["reading_sign"] = in.reading_sign;
    if (in.bar_mm) i["bar_mm"] = *in.bar_mm;
    if (!in.bar_parts_mm.empty()) i["bar_parts_mm"] = in.bar_parts_mm;
    if (in.cup_mm) i["stack_mm"] = {{"cup", *in.cup_mm}, {"blocks", in.blocks_mm}};
    if (!in.description.empty()) i["description"] = in.description;
    if (in.setup_std.any()) i["setup_std"] = setup_override_to_json(in.setup_std);
    if (!in.angles_deg.empty()) i["angles_deg"] = in.angles_deg;
    list.push_back(i);
  }
  j["installations"] = list;
}

void write_spheres(json& j, const Design& d) {
  json spheres = json::array();
  for (const Sphere& sp : d.spheres) {
    json o = {{"id", sp.id}, {"ball_mm", ball_json(d.axis, sp.L_mm, sp.D_mm, sp.H_mm)}};
    if (!sp.description.empty()) o["description"] = sp.description;
    spheres.push_back(o);
  }
  j["spheres"] = spheres;
}

// Each instrument's part of a design file, in the order of InstrumentKind: what it measures (a
// ball bar's installations, a probe's spheres), read and written. The rest of the file is every
// instrument's.
struct InstrumentFile {
  InstrumentKind kind;
  void (*read)(ObjectReader& top, Design& d);
  void (*write)(json& j, const Design& d);
};
constexpr std::array<InstrumentFile, 2> kInstrumentFiles = {{
    {InstrumentKind::kBallbar, read_installations, write_installations},
    {InstrumentKind::kProbe, read_spheres, write_spheres},
}};
static_assert(kInstrumentFiles[0].kind == InstrumentKind::kBallbar &&
                  kInstrumentFiles[1].kind == InstrumentKind::kProbe,
              "kInstrumentFiles is indexed by InstrumentKind");
const InstrumentFile& instrument_file(InstrumentKind kind) {
  return kInstrumentFiles[static_cast<std::size_t>(kind)];
}

}  // namespace

Design design_from_json(const json& j, const std::string& source, const std::string& base_dir) {
  ObjectReader top(j, source, "");
  Design d;
  const std::string format = top.string("format");
  if (format != kDesignFormat)
    top.fail("format", "expected \"" + std::string(kDesignFormat) + "\", found \"" + format + "\"");
  d.name = top.optional_string("name").value_or("");
  d.description = top.optional_string("description").value_or("");
  if (const json* a = top.optional("assumed")) {
    ObjectReader assumed(*a, source, "assumed");
    for (auto it = a->begin(); it != a->end(); ++it) {
      d.assumed[it.key()] = assumed.string(it.key());
    }
  }
  if (top.has("machine")) {
    d.machine = read_design_machine(top, base_dir);
    d.axis = d.machine->machine->axis_frame(d.machine->axis, d.machine->park_angles());
  } else {
    if (top.has("park_deg"))
      top.fail("park_deg", "park angles belong to a design that names its machine");
    d.axis = read_axis(top);
  }
  d.angles_deg = read_angles(top);
  if (const json* n = top.optional("noise"))
    d.noise = *read_noise(ObjectReader(*n, source, "noise"), false);
  if (const json* e = top.optional("errors"))
    d.errors = read_error_model(ObjectReader(*e, source, "errors"));
  d.reference_length_mm = top.optional_number("reference_length_mm");
  if (const json* inst = top.optional("instrument")) {
    ObjectReader r(*inst, source, "instrument");
    if (const auto kind = r.optional_string("kind")) {
      const std::optional<InstrumentKind> named = instrument_named(*kind);
      if (!named)
        r.fail("kind",
               quote_value(*kind) + " is no instrument (expected " + instrument_names() + ")");
      d.instrument = *named;
    }
    if (const auto v = r.optional_number("range_mm")) d.instrument_range_mm = *v;
    if (const auto v = r.optional_number("max_drift_um_per_min")) d.max_drift_um_per_min = *v;
    r.finish();
  }
  if (const json* v = top.optional("return_reading")) {
    if (!v->is_boolean()) top.fail("return_reading", "expected true or false");
    d.return_reading = v->get<bool>();
  }
  if (const json* u = top.optional("setup_std_mm")) {
    // The short form of the ball placement alone: {"L": u, "D": u, "H": u} [mm].
    if (top.has("setup_std"))
      top.fail("setup_std_mm",
               "give the ball placement in setup_std (L_mm, D_mm, H_mm) or here, not both");
    ObjectReader setup(*u, source, "setup_std_mm");
    d.setup_std.L_mm = setup.optional_number("L").value_or(0.0);
    d.setup_std.D_mm = setup.optional_number("D").value_or(0.0);
    d.setup_std.H_mm = setup.optional_number("H").value_or(0.0);
    setup.finish();
  }
  if (const json* u = top.optional("setup_std"))
    d.setup_std = read_setup_override(ObjectReader(*u, source, "setup_std")).over({});

  instrument_file(d.instrument).read(top, d);
  // An installation's own angle within kAngleTolerance_deg of a design angle is that angle, as
  // the design writes it (readings are matched to it exactly); others are refused by
  // validate_design.
  std::vector<double> sorted = d.angles_deg;
  std::sort(sorted.begin(), sorted.end());
  for (Installation& in : d.installations) {
    for (double& a : in.angles_deg)
      if (const long k = angle_index(sorted, a); k >= 0) a = sorted[static_cast<std::size_t>(k)];
  }
  if (const json* p = top.optional("predicted")) {
    ObjectReader pr(*p, source, "predicted");
    Prediction pred;
    pred.criterion = pr.optional_string("criterion").value_or("");
    for (auto [key, field] : {std::pair{"worst_std_um", &pred.worst_std_um},
                              std::pair{"worst_determined_std_um", &pred.worst_determined_std_um},
                              std::pair{"worst_total_std_um", &pred.worst_total_std_um}}) {
      if (const json* v = pr.optional(key); v && !v->is_null())
        *field = as_number(*v, source, pr.key_path(key));
    }
    pred.rank = pr.integer("rank");
    pred.n_unknowns = pr.integer("n_unknowns");
    pred.time_s = pr.optional_number("time_s");
    pr.finish();
    d.predicted = pred;
  }
  top.finish();
  validate_design(d, source);
  return d;
}

Design read_design_file(const std::string& path) {
  return design_from_json(parse_json(read_json_file(path), path), path,
                          std::filesystem::path(path).parent_path().string());
}

json design_to_json(const Design& d) {
  json j;
  j["format"] = kDesignFormat;
  if (!d.name.empty()) j["name"] = d.name;
  if (!d.description.empty()) j["description"] = d.description;
  if (!d.assumed.empty()) j["assumed"] = d.assumed;
  if (d.machine) {
    j["machine"] = d.machine->file;
    j["axis"] = std::string(1, d.machine->letter());
    if (!d.machine->park_overrides.empty()) {
      json park = json::object();
      for (const auto& [letter, angle] : d.machine->park_overrides)
        park[std::string(1, letter)] = angle;
      j["park_deg"] = park;
    }
  } else {
    j["axis"] = axis_to_json(d.axis);
  }
  j["angles_deg"] = d.angles_deg;
  j["noise"] = noise_to_json(d.noise);
  json errors;
  if (d.errors.kind == ErrorModel::Kind::kPerAngle) {
    errors["model"] = "per_angle";
  } else {
    errors["model"] = d.errors.kind == ErrorModel::Kind::kFourier ? "fourier" : "legendre";
    errors["order"] = d.errors.order;
  }
  j["errors"] = errors;
  if (d.reference_length_mm) j["reference_length_mm"] = *d.reference_length_mm;
  if (d.instrument != InstrumentKind::kBallbar)
    j["instrument"]["kind"] = instrument_info(d.instrument).name;
  if (d.instrument_range_mm != kDefaultInstrumentRange_mm)
    j["instrument"]["range_mm"] = d.instrument_range_mm;
  if (d.max_drift_um_per_min != kDefaultMaxDrift_um_per_min)
    j["instrument"]["max_drift_um_per_min"] = d.max_drift_um_per_min;
  if (d.return_reading) j["return_reading"] = true;
  if (d.setup_std.nuisance()) {
    j["setup_std"] = setup_to_json(d.setup_std, d.axis);
  } else if (d.setup_std.any()) {
    j["setup_std_mm"] = {{"L", d.setup_std.L_mm}, {"D", d.setup_std.D_mm}};
    if (d.axis.has_H()) j["setup_std_mm"]["H"] = d.setup_std.H_mm;
  }
  instrument_file(d.instrument).write(j, d);
  if (d.predicted) {
    const Prediction& p = *d.predicted;
    json pj;
    if (!p.criterion.empty()) pj["criterion"] = p.criterion;
    pj["worst_std_um"] = p.worst_std_um ? json(*p.worst_std_um) : json(nullptr);
    pj["worst_determined_std_um"] =
        p.worst_determined_std_um ? json(*p.worst_determined_std_um) : json(nullptr);
    if (p.worst_total_std_um) pj["worst_total_std_um"] = *p.worst_total_std_um;
    pj["rank"] = p.rank;
    pj["n_unknowns"] = p.n_unknowns;
    if (p.time_s) pj["time_s"] = *p.time_s;
    j["predicted"] = pj;
  }
  return j;
}

}  // namespace dbbkit::io
