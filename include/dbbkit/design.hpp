#pragma once
// A measurement design: which rotary axis, at which angles, with which DBB
// installations (ball position and reading direction), and with which noise
// and error parameterisation. Format `dbbkit.design/1` (formats.md).

#include <Eigen/Core>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "dbbkit/axis_frame.hpp"
#include "dbbkit/machine.hpp"

namespace dbbkit {

// The rotary axis under test (axis_frame.hpp): C, a turntable about Z, ball at table
// coordinates (L, D, H); B, a swinging head about Y, ball at (L sin b, D, L cos b) (model.md
// §3-4); any other axis in the general form.
using Axis = AxisFrame;

// Reading direction in the rotating (body) frame. The body frame coincides
// with the machine frame at angle 0, so `body` is the machine-frame direction
// at angle 0: radial = the axis' reference, tangential = direction x reference, axial = its
// direction (C: X, Y, Z; B: Z (tool axis), X, Y (swing axis)).
struct Direction {
  enum class Kind { kRadial, kTangential, kAxial, kVector };
  Kind kind = Kind::kRadial;
  Eigen::Vector3d body = Eigen::Vector3d::UnitX();  // unit vector

  static Direction named(const AxisFrame& axis, Kind kind);
  static Direction vector(const Eigen::Vector3d& unit_body);
  std::string label() const;  // "radial", ..., or "[x, y, z]"
};

// Declared standard uncertainties of the set-up of one installation,
// independent between installations and between components; 0 = exact:
//   length_offset_um  the bar's absolute length as installed (a constant on every
//                     reading of the installation),
//   centring_um       each component (x, y, z, machine frame) of the offset of the
//                     following ball's path centre from the axis,
//   L_mm, D_mm, H_mm  the ball as placed;
// a touch probe's (instrument.hpp):
//   trigger_offset_um the probe's offset along each machine axis (a constant on every reading
//                     of a channel),
//   placement_um      each body coordinate (L, D, H) of the sphere's centre off its stated one
//                     (a first-order term: the sphere's centre turns with the table).
// The length offset, the centring, the trigger offset and the sphere's placement are nuisance
// effects of the linear model (columns of the effect library with a zero-mean prior,
// setup.hpp); the ball placement changes a row of J only in proportion to the errors and is
// propagated at the identified errors (uncertainty.hpp).
struct SetupUncertainty {
  double length_offset_um = 0, centring_um = 0;
  double L_mm = 0, D_mm = 0, H_mm = 0;
  double trigger_offset_um = 0, placement_um = 0;
  bool placement() const { return L_mm > 0 || D_mm > 0 || H_mm > 0; }
  bool nuisance() const {
    return length_offset_um > 0 || centring_um > 0 || trigger_offset_um > 0 || placement_um > 0;
  }
  bool any() const { return placement() || nuisance(); }
};

// Per installation: the keys given replace the design's default.
struct SetupOverride {
  std::optional<double> length_offset_um, centring_um, L_mm, D_mm, H_mm;
  std::optional<double> trigger_offset_um, placement_um;
  bool any() const {
    return length_offset_um || centring_um || L_mm || D_mm || H_mm || trigger_offset_um ||
           placement_um;
  }
  SetupUncertainty over(const SetupUncertainty& base) const;
};

struct Installation {
  std::string id;
  // Body coordinates (axis_frame.hpp): L along the reference (C: radial distance from the
  // axis; B: distance along the tool axis), D (C: along body Y; B: along the swing axis Y),
  // H along the axis (C: height above the table surface; unused for B).
  double L_mm = 0.0;
  double D_mm = 0.0;
  double H_mm = 0.0;
  Direction direction;
  int sign = +1;  // s of model.md §2: F = P - s bar u (geometry)
  // How the instrument counted (formats.md, sign): +1, a positive reading is a longer bar (as a
  // QC20-W counts); -1, the data were recorded with the opposite count. The model reads
  // reading_sign * reading as the bar's length change; sign stays geometry.
  int reading_sign = +1;
  std::optional<double> bar_mm;  // bar length, when declared
  std::string description;       // free text for the person setting it up
  SetupOverride setup_std;       // this installation's set-up tolerances, over the design's default
  // The hardware as assembled, when known (optimize writes it from the kit; the set-up sheet
  // shows it). bar_parts_mm: the base bar first, then the extensions screwed on; their sum
  // is bar_mm. C: cup_mm, the height of the ball's centre in its cup on the table, and
  // blocks_mm, the cushion blocks under the cup; cup_mm + the blocks = H.
  std::vector<double> bar_parts_mm;
  std::optional<double> cup_mm;
  std::vector<double> blocks_mm;
  // The angles this installation is read at, when not every angle of the design (design key
  // installations[i].angles_deg): a subset of the design's angles, e.g. one side of a trunnion's
  // travel with the bar on that side. Empty: every angle of the design.
  std::vector<double> angles_deg;
  // A touch probe's channel (instrument.hpp): the sphere (Design::spheres) and the machine
  // coordinate (0, 1, 2: x, y, z) it reads, its direction fixed in the machine frame; -1 for a
  // ball bar's installation, whose direction turns with the body.
  int sphere = -1;
  int coordinate = -1;
  bool probe_channel() const { return coordinate >= 0; }
};

// What a design's readings are (instrument.hpp): a ball bar's length changes, or a touch
// probe's sphere centres in three machine coordinates.
enum class InstrumentKind { kBallbar, kProbe };

// A calibration sphere fixed to the body that turns (a table axis: on the table; a head: the
// point of the head the probe in the spindle meets the sphere at), at body coordinates (L, D,
// H) as a ball bar's ball.
struct Sphere {
  std::string id;
  double L_mm = 0.0, D_mm = 0.0, H_mm = 0.0;
  std::string description;
};

// Instrument noise of one reading. Uniform: +-half_width (the instrument's
// stated accuracy), sigma = a / sqrt(3) (JCGM 100 rectangular). Normal: sigma given.
struct NoiseModel {
  enum class Distribution { kUniform, kNormal };
  Distribution distribution = Distribution::kUniform;
  double half_width_um = 1.25;  // Uniform only
  double std_um = 0.0;          // Normal only

  double sigma_um() const;
  std::string describe() const;
};

// How the six errors depend on the angle (model.md §5).
struct ErrorModel {
  enum class Kind { kPerAngle, kFourier, kLegendre };
  Kind kind = Kind::kPerAngle;
  int order = 0;  // series order K (Fourier: harmonics 0..K; Legendre: degree 0..K)

  std::string describe() const;
};

// What `optimize` predicted for a design it wrote (informative; `evaluate` recomputes it).
struct Prediction {
  std::string criterion;
  std::optional<double> worst_std_um, worst_determined_std_um;
  // With declared set-up tolerances: the worst of noise and set-up (the criterion
  // worst_total_std_um ranks by it).
  std::optional<double> worst_total_std_um;
  int rank = 0, n_unknowns = 0;
  std::optional<double> time_s;
};

inline constexpr double kDefaultInstrumentRange_mm = 1.0;
// The least instrument range a design may declare (instrument.range_mm): 1 um.
inline constexpr double kMinInstrumentRange_mm = 1e-3;
// The fastest drift a finding may have [um/min] unless the design states its own
// (instrument.max_drift_um_per_min): 0.6 mm an hour, several times the thermal growth of a
// machine warming up or of a steel bar in a shop, so that no true drift is refused; a fitted
// drift faster than this stands for something else the model lacks. At most
// kMaxMaxDrift_um_per_min.
inline constexpr double kDefaultMaxDrift_um_per_min = 10.0;
inline constexpr double kMinMaxDrift_um_per_min = 1e-3;
inline constexpr double kMaxMaxDrift_um_per_min = 1e4;
// The shortest bar (bar_mm): two balls of about 13 mm and their cups cannot come closer.
inline constexpr double kMinBar_mm = 25.0;

// The parts of a bar add up to bar_mm, and a cup and its blocks to H, when
// |sum - value| <= kAssemblyTolerance_mm (lengths written with 6 decimals).
inline constexpr double kAssemblyTolerance_mm = 1e-6;

// The machine a design names (formats.md, "Machine file") and its axis under test: the design's
// frame is that axis' nominal line with every other axis at its park angle, its origin the
// axis' nominal point there (the preset a program teaches).
struct DesignMachine {
  std::string file;                        // as the design names it
  std::shared_ptr<const Machine> machine;  // as read
  int axis = 0;                            // the index of the axis under test
  std::map<char, double> park_overrides;   // the design's "park_deg": letter -> angle
  // Every rotary axis' angle while this axis is measured (its own: its park angle).
  std::vector<double> park_angles() const { return machine->park_angles(park_overrides); }
  // The axis' nominal point in the machine frame at the park angles: the frame's origin.
  Eigen::Vector3d origin_mm() const { return machine->point_at(axis, park_angles()); }
  // Every rotary axis' angle (machine order) with the axis under test at `tested_deg`, the
  // others parked.
  std::vector<double> angles_at(double tested_deg) const;
  char letter() const { return machine->rotary[axis].letter; }
  // Every rotary axis' letter and angle in the machine's order, the axis under test at
  // `tested_deg` and the others parked; others(): the others alone.
  struct AxisAngle {
    char letter = 'C';
    double angle_deg = 0;
  };
  std::vector<AxisAngle> angles_with(double tested_deg) const;
  std::vector<AxisAngle> others() const;
};

struct Design {
  std::string name;
  std::string description;
  std::map<std::string, std::string>
      assumed;     // declared assumptions, e.g. "L1": "100 mm, not given by the paper"
  AxisFrame axis;  // default: the C turntable
  std::optional<DesignMachine> machine;  // when the design names one (axis then from it)
  std::vector<double> angles_deg;
  NoiseModel noise;
  ErrorModel errors;
  std::optional<double> reference_length_mm;
  // The instrument's measuring range: a reading beyond +-range_mm is refused (a ballbar of
  // the QC20-W class reads within about +-1 mm; larger values are almost always a unit
  // mix-up, um in a mm column). Design key instrument.range_mm, at most 10 mm.
  double instrument_range_mm = kDefaultInstrumentRange_mm;
  // The fastest drift of the bar or the machine the readings may be said to show [um/min]
  // (design key instrument.max_drift_um_per_min): a drift or a warm-up whose rate exceeds it
  // is no finding (selection.hpp, kBeyondDriftRate), and a design whose least detectable drift
  // exceeds it cannot see a drift.
  double max_drift_um_per_min = kDefaultMaxDrift_um_per_min;
  // Each sweep of each installation ends by reading its first angle again (design key
  // return_reading): the axis turns back along the sweep's arc, approaching that angle from the
  // other side (the reading's sweep is the opposite one), so that the two readings of one
  // position, minutes apart, show a drift of the bar or the machine (sweep_readings).
  bool return_reading = false;
  SetupUncertainty setup_std;  // default for every installation
  // The instrument (design key instrument.kind). A probe design states its spheres; its
  // installations are their channels, three a sphere (instrument.hpp, probe_channels), which
  // every model, estimate and check reads as it reads a ball bar's installations.
  InstrumentKind instrument = InstrumentKind::kBallbar;
  std::vector<Sphere> spheres;
  std::vector<Installation> installations;
  std::optional<Prediction> predicted;

  // The angles installation i is read at: its own, or every angle of the design.
  const std::vector<double>& angles_of(int i) const {
    const std::vector<double>& own = installations[static_cast<std::size_t>(i)].angles_deg;
    return own.empty() ? angles_deg : own;
  }
  // Whether some installation is read at part of the design's angles only (the closed forms of
  // observability.hpp take every installation at every angle).
  bool partial_sweeps() const;
  // Whether every reading's direction turns with the axis (a ball bar): the closed forms of
  // observability.hpp turn one body-frame information by the axis' rotation.
  bool directions_turn() const;  // instrument_info(instrument).directions_turn
  // The readings one sweep of installation i takes: its angles, and the return reading.
  int readings_per_sweep(int i) const {
    const std::size_t n = angles_of(i).size();
    return static_cast<int>(n) + (return_reading && n > 1 ? 1 : 0);
  }
  // The readings one sweep of every installation takes, together.
  int readings_per_round() const;
  // The set-up tolerances of installation i (its override over the default).
  SetupUncertainty setup_of(int i) const;
  // Whether any installation declares a length offset or centring tolerance
  // (the set-up enters the model as nuisance effects).
  bool setup_nuisance_declared() const;

  // Index of the installation with this id, or -1.
  int find_installation(const std::string& id) const;
  // The index of each id in one pass (hash map): for loops over many readings,
  // where find_installation per reading would be quadratic in the installations.
  std::unordered_map<std::string, int> installation_index() const;
};

// The noise is positive and finite; a series suits the axis' travel (Fourier: a full turn,
// Legendre: an arc).
void validate_noise_and_model(const NoiseModel& noise, const ErrorModel& errors,
                              const AxisFrame& axis, const std::string& source);

// Set-up tolerances within the documented limits; throws InputError(source, key.<name>).
void validate_setup_uncertainty(const SetupUncertainty& u, const AxisFrame& axis,
                                const std::string& source, const std::string& key);

// A finite length within +-limits::kMaxLength_mm.
bool length_within_limits(double x_mm);

// The largest sign (u . reference) a head installation may have: a bar across the tool written
// with 12 digits.
inline constexpr double kBeyondTool = 1e-9;

// On a head the table ball lies beyond the spindle ball along the tool (the table is there):
// (F - P) . tool >= 0 at every angle, F - P = -sign bar u, so sign (u . reference) <= 0.
// A bar across the tool (tangential, axial) may take either sign.
bool table_ball_beyond_tool(const AxisFrame& axis, const Direction& direction, int sign);

// The table ball stands in a cup on a stand: the bar may point at most this far below the plane
// through its centre across the table's normal, the cup's rim and the stand lying beyond [deg].
// A ballbar's arcs in a vertical plane stop there (220 deg arcs, 20 deg below either side).
inline constexpr double kMaxBarBelowCup_deg = 20.0;

// How far the spindle ball lies below the deepest place kMaxBarBelowCup_deg allows it, along the
// table's normal [mm]: `rise_mm` is the spindle ball's centre's height above the table ball's
// along the normal, `bar_mm` their distance. Positive: the spindle ball or the bar would be
// driven into the table ball's cup or stand.
double below_cup_mm(double rise_mm, double bar_mm);

// A head's spindle direction (from the pivot towards the tool) with the axis under test at 0, in
// the design's frame: from the machine (the innermost head axis' reference turned by the head
// axes at the design's angles) or, without one, the frame's reference, except on a head turning
// about Z, whose reference crosses a spindle the design does not state (nothing then). Nothing
// for a table.
std::optional<Eigen::Vector3d> head_tool_direction(const AxisFrame& axis,
                                                   const std::optional<DesignMachine>& machine);

// Which way the table faces (up from the table ball's cup) with the axis under test at
// `angle_deg`, in the design's frame; nothing where the design does not say (a table in the
// general form not about Z, without a machine). A machine's table faces +Z with every axis at
// zero and turns with the innermost table axis' chain (a head does not turn it); without one, a
// C table faces +Z (the machine's Z, up) and a head's table faces against its spindle, or +Z
// under a head turning about Z.
std::optional<Eigen::Vector3d> table_up(const AxisFrame& axis,
                                        const std::optional<DesignMachine>& machine,
                                        double angle_deg);

// Checks a design built in code or read from a file; throws InputError with
// `source` and the key of the first problem.
void validate_design(const Design& design, const std::string& source = "design");

// Tolerance on angles: two angles closer than this are the same position.
// |a - b| < kAngleTolerance_deg  (a full turn: compared modulo 360).
inline constexpr double kAngleTolerance_deg = 1e-6;

// The index in `sorted` (ascending) of an angle within kAngleTolerance_deg of a, or -1 (a binary
// search: one place for matching an angle to a list of them).
long angle_index(const std::vector<double>& sorted, double a);

}  // namespace dbbkit
