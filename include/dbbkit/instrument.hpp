#pragma once
// The instrument: what a reading is (docs/architecture.md, "The instrument seam").
//
// Every model, estimate and check of dbbkit reads an installation's readings through one row,
// J_reading_error (kinematics.hpp): reading = s u . dP, dP = d + 1e-3 e x P the displacement of
// the body's point P. Two instruments give such readings:
//   ball bar: u the bar's direction, turning with the body (u = R(g) u0); the reading is the
//             bar's length change, the other ball following on its nominal path;
//   probe:    a touch probe on a calibration sphere fixed to the turning body; each sphere is
//             read in three machine coordinates, each a channel (an Installation) whose u is the
//             machine's x, y or z, fixed in the machine frame. The probed centre minus the
//             nominal one: s = +1 on a table (the sphere moves with the table), s = -1 on a
//             head (the probe in the spindle moves with the head, the sphere on the table does
//             not, so the probed centre moves the other way).
// The rows of both are harmonic in (1, cos g, sin g); the closed forms of observability.hpp
// turn one body-frame information by R(g) and hold for directions that turn
// (Design::directions_turn); a probe's design takes the general path.
//
// What differs lives here: a probe's channels from its spheres, its exact reading for the
// simulator and the file form of its readings (io/measurement_io).

#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "dbbkit/design.hpp"
#include "dbbkit/kinematics.hpp"

namespace dbbkit {

// What an instrument is to everything that does not compute its rows: one entry per instrument
// (instrument_info), read by the writers, the checks and the commands instead of asking which
// instrument it is. Its words are those of the results (formats.md); a flag says what a design of
// it can have (a clock, a program, directions that turn). Adding an instrument is its enum value
// (design.hpp), its entry here, its rows (kinematics: J_reading_error's direction), its exact
// reading (exact_instrument_reading_um), its file (io) and its kit's fit (kit.cpp).
struct InstrumentInfo {
  InstrumentKind kind;
  const char* name;  // the design key instrument.kind: "ballbar", "probe"
  const char* noun;  // "a ball bar", "a touch probe"
  // What a design adds to see more, and their plurals: "an installation", "installations",
  // "Installations" (a ball bar's); "a sphere", "spheres", "Spheres" (a probe's).
  const char* item;
  const char* items;
  const char* items_capitalised;
  // The points the design places on the body: "balls", "spheres".
  const char* points;
  // A row's carrier as a place is named ("in installation 1r", "in channel s1:x").
  const char* row_carrier;
  // Its column's heading in a text table, eight characters at most ("inst", "channel").
  const char* row_column;
  // How many of them one item has (a ball bar's installation is one, a probe's sphere three
  // channels), and how the item is read when more than one ("probed in x, y and z").
  std::size_t rows_per_item;
  const char* item_read;
  // The set-up effects: their nouns ("length offset and centring"), their plural as a result's
  // note names what is not included ("length offsets and centrings"), the design keys of their
  // tolerances, a tolerance as a kit must declare one ("a length offset or centring tolerance")
  // and as a design declares none ("length offset or centring tolerance").
  const char* setup_effect_nouns;
  const char* setup_effects_plural;
  const char* setup_tolerance_keys;
  const char* setup_tolerance_phrase;
  const char* setup_tolerance_none;
  // What else evaluate's note says of the set-up when its tolerances are included (a ball bar:
  // that the ball placement is propagated by identify), or "".
  const char* setup_included_more;
  // Whether a design's readings have times (a drift or a warm-up can be told), and why not.
  bool has_clock;
  const char* no_clock_reason;
  // Whether every reading's direction turns with the axis (the closed forms of observability).
  bool directions_turn;
  // Whether dbbkit writes its part program and set-up sheet, and reads its traces.
  bool has_program;
  // The next steps the briefs name: a design that leaves errors undetermined (evaluate's, and
  // identify's), a design that is ready to measure, and a kit in which no design fits.
  const char* evaluate_add_next;
  const char* identify_add_next;
  const char* measure_next;
  const char* widen_next;
  // What a rigid motion that no reading sees is, for the design's points: on one line with all
  // of them, or moving them only where no reading looks.
  const char* motion_on_all_points;
  const char* motion_across_readings;
  // The report's caption of the design's drawing.
  const char* design_caption;
  // The residual around the turn (the reports' polar plot): what it is shown as ("a ballbar
  // plot") and which way a trace leaves the circle.
  const char* polar_plot;
  const char* polar_reading;
  // Two equivalent effects (each spans the other modulo the model): what the data determine of
  // them, and to which one diagnose attributes the effect by convention (the later installation;
  // of a probe, the later sphere or channel, and within one sphere the component found first).
  const char* equivalent_determined;
  const char* equivalent_convention;
  // The second-order term of a reading the first-order check bounds (identify's JSON).
  const char* first_order_term;
};
const InstrumentInfo& instrument_info(InstrumentKind kind);
// The instrument a design or kit names (instrument.kind), or none; and every name, as a reader's
// message lists them ("ballbar or probe").
std::optional<InstrumentKind> instrument_named(const std::string& name);
std::string instrument_names();

// What only a ball bar's design has (a program that drives the bar's arcs, a set-up sheet of
// bars and cups, readings from a bar's traces, a kit's reference): throws InputError(source,
// "instrument.kind", ...) for a probe's design, naming `what`.
void require_ballbar(const Design& design, const std::string& source, const std::string& what);

inline constexpr std::array<const char*, 3> kProbeCoordinates = {"x", "y", "z"};

// How many items a design measures (InstrumentInfo::item): a probe's spheres (each three
// channels, its installations), a ball bar's installations.
std::size_t measured_count(const Design& design);
// What a design measures, counted: "7 installations", "3 spheres probed in x, y and z (9
// channels)".
std::string measured_phrase(const Design& design);

// What is wrong with set-up tolerances for the instrument (a probe's are trigger_offset_um and
// placement_um, a ball bar's the others), or none.
std::optional<std::string> setup_tolerance_problem(const SetupUncertainty& u, InstrumentKind kind);

// The id of a probe channel: the sphere's id, ':' and its coordinate ("s1:x").
std::string probe_channel_id(const std::string& sphere_id, int coordinate);

// The three channels of every sphere, in the spheres' order (x, y, z each): the sphere's body
// coordinates, a direction fixed in the machine frame, s = +1 on a table and -1 on a head.
std::vector<Installation> probe_channels(const AxisFrame& axis, const std::vector<Sphere>& spheres);

// What is wrong with a sphere's id (a design's spheres[].id, a probe kit's pattern position id),
// or none: an id of user_text.hpp, no ':' (its channels' ids are id:x, id:y, id:z), not "all"
// (an effect's label for the whole test), short enough for a channel's id.
std::optional<std::string> sphere_id_problem(const std::string& id);

// The index of the sphere with this id, or -1.
int find_sphere(const Design& design, const std::string& id);

// The exact reading of a probe channel, no linearisation: the sphere as placed,
// B0 = body_point(L + dL, D + dD, H + dH), really at E(e6) R(g) B0 with E = Trans(d) Rx(ex)
// Ry(ey) Rz(ez); the nominal centre R(g) body_point(L, D, H); reading = s (real - nominal) .
// e_k [um] plus the trigger offset (SetupError::length_offset_um, the constant of the channel)
// and the centring's component along e_k (a constant too).
double exact_probe_reading_um(const AxisFrame& axis, const Installation& channel, double angle_deg,
                              const Vector6d& e6, const SetupError& setup);

// The exact reading of any installation: a ball bar's (exact_setup_reading_um, bar_mm its
// bar) or a probe channel's (bar_mm not read).
double exact_instrument_reading_um(const AxisFrame& axis, const Installation& inst,
                                   double angle_deg, const Vector6d& e6, double bar_mm,
                                   const SetupError& setup);

}  // namespace dbbkit
