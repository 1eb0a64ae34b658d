#pragma once
// Effects the six error motions do not describe (model.md §6), each a block of
// extra columns of J with a name, a unit and the installations it applies to. A reading changes
// by row . value. Every kind is one entry of the table in effects.cpp (EffectInfo): its name,
// unit, parameters, row, where it applies, its position (a step's time, a warm-up's time
// constant), its value's form in a truth file and diagnose's noun and next step. Adding an effect
// is an enum value here, an entry and its row there, and its line in the truth file's format
// (README, "Truth file").

#include <Eigen/Core>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "dbbkit/design.hpp"
#include "dbbkit/measurement.hpp"

namespace dbbkit {

// In the order diagnose offers them (candidate_effects, scan_families) and names a set-up's parts.
enum class EffectKind {
  kLengthOffset,
  kTriggerOffset,
  kPlacement,
  kCentring,
  kDrift,
  kReversal,
  kScale,
  kSquareness,
  kPeriodic,
  kStep,
  kThermal
};

struct EffectCandidate;

// What one reading's row of an effect is formed from; t0_s is the first time of the readings the
// effect spans (its installation's, or the whole test's for a whole-test effect).
struct EffectRowInput {
  const Design& design;
  const Reading& reading;
  const Installation& installation;
  double t0_s;
  const EffectCandidate& effect;
};
// Writes the effect's row for one reading (reading um per unit of each parameter) into `row`,
// zeroed, one entry per parameter.
using EffectRowFn = void (*)(const EffectRowInput& in, double* row);

// What places an effect beyond its kind and installation:
//   kNone: nothing; diagnose offers it as one block (candidate_effects);
//   kTime: a time on the test's clock (EffectCandidate::at_s; label "(t=<s>s)", truth "at_s"),
//     scanned over the installation's readings, split in two (scan_families);
//   kTimeConstant: a time constant (tau_min; label "(tau=<min>min)", truth "tau_min"), scanned
//     over a grid and refined (scan_families, selection);
//   kHarmonic: a harmonic and a phase (harmonic, phase_deg; truth "harmonic", "phase_deg"): a
//     simulated truth's alone, no label reads it back.
enum class EffectPosition { kNone, kTime, kTimeConstant, kHarmonic };

// How a truth file states the effect's value (README, "Truth file"):
//   kNumber: a number; kList: the parameters as a list, the last may be left out ([cx, cy] or
//   [cx, cy, cz]); kNamed: an object of the parameters by name, each 0 when left out; kObject:
//   an object of `truth_value_key` and the position's keys.
enum class TruthValue { kNumber, kList, kNamed, kObject };

// One effect, one place: what each kind is, read by its labels, its rows, the parameter names,
// the block's applicability, the scans of selection, the truth reader, the simulator's checks and
// diagnose's text.
struct EffectInfo {
  EffectKind kind = EffectKind::kLengthOffset;
  const char* name = "";  // in labels, truth files and reports
  const char* unit = "";  // of its values
  const char* noun = "";  // in diagnose's text: "a centring error of ..."
  // Its parameters' names (nullptr beyond the last): one column of J each.
  const char* parameters[3] = {};
  EffectRowFn row = nullptr;
  EffectPosition position = EffectPosition::kNone;
  TruthValue truth_value = TruthValue::kNumber;
  const char* truth_value_key = "";  // kObject: the value's key, e.g. "size_um"
  // Where it applies: shared by every installation (the machine's linear axes, no [..]); or per
  // installation, with a whole-test form [all] too, or the whole test's alone ([all] only).
  bool shared = false;
  bool whole_test_form = false;
  bool whole_test_only = false;
  // Offered one parameter at a time (part of it can be confounded while the rest is not), and
  // its parameters named in diagnose's text.
  bool by_component = false;
  // What its rows need: time_s (a step without times is placed by reading order instead), the
  // bar (the following ball's position), readings of both sweeps.
  bool needs_times = false;
  bool needs_bar = false;
  bool needs_both_sweeps = false;
  // Which instrument's readings it belongs to (instrument.hpp): a ball bar's alone (its set-up,
  // the linear axes moving its following ball, and what needs the times or sweeps a probe's file
  // does not have), a probe's alone, or either; per_sphere: one effect of a probe's sphere, on its
  // three channels (its label names the sphere).
  bool ballbar_only = false;
  bool probe_only = false;
  bool per_sphere = false;
  // A set-up effect of its instrument (setup.hpp): one a design may declare a tolerance of (the
  // member of SetupUncertainty that holds it) and evaluate judges the detection of.
  bool setup = false;
  double SetupUncertainty::*setup_std = nullptr;
  // Diagnose's next step when the effect is found, with {where} the installation(s) or sphere,
  // {settle_min} three time constants (min), {harmonic} the harmonic: for an installation's (or
  // sphere's) effect; for the whole test's or a shared one (nullptr: the first); on a head's axis
  // (nullptr: as on a table). redo_setup: the set-up is redone, then the test measured again.
  const char* next_step = "";
  const char* next_step_whole_test = nullptr;
  const char* next_step_on_head = nullptr;
  bool redo_setup = false;
};
// Every kind, in the enum's order.
std::vector<EffectKind> effect_kinds();
const EffectInfo& effect_info(EffectKind kind);

const char* effect_name(EffectKind kind);
// Throws InputError(source, key, ...) for an unknown name.
EffectKind effect_kind(const std::string& name, const std::string& source, const std::string& key);
bool effect_is_shared(EffectKind kind);
// Length offset, drift and reversal also exist once for the whole test (installation -1, label
// "[all]"); thermal exists only for the whole test.
bool effect_has_whole_test_form(EffectKind kind);
const char* effect_unit(EffectKind kind);
// Names of the full parameter vector of an effect (before unseen columns are dropped).
std::vector<std::string> effect_parameter_names(EffectKind kind);

// Whether the effect belongs to the design's instrument.
bool effect_fits_instrument(EffectKind kind, InstrumentKind instrument);

struct EffectCandidate {
  EffectKind kind = EffectKind::kLengthOffset;
  // -1: shared by all installations; a sphere's effect (EffectInfo::per_sphere): its first
  // channel.
  int installation = -1;
  int component = -1;    // one parameter of a multi-parameter effect (e.g. scale.x); -1: all
  int harmonic = 0;      // Periodic only
  double phase_deg = 0;  // Periodic only
  // Step: the readings of the installation from the time at_s on (the test's clock, as
  // time_s) are offset; a step found in data without times is placed by reading order.
  double at_s = std::numeric_limits<double>::quiet_NaN();
  double tau_min = 0;                             // Thermal only: the time constant
  std::string label(const Design& design) const;  // e.g. "centring[2r]", "squareness.xy"
};

// Whether an effect applies to the readings of installation `inst`: its own, its sphere's
// channels, or every installation's.
bool effect_applies_to(const Design& design, const EffectCandidate& effect, int inst);
// The installation an effect of `kind` names by `id` (a label's [id], a truth file's
// installation): the sphere's first channel for a sphere's effect; -1 when the design has none.
int effect_installation(const Design& design, EffectKind kind, const std::string& id);
// The id a label and a truth file name an effect's installation by (its sphere's for a sphere's
// effect); empty for a shared or whole-test effect.
std::string effect_installation_id(const Design& design, const EffectCandidate& effect);

// The effect a label names (EffectCandidate::label's form, as diagnose writes it):
// name[.component][[installation id | all]][(t=<s>s) | (tau=<min>min)]. Throws
// InputError(source, key) naming what is wrong; a periodic effect (whose label has no phase)
// is refused.
EffectCandidate effect_from_label(const Design& design, const std::string& label,
                                  const std::string& source, const std::string& key);
// The effects of a comma-separated list of labels (spaces around a label ignored); empty for
// an empty list. Throws InputError(source, the label) as effect_from_label.
std::vector<EffectCandidate> effects_from_list(const Design& design, const std::string& list,
                                               const std::string& source);

// Per reading, the full-length row of the effect; `t0_s` the first time of the readings the effect
// spans: the reading's installation, or the whole test for a whole-test drift (test_start_time).
Eigen::VectorXd J_reading_effect(const Design& design, const Reading& reading, double t0_s,
                                 const EffectCandidate& effect);
// The same, with the reading's installation index already known (loops over readings).
Eigen::VectorXd J_reading_effect(const Design& design, const Reading& reading, int installation,
                                 double t0_s, const EffectCandidate& effect);

// The set-up rows of the library without a Reading (the fast paths of observability.cpp):
// the length offset's row is 1 at every angle; the centring's is -s u(angle) (3 components).
// J_reading_effect answers with these.
inline constexpr double kLengthOffsetRow = 1.0;
Eigen::Vector3d centring_row(const AxisFrame& axis, const Installation& installation,
                             double angle_deg);

// First time_s of every installation (NaN when it has no time).
std::vector<double> installation_start_times(const Design& design,
                                             const std::vector<Reading>& readings);
// First time_s of the whole test (NaN when no reading has a time).
double test_start_time(const std::vector<Reading>& readings);
// The test's length [min], first timed reading to the last (0 without two times).
double test_minutes(const std::vector<Reading>& readings);
// What an effect of `value` (its parameters, one per column of J_reading_effect) alone moves the
// bar by in these readings [um]: its largest part of a reading (a drift over the span its column
// covers: its installation, or the whole test). Beyond the instrument's range, the readings
// could not hold it.
double effect_reach_um(const Eigen::MatrixXd& J_reading_effect, const Eigen::VectorXd& value);
// The fastest rate of a drift or a warm-up of `value` [um/min]: a drift's largest |value|, a
// warm-up's |plateau| / tau (its slope at the start; tau its time constant plus the correction
// of a linearised block's second column; infinite when tau is not above 0); nothing for any
// other kind.
std::optional<double> drift_rate_um_per_min(const EffectCandidate& effect,
                                            const Eigen::VectorXd& value);

// Why an effect cannot be formed from a set of readings (io::not_applicable_text says it):
// a drift or warm-up without time_s on a reading it applies to (kNeedsTimes), a reversal
// without both sweeps, scale or squareness without a bar, an effect no reading sees, a
// warm-up without a time on every reading (kNeedsEveryTime) or with one time only, a step
// with fewer than min_readings readings of its installation.
enum class NotApplicable {
  kNone,
  kNeedsTimes,
  kNeedsBothSweeps,
  kNeedsBar,
  kChangesNoReading,
  kNeedsEveryTime,
  kNeedsSeveralTimes,
  kTooFewReadings,
  kNeedsCommonClock,  // an effect over the whole test: the installations' times overlap
};
struct Applicability {
  NotApplicable why = NotApplicable::kNone;
  int min_readings = 0;  // kTooFewReadings
  bool applicable() const { return why == NotApplicable::kNone; }
};

// Why an effect cannot be formed from the readings: "needs readings of both sweeps (cw and
// ccw)", ...; empty when it can.
std::string not_applicable_text(const Applicability& a);

struct EffectBlock {
  EffectCandidate effect;
  std::string label;
  std::string unit;
  std::vector<std::string> parameters;  // the columns kept
  Eigen::MatrixXd J_reading_effect;     // n_readings x parameters [reading um per unit]
  Applicability applicability;          // whether the effect can be formed from these readings
};

// Where each reading belongs and when each installation and the test begin, found once for
// the many effect blocks of one set of readings (one pass over the readings, so building a
// block per installation stays linear in the readings per block).
struct ReadingLayout {
  ReadingLayout(const Design& design, const std::vector<Reading>& readings);
  std::vector<int> installation;  // per reading, its installation's index
  std::vector<double> start_s;    // per installation, installation_start_times
  double test_start_s;            // test_start_time
  // The readings' times lie on one clock: no two runs of consecutive readings of one
  // installation overlap in time_s (a ball bar measures one installation at a time; an
  // installation measured again later is a run of its own). False when each trace's clock
  // restarted.
  bool common_clock = true;
};

// Whether the readings' times can be those of one clock (ReadingLayout::common_clock).
bool readings_on_one_clock(const Design& design, const std::vector<Reading>& readings);

// The columns of an effect over the readings; all-zero columns are dropped.
EffectBlock effect_block(const Design& design, const std::vector<Reading>& readings,
                         const EffectCandidate& effect);
EffectBlock effect_block(const Design& design, const std::vector<Reading>& readings,
                         const ReadingLayout& layout, const EffectCandidate& effect);

// Every effect of the library that the readings could show (applicable or not, with the reason).
std::vector<EffectBlock> candidate_effects(const Design& design,
                                           const std::vector<Reading>& readings);

// An effect with a free position, one column per alternative (selection.hpp scans them):
//   step[i]: a step between two consecutive readings of installation i, in time order
//     (file order when a reading of i has no time), at least kStepMinSegment readings from
//     either end;
//   thermal[all]: the warm-up 1 - exp(-(t - t0) / tau) for tau on a geometric grid of
//     kThermalTaus values from T / 20 to 2 T, T the test's duration.
inline constexpr int kStepMinSegment = 3;
inline constexpr int kThermalTaus = 12;
struct ScanFamily {
  EffectCandidate effect;  // the kind and installation; the position is the alternative's
  std::string label;       // e.g. "step[2r]", "thermal[all]"
  std::vector<int> rows;   // step: the installation's readings in order
  bool timed = false;      // step: ordered by time_s
  int min_segment = kStepMinSegment;
  std::vector<EffectBlock> alternatives;  // thermal: one block per tau
  Applicability applicability;
  // The block of alternative k (step: the first reading after the step is rows[k]).
  EffectBlock alternative(const Design& design, const std::vector<Reading>& readings, int k) const;
};
std::vector<ScanFamily> scan_families(const Design& design, const std::vector<Reading>& readings);

}  // namespace dbbkit
