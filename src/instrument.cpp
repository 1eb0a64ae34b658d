#include "dbbkit/instrument.hpp"

#include <Eigen/Geometry>
#include <array>

#include "dbbkit/error.hpp"
#include "dbbkit/limits.hpp"
#include "dbbkit/user_text.hpp"

namespace dbbkit {

namespace {

// In the order of InstrumentKind (checked below).
constexpr std::array<InstrumentInfo, 2> kInstruments = {{
    {.kind = InstrumentKind::kBallbar,
     .name = "ballbar",
     .noun = "a ball bar",
     .item = "an installation",
     .items = "installations",
     .items_capitalised = "Installations",
     .points = "balls",
     .row_carrier = "installation",
     .row_column = "inst",
     .rows_per_item = 1,
     .item_read = "",
     .setup_effect_nouns = "length offset and centring",
     .setup_effects_plural = "length offsets and centrings",
     .setup_tolerance_keys = "length_offset_um, centring_um",
     .setup_tolerance_phrase = "a length offset or centring tolerance",
     .setup_tolerance_none = "length offset or centring tolerance",
     .setup_included_more =
         "; the ball placement (L, D, H) is propagated at the identified errors by identify",
     .has_clock = true,
     .no_clock_reason = "",
     .directions_turn = true,
     .has_program = true,
     .evaluate_add_next = "add installations that see the undetermined errors (dbbkit optimize)",
     .identify_add_next = "add installations that see the undetermined errors",
     .measure_next = "measure it (dbbkit program, setup-sheet), then identify",
     .widen_next = "Next: widen what binds (the travel, the time budget, the blocks or bars).",
     .motion_on_all_points = "every ball of the design lies on that line, so no reading sees it",
     .motion_across_readings = "it moves the balls only across their reading directions",
     .design_caption = "Ball positions (red) and bars to the following ball (blue), labelled "
                       "with the installations that use them; dashed: the axis of rotation.",
     .polar_plot = "a ballbar plot",
     .polar_reading = "the bar read longer than the model, inwards where shorter",
     .equivalent_determined = "only their difference",
     .equivalent_convention = "the later installation",
     .first_order_term =
         "|D_perp|^2 / (2 bar), D_perp: the balls' relative displacement across the bar from the "
         "identified errors and the set-up at 3 standard uncertainties"},
    {.kind = InstrumentKind::kProbe,
     .name = "probe",
     .noun = "a touch probe",
     .item = "a sphere",
     .items = "spheres",
     .items_capitalised = "Spheres",
     .points = "spheres",
     .row_carrier = "channel",
     .row_column = "channel",
     .rows_per_item = 3,
     .item_read = "probed in x, y and z",
     .setup_effect_nouns = "trigger offset and sphere placement",
     .setup_effects_plural = "trigger offset and sphere placement",
     .setup_tolerance_keys = "trigger_offset_um, placement_um",
     .setup_tolerance_phrase = "a trigger offset or placement tolerance",
     .setup_tolerance_none = "trigger offset and sphere placement tolerance",
     .setup_included_more = "",
     .has_clock = false,
     .no_clock_reason = "a probe's file has no time column, so dbbkit tells no drift from it",
     .directions_turn = false,
     .has_program = false,
     .evaluate_add_next =
         "add a sphere that sees the undetermined errors (evaluate --sweep maps where)",
     .identify_add_next = "add a sphere that sees the undetermined errors",
     .measure_next = "probe the spheres at the design's angles, then identify",
     .widen_next = "Next: widen what binds (the travel or approach_mm, max_stem_tilt_deg, the "
                   "angle range, the time budget, the blocks).",
     .motion_on_all_points =
         "every sphere's centre of the design lies on that line, so no probing sees it",
     .motion_across_readings = "it moves the spheres' centres only along coordinates not probed",
     .design_caption = "Sphere centres (red) and the directions each is probed in (blue: machine "
                       "x, y and z), labelled with their channels; dashed: the axis of rotation.",
     .polar_plot = "a polar plot",
     .polar_reading = "the channel read more than the model along its machine axis, inwards where "
                      "less",
     .equivalent_determined = "only one combination of them",
     .equivalent_convention =
         "the later sphere or channel (within one sphere, to the component found first)",
     .first_order_term = "the probed coordinate of the sphere's centre turned by the exact "
                         "transform less the first-order row's, at the identified errors"},
}};

constexpr bool instruments_in_order() {
  for (std::size_t i = 0; i < kInstruments.size(); ++i)
    if (static_cast<std::size_t>(kInstruments[i].kind) != i) return false;
  return true;
}
static_assert(instruments_in_order(), "kInstruments is indexed by InstrumentKind");

}  // namespace

const InstrumentInfo& instrument_info(InstrumentKind kind) {
  return kInstruments[static_cast<std::size_t>(kind)];
}

std::optional<InstrumentKind> instrument_named(const std::string& name) {
  for (const InstrumentInfo& i : kInstruments)
    if (name == i.name) return i.kind;
  return std::nullopt;
}

std::string instrument_names() {
  std::string out;
  for (std::size_t i = 0; i < kInstruments.size(); ++i)
    out += std::string(i == 0                         ? ""
                       : i + 1 == kInstruments.size() ? " or "
                                                      : ", ") +
           kInstruments[i].name;
  return out;
}

std::size_t measured_count(const Design& design) {
  return design.installations.size() / instrument_info(design.instrument).rows_per_item;
}

std::string measured_phrase(const Design& design) {
  const InstrumentInfo& info = instrument_info(design.instrument);
  std::string out = std::to_string(measured_count(design)) + " " + info.items;
  if (info.rows_per_item > 1)
    out += std::string(" ") + info.item_read + " (" + std::to_string(design.installations.size()) +
           " " + info.row_carrier + "s)";
  return out;
}

void require_ballbar(const Design& design, const std::string& source, const std::string& what) {
  if (instrument_info(design.instrument).has_program) return;
  throw InputError(source, "instrument.kind",
                   what + " is a ball bar's; this design's instrument is " +
                       instrument_info(design.instrument).noun +
                       " (its "
                       "spheres are probed by the controller's own cycle, e.g. "
                       "KinematicsOpt's or CYCLE996's, at the design's angles)");
}

std::string probe_channel_id(const std::string& sphere_id, int coordinate) {
  return sphere_id + ":" + kProbeCoordinates[static_cast<std::size_t>(coordinate)];
}

std::vector<Installation> probe_channels(const AxisFrame& axis,
                                         const std::vector<Sphere>& spheres) {
  std::vector<Installation> out;
  out.reserve(3 * spheres.size());
  for (std::size_t s = 0; s < spheres.size(); ++s) {
    for (int k = 0; k < 3; ++k) {
      Installation c;
      c.id = probe_channel_id(spheres[s].id, k);
      c.L_mm = spheres[s].L_mm;
      c.D_mm = spheres[s].D_mm;
      c.H_mm = spheres[s].H_mm;
      c.direction = Direction::vector(Eigen::Vector3d::Unit(k));
      c.sign = axis.head() ? -1 : +1;
      c.sphere = static_cast<int>(s);
      c.coordinate = k;
      out.push_back(c);
    }
  }
  return out;
}

std::optional<std::string> setup_tolerance_problem(const SetupUncertainty& u, InstrumentKind kind) {
  if (kind == InstrumentKind::kProbe &&
      (u.placement() || u.length_offset_um != 0 || u.centring_um != 0))
    return std::string(
        "a probe's set-up tolerances are trigger_offset_um and placement_um (a ball bar's "
        "length offset, centring and ball placement have no meaning for it)");
  if (kind == InstrumentKind::kBallbar && (u.trigger_offset_um != 0 || u.placement_um != 0))
    return std::string(
        "trigger_offset_um and placement_um are a touch probe's set-up tolerances (instrument."
        "kind probe)");
  return std::nullopt;
}

std::optional<std::string> sphere_id_problem(const std::string& id) {
  // The sphere's own limit first: an id too long for its channels is told so at any length.
  if (id.size() + 2 > limits::kMaxIdBytes)
    return "a sphere's id is at most " + std::to_string(limits::kMaxIdBytes - 2) +
           " bytes (its channels' ids add \":x\"); this one has " + std::to_string(id.size());
  if (const auto p = id_problem(id)) return p;
  if (id == "all")
    return std::string(
        "\"all\" names the whole test in an effect's label ([all]): give the sphere "
        "another id");
  if (id.find(':') != std::string::npos)
    return std::string("a sphere's id holds no ':' (its channels' ids are id:x, id:y, id:z)");
  return std::nullopt;
}

int find_sphere(const Design& design, const std::string& id) {
  for (std::size_t s = 0; s < design.spheres.size(); ++s)
    if (design.spheres[s].id == id) return static_cast<int>(s);
  return -1;
}

double exact_probe_reading_um(const AxisFrame& axis, const Installation& c, double angle_deg,
                              const Vector6d& e6, const SetupError& setup) {
  const Eigen::Matrix3d R = axis_rotation(axis, angle_deg);
  const Eigen::Vector3d nominal = R * axis.body_point(c.L_mm, c.D_mm, c.H_mm);
  const Eigen::Vector3d placed =
      R * axis.body_point(c.L_mm + setup.ball_mm(0), c.D_mm + setup.ball_mm(1),
                          axis.has_H() ? c.H_mm + setup.ball_mm(2) : c.H_mm);
  const Eigen::Vector3d real = error_rotation(e6) * placed + 1e-3 * e6.head<3>();
  const int k = c.coordinate;
  return c.sign * 1e3 * (real(k) - nominal(k)) + setup.length_offset_um + setup.centring_um(k);
}

double exact_instrument_reading_um(const AxisFrame& axis, const Installation& inst,
                                   double angle_deg, const Vector6d& e6, double bar_mm,
                                   const SetupError& setup) {
  if (inst.probe_channel()) return exact_probe_reading_um(axis, inst, angle_deg, e6, setup);
  return exact_setup_reading_um(axis, inst, angle_deg, e6, bar_mm, setup);
}

}  // namespace dbbkit
