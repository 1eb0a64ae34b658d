#include "dbbkit/effects.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <iterator>
#include <limits>
#include <locale>
#include <optional>
#include <sstream>

#include "dbbkit/error.hpp"
#include "dbbkit/instrument.hpp"
#include "dbbkit/kinematics.hpp"
#include "dbbkit/user_text.hpp"
#include "number_text.hpp"
#include "tolerances.hpp"

namespace dbbkit {

namespace {

// Each kind's row of one reading (EffectRowFn), F = P - s bar u the following ball (mm).

// length_offset (per installation or [all], um): 1.
void row_length_offset(const EffectRowInput&, double* row) { row[0] = kLengthOffsetRow; }

// centring (per installation, um): -s u . c, c the constant offset of the following ball's path
// (machine frame).
void row_centring(const EffectRowInput& in, double* row) {
  Eigen::Map<Eigen::Vector3d> out(row);
  out = centring_row(in.design.axis, in.installation, in.reading.angle_deg);
}

// drift (per installation or [all], um/min): (t - t0) / 60, t0 the first reading's time of the
// installation, or of the whole test (one clock through the test).
void row_drift(const EffectRowInput& in, double* row) {
  if (in.reading.time_s && std::isfinite(in.t0_s)) row[0] = (*in.reading.time_s - in.t0_s) / 60.0;
}

// reversal (per installation or [all], um): +1/2 on cw sweeps, -1/2 on ccw: value = cw - ccw.
void row_reversal(const EffectRowInput& in, double* row) {
  if (in.reading.sweep) row[0] = *in.reading.sweep == Sweep::kCW ? 0.5 : -0.5;
}

// The following ball F (mm) and the reading per um of its motion per mm of F, or nothing
// without a bar.
bool following_ball(const EffectRowInput& in, Eigen::Vector3d& F, Eigen::Vector3d& w) {
  const Installation& inst = in.installation;
  if (!inst.bar_mm) return false;
  const AxisFrame& axis = in.design.axis;
  const Eigen::Vector3d u = direction_machine(axis, inst, in.reading.angle_deg);
  F = ball_position_mm(axis, inst, in.reading.angle_deg) - inst.sign * *inst.bar_mm * u;
  w = -inst.sign * 1e-3 * u;
  return true;
}

// scale (shared, um/m): -s u . dF, dF_k = 1e-3 k_k F_k.
void row_scale(const EffectRowInput& in, double* row) {
  Eigen::Vector3d F, w;
  if (!following_ball(in, F, w)) return;
  Eigen::Map<Eigen::Vector3d> out(row);
  out = w.cwiseProduct(F);
}

// squareness (shared, urad): -s u . dF, dF = 1e-3 (S_xy F_y, S_yz F_z, S_zx F_x).
void row_squareness(const EffectRowInput& in, double* row) {
  Eigen::Vector3d F, w;
  if (!following_ball(in, F, w)) return;
  row[0] = w.x() * F.y(), row[1] = w.y() * F.z(), row[2] = w.z() * F.x();
}

// periodic (per installation, um): cos(k a - phase) times the amplitude; a simulated truth's,
// for tests of what the tool does with an effect it does not know.
void row_periodic(const EffectRowInput& in, double* row) {
  double s, c;
  sincos_deg(in.effect.harmonic * in.reading.angle_deg - in.effect.phase_deg, s, c);
  row[0] = c;
}

// step (per installation, um): 1 from the reading at which the installation's readings jump on
// (a knock, a slipped magnet); its time is scanned (selection.hpp).
void row_step(const EffectRowInput& in, double* row) {
  if (in.reading.time_s && *in.reading.time_s >= in.effect.at_s) row[0] = 1.0;
}

// thermal ([all], um): 1 - exp(-(t - t0) / tau), t0 the test's first reading: a warm-up
// approaching a plateau of the value; tau is scanned (selection.hpp).
void row_thermal(const EffectRowInput& in, double* row) {
  if (in.reading.time_s && std::isfinite(in.t0_s) && in.effect.tau_min > 0)
    row[0] = -std::expm1(-(*in.reading.time_s - in.t0_s) / (60.0 * in.effect.tau_min));
}

// trigger_offset (per probe channel, um): 1, the probe's offset along the channel's axis.
void row_trigger_offset(const EffectRowInput&, double* row) { row[0] = 1.0; }

// placement (per sphere, um): s e_k . R(g) (dL e_L + dD e_D + dH e_H), the sphere's centre off
// its stated body coordinates.
void row_placement(const EffectRowInput& in, double* row) {
  if (!in.installation.probe_channel()) return;
  const AxisFrame& a = in.design.axis;
  const Eigen::Matrix3d R = axis_rotation(a, in.reading.angle_deg);
  const Eigen::Vector3d per_um[3] = {a.body_point(1e-3, 0, 0), a.body_point(0, 1e-3, 0),
                                     a.body_point(0, 0, a.has_H() ? 1e-3 : 0.0)};
  for (int j = 0; j < 3; ++j)
    row[j] = in.installation.sign * 1e3 * (R * per_um[j])(in.installation.coordinate);
}

// Scale and squareness: the linear axes' errors, one step for both.
constexpr const char* kLinearAxesNextStep =
    "check the linear axes' scale and squareness before compensating the rotary axis";

// The kinds, in EffectKind's order.
constexpr EffectInfo kEffects[] = {
    {.kind = EffectKind::kLengthOffset,
     .name = "length_offset",
     .unit = "um",
     .noun = "a length offset",
     .parameters = {"value"},
     .row = row_length_offset,
     .whole_test_form = true,
     .ballbar_only = true,
     .setup = true,
     .setup_std = &SetupUncertainty::length_offset_um,
     .next_step = "re-zero the bar in its calibrator and re-seat the balls of installation {where}",
     .next_step_whole_test = "check the bar's calibrated length",
     .redo_setup = true},
    {.kind = EffectKind::kTriggerOffset,
     .name = "trigger_offset",
     .unit = "um",
     .noun = "a probe trigger offset",
     .parameters = {"value"},
     .row = row_trigger_offset,
     .probe_only = true,
     .setup = true,
     .setup_std = &SetupUncertainty::trigger_offset_um,
     .next_step = "calibrate the probe (its trigger offsets, on the calibration sphere or ring)",
     .redo_setup = true},
    {.kind = EffectKind::kPlacement,
     .name = "placement",
     .unit = "um",
     .noun = "a sphere placement error",
     .parameters = {"dL", "dD", "dH"},
     .row = row_placement,
     .truth_value = TruthValue::kNamed,
     .by_component = true,
     .probe_only = true,
     .per_sphere = true,
     .setup = true,
     .setup_std = &SetupUncertainty::placement_um,
     .next_step = "state where sphere {where} really is (ball_mm; it is off the stated centre), or "
                  "declare its placement tolerance (setup_std.placement_um)",
     .next_step_on_head = "check the probe's length and radius in the tool table (the point it "
                          "meets the sphere at is off the stated one)"},
    {.kind = EffectKind::kCentring,
     .name = "centring",
     .unit = "um",
     .noun = "a centring error",
     .parameters = {"cx", "cy", "cz"},
     .row = row_centring,
     .truth_value = TruthValue::kList,
     .ballbar_only = true,
     .setup = true,
     .setup_std = &SetupUncertainty::centring_um,
     .next_step = "re-centre the cup of installation {where}",
     .redo_setup = true},
    {.kind = EffectKind::kDrift,
     .name = "drift",
     .unit = "um/min",
     .noun = "a drift",
     .parameters = {"value"},
     .row = row_drift,
     .whole_test_form = true,
     .needs_times = true,
     .ballbar_only = true,
     .next_step = "warm the machine up until the readings stop drifting, and measure again"},
    {.kind = EffectKind::kReversal,
     .name = "reversal",
     .unit = "um",
     .noun = "a cw-ccw difference",
     .parameters = {"value"},
     .row = row_reversal,
     .whole_test_form = true,
     .needs_both_sweeps = true,
     .ballbar_only = true,
     .next_step = "check the axis' backlash (the cw-ccw difference in {where})",
     .next_step_whole_test = "check the axis' backlash (the cw-ccw difference)"},
    {.kind = EffectKind::kScale,
     .name = "scale",
     .unit = "um/m",
     .noun = "a linear-axis scale error",
     .parameters = {"x", "y", "z"},
     .row = row_scale,
     .truth_value = TruthValue::kNamed,
     .shared = true,
     .by_component = true,
     .needs_bar = true,
     .ballbar_only = true,
     .next_step = kLinearAxesNextStep},
    {.kind = EffectKind::kSquareness,
     .name = "squareness",
     .unit = "urad",
     .noun = "a linear-axis squareness error",
     .parameters = {"xy", "yz", "zx"},
     .row = row_squareness,
     .truth_value = TruthValue::kNamed,
     .shared = true,
     .by_component = true,
     .needs_bar = true,
     .ballbar_only = true,
     .next_step = kLinearAxesNextStep},
    {.kind = EffectKind::kPeriodic,
     .name = "periodic",
     .unit = "um",
     .noun = "a periodic error",
     .parameters = {"value"},
     .row = row_periodic,
     .position = EffectPosition::kHarmonic,
     .truth_value = TruthValue::kObject,
     .truth_value_key = "amplitude_um",
     .next_step = "check the axis drive for a {harmonic}-per-turn error"},
    {.kind = EffectKind::kStep,
     .name = "step",
     .unit = "um",
     .noun = "a step",
     .parameters = {"value"},
     .row = row_step,
     .position = EffectPosition::kTime,
     .truth_value = TruthValue::kObject,
     .truth_value_key = "size_um",
     .needs_times = true,
     .next_step = "look for a knocked or loose ball in installation {where}"},
    {.kind = EffectKind::kThermal,
     .name = "thermal",
     .unit = "um",
     .noun = "a warm-up",
     .parameters = {"value"},
     .row = row_thermal,
     .position = EffectPosition::kTimeConstant,
     .truth_value = TruthValue::kObject,
     .truth_value_key = "plateau_um",
     .whole_test_form = true,
     .whole_test_only = true,
     .needs_times = true,
     .ballbar_only = true,
     .next_step = "warm the machine up (three time constants: about {settle_min} min) and measure "
                  "again"},
};

// Each entry at its kind's place: effect_info indexes the table.
constexpr bool in_kind_order() {
  for (std::size_t i = 0; i < std::size(kEffects); ++i)
    if (static_cast<std::size_t>(kEffects[i].kind) != i) return false;
  return std::size(kEffects) == static_cast<std::size_t>(EffectKind::kThermal) + 1;
}
static_assert(in_kind_order(), "kEffects holds every EffectKind once, in the enum's order");
}  // namespace

const EffectInfo& effect_info(EffectKind kind) { return kEffects[static_cast<std::size_t>(kind)]; }

std::vector<EffectKind> effect_kinds() {
  std::vector<EffectKind> out;
  for (const EffectInfo& i : kEffects) out.push_back(i.kind);
  return out;
}

const char* effect_name(EffectKind kind) { return effect_info(kind).name; }
const char* effect_unit(EffectKind kind) { return effect_info(kind).unit; }
bool effect_is_shared(EffectKind kind) { return effect_info(kind).shared; }
bool effect_has_whole_test_form(EffectKind kind) { return effect_info(kind).whole_test_form; }

EffectKind effect_kind(const std::string& name, const std::string& source, const std::string& key) {
  std::string names;
  for (const EffectInfo& i : kEffects) {
    if (name == i.name) return i.kind;
    names += std::string(names.empty()                  ? ""
                         : &i == std::end(kEffects) - 1 ? " or "
                                                        : ", ") +
             i.name;
  }
  throw InputError(source, key,
                   "unknown effect " + quote_value(name) + " (expected " + names + ")");
}

bool effect_fits_instrument(EffectKind kind, InstrumentKind instrument) {
  const EffectInfo& i = effect_info(kind);
  return instrument == InstrumentKind::kProbe ? !i.ballbar_only : !i.probe_only;
}

bool effect_applies_to(const Design& design, const EffectCandidate& e, int inst) {
  if (e.installation < 0 || e.installation == inst) return true;
  if (!effect_info(e.kind).per_sphere) return false;
  const int s = design.installations[static_cast<std::size_t>(e.installation)].sphere;
  return s >= 0 && design.installations[static_cast<std::size_t>(inst)].sphere == s;
}

int effect_installation(const Design& design, EffectKind kind, const std::string& id) {
  if (!effect_info(kind).per_sphere) return design.find_installation(id);
  const int s = find_sphere(design, id);
  for (std::size_t i = 0; s >= 0 && i < design.installations.size(); ++i)
    if (design.installations[i].sphere == s) return static_cast<int>(i);
  return -1;
}

std::string effect_installation_id(const Design& design, const EffectCandidate& e) {
  if (e.installation < 0) return "";
  const Installation& in = design.installations[static_cast<std::size_t>(e.installation)];
  if (effect_info(e.kind).per_sphere && in.sphere >= 0)
    return design.spheres[static_cast<std::size_t>(in.sphere)].id;
  return in.id;
}

namespace {
// A position in a label: up to 6 significant digits.
std::string short_number(double x) { return text::significant(x, 6); }

// Parameters of an effect: three components for the vector effects, else one.
int effect_parameter_count(EffectKind kind) {
  const EffectInfo& i = effect_info(kind);
  int n = 0;
  while (n < 3 && i.parameters[n]) ++n;
  return n;
}
}  // namespace

std::vector<std::string> effect_parameter_names(EffectKind kind) {
  const EffectInfo& i = effect_info(kind);
  return std::vector<std::string>(i.parameters, i.parameters + effect_parameter_count(kind));
}

std::string EffectCandidate::label(const Design& design) const {
  std::string s = effect_name(kind);
  if (component >= 0) s += "." + effect_parameter_names(kind)[component];
  if (installation >= 0) s += "[" + effect_installation_id(design, *this) + "]";
  if (installation < 0 && effect_has_whole_test_form(kind)) s += "[all]";
  switch (effect_info(kind).position) {
    case EffectPosition::kNone:
      break;
    case EffectPosition::kHarmonic:
      s += "(" + std::to_string(harmonic) + "/turn)";
      break;
    case EffectPosition::kTime:
      if (std::isfinite(at_s)) s += "(t=" + short_number(at_s) + "s)";
      break;
    case EffectPosition::kTimeConstant:
      s += "(tau=" + short_number(tau_min) + "min)";
      break;
  }
  return s;
}

namespace {

// A finite number that is the whole of `text` (no hex, no trailing text), and positive when
// asked.
std::optional<double> label_number(const std::string& text, bool positive) {
  if (text.empty() || text.size() > 32 ||
      text.find_first_not_of("0123456789.eE+-") != std::string::npos)
    return std::nullopt;
  std::istringstream in(text);
  in.imbue(std::locale::classic());
  double x = 0;
  if (!(in >> x) || in.peek() != std::char_traits<char>::eof() || !std::isfinite(x) ||
      (positive && !(x > 0)))
    return std::nullopt;
  return x;
}

}  // namespace

std::string not_applicable_text(const Applicability& a) {
  switch (a.why) {
    case NotApplicable::kNone:
      return "";
    case NotApplicable::kNeedsTimes:
      return "needs time_s on every reading it applies to";
    case NotApplicable::kNeedsBothSweeps:
      return "needs readings of both sweeps (cw and ccw)";
    case NotApplicable::kNeedsBar:
      return "needs bar_mm on every installation (the following ball's position)";
    case NotApplicable::kChangesNoReading:
      return "changes no reading of this design";
    case NotApplicable::kNeedsEveryTime:
      return "needs time_s on every reading";
    case NotApplicable::kNeedsSeveralTimes:
      return "needs readings at more than one time";
    case NotApplicable::kTooFewReadings:
      return "needs at least " + std::to_string(a.min_readings) + " readings of the installation";
    case NotApplicable::kNeedsCommonClock:
      return "needs the installations' times on one clock (their spans of time_s overlap, as when "
             "each trace's clock starts at zero: dbbkit readings --start)";
  }
  return "";
}

EffectCandidate effect_from_label(const Design& design, const std::string& label,
                                  const std::string& source, const std::string& key) {
  auto fail = [&](const std::string& why) {
    throw InputError(source, key, quote_value(label) + ": " + why);
  };
  const std::string forms =
      "write name[installation], e.g. length_offset[2r], centring[1a], drift[all], "
      "reversal[3t], scale.x, squareness.xy, step[2r](t=120s), thermal[all](tau=30min)";
  const std::size_t name_end = label.find_first_of(".[(");
  EffectCandidate e;
  e.kind = effect_kind(label.substr(0, name_end), source, key);
  // Of the other instrument: said before its place is looked for among this design's.
  if (!effect_fits_instrument(e.kind, design.instrument))
    fail(std::string(effect_name(e.kind)) + " is an effect of " +
         instrument_info(effect_info(e.kind).ballbar_only ? InstrumentKind::kBallbar
                                                          : InstrumentKind::kProbe)
             .noun +
         "; this design's instrument is " + instrument_info(design.instrument).noun);
  const EffectPosition position = effect_info(e.kind).position;
  if (position == EffectPosition::kHarmonic)
    fail("a periodic effect is a simulated truth's (its phase is not in the label); " + forms);
  std::size_t at = name_end == std::string::npos ? label.size() : name_end;
  if (at < label.size() && label[at] == '.') {  // one component of a vector effect
    const std::size_t end = label.find_first_of("[(", at + 1);
    const std::string c = label.substr(at + 1, end == std::string::npos ? end : end - at - 1);
    const std::vector<std::string> names = effect_parameter_names(e.kind);
    const auto it = std::find(names.begin(), names.end(), c);
    if (names.size() < 2 || it == names.end()) {
      std::string list;
      for (const std::string& n : names) list += (list.empty() ? "" : ", ") + n;
      fail(names.size() < 2 ? "has one parameter, no component"
                            : "no component " + quote_value(c) + " (one of " + list + ")");
    }
    e.component = static_cast<int>(it - names.begin());
    at = end == std::string::npos ? label.size() : end;
  }
  bool bracket = false;
  if (at < label.size() && label[at] == '[') {
    const std::size_t close = label.find(']', at);
    if (close == std::string::npos) fail("no closing ']'; " + forms);
    const std::string id = label.substr(at + 1, close - at - 1);
    bracket = true;
    if (id == "all") {
      if (!effect_has_whole_test_form(e.kind))
        fail(std::string(effect_name(e.kind)) + " has no whole-test form [all]");
    } else {
      e.installation = effect_installation(design, e.kind, id);
      if (e.installation < 0 && !effect_info(e.kind).per_sphere && find_sphere(design, id) >= 0)
        fail(quote_value(id) + " is a sphere; " + effect_name(e.kind) +
             " is one channel's: " + probe_channel_id(id, 0) + ", " + probe_channel_id(id, 1) +
             " or " + probe_channel_id(id, 2));
      if (e.installation < 0)
        fail(quote_value(id) + " is no " +
             (effect_info(e.kind).per_sphere ? "sphere"
                                             : instrument_info(design.instrument).row_carrier) +
             " of the design");
    }
    at = close + 1;
  }
  if (effect_is_shared(e.kind) && bracket)
    fail(std::string(effect_name(e.kind)) + " is shared by every installation: no [...]");
  if (!effect_is_shared(e.kind) && !bracket)
    fail("which installation ([id], or [all] where the effect has a whole-test form)? " + forms);
  if (effect_info(e.kind).whole_test_only && e.installation >= 0)
    fail("a warm-up is the whole test's: thermal[all](tau=...min)");
  if (at < label.size()) {
    if (label[at] != '(' || label.back() != ')') fail("unexpected text after the name; " + forms);
    const std::string arg = label.substr(at + 1, label.size() - at - 2);
    if (position == EffectPosition::kTime && arg.rfind("t=", 0) == 0 && arg.back() == 's') {
      const std::optional<double> t = label_number(arg.substr(2, arg.size() - 3), false);
      if (!t) fail("the step's time must be a number of seconds, e.g. (t=120s)");
      e.at_s = *t;
    } else if (position == EffectPosition::kTimeConstant && arg.rfind("tau=", 0) == 0 &&
               arg.size() > 7 && arg.compare(arg.size() - 3, 3, "min") == 0) {
      const std::optional<double> t = label_number(arg.substr(4, arg.size() - 7), true);
      if (!t) fail("the time constant must be a positive number of minutes, e.g. (tau=30min)");
      e.tau_min = *t;
    } else {
      fail(quote_value("(" + arg + ")") + " is not a position of " + effect_name(e.kind) + "; " +
           forms);
    }
  } else if (position == EffectPosition::kTime) {
    fail(
        "a step needs its time on the test's clock: step[id](t=...s) (a step found in readings "
        "without time_s has no time to name)");
  } else if (position == EffectPosition::kTimeConstant) {
    fail("a warm-up needs its time constant: thermal[all](tau=...min)");
  }
  return e;
}

std::vector<EffectCandidate> effects_from_list(const Design& design, const std::string& list,
                                               const std::string& source) {
  std::vector<EffectCandidate> out;
  if (list.find_first_not_of(" \t") == std::string::npos) return out;
  std::size_t at = 0;
  while (true) {
    const std::size_t comma = list.find(',', at);
    std::string label = list.substr(at, comma == std::string::npos ? comma : comma - at);
    const std::size_t b = label.find_first_not_of(" \t"), e = label.find_last_not_of(" \t");
    label = b == std::string::npos ? "" : label.substr(b, e - b + 1);
    const std::string key = "effect " + std::to_string(out.size() + 1);
    if (label.empty()) throw InputError(source, key, "an empty label in the list");
    out.push_back(effect_from_label(design, label, source, key));
    if (comma == std::string::npos) break;
    at = comma + 1;
  }
  return out;
}

namespace {

// Each installation's earliest reading time (NaN without one), the readings' installations
// given (-1: none of the design's).
std::vector<double> start_times(const Design& design, const std::vector<Reading>& readings,
                                const std::vector<int>& installation) {
  std::vector<double> t0(design.installations.size(), std::numeric_limits<double>::quiet_NaN());
  for (std::size_t k = 0; k < readings.size(); ++k) {
    const int i = installation[k];
    const Reading& r = readings[k];
    if (i >= 0 && r.time_s && !(t0[static_cast<std::size_t>(i)] <= *r.time_s))
      t0[static_cast<std::size_t>(i)] = *r.time_s;
  }
  return t0;
}

}  // namespace

std::vector<double> installation_start_times(const Design& design,
                                             const std::vector<Reading>& readings) {
  const auto index = design.installation_index();
  std::vector<int> installation;
  installation.reserve(readings.size());
  for (const Reading& r : readings) {
    const auto it = index.find(r.installation);
    installation.push_back(it == index.end() ? -1 : it->second);
  }
  return start_times(design, readings, installation);
}

double test_start_time(const std::vector<Reading>& readings) {
  double t0 = std::numeric_limits<double>::quiet_NaN();
  for (const Reading& r : readings) {
    if (r.time_s && !(t0 <= *r.time_s)) t0 = *r.time_s;
  }
  return t0;
}

double test_minutes(const std::vector<Reading>& readings) {
  double t0 = std::numeric_limits<double>::infinity(), t1 = -t0;
  for (const Reading& r : readings) {
    if (r.time_s) t0 = std::min(t0, *r.time_s), t1 = std::max(t1, *r.time_s);
  }
  return t1 > t0 ? (t1 - t0) / 60.0 : 0.0;
}

double effect_reach_um(const Eigen::MatrixXd& J_reading_effect, const Eigen::VectorXd& value) {
  if (J_reading_effect.rows() == 0) return 0.0;
  return (J_reading_effect * value).cwiseAbs().maxCoeff();
}

std::optional<double> drift_rate_um_per_min(const EffectCandidate& effect,
                                            const Eigen::VectorXd& value) {
  if (value.size() == 0) return std::nullopt;
  if (effect.kind == EffectKind::kDrift) return value.cwiseAbs().maxCoeff();
  if (effect.kind == EffectKind::kThermal) {
    // [plateau] or, linearised about tau_min, [plateau, correction to tau_min].
    const double tau = effect.tau_min + (value.size() > 1 ? value(1) : 0.0);
    if (!(tau > 0)) return std::numeric_limits<double>::infinity();  // no warm-up at all
    return std::abs(value(0)) / tau;
  }
  return std::nullopt;
}

Eigen::Vector3d centring_row(const AxisFrame& axis, const Installation& in, double angle_deg) {
  return -in.sign * direction_machine(axis, in, angle_deg);
}

Eigen::VectorXd J_reading_effect(const Design& design, const Reading& r, double t0_s,
                                 const EffectCandidate& e) {
  return J_reading_effect(design, r, design.find_installation(r.installation), t0_s, e);
}

namespace {

// J_reading_effect's row without a heap allocation (at most three parameters): effect_block
// forms one per reading and effect.
using EffectRow = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, 3, 1>;
EffectRow effect_row(const Design& design, const Reading& r, int inst, double t0_s,
                     const EffectCandidate& e);

}  // namespace

Eigen::VectorXd J_reading_effect(const Design& design, const Reading& r, int inst, double t0_s,
                                 const EffectCandidate& e) {
  return effect_row(design, r, inst, t0_s, e);
}

namespace {

EffectRow effect_row(const Design& design, const Reading& r, int inst, double t0_s,
                     const EffectCandidate& e) {
  EffectRow row = EffectRow::Zero(effect_parameter_count(e.kind));
  if (!effect_applies_to(design, e, inst)) return row;
  effect_info(e.kind).row({design, r, design.installations[inst], t0_s, e}, row.data());
  return row;
}

}  // namespace

ReadingLayout::ReadingLayout(const Design& design, const std::vector<Reading>& readings)
    : test_start_s(test_start_time(readings)) {
  const auto index = design.installation_index();  // each reading's installation, looked up once
  installation.reserve(readings.size());
  for (const Reading& r : readings) installation.push_back(index.at(r.installation));
  start_s = start_times(design, readings, installation);
  // The span of time_s of each run of consecutive readings of one installation (a trace, a
  // sweep, an installation measured again later); two runs that overlap in time cannot be on one
  // clock (a ball bar measures one installation at a time).
  std::vector<std::pair<double, double>> runs;
  for (std::size_t k = 0; k < readings.size(); ++k) {
    const bool new_run = k == 0 || installation[k] != installation[k - 1];
    if (new_run)
      runs.emplace_back(std::numeric_limits<double>::infinity(),
                        -std::numeric_limits<double>::infinity());
    if (!readings[k].time_s) continue;
    auto& [lo, hi] = runs.back();
    lo = std::min(lo, *readings[k].time_s), hi = std::max(hi, *readings[k].time_s);
  }
  std::vector<std::pair<double, double>> timed;
  for (const auto& r : runs)
    if (r.first <= r.second) timed.push_back(r);
  std::sort(timed.begin(), timed.end());
  for (std::size_t i = 1; i < timed.size(); ++i)
    common_clock = common_clock && timed[i].first > timed[i - 1].second;
}

bool readings_on_one_clock(const Design& design, const std::vector<Reading>& readings) {
  return ReadingLayout(design, readings).common_clock;
}

EffectBlock effect_block(const Design& design, const std::vector<Reading>& readings,
                         const EffectCandidate& e) {
  return effect_block(design, readings, ReadingLayout(design, readings), e);
}

EffectBlock effect_block(const Design& design, const std::vector<Reading>& readings,
                         const ReadingLayout& layout, const EffectCandidate& e) {
  EffectBlock b;
  b.effect = e;
  b.label = e.label(design);
  b.unit = effect_unit(e.kind);
  const std::vector<std::string> names = effect_parameter_names(e.kind);
  // Zero where the effect does not apply (another installation's readings): effect_row's own
  // value there.
  Eigen::MatrixXd full = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(readings.size()),
                                               static_cast<Eigen::Index>(names.size()));
  bool time_missing = false, cw = false, ccw = false, bar_missing = false;
  for (std::size_t i = 0; i < readings.size(); ++i) {
    const Reading& r = readings[i];
    const int inst = layout.installation[i];
    if (!effect_applies_to(design, e, inst)) continue;  // does not apply
    time_missing = time_missing || !r.time_s;
    cw = cw || (r.sweep && *r.sweep == Sweep::kCW);
    ccw = ccw || (r.sweep && *r.sweep == Sweep::kCCW);
    bar_missing = bar_missing || !design.installations[inst].bar_mm;
    const double start = e.installation < 0 ? layout.test_start_s : layout.start_s[inst];
    full.row(static_cast<Eigen::Index>(i)) = effect_row(design, r, inst, start, e).transpose();
  }
  const EffectInfo& info = effect_info(e.kind);
  const bool timed_effect =
      info.needs_times && (info.position != EffectPosition::kTime || std::isfinite(e.at_s));
  if (timed_effect && time_missing) {
    b.applicability.why = NotApplicable::kNeedsTimes;
  } else if (timed_effect && e.installation < 0 && !layout.common_clock) {
    b.applicability.why = NotApplicable::kNeedsCommonClock;
  }
  if (info.needs_both_sweeps && !(cw && ccw)) b.applicability.why = NotApplicable::kNeedsBothSweeps;
  if (info.needs_bar && bar_missing) {
    b.applicability.why = NotApplicable::kNeedsBar;
  }
  std::vector<int> keep;
  for (int j = 0; j < full.cols(); ++j) {
    if ((e.component < 0 || e.component == j) &&
        full.col(j).cwiseAbs().maxCoeff() > tol::kSeenValue)
      keep.push_back(j);
  }
  if (keep.empty() && b.applicability.applicable())
    b.applicability.why = NotApplicable::kChangesNoReading;
  for (int j : keep) b.parameters.push_back(names[static_cast<std::size_t>(j)]);
  if (static_cast<Eigen::Index>(keep.size()) == full.cols()) {  // every column kept, in order
    b.J_reading_effect = std::move(full);
    return b;
  }
  b.J_reading_effect.resize(full.rows(), static_cast<Eigen::Index>(keep.size()));
  for (std::size_t j = 0; j < keep.size(); ++j)
    b.J_reading_effect.col(static_cast<Eigen::Index>(j)) = full.col(keep[j]);
  return b;
}

std::vector<EffectBlock> candidate_effects(const Design& design,
                                           const std::vector<Reading>& readings) {
  std::vector<EffectBlock> out;
  const ReadingLayout layout(design, readings);
  // The effects of a fixed position, in the table's order, those of the design's instrument.
  for (const EffectInfo& info : kEffects) {
    const EffectKind k = info.kind;
    if (info.position != EffectPosition::kNone || !effect_fits_instrument(k, design.instrument))
      continue;
    if (info.shared) {
      // Shared effects one parameter at a time: part of a scale or squareness can be
      // confounded (an isotropic scale is a length offset) while the rest is not.
      for (int c = 0; c < effect_parameter_count(k); ++c)
        out.push_back(effect_block(design, readings, layout, {k, -1, c}));
      continue;
    }
    for (std::size_t i = 0; i < design.installations.size(); ++i) {
      if (info.per_sphere) {
        // A sphere's placement once, on its first channel, one coordinate at a time: part of it
        // can be a rigid motion of the body at every angle (across the plane of three spheres,
        // a rotation about the line through the other two) while the rest is not.
        if (design.installations[i].coordinate != 0) continue;
        for (int c = 0; c < effect_parameter_count(k); ++c)
          out.push_back(effect_block(design, readings, layout, {k, static_cast<int>(i), c}));
        continue;
      }
      out.push_back(effect_block(design, readings, layout, {k, static_cast<int>(i)}));
    }
    // The same effect once for the whole test: a length change common to every reading (the
    // bar's own length), one drift on the test's clock, one reversal of every installation.
    if (info.whole_test_form) out.push_back(effect_block(design, readings, layout, {k, -1}));
  }
  return out;
}

EffectBlock ScanFamily::alternative(const Design& design, const std::vector<Reading>& readings,
                                    int k) const {
  if (effect_info(effect.kind).position != EffectPosition::kTime)
    return alternatives.at(static_cast<std::size_t>(k));
  EffectBlock b;
  b.effect = effect;
  const Reading& first =
      readings.at(static_cast<std::size_t>(rows.at(static_cast<std::size_t>(k))));
  if (timed) b.effect.at_s = *first.time_s;
  b.label = b.effect.label(design);
  if (!timed)
    b.label +=
        "(from reading " + std::to_string(k + 1) + " of " + std::to_string(rows.size()) + ")";
  b.unit = effect_unit(effect.kind);
  b.parameters = {"value"};
  b.J_reading_effect = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(readings.size()), 1);
  for (std::size_t j = static_cast<std::size_t>(k); j < rows.size(); ++j)
    b.J_reading_effect(rows[j], 0) = 1.0;
  return b;
}

namespace {

// A family of each installation whose position is a time: the installation's readings in time
// order (file order when one has no time), split in two at each alternative.
void time_families(const Design& design, const std::vector<Reading>& readings, EffectKind kind,
                   std::vector<ScanFamily>& out) {
  const auto index = design.installation_index();
  std::vector<std::vector<int>> rows(design.installations.size());
  for (std::size_t j = 0; j < readings.size(); ++j)
    rows[index.at(readings[j].installation)].push_back(static_cast<int>(j));
  for (std::size_t i = 0; i < design.installations.size(); ++i) {
    ScanFamily f;
    f.effect.kind = kind;
    f.effect.installation = static_cast<int>(i);
    f.label = f.effect.label(design);
    f.rows = rows[i];
    f.timed = !f.rows.empty() && std::all_of(f.rows.begin(), f.rows.end(),
                                             [&](int j) { return readings[j].time_s.has_value(); });
    if (f.timed) {
      std::stable_sort(f.rows.begin(), f.rows.end(),
                       [&](int a, int b) { return *readings[a].time_s < *readings[b].time_s; });
    }
    if (static_cast<int>(f.rows.size()) < 2 * f.min_segment) {
      f.applicability = {NotApplicable::kTooFewReadings, 2 * f.min_segment};
    }
    out.push_back(f);
  }
}

// The whole test's family whose position is a time constant: a block for each of a geometric
// grid of kThermalTaus values from T / 20 to 2 T, T the test's duration.
void time_constant_family(const Design& design, const std::vector<Reading>& readings,
                          EffectKind kind, std::vector<ScanFamily>& out) {
  ScanFamily th;
  th.effect.kind = kind;
  th.label = th.effect.label(design);
  th.label = th.label.substr(0, th.label.find('('));
  double t0 = std::numeric_limits<double>::infinity(), t1 = -t0;
  bool all_timed = !readings.empty();
  for (const Reading& r : readings) {
    if (!r.time_s) {
      all_timed = false;
      break;
    }
    t0 = std::min(t0, *r.time_s), t1 = std::max(t1, *r.time_s);
  }
  if (!all_timed) {
    th.applicability.why = NotApplicable::kNeedsEveryTime;
  } else if (!(t1 > t0)) {
    th.applicability.why = NotApplicable::kNeedsSeveralTimes;
  } else if (const ReadingLayout layout(design, readings); !layout.common_clock) {
    th.applicability.why = NotApplicable::kNeedsCommonClock;
  } else {
    const double T_min = (t1 - t0) / 60.0;
    for (int k = 0; k < kThermalTaus; ++k) {
      EffectCandidate c = th.effect;
      c.tau_min = T_min / 20.0 * std::pow(40.0, k / double(kThermalTaus - 1));
      th.alternatives.push_back(effect_block(design, readings, layout, c));
    }
  }
  out.push_back(th);
}

}  // namespace

std::vector<ScanFamily> scan_families(const Design& design, const std::vector<Reading>& readings) {
  std::vector<ScanFamily> out;
  for (const EffectInfo& info : kEffects) {
    if (!effect_fits_instrument(info.kind, design.instrument)) continue;
    if (info.position == EffectPosition::kTime) time_families(design, readings, info.kind, out);
    if (info.position == EffectPosition::kTimeConstant)
      time_constant_family(design, readings, info.kind, out);
  }
  return out;
}

}  // namespace dbbkit
